"""HARL-U2 commands: typed requests and the decoding of their replies, sans I/O.

A :class:`Request` is the command letters and its fields; ``payload`` is the text
between ``station SP`` and ETX.  A request knows the type of its reply: the
builders below return a ``Request[Step]``, a ``Request[str]`` (a timer's text), a
``Request[Config]``, a ``Request[Ack]`` for every write ..., and
:meth:`Request.decode` turns the reply into that type, or into an
:class:`ErrorReply` for ``E`` + status.  A reply that does not fit the request
raises :class:`~harlsync.errors.ReplyError`.  A request made from its letters
alone (:func:`parse_request`, the simulator's side) is a ``Request[object]``
that decodes by its letters.

Request builders, one per command of the profile::

    LNA/LNM/LNS/LNH  read_step       SNA/SNM/SNS/SNH  write_step
    LNT read_timer   LND read_register   SNT write_timer   SND write_register
    LNL read_offset                      SNL write_offset
    LNIB/LNID read_di_bit/read_di_port
    LNOB/LNOD read_do_bit/read_do_port
    LNBB/LNBD read_mem_bit/read_mem_port
    LNE read_parameters                  SNE write_parameters
    LNR read_status   LNV read_version   LNX read_config   SNX write_config

SNO (physical outputs) and SNB (memory bits) have no builder, and
:meth:`Request.encode` refuses them and every other command off
``profile.SENT_COMMANDS``: harlsync never sends them.  The simulator still
parses them (:func:`parse_request`), as the controller does.

What a write must be for the wire to give it back is :mod:`.readback`'s.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Generic, TypeVar, overload

from ....errors import FrameError, ReplyError
from ..model import (
    MAX_STEP_DATA,
    REGISTER_RE,
    TIMER_RE,
    TOKEN_RE,
    Config,
    OffsetTable,
    Parameters,
    ProgramType,
    Status,
    Step,
    TaskState,
)
from . import profile
from .frame import Frame, encode_frame

__all__ = [
    "READ_LETTERS",
    "UNSAFE_LETTERS",
    "VOLATILE_LETTERS",
    "WRITE_LETTERS",
    "Ack",
    "ErrorReply",
    "Parse",
    "Request",
    "decode_reply",
    "parse_request",
    "read_config",
    "read_di_bit",
    "read_di_port",
    "read_do_bit",
    "read_do_port",
    "read_mem_bit",
    "read_mem_port",
    "read_offset",
    "read_parameters",
    "read_register",
    "read_status",
    "read_step",
    "read_timer",
    "read_version",
    "write_config",
    "write_offset",
    "write_parameters",
    "write_register",
    "write_step",
    "write_timer",
]

#: SN commands the manual forbids during automatic operation.
UNSAFE_LETTERS = frozenset(("SNA", "SNM", "SNS", "SNH", "SNE", "SNX"))
#: Reads whose answer changes without any write: task states, I/O and memory bits.
VOLATILE_LETTERS = frozenset(("LNR", "LNIB", "LNID", "LNOB", "LNOD", "LNBB", "LNBD"))

_INT_RE = re.compile(r"[0-9]+")
_BIT_RE = re.compile(r"[01]")
_BYTE_RE = re.compile(r"[0-9]{1,3}")


T = TypeVar("T")
#: A request's reply type: a ``Request[Step]`` is a ``Request[object]`` too.
T_co = TypeVar("T_co", covariant=True)

#: How a request reads the fields of its reply: ``parse(request, fields)``.  It
#: raises :class:`ValueError` or :class:`IndexError` for a reply that does not fit
#: (made a :class:`ReplyError` naming the reply), or :class:`ReplyError` itself.
Parse = Callable[["Request[object]", list[str]], T_co]


@dataclass(frozen=True, init=False)
class Request(Generic[T_co]):
    """One command: its letters (``"LNM"``), its fields (``("2", "3")``) and how
    to read its reply.  Requests compare by letters and fields."""

    letters: str
    args: tuple[str, ...]
    parse: Parse[T_co] = field(repr=False, compare=False)

    @overload
    def __init__(self: Request[object], letters: str, args: tuple[str, ...] = ()) -> None: ...

    @overload
    def __init__(self, letters: str, args: tuple[str, ...], parse: Parse[T_co]) -> None: ...

    def __init__(
        self, letters: str, args: tuple[str, ...] = (), parse: Parse[T_co] | None = None
    ) -> None:
        object.__setattr__(self, "letters", letters)
        object.__setattr__(self, "args", args)
        object.__setattr__(self, "parse", _by_letters if parse is None else parse)

    @property
    def payload(self) -> str:
        return " ".join((self.letters, *self.args))

    @property
    def is_write(self) -> bool:
        return self.letters in WRITE_LETTERS

    @property
    def unsafe(self) -> bool:
        """Forbidden by the manual during automatic operation."""
        return self.letters in UNSAFE_LETTERS

    @property
    def volatile(self) -> bool:
        """Its answer may change between two attempts (LNR: the operator pressed start)."""
        return self.letters in VOLATILE_LETTERS

    def encode(self, station: int) -> bytes:
        """The request frame for ``station``.  Raises :class:`~harlsync.errors.FrameError`
        for a command off ``profile.SENT_COMMANDS`` (SNO, SNB ...: never sent) or a
        payload a frame cannot carry."""
        if self.letters not in profile.SENT_COMMANDS:
            raise FrameError(f"{self.letters} is not on the HARL-U2 allow-list: it is never sent")
        return encode_frame(station, self.payload)

    def decode(self, frame: Frame) -> T_co | ErrorReply:
        """The typed value the reply ``frame`` carries (the station is the link's to check).

        Raises :class:`ReplyError` when the frame does not answer this request.
        """
        return self.decode_payload(frame.payload)

    def decode_payload(self, payload: str) -> T_co | ErrorReply:
        """The typed value of the reply payload, or :class:`ErrorReply` for ``E`` + status.

        Raises :class:`ReplyError` when the payload does not fit the request.
        """
        if payload.startswith(profile.ERROR_PREFIX):
            return ErrorReply(payload[len(profile.ERROR_PREFIX) :])
        fields = payload.split(" ") if payload else []
        try:
            return self.parse(self, fields)
        except (ValueError, IndexError) as exc:
            raise ReplyError(f"{self.letters}: bad reply {payload!r}: {exc}") from exc

    def __str__(self) -> str:
        return self.payload


@dataclass(frozen=True)
class ErrorReply:
    """The controller answered ``E`` + status; ``status`` is the raw text after E."""

    status: str


@dataclass(frozen=True)
class Ack:
    """A successful SN write; ``payload`` is what the controller answered."""

    payload: str


# --- request builders --------------------------------------------------------------


def _program_args(ptype: ProgramType, program: int, step: int) -> tuple[str, ...]:
    if ptype.numbered:
        return (str(program), str(step))
    if program != 0:
        raise ValueError("START is a single program: its number is 0")
    return (str(step),)


def read_step(ptype: ProgramType, program: int, step: int) -> Request[Step]:
    return Request(f"LN{ptype.letter}", _program_args(ptype, program, step), _parse_step)


def write_step(ptype: ProgramType, program: int, step: int, value: Step) -> Request[Ack]:
    problems = value.problems()
    if problems:
        raise ValueError(f"step {step}: {'; '.join(problems)}")
    args = _program_args(ptype, program, step) + value.tokens
    return Request(f"SN{ptype.letter}", args, _parse_ack)


def read_timer(number: int) -> Request[str]:
    return Request("LNT", (str(number),), _parse_timer)


def write_timer(number: int, value: str) -> Request[Ack]:
    _check(TIMER_RE, value, "timer value", "0.00-9.99")
    return Request("SNT", (str(number), value), _parse_ack)


def read_register(number: int) -> Request[str]:
    return Request("LND", (str(number),), _parse_register)


def write_register(number: int, value: str) -> Request[Ack]:
    _check(REGISTER_RE, value, "register value", "0000-9999")
    return Request("SND", (str(number), value), _parse_ack)


def read_offset(table: int) -> Request[OffsetTable]:
    return Request("LNL", (str(table),), _parse_offset)


def write_offset(table: int, value: OffsetTable) -> Request[Ack]:
    problems = value.problems()
    if problems:
        raise ValueError(f"offset table {table}: {'; '.join(problems)}")
    return Request("SNL", (str(table), *value.values), _parse_ack)


def read_di_bit(bit: int) -> Request[int]:
    return Request("LNIB", (str(bit),), _parse_bit)


def read_di_port(port: int) -> Request[int]:
    return Request("LNID", (str(port),), _parse_byte)


def read_do_bit(bit: int) -> Request[int]:
    return Request("LNOB", (str(bit),), _parse_bit)


def read_do_port(port: int) -> Request[int]:
    return Request("LNOD", (str(port),), _parse_byte)


def read_mem_bit(bit: int) -> Request[int]:
    return Request("LNBB", (str(bit),), _parse_bit)


def read_mem_port(port: int) -> Request[int]:
    return Request("LNBD", (str(port),), _parse_byte)


def read_parameters() -> Request[Parameters]:
    return Request("LNE", (), _parse_parameters)


def write_parameters(value: Parameters) -> Request[Ack]:
    for name, text in value.as_dict().items():
        _check(TOKEN_RE, text, f"parameter {name}", "one token, no spaces")
    return Request("SNE", value.values, _parse_ack)


def read_status() -> Request[Status]:
    return Request("LNR", (), _parse_status)


def read_version() -> Request[str]:
    return Request("LNV", (), _parse_version)


def read_config() -> Request[Config]:
    return Request("LNX", (), _parse_config)


def write_config(value: Config) -> Request[Ack]:
    return Request("SNX", tuple(str(n) for n in value.numbers()[:8]), _parse_ack)


def _check(pattern: re.Pattern[str], value: str, what: str, allowed: str) -> None:
    if not pattern.fullmatch(value):
        raise ValueError(f"{what} {value!r} out of range (allowed: {allowed})")


# --- request parsing (the controller's side: the simulator uses it) ----------------

#: Request letters -> (fewest, most) fields it takes.
_ARITY: dict[str, tuple[int, int]] = {
    "LNA": (1, 1), "LNM": (2, 2), "LNS": (2, 2), "LNH": (2, 2),
    "LNT": (1, 1), "LND": (1, 1), "LNL": (1, 1),
    "LNIB": (1, 1), "LNID": (1, 1), "LNOB": (1, 1), "LNOD": (1, 1),
    "LNBB": (1, 1), "LNBD": (1, 1),
    "LNE": (0, 0), "LNR": (0, 0), "LNV": (0, 0), "LNX": (0, 0),
    "SNA": (1, 6), "SNM": (2, 7), "SNS": (2, 7), "SNH": (2, 7),
    "SNT": (2, 2), "SND": (2, 2), "SNL": (9, 9),
    "SNOB": (2, 2), "SNOD": (2, 2), "SNBB": (2, 2), "SNBD": (2, 2),
    "SNE": (13, 13), "SNX": (8, 8),
}  # fmt: skip


#: Every LN command of the profile.
READ_LETTERS = frozenset(k for k in _ARITY if k.startswith("LN"))
#: Every SN command of the profile.
WRITE_LETTERS = frozenset(k for k in _ARITY if k.startswith("SN"))


def parse_request(payload: str) -> Request[object]:
    """Split a request payload into a :class:`Request` that decodes by its letters.

    Raises :class:`ReplyError` for unknown letters or a wrong number of fields.
    """
    letters, *args = payload.split(" ")
    arity = _ARITY.get(letters)
    if arity is None:
        raise ReplyError(f"unknown command {letters!r}")
    lo, hi = arity
    if not lo <= len(args) <= hi:
        raise ReplyError(f"{letters} takes {lo}-{hi} fields, got {len(args)}")
    return Request(letters, tuple(args))


# --- reply decoding ----------------------------------------------------------------


def decode_reply(request: Request[T], payload: str) -> T | ErrorReply:
    """The typed value the reply to ``request`` carries: ``request.decode_payload``.

    Returns :class:`ErrorReply` for ``E`` + status, :class:`Ack` for an SN
    success, and for LN commands: :class:`Step`, the timer or register text,
    :class:`OffsetTable`, ``int`` for bits and ports, :class:`Parameters`,
    :class:`Status`, the version text or :class:`Config`.

    Raises :class:`ReplyError` when the payload does not fit the request.
    """
    return request.decode_payload(payload)


def _one(fields: list[str], pattern: re.Pattern[str], what: str) -> str:
    if len(fields) != 1 or not pattern.fullmatch(fields[0]):
        raise ValueError(f"expected one {what}")
    return fields[0]


def _parse_ack(request: Request[object], fields: list[str]) -> Ack:
    payload = " ".join(fields)
    if payload != profile.SN_OK:
        raise ReplyError(f"{request.letters}: unexpected write reply {payload!r}")
    return Ack(payload)


def _parse_step(request: Request[object], fields: list[str]) -> Step:
    if not fields:
        raise ValueError("no step number")
    if fields[0] != request.args[-1]:
        raise ValueError(f"answers step {fields[0]}, asked for {request.args[-1]}")
    tokens = fields[1:]
    if len(tokens) > 1 + MAX_STEP_DATA:
        raise ValueError(f"more than {MAX_STEP_DATA} data items")
    if not all(TOKEN_RE.fullmatch(t) for t in tokens):
        raise ValueError("token with a control character")
    return Step.from_tokens(tokens)


def _parse_timer(request: Request[object], fields: list[str]) -> str:
    return _one(fields, TIMER_RE, "timer value 0.00-9.99")


def _parse_register(request: Request[object], fields: list[str]) -> str:
    return _one(fields, REGISTER_RE, "register value 0000-9999")


def _parse_offset(request: Request[object], fields: list[str]) -> OffsetTable:
    if len(fields) != 8:
        raise ValueError(f"{len(fields)} fields, expected 8 (X Y Z W R C M F)")
    table = OffsetTable.from_values(fields)
    problems = table.problems()
    if problems:
        raise ValueError("; ".join(problems))
    return table


def _parse_bit(request: Request[object], fields: list[str]) -> int:
    return int(_one(fields, _BIT_RE, "bit 0 or 1"))


def _parse_byte(request: Request[object], fields: list[str]) -> int:
    value = int(_one(fields, _BYTE_RE, "port value 0-255"))
    if value > 255:
        raise ValueError("port value above 255")
    return value


def _parse_parameters(request: Request[object], fields: list[str]) -> Parameters:
    if len(fields) != 13:
        raise ValueError(f"{len(fields)} fields, expected 13")
    return Parameters.from_values(fields)


def _parse_status(request: Request[object], fields: list[str]) -> Status:
    """Every field well formed or none: S, N and L plain decimal digits (no sign,
    no ``_``, which Python's ``int`` would take), K one of the four program types.

    A reply with another number of whole groups is a :class:`Status` that is not
    idle (:attr:`Status.idle` counts the tasks).
    """
    if len(fields) % 4 or not fields:
        raise ValueError(f"{len(fields)} fields, expected {profile.TASK_COUNT} x (S K N L)")
    tasks = []
    for i in range(0, len(fields), 4):
        s, k, n, step = fields[i : i + 4]
        task = i // 4
        for what, text in (("status", s), ("program number", n), ("step", step)):
            if not _INT_RE.fullmatch(text):
                raise ValueError(f"task {task}: {what} {text!r} is not a number")
        if k not in _PROGRAM_TYPE_WORDS:
            raise ValueError(f"task {task}: program type {k!r} is not START, MAIN, SUB or HAND")
        tasks.append(TaskState(task, int(s), k, int(n), int(step)))
    return Status(tuple(tasks), profile.TASK_COUNT)


#: The program type words LNR may answer in K.
_PROGRAM_TYPE_WORDS = frozenset(t.value for t in ProgramType)


def _parse_version(request: Request[object], fields: list[str]) -> str:
    return _one(fields, TOKEN_RE, "version")


def _parse_config(request: Request[object], fields: list[str]) -> Config:
    if len(fields) != 11 or not all(_INT_RE.fullmatch(f) for f in fields):
        raise ValueError("expected 11 numbers: P S P S P S P S T M R")
    return Config.from_numbers([int(f) for f in fields])


#: How a request made from its letters alone reads the reply to an LN command.
_PARSERS: dict[str, Parse[object]] = {
    "LNA": _parse_step,
    "LNM": _parse_step,
    "LNS": _parse_step,
    "LNH": _parse_step,
    "LNT": _parse_timer,
    "LND": _parse_register,
    "LNL": _parse_offset,
    "LNIB": _parse_bit,
    "LNOB": _parse_bit,
    "LNBB": _parse_bit,
    "LNID": _parse_byte,
    "LNOD": _parse_byte,
    "LNBD": _parse_byte,
    "LNE": _parse_parameters,
    "LNR": _parse_status,
    "LNV": _parse_version,
    "LNX": _parse_config,
}


def _by_letters(request: Request[object], fields: list[str]) -> object:
    """The reply as its letters say: an :class:`Ack` for an SN, else the LN's value."""
    if request.is_write:
        return _parse_ack(request, fields)
    parse = _PARSERS.get(request.letters)
    if parse is None:
        raise ReplyError(f"no decoder for {request.letters}")
    return parse(request, fields)
