"""What the audit log's size costs a pull: `harlsync pull` with an empty log and with
a 50,000-record one, alternating.

    python bench/auditlog.py                       default robot at 115200, 5 pairs: ~1 min
    python bench/auditlog.py --robot medium --pairs 9 --records 100000

A simulator process (bench/simserver.py) serves the robot on a pty with wire-time
emulation; ``harlsync pull DIR`` runs as a process of its own over the project a
first pull saved (a nightly pull of an unchanged robot), its ``HARLSYNC_AUDIT_LOG``
pointing, in turn, at an empty log and at one of ``--records`` records: pushes
(start, 3 writes, end) to 128 other robots, as a plant's log grows.  One pull with
each log first, not counted (it builds the big log's index, once).  It prints each
pair, the medians of the whole pull and of its CPU time, and their ratio.

Then, in this process, what the pull asks of the log (the robot's unfinished
pushes and those since its last backup) against the big log: through the index
(bytes and lines it read) and, for the record, the whole log read as before
issue 24.

Target (issue 24): the pull with the big log within 1.01 x the one with the empty log.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from machine import ROBOTS, SimProcess, describe, harlsync_command, process_env, timed_process
from process import robot_yaml

from harlsync.sync import audit, auditindex

TARGET = 1.01


def big_log(path: Path, records: int) -> None:
    """``records`` records of pushes to 128 robots that are not the bench's."""
    with open(path, "w") as f:
        for n in range(records // 5):
            rid = f"{n:016x}"
            robot = {"name": f"r{n % 128}", "port": f"/dev/ttyUSB{n % 128}", "station": 1}
            head = {"id": rid, "time": "2026-11-24T02:00:00+00:00", "user": "alice", "host": "pc"}
            lines = [{"event": "start", **head, "action": "push", "robot": robot, "plan": ["a"]}]
            lines += [
                {"event": "write", **head, "item": f"position {i}", "command": f"W{i}"}
                for i in range(3)
            ]
            lines.append({"event": "end", **head, "action": "push", "robot": robot, "result": "ok"})
            f.writelines(json.dumps(r, sort_keys=True) + "\n" for r in lines)


def pull(sim: SimProcess, baud: int, project: Path, log: Path) -> dict[str, Any]:
    env = process_env(project.parent / "locks")
    env["HARLSYNC_AUDIT_LOG"] = str(log)
    return timed_process(sim, baud, [*harlsync_command(), "pull", str(project)], env)


def in_process(log: Path, project: Path) -> None:
    """What a pull asks of the log, through the index and by reading all of it."""
    port, station = "/dev/ttyUSB999", 1
    start = time.perf_counter()
    index = auditindex.load(log)
    index.robot(port, station, project)
    took = time.perf_counter() - start
    start = time.perf_counter()
    audit.unsettled(audit.of_robot(audit.results(log, []), port, station, project))
    whole = time.perf_counter() - start
    size = log.stat().st_size
    print(
        f"\nin this process, the big log ({size / 2**20:.1f} MiB): through its index "
        f"{took * 1000:.1f} ms, {index.bytes_read:,} bytes and {index.lines_parsed} lines read; "
        f"the whole log read (before issue 24) {whole * 1000:.0f} ms"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--robot", choices=sorted(ROBOTS), default="default")
    parser.add_argument("--baud", type=int, default=115200)
    parser.add_argument("--pairs", type=int, default=5, help="pulls with each log, alternating")
    parser.add_argument("--records", type=int, default=50_000, help="records in the big log")
    args = parser.parse_args()

    print(f"harlsync audit log bench: {describe()}")
    with tempfile.TemporaryDirectory(prefix="harlsync-bench-") as tmp:
        root = Path(tmp)
        empty, big = root / "empty.jsonl", root / "big.jsonl"
        empty.touch()
        big_log(big, args.records)
        with SimProcess(args.robot, baud=args.baud) as sim:
            project = root / args.robot
            project.mkdir()
            (project / "robot.yaml").write_text(robot_yaml(args.robot, sim.ports[0], args.baud))
            pull(sim, args.baud, project, empty)  # the first pull: the project to pull again
            pull(sim, args.baud, project, big)  # builds the big log's index, once
            print(
                f"{args.robot} at {args.baud} baud, `harlsync pull` again; "
                f"{args.records:,} records in the big log; {args.pairs} pairs\n"
            )
            print(
                f"{'pair':>4} {'empty s':>8} {'big s':>8} {'ratio':>6} {'CPU empty':>9} {'CPU big':>8}"
            )
            runs: dict[str, list[dict[str, Any]]] = {"empty": [], "big": []}
            for n in range(args.pairs):
                order = (
                    [("empty", empty), ("big", big)]
                    if n % 2 == 0
                    else [("big", big), ("empty", empty)]
                )
                for name, log in order:
                    runs[name].append(pull(sim, args.baud, project, log))
                e, b = runs["empty"][-1], runs["big"][-1]
                print(
                    f"{n + 1:>4} {e['whole']:>8.3f} {b['whole']:>8.3f} {b['whole'] / e['whole']:>6.3f} "
                    f"{e['cpu']:>9.3f} {b['cpu']:>8.3f}",
                    flush=True,
                )
        whole = {k: statistics.median(r["whole"] for r in v) for k, v in runs.items()}
        cpu = {k: statistics.median(r["cpu"] for r in v) for k, v in runs.items()}
        ratio = whole["big"] / whole["empty"]
        print(
            f"\nmedian whole pull: empty log {whole['empty']:.3f} s, big log {whole['big']:.3f} s: "
            f"{ratio:.3f} x ({'PASS' if ratio <= TARGET else 'MISS'}, target {TARGET})"
        )
        print(
            f"median CPU: empty log {cpu['empty']:.3f} s, big log {cpu['big']:.3f} s: "
            f"{cpu['big'] / cpu['empty']:.3f} x"
        )
        in_process(big, project)


if __name__ == "__main__":
    sys.exit(main())
