"""The engine's neutral serial settings are the HARL-U2's: every existing robot.yaml
was written against them (the settings' own tests are in tests/test_settings.py)."""

from __future__ import annotations

from harlsync.families.harl_u2.link import Link
from harlsync.families.harl_u2.protocol import profile
from harlsync.families.harl_u2.protocol.codec import CODEC
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


def test_the_harl_u2_codec_supplies_the_same_defaults_to_a_link_given_none() -> None:
    assert CODEC.settings == SerialSettings()
    assert Link("loop://").settings == SerialSettings()
    assert Link("loop://", settings=SerialSettings(timeout=0.5)).settings.timeout == 0.5
