"""The simulated HARL-U2: the controller's side of every HARL-U2 command, played
with the family's own codec, on the shared simulated line (:mod:`harlsync.sim`).

How this works::

    frame for one of our stations --> handle(state, payload) --> reply payload
                                          |                    ("E"+status on error)
                                      encode_frame(station, reply) --> the line

The line (:class:`harlsync.sim.Simulator`) does the rest: decoding, station
lookup, wire time, faults and the record of every request.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

from ....errors import ProtocolError
from ....sim import device
from ....sim.device import Refused
from ....sim.family import Verb
from ....sim.variants import Variant
from ..model import (
    MAX_STEP_DATA,
    OFFSET_TABLE_COUNT,
    REGISTER_RE,
    TIMER_RE,
    TOKEN_RE,
    Config,
    OffsetTable,
    Parameters,
    ProgramType,
    Status,
    Step,
)
from ..protocol import Frame, FrameDecoder, Request, encode_frame, parse_request, profile
from .state import IO_BITS, MEM_BIT_BASE, SimState

__all__ = [
    "SIM_FAMILY",
    "STATUS_BUSY",
    "STATUS_COMMAND",
    "STATUS_DATA",
    "STATUS_RANGE",
    "VARIANTS",
    "Simulator",
]

#: Error statuses the simulator answers with (the real codes are in the HRCS-R3
#: manual, which we do not have; harlsync shows them raw and relies on none).
STATUS_RANGE = profile.NO_SUCH_TABLE  # number outside the configuration (the profile's)
STATUS_COMMAND = "10"  # unknown command or wrong number of fields
STATUS_DATA = "22"  # value out of range for a write
STATUS_BUSY = "30"  # cannot answer normally now (``SimState.errors``)

#: How this simulator may fill the manual's silences (:mod:`harlsync.sim.variants`),
#: the profile's guess first.  docs/profile.md lists them with the guesses they vary.
VARIANTS = (
    Variant(
        "missing_table",
        (profile.ERROR_PREFIX + STATUS_RANGE, "E2", "E99"),
        "the reply to a number it does not have: an offset table past its last, a "
        "program, step, timer or register outside LNX's configuration",
    ),
    Variant(
        "offset_tables",
        (str(OFFSET_TABLE_COUNT), "64"),
        "how many offset tables it has (one with more than robot.yaml's offset_tables "
        "is refused by the default pull, so it is tested apart: SimState.offset_tables)",
    ),
)


class HarlU2SimFamily:
    """The HARL-U2 side of the simulator framework (a :class:`~harlsync.sim.SimFamily`)."""

    name = "harl-u2"
    verbs = (
        Verb("auto", "[STATION [TASK]]", "task in execution (automatic operation)"),
        Verb("suspend", "[STATION [TASK]]", "task suspended"),
        Verb("stop", "[STATION]", "every task stopped: the robot is idle"),
    )
    busy_verb = "auto"
    default_station = 1
    #: how it may fill its manual's silences (harlsync.sim.variants); the profile's first
    variants: tuple[Variant, ...] = VARIANTS

    def decoder(self) -> FrameDecoder:
        return FrameDecoder()

    def generate(self, seed: int, stations: Sequence[int]) -> Simulator:
        return Simulator({n: SimState.generate(seed + i) for i, n in enumerate(stations)})

    def from_project(self, project: Path, stations: Sequence[int] | None) -> Simulator:
        from ....project import load_project

        loaded = load_project(project)
        return Simulator(
            {
                number: SimState.from_robot_data(loaded.data)
                for number in stations or [loaded.robot.station]
            }
        )


SIM_FAMILY = HarlU2SimFamily()


class Simulator(device.Simulator[SimState, Frame]):
    """A simulated HNC controller: one serial line and the robots (stations) on it.

    ``busy_after_writes`` puts task 0 of the written station into automatic
    operation once that many SN writes have been carried out.
    """

    family = SIM_FAMILY

    # --- the line's hooks ---------------------------------------------------------------

    def respond(self, station: int, state: SimState, frame: Frame) -> bytes:
        return encode_frame(station, self.handle(state, frame.payload))

    def command(self, frame: Frame) -> str:
        return frame.payload.split(" ", 1)[0]

    def is_write(self, frame: Frame) -> bool:
        return self.command(frame).startswith("SN")

    def busy(self, state: SimState) -> bool:
        return state.automatic

    def corrupt_checksum(self, frame: bytes) -> bytes:
        return frame[:-1] + bytes([frame[-1] ^ 0x5A])  # the LRC is the last byte

    def control(self, verb: str, state: SimState, args: Sequence[str]) -> None:
        task = int(args[0]) if args else 0
        if not 0 <= task < len(state.tasks):
            raise ValueError(f"no task {task} (allowed: 0 to {len(state.tasks) - 1})")
        if verb == "auto":
            state.start_task(task)
        elif verb == "suspend":
            state.suspend_task(task)
        elif verb == "stop":
            state.stop_all()
        else:
            raise ValueError(f"unknown command {verb!r}")

    def describe(self, state: SimState) -> str:
        """As a client's LNR read says it: ``idle``, or each task in execution
        (automatic operation) or suspended, with its program and step."""
        return Status(tuple(state.tasks)).describe()

    def save_station(self, station: int, directory: Path) -> None:
        """Save the station as the robot project ``directory`` (atomically, as a pull does)."""
        from ....project import Project, new_robot, save_project

        robot = new_robot(
            directory.name, f"sim://{directory.resolve()}", station, keep_registers=True
        )
        save_project(directory, Project(directory, robot, self.stations[station].data))

    def load_station(self, station: int, directory: Path) -> bool:
        """Restore the station from the robot project ``directory``, when there is one.
        Tasks and I/O are not kept: a restarted controller has every task stopped."""
        from ....project import load_project

        if not (directory / "robot.yaml").exists():
            return False
        self.stations[station] = SimState.from_robot_data(load_project(directory).data)
        return True

    # --- the controller -----------------------------------------------------------

    def handle(self, state: SimState, payload: str) -> str:
        """The reply payload to one request payload for one robot."""
        try:
            request = parse_request(payload)
        except ProtocolError:
            return profile.ERROR_PREFIX + STATUS_COMMAND
        if payload in state.errors:
            return profile.ERROR_PREFIX + state.errors[payload]
        try:
            if request.is_write:
                reply = self._write(state, request)
                self.wrote(state)
                return reply
            return self._read(state, request)
        except Refused as refusal:
            if refusal.code == STATUS_RANGE:  # a number it does not have
                return self.variant["missing_table"]
            return profile.ERROR_PREFIX + refusal.code
        except ValueError:
            return profile.ERROR_PREFIX + STATUS_COMMAND

    def _read(self, state: SimState, req: Request[object]) -> str:
        data, cfg, a = state.data, state.data.config, req.args
        letters = req.letters
        if letters in ("LNA", "LNM", "LNS", "LNH"):
            key, step = _program_step(cfg, letters, a)
            found = data.programs[key].get(step, Step())
            return " ".join((str(step), *found.tokens))
        if letters == "LNT":
            return data.timers[_index(a[0], cfg.timers)]
        if letters == "LND":
            assert data.registers is not None
            return data.registers[_index(a[0], cfg.registers)]
        if letters == "LNL":
            return " ".join(data.offsets[_index(a[0], self.offset_tables(state))].values)
        if letters in ("LNIB", "LNOB"):
            bits = state.di if letters == "LNIB" else state.do
            return str(bits[_index(a[0], IO_BITS)])
        if letters in ("LNID", "LNOD"):
            bits = state.di if letters == "LNID" else state.do
            return str(_port_value(bits, _index(a[0], IO_BITS // 8)))
        if letters == "LNBB":
            return str(state.mem[_index(a[0], cfg.memory_bits, MEM_BIT_BASE)])
        if letters == "LNBD":
            return str(_port_value(state.mem, _index(a[0], cfg.memory_bits // 8)))
        if letters == "LNE":
            return " ".join(data.parameters.values)
        if letters == "LNR":
            return " ".join(
                f"{t.status} {t.program_type} {t.program} {t.step}" for t in state.tasks
            )
        if letters == "LNV":
            return data.version
        if letters == "LNX":
            return " ".join(str(n) for n in cfg.numbers())
        raise Refused(STATUS_COMMAND)

    def _write(self, state: SimState, req: Request[object]) -> str:
        data, cfg, a = state.data, state.data.config, req.args
        letters = req.letters
        if letters in ("SNA", "SNM", "SNS", "SNH"):
            numbered = letters != "SNA"
            key, step = _program_step(cfg, "LN" + letters[2], a[: 2 if numbered else 1])
            tokens = a[2 if numbered else 1 :]
            if len(tokens) > 1 + MAX_STEP_DATA:
                raise Refused(STATUS_DATA)
            if tokens:
                data.programs[key][step] = Step.from_tokens(tokens)
            else:
                data.programs[key].pop(step, None)
        elif letters == "SNT":
            data.timers[_index(a[0], cfg.timers)] = _valid(TIMER_RE, a[1])
        elif letters == "SND":
            assert data.registers is not None
            data.registers[_index(a[0], cfg.registers)] = _valid(REGISTER_RE, a[1])
        elif letters == "SNL":
            table = OffsetTable.from_values(a[1:])
            if table.problems():
                raise Refused(STATUS_DATA)
            data.offsets[_index(a[0], self.offset_tables(state))] = table
        elif letters in ("SNOB", "SNBB"):
            bits = state.do if letters == "SNOB" else state.mem
            base, size = (0, IO_BITS) if letters == "SNOB" else (MEM_BIT_BASE, cfg.memory_bits)
            bits[_index(a[0], size, base)] = int(_valid_bit(a[1]))
        elif letters in ("SNOD", "SNBD"):
            bits = state.do if letters == "SNOD" else state.mem
            port = _index(a[0], len(bits) // 8)
            value = int(a[1])
            if not 0 <= value <= 255:
                raise Refused(STATUS_DATA)
            for i in range(8):
                bits[port * 8 + i] = (value >> i) & 1
        elif letters == "SNE":
            if not all(TOKEN_RE.fullmatch(v) for v in a):
                raise Refused(STATUS_DATA)
            data.parameters = Parameters.from_values(a)
        elif letters == "SNX":
            data.config = Config.from_numbers(
                [*(int(v) for v in a), cfg.timers, cfg.memory_bits, cfg.registers]
            )
            # The manual: changing the configuration breaks the programs made.
            data.programs = {key: {} for key in data.config.programs()}
        else:
            raise Refused(STATUS_COMMAND)
        return profile.SN_OK

    def offset_tables(self, state: SimState) -> int:
        """How many offset tables the robot has: its own count when it has one (a
        robot built with more, or from a project), else the ``offset_tables`` variant's."""
        if state.offset_tables is not None:
            return state.offset_tables
        return int(self.variant["offset_tables"])

    # --- for tests -------------------------------------------------------------------

    def unsafe_in_automatic(self) -> list[device.Received]:
        """Unsafe SN commands (SNA/SNM/SNS/SNH/SNE/SNX) received during automatic operation."""
        with self.lock:
            return [r for r in self.received if r.busy and Request(r.command).unsafe]


def _index(text: str, size: int, base: int = 0) -> int:
    """A number field within [base, base+size), else a range error."""
    if not text.isdigit():
        raise Refused(STATUS_COMMAND)
    n = int(text) - base
    if not 0 <= n < size:
        raise Refused(STATUS_RANGE)
    return n


def _program_step(
    cfg: Config, letters: str, args: tuple[str, ...]
) -> tuple[tuple[ProgramType, int], int]:
    ptype = next(t for t in ProgramType if t.letter == letters[2])
    area = cfg.area(ptype)
    if ptype is ProgramType.START:
        number, step_text = 0, args[0]
        if area.count < 1:
            raise Refused(STATUS_RANGE)
    else:
        number, step_text = _index(args[0], area.count), args[1]
    return (ptype, number), _index(step_text, area.steps)


def _port_value(bits: list[int], port: int) -> int:
    return sum(bits[port * 8 + i] << i for i in range(8))


def _valid(pattern: re.Pattern[str], text: str) -> str:
    if not pattern.fullmatch(text):
        raise Refused(STATUS_DATA)
    return text


def _valid_bit(text: str) -> str:
    if text not in ("0", "1"):
        raise Refused(STATUS_DATA)
    return text
