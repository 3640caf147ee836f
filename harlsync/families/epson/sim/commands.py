"""The controller's side of the Remote Control command words, written from the
manual (§7, §8, §10) and the profile, not from the client's codec: a command
the client encodes wrongly gets the error a controller would give it.

How this works::

    command words (latched at the request)        response words (from word 0)
    number  param 1 .. param 7   ------------>    echo  data ...              read
            unused words 0 (profile)              echo  0000H 0000H           set/register
                                                  echo  code  detail          error (ExtCmdResult 1)

    number off the command set ........................ 1000 (recorded as off-list)
    more words than the map's command words ........... 2002
    a word after the command's own words not 0 ........ 2004 (the profile: unused words 0)
    a parameter out of range .......................... 2004; a table number over 15: 2005
    a table entry never registered .................... 2006; an undefined point: 2004
    a later step of a split or Rn write out of turn ... 1002 (command sequence error)
    a response longer than the map's response words ... 2003

Split writes (S1/S2, R1/R2: 54/55, 104/105, 204/205, 351/352, 401/402,
451/452, 601/602, 751/752, 801/802) and Rn sequences (600, 650, 700, 750,
850: one axis a command, in order X, Y, Z ...) take effect at their last
step.  Any other command in between cancels them silently (the profile); a
later step that does not follow its earlier ones is refused with 1002 and
cancels the sequence (§10.2 "an error response will be returned", §10.13
"values received at that point will be canceled and an error response will be
returned").

The handlers live by what they carry out: :mod:`.settings` (the tables and
settings, §10.1-10.18, §10.26), :mod:`.points` (§10.25) and :mod:`.status`
(§8.5); each lists its command numbers, and this module carries a command out
(:func:`execute`) through the table they make.  The handlers read their
parameters through :class:`~.params.Params`, the only place that shares the
codec's two's complement word conversions.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from types import MappingProxyType
from typing import NamedTuple

from . import points, settings, status
from .codes import COMMAND_WORDS, NORMAL, PARAMETER, RESPONSE_WORDS, UNSUPPORTED, Outcome, Refused
from .params import Params
from .session import Handler, Session, WordCount
from .state import SimState

__all__ = ["COMMAND_SET", "READS", "WRITES", "execute"]

log = logging.getLogger(__name__)

#: The fewest response words the controller sets (§7: an error response is 3).
_MIN_RESPONSE = 3


class _Spec(NamedTuple):
    #: command words, word 0 included, for a robot of so many axes
    words: Callable[[int], int]
    handler: Handler


def _fixed(count: int) -> Callable[[int], int]:
    return lambda axes: count


def _specs(*tables: Mapping[int, tuple[WordCount, Handler]]) -> dict[int, _Spec]:
    return {
        number: _Spec(count if callable(count) else _fixed(count), handler)
        for table in tables
        for number, (count, handler) in table.items()
    }


_READS = (settings.READ_COMMANDS, points.READ_COMMANDS, status.READ_COMMANDS)
_WRITES = (settings.WRITE_COMMANDS, points.WRITE_COMMANDS)
_COMMANDS: Mapping[int, _Spec] = MappingProxyType(_specs(*_READS, *_WRITES))
#: The commands the simulated controller carries out: the digest's backup reads
#: and deploy writes that harlsync sends.  Everything else is answered 1000.
COMMAND_SET = frozenset(_COMMANDS)
READS = frozenset(n for table in _READS for n in table)
WRITES = COMMAND_SET - READS


def execute(
    session: Session,
    state: SimState,
    words: Sequence[int],
    *,
    command_words: int = 8,
    response_words: int = 8,
) -> Outcome:
    """Carry out the command in ``words`` (word 0 its number) on ``state``, in
    ``session``; ``command_words`` and ``response_words`` are how many words the
    controller's map assigns (§5.3)."""
    number = words[0] if words else 0
    session.begin()
    spec = _COMMANDS.get(number)
    is_write = number not in READS
    if spec is None:
        log.warning(
            "sim: command %d is off the command set: refused with %04X", number, UNSUPPORTED
        )
        return Outcome(number, (number, UNSUPPORTED, 0), True, True, False)
    if number in session.lacks:
        return Outcome(number, (number, UNSUPPORTED, 0), True, is_write, True)
    try:
        need = spec.words(state.axes)
        if need > command_words:
            raise Refused(COMMAND_WORDS)
        if any(words[need:]):  # the profile: unused command words are 0
            raise Refused(PARAMETER)
        data = spec.handler(session, state, Params(words))
        response = (number, *data) if data else (number, NORMAL, 0)
        response += (0,) * (_MIN_RESPONSE - len(response))
        if len(response) > response_words:
            raise Refused(RESPONSE_WORDS)
    except Refused as refusal:
        session.pending = None
        return Outcome(number, (number, refusal.code, refusal.detail), True, is_write, True)
    return Outcome(
        number, response, False, is_write, True, session.took_effect, session.continuation
    )
