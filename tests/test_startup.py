"""What ``harlsync --help`` imports: every family's declaration, and nothing of
its catalogue, layout, protocol or the project store (issue 24 item 1: start-up
pays only for what the command uses)."""

from __future__ import annotations

import json
import subprocess
import sys

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
