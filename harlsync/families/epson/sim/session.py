"""The command session of one controller: what it keeps between commands (a
split or Rn write under way, the model name read so far, how points not there
are answered), not the robot's state, which each command is given; and the
shape of a command handler and of the tables that list them.

A write that takes several commands (S1/S2, R1/R2, an Rn sequence: see
:mod:`.commands`) is a :meth:`Session.sequence` of steps: the first opens it,
each later one must follow the steps before it, and the last carries it out::

    step 1          step 2 ... step n-1          step n
    opens: pending  appends: pending again       appends, applies: took effect
                    out of turn: 1002, cancelled
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from .codes import SEQUENCE, PointAnswers, Refused
from .params import Params
from .state import SimState

__all__ = ["Handler", "Parted", "Session", "WordCount", "parts", "with_halves"]


@dataclass
class _Sequence:
    """A split or Rn write under way: the steps it takes, the values so far."""

    key: tuple[object, ...]
    steps: tuple[tuple[int, int], ...]
    values: list[tuple[int, ...]]
    apply: Callable[[list[tuple[int, ...]]], None]


class Session:
    """The command handling of one controller: what it keeps between commands
    (a split or Rn write under way, the model name read so far), not the
    robot's state, which each call is given."""

    def __init__(self) -> None:
        self.pending: _Sequence | None = None
        #: the next character of the model name 2154 answers (None: not reading it)
        self.name_at: int | None = None
        #: how points not there are answered (set by the simulator before each command)
        self.points = PointAnswers()
        #: commands of the set this controller lacks (an older firmware): answered 1000
        self.lacks: frozenset[int] = frozenset()
        #: what the command being carried out did: carried out a write's last step,
        #: took a later step of one
        self.took_effect = False
        self.continuation = False
        self._before: _Sequence | None = None

    def reset(self) -> None:
        """As a controller comes up: no write under way, no name being read."""
        self.pending = None
        self.name_at = None

    def begin(self) -> None:
        """A command arrives.  Any command cancels a split or Rn write under way,
        unless it is its next step (:meth:`sequence` looks at the one it cancelled)."""
        self._before, self.pending = self.pending, None
        self.took_effect = self.continuation = False

    def sequence(
        self,
        key: tuple[object, ...],
        steps: tuple[tuple[int, int], ...],
        step: tuple[int, int],
        values: tuple[int, ...],
        apply: Callable[[list[tuple[int, ...]]], None],
    ) -> tuple[int, ...]:
        """One step of a write that takes several commands; it takes effect at the last."""
        index = steps.index(step)
        if index == 0:
            sequence = _Sequence(key, steps, [values], apply)
        else:
            sequence_ = self._before
            if (
                sequence_ is None
                or sequence_.key != key
                or sequence_.steps != steps
                or len(sequence_.values) != index
            ):
                raise Refused(SEQUENCE)
            sequence = sequence_
            sequence.values.append(values)
            self.continuation = True
        if len(sequence.values) == len(steps):
            sequence.apply(sequence.values)
            self.took_effect = True
        else:
            self.pending = sequence
        return ()

    def split(
        self,
        key: tuple[object, ...],
        first: int,
        second: int,
        number: int,
        values: tuple[int, ...],
        apply: Callable[[tuple[int, ...], tuple[int, ...]], None],
    ) -> tuple[int, ...]:
        """S1/S2 or R1/R2: ``first`` then ``second``."""
        return self.sequence(
            key, ((first, 0), (second, 0)), (number, 0), values, lambda v: apply(v[0], v[1])
        )

    def done(self) -> tuple[int, ...]:
        """A write carried out in one command."""
        self.took_effect = True
        return ()


# --- command tables -------------------------------------------------------------------------

#: Carries out one command on the robot's state: the response words after the
#: echo (none: a normal response, 0000H 0000H), or raises :class:`~.codes.Refused`.
Handler = Callable[[Session, SimState, Params], tuple[int, ...]]
#: A read of a part of an entry: the slice of its values it answers.
Parted = Callable[[Session, SimState, Params, slice], tuple[int, ...]]
#: Command words, word 0 included: a number, or one a robot's axes give.
WordCount = int | Callable[[int], int]
#: An entry's two values, its first, its second.
_HALVES = (slice(0, 2), slice(0, 1), slice(1, 2))


def parts(
    first: int, words: int, read: Parted, which: tuple[slice, slice, slice] = _HALVES
) -> dict[int, tuple[WordCount, Handler]]:
    """A read of a whole entry (``first``) and of its parts (``first + 1``, ``+ 2``:
    59 an AccelS entry, 60 its accel, 61 its decel), ``words`` command words each."""

    def part(part_of: slice) -> Handler:
        return lambda s, st, p: read(s, st, p, part_of)

    return {first + i: (words, part(part_of)) for i, part_of in enumerate(which)}


def with_halves(
    first: int, words: tuple[WordCount, WordCount, WordCount], whole: Handler, half: Handler
) -> dict[int, tuple[WordCount, Handler]]:
    """A write in one command (``first``) and in two halves (``first + 1``, ``+ 2``:
    53 an AccelS entry, 54 its accel, 55 its decel)."""
    return {first: (words[0], whole), first + 1: (words[1], half), first + 2: (words[2], half)}
