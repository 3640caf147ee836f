"""The ``harlsync`` process spares the garbage collector at its start and its end
(issue 24: the shutdown's collections were 15-20 ms of CPU after a pull), and loses
nothing by it: its output, the atexit handlers and the logging's buffered records
all still come out.  A caller of :func:`harlsync.cli.main` with an argument list (a
test, a program) is left as it was."""

from __future__ import annotations

import gc
import shutil
import subprocess
import sys
from pathlib import Path

from harlsync.cli import main

EXAMPLE = Path(__file__).resolve().parent.parent / "projects" / "pick-and-place"

#: A harlsync process as the console script runs it (``main()``, no arguments), with
#: an atexit handler and a logging record that only logging's own atexit flush writes.
PROCESS = """
import atexit, gc, logging, logging.handlers, sys
from harlsync.cli import main

log_file = sys.argv.pop()
target = logging.FileHandler(log_file)
held = logging.handlers.MemoryHandler(1000, flushLevel=logging.CRITICAL + 1, target=target)
logging.getLogger("harlsync.test").addHandler(held)
logging.getLogger("harlsync.test").propagate = False
logging.getLogger("harlsync.test").warning("held until logging's shutdown")
atexit.register(lambda: print("atexit ran, frozen", gc.get_freeze_count() > 0, flush=True))
sys.argv = ["harlsync", *sys.argv[1:]]
sys.exit(main())
"""


def test_issue_24_the_process_ends_with_its_output_atexit_and_logging_intact(
    tmp_path: Path,
) -> None:
    project = tmp_path / "project"
    shutil.copytree(EXAMPLE, project)
    timers = project / "timers.yaml"
    timers.write_text(timers.read_text().replace("\n  0: 0.30\n", "\n  0: 12.345\n"))
    log_file = tmp_path / "held.log"
    done = subprocess.run(
        [sys.executable, "-c", PROCESS, "validate", str(project), str(log_file)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 1, done.stderr
    assert done.stdout.splitlines() == [
        "timers.yaml:4: timers.0: 12.345 is out of range (allowed: 0.00-9.99, two decimals)",
        "atexit ran, frozen True",  # after the command's own output
    ]
    assert done.stderr == f"harlsync: {project}: 1 problem(s)\n"
    assert log_file.read_text() == "held until logging's shutdown\n"


def test_issue_24_a_failing_command_still_says_why_before_the_process_ends(
    tmp_path: Path,
) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "harlsync", "validate", str(tmp_path / "none")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 2
    assert done.stderr.startswith("harlsync: error: ")
    assert "not a project directory" in done.stderr


def test_issue_24_main_with_arguments_leaves_the_collector_as_it_was(
    capsys: object,
) -> None:
    frozen = gc.get_freeze_count()
    assert main(["validate", str(EXAMPLE)]) == 0
    assert gc.get_freeze_count() == frozen
    assert gc.isenabled()
