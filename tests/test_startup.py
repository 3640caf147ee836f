"""What ``harlsync --help`` imports: every family's declaration, and nothing of
its catalogue, layout, protocol or the project store (issue 24 item 1: start-up
pays only for what the command uses)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

#: ``--help`` of every command, then the modules it left imported.
HELP = """
import contextlib, io, json, sys
from harlsync.cli import build_parser
parser = build_parser()
for argv in (["--help"], ["pull", "--help"], ["push", "--help"], ["backup", "--help"]):
    with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):
        parser.parse_args(argv)
print(json.dumps(sorted(m for m in sys.modules if m.startswith(("harlsync", "yaml")))))
"""


def test_help_imports_the_families_declarations_and_not_their_catalogues() -> None:
    done = subprocess.run([sys.executable, "-c", HELP], capture_output=True, text=True, check=True)
    loaded = json.loads(done.stdout)
    assert {"harlsync.families.epson.family", "harlsync.families.iai.family"} <= set(loaded)
    assert "harlsync.families.harl_u2.family" in loaded
    heavy = [
        m
        for m in loaded
        if m.startswith(("yaml", "harlsync.project"))
        or m.rsplit(".", 1)[-1] in ("catalogue", "layout", "model", "protocol", "codec")
    ]
    assert heavy == []


#: A pull's engine imported, then what of the push machinery came with it.
PULL = """
import json, sys
from harlsync.sync import pulling
print(json.dumps(sorted(m for m in sys.modules if m.startswith("harlsync.sync."))))
"""


def test_issue_24_the_pull_engine_imports_none_of_the_push_plan_and_comparison_machinery() -> None:
    done = subprocess.run([sys.executable, "-c", PULL], capture_output=True, text=True, check=True)
    loaded = set(json.loads(done.stdout))
    assert "harlsync.sync.pulling" in loaded
    assert loaded.isdisjoint(
        {
            "harlsync.sync.comparison",
            "harlsync.sync.deploy",
            "harlsync.sync.plan",
            "harlsync.sync.writes",
        }
    )


#: The package's names, looked up with the module that defines one failing to import.
FAILING = """
import importlib.abc, sys

class Broken(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name == "harlsync.sync.deploy":
            raise ImportError("deploy is broken here")
        return None

sys.meta_path.insert(0, Broken())
import harlsync.sync as sync
print(sync.pull.__module__, sync.plan.__module__, flush=True)
sync.PushOptions
"""


def test_issue_24_a_name_whose_module_fails_to_import_raises_that_import_error() -> None:
    done = subprocess.run(
        [sys.executable, "-c", FAILING], capture_output=True, text=True, check=False
    )
    assert done.stdout == "harlsync.sync.pulling harlsync.sync.comparison\n"
    assert done.returncode == 1
    assert done.stderr.rstrip().endswith("ImportError: deploy is broken here")


def test_issue_24_a_pull_process_still_takes_the_line_lock_and_says_so_in_one_line(
    tmp_path: Path,
) -> None:
    from harlsync.families.harl_u2.link import Link
    from harlsync.families.harl_u2.sim import SimState, Simulator
    from harlsync.sim.serve import PtyServer

    locks = tmp_path / "locks"
    env = dict(os.environ, HARLSYNC_LOCK_DIR=str(locks))
    server = PtyServer(Simulator(SimState.generate(1)))
    with server, Link(server.device, 1, lock_dir=locks):  # another harlsync on the line
        done = subprocess.run(
            [sys.executable, "-m", "harlsync", "pull", str(tmp_path / "cell")]
            + ["--port", server.device, "--lock-timeout", "0"],
            capture_output=True,
            text=True,
            env=env,
            check=False,
        )
    assert done.returncode == 2
    assert done.stderr.startswith(f"harlsync: error: port {server.device}: in use by ")
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
    assert not (tmp_path / "cell" / "robot.yaml").exists()
