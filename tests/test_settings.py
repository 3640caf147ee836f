"""Serial settings are neutral data: no pyserial behind them, and one class,
from the settings or the link.  That their defaults are those every existing robot.yaml
was written against (the HARL-U2's) is tests/families/harl_u2/test_serial_defaults.py's."""

from __future__ import annotations

import subprocess
import sys

from harlsync.link import SerialSettings as FromTheLink
from harlsync.settings import SerialSettings


def test_the_link_still_offers_the_same_class() -> None:
    assert FromTheLink is SerialSettings


def test_the_settings_module_imports_no_pyserial() -> None:
    code = "import sys, harlsync.settings; sys.exit('serial' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr or "harlsync.settings imported pyserial"
