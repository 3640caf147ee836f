"""Commands on the wire: encoding a command into its words, a request that knows
how to decode its reply, and the write sequence of a split or Rn write."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Generic, TypeVar

from ....errors import ReplyError
from .allowlist import COMMANDS, refusal
from .codes import ErrorReply, describe_code
from .numbers import _WORD, MAX_WORDS, int32_from_words, real_text

T = TypeVar("T")
#: A request's reply type: a ``Request[str]`` is a ``Request[object]`` too.
R_co = TypeVar("R_co", covariant=True)


# --- commands on the wire ------------------------------------------------------------


@dataclass(frozen=True)
class Command:
    """A command number and its parameters, one 16-bit word each."""

    number: int
    params: tuple[int, ...] = ()

    @property
    def words(self) -> tuple[int, ...]:
        return (self.number, *self.params)

    def __str__(self) -> str:
        return " ".join(f"{w & _WORD:04X}H" for w in self.words)


def encode(command: Command, width: int = MAX_WORDS) -> tuple[int, ...]:
    """The ``width`` command words of ``command``: number, parameters, unused words 0.

    Raises :class:`ValueError` for a command off the allow-list (nothing else is
    ever sent), a parameter count the command does not take, a word outside
    0000H-FFFFH, or more words than ``width``.
    """
    why = refusal(command.number)
    if why is not None:
        raise ValueError(why)
    spec = COMMANDS[command.number]
    if len(command.params) not in spec.params:
        counts = " or ".join(str(n) for n in sorted(spec.params))
        raise ValueError(
            f"command {command.number} ({spec.name}) takes {counts} parameters, "
            f"not {len(command.params)}"
        )
    for i, word in enumerate(command.params, 1):
        if not 0 <= word <= _WORD:
            raise ValueError(
                f"command {command.number} parameter {i}: {word} is not a 16-bit word (0 to 65535)"
            )
    if not 1 <= width <= MAX_WORDS:
        raise ValueError(f"width {width} out of range (allowed: 1 to {MAX_WORDS})")
    words = command.words
    if len(words) > width:
        raise ValueError(
            f"command {command.number} ({spec.name}) needs {len(words)} "
            f"command words, the map has {width}"
        )
    return words + (0,) * (width - len(words))


class _Words:
    """A cursor over a response's data words (after the echo)."""

    def __init__(self, words: Sequence[int]) -> None:
        self._words = words
        self._at = 0

    def word(self, what: str) -> int:
        if self._at >= len(self._words):
            raise ValueError(f"the response ends before {what}")
        value = self._words[self._at]
        if not 0 <= value <= _WORD:
            raise ValueError(f"{what} {value} is not a 16-bit word")
        self._at += 1
        return value

    def expect(self, value: int, what: str) -> None:
        got = self.word(what)
        if got != value:
            raise ValueError(f"{what} {got}, asked for {value}")

    def int32(self, what: str) -> int:
        return int32_from_words(self.word(f"{what} (high word)"), self.word(f"{what} (low word)"))

    def real(self, what: str) -> str:
        return real_text(self.int32(what))

    def number(self, low: int, high: int, what: str) -> int:
        value = self.word(what)
        if not low <= value <= high:
            raise ValueError(f"{what} {value} out of range (allowed: {low} to {high})")
        return value


@dataclass(frozen=True)
class Request(Generic[R_co]):
    """One command and how to read its response.

    ``parse`` turns the response's data words (after the echo) into the value,
    raising :class:`ValueError` when they do not fit; ``data_words`` is how many
    the response carries.  Requests compare by command.  Constructing one for a
    command off the allow-list raises :class:`ValueError`.
    """

    command: Command
    what: str
    parse: Callable[[_Words], R_co] = field(repr=False, compare=False)
    data_words: int = field(default=2, compare=False)

    def __post_init__(self) -> None:
        encode(self.command)  # the allow-list and the parameter counts

    @property
    def number(self) -> int:
        return self.command.number

    @property
    def is_write(self) -> bool:
        return COMMANDS[self.number].is_write

    @property
    def command_words(self) -> int:
        """Command words the request needs (word 0 included)."""
        return len(self.command.words)

    @property
    def response_words(self) -> int:
        """Response words the reply needs: echo and data, and at least the 3 of an
        error response."""
        return max(3, 1 + self.data_words)

    def encode(self, width: int = MAX_WORDS) -> tuple[int, ...]:
        """The command words, padded with 0 to ``width``.  Raises :class:`ValueError`
        when the command needs more."""
        return encode(self.command, width)

    def decode(self, words: Sequence[int], *, error: bool = False) -> R_co | ErrorReply:
        """The value ``words`` (the response words from word 0) answer, or an
        :class:`ErrorReply` when ``error`` (ExtCmdResult was 1).

        Raises :class:`ReplyError` when word 0 does not echo the command number,
        or the words are too few or do not fit the command's layout.
        """
        need = 3 if error else 1 + self.data_words
        if len(words) < need:
            raise ReplyError(f"{self}: {len(words)} response words, {need} needed")
        if words[0] != self.number:
            raise ReplyError(
                f"{self}: response word 0 is {words[0]:04X}H, not the command "
                f"number {self.number:04X}H echoed"
            )
        if error:
            return ErrorReply(self.number, words[1], words[2])
        try:
            return self.parse(_Words(words[1 : 1 + self.data_words]))
        except ValueError as exc:
            shown = " ".join(f"{w:04X}H" for w in words[:need])
            raise ReplyError(f"{self}: bad response {shown}: {exc}") from exc

    def __str__(self) -> str:
        return f"{self.number} ({self.what})"


@dataclass(frozen=True)
class WriteSequence:
    """The commands of one write, in order.  More than one is a split write or an
    Rn sequence: they go out back to back, nothing in between (any other command
    cancels them), and take effect at the last."""

    what: str
    requests: tuple[Request[None], ...]

    @property
    def command_words(self) -> int:
        """Command words the longest of them needs."""
        return max(r.command_words for r in self.requests)

    def __iter__(self) -> Iterator[Request[None]]:
        return iter(self.requests)

    def __len__(self) -> int:
        return len(self.requests)


# --- building requests -------------------------------------------------------------


def _check(value: int, low: int, high: int, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ValueError(f"{what} {value!r} out of range (allowed: {low} to {high})")
    return value


def _table(table: int) -> int:
    return _check(table, 0, 15, "table number")


def _read(
    number: int, params: tuple[int, ...], what: str, data_words: int, parse: Callable[[_Words], T]
) -> Request[T]:
    return Request(Command(number, params), what, parse, data_words)


def _ack(words: _Words) -> None:
    code = words.word("Response 1")
    if code:
        raise ValueError(f"Response 1 is {describe_code(code)} with ExtCmdResult 0")


def _write(number: int, params: Sequence[int], what: str) -> Request[None]:
    return Request(Command(number, tuple(params)), what, _ack, 2)


def _fit(what: str, command_words: int, *forms: tuple[Request[None], ...]) -> WriteSequence:
    """The first form whose commands fit ``command_words`` words."""
    for form in forms:
        sequence = WriteSequence(what, form)
        if sequence.command_words <= command_words:
            return sequence
    need = min(WriteSequence(what, form).command_words for form in forms)
    raise ValueError(f"{what}: needs {need} command words, the map has {command_words}")


def _echo_read(
    number: int,
    echoed: Sequence[tuple[int, str]],
    what: str,
    data_words: int,
    rest: Callable[[_Words], T],
) -> Request[T]:
    """A read whose parameters (table, axis, joint ...) come back before its data."""

    def parse(words: _Words) -> T:
        for value, name in echoed:
            words.expect(value, name)
        return rest(words)

    return _read(number, tuple(value for value, _ in echoed), what, data_words, parse)
