"""What a `harlsync pull` does before its first request: modules, CPU, instructions.

    python bench/startup.py                       the default robot at 115200, 10 pulls: ~15 s
    python bench/startup.py --against TREE        and a tree of another harlsync (git
                                                  worktree add --detach TREE REV),
                                                  alternating with this one
    python bench/startup.py --instructions        and the instructions to the first
                                                  request, under valgrind: ~40 s

A simulator process (bench/simserver.py, as bench/floor.py runs it) serves the
robot on a pty; each `harlsync pull DIR` (robot.yaml naming the pty, as
bench/process.py writes it) runs in a process of its own, its ``os.write`` watched:
at the first write to the pty it notes the modules imported (``sys.modules``), its
CPU time so far (getrusage) and the time since the bench started it; the
simulator says when it read that first byte.  Printed for each tree: the module
count and the modules this tree has and the other has not, and the best and median
of each figure; with ``--against``, the median of the per-pair ratios of CPU and
start-up.  CPU and module counts hold on a busy machine, wall time does not.

Each pull runs on to its end: **whole** is its whole time and **gaps** the time
from each reply's last byte to the next request, in all (bench/floor.py's), medians
both: what start-up no longer does happens later.

``--instructions``: the instructions (valgrind's callgrind, ``I refs``) from the
interpreter's start to that first write (the process ends there), for a bare
``python -c pass`` too: a count that does not depend on the load at all.
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

#: Run as the pull's process: harlsync's command line, with ``os.write`` watched.
#: $STARTUP_TREE: import harlsync from that tree, not the installed one.
WATCHED = """
import os, resource, sys, time
port, out, started = os.environ["STARTUP_PORT"], os.environ["STARTUP_OUT"], os.environ["STARTUP_T0"]
write = os.write

def watched(fd, data):
    if fd > 2 and not os.path.exists(out) and os.isatty(fd) and os.ttyname(fd) == port:
        at, used = time.monotonic(), resource.getrusage(resource.RUSAGE_SELF)
        import json
        with open(out, "w") as f:
            json.dump({"wall": at - float(started), "cpu": used.ru_utime + used.ru_stime,
                       "modules": sorted(sys.modules)}, f)
        if os.environ.get("STARTUP_EXIT"):
            write(fd, data)
            os._exit(0)
    return write(fd, data)

os.write = watched
tree = os.environ.get("STARTUP_TREE")
if tree:  # ahead of the editable install's finder
    sys.meta_path[:] = [f for f in sys.meta_path if "editable" not in str(getattr(f, "__module__", ""))]
    sys.path.insert(0, tree)
from harlsync.cli import main
sys.exit(main(sys.argv[1:]))
"""


def pull(sim: Any, text: str, tree: str | None, tmp: Path, n: int, **more: str) -> dict[str, Any]:
    """One `harlsync pull` into a new directory, watched; what it noted."""
    from machine import process_env

    project, out = tmp / f"p{n}", tmp / f"first-{n}.json"
    project.mkdir()
    (project / "robot.yaml").write_text(text)
    env = process_env(tmp / "locks", STARTUP_PORT=sim.ports[0], STARTUP_OUT=str(out), **more)
    if tree:
        env["STARTUP_TREE"] = tree
    sim.reset()
    started = time.monotonic()
    env["STARTUP_T0"] = repr(started)
    done = subprocess.run(
        [sys.executable, "-c", WATCHED, "pull", str(project)],
        capture_output=True,
        text=True,
        env=env,
        check=False,
    )
    if done.returncode:
        sys.exit(
            f"startup: the pull ({tree or 'this tree'}) exited {done.returncode}:\n{done.stderr}"
        )
    ended = time.monotonic()
    counted = sim.stats()[0]
    noted: dict[str, Any] = json.loads(out.read_text())
    noted["first"] = counted["first_in"] - started
    noted["whole"], noted["gaps"] = ended - started, counted["gaps"]
    shutil.rmtree(project)
    return noted


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robot", default="default")
    parser.add_argument("--baud", type=int, default=115200)
    parser.add_argument("--repeat", type=int, default=10, help="pulls of each tree (default 10)")
    parser.add_argument("--against", metavar="TREE", help="another harlsync's source tree")
    parser.add_argument("--instructions", action="store_true", help="count them under valgrind")
    args = parser.parse_args()
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from machine import SimProcess, describe, instructions, process_env
    from process import robot_yaml

    trees: list[str | None] = [None] + ([str(Path(args.against).resolve())] if args.against else [])
    names = {None: "this tree"} | {t: t for t in trees if t}
    print(f"harlsync start-up bench: {describe()}")
    print(f"robot {args.robot} at {args.baud} baud, {args.repeat} pulls of each, alternating")
    tmp = Path(tempfile.mkdtemp(prefix="harlsync-startup-"))
    runs: dict[str | None, list[dict[str, Any]]] = {tree: [] for tree in trees}
    counted: dict[str | None, int] = {}
    bare = 0
    try:
        with SimProcess(args.robot, baud=args.baud) as sim:
            text = robot_yaml(args.robot, sim.ports[0], args.baud)
            n = 0
            for tree in trees:  # once each first: their bytecode cached
                pull(sim, text, tree, tmp, n := n + 1)
            for _ in range(args.repeat):
                for tree in trees:
                    runs[tree].append(pull(sim, text, tree, tmp, n := n + 1))
            if args.instructions:
                env = process_env(tmp / "locks")
                bare = instructions([sys.executable, "-c", "pass"], env, "startup")
                for tree in trees:
                    project = tmp / f"i{n}"
                    project.mkdir()
                    (project / "robot.yaml").write_text(text)
                    out = tmp / f"first-i{n}.json"
                    env = process_env(
                        tmp / "locks",
                        STARTUP_PORT=sim.ports[0],
                        STARTUP_OUT=str(out),
                        STARTUP_T0="0",
                        STARTUP_EXIT="1",
                        **({"STARTUP_TREE": tree} if tree else {}),
                    )
                    command = [sys.executable, "-c", WATCHED, "pull", str(project)]
                    counted[tree] = instructions(command, env, "startup")
                    n += 1
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    modules = {tree: set(rs[-1]["modules"]) for tree, rs in runs.items()}
    print(
        f"\n{'tree':32} {'modules':>7} {'first request s':>15} {'median':>7} {'CPU s':>7} "
        f"{'median':>7} {'whole':>6} {'gaps':>6}"
    )
    for tree, rs in runs.items():
        first, cpu = [r["first"] for r in rs], [r["cpu"] for r in rs]
        print(
            f"{names[tree][-32:]:32} {len(modules[tree]):>7} {min(first):>15.4f} "
            f"{statistics.median(first):>7.4f} {min(cpu):>7.4f} {statistics.median(cpu):>7.4f} "
            f"{statistics.median(r['whole'] for r in rs):>6.3f} "
            f"{statistics.median(r['gaps'] for r in rs):>6.3f}"
        )
    if args.against:
        mine, other = runs[None], runs[trees[1]]
        cpu = statistics.median(a["cpu"] / b["cpu"] for a, b in zip(mine, other))
        first = statistics.median(a["first"] / b["first"] for a, b in zip(mine, other))
        print(
            f"this tree / the other, median of the pairs: CPU {cpu:.3f}, first request {first:.3f}"
        )
        for label, more in (
            ("only here", modules[None] - modules[trees[1]]),
            ("only there", modules[trees[1]] - modules[None]),
        ):
            shown = sorted(m for m in more if not m.startswith("_"))
            print(f"{label} ({len(more)}): {' '.join(shown) or '-'}")
    if counted:
        print(f"\ninstructions (valgrind I refs): python -c pass {bare / 1e6:.1f} M")
        for tree in trees:
            print(f"  {names[tree][-40:]:40} {counted[tree] / 1e6:.1f} M to the first request")
    print(f"machine at the end: {describe()}")


if __name__ == "__main__":
    main()
