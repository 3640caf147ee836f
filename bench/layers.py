"""Where a harlsync exchange spends its CPU, by layer: one fleet run profiled.

    python bench/layers.py                   32 small-full robots at 19200 baud: ~30 s
    python bench/layers.py --robots 8 --robot default-full --baud 115200
    python bench/layers.py --top 30          and the 30 functions that cost most

A simulator process (bench/simserver.py, one event loop) serves every robot on a pty
of its own with wire-time emulation, as bench/fleet.py does; then one fleet backup
(``backup(..., workers=1)``: every line a thread of this process, which is what a
worker process runs) is profiled, each thread with a ``cProfile.Profile`` of its own
on its own CPU clock (``time.thread_time``): time a thread spends blocked (waiting
for bytes) is not counted, so the figures are CPU.

Each function's own time goes to the layer of the module that defines it; the
time of a built-in (``os.read``, ``poll``, ``time.monotonic``) and of a library
function outside these layers goes to its callers' layers, in the shares cProfile
recorded per caller.  The layers:

- link: harlsync/link/, a family's link glue, pyserial;
- codec: a family's frames and commands (harl_u2/protocol, iai/codec);
- driver: a family's driver and controller (what asks for the next item);
- catalogue: a family's catalogue (the items and their order);
- progress: the progress callbacks (robotbackup, fleettask, the watch);
- logging: the logging package and harlsync.robotlog;
- threads: threading, queue, concurrent.futures (the fleet's pool, locks, events);
- project and save: harlsync/project/, PyYAML, the schema; git and the backup:
  the rest of harlsync/sync/ and subprocess: fixed per robot, not per exchange.

cProfile adds its own cost to every call it sees (a deterministic profiler), more
to layers of many small calls: the split is the profile's, the absolute CPU an
exchange is bench/fleet.py's.  The profiled run's total, over the exchanges, is
printed beside it for scale.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import tempfile
import threading
import time
from collections import defaultdict
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from machine import ROBOTS, SimProcess, describe

from harlsync.project import Project, new_robot, save_project
from harlsync.settings import SerialSettings
from harlsync.sync.backup import backup

Func = tuple[str, int, str]

#: (a piece of the path, the layer), the first that matches wins.
LAYERS: list[tuple[str, str]] = [
    ("/harlsync/link/", "link"),
    ("/harlsync/families/harl_u2/link.py", "link"),
    ("/serial/", "link"),
    ("/harlsync/families/harl_u2/protocol/", "codec"),
    ("/harlsync/families/iai/codec.py", "codec"),
    ("/harlsync/families/iai/protocol/", "codec"),
    ("/catalogue.py", "catalogue"),
    ("/harlsync/families/", "driver"),
    ("/harlsync/terminal.py", "progress"),
    ("/harlsync/sync/fleettask.py", "progress"),
    ("/harlsync/robotlog.py", "logging"),
    ("/logging/", "logging"),
    ("/threading.py", "threads"),
    ("/queue.py", "threads"),
    ("/concurrent/", "threads"),
    ("/harlsync/project/", "project and save"),
    ("/yaml/", "project and save"),
    ("/harlsync/", "git, backup and the rest"),
    ("/subprocess.py", "git, backup and the rest"),
]
#: functions by name that are progress wherever they live (robotbackup's closures)
PROGRESS_NAMES = {"progress"}
ORDER = [
    "link",
    "codec",
    "driver",
    "catalogue",
    "progress",
    "logging",
    "threads",
    "project and save",
    "git, backup and the rest",
    "unattributed",
]


def layer_of(func: Func) -> str | None:
    path, _, name = func
    if name in PROGRESS_NAMES and "/harlsync/" in path:
        return "progress"
    for piece, layer in LAYERS:
        if piece in path:
            return layer
    return None


def by_layer(stats: dict[Func, Any]) -> dict[str, float]:
    """Each layer's CPU seconds: own time by module, the rest through the callers."""
    memo: dict[Func, dict[str, float]] = {}

    def shares(func: Func, depth: int = 0) -> dict[str, float]:
        """How ``func``'s own time splits over layers (fractions summing to 1)."""
        layer = layer_of(func)
        if layer is not None:
            return {layer: 1.0}
        if func in memo:
            return memo[func]
        memo[func] = {"unattributed": 1.0}  # a cycle resolves to this
        callers = stats[func][4] if func in stats else {}
        total = sum(c[2] for c in callers.values()) or sum(c[0] for c in callers.values())
        if depth > 30 or not callers or not total:
            return memo[func]
        out: dict[str, float] = defaultdict(float)
        for caller, c in callers.items():
            weight = (c[2] if sum(x[2] for x in callers.values()) else c[0]) / total
            for name, part in shares(caller, depth + 1).items():
                out[name] += weight * part
        memo[func] = dict(out)
        return memo[func]

    layers: dict[str, float] = defaultdict(float)
    for func, (_, _, own, _, _) in stats.items():
        for name, part in shares(func).items():
            layers[name] += own * part
    return layers


def profiled_threads(profiles: list[cProfile.Profile]) -> Callable[[], None]:
    """Every thread started from now on runs under a profiler of its own (CPU clock);
    the returned function puts ``Thread.run`` back."""
    run = threading.Thread.run

    def profiled(self: threading.Thread) -> None:
        profile = cProfile.Profile(time.thread_time)
        profiles.append(profile)
        profile.enable()
        try:
            run(self)
        finally:
            profile.disable()

    threading.Thread.run = profiled  # type: ignore[method-assign]

    def restore() -> None:
        threading.Thread.run = run  # type: ignore[method-assign]

    return restore


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--robot", choices=sorted(ROBOTS), default="small-full")
    parser.add_argument("--robots", type=int, default=32)
    parser.add_argument("--baud", type=int, default=19200)
    parser.add_argument("--top", type=int, default=0, help="also the N costliest functions")
    parser.add_argument("--dump", metavar="FILE", help="the merged profile, for pstats")
    args = parser.parse_args()
    print(f"harlsync layers bench: {describe()}")
    print(
        f"{args.robots} {args.robot} robots at {args.baud} baud, one fleet backup in one "
        "process (a thread a line), each thread profiled on its CPU clock\n"
    )
    with tempfile.TemporaryDirectory() as tmp, ExitStack() as stack:
        os.environ["HARLSYNC_LOCK_DIR"] = str(Path(tmp) / "locks")
        os.environ["HARLSYNC_AUDIT_LOG"] = str(Path(tmp) / "audit.jsonl")
        sim = stack.enter_context(
            SimProcess(args.robot, baud=args.baud, lines=args.robots, loop=True)
        )
        data = ROBOTS[args.robot]().data
        plant = Path(tmp) / "plant"
        for n, port in enumerate(sim.ports):
            path = plant / f"robot-{n:03d}"
            bot = new_robot(path.name, port, serial=SerialSettings(baudrate=args.baud))
            save_project(path, Project(path, bot, data))
        sim.reset()
        profiles: list[cProfile.Profile] = []
        restore = profiled_threads(profiles)
        main_profile = cProfile.Profile(time.thread_time)
        before, start = os.times(), time.perf_counter()
        main_profile.enable()
        try:
            report = backup([plant], workers=1)
        finally:
            main_profile.disable()
            restore()
        took, after = time.perf_counter() - start, os.times()
        assert report.ok, report.render()
        exchanges = sum(line["exchanges"] for line in sim.stats())
    cpu = sum(after[:4]) - sum(before[:4])
    merged = pstats.Stats(main_profile)
    for profile in profiles:
        merged.add(profile)
    if args.dump:
        merged.dump_stats(args.dump)
    stats: dict[Func, Any] = merged.stats  # type: ignore[attr-defined]
    layers = by_layer(stats)
    total = sum(layers.values())
    print(
        f"{exchanges:,} exchanges in {took:.1f} s; the process's CPU under the profiler "
        f"{cpu:.2f} s ({cpu / exchanges * 1e6:.0f} us an exchange), profiled {total:.2f} s "
        f"in {len(profiles) + 1} threads\n"
    )
    print(f"{'layer':26} {'CPU s':>7} {'share':>6} {'us/exch':>8}")
    for name in sorted(layers, key=lambda n: ORDER.index(n) if n in ORDER else 99):
        print(
            f"{name:26} {layers[name]:>7.2f} {layers[name] / total:>6.1%} "
            f"{layers[name] / exchanges * 1e6:>8.1f}"
        )
    print(f"{'all':26} {total:>7.2f} {1:>6.1%} {total / exchanges * 1e6:>8.1f}")
    if args.top:
        print(f"\nthe {args.top} functions of most own time (layer, calls, own s, with callees s)")
        top = sorted(stats.items(), key=lambda kv: -kv[1][2])[: args.top]
        for (path, line, name), (_, calls, own, inclusive, _) in top:
            where = f"{Path(path).name}:{line} {name}" if path != "~" else name
            print(
                f"  {layer_of((path, line, name)) or '-':12} {calls:>9,} {own:>7.3f} "
                f"{inclusive:>7.3f}  {where[:90]}"
            )


if __name__ == "__main__":
    main()
