"""Serial settings are neutral data: no pyserial behind them, and defaults that
every existing robot.yaml was written against."""

from __future__ import annotations

import subprocess
import sys

from harlsync.families.harl_u2.link import Link
from harlsync.families.harl_u2.protocol import profile
from harlsync.families.harl_u2.protocol.codec import CODEC
from harlsync.link import SerialSettings as FromTheLink
from harlsync.settings import SerialSettings


def test_the_neutral_defaults_are_the_harl_u2_profiles_so_no_project_changes_meaning() -> None:
    assert SerialSettings() == SerialSettings(
        baudrate=profile.BAUDRATE,
        bytesize=profile.BYTESIZE,
        parity=profile.PARITY,
        stopbits=profile.STOPBITS,
        rtscts=profile.RTSCTS,
        timeout=profile.REPLY_TIMEOUT,
        retries=3,
    )


def test_the_link_still_offers_the_same_class() -> None:
    assert FromTheLink is SerialSettings


def test_the_settings_module_imports_no_pyserial() -> None:
    code = "import sys, harlsync.settings; sys.exit('serial' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr or "harlsync.settings imported pyserial"


def test_the_harl_u2_codec_supplies_the_same_defaults_to_a_link_given_none() -> None:
    assert CODEC.settings == SerialSettings()
    assert Link("loop://").settings == SerialSettings()
    assert Link("loop://", settings=SerialSettings(timeout=0.5)).settings.timeout == 0.5
