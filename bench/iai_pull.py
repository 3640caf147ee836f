"""An IAI pull of 1,000 positions against the line limit, and its requests against the minimum.

    python bench/iai_pull.py            quick (~40 s): both tables at 115200 baud, TTA and TT
    python bench/iai_pull.py --full     adds 9600 baud (TTA), best of 3 at 115200 (~4 min)
    python bench/iai_pull.py --table mix --model TTA --baud 9600,115200 --repeat 2

Two tables of 1,000 defined positions (every number of the default range 1-1000):
``mix``, a 4-axis robot whose positions use 3 or 4 axes (44- and 52-byte records,
about half each), and ``8axis``, every position on 8 axes (84-byte records, the
worst case the 22DH queries are sized for).  Each is served by a simulator process
(bench/simserver.py: the IAI simulator on the framework's PtyServer, or TcpServer
with --tcp) with wire-time emulation at the baud rate, and pulled by the whole
``harlsync pull DIR --family iai --port PTY --station 99`` command in a process of
its own, into a directory whose robot.yaml names the baud rate and the model (as a
site writes it for a controller not at the defaults).

Times, from the one monotonic clock every process of the machine shares:

- start-up: from starting the process until the simulator reads the first request
  byte (interpreter, imports, the project and the line lock, opening the port);
- read: from there until the last reply byte is due on the emulated line;
- save: from there until the process has exited (decoding the last reply, writing
  the project, exiting).

Beside them: the harlsync process's CPU time, and for scale the start of a bare
interpreter and of one importing what a pull imports, and the two halves of a save
timed in this process (rendering the YAML; reading it back and checking it).

The line limit is what the simulator counted crossing the line, both ways, at 10
bits a character (8N1): bytes x 10 / baud.  The target (issue 12) is the whole
process within 1.05 x the line limit.  The request count is set against the
minimum the send buffer allows: ceil(1000 / records per reply) 22DH queries plus
the 201H version query, where a reply may hold (send buffer - 16) // 84 records of
the worst case (8 axes), computed here from the profile's frame layout.
"""

from __future__ import annotations

import argparse
import math
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from machine import (
    IAI_ROBOTS,
    SimProcess,
    describe,
    harlsync_command,
    minutes,
    process_env,
    timed_process,
)

from harlsync.families.iai import analysis, profile
from harlsync.families.iai.family import FAMILY
from harlsync.families.iai.layout import IaiData
from harlsync.families.iai.protocol import max_positions_per_read

TARGET = 1.05
POSITIONS = 1000
TABLES = {"mix": "iai-mix", "8axis": "iai-8axis"}
MODELS = ("TTA", "TT")
#: A 22DH reply around its records: '#', station, id, reserved 00, record count,
#: SC, CR, LF (profile: frame; digest: 22DH).
READ_REPLY_OVERHEAD = 1 + 2 + 3 + 2 + 4 + 2 + 2
#: The longest 22DH record: number, pattern, acc, dec, speed, 8 coordinates, extended.
RECORD_8_AXES = 4 + 2 + 4 + 4 + 4 + 8 * 8 + 2

ROBOT_YAML = """\
format: 1
family: iai
name: bench
connection:
  port: {port}
  station: "99"
  baudrate: {baud}
  bytesize: 8
  parity: N
  stopbits: 1
  rtscts: false
  timeout: 0.5
  retries: 3
controller:
  model: {model}
  first_position: 1
  last_position: {last}
maintenance_windows: []
"""


def minimum_requests(model: str) -> tuple[int, int]:
    """(records per 22DH reply in the worst case, fewest requests for a whole pull)."""
    per_reply = (profile.BUFFERS[model].send - READ_REPLY_OVERHEAD) // RECORD_8_AXES
    return per_reply, math.ceil(POSITIONS / per_reply) + 1


def pull_once(sim: SimProcess, baud: int, model: str, project: Path) -> dict[str, Any]:
    """``harlsync pull`` as a process of its own, timed against the simulator's clock."""
    project.mkdir()
    (project / "robot.yaml").write_text(
        ROBOT_YAML.format(port=sim.ports[0], baud=baud, model=model, last=POSITIONS)
    )
    command = [
        *harlsync_command(),
        "pull",
        str(project),
        "--family",
        "iai",
        "--port",
        sim.ports[0],
        "--station",
        "99",
    ]
    result = timed_process(sim, baud, command, process_env(project.parent / "locks"))
    text = (project / "positions.yaml").read_text()
    pulled = len(re.findall(r"^  [0-9]+: \{", text, re.MULTILINE))
    if pulled != POSITIONS:
        sys.exit(f"{project}: {pulled} positions pulled, not {POSITIONS}")
    return result


def bare_start(repeat: int = 3) -> tuple[float, float]:
    """Best wall time of ``python -c pass`` and of ``python -c 'import ...'`` with what a
    pull imports before its first byte: what any Python CLI pays to start."""
    imports = (
        "import harlsync.cli, harlsync.sync.engine, harlsync.families.iai.family, "
        "harlsync.families.iai.controller, harlsync.families.iai.driver, "
        "harlsync.project"
    )
    out = []
    for code in ("pass", imports):
        best = math.inf
        for _ in range(repeat):
            start = time.monotonic()
            subprocess.run(
                [sys.executable, "-c", code],
                check=True,
                env=process_env(Path(tempfile.gettempdir())),
            )
            best = min(best, time.monotonic() - start)
        out.append(best)
    return out[0], out[1]


def save_parts(table: str, repeat: int = 3) -> tuple[float, float]:
    """Best seconds, in this process, of the two halves of saving the table: rendering
    the files (PyYAML's emitter) and reading them back and checking them (parse,
    JSON Schema, the IAI checks), as ``save_project`` does before it writes."""
    state = IAI_ROBOTS[TABLES[table]]()
    robot = FAMILY.new_robot("bench", "/dev/null", profile.DEFAULT_STATION)
    data = IaiData(state.versions[(0, 0)], dict(state.positions))
    render = check = math.inf
    for _ in range(repeat):
        start = time.perf_counter()
        texts = FAMILY.render_files(robot, data)
        middle = time.perf_counter()
        found = analysis.analyse({name: text.encode() for name, text in texts.items()})
        end = time.perf_counter()
        assert not found.issues, found.issues
        render, check = min(render, middle - start), min(check, end - middle)
    return render, check


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--full", action="store_true", help="9600 baud too, and best of 3 at 115200 (~4 min)"
    )
    parser.add_argument(
        "--table",
        choices=sorted(TABLES),
        action="append",
        help="mix or 8axis (default both; repeat the option for several)",
    )
    parser.add_argument(
        "--model",
        choices=MODELS,
        action="append",
        help="TTA or TT (default both at 115200, TTA only at 9600)",
    )
    parser.add_argument(
        "--baud", help="comma-separated baud rates (default: 115200; --full: 9600,115200)"
    )
    parser.add_argument("--repeat", type=int, help="pulls per case at 115200 (the best is shown)")
    parser.add_argument("--tcp", action="store_true", help="serve over TCP instead of a pty")
    args = parser.parse_args()
    tables = args.table or ["mix", "8axis"]
    bauds = [int(b) for b in (args.baud or ("9600,115200" if args.full else "115200")).split(",")]
    fast_repeat = args.repeat or (3 if args.full else 1)

    cases = []
    for baud in bauds:
        # TT's figure is its request count: the 9600-baud minutes go to TTA only.
        models = args.model or (MODELS if baud > 9600 else ("TTA",))
        cases += [(table, model, baud) for model in models for table in tables]

    print(f"harlsync IAI pull bench: {describe()}")
    print(
        f"{POSITIONS:,} positions (mix: 3-4 axes; 8axis: 8 axes), over "
        f"{'TCP' if args.tcp else 'a pty'} from a simulator process, "
        f"`harlsync pull` as a process of its own; best of {fast_repeat} above 9600 baud\n"
    )
    began = time.monotonic()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n, (table, model, baud) in enumerate(cases):
            robot = TABLES[table] + ("-tt" if model == "TT" else "")
            repeat = 1 if baud <= 9600 else fast_repeat
            with SimProcess(robot, baud=baud, tcp=args.tcp) as sim:
                runs = [
                    pull_once(sim, baud, model, Path(tmp) / f"case{n}-{r}") for r in range(repeat)
                ]
            for r in range(repeat):
                shutil.rmtree(Path(tmp) / f"case{n}-{r}")
            best = min(runs, key=lambda run: run["whole"])
            rows.append({"table": table, "model": model, "baud": baud, **best})
            show_row(rows[-1], header=n == 0)
        python, imports = bare_start()
        parts = {table: save_parts(table) for table in tables}

    print(
        f"\nTarget: whole/limit at most {TARGET}.  start-up: from starting the process to the "
        "first request byte;\nread: to the last reply byte due on the line; save: to the "
        "process's exit; over ms/exch:\n(read - limit) / exchanges; CPU s: the harlsync "
        "process's user + system time."
    )
    print(
        f"For scale: `python -c pass` {python:.3f} s; importing what a pull imports "
        f"{imports:.3f} s (best of 3)."
    )
    for table, (render, check) in parts.items():
        print(
            f"Saving the {table} table, in process: render {render:.3f} s, read back and "
            f"check {check:.3f} s (best of 3)."
        )
    lates = [r["late_worst"] for r in rows if r["late_worst"]]
    if lates:
        mean = sum(r["late_mean"] for r in rows) / len(rows)
        print(
            f"Simulator replies late by {mean * 1e6:.0f} us on average, "
            f"{max(lates) * 1e3:.1f} ms at worst."
        )

    print(
        "\nRequests of a pull against the fewest the send buffer allows "
        "(ceil(1000 / records per reply) + 201H):"
    )
    print(
        f"  {'model':5} {'send buffer':>11} {'records/reply':>13} {'client asks':>11} "
        f"{'minimum':>7} {'sent':>5}  {'201H':>4} {'22DH':>4}"
    )
    for model in dict.fromkeys(r["model"] for r in rows):
        per_reply, least = minimum_requests(model)
        sent = {r["exchanges"] for r in rows if r["model"] == model}
        letters = next(r["letters"] for r in rows if r["model"] == model)
        mark = "" if sent == {least} else "   <-- differs"
        print(
            f"  {model:5} {profile.BUFFERS[model].send:>11,} {per_reply:>13} "
            f"{max_positions_per_read(model):>11} {least:>7} "
            f"{'/'.join(map(str, sorted(sent))):>5}  {letters.get('201', 0):>4} "
            f"{letters.get('22D', 0):>4}{mark}"
        )
    print(f"\nran in {minutes(time.monotonic() - began)}")


def show_row(r: dict[str, Any], *, header: bool) -> None:
    if header:
        print(
            f"{'table':6} {'model':5} {'baud':>6} {'exch':>4} {'bytes':>7} {'limit s':>8} "
            f"{'start-up':>8} {'read':>7} {'save':>6} {'whole':>7} {'read/lim':>8} "
            f"{'whole/lim':>9} {'over ms/exch':>12} {'CPU s':>5}"
        )
    over = (r["read"] - r["limit"]) / r["exchanges"] * 1e3
    verdict = "PASS" if r["whole"] / r["limit"] <= TARGET else "MISS"
    print(
        f"{r['table']:6} {r['model']:5} {r['baud']:>6} {r['exchanges']:>4} {r['bytes']:>7,} "
        f"{r['limit']:>8.2f} {r['startup']:>8.3f} {r['read']:>7.2f} {r['save']:>6.3f} "
        f"{r['whole']:>7.2f} {r['read'] / r['limit']:>8.3f} {r['whole'] / r['limit']:>9.3f} "
        f"{over:>12.2f} {r['cpu']:>5.2f}  {verdict}",
        flush=True,
    )


if __name__ == "__main__":
    main()
