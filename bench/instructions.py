"""A whole `harlsync pull` in instructions and CPU, this tree against others: what a
concept kept for speed gains, load-independent.

    python bench/instructions.py --against /tmp/nofreeze --against /tmp/eager   ~3 min
    python bench/instructions.py --robot 'sim://?seed=7' --repeat 8

The robot is served by ``sim://`` (harlsync's simulator in the pulling process, no
wire-time emulation: only CPU, the simulator's the same in every tree).  A first
pull makes the project; then, for each tree (this one, then each ``--against
TREE``: its ``harlsync`` package on PYTHONPATH, e.g. a ``git archive`` of it with
a concept taken out), a pull compiles its bytecode, one pull under valgrind
(callgrind, ``I refs``, one hash seed) counts its instructions, and ``--repeat``
pulls, the trees alternating, measure its user + system CPU (``os.wait4`` of the
process).  Each pull is a nightly one: the backup is there and nothing changed.

Printed: the instructions and the median CPU of each tree, and both against this
tree's (the median of the pairs' ratios for the CPU): a concept taken out in the
other tree gains what this tree saves against it.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from machine import PYCACHE, describe, harlsync_command, instructions


def env_of(tmp: Path, tree: str | None) -> dict[str, str]:
    env = dict(
        os.environ,
        HARLSYNC_LOCK_DIR=str(tmp / "locks"),
        HARLSYNC_AUDIT_LOG=str(tmp / "audit.jsonl"),
        PYTHONPYCACHEPREFIX=str(PYCACHE),
        PYTHONHASHSEED="0",
    )
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    if tree:
        env["PYTHONPATH"] = tree
    return env


def cpu_of(command: list[str], env: dict[str, str]) -> float:
    """The user + system CPU of ``command``, run to its end (it must succeed)."""
    child = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode:
        sys.exit(f"instructions: {' '.join(command)} exited {child.returncode}")
    return usage.ru_utime + usage.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--robot", default="sim://?seed=7", help="the port the robot is on")
    parser.add_argument("--repeat", type=int, default=6, help="pulls of each tree for the CPU")
    parser.add_argument("--against", action="append", default=[], metavar="TREE")
    args = parser.parse_args()
    trees: list[tuple[str, str | None]] = [("this tree", None)]
    trees += [(tree, str(Path(tree).resolve())) for tree in args.against]
    print(f"harlsync instructions bench: {describe()}")
    print(f"a nightly `harlsync pull` of {args.robot}, {args.repeat} pulls of each tree\n")
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        project = tmp / "robot"
        first = [*harlsync_command(), "pull", str(project), "--port", args.robot]
        subprocess.run(first, env=env_of(tmp, None), check=True, stdout=subprocess.DEVNULL)
        pull = [*harlsync_command(), "pull", str(project)]
        counted: dict[str, int] = {}
        for name, tree in trees:
            cpu_of(pull, env_of(tmp, tree))  # its bytecode compiled and cached
            counted[name] = instructions(pull, env_of(tmp, tree), "instructions")
        cpus: dict[str, list[float]] = {name: [] for name, _ in trees}
        for _ in range(args.repeat):
            for name, tree in trees:
                cpus[name].append(cpu_of(pull, env_of(tmp, tree)))
    print(f"{'tree':32} {'instructions':>14} {'x this':>7} {'CPU s':>7} {'x this':>7}")
    mine = cpus["this tree"]
    for name, _ in trees:
        pairs = statistics.median(a / b for a, b in zip(cpus[name], mine))
        print(
            f"{name:32} {counted[name] / 1e6:>12,.1f} M {counted[name] / counted['this tree']:>7.3f} "
            f"{statistics.median(cpus[name]):>7.3f} {pairs:>7.3f}"
        )
    print(f"\nmachine at the end: {describe()}")


if __name__ == "__main__":
    main()
