"""How long load, validate, diff and save take on a full-size project, and their memory.

    python bench/project.py              best of 5 (~15 s)
    python bench/project.py --repeat 10  best of 10 (~25 s)
    python bench/project.py --only load diff-1pct   some cases only
    python bench/project.py --robot default --only save-write save-new   another robot

The project is the largest default configuration of the manual with every step
used (bench/pull.py's ``max-full`` robot): 49 programs x 256 steps = 12,544 steps,
100 offset tables, 16 timers.  It is saved once into a temporary directory, and
each case then runs in a fresh interpreter, so that its peak RSS is its own: the
case ``--repeat`` times for the best time, then once more under tracemalloc for
the peak of Python allocations.  See bench/README.md and docs/BENCHMARKS.md.

Targets (issue 7): a diff in at most 0.2 s, load plus validate in at most 0.5 s.
Issue 24: a full-size project written to disk (``save-write``: what the save does
after rendering and checking) in at most 0.05 s, with the syncs it made counted.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from machine import ROBOTS, describe, peak_rss_mib, process_env, run_child

from harlsync import families
from harlsync.families.harl_u2 import checks, layout
from harlsync.families.harl_u2.catalogue import CATALOGUE
from harlsync.families.harl_u2.model import RobotData, Step
from harlsync.project import (
    Project,
    atomic,
    load_project,
    new_robot,
    save_project,
    store,
    validate_project,
    yamlio,
)
from harlsync.project.files import Flaws
from harlsync.sync.engine import change_summary
from harlsync.sync.items import diff, render_text, to_json

DIFF_TARGET = 0.2
LOAD_TARGET = 0.5
#: Issue 15: a full-size project rendered, checked and saved.
SAVE_TARGET = 0.1
#: Issue 24: a full-size project's files written, made durable and put in place.
WRITE_TARGET = 0.05


def full_size(name: str = "max-full") -> tuple[Project, RobotData]:
    """The robot ``name``'s project (not yet on disk; by default the full-size one)
    and the same robot with a change set: for max-full 1 % of the steps (110 edited,
    15 cleared), 5 offset tables and 3 timers (fewer where a smaller robot lacks them)."""
    data = ROBOTS[name]().data
    robot = new_robot(name, "sim://?seed=1")
    changed = replace(
        data,
        programs={key: dict(steps) for key, steps in data.programs.items()},
        offsets=dict(data.offsets),
        timers=dict(data.timers),
    )
    keys = list(changed.programs)
    for i in range(125):
        steps = changed.programs[keys[i * 7 % len(keys)]]
        n = i * 53 % 255
        if n not in steps or not steps[n].data:
            continue
        if i < 110:
            steps[n] = Step("MOVE", (steps[n].data[0], "S80"))
        else:
            del steps[n]
    for n in (3, 17, 42, 64, 99):
        if n in changed.offsets:
            changed.offsets[n] = replace(changed.offsets[n], x="123.45", f="7")
    for n in (0, 5, 15):
        if n in changed.timers:
            changed.timers[n] = "0.75" if changed.timers[n] != "0.75" else "0.80"
    return Project(Path(), robot, data), changed


def _parse_all(path: Path) -> dict[str, tuple[str, yamlio.Parsed]]:
    """Every project file read and parsed (no schema, no checks): name -> (kind, doc)."""
    out = {}
    for file in sorted(path.rglob("*.yaml")):
        name = file.relative_to(path).as_posix()
        if name.startswith(layout.SCHEMAS_DIR):
            continue
        kind = layout.ROOT_FILES.get(name, "program")
        out[name] = (kind, yamlio.parse(file.read_text(encoding="utf-8")))
    return out


def _check_all(docs: dict[str, tuple[str, yamlio.Parsed]]) -> None:
    """The schema check of every file, and the checks against controller.yaml."""
    issues = [
        i for name, (kind, doc) in docs.items() for i in layout.SCHEMAS.check(kind, name, doc)
    ]
    programs = {
        layout.program_key(name): doc for name, (kind, doc) in docs.items() if kind == "program"
    }
    plain = {name: doc for name, (_, doc) in docs.items()}
    limits = checks.Limits.of(plain["controller.yaml"], Flaws())
    checks.check_against_config(limits, plain, programs, issues)  # type: ignore[arg-type]
    assert not issues, issues


def _cli(path: Path) -> Callable[[], object]:
    command = [sys.executable, "-m", "harlsync", "validate", str(path)]
    env = process_env(path.parent)
    return lambda: subprocess.run(command, check=True, env=env)


#: name -> (what it measures, target in seconds or None).
CASES: dict[str, tuple[str, float | None]] = {
    "parse": ("read + parse every YAML file (no checks)", None),
    "check": ("schemas + checks against controller.yaml", None),
    "load": ("load_project (push, diff, plan: validates)", LOAD_TARGET),
    "validate": ("validate_project (harlsync validate)", LOAD_TARGET),
    "validate-cli": ("`harlsync validate DIR`, whole process", LOAD_TARGET),
    "diff-same": ("diff, identical robots", DIFF_TARGET),
    "diff-1pct": ("diff, 1 % of steps, 5 tables, 3 timers", DIFF_TARGET),
    "compare": ("diff + summary + text + JSON (no wire)", DIFF_TARGET),
    "render": ("render every file's text (no check)", None),
    "check-save": ("what save checks before it writes", None),
    "save-new": ("save_project into an empty directory", SAVE_TARGET),
    "save-same": ("save_project, nothing changed", SAVE_TARGET),
    "save-write": ("save-new's disk part: write, sync, rename", WRITE_TARGET),
    "write-fsyncs": ("the same, an fsync per file (before issue 24)", None),
}


#: Cases whose action returns the seconds of the part it measures.
TIMED_INSIDE = {"check-save", "save-write", "write-fsyncs"}
#: Cases whose fsync and syncfs calls are counted.
SYNCS_COUNTED = {"save-new", "save-same", "save-write", "write-fsyncs"}
SYNCS = {"fsync": 0, "syncfs": 0}


def _count_syncs() -> None:
    """Count every fsync and syncfs this process makes from now on."""
    real_fsync, real_syncfs = os.fsync, atomic._syncfs

    def fsync(fd: int) -> None:
        SYNCS["fsync"] += 1
        real_fsync(fd)

    def syncfs(fd: int) -> None:
        SYNCS["syncfs"] += 1
        real_syncfs(fd)

    os.fsync = fsync
    atomic._syncfs = syncfs  # type: ignore[assignment]


def setup_case(case: str, path: Path, robot: str = "max-full") -> Callable[[], object]:
    """What to time for ``case``, with everything it needs already built (only that,
    so that the peak RSS of a load is the load's)."""
    if case == "parse":
        return lambda: _parse_all(path)
    if case == "check":
        docs = _parse_all(path)
        return lambda: _check_all(docs)
    if case == "load":
        return lambda: load_project(path)
    if case == "validate":
        return lambda: validate_project(path)
    if case == "validate-cli":
        return _cli(path)
    project, changed = full_size(robot)
    if case == "diff-same":
        other = load_project(path).data
        return lambda: diff(CATALOGUE, project.data, other)
    if case == "diff-1pct":
        return lambda: diff(CATALOGUE, project.data, changed)
    if case == "compare":

        def compare() -> object:
            changes = diff(CATALOGUE, project.data, changed)
            return (
                change_summary(changes),
                render_text(changes, "robot", "project"),
                json.dumps([to_json(c) for c in changes]),
            )

        return compare
    family = families.get(project.robot.family)
    if case == "render":
        return lambda: family.render_files(project.robot, project.data)
    if case == "check-save":

        def check_save() -> object:
            # store.save_project's check, on texts just rendered (as a save has them)
            texts = family.render_files(project.robot, project.data)
            start = time.perf_counter()
            problems = family.data_problems(project.data)
            found = family.analyse({k: v.encode() for k, v in texts.items()})
            assert not problems and not found.issues
            return time.perf_counter() - start

        return check_save
    if case == "save-new":
        counter = iter(range(1_000_000))  # beside the project, removed with it
        return lambda: save_project(path.parent / f"save-new-{next(counter)}", project)
    if case == "save-same":
        return lambda: save_project(path, project)
    if case in ("save-write", "write-fsyncs"):
        if case == "write-fsyncs":  # as where there is no syncfs(2)
            atomic._load_syncfs = lambda: None  # type: ignore[assignment]
        counter = iter(range(1_000_000))
        real_commit = store._commit  # the name save_project calls

        def save_write() -> object:
            took = []

            def commit(*args: Any) -> None:
                start = time.perf_counter()
                real_commit(*args)
                took.append(time.perf_counter() - start)

            store._commit = commit  # type: ignore[assignment]
            try:
                save_project(path.parent / f"{case}-{next(counter)}", project)
            finally:
                store._commit = real_commit  # type: ignore[assignment]
            return took[0]

        return save_write
    raise ValueError(case)


def _cpu_seconds() -> float:
    """CPU time of this process and of its finished children (harlsync validate)."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def run_case(case: str, path: Path, repeat: int, robot: str = "max-full") -> dict[str, Any]:
    """One case in this process: the best time, the tracemalloc peak, the RSS, and
    the syncs of one run (save cases)."""
    action = setup_case(case, path, robot)
    if case in SYNCS_COUNTED:
        _count_syncs()
    rss_before = peak_rss_mib()
    times, cpu_times = [], []
    for _ in range(repeat):
        start, cpu_start = time.perf_counter(), _cpu_seconds()
        result = action()
        took, cpu = time.perf_counter() - start, _cpu_seconds() - cpu_start
        if case in TIMED_INSIDE and isinstance(result, float):  # it timed its own part
            took = cpu = result
        times.append(took)
        cpu_times.append(cpu)
    syncs = {name: count // repeat for name, count in SYNCS.items()}
    rss_after = peak_rss_mib()
    if case == "validate-cli":  # the peak of the largest child: one harlsync validate
        rss_before = None
        rss_after = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    del result
    traced = None
    if case != "validate-cli":  # another process: tracemalloc cannot see it
        tracemalloc.start()
        action()
        traced = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
    return {
        "case": case,
        "best": min(times),
        "median": sorted(times)[len(times) // 2],
        "cpu": min(cpu_times),
        "traced": traced,
        "rss_before": rss_before,
        "rss_peak": rss_after,
        "syncs": syncs if case in SYNCS_COUNTED else None,
    }


def in_child(case: str, path: Path, repeat: int, robot: str) -> dict[str, Any]:
    """:func:`run_case` in a fresh interpreter, so that its peak RSS is its own."""
    command = [sys.executable, __file__, "--case", case, str(path), "--repeat", str(repeat)]
    command += ["--robot", robot]
    return run_child(command, case)


def show(rows: list[dict[str, Any]]) -> None:
    print(
        f"{'case':13} {'what':44} {'best s':>7} {'median':>7} {'CPU s':>6} {'target':>7} {'':4} "
        f"{'traced MiB':>10} {'RSS MiB':>7} {'(case +)':>8}  syncs"
    )
    for r in rows:
        what, target = CASES[r["case"]]
        verdict = "" if target is None else ("PASS" if r["best"] <= target else "MISS")
        traced = "-" if r["traced"] is None else f"{r['traced']:.2f}"
        grown = "" if r["rss_before"] is None else f"(+{r['rss_peak'] - r['rss_before']:>5.1f})"
        syncs = r.get("syncs")
        counted = f"  {syncs['fsync']} fsync, {syncs['syncfs']} syncfs" if syncs else ""
        print(
            f"{r['case']:13} {what:44} {r['best']:>7.3f} {r['median']:>7.3f} {r['cpu']:>6.3f} "
            f"{'-' if target is None else f'{target:g}':>7} {verdict:4} {traced:>10} "
            f"{r['rss_peak']:>7.1f} {grown:>8}{counted}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs per case (best is shown)")
    parser.add_argument("--only", nargs="+", choices=CASES, metavar="CASE", help="these cases")
    parser.add_argument(
        "--robot", choices=ROBOTS, default="max-full", help="bench/machine.py's (default max-full)"
    )
    parser.add_argument("--case", nargs=2, metavar=("CASE", "DIR"), help=argparse.SUPPRESS)
    args = parser.parse_args()

    if args.case:
        case, path = args.case
        print(json.dumps(run_case(case, Path(path), args.repeat, args.robot)))
        return

    started = time.perf_counter()
    print(f"harlsync project bench: {describe()}")
    project, changed = full_size(args.robot)
    data = project.data
    steps = sum(len(p) for p in data.programs.values())
    programs = len(data.programs)
    with tempfile.TemporaryDirectory(prefix="harlsync-bench-") as tmp:
        path = Path(tmp) / args.robot
        save_project(path, replace(project, path=path))
        size = sum(f.stat().st_size for f in path.rglob("*.yaml") if ".schemas" not in f.parts)
        print(
            f"{args.robot}: {programs} programs, {steps:,} steps, {len(data.offsets)} tables, "
            f"{len(data.timers)} timers: {size / 1024:.0f} KiB of YAML; "
            f"change set: {len(diff(CATALOGUE, data, changed))} items; best of {args.repeat}\n"
        )
        rows = [in_child(case, path, args.repeat, args.robot) for case in args.only or CASES]
    show(rows)
    print(
        "\nEach case runs in its own interpreter.  best s, median: wall time of one run;"
        "\nCPU s: the least CPU time of one run (steadier than wall time on a busy machine);"
        "\ntraced MiB: tracemalloc peak of one more run; RSS MiB: the process's peak"
        "\n(validate-cli: the harlsync process's); (case +): its growth during the timed runs;"
        "\nsyncs: fsync and syncfs calls of one run."
    )
    print(f"ran in {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
