"""Every choice the Epson Remote Control manual leaves open, in one place.

These are the *(profile)* decisions of ``shared/spec/epson-remote-control-profile.md``.
The manual defines the command words and the handshake; it does not say where
the Remote I/O signals and words sit on a fieldbus (the site assigns them in
RC+, [Setup]-[System Configuration]-[Controller]-[Remote Control]).  The
default map is here, and every register and bit of it can be moved per robot
(:class:`RegisterMap`, built from the plain dict robot.yaml gives:
:mod:`.map_form`)::

    holding registers (harlsync writes the controller's Remote inputs)
      in_base        bit 0 ExtCmdSet   bit 1 ExtRespGet   bit 2 ExtCmdReset
      in_base+1..+8  ExtCmd word 0..7  (word 0 = command number)
    input registers (harlsync reads the controller's Remote outputs)
      out_base       bit 0 ExtCmdGet   bit 1 ExtRespSet   bit 2 ExtCmdResult
                     bit 3 ExtError    bit 8 Ready        bit 9 Running
                     bit 10 Paused     bit 11 Error       bit 12 EStopOn
                     bit 13 SafeguardOn
      out_base+1..+8 ExtResp word 0..7 (word 0 = the command number echoed)

    16 Remote I/O bits a register, bit 0 = the register's lowest bit.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from functools import cached_property
from types import MappingProxyType
from typing import NamedTuple

from .declared import DEFAULT_PORT, DEFAULT_UNIT

__all__ = [
    "BLOCK_WRITE_WHOLE",
    "COMMAND_DEADLINE",
    "DEFAULT_BITS",
    "DEFAULT_POINT_RANGE",
    "DEFAULT_PORT",
    "DEFAULT_UNIT",
    "FUNCTION_RESET_LOW",
    "HANDSHAKE_INPUTS",
    "HANDSHAKE_OUTPUTS",
    "INTERLOCK_SIGNALS",
    "MODBUS_MAX_READ",
    "MODBUS_RETRIES",
    "MODBUS_TIMEOUT",
    "POINT_PROBE_END",
    "POLL_INTERVAL",
    "READY",
    "REQUIRED_FOR_WRITES",
    "ROBOT_AXES",
    "SIGNAL_FIELDS",
    "SIGNAL_NAMES",
    "STATUS_SIGNALS",
    "TABLE_NOT_REGISTERED",
    "TABLE_OUT_OF_RANGE",
    "UNDEFINED_POINT",
    "UNMAPPED_RISK",
    "WRITE_WITHOUT",
    "Bit",
    "RegisterMap",
    "RegisterMapInvalid",
]

# --- the line ------------------------------------------------------------------------

#: Seconds one Modbus transaction may take before it counts as unanswered.
MODBUS_TIMEOUT = 0.5
#: How often a Modbus *read* is sent again after no answer (a read changes
#: nothing).  A write is never sent again by the link (issue 34): a write sent
#: once more is a write, and only harlsync sends it, after the interlock.
MODBUS_RETRIES = 2
#: The most registers one Modbus read returns (the Modbus specification): the
#: handshake reads every output signal and response word in one read.
MODBUS_MAX_READ = 125

# --- the handshake (§6) --------------------------------------------------------------

#: Seconds between two reads of the controller's outputs while waiting on a step.
POLL_INTERVAL = 0.005
#: Seconds one command may take, all ten steps of §6.3 together.
COMMAND_DEADLINE = 2.0
#: Seconds all three inputs stay low in the §6.5.2 function reset (the manual: at
#: least 30 ms, its only timing value).
FUNCTION_RESET_LOW = 0.030
#: Whether the controller's Modbus slave hands one write of several holding
#: registers (function 16) to the Remote inputs whole: the controller sees every
#: register of it change at once, never a part.  The Modbus specification defines
#: the request, not when the slave's device sees its registers, and the manual
#: does not name the fieldbus at all.  False, the safe choice: on a slave that
#: hands a write over a register at a time, ExtCmdSet (first in the block) would
#: rise over the last command's words, and the controller would run that command
#: (the simulator's ``whole_writes=False`` shows command 0, an Accel write, run so).
#: A site whose slave is known to apply a write whole sets robot.yaml
#: ``connection.writes_whole: true``.  It decides
#: steps 2 and 3 of §6.3 when ExtCmdSet's register lies just before the command
#: words (the default map): True, one write of that register and the words; False,
#: the words, then ExtCmdSet (one round trip more).  A map with ExtCmdSet's
#: register just after the words has them in one write either way: the registers'
#: order is then the manual's (the words before ExtCmdSet rises), whole or not.
#: (:meth:`RegisterMap.command_block`)
BLOCK_WRITE_WHOLE = False

# --- answers the manual leaves open ---------------------------------------------------

#: Response 1 of a point that is not defined (1215-1222): parameter error.
UNDEFINED_POINT = 0x2004
#: Response 1 of a table entry never registered: table registration error.
TABLE_NOT_REGISTERED = 0x2006
#: Response 1 of a table number over 15.
TABLE_OUT_OF_RANGE = 0x2005

#: Points backed up when the robot file gives no range: P0 to P99, inclusive.
DEFAULT_POINT_RANGE = (0, 99)
#: The last point a pull looks for past the robot file's range: the manual gives
#: no command that reports how many points a controller holds, nor their highest
#: number, so a pull probes each point after ``last_point`` up to this one (the
#: last of an RC+ point file, P999) with one 1222 read, and fails when any is
#: defined: a backup never leaves points out without a word.
POINT_PROBE_END = 999

#: Manipulator type (command 2153) -> its axes: the coordinates of a point, Plane,
#: Local and Base, the joints of JRange and the words of Fine.  Types not listed
#: (1 Joint, 2 Cartesian) need the axis count in the robot file.
ROBOT_AXES: Mapping[int, int] = MappingProxyType({3: 4, 5: 6, 6: 4})

# --- the register map -----------------------------------------------------------------

#: The controller's Remote inputs harlsync drives, with their default bit of ``in_base``.
HANDSHAKE_INPUTS: Mapping[str, int] = MappingProxyType(
    {"ExtCmdSet": 0, "ExtRespGet": 1, "ExtCmdReset": 2}
)
#: The handshake's Remote outputs, default bits of ``out_base``.  All seven
#: handshake signals must be mapped: the function does not work without them (§5.2).
HANDSHAKE_OUTPUTS: Mapping[str, int] = MappingProxyType(
    {"ExtCmdGet": 0, "ExtRespSet": 1, "ExtCmdResult": 2, "ExtError": 3}
)
#: The controller's standard Remote outputs harlsync reads for the interlock,
#: default bits of ``out_base``; the site may leave any of them unmapped.
STATUS_SIGNALS: Mapping[str, int] = MappingProxyType(
    {"Ready": 8, "Running": 9, "Paused": 10, "Error": 11, "EStopOn": 12, "SafeguardOn": 13}
)
#: A write goes out only while all of these are 0 (those that are mapped).
#: SafeguardOn is the safety door open (issue 34 item 16): a person may be in the cell.
INTERLOCK_SIGNALS = ("Running", "Paused", "EStopOn", "Error", "SafeguardOn")
#: A robot whose map lacks one of these is never written.
REQUIRED_FOR_WRITES = ("Running", "Paused", "EStopOn", "Error")
#: A robot whose map lacks one of these is not written either, unless robot.yaml
#: ``connection.write_without`` names it: the site then accepts what harlsync
#: cannot see (:data:`UNMAPPED_RISK`).
WRITE_WITHOUT = ("Ready", "SafeguardOn")
#: What harlsync cannot see without each of :data:`WRITE_WITHOUT`.
UNMAPPED_RISK: Mapping[str, str] = MappingProxyType(
    {
        "Ready": "a controller at rest cannot be told from status signals mapped to "
        "addresses it does not drive (they read 0, which looks idle)",
        "SafeguardOn": "an open safeguard (safety door) cannot be seen: a person may be "
        "in the cell",
    }
)
#: Ready (started up, no task running) must read 1 before a write, where it is
#: mapped: a status bit mapped to an address the controller does not drive reads 0,
#: so Ready 0 on an otherwise idle robot says the map is wrong (or it is starting).
READY = "Ready"
SIGNAL_NAMES = (*HANDSHAKE_INPUTS, *HANDSHAKE_OUTPUTS, *STATUS_SIGNALS)
#: Every signal's default bit of its base register.
DEFAULT_BITS: Mapping[str, int] = {**HANDSHAKE_INPUTS, **HANDSHAKE_OUTPUTS, **STATUS_SIGNALS}

IN_BASE = 0
OUT_BASE = 0
COMMAND_WORDS = 8
RESPONSE_WORDS = 8
#: Command and response words the manual allows: up to 8; at least 3 response
#: words (§5.3.2), and the smallest read harlsync sends is 3 command words.
WORDS_RANGE = (3, 8)
_REGISTER_MAX = 0xFFFF


class Bit(NamedTuple):
    """Where one Remote I/O signal sits: a register and a bit of it (0 = lowest)."""

    register: int
    bit: int

    def __str__(self) -> str:
        return f"register {self.register} bit {self.bit}"


#: The profile's map: signal name -> its register and bit.
_DEFAULT_MAP: Mapping[str, Bit] = MappingProxyType(
    {
        name: Bit(IN_BASE if name in HANDSHAKE_INPUTS else OUT_BASE, bit)
        for name, bit in DEFAULT_BITS.items()
    }
)


class RegisterMapInvalid(ValueError):
    """A register map that cannot work; ``issues`` says every problem, one a line."""

    def __init__(self, issues: list[str]) -> None:
        self.issues = list(issues)
        super().__init__("; ".join(self.issues))


#: Field name -> the signal's name as the manual and RC+ write it.
_FIELD_SIGNALS: Mapping[str, str] = MappingProxyType(
    {
        "ext_cmd_set": "ExtCmdSet",
        "ext_resp_get": "ExtRespGet",
        "ext_cmd_reset": "ExtCmdReset",
        "ext_cmd_get": "ExtCmdGet",
        "ext_resp_set": "ExtRespSet",
        "ext_cmd_result": "ExtCmdResult",
        "ext_error": "ExtError",
        "ready": "Ready",
        "running": "Running",
        "paused": "Paused",
        "error": "Error",
        "estop_on": "EStopOn",
        "safeguard_on": "SafeguardOn",
    }
)
#: The signal's name as the manual writes it -> its :class:`RegisterMap` field.
SIGNAL_FIELDS: Mapping[str, str] = {signal: name for name, signal in _FIELD_SIGNALS.items()}


@dataclass(frozen=True)
class RegisterMap:
    """Where the Remote Control signals and words sit in the Modbus registers.

    Inputs (``ext_cmd_set`` ... and the command words) are holding registers
    harlsync writes; outputs (``ext_cmd_get`` ... , the status signals and the
    response words) are input registers it reads.  A status signal is ``None``
    when the site did not map it.  Constructing one checks it: raises
    :class:`RegisterMapInvalid` listing every problem.
    """

    ext_cmd_set: Bit = _DEFAULT_MAP["ExtCmdSet"]
    ext_resp_get: Bit = _DEFAULT_MAP["ExtRespGet"]
    ext_cmd_reset: Bit = _DEFAULT_MAP["ExtCmdReset"]
    command_base: int = IN_BASE + 1
    command_words: int = COMMAND_WORDS
    ext_cmd_get: Bit = _DEFAULT_MAP["ExtCmdGet"]
    ext_resp_set: Bit = _DEFAULT_MAP["ExtRespSet"]
    ext_cmd_result: Bit = _DEFAULT_MAP["ExtCmdResult"]
    ext_error: Bit = _DEFAULT_MAP["ExtError"]
    ready: Bit | None = _DEFAULT_MAP["Ready"]
    running: Bit | None = _DEFAULT_MAP["Running"]
    paused: Bit | None = _DEFAULT_MAP["Paused"]
    error: Bit | None = _DEFAULT_MAP["Error"]
    estop_on: Bit | None = _DEFAULT_MAP["EStopOn"]
    safeguard_on: Bit | None = _DEFAULT_MAP["SafeguardOn"]
    response_base: int = OUT_BASE + 1
    response_words: int = RESPONSE_WORDS
    #: the signals of :data:`WRITE_WITHOUT` robot.yaml accepts to write without
    #: (``connection.write_without``): not part of the map's dict form
    write_without: frozenset[str] = frozenset()

    def __post_init__(self) -> None:
        issues = self._problems()
        if issues:
            raise RegisterMapInvalid(issues)

    # --- what the handshake and the interlock need ---------------------------------

    def signals(self) -> Iterator[tuple[str, Bit | None]]:
        """Every signal by its manual name, inputs first."""
        return iter(self._signal_bits)

    @cached_property
    def _signal_bits(self) -> tuple[tuple[str, Bit | None], ...]:
        # once a map: the handshake asks at every poll
        return tuple((signal, getattr(self, name)) for name, signal in _FIELD_SIGNALS.items())

    def signal(self, name: str) -> Bit | None:
        """The bit of signal ``name`` (manual spelling); None when it is not mapped.

        Raises :class:`KeyError` for a name that is no signal.
        """
        bit: Bit | None = getattr(self, SIGNAL_FIELDS[name])
        return bit

    @property
    def unwritable(self) -> str | None:
        """Why harlsync never writes to this robot, or None when it may: a map without
        Running, Paused, EStopOn or Error; or without Ready or SafeguardOn, unless
        robot.yaml accepts that (issue 34 item 16: it only warned of Ready)."""
        missing = [name for name in REQUIRED_FOR_WRITES if self.signal(name) is None]
        if missing:
            return (
                f"the register map has no {', '.join(missing)} signal: harlsync cannot see "
                "whether the robot is busy, so it never writes to it (map the signal in RC+ "
                "and in robot.yaml)"
            )
        risky = [
            name
            for name in WRITE_WITHOUT
            if self.signal(name) is None and name not in self.write_without
        ]
        if not risky:
            return None
        return (
            f"the register map has no {' or '.join(risky)} signal: "
            + "; ".join(UNMAPPED_RISK[name] for name in risky)
            + "; so harlsync does not write to it. Map "
            + " and ".join(risky)
            + " in RC+ and robot.yaml connection.map, or accept that risk with "
            + f"connection.write_without: [{', '.join(risky)}] in robot.yaml"
        )

    @property
    def ready_note(self) -> str | None:
        """What a plan and ``validate`` say of a map without Ready or SafeguardOn that
        robot.yaml accepts to write without, or None."""
        accepted = [
            name
            for name in WRITE_WITHOUT
            if self.signal(name) is None and name in self.write_without
        ]
        if not accepted:
            return None
        return (
            f"the register map has no {' or '.join(accepted)} signal and robot.yaml "
            f"connection.write_without accepts writing without it: "
            + "; ".join(UNMAPPED_RISK[name] for name in accepted)
        )

    @property
    def control_registers(self) -> tuple[int, ...]:
        """The holding registers that hold ExtCmdSet, ExtRespGet and ExtCmdReset."""
        return tuple(
            sorted(
                {self.ext_cmd_set.register, self.ext_resp_get.register, self.ext_cmd_reset.register}
            )
        )

    def command_block(self, *, whole: bool = BLOCK_WRITE_WHOLE) -> int | None:
        """Where one write of the command words with ExtCmdSet's register starts
        (§6.3 steps 2 and 3 in one request), or None when they must be two.

        They are one when ExtCmdSet's register lies just after the words (the
        register order is then the manual's: the words are there before ExtCmdSet
        rises), or just before them and the slave applies a write ``whole``
        (:data:`BLOCK_WRITE_WHOLE`); anywhere else they are not contiguous."""
        register = self.ext_cmd_set.register
        if register == self.command_base + self.command_words:
            return self.command_base
        if whole and register == self.command_base - 1:
            return register
        return None

    @cached_property
    def input_span(self) -> tuple[int, int]:
        """(first register, count): the one read that gets every output signal and
        every response word."""
        registers = self._output_registers()
        first = min(registers)
        return first, max(registers) - first + 1

    def _output_registers(self) -> set[int]:
        registers = {
            bit.register
            for name, bit in self.signals()
            if bit is not None and name not in HANDSHAKE_INPUTS
        }
        registers.update(range(self.response_base, self.response_base + self.response_words))
        return registers

    def _problems(self) -> list[str]:
        issues: list[str] = []
        low, high = WORDS_RANGE
        for what, words, base in (
            ("command", self.command_words, self.command_base),
            ("response", self.response_words, self.response_base),
        ):
            if not low <= words <= high:
                issues.append(f"{what}_words: {words} out of range (allowed: {low} to {high})")
            if not 0 <= base <= _REGISTER_MAX - max(words, 1) + 1:
                issues.append(
                    f"{what}_base: {base} out of range (allowed: 0 to "
                    f"{_REGISTER_MAX - max(words, 1) + 1} for {words} words)"
                )
        seen: dict[tuple[bool, Bit], str] = {}
        for name, bit in self.signals():
            if bit is None:
                if name not in STATUS_SIGNALS:
                    issues.append(
                        f"signals: {name} must be mapped: the Remote Control "
                        "function needs all seven handshake signals"
                    )
                continue
            if not (0 <= bit.register <= _REGISTER_MAX and 0 <= bit.bit <= 15):
                issues.append(
                    f"signals: {name} at {bit}: out of range (allowed: register 0 "
                    f"to {_REGISTER_MAX}, bit 0 to 15)"
                )
            key = (name in HANDSHAKE_INPUTS, bit)
            if key in seen:
                issues.append(f"signals: {seen[key]} and {name} are both at {bit}")
            seen[key] = name
        command = range(self.command_base, self.command_base + self.command_words)
        response = range(self.response_base, self.response_base + self.response_words)
        for name, bit in self.signals():
            if bit is None:
                continue
            is_input = name in HANDSHAKE_INPUTS
            span, what = (command, "command") if is_input else (response, "response")
            if bit.register in span:
                issues.append(
                    f"signals: {name} at {bit} lies in the {what} words "
                    f"(registers {span.start} to {span.stop - 1})"
                )
        if not issues:
            first, count = self.input_span
            if count > MODBUS_MAX_READ:
                issues.append(
                    f"the output signals and response words span {count} input "
                    f"registers from {first}: more than one Modbus read "
                    f"({MODBUS_MAX_READ})"
                )
        return issues
