"""What an IAI controller can do for harlsync, as methods: version, status, read and
write positions.

A :class:`Controller` talks to one station through the shared
:class:`~harlsync.link.Link` with the IAI codec, and sends only what the codec
can encode (the profile's allow-list).  Every failure names the port, the
station (in hex) and the message: an ``&`` reply raises
:class:`~harlsync.errors.ControllerError` with its 3-hex code.

Reading the table walks the robot's position range with 22DH queries sized so
that no reply can be cut by the controller's send buffer (it could not be told
from undefined positions).  Writes (291H) are confirmed, never blindly
repeated (:func:`~harlsync.link.confirm.confirmed_write`): after a lost reply the
run is read back, and a second send first checks that the robot is still idle.

The interlock (:meth:`Controller.status`) is 215H and 212H together, as the
profile says: AUTO mode, no program running, no flash write, system ready, no
emergency stop, and no axis of the robot in use.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import TypeVar

from ...errors import ControllerError, HarlsyncError, InterlockError, ReplyError, WriteUnconfirmed
from ...link import DEFAULT_LOCK_TIMEOUT, Link
from ...link.confirm import confirmed_write
from ...settings import SerialSettings
from ..base import Progress
from . import profile
from .codec import CODEC
from .layout import IaiData
from .model import AxisStatus, Position, SystemStatus, Version, axes_refusal
from .protocol import (
    ErrorReply,
    Frame,
    Request,
    max_positions_per_read,
    read_positions,
    system_status,
    version,
    write_positions,
)
from .protocol import axis_status as axis_status_request

__all__ = ["Controller", "IaiStatus"]

log = logging.getLogger(__name__)

T = TypeVar("T")

#: 212H for every axis the controller has (it reports only those connected).
ALL_AXES = 0xFF


@dataclass(frozen=True)
class IaiStatus:
    """The interlock's answer: 215H and 212H, and the first reason not to write."""

    system: SystemStatus
    axes: tuple[AxisStatus, ...]
    refusal: str | None

    @property
    def idle(self) -> bool:
        return self.refusal is None

    def describe(self) -> str:
        return "idle" if self.refusal is None else self.refusal


class Controller:
    """One IAI controller on a link.

    ``axes`` are the robot's axes (robot.yaml); ``None`` checks every axis the
    controller reports.  ``first``/``last`` bound the position table; ``model``
    sizes the queries (its send and receive buffers).
    """

    def __init__(
        self,
        link: Link[Frame],
        *,
        model: str = profile.DEFAULT_MODEL,
        axes: tuple[int, ...] | None = None,
        first: int = profile.DEFAULT_POSITION_RANGE[0],
        last: int = profile.DEFAULT_POSITION_RANGE[1],
    ) -> None:
        self.link = link
        self.station = link.station
        self.model = model
        self.axes = axes
        self.first, self.last = first, last
        self._owns_link = False

    @classmethod
    def from_url(
        cls,
        url: str,
        station: int = profile.DEFAULT_STATION,
        settings: SerialSettings | None = None,
        *,
        lock_timeout: float = DEFAULT_LOCK_TIMEOUT,
        lock_dir: str | os.PathLike[str] | None = None,
        **options: object,
    ) -> Controller:
        """Open a link to ``url``; the controller closes it on :meth:`close`.

        Raises :class:`~harlsync.errors.PortBusyError` or :class:`~harlsync.errors.PortError`.
        """
        link = Link(url, station, settings, codec=CODEC, lock_timeout=lock_timeout,
                    lock_dir=lock_dir).open()
        controller = cls(link, **options)  # type: ignore[arg-type]
        controller._owns_link = True
        return controller

    @property
    def port(self) -> str:
        return self.link.url

    @property
    def label(self) -> str:
        return f"port {self.port} station {self.station:02X}"

    def close(self) -> None:
        if self._owns_link:
            self.link.close()

    def __enter__(self) -> Controller:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # --- the one place requests go through ---------------------------------------

    def request(self, request: Request[T]) -> T:
        """Send one request and return its typed value; ``&`` raises ControllerError."""
        value = self.link.exchange(request)
        if isinstance(value, ErrorReply):
            raise ControllerError(
                value.code, port=self.port, station=self.station, command=request.payload,
                station_text=f"{self.station:02X}",
                message=f"controller answered error {value.code}H (& reply: the command "
                        "was not carried out)",
            )
        return value

    # --- reads ----------------------------------------------------------------------

    def version(self) -> Version:
        return self.request(version())

    def status(self) -> IaiStatus:
        """215H and 212H: whether a write may go now, and if not, which bit says no.

        The two must be answered back to back.  A 212H sent again (its reply lost or
        garbled) leaves the 215H before it stale by a whole deadline or more, and
        MANUAL mode or an emergency stop since then are not in 212H's reply: both
        are read again.  When they cannot be read back to back, that is not idle.
        """
        pattern = ALL_AXES if self.axes is None else sum(1 << (a - 1) for a in self.axes)
        rounds = 1 + max(0, self.link.settings.retries)
        for _ in range(rounds):
            system = self.request(system_status())
            retries = self.link.stats.retries
            axes = self.request(axis_status_request(pattern))
            if self.link.stats.retries == retries:
                break
            log.info("%s: 212H was sent again, so the 215H before it is stale: reading both "
                     "again", self.label)
        else:
            return IaiStatus(system, axes, f"215H and 212H could not be read back to back "
                                           f"({rounds} times 212H had to be sent again)")
        refusal = system.refusal
        if refusal is None:
            wanted = self.axes if self.axes is not None else tuple(s.axis for s in axes)
            refusal = axes_refusal(wanted, axes)
        return IaiStatus(system, axes, refusal)

    def read_positions(self, head: int, count: int) -> dict[int, Position]:
        """The defined positions among ``head`` .. ``head + count - 1``, in queries
        that fit the send buffer."""
        step = max_positions_per_read(self.model)
        out: dict[int, Position] = {}
        for start in range(head, head + count, step):
            n = min(step, head + count - start)
            for position in self.request(read_positions(start, n)):
                out[position.number] = position
        return out

    def read_run(self, start: int, size: int) -> tuple[Position | None, ...]:
        """Positions ``start`` .. ``start + size - 1``, ``None`` where undefined."""
        found = self.read_positions(start, size)
        return tuple(found.get(n) for n in range(start, start + size))

    def read_all(self, progress: Progress | None = None) -> IaiData:
        """The version and every defined position of the robot's range."""
        step = max_positions_per_read(self.model)
        starts = range(self.first, self.last + 1, step)
        total = 1 + len(starts)
        data = IaiData(version=self.version(), model=self.model)
        if progress is not None:
            progress(1, total)
        for i, start in enumerate(starts, 2):
            n = min(step, self.last + 1 - start)
            for position in self.request(read_positions(start, n)):
                data.positions[position.number] = position
            if progress is not None:
                progress(i, total)
        return data

    # --- writes ---------------------------------------------------------------------

    def write_run(
        self, start: int, positions: Sequence[Position], old: Sequence[Position | None]
    ) -> None:
        """Write consecutive positions with one 291H and confirm it.

        Raises InterlockError instead of sending it again after a lost reply when
        the robot is not idle, WriteUnconfirmed when the read-back is neither.
        """
        request = write_positions(start, positions)
        if request.frame_size > profile.BUFFERS[self.model].receive:
            raise ReplyError(f"{request.payload[:12]}...: {request.frame_size} bytes do not fit "
                             f"the {self.model}'s receive buffer")
        wanted = tuple(positions)

        def sent() -> None:
            written = self.request(request)
            if written != len(positions):
                raise ControllerError(
                    str(written), port=self.port, station=self.station,
                    command=request.payload[:12], station_text=f"{self.station:02X}",
                    message=f"291H wrote {written} of {len(positions)} positions",
                )

        confirmed_write(
            sent,
            lambda: self.read_run(start, len(positions)),
            wanted,
            tuple(old),
            before_resend=lambda lost: self._idle_before_resend(request, lost),
            what=f"positions {start}-{start + len(positions) - 1}",
        )

    def _idle_before_resend(self, request: Request[int], lost: WriteUnconfirmed) -> None:
        try:
            status = self.status()
        except HarlsyncError as exc:
            why = f"cannot read the status ({exc})"
        else:
            if status.idle:
                return
            why = f"the robot is not idle: {status.describe()}"
        raise InterlockError(
            f"{self.label}, message 291H: the write did not take and {why}; "
            "not sending it again"
        ) from lost
