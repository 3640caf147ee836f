"""The simulated Epson controller over a real Modbus TCP socket, driven by the
family's own handshake and transport: every backup read and deploy write, the
split and Rn writes, the §6.5 function error (only when driven wrongly on
purpose: every correct run asserts the simulator saw none), a power cycle,
faults, the status bits and their verbs, and commands off the lists refused and
recorded."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

import pytest
from serial import SerialException
from simprocess import harlsync_sim

from harlsync.errors import InterlockError, LinkTimeout, ReplyError
from harlsync.families.epson import protocol as p
from harlsync.families.epson.handshake import Handshake
from harlsync.families.epson.map_form import map_from_dict
from harlsync.families.epson.profile import RegisterMap
from harlsync.families.epson.protocol import (
    AccelPercent,
    AccelReal,
    Distances,
    ErrorReply,
    Inertia,
    Limits,
    PulseLimits,
    SpeedPercent,
    SpeedReal,
    Weight,
    real_text,
)
from harlsync.families.epson.sim import (
    SCARA,
    SIX_AXIS,
    Point,
    SimState,
    Simulator,
    commands,
)
from harlsync.families.epson.steps import FunctionError, HandshakeTimeout, Step
from harlsync.families.epson.transport import ModbusLink
from harlsync.sim import ServedFamily, sim_family
from harlsync.sim.control import apply_command
from harlsync.sim.memory import keep_state
from harlsync.sim.protocol_sim import simulator_from_url

SEED = 11
#: Seconds any wait in these tests may take before it fails.
DEADLINE = 5.0


class ManualClock:
    """The simulator's time, moved by the test: a command runs, or a reset lasts,
    exactly as long as the test says."""

    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now

    def advance(self, seconds: float) -> None:
        self.now += seconds

    # the handshake's Clock too: its polls move the time, nothing waits
    def monotonic(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds


def robot(robot_type: int = SCARA) -> SimState:
    """A generated robot with known table entries and LimZ to test against."""
    state = SimState.generate(SEED, robot_type=robot_type)
    state.accel[4] = (90, 70)
    state.accel_s[4] = (100_123, 200_000)  # the manual's example (§10.2)
    state.limz = -12_345
    return state


def no_function_error(sim: Simulator) -> None:
    """What every correct run leaves: no function error, nothing off the lists, no
    write while the robot was busy, no request over command words not all written."""
    assert sim.function_errors == []
    assert sim.off_list() == []
    assert sim.writes_while_busy() == []
    assert sim.stale_requests == []


@contextmanager
def connected(
    sim: Simulator, *, deadline: float = 2.0, timeout: float = 0.5, retries: int = 2
) -> Iterator[tuple[Handshake, ModbusLink]]:
    """The family's handshake and Modbus link to ``sim``, served on a free port."""
    with sim.serve() as server, ModbusLink(server.url, timeout=timeout, retries=retries) as link:
        yield Handshake(link, sim.register_map, deadline=deadline), link


@pytest.fixture
def sim() -> Simulator:
    return Simulator(robot(), execution_time=0.0)


@pytest.fixture
def client(sim: Simulator) -> Iterator[Handshake]:
    """A correct client: the simulator must see no function error in its run."""
    with connected(sim) as (handshake, _):
        yield handshake
    no_function_error(sim)


def wait_until(condition: Callable[[], bool], what: str, deadline: float = DEADLINE) -> None:
    """Poll ``condition`` (each poll a Modbus round trip) until true, or fail."""
    end = time.monotonic() + deadline
    while not condition():
        assert time.monotonic() < end, f"{what}: not within {deadline} s"


class Remote:
    """The Remote I/O driven by hand, bypassing the codec and the handshake: to
    send what harlsync never would, and to drive the handshake wrongly on purpose.
    (The default map: every input in one register.)"""

    def __init__(self, link: ModbusLink, register_map: RegisterMap | None = None) -> None:
        self.link = link
        self.map = register_map or RegisterMap()
        self.control = 0

    def drive(self, **levels: bool) -> None:
        """Set inputs (``ExtCmdSet=True`` ...) in one write of their register."""
        for name, on in levels.items():
            bit = self.map.signal(name)
            assert bit is not None
            self.control = self.control | 1 << bit.bit if on else self.control & ~(1 << bit.bit)
        self.link.write_holding(self.map.ext_cmd_set.register, [self.control])

    def words(self, *words: int) -> None:
        self.link.write_holding(
            self.map.command_base, [*words, *[0] * (self.map.command_words - len(words))]
        )

    def outputs(self) -> tuple[dict[str, bool], list[int]]:
        first, count = self.map.input_span
        values = self.link.read_input(first, count)
        levels = {
            name: bool(values[bit.register - first] >> bit.bit & 1)
            for name, bit in self.map.signals()
            if bit is not None and name not in ("ExtCmdSet", "ExtRespGet", "ExtCmdReset")
        }
        start = self.map.response_base - first
        return levels, values[start : start + self.map.response_words]

    def wait(self, name: str, level: bool) -> list[int]:
        """Wait for an output; the response words then."""
        seen: list[int] = []

        def reached() -> bool:
            levels, words = self.outputs()
            seen[:] = words
            return levels[name] == level

        wait_until(reached, f"{name} {int(level)}")
        return seen

    def request(self, *words: int) -> None:
        """Steps 1-4 of §6.3: the controller has taken the command."""
        self.drive(ExtCmdReset=True)
        self.words(*words)
        self.drive(ExtCmdSet=True)
        self.wait("ExtCmdGet", True)

    def collect(self) -> tuple[bool, list[int]]:
        """Steps 5-10: ExtCmdResult and the response words."""
        self.drive(ExtCmdSet=False)
        response = self.wait("ExtRespSet", True)
        error = self.outputs()[0]["ExtCmdResult"]
        self.drive(ExtRespGet=True)
        self.wait("ExtRespSet", False)
        self.drive(ExtRespGet=False)
        return error, response

    def command(self, *words: int) -> tuple[bool, list[int]]:
        """The ten steps of §6.3 by hand."""
        self.request(*words)
        return self.collect()


def error_code(reply: object) -> int:
    assert isinstance(reply, ErrorReply), reply
    return reply.code


def rt(units: int) -> str:
    return real_text(units)


# --- the command set --------------------------------------------------------------------


def test_the_simulator_takes_exactly_the_commands_the_family_sends() -> None:
    assert commands.COMMAND_SET == p.BACKUP_READS | p.DEPLOY_WRITES
    assert commands.READS == p.BACKUP_READS
    assert commands.COMMAND_SET.isdisjoint(p.NEVER_SEND)


# --- every backup read ---------------------------------------------------------------------


@pytest.mark.parametrize("robot_type", [SCARA, SIX_AXIS])
def test_every_backup_read_answers_what_the_robot_holds(robot_type: int) -> None:
    state = robot(robot_type)
    sim = Simulator(state.copy(), execution_time=0.0)
    axes = state.axes
    with connected(sim) as (hs, _):
        for t in range(16):
            if t in state.accel:
                assert hs.execute(p.read_accel(t)) == AccelPercent(*state.accel[t])
            else:
                assert error_code(hs.execute(p.read_accel(t))) == 0x2006
            for table, read, accel, decel in (
                (state.accel_s, p.read_accel_s, p.read_accel_s_accel, p.read_accel_s_decel),
                (state.accel_r, p.read_accel_r, p.read_accel_r_accel, p.read_accel_r_decel),
            ):
                if t in table:
                    a, d = table[t]
                    assert hs.execute(read(t)) == AccelReal(rt(a), rt(d))
                    assert hs.execute(accel(t)) == rt(a)
                    assert hs.execute(decel(t)) == rt(d)
                else:
                    assert error_code(hs.execute(read(t))) == 0x2006
            if t in state.speed:
                assert hs.execute(p.read_speed(t)) == SpeedPercent(*state.speed[t])
            else:
                assert error_code(hs.execute(p.read_speed(t))) == 0x2006
            if t in state.speed_s:
                speed, depart, approach = (rt(v) for v in state.speed_s[t])
                assert hs.execute(p.read_speed_s(t)) == SpeedReal(speed, depart, approach)
                assert hs.execute(p.read_speed_s_speed_depart(t)) == (speed, depart)
                assert hs.execute(p.read_speed_s_approach(t)) == approach
            else:
                assert error_code(hs.execute(p.read_speed_s_approach(t))) == 0x2006
            if t in state.speed_r:
                assert hs.execute(p.read_speed_r(t)) == rt(state.speed_r[t])
            else:
                assert error_code(hs.execute(p.read_speed_r(t))) == 0x2006
        assert hs.execute(p.read_weight()) == Weight(*(rt(v) for v in state.weight))
        assert hs.execute(p.read_inertia()) == Inertia(*(rt(v) for v in state.inertia))
        assert hs.execute(p.read_inertia_load()) == rt(state.inertia[0])
        assert hs.execute(p.read_inertia_eccentricity()) == rt(state.inertia[1])
        for arch in range(7):
            depart, approach = (rt(v) for v in state.arch[arch])
            assert hs.execute(p.read_arch(arch)) == Distances(depart, approach)
            assert hs.execute(p.read_arch_depart(arch)) == depart
            assert hs.execute(p.read_arch_approach(arch)) == approach
        assert hs.execute(p.read_fine(axes)) == state.fine
        assert hs.execute(p.read_fine_123()) == state.fine[:3]
        assert hs.execute(p.read_fine_456(axes)) == state.fine[3:]
        assert hs.execute(p.read_tool()) == state.tool
        for area in (*state.boxes, min(set(range(1, 16)) - set(state.boxes))):
            limits = state.boxes.get(area, ((0, 0), (0, 0), (0, 0)))
            for axis, (low, high) in enumerate(limits):
                assert hs.execute(p.read_box(area, axis)) == Limits(rt(low), rt(high))
                assert hs.execute(p.read_box_lower(area, axis)) == rt(low)
                assert hs.execute(p.read_box_upper(area, axis)) == rt(high)
        for frames, read_frame in ((state.planes, p.read_plane), (state.locals, p.read_local)):
            for number in (*frames, min(set(range(1, 16)) - set(frames))):
                coords = frames.get(number, (0,) * axes)
                assert [hs.execute(read_frame(number, c)) for c in range(axes)] == [
                    rt(v) for v in coords
                ]
        for axis, (low, high) in enumerate(state.xylim):
            assert hs.execute(p.read_xylim(axis)) == Limits(rt(low), rt(high))
            assert hs.execute(p.read_xylim_lower(axis)) == rt(low)
            assert hs.execute(p.read_xylim_upper(axis)) == rt(high)
        for joint, (low, high) in enumerate(state.jrange, 1):
            assert hs.execute(p.read_jrange(joint)) == PulseLimits(low, high)
            assert hs.execute(p.read_jrange_lower(joint)) == low
            assert hs.execute(p.read_jrange_upper(joint)) == high
        assert [hs.execute(p.read_base(c)) for c in range(axes)] == [rt(v) for v in state.base]
        assert hs.execute(p.read_limz()) == "-12.345"
        assert hs.execute(p.read_robot_type()) == robot_type
        defined = sorted(state.points)
        undefined = min(set(range(200)) - set(state.points))
        for number in defined[:3]:
            point = state.points[number]
            assert [hs.execute(p.read_point_coord(number, a)) for a in range(axes)] == [
                rt(v) for v in point.coords
            ]
            for name in ("hand", "elbow", "wrist", "j4flag", "j6flag", "local"):
                assert hs.execute(p.read_point_attribute(name, number)) == getattr(point, name)
        assert error_code(hs.execute(p.read_point_coord(undefined, 0))) == 0x2004
        assert error_code(hs.execute(p.read_point_attribute("hand", undefined))) == 0x2004
        name, reply = "", hs.execute(p.read_model_name_char(True))
        while True:
            assert not isinstance(reply, ErrorReply)
            name += reply.char
            if reply.status != 1:
                break
            reply = hs.execute(p.read_model_name_char(False))
        assert (name, reply.status) == (state.model, 0)
        finished = hs.execute(p.read_model_name_char(False))
        assert not isinstance(finished, ErrorReply) and finished.status == 2
    assert sim.stations[1] == state  # reads change nothing
    assert sim.writes_received() == [] and sim.writes == 0
    no_function_error(sim)


# --- every deploy write -----------------------------------------------------------------------


@pytest.mark.parametrize("robot_type", [SCARA, SIX_AXIS])
def test_every_deploy_write_takes_effect_in_each_of_its_forms(robot_type: int) -> None:
    sim = Simulator(robot(robot_type), execution_time=0.0)
    st = sim.stations[1]
    axes = st.axes
    coords = [f"{i}.5" for i in range(1, axes + 1)]
    sent = 0
    with connected(sim) as (hs, _):

        def write(sequence: p.WriteSequence) -> None:
            nonlocal sent
            assert hs.execute_sequence(sequence) is None, sequence.what
            sent += 1

        write(p.register_accel(5, 100, 80))
        write(p.register_accel_s(6, AccelReal("100.123", "200.000")))
        write(p.register_accel_s(7, AccelReal("1", "2"), command_words=4))
        write(p.register_accel_r(6, AccelReal("3.5", "4.25")))
        write(p.register_accel_r(7, AccelReal("5", "6"), command_words=4))
        write(p.register_speed(5, SpeedPercent(100, 80, 50)))
        write(p.register_speed_s(6, SpeedReal("1000", "800.5", "50.25")))
        write(p.register_speed_s(7, SpeedReal("1", "2", "3"), command_words=6))
        write(p.register_speed_r(6, "1000"))
        assert (st.accel[5], st.accel_s[6], st.accel_s[7]) == (
            (100, 80),
            (100_123, 200_000),
            (1000, 2000),
        )
        assert (st.accel_r[6], st.accel_r[7], st.speed[5]) == (
            (3500, 4250),
            (5000, 6000),
            (100, 80, 50),
        )
        assert (st.speed_s[6], st.speed_s[7], st.speed_r[6]) == (
            (1_000_000, 800_500, 50_250),
            (1000, 2000, 3000),
            1_000_000,
        )
        write(p.set_weight("5.12", "120.001"))
        assert st.weight == ((5120, 120_001) if robot_type == SCARA else (5120, 0))
        write(p.set_weight("4"))
        assert st.weight[0] == 4000
        write(p.set_inertia(Inertia("0.05", "10")))
        assert st.inertia == (50, 10_000)
        write(p.set_inertia(Inertia("0.06", "11"), command_words=4))
        assert st.inertia == (60, 11_000)
        write(p.set_arch(3, Distances("10.123", "20.123")))
        write(p.set_arch(4, Distances("1", "2"), command_words=4))
        assert (st.arch[3], st.arch[4]) == ((10_123, 20_123), (1000, 2000))
        write(p.set_fine(tuple(range(100, 100 + axes))))
        assert st.fine == tuple(range(100, 100 + axes))
        write(p.set_fine(tuple(range(200, 200 + axes)), command_words=4))
        assert st.fine == tuple(range(200, 200 + axes))
        write(p.select_tool(5))
        assert st.tool == 5
        box = [Limits("0", "200"), Limits("100", "100"), Limits("-1", "100")]
        write(p.set_box(1, box))
        write(p.set_box(2, box, command_words=5))
        assert st.boxes[1] == st.boxes[2] == ((0, 200_000), (100_000, 100_000), (-1000, 100_000))
        write(p.set_plane(1, coords))
        write(p.set_local(2, coords))
        write(p.set_base(coords))
        assert (
            st.planes[1]
            == st.locals[2]
            == st.base
            == tuple(i * 1000 + 500 for i in range(1, axes + 1))
        )
        limits = [Limits("10", "200"), Limits("20", "100"), Limits("30", "100")]
        write(p.set_xylim(limits))
        assert st.xylim == ((10_000, 200_000), (20_000, 100_000), (30_000, 100_000))
        write(p.set_xylim(list(reversed(limits)), command_words=4))
        assert st.xylim == ((30_000, 100_000), (20_000, 100_000), (10_000, 200_000))
        write(p.set_jrange(1, PulseLimits(-6000, 7000)))
        write(p.set_jrange(axes, PulseLimits(-1, 1), command_words=4))
        assert (st.jrange[0], st.jrange[-1]) == ((-6000, 7000), (-1, 1))
        write(p.set_limz("-100"))
        assert st.limz == -100_000
        new = max(st.points) + 5
        write(p.set_point_coord(new, 1, "-100.003"))  # the first 1204 defines the point
        assert st.points[new].coords == tuple(-100_003 if a == 1 else 0 for a in range(axes))
        for name, value in (
            ("hand", 0),
            ("elbow", 1),
            ("wrist", 1),
            ("j4flag", 1),
            ("j6flag", 127),
            ("local", 15),
            ("hand", 1),
        ):
            write(p.set_point_attribute(name, new, value))  # type: ignore[arg-type]
            assert getattr(st.points[new], name) == value
        # each write reads back through the codec as written
        assert hs.execute(p.read_accel_s(6)) == AccelReal("100.123", "200.000")
        assert hs.execute(p.read_point_coord(new, 1)) == "-100.003"
    assert sim.writes == sent  # a split or Rn write counts once
    assert all(r.answered and r.code == 0 for r in sim.commands())
    no_function_error(sim)


def test_a_write_counts_once_when_it_takes_effect(sim: Simulator) -> None:
    with connected(sim) as (hs, _):
        hs.execute_sequence(p.register_accel_s(2, AccelReal("1", "2"), command_words=4))
        hs.execute_sequence(p.set_box(3, [Limits("1", "2")] * 3, command_words=5))
        hs.execute_sequence(p.set_plane(3, ["1", "2", "3", "4"]))
    # 2 + 6 + 4 write commands, three writes
    assert (len(sim.writes_received()), sim.writes) == (12, 3)
    assert [r.continuation for r in sim.commands()] == [
        False,
        True,
        False,
        *[True] * 5,
        False,
        True,
        True,
        True,
    ]
    no_function_error(sim)


# --- split and Rn writes ------------------------------------------------------------------------


def test_a_split_write_takes_effect_only_at_its_second_half(sim: Simulator) -> None:
    st = sim.stations[1]
    free = min(set(range(16)) - set(st.accel_s))
    first, second = p.register_accel_s(free, AccelReal("7", "8"), command_words=4)
    with connected(sim) as (hs, _):
        assert hs.execute(first) is None
        assert free not in st.accel_s  # nothing yet
        assert hs.execute(second) is None
    assert st.accel_s[free] == (7000, 8000)
    no_function_error(sim)


def test_a_command_between_the_halves_cancels_a_split_write_silently(sim: Simulator) -> None:
    st = sim.stations[1]
    before = st.accel_s[4]
    first, second = p.register_accel_s(4, AccelReal("7", "8"), command_words=4)
    with connected(sim) as (hs, _):
        assert hs.execute(first) is None
        assert hs.execute(p.read_accel_s(4)) == AccelReal(rt(before[0]), rt(before[1]))
        assert error_code(hs.execute(second)) == 0x1002  # its first half is gone
        assert hs.execute(p.read_accel_s(4)) == AccelReal(rt(before[0]), rt(before[1]))
    assert st.accel_s[4] == before
    assert sim.writes == 0
    no_function_error(sim)


def test_an_rn_sequence_takes_effect_at_its_last_axis_and_a_read_between_cancels_it(
    sim: Simulator,
) -> None:
    st = sim.stations[1]
    boxes = dict(st.boxes)
    steps = list(p.set_plane(7, ["1", "2", "3", "4"]))
    with connected(sim) as (hs, _):
        for step in steps[:3]:
            assert hs.execute(step) is None
        assert 7 not in st.planes
        assert hs.execute(steps[3]) is None
        assert st.planes[7] == (1000, 2000, 3000, 4000)
        again = list(p.set_plane(7, ["9", "9", "9", "9"]))
        assert hs.execute(again[0]) is None
        assert hs.execute(p.read_plane(7, 0)) == "1.000"  # cancels the sequence
        assert error_code(hs.execute(again[1])) == 0x1002
        # out of order, as its own first step: refused too
        assert error_code(hs.execute(list(p.set_box(2, [Limits("1", "2")] * 3))[1])) == 0x1002
    assert st.planes[7] == (1000, 2000, 3000, 4000)
    assert st.boxes == boxes
    no_function_error(sim)


def test_a_split_box_write_goes_lower_xyz_then_upper_xyz(sim: Simulator) -> None:
    sequence = p.set_box(5, [Limits("1", "2"), Limits("3", "4"), Limits("5", "6")], command_words=5)
    assert [(r.number, r.command.params[1]) for r in sequence] == [
        (601, 0),
        (601, 1),
        (601, 2),
        (602, 0),
        (602, 1),
        (602, 2),
    ]
    with connected(sim) as (hs, _):
        assert hs.execute_sequence(sequence) is None
    assert sim.stations[1].boxes[5] == ((1000, 2000), (3000, 4000), (5000, 6000))
    no_function_error(sim)


# --- what a codec bug gets ----------------------------------------------------------------------


def test_wrongly_encoded_commands_get_the_controllers_errors_not_a_silent_write(
    sim: Simulator,
) -> None:
    st = sim.stations[1]
    before = st.copy()
    with connected(sim) as (_, link):
        remote = Remote(link)
        assert remote.command(151, 5, 0, 80, 50)[1][:3] == [151, 0x2004, 0]  # speed 0
        assert remote.command(1, 16, 1, 1)[1][:3] == [1, 0x2005, 0]  # table 16
        assert remote.command(59, 4, 1)[1][:3] == [59, 0x2004, 0]  # an unused word not 0
        assert remote.command(1204, 3, 0x0010, 0, 1)[1][:3] == [1204, 0x2004, 0]  # reserved bit
        assert remote.command(1204, 3, 4, 0, 1)[1][:3] == [1204, 0x2004, 0]  # no V on a SCARA
        assert remote.command(1214, min(st.points), 0x8001)[1][:3] == [1214, 0x2000, 0]
        assert remote.command(403, 7)[1][:3] == [403, 0x2004, 0]  # arch 7 is no entry
        assert remote.command(2154, 2)[1][:3] == [2154, 0x2004, 0]
        # a correct one, for contrast: the manual's example (§10.2, command 59)
        error, words = remote.command(59, 4)
        assert (error, words[:6]) == (False, [59, 4, 0x0001, 0x871B, 0x0003, 0x0D40])
    assert st == before
    assert sim.function_errors == []


def test_a_response_longer_than_the_maps_response_words_is_refused_2003() -> None:
    short = RegisterMap(response_words=5, command_words=8)
    sim = Simulator(robot(), register_map=short, execution_time=0.0)
    with connected(sim) as (hs, link):
        assert Remote(link, short).command(59, 4)[1][:3] == [59, 0x2003, 0]
        assert hs.execute(p.read_accel_s_accel(4)) == "100.123"  # 4 words: fits
    no_function_error(sim)


def test_a_moved_register_map_is_served_where_it_says() -> None:
    moved = map_from_dict(
        {
            "in_base": 100,
            "out_base": 200,
            "command_words": 6,
            "signals": {"Running": {"register": 300, "bit": 5}},
        }
    )
    sim = Simulator(robot(), register_map=moved, execution_time=0.0)
    with connected(sim) as (hs, _):
        assert hs.execute(p.read_accel(4)) == AccelPercent(90, 70)
        assert (
            hs.execute_sequence(p.register_accel_s(1, AccelReal("1", "2"), command_words=6)) is None
        )
        apply_command(sim, "run")
        assert hs.status().busy == ("Running",)
    assert sim.stations[1].accel_s[1] == (1000, 2000)
    no_function_error(sim)


# --- commands off the lists ---------------------------------------------------------------------


@pytest.mark.parametrize("number", [2000, 1450, 1150, 2052, 554, 0, 2, 4242])
def test_a_command_off_the_lists_is_refused_and_recorded(sim: Simulator, number: int) -> None:
    before = sim.stations[1].copy()
    with connected(sim) as (_, link):
        error, words = Remote(link).command(number, 1, 2)
    assert (error, words[:3]) == (True, [number, 0x1000, 0])
    [record] = sim.off_list()
    assert (record.number, record.is_write, record.known, record.code) == (
        number,
        True,
        False,
        0x1000,
    )
    assert sim.stations[1] == before
    assert sim.function_errors == []


def test_a_correct_client_never_sends_a_command_off_the_lists(
    client: Handshake, sim: Simulator
) -> None:
    client.execute(p.read_robot_type())
    client.execute_sequence(p.set_limz("1"))
    assert [r.number for r in sim.commands()] == [2153, 1250]  # off_list() checked on teardown


# --- the record --------------------------------------------------------------------------


def test_each_command_is_recorded_with_its_number_whether_a_write_and_whether_busy(
    sim: Simulator,
) -> None:
    with connected(sim) as (hs, link):
        hs.execute(p.read_accel(4))
        hs.execute_sequence(p.select_tool(2))
        apply_command(sim, "pause")
        Remote(link).command(500, 3)  # bypassing harlsync's interlock, on purpose
    read, write, busy = sim.commands()
    assert (read.number, read.command, read.is_write, read.busy, read.answered) == (
        3,
        "3",
        False,
        False,
        True,
    )
    assert read.payload == "0003 0004 0000 0000 0000 0000 0000 0000"
    assert (write.number, write.is_write, write.busy, write.code) == (500, True, False, 0)
    assert (busy.number, busy.is_write, busy.busy) == (500, True, True)
    assert sim.writes_while_busy() == [busy]
    # the manual names no interlock in the controller: it carried the write out
    assert sim.stations[1].tool == 3
    assert sim.function_errors == []


def test_the_later_steps_of_a_write_started_idle_are_not_writes_while_busy(sim: Simulator) -> None:
    first, second = p.register_accel_r(3, AccelReal("1", "2"), command_words=4)
    with connected(sim) as (hs, link):
        assert hs.execute(first) is None
        apply_command(sim, "run")  # the operator starts a task between the halves
        # the handshake sends the second half without a second look (the profile)
        error, words = Remote(link).command(*second.command.words)
        assert (error, words[:3]) == (False, [105, 0, 0])
    assert sim.commands()[1].busy and sim.commands()[1].continuation
    no_function_error(sim)


# --- status bits and control verbs -------------------------------------------------------------


@pytest.mark.parametrize(
    "verb, signals",
    [
        ("run", ("Running",)),
        ("pause", ("Paused",)),
        ("estop", ("EStopOn",)),
        ("error", ("Error",)),
    ],
)
def test_a_busy_robot_shows_its_signal_and_the_client_writes_nothing(
    client: Handshake, sim: Simulator, verb: str, signals: tuple[str, ...]
) -> None:
    assert client.status().busy == () and client.status()["Ready"]
    apply_command(sim, verb)
    status = client.status()
    assert status.busy == signals and not status["Ready"]
    with pytest.raises(InterlockError, match=signals[0]):
        client.execute_sequence(p.set_limz("5"))
    assert client.execute(p.read_limz()) == "-12.345"  # reads go on
    apply_command(sim, "stop")
    assert client.status().idle
    client.execute_sequence(p.set_limz("5"))
    assert sim.stations[1].limz == 5000


def test_an_open_safeguard_pauses_a_running_task(client: Handshake, sim: Simulator) -> None:
    apply_command(sim, "run")
    apply_command(sim, "safeguard")
    status = client.status()
    assert (status["SafeguardOn"], status["Running"], status["Paused"]) == (True, False, True)
    assert "Paused" in apply_command(sim, "status")


def test_the_robot_starts_a_task_after_n_writes(client: Handshake, sim: Simulator) -> None:
    assert apply_command(sim, "run-after-writes 2") == "run after 2 more writes"
    client.execute_sequence(p.select_tool(1))
    client.execute_sequence(p.register_accel_s(2, AccelReal("1", "2"), command_words=4))
    with pytest.raises(InterlockError, match="Running 1"):
        client.execute_sequence(p.select_tool(3))
    assert (sim.writes, sim.stations[1].tool) == (2, 1)


# --- the §6.5 function error, only when driven wrongly -------------------------------------------


def test_a_second_request_while_a_command_runs_halts_the_function() -> None:
    clock = ManualClock()
    sim = Simulator(robot(), execution_time=1.0, clock=clock)
    with connected(sim) as (hs, link):
        remote = Remote(link)
        remote.request(59, 4)
        remote.drive(ExtCmdSet=False)
        remote.words(3, 4)
        remote.drive(ExtCmdSet=True)  # while 59 still runs: the phases no longer match
        response = remote.wait("ExtError", True)
        assert response[:3] == [59, 0x9999, 0x0001]
        levels, _ = remote.outputs()
        assert not (levels["ExtCmdGet"] or levels["ExtRespSet"])
        clock.advance(5)  # 59 was aborted: it never answers
        assert not remote.outputs()[0]["ExtRespSet"]
        with pytest.raises(FunctionError) as caught:  # a correct client finds it halted
            hs.execute(p.read_tool())
        assert (caught.value.code, caught.value.detail) == (0x9999, 0x0001)
    [fault] = sim.function_errors
    assert (fault.detail, fault.number) == (0x0001, 59)
    aborted, offending = sim.commands()
    assert (aborted.number, aborted.answered, offending.number, offending.answered) == (
        59,
        False,
        3,
        False,
    )


def test_a_request_before_the_last_response_is_released_halts_the_function(sim: Simulator) -> None:
    with connected(sim) as (_, link):
        remote = Remote(link)
        remote.request(501)
        remote.drive(ExtCmdSet=False)
        remote.wait("ExtRespSet", True)
        remote.drive(ExtCmdSet=True)  # never raised ExtRespGet for 501
        assert remote.wait("ExtError", True)[:3] == [501, 0x9999, 0x0001]
    assert [(r.number, r.answered) for r in sim.commands()] == [(501, True), (501, False)]


def test_a_request_while_the_reset_is_low_is_ignored_and_is_no_function_error(
    sim: Simulator,
) -> None:
    with connected(sim) as (_, link):
        remote = Remote(link)
        remote.words(501)
        remote.drive(ExtCmdSet=True)  # ExtCmdReset is still 0
        remote.drive(ExtCmdReset=True)  # raised under a high ExtCmdSet: no request either
        levels, _ = remote.outputs()
        assert not (levels["ExtCmdGet"] or levels["ExtError"])
        assert sim.commands() == []
        remote.drive(ExtCmdSet=False)
        remote.drive(ExtCmdSet=True)  # a Low -> High edge with the reset high: taken
        remote.wait("ExtCmdGet", True)
        assert remote.collect()[1][:2] == [501, sim.stations[1].tool]
    assert [e.kind for e in sim.remote().events] == ["ignored"]
    assert [(r.number, r.answered) for r in sim.commands()] == [(501, True)]
    assert sim.function_errors == []


def test_issue_24_a_request_over_words_not_all_written_is_flagged_and_taken_as_is() -> None:
    # a slave that hands a write over a register at a time, and a client that
    # writes ExtCmdSet's register and the words after it in one: ExtCmdSet rises first
    sim = Simulator(robot(), execution_time=0.0, whole_writes=False)
    with connected(sim) as (_, link):
        careless = Handshake(link, sim.register_map, block_write_whole=True)
        with pytest.raises(ReplyError, match="response word 0 is 0000H"):
            careless.execute(p.read_tool())  # the controller took words 0: command 0
        assert len(sim.stale_requests) == 1
        assert "words 0, 1, 2, 3, 4, 5, 6, 7 not written" in sim.stale_requests[0]
        # the handshake without the profile's assumption writes the words first
        fresh = Handshake(link, sim.register_map, block_write_whole=False)
        before = sim.accesses()["write"]
        assert fresh.execute(p.read_tool()) == sim.stations[1].tool
        assert sim.accesses()["write"] - before == 5
    # what the stale request was: command 0, Accel set, a write off the lists
    assert len(sim.stale_requests) == 1
    assert [(r.number, r.is_write) for r in sim.off_list()] == [(0, True)]


def test_issue_24_the_handshake_writes_words_and_extcmdset_in_one_request(
    sim: Simulator,
) -> None:
    # a site whose slave hands a write over whole (profile.BLOCK_WRITE_WHOLE True)
    with connected(sim) as (_, link):
        client = Handshake(link, sim.register_map, block_write_whole=True)
        trips(client, sim)
    no_function_error(sim)


def trips(client: Handshake, sim: Simulator) -> None:
    client.execute(p.read_tool())
    before = sim.accesses()
    assert client.execute(p.read_arch(3)) is not None
    after = sim.accesses()
    # read back, step 1, the words with ExtCmdSet, 3 polls, 3 writes of signals
    assert {k: after[k] - before[k] for k in after} == {
        "read_holding": 1,
        "read_input": 4,
        "write": 4,
    }


def test_only_a_function_reset_of_30_ms_clears_the_function_error() -> None:
    clock = ManualClock()
    sim = Simulator(robot(), execution_time=0.0, clock=clock)
    with connected(sim) as (_, link):
        remote = Remote(link)
        remote.drive(ExtCmdReset=True)
        apply_command(sim, "function-error 1 0001")
        assert remote.outputs()[0]["ExtError"]
        remote.drive(ExtCmdReset=False, ExtCmdSet=False, ExtRespGet=False)
        clock.advance(0.010)
        remote.drive(ExtCmdReset=True)
        assert remote.outputs()[0]["ExtError"]  # 10 ms: not a reset (§6.5.2)
        remote.drive(ExtCmdReset=False)
        clock.advance(0.031)
        remote.drive(ExtCmdReset=True)
        assert not remote.outputs()[0]["ExtError"]
        assert remote.command(501)[1][:2] == [501, sim.stations[1].tool]
    assert [e.kind for e in sim.remote().events] == ["short reset"]


def test_the_handshakes_function_reset_clears_a_function_error_the_client_caused(
    sim: Simulator,
) -> None:
    with connected(sim) as (hs, _):
        hs.start()
        apply_command(sim, "function-error 1 0001")
        with pytest.raises(FunctionError):
            hs.execute(p.read_tool())
        hs.reset_function()
        assert hs.execute(p.read_tool()) == sim.stations[1].tool
    assert len(sim.function_errors) == 1


def test_a_function_error_of_the_controller_needs_a_controller_reset(sim: Simulator) -> None:
    with connected(sim, deadline=0.3) as (hs, _):
        hs.start()
        apply_command(sim, "function-error")  # 9901 by default
        with pytest.raises(FunctionError) as caught:
            hs.execute(p.read_tool())
        assert caught.value.detail == 0x9901
        with pytest.raises(HandshakeTimeout, match="not ready"):
            hs.reset_function()  # a function reset does not clear it
        sim.power_cycle()
        fresh = Handshake(hs.registers, sim.register_map)  # as a new harlsync run
        assert fresh.execute(p.read_tool()) == sim.stations[1].tool
    assert [e.kind for e in sim.remote().events] == ["still halted"]
    assert [f.detail for f in sim.function_errors] == [0x9901]


def test_a_correct_client_never_halts_the_function_over_many_commands(
    client: Handshake, sim: Simulator
) -> None:
    for i in range(40):
        client.execute(p.read_accel(i % 16))
        client.execute_sequence(p.set_plane(1 + i % 15, [str(i), "0", "0", "0"]))
    assert len(sim.commands()) == 40 * 5  # and no function error: checked on teardown


# --- power cycle ------------------------------------------------------------------------------


def test_a_power_cycle_clears_the_tables_and_limz_and_keeps_the_rest(sim: Simulator) -> None:
    st = sim.stations[1]
    before = st.copy()
    with connected(sim) as (hs, link):
        hs.execute_sequence(p.set_weight("3.25", "50"))
        assert hs.execute(p.read_accel(4)) == AccelPercent(90, 70)
        apply_command(sim, "run")
        apply_command(sim, "power-cycle")
        # the controller's inputs are 0 again: a new harlsync run starts the function
        fresh = Handshake(link, sim.register_map)
        assert error_code(fresh.execute(p.read_accel(4))) == 0x2006
        assert error_code(fresh.execute(p.read_accel_s(4))) == 0x2006
        assert fresh.execute(p.read_limz()) == "0.000"
        assert fresh.execute(p.read_weight()) == Weight("3.250", "50.000")
        assert fresh.status().idle
    assert (st.accel, st.accel_s, st.accel_r, st.speed, st.speed_s, st.speed_r) == (
        {},
        {},
        {},
        {},
        {},
        {},
    )
    assert st == replace(
        before,
        accel={},
        accel_s={},
        accel_r={},
        speed={},
        speed_s={},
        speed_r={},
        limz=0,
        weight=(3250, 50_000),
    )
    assert sim.function_errors == []


def test_the_state_directory_keeps_what_a_power_cycle_keeps(tmp_path: Path) -> None:
    sim = Simulator(robot(), execution_time=0.0)
    keep_state(sim, tmp_path)
    with connected(sim) as (hs, _):
        hs.execute_sequence(p.select_tool(9))
        hs.execute_sequence(p.register_speed(3, SpeedPercent(1, 2, 3)))
    memory = json.loads((tmp_path / "station-1" / "memory.json").read_text())
    assert memory["tool"] == 9 and "speed" not in memory
    restarted = Simulator(SimState.generate(99), execution_time=0.0)
    keep_state(restarted, tmp_path)
    st = restarted.stations[1]
    assert (st.tool, st.speed, st.limz, st.points) == (9, {}, 0, sim.stations[1].points)
    no_function_error(sim)


# --- faults ---------------------------------------------------------------------------------------


def test_a_slow_command_times_out_at_the_response_and_its_late_answer_is_taken_after() -> None:
    clock = ManualClock()
    sim = Simulator(robot(), execution_time=0.0, clock=clock)
    sim.faults.slow, sim.faults.slow_delay = 1.0, 3.0
    with connected(sim, deadline=0.3) as (hs, _):
        with pytest.raises(HandshakeTimeout) as caught:
            hs.execute(p.read_tool())
        assert (caught.value.step, caught.value.acquired) == (Step.RESPONSE_SET, True)
        sim.faults.slow = 0.0
        clock.advance(3.0)  # the slow command completes; the next one collects its answer
        assert hs.execute(p.read_robot_type()) == SCARA
    assert [(r.number, r.answered) for r in sim.commands()] == [(501, True), (2153, True)]
    assert sim.function_errors == []


def test_a_dropped_modbus_reply_is_sent_again_by_the_link(sim: Simulator) -> None:
    with connected(sim, timeout=0.2) as (hs, _):
        assert sim.server is not None
        sim.drop_replies(1)
        assert hs.execute(p.read_accel(4)) == AccelPercent(90, 70)
        assert sim.server.dropped == 1
    no_function_error(sim)


def test_issue_34_a_command_whose_extcmdset_reply_was_lost_is_waited_for_before_letting_go() -> (
    None
):
    """Issue 34 item 0: the link no longer sends a write again, so a lost reply to
    the write that raised ExtCmdSet reaches the handshake, which does not know
    whether the controller took the command.  It looks (ExtCmdGet) before dropping
    ExtCmdSet, and waits out the command's own deadline and one more before the
    line is let go: the next client's first request then finds the function idle,
    not a command still running (which a request would halt, §6.5.1)."""
    clock = ManualClock()
    sim = Simulator(robot(), execution_time=0.45, clock=clock)
    remote = sim.remote()
    real = remote.write_holding
    lost: list[int] = []

    def write_holding(address: int, values: list[int]) -> None:
        real(address, values)
        if not lost and address == 0 and values[0] & 1:  # ExtCmdSet raised: reply lost
            lost.append(values[0])
            sim.drop_replies(1)

    remote.write_holding = write_holding  # type: ignore[method-assign]
    with sim.serve() as server:
        with ModbusLink(server.url, timeout=0.2, retries=2) as link:
            hs = Handshake(link, sim.register_map, deadline=0.3, clock=clock)
            with pytest.raises(LinkTimeout):
                hs.execute(p.read_tool())
            hs.finish()  # what closing the line does
        assert lost
        with ModbusLink(server.url, timeout=0.2) as link:  # the next harlsync
            assert (
                Handshake(link, sim.register_map, clock=clock).execute(p.read_robot_type()) == SCARA
            )
    assert [(r.number, r.answered) for r in sim.commands()] == [(501, True), (2153, True)]
    no_function_error(sim)


def test_a_server_that_stops_answering_is_a_link_timeout(sim: Simulator) -> None:
    with connected(sim, timeout=0.1, retries=1) as (hs, _):
        sim.faults.drop = 1.0
        with pytest.raises(LinkTimeout):
            hs.execute(p.read_accel(4))
        sim.faults.drop = 0.0
        hs.start()  # the inputs may or may not have been written: read them again
        assert hs.execute(p.read_accel(4)) == AccelPercent(90, 70)
    assert sim.function_errors == []


def test_faults_of_a_serial_line_are_refused(sim: Simulator) -> None:
    sim.faults.noise = 0.1
    with pytest.raises(ValueError, match="noise"):
        sim.serve()


# --- the robot ------------------------------------------------------------------------------------


def test_generated_robots_are_scara_or_six_axis_and_repeat_by_seed() -> None:
    kinds = {SimState.generate(seed).robot_type for seed in range(20)}
    assert kinds == {SCARA, SIX_AXIS}
    assert SimState.generate(7) == SimState.generate(7)
    six = SimState.generate(7, robot_type=SIX_AXIS)
    assert six.axes == 6 and all(len(pt.coords) == 6 for pt in six.points.values())
    assert max(six.points) > 99  # beyond the P0-P99 a project backs up by default


def test_a_state_the_controller_could_not_hold_is_refused_naming_each_problem() -> None:
    with pytest.raises(ValueError) as caught:
        SimState(
            accel={16: (1, 1)}, speed={1: (0, 50, 50)}, points={3: Point((1, 2, 3))}, fine=(1, 2)
        )
    text = str(caught.value)
    for problem in ("accel table 16", "speed table 1", "point 3: 3 coordinates", "fine"):
        assert problem in text


def test_the_epson_simulator_is_served_not_a_serial_line() -> None:
    family = sim_family("epson")
    assert isinstance(family, ServedFamily)
    assert family.busy_verb == "run" and family.default_station == 1


def test_harlsync_sim_serves_an_epson_controller_over_modbus_tcp() -> None:
    with harlsync_sim("--family", "epson", "--listen", "127.0.0.1:0", "--seed", "5", lines=2) as (
        proc,
        lines,
    ):
        assert lines["tcp"].startswith("modbus://127.0.0.1:")
        assert lines["stations"] == "1"
        with ModbusLink(lines["tcp"]) as link:
            hs = Handshake(link)
            assert hs.execute(p.read_robot_type()) == SimState.generate(5).robot_type
            assert proc.stdin is not None and proc.stdout is not None
            proc.stdin.write("run\n")
            proc.stdin.flush()
            assert proc.stdout.readline().strip() == (
                "station 1: Running, function idle; 0 writes received"
            )
            assert hs.status().busy == ("Running",)


def test_harlsync_sim_epson_needs_listen() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "harlsync", "sim", "--family", "epson"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    assert "--listen HOST:PORT" in done.stderr


def test_a_sim_port_refuses_the_epson_simulator_it_is_no_serial_line() -> None:
    with pytest.raises(SerialException, match="not a serial line"):
        simulator_from_url("sim://?family=epson")


def test_after_a_power_cycle_the_same_handshake_starts_the_function_again(sim: Simulator) -> None:
    """Regression: the handshake kept its inputs as it last wrote them, and after a
    power cycle (every register 0 again) its next write raised ExtCmdSet together
    with ExtCmdReset, which the controller ignores: a timeout at step 4.  It now
    reads them back before each command's step 1 and starts the function again."""
    with connected(sim, deadline=0.5) as (hs, _):
        assert hs.execute(p.read_accel(4)) == AccelPercent(90, 70)
        apply_command(sim, "power-cycle")
        assert sim.remote().read_holding(RegisterMap().ext_cmd_reset.register, 1) == [0]
        assert error_code(hs.execute(p.read_accel(4))) == 0x2006  # no timeout
        hs.execute_sequence(p.register_accel(4, 90, 70))  # a write too
        assert hs.execute(p.read_accel(4)) == AccelPercent(90, 70)
        apply_command(sim, "power-cycle")
        hs.execute_sequence(p.set_weight("3.25", "50"))
        assert hs.execute(p.read_weight()) == Weight("3.250", "50.000")
    no_function_error(sim)


def test_a_command_left_running_at_a_timeout_is_answered_before_the_line_is_let_go() -> None:
    """Regression (found by the interlock property test): a command that ran past the
    deadline was left running when the run ended; the controller's outputs then look
    idle (ExtCmdGet falls with ExtCmdSet), so the next run's first request halted the
    function (§6.5.1).  Closing now waits for it once more and takes its response."""
    sim = Simulator(robot(), execution_time=0.3)
    with connected(sim, deadline=0.2) as (hs, link):
        with pytest.raises(HandshakeTimeout) as caught:
            hs.execute(p.read_tool())
        assert caught.value.step == Step.RESPONSE_SET
        hs.finish()  # what Controller.close does before letting go
        assert hs.pending is None
        sim.execution_time = 0.0
        fresh = Handshake(link, sim.register_map)  # as the next harlsync run
        assert fresh.execute(p.read_tool()) == sim.stations[1].tool
    no_function_error(sim)


class LoseOneReply:
    """A line whose reply to the next write raising ExtCmdSet is lost (the write
    takes effect: the controller takes the command)."""

    def __init__(self, link: ModbusLink, register_map: RegisterMap) -> None:
        self.link, self.map, self.label = link, register_map, link.label
        self.armed = False

    def read_holding(self, address: int, count: int) -> list[int]:
        return self.link.read_holding(address, count)

    def read_input(self, address: int, count: int) -> list[int]:
        return self.link.read_input(address, count)

    def write_holding(self, address: int, values: Sequence[int]) -> None:
        self.link.write_holding(address, values)
        bit = self.map.ext_cmd_set
        if self.armed and address == bit.register and values[0] >> bit.bit & 1:
            self.armed = False
            raise LinkTimeout("write: no answer", port=self.label)


def test_a_command_taken_when_its_reply_was_lost_is_waited_for_not_sent_over() -> None:
    """Regression (found by the interlock property test, seed 900837): the reply to
    the write raising ExtCmdSet was lost, so the handshake never saw ExtCmdGet; once
    ExtCmdSet fell, the command running looked like one never taken (ExtCmdGet 0,
    ExtRespSet 0) and was dropped at once, and the next request halted the function
    (§6.5.1).  Now only a deadline without an answer drops it."""
    sim = Simulator(robot(), execution_time=0.0)
    with connected(sim, deadline=1.0) as (_, link):
        line = LoseOneReply(link, sim.register_map)
        hs = Handshake(line, sim.register_map, deadline=1.0)
        assert hs.execute(p.read_tool()) == sim.stations[1].tool
        sim.execution_time = 0.3
        line.armed = True
        with pytest.raises(LinkTimeout):
            hs.execute(p.read_limz())
        sim.execution_time = 0.0
        assert hs.execute(p.read_tool()) == sim.stations[1].tool  # after 1251's answer
    no_function_error(sim)
    assert [c.number for c in sim.commands()] == [501, 1251, 501]
