"""What every Epson test shares."""

from __future__ import annotations

import pytest

from harlsync.families.epson import profile

#: The last point a pull probes in the tests: past every range they use, and far
#: short of the profile's P999, so that a pull in a test costs a few hundred reads
#: less (tests that probe further set it themselves).
TEST_PROBE_END = 199


@pytest.fixture(autouse=True)
def shorter_probe(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(profile, "POINT_PROBE_END", TEST_PROBE_END)
