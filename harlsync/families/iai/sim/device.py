"""The simulated IAI controller (protocol B): the controller's side of every
allow-listed message, exactly as the profile says, on the shared simulated line
(:mod:`harlsync.sim`).

How this works::

    '!' frame for one of our stations --> handle(state, frame) --> reply data --> '#' frame
    ('#' or '&' frame: silence)               |
                                      refused: '&' station code SC CR LF  (codes.py)

The line does the decoding: a bad SC, a foreign station, a bad header or a
missing LF never reach :meth:`Simulator.handle`, and get no reply (p.9).  A
well-formed command that cannot be carried out gets an ``&`` reply with one of
the placeholder codes of :mod:`~harlsync.families.iai.sim.codes` (each message's
answer is in :mod:`~harlsync.families.iai.sim.messages`):

- any message off the allow-list (motion, servo, program control, resets ...):
  refused and recorded, so a test can assert it was never sent (:meth:`Simulator.off_list`);
- a write (291H, 24BH-24EH) while the controller is not idle by the profile's
  interlock: refused before its data is looked at;
- 291H with a record of axis pattern 00, a coordinate for an axis the robot does
  not have, extended bits 0-3 set, or a number outside the position range:
  nothing of it is written (a 291H is applied whole or not at all);
- a 20DH whose start flag is not a multiple of 8 (the profile's reading of
  "a category's head flag + a multiple of 8", p.22);
- a command larger than the model's receive buffer, or a read whose reply would
  not fit its send buffer; a 22DH reply is cut to the whole records that fit
  instead, its count saying how many.

**(simulator)** The manual does not say what a controller in MANUAL mode does
with a command (p.7 says the protocol runs in AUTO).  This simulator answers
reads in MANUAL mode, reporting mode 2 in 215H, and refuses writes; a real
controller that stays silent instead looks to the client like one that does not
answer, which its interlock also treats as not idle (``manual_mode=silent``).

Where the manual is silent, :data:`VARIANTS` (issue 29) are the other ways a
controller may answer, each read where it answers (:attr:`Simulator.variant`):

- ``past_table``: a query naming a number its table lacks (22DH: a head past or
  before the table; 20DH-20FH, 210H, 2A0H: any number outside) is refused with
  ``&`` and that code, or answered normally with nothing for it: no records, a
  count that stops at the table's end (``empty``).  A 22DH whose head is in the
  table scans to its end either way;
- ``wide_query``: a 22DH asking for more numbers than a read of 8-axis records
  carries scans every one (its reply cut to the whole records that fit), scans
  only that many (``scans-less``: zero records when none is defined there), or is
  refused (``refused``, code 0A3);
- ``count_means``: 22DH's count is the numbers scanned, or the defined records
  returned (``records``: positions past the count's numbers come too);
- ``tables``: the tables' sizes (:func:`resize`): each controller's own
  (``ranges``: positions its range, flags and variables every number their
  message names), exactly the profile's default ranges, smaller or larger;
- ``real_word_order``: how 20FH and 24DH carry a real (p.24);
- ``reply_case``: its replies' hex digits in upper or lower case;
- ``manual_mode``: in MANUAL mode, answer (reads, refusing writes) or stay silent.
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

from ....errors import ProjectError, ProjectFormatError
from ....sim import device
from ....sim.device import Refused
from ....sim.family import Verb
from ....sim.variants import Variant
from .. import profile
from ..model import real_value
from ..protocol import Frame, FrameDecoder
from ..protocol.frame import _FRAME_OVERHEAD, sc
from . import codes
from .messages import HANDLERS
from .state import DEFAULT_AXES, MANUAL, SimState

__all__ = ["SIM_FAMILY", "VARIANTS", "IaiSimFamily", "Simulator", "resize"]

#: How a controller may fill the manual's silences, the profile's own way first
#: (:mod:`harlsync.sim.variants`; docs/profile.md lists them).
VARIANTS = (
    Variant(
        "past_table",
        ("refused-0A3", "empty", "refused-0B4"),
        "a query for a number a table lacks: refused with & and that code, or answered empty",
    ),
    Variant(
        "wide_query",
        ("scans-all", "scans-less", "refused"),
        "a 22DH for more numbers than a read of 8-axis records carries: scans them all, "
        "scans only that many, or is refused (& 0A3)",
    ),
    Variant(
        "count_means",
        ("numbers", "records"),
        "22DH's count: the numbers it scans, or the defined records it returns",
    ),
    Variant(
        "tables",
        ("ranges", "exact", "smaller", "larger"),
        "the tables' sizes: the robot's position range and every flag and variable "
        "number, exactly the profile's ranges, smaller than them, or larger",
    ),
    Variant(
        "real_word_order",
        ("upper-first", "lower-first"),
        "how 20FH and 24DH carry a real variable's double (p.24)",
    ),
    Variant("reply_case", ("upper", "lower"), "the case of the hex digits of its replies"),
    Variant(
        "manual_mode",
        ("answers", "silent"),
        "in MANUAL mode: answers reads and refuses writes, or answers nothing",
    ),
)

log = logging.getLogger(__name__)

#: The file a station's battery-backed memory is kept in, in its state directory.
MEMORY_FILE = "memory.json"


class IaiSimFamily:
    """The IAI side of the simulator framework (a :class:`~harlsync.sim.SimFamily`)."""

    name = "iai"
    verbs = (
        Verb("run", "[STATION]", "a program running, holding every axis"),
        Verb("manual", "[STATION]", "MANUAL mode"),
        Verb("estop", "[STATION]", "emergency stop"),
        Verb("flash", "[STATION]", "a flash ROM write in progress"),
        Verb("hold", "[STATION [AXIS]]", "an axis in use (default: the first)"),
        Verb("positioner", "[STATION]", "positioner mode (a PLC moves to position numbers)"),
        Verb("error", "[STATION [CODE]]", "a critical error (default code 0E1)"),
        Verb("cutoff", "[STATION]", "the drive source cut off"),
        Verb("gate", "[STATION]", "the safety gate open (a TTA: the enable switch)"),
        Verb("unplug", "[STATION [AXIS]]", "212H leaves an axis out (default: the first)"),
        Verb("stop", "[STATION]", "idle: AUTO mode, no program, nothing held"),
    )
    busy_verb = "run"
    default_station = profile.DEFAULT_STATION
    #: how it may fill its manual's silences (harlsync.sim.variants); the profile's first
    variants: tuple[Variant, ...] = VARIANTS

    def decoder(self) -> FrameDecoder:
        return FrameDecoder()

    def generate(self, seed: int, stations: Sequence[int]) -> Simulator:
        return Simulator({n: SimState.generate(seed + i) for i, n in enumerate(stations)})

    def from_project(self, project: Path, stations: Sequence[int] | None) -> Simulator:
        """The robot of an IAI project: its table, axes (robot.yaml's, else the
        default), model, position range and version."""
        from ....project import load_project
        from ..layout import position_range

        loaded = load_project(project)
        robot, data = loaded.robot, loaded.data
        try:
            states = {
                number: SimState.from_positions(
                    data.positions,
                    axes=robot.options.get("axes") or DEFAULT_AXES,
                    model=data.model,
                    position_range=position_range(robot),
                    version=data.version,
                )
                for number in stations or [robot.station]
            }
            for state in states.values():  # the flags and variables, when the project keeps them
                state.work_coordinates = dict(data.work_coordinates or {})
                state.tool_coordinates = dict(data.tool_coordinates or {})
                state.strings = {
                    start + i: int(row[2 * i : 2 * i + 2], 16)
                    for start, row in (data.strings or {}).items()
                    for i in range(len(row) // 2)
                }
                state.real_word_order = str(
                    robot.options.get("real_word_order", profile.DEFAULT_REAL_WORD_ORDER)
                )
                state.flags = {n for n, on in (data.flags or {}).items() if on}
                state.integers = dict(data.integers or {})
                state.reals = {n: real_value(text) for n, text in (data.reals or {}).items()}
        except ValueError as exc:
            raise ProjectError(f"{project}: the simulator cannot hold this robot: {exc}") from exc
        return Simulator(states)


SIM_FAMILY = IaiSimFamily()

#: The control verbs that switch one condition of the controller on, and its field.
_SWITCHES = {
    "estop": "emergency_stop",
    "flash": "flash_writing",
    "positioner": "positioner_mode",
    "cutoff": "drive_cut_off",
    "gate": "safety_gate_open",
}

#: The critical error the ``error`` verb sets when given no code: a placeholder (the
#: manual's error list is not in our pages), like the codes of :mod:`.codes`.
CRITICAL_ERROR = "0E1"


class Simulator(device.Simulator[SimState, Frame]):
    """A simulated IAI controller: one serial line and the controllers (stations) on it.

    ``busy_after_writes`` starts a program on the written station once that many
    writes have been carried out.
    """

    family = SIM_FAMILY

    # --- the line's hooks -----------------------------------------------------------------

    def respond(self, station: int, state: SimState, frame: Frame) -> bytes | None:
        if frame.kind != "!":
            return None  # a reply or an error is no command: a bad header (p.9)
        if state.mode == MANUAL and self.variant["manual_mode"] == "silent":
            return None
        try:
            reply = Frame("#", station, frame.message_id, self.handle(state, frame))
        except Refused as refusal:
            reply = Frame("&", station, None, refusal.code)
        encoded = reply.encode()
        return _lower_case(encoded) if self.variant["reply_case"] == "lower" else encoded

    def vary(self, chosen: Mapping[str, str]) -> None:
        """As :meth:`~harlsync.sim.device.Device.vary`; a ``tables`` or
        ``real_word_order`` chosen reshapes every station's state now (their tables,
        and what lies outside them dropped; the order its reals are kept in)."""
        super().vary(chosen)
        given = {name.strip().replace("-", "_") for name in chosen}
        for state in self.stations.values():
            if "tables" in given:
                resize(state, self.variant["tables"])
            if "real_word_order" in given:
                state.real_word_order = self.variant["real_word_order"]

    def command(self, frame: Frame) -> str:
        return frame.payload[:3]

    def is_write(self, frame: Frame) -> bool:
        return frame.message_id in profile.WRITE_MESSAGE_IDS

    def busy(self, state: SimState) -> bool:
        return not state.idle

    def corrupt_checksum(self, frame: bytes) -> bytes:
        wrong = int(frame[-4:-2], 16) ^ 0x5A  # the SC: two hex digits before CR LF
        return frame[:-4] + f"{wrong:02X}".encode("ascii") + frame[-2:]

    def control(self, verb: str, state: SimState, args: Sequence[str]) -> None:
        if verb in ("hold", "unplug"):
            axis = int(args[0]) if args else state.axes[0]
            if axis not in state.axes:
                raise ValueError(f"no axis {axis} (the robot has {list(state.axes)})")
            (state.axes_in_use if verb == "hold" else state.unreported_axes).add(axis)
        elif verb == "error":
            code = (args[0] if args else CRITICAL_ERROR).upper()
            if len(code) != 3 or not all(c in "0123456789ABCDEF" for c in code) or code == "000":
                raise ValueError(f"error code {code!r}: three hex digits, not 000")
            state.critical_error = state.latest_error = code
        elif args:
            raise ValueError(f"{verb} takes only a station")
        elif verb == "run":
            state.run_program()
        elif verb == "manual":
            state.mode = MANUAL
        elif verb in _SWITCHES:
            setattr(state, _SWITCHES[verb], True)
        elif verb == "stop":
            state.stop()
        else:
            raise ValueError(f"unknown command {verb!r}")

    def describe(self, state: SimState) -> str:
        return ", ".join(state.not_idle()) or "idle"

    def save_station(self, station: int, directory: Path) -> None:
        """Write the station's table, flags and variables to ``directory/memory.json``
        (a new file renamed over the old one: a kill never leaves half of it)."""
        directory.mkdir(parents=True, exist_ok=True)
        target = directory / MEMORY_FILE
        temp = directory / f".{MEMORY_FILE}.{os.getpid()}"
        temp.write_text(json.dumps(self.stations[station].memory(), indent=1) + "\n")
        os.replace(temp, target)

    def load_station(self, station: int, directory: Path) -> bool:
        path = directory / MEMORY_FILE
        if not path.exists():
            return False
        old = self.stations[station]
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
            self.stations[station] = SimState.from_memory(doc, old.versions)
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ProjectFormatError(f"{path}: not a simulator memory: {exc}") from exc
        return True

    # --- the controller ---------------------------------------------------------------------

    def handle(self, state: SimState, frame: Frame) -> str:
        """The reply data to one command for one controller.  Raises :class:`~harlsync.sim.Refused`."""
        assert frame.message_id is not None  # a '!' frame always has one
        handler = HANDLERS.get(frame.message_id)
        if handler is None or frame.message_id not in profile.ALLOWED_MESSAGE_IDS:
            log.warning(
                "sim: station %02X got message %03XH, which is off the allow-list",
                frame.station,
                frame.message_id,
            )
            raise Refused(codes.NOT_SUPPORTED)
        if _FRAME_OVERHEAD + len(frame.data) > state.buffers.receive:
            raise Refused(codes.TOO_LONG)
        if frame.message_id in profile.WRITE_MESSAGE_IDS and not state.idle:
            raise Refused(codes.NOT_IDLE)
        try:
            reply = handler(self, state, frame.data)
        except ValueError:
            raise Refused(codes.BAD_DATA) from None
        if _FRAME_OVERHEAD + len(reply) > state.buffers.send:
            raise Refused(codes.TOO_LONG)
        return reply

    # --- for tests -----------------------------------------------------------------------------

    def off_list(self) -> list[device.Received]:
        """Every request received whose message is off the profile's allow-list."""
        with self.lock:
            return [
                r for r in self.received if int(r.command, 16) not in profile.ALLOWED_MESSAGE_IDS
            ]

    def writes_while_busy(self) -> list[device.Received]:
        """Every write received while the controller was not idle (each one refused)."""
        return [r for r in self.writes_received() if r.busy]


def _lower_case(frame: bytes) -> bytes:
    """A reply frame with its hex digits in lower case, and its SC summed over them."""
    body = frame[:-4].lower()
    return body + f"{sc(body):02x}".encode("ascii") + b"\r\n"


#: The flag and variable tables of ``tables=smaller`` and ``tables=larger``.
_SMALLER = {"flags": (600, 799), "integers": (200, 265), "reals": (300, 365)}
_LARGER = {"flags": (0, 1199), "integers": (1, 1299), "reals": (1, 1399)}


def resize(state: SimState, size: str) -> None:
    """Give ``state`` the tables of the ``tables`` variant ``size`` and drop what
    lies outside them: ``ranges`` leaves it as it is; ``exact`` makes flags and
    integer and real variables the profile's default ranges; ``smaller`` makes
    each table smaller than the profile's (its position range three fifths as
    long); ``larger`` larger (twice as long).  Raises ValueError for another size."""
    first, last = state.position_range
    length = last - first + 1
    if size == "ranges":
        return
    if size == "exact":
        state.tables.update(profile.DEFAULT_VARIABLE_RANGES)
    elif size == "smaller":
        state.tables.update(_SMALLER)
        state.position_range = (first, first + max(1, length * 3 // 5) - 1)
    elif size == "larger":
        state.tables.update(_LARGER)
        state.position_range = (first, min(0xFFFF, first + 2 * length - 1))
    else:
        raise ValueError(f"tables {size}: one of ranges, exact, smaller, larger")
    low, high = state.position_range
    state.positions = {n: p for n, p in state.positions.items() if low <= n <= high}

    def inside(section: str, n: int) -> bool:
        low, high = state.tables[section]
        return low <= n <= high

    state.flags = {n for n in state.flags if inside("flags", n)}
    state.integers = {n: v for n, v in state.integers.items() if inside("integers", n)}
    state.reals = {n: v for n, v in state.reals.items() if inside("reals", n)}
