"""Issue 31: ``harlsync probe`` against every family's simulator and every variant.

From the simulator's own record: the probe sends no write, whichever way the
controller fills its manual's silences; and ``probe --write DIR`` followed by
``pull DIR`` backs the robot up with no setting typed by hand.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from harlsync import cli, families
from harlsync.errors import ProtocolError
from harlsync.project import load_project
from harlsync.sim.device import LineFamily, Simulator

from .harness import HARNESSES, join, served, variant_cases
from .test_conformance import writes_since


def _probe(family: str, url: str, station: int, *extra: str) -> int:
    fam = families.get(family)
    return cli.main(
        [
            "probe",
            "--port",
            url,
            "--family",
            family,
            "--station",
            fam.format_station(station),
            *extra,
        ]
    )


@pytest.mark.parametrize(("family", "variant"), variant_cases())
def test_issue_31_the_probe_sends_only_reads_to_every_variant_of_every_family(
    family: str, variant: dict[str, str], monkeypatch: pytest.MonkeyPatch
) -> None:
    join(family, monkeypatch)
    HARNESSES[family].quick(monkeypatch)
    with served(family, 21, variant) as (device, station, url):
        assert _probe(family, url, station) == 0
        assert writes_since(device, 0) == []
        # a simulator that counts its register accesses too (a Modbus slave's
        # handshake signals are written without a command): none was a write
        accesses = getattr(device, "accesses", None)
        if accesses is not None:
            assert accesses()["write"] == 0


@pytest.mark.parametrize(
    ("family", "variant"),
    [case for case in variant_cases() if case.values[0] in families.names()],
)
def test_issue_31_probe_write_then_pull_backs_up_every_variant_with_no_setting_typed(
    family: str,
    variant: dict[str, str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    join(family, monkeypatch)
    HARNESSES[family].quick(monkeypatch)
    project = tmp_path / "cell"
    with served(family, 21, variant) as (device, station, url):
        assert _probe(family, url, station, "--write", str(project)) == 0
        assert (project / "robot.yaml").read_text().startswith("# Written by harlsync probe")
        assert cli.main(["pull", str(project)]) == 0, capsys.readouterr().err
        assert writes_since(device, 0) == []
    loaded = load_project(project)
    assert loaded.robot.family in (family, "")


@pytest.mark.parametrize("family", [n for n in families.names() if not families.get(n).schemes])
def test_issue_31_a_probe_capture_of_every_serial_family_replays(
    family: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    join(family, monkeypatch)
    capture = tmp_path / "probe.txt"
    with served(family, 21) as (_device, station, url):
        assert _probe(family, url, station, "--json", "--capture", str(capture)) == 0
        live = json.loads(capsys.readouterr().out)
    replay = f"replay://{capture}?timing=0&family={family}"
    assert _probe(family, replay, station, "--json") == 0, capsys.readouterr().err
    replayed = json.loads(capsys.readouterr().out)
    timing = ("turnaround_seconds", "pull_seconds", "held_seconds", "port")
    assert {k: v for k, v in replayed.items() if k not in timing} == {
        k: v for k, v in live.items() if k not in timing
    }


def _at_another_rate(data: bytes, sent: int, heard: int, phase: float) -> bytes:
    """The bytes a UART at ``heard`` baud makes of ``data`` sent at ``sent`` baud, 8N1:
    it waits for a start bit (a falling edge), samples each bit's middle at its own
    rate, and takes the character whatever its stop bit (a framing error is still a
    byte on most ports).  ``phase`` (0-1 of a bit) shifts where its clock starts."""
    bits = [1] * 3
    for byte in data:
        bits += [0, *((byte >> i) & 1 for i in range(8)), 1]
    bits += [1] * 12
    length = len(bits) / sent

    def level(t: float) -> int:
        i = int(t * sent)
        return bits[i] if 0 <= i < len(bits) else 1

    out, t, step = bytearray(), phase / heard, 1 / heard
    while t < length:
        if level(t) == 1 or level(t - step) == 0:  # no falling edge here
            t += step / 4
            continue
        value = sum(level(t + (1.5 + i) * step) << i for i in range(8))
        out.append(value)
        t += 9.5 * step
    return bytes(out)


RATES = (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200)


@pytest.mark.parametrize("family", [n for n in families.names() if not families.get(n).schemes])
def test_issue_31_the_probe_s_reads_at_a_wrong_baud_rate_never_decode_as_a_write(
    family: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """At a wrong baud rate the controller hears the probe's bytes as noise: every
    request the probe sent (its own capture), heard at every other rate the manuals
    list and at several clock phases, is fed to the family's request decoder, and no
    frame it makes of them is a write (from the simulator's own judgement)."""
    from harlsync.sim import sim_family
    from harlsync.sim.replay import load_spy_log

    join(family, monkeypatch)
    capture = tmp_path / "probe.txt"
    with served(family, 21) as (device, station, url):
        assert _probe(family, url, station, "--capture", str(capture)) == 0
    # the identity reads, which are what a probe sends at a rate it is trying
    sent = [c.data for c in load_spy_log(capture) if c.direction == "TX"][:3]
    assert sent
    side = sim_family(family)
    assert isinstance(side, LineFamily) and isinstance(device, Simulator)  # no schemes
    for rate in RATES:  # the model of the line: at the same rate, the reads themselves
        assert [_at_another_rate(f, rate, rate, 0.5) for f in sent] == sent
    for rate in RATES:
        for heard in RATES:
            if heard == rate:
                continue
            for phase in (0.0, 0.5):
                decoder = side.decoder()
                decoder.feed(b"".join(_at_another_rate(f, rate, heard, phase) for f in sent))
                for _ in range(1000):  # each call takes a frame or fails on one
                    try:
                        frame = decoder.next_frame()
                    except ProtocolError:
                        continue
                    if frame is None:
                        break
                    assert not device.is_write(frame), (rate, heard, frame.payload)
