"""Captured traffic against the real Controller: what each recorded request returns.

:func:`play` opens a :class:`~harlsync.link.Link` on a ``replay://`` URL and sends
every request of the capture, in capture order, through
:meth:`Controller.request <harlsync.families.harl_u2.controller.Controller.request>` (one
controller per station): the link and the codec meet the capture's bytes, with
its noise, fragments and silences.  The link's own retries send the recorded
retries; what is left is the next request of the capture.

Each outcome is written plain (:func:`plain`) so that it can be compared with an
expectation file, ``NAME.expect.yaml`` next to ``NAME.txt``::

    settings: {timeout: 0.3, retries: 1}      # SerialSettings the capture was taken with
    exchanges:
    - request: 1 LNM 0 3                      # station and payload, in capture order
      value: MOVE P010 S50                    # the typed value, plain
    - request: 1 LNM 9 0
      error: '21'                             # an "E"+status reply
    - request: 3 LNV
      timeout: true                           # no reply after every retry
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import yaml

from harlsync.errors import ControllerError, LinkTimeout
from harlsync.families.harl_u2.controller import Controller
from harlsync.families.harl_u2.link import Link
from harlsync.families.harl_u2.model import Config, OffsetTable, Parameters, Status, Step
from harlsync.families.harl_u2.protocol import Ack, parse_request
from harlsync.link import SerialSettings
from harlsync.sim.replay import Replay

TRAFFIC = Path(__file__).parent / "fixtures" / "traffic"


def captures() -> list[Path]:
    """Every capture in the fixture folder."""
    return sorted(TRAFFIC.glob("*.txt"))


def expect_path(capture: Path) -> Path:
    return capture.with_name(capture.stem + ".expect.yaml")


def plain(value: Any) -> Any:
    """A typed reply value as plain YAML data (steps as their text)."""
    if isinstance(value, Step):
        return value.text
    if isinstance(value, Ack):
        return {"ack": value.payload}
    if isinstance(value, Status):
        return {
            "idle": value.idle,
            "tasks": [dataclasses.asdict(t) for t in value.tasks],
        }
    if isinstance(value, (Config, OffsetTable, Parameters)):
        return dataclasses.asdict(value)
    if isinstance(value, (str, int)):
        return value
    raise TypeError(f"no plain form for {value!r}")


@dataclass(frozen=True)
class Exchange:
    """One request of the capture and what the controller API made of its reply."""

    request: str  # "station payload"
    value: Any = None
    error: ControllerError | None = None
    timeout: LinkTimeout | None = None

    def plain(self) -> dict[str, Any]:
        if self.error is not None:
            return {"request": self.request, "error": self.error.status}
        if self.timeout is not None:
            return {"request": self.request, "timeout": True}
        return {"request": self.request, "value": plain(self.value)}


def outcome(request: str, call: Callable[[], Any]) -> Exchange:
    """Run ``call()`` and keep its value, its ControllerError or its LinkTimeout."""
    try:
        return Exchange(request, value=call())
    except ControllerError as exc:
        return Exchange(request, error=exc)
    except LinkTimeout as exc:
        return Exchange(request, timeout=exc)


def play(replay: Replay, url: str, settings: SerialSettings, lock_dir: Path) -> Iterator[Exchange]:
    """Send every request of ``replay`` (served at ``url``) through the Controller.

    Raises :class:`~harlsync.errors.PortError` when the client sends something
    the capture does not hold (``replay.mismatch`` says what).
    """
    with Link(url, settings=settings, lock_dir=lock_dir) as link:
        while (frame := replay.next_request()) is not None:
            controller = Controller(link, frame.station)
            request = parse_request(frame.payload)
            yield outcome(f"{frame.station} {frame.payload}", partial(controller.request, request))


def load_expectations(capture: Path) -> tuple[SerialSettings, list[dict[str, Any]] | None]:
    """The link settings and expected exchanges for ``capture`` (None: no expectation file)."""
    path = expect_path(capture)
    if not path.exists():
        return SerialSettings(), None
    doc = yaml.safe_load(path.read_text()) or {}
    return SerialSettings(**doc.get("settings", {})), doc.get("exchanges")


def save_expectations(
    capture: Path, settings: SerialSettings, exchanges: list[dict[str, Any]], header: str
) -> None:
    doc = {
        "settings": {"timeout": settings.timeout, "retries": settings.retries},
        "exchanges": exchanges,
    }
    comment = "".join(f"# {line}\n" if line else "#\n" for line in header.splitlines())
    text = yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=100)
    expect_path(capture).write_text(comment + text)
