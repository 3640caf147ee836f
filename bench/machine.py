"""What the bench scripts share: the machine they ran on, the robots they read,
and a simulator served from a process of its own."""

from __future__ import annotations

import argparse
import json
import os
import platform
import random
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from datetime import datetime
from pathlib import Path
from typing import Any

from harlsync.families.harl_u2.model import Config, ProgramArea, Step
from harlsync.families.harl_u2.sim import DEFAULT_CONFIG, SimState
from harlsync.families.iai.model import Position
from harlsync.families.iai.sim import SimState as IaiState
from harlsync.project.robot import Robot

BENCH = Path(__file__).resolve().parent
BITS_PER_BYTE = 10  # 8N1: start bit, 8 data bits, stop bit


def describe() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as info:
            cpu = next(
                line.split(":", 1)[1].strip() for line in info if line.startswith("model name")
            )
    except (OSError, StopIteration):
        pass
    load = ""
    if hasattr(os, "getloadavg"):
        one, five, fifteen = os.getloadavg()
        load = f" load {one:.1f} {five:.1f} {fifteen:.1f},"
    return (
        f"{datetime.now():%Y-%m-%d %H:%M}, {platform.system()} {platform.release()}, "
        f"{os.cpu_count()} cores ({cpu}),{load} Python {platform.python_version()}"
    )


def peak_rss_mib() -> float:
    """This process's peak resident set size so far, in MiB (Linux reports KiB)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / (1024 * 1024 if platform.system() == "Darwin" else 1024)


def minutes(seconds: float) -> str:
    return f"{seconds / 60:.1f} min" if seconds >= 60 else f"{seconds:.1f} s"


# --- robots ------------------------------------------------------------------------------

#: The manual's default ranges at their largest: programs 0-15, steps 0-255,
#: timers 0-15, memory bits 256-383, registers 0-63.
MAX_CONFIG = Config(
    start=ProgramArea(1, 256),
    main=ProgramArea(16, 256),
    sub=ProgramArea(16, 256),
    hand=ProgramArea(16, 256),
    timers=16,
    memory_bits=128,
    registers=64,
)


def every_step_used(config: Config = MAX_CONFIG) -> SimState:
    """A robot with every step holding a command (a generated robot uses about one
    step in twenty, and an empty step's reply is shorter): the worst case on the wire."""
    state = SimState.generate(1, config)
    for ptype, number in config.programs():
        steps = config.area(ptype).steps
        program = {
            n: Step("MOVE", (f"P{(n * 37 + number) % 1000:03d}", "S100")) for n in range(steps)
        }
        program[steps - 1] = Step("END")
        state.data.programs[(ptype, number)] = program
    return state


#: A few hundred exchanges: for trying the scripts out.
SMALL_CONFIG = Config(
    start=ProgramArea(1, 32),
    main=ProgramArea(2, 32),
    sub=ProgramArea(2, 16),
    hand=ProgramArea(1, 16),
    timers=16,
    memory_bits=128,
    registers=64,
)

#: About 500 exchanges (535): issue 15's mid-size robot, its programs as generated.
MEDIUM_CONFIG = Config(
    start=ProgramArea(1, 32),
    main=ProgramArea(3, 64),
    sub=ProgramArea(4, 32),
    hand=ProgramArea(4, 16),
    timers=16,
    memory_bits=128,
    registers=64,
)

ROBOTS: dict[str, Callable[[], SimState]] = {
    "default": lambda: SimState.generate(1, DEFAULT_CONFIG),
    "medium": lambda: SimState.generate(1, MEDIUM_CONFIG),
    "maximum": lambda: SimState.generate(1, MAX_CONFIG),
    "max-full": every_step_used,
    # Every step used, smaller configurations: quick stand-ins for max-full.
    "default-full": lambda: every_step_used(DEFAULT_CONFIG),
    "small-full": lambda: every_step_used(SMALL_CONFIG),
}


# --- IAI robots --------------------------------------------------------------------------

#: Position numbers an IAI bench table defines: all of the default range 1-1000.
IAI_POSITIONS = 1000


def _iai_coord(rng: random.Random, low: int, high: int) -> str:
    units = rng.randint(low, high)  # 0.001 mm (or deg)
    sign = "-" if units < 0 else ""
    return f"{sign}{abs(units) // 1000}.{abs(units) % 1000:03d}"


def _iai_g(rng: random.Random) -> str:
    hundredths = 0 if rng.random() < 0.2 else rng.randint(10, 100)
    return f"{hundredths // 100}.{hundredths % 100:02d}"


def iai_table(axes: int, model: str = "TTA", seed: int = 1) -> IaiState:
    """An IAI controller with every position of 1-1000 defined (the largest table a
    default range holds: the most 22DH records a pull reads).

    ``axes=4``: the realistic mix, a 4-axis robot (X, Y, Z, R) whose positions use 3
    axes (X, Y, Z: 44-byte records) or all 4 with the SCARA arm system set (52 bytes),
    about half each.  ``axes=8``: every position on 8 axes, 84-byte records, the worst
    case the 22DH queries are sized for.  ``model`` sets the buffers (TTA 2048-byte
    send buffer, TT 1024).
    """
    rng = random.Random(seed)
    robot_axes = tuple(range(1, axes + 1))
    positions = []
    for number in range(1, IAI_POSITIONS + 1):
        used = robot_axes if axes != 4 or rng.random() < 0.5 else robot_axes[:3]
        coords = tuple(
            _iai_coord(rng, -180_000, 180_000)
            if axes == 4 and a == 4
            else _iai_coord(rng, -300_000, 600_000)
            for a in used
        )
        speed = 0 if rng.random() < 0.2 else rng.choice((50, 100, 200, 300, 500, 800, 1000))
        arm1 = rng.choice((1, 2)) if len(used) == 4 else 0
        positions.append(Position(number, used, _iai_g(rng), _iai_g(rng), speed, coords, arm1))
    return IaiState.from_positions(positions, axes=robot_axes, model=model)


IAI_ROBOTS: dict[str, Callable[[], IaiState]] = {
    "iai-mix": lambda: iai_table(4),
    "iai-8axis": lambda: iai_table(8),
    "iai-mix-tt": lambda: iai_table(4, "TT"),
    "iai-8axis-tt": lambda: iai_table(8, "TT"),
}


# --- a simulator in its own process -----------------------------------------------------


class SimProcess:
    """``bench/simserver.py`` in a child process: ``lines`` simulated robots, each on
    its own pty (or TCP port), so that the client under test and the simulator do
    not share a GIL.  ``robot`` names a HARL-U2 robot of :data:`ROBOTS` or an IAI
    one of :data:`IAI_ROBOTS`.  ``ports`` are what the client opens; :meth:`stats`
    is what each line's simulator counted so far, :meth:`reset` zeroes it.
    """

    def __init__(
        self,
        robot: str,
        *,
        baud: int = 0,
        lines: int = 1,
        tcp: bool = False,
        tick: float = 0.0,
        loop: bool = False,
    ) -> None:
        command = [
            sys.executable,
            str(BENCH / "simserver.py"),
            robot,
            "--baud",
            str(baud),
            "--lines",
            str(lines),
        ]
        if tcp:
            command.append("--tcp")
        if loop:
            command.append("--loop")
        if tick:
            command += ["--tick", str(tick)]
        self._proc = subprocess.Popen(
            command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
        )
        self.ports: list[str] = self._answer()["ports"]

    def _answer(self) -> Any:
        assert self._proc.stdout is not None
        line = self._proc.stdout.readline()
        if not line:
            raise RuntimeError(f"simserver exited with {self._proc.wait()}")
        return json.loads(line)

    def _ask(self, command: str) -> Any:
        assert self._proc.stdin is not None
        self._proc.stdin.write(command + "\n")
        return self._answer()

    def stats(self) -> list[dict[str, int]]:
        """Per line: ``exchanges``, ``bytes_in``, ``bytes_out``, ``letters`` (request counts),
        ``first_in`` and ``last_due`` (``time.monotonic``: the first request byte read,
        the last reply byte due), ``gaps`` (seconds from each reply's last byte due to
        the next request's first byte read, in all), and on a pty
        ``late_mean``/``late_worst``."""
        result: list[dict[str, int]] = self._ask("stats")
        return result

    def reset(self) -> None:
        self._ask("reset")

    def record(self, keep: bool = True) -> None:
        """From now on the simulator keeps every byte each way (:meth:`wire`); with
        ``keep`` false, no longer."""
        self._ask("record" if keep else "unrecord")

    def wire(self) -> list[tuple[bytes, bytes]]:
        """Per line: the bytes the client sent and the reply bytes, in order, since the
        last :meth:`reset` (kept once :meth:`record` was asked)."""
        return [
            (bytes.fromhex(line["in"]), bytes.fromhex(line["out"])) for line in self._ask("wire")
        ]

    def close(self) -> None:
        if self._proc.stdin:
            self._proc.stdin.close()
        try:
            self._proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()

    def __enter__(self) -> SimProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def case_options(parser: argparse.ArgumentParser, robots: list[str], quick: str) -> None:
    """``--quick``, ``--robot`` and ``--baud`` of a bench that pulls ``robots`` at
    19200 and 115200 baud (``--quick``: ``quick`` at 115200); read by :func:`cases`."""
    parser.add_argument("--quick", action="store_true", help=f"{quick} at 115200 only")
    parser.add_argument(
        "--robot",
        action="append",
        choices=sorted(ROBOTS | IAI_ROBOTS),
        help=f"default: {' and '.join(robots)} (repeat the option for several)",
    )
    parser.add_argument("--baud", help="comma-separated (default 19200,115200)")


def cases(args: argparse.Namespace, robots: list[str], quick: str) -> tuple[list[str], list[int]]:
    """The robots and baud rates :func:`case_options` asked for."""
    chosen = args.robot or ([quick] if args.quick else robots)
    bauds = args.baud or ("115200" if args.quick else "19200,115200")
    return chosen, [int(b) for b in bauds.split(",")]


def timed_pull(port: str, into: Path) -> tuple[float, float]:
    """``harlsync.sync.engine.pull`` of ``port`` into a new directory ``into``:
    (seconds until the last item was read, seconds for the whole pull)."""
    from harlsync.sync.engine import pull

    os.environ.setdefault("HARLSYNC_LOCK_DIR", str(into.parent / "locks"))
    read_done = 0.0

    def progress(done: int, total: int) -> None:
        nonlocal read_done
        read_done = time.perf_counter()

    start = time.perf_counter()
    pull(into, port=port, progress=progress)
    return read_done - start, time.perf_counter() - start


def harlsync_command() -> list[str]:
    """The ``harlsync`` script of this interpreter's environment (``-m`` without one)."""
    script = Path(sys.executable).with_name("harlsync")
    return [str(script)] if script.exists() else [sys.executable, "-m", "harlsync"]


#: Where the harlsync processes the benches start keep their compiled bytecode.
PYCACHE = Path(tempfile.gettempdir()) / "harlsync-bench-pycache"


def process_env(locks: Path, **more: str) -> dict[str, str]:
    """The environment of a harlsync process a bench starts: its own lock directory
    and audit log, and bytecode cached as after ``pip install`` (a shell that sets
    PYTHONDONTWRITEBYTECODE makes every process compile harlsync's 90 modules
    again, about 0.1 s of start-up no installed harlsync pays; the cache goes to
    :data:`PYCACHE`, not into the worktree)."""
    env = dict(
        os.environ,
        HARLSYNC_LOCK_DIR=str(locks),
        HARLSYNC_AUDIT_LOG=str(locks / "audit.jsonl"),
        PYTHONPYCACHEPREFIX=str(PYCACHE),
        **more,
    )
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def bench_robot(robot: str, port: str, baud: int) -> Robot:
    """The robot of :data:`ROBOTS` or :data:`IAI_ROBOTS` called ``robot`` on ``port`` at
    ``baud``, as a site writes its robot.yaml (IAI: station 99, the table's model)."""
    from harlsync import families
    from harlsync.settings import SerialSettings

    iai = robot in IAI_ROBOTS
    options: dict[str, Any] = {"serial": SerialSettings(baudrate=baud, timeout=0.5 if iai else 1.0)}
    if iai:
        model = "TT" if robot.endswith("-tt") else "TTA"
        options["options"] = {"model": model, "first": 1, "last": IAI_POSITIONS}
    return families.get("iai" if iai else "harl-u2").new_robot(
        "bench", port, 0x99 if iai else 1, **options
    )


def timed_process(
    sim: SimProcess, baud: int, command: list[str], env: dict[str, str]
) -> dict[str, Any]:
    """``command`` (a harlsync pull) run to its end against ``sim``'s line, timed on the
    clock every process shares: ``startup`` (to the first request byte the simulator
    read), ``read`` (to the last reply byte due on the line), ``save`` (to the exit),
    ``whole``; ``limit`` (bytes both ways x 10 / baud), ``cpu`` (the process's user +
    system time), ``sim_cpu`` (the simulator process's, over the same time), and what
    the simulator counted.  Exits the bench if the pull fails."""
    sim.reset()
    sim_before = sim.stats()[0]["cpu"]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.monotonic()
    done = subprocess.run(command, capture_output=True, text=True, env=env, check=False)
    end = time.monotonic()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode:
        sys.exit(f"{' '.join(command)} exited {done.returncode}:\n{done.stderr}")
    counted = sim.stats()[0]
    nbytes = counted["bytes_in"] + counted["bytes_out"]
    return {
        "exchanges": counted["exchanges"],
        "letters": counted["letters"],
        "bytes": nbytes,
        "limit": nbytes * BITS_PER_BYTE / baud,
        "startup": counted["first_in"] - start,
        "read": counted["last_due"] - counted["first_in"],
        "save": end - counted["last_due"],
        "whole": end - start,
        "cpu": after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime,
        "sim_cpu": counted["cpu"] - sim_before,
        "gaps": counted["gaps"],
        "late_mean": counted.get("late_mean", 0.0),
        "late_worst": counted.get("late_worst", 0.0),
        "output": done.stdout + done.stderr,
    }


def run_child(command: list[str], what: str) -> dict[str, Any]:
    """Run a bench case in a fresh interpreter (so its peak RSS is its own); its JSON."""
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode:
        sys.exit(f"{what} failed:\n{done.stderr}")
    result: dict[str, Any] = json.loads(done.stdout)
    return result


def instructions(command: list[str], env: dict[str, str], who: str) -> int:
    """The instructions ``command`` runs, counted by valgrind's callgrind (the same
    for the same binary and inputs, whatever the machine's load); ``who`` names the
    bench in its one-line failure."""
    done = subprocess.run(
        ["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", *command],
        capture_output=True,
        text=True,
        env=env,
        check=False,
    )
    refs = [line for line in done.stderr.splitlines() if "Collected" in line]
    if done.returncode or not refs:
        sys.exit(f"{who}: valgrind counted nothing:\n{done.stderr[-2000:]}")
    return int(refs[-1].rsplit(":", 1)[1].replace(",", "").strip())
