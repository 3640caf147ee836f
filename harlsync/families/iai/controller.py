"""What an IAI controller can do for harlsync, as methods: version, status, read and
write positions, the global flags and integer and real variables, and string
variables; read coordinate systems.

A :class:`Controller` talks to one station through the shared
:class:`~harlsync.link.Link` with the IAI codec, and sends only what the codec
can encode (the profile's allow-list).  Every failure names the port, the
station (in hex) and the message: an ``&`` reply raises
:class:`~harlsync.errors.ControllerError` with its 3-hex code.

The controller is built in layers, a module each: :mod:`.station` sends the
requests, reads by number and reads the status; :mod:`.backup_read` reads a
whole backup and how far each table goes; this module writes.  Writes (291H,
24BH, 24CH, 24DH, 24EH) are confirmed, never blindly repeated
(:func:`~harlsync.link.confirm.confirmed_write`): after a lost reply what was
written is read back, and a second send first checks that the robot is still
idle.

The interlock (:meth:`Controller.status`) is 212H then 215H, back to back (215H
last, so MANUAL mode and an emergency stop are the freshest read): AUTO mode, no
program running, no flash write, system ready, no emergency stop, no critical
error, drive source on, program (not positioner) mode, safety gate closed, and
every axis of the robot reported and not in use.  With no axes in robot.yaml the
robot's axes are every axis any 212H has reported (this session, and the pulls
before it: controller.yaml ``axes``) and every axis a position read or written
uses: an axis reported once and then left out of a reply is not idle.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import TypeVar

from ...errors import (
    ControllerError,
    HarlsyncError,
    InterlockError,
    NotWritten,
    ReplyError,
    SyncError,
    WriteRefused,
    WriteUnconfirmed,
)
from ...link import DEFAULT_LOCK_TIMEOUT, Link
from ...link.confirm import confirmed_write, refuse_unless_idle
from ...settings import SerialSettings
from . import profile
from .backup_read import BackupRead
from .codec import CODEC
from .model import Position, real_value
from .protocol import (
    Request,
    real_to_wire,
    write_flag,
    write_integers,
    write_positions,
    write_reals,
    write_strings,
)
from .station import ERROR_CODE_NOTE

__all__ = ["Controller"]

T = TypeVar("T")


def _numbers(one: str, several: str, start: int, count: int) -> str:
    """``position 7``, ``positions 7-9``: what a write of ``count`` items from ``start`` is."""
    return f"{one} {start}" if count == 1 else f"{several} {start}-{start + count - 1}"


class _AxisUnseen(InterlockError, NotWritten):
    """A write refused before it was sent: it moves an axis 212H did not report."""


class Controller(BackupRead):
    """One IAI controller on a link.

    ``axes`` are the robot's axes (robot.yaml); ``None`` checks every axis the
    controller reports.  ``first``/``last`` bound the position table; ``model``
    sizes the queries (its send and receive buffers).  ``variables`` are the
    flags and variables :meth:`read_all` reads when asked, by section
    (``flags``, ``integers``, ``reals``) -> (first, last); the profile's by default.
    ``known_axes`` are the axes earlier 212H replies reported (controller.yaml's
    ``axes``): with no ``axes``, every later reply must report them too.
    """

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
        link = Link(
            url, station, settings, codec=CODEC, lock_timeout=lock_timeout, lock_dir=lock_dir
        ).open()
        controller = cls(link, **options)  # type: ignore[arg-type]
        controller._owns_link = True
        return controller

    # --- writes ---------------------------------------------------------------------

    def writing_order(self, start: int, values: Sequence[float]) -> str:
        """:meth:`word_order`, for writing ``values``; raises SyncError (nothing
        sent) when nothing tells the order and a value differs between the two."""
        if self.real_word_order or self._seen_word_order or self.recorded_word_order:
            return self.word_order()
        for i, value in enumerate(values):
            words = real_to_wire(value)
            if words[:8] != words[8:]:
                raise SyncError(
                    f"{self.label}: real variable {start + i} is not written: the controller's "
                    "real variables read 0 (or alike in both word orders), so harlsync cannot "
                    "tell in which order it keeps their words (p.24); set "
                    "controller.real_word_order in robot.yaml (upper-first, or lower-first on "
                    "an X-SEL-J/K V0.41 or earlier or with Other parameter No. 46 bits 0-3 at 0)"
                )
        return self.word_order()

    def write_run(
        self, start: int, positions: Sequence[Position], old: Sequence[Position | None]
    ) -> None:
        """Write consecutive positions with one 291H and confirm it.

        Raises InterlockError instead of sending it again after a lost reply when
        the robot is not idle, WriteUnconfirmed when the read-back is neither, and
        before sending it (nothing written) when it moves an axis the status read
        just before did not report.
        """
        self.note_axes(positions)
        what = _numbers("position", "positions", start, len(positions))
        self._refuse_unseen_axes(positions, what)
        self._confirmed(
            write_positions(start, positions),
            len(positions),
            lambda: self.read_run(start, len(positions)),
            tuple(positions),
            tuple(old),
            what,
        )

    def _refuse_unseen_axes(self, positions: Sequence[Position], what: str) -> None:
        """Refuse (nothing sent) positions with an axis the last 212H did not report
        idle: with no axes in robot.yaml, a new position's axis is known only now."""
        last = self._last_status
        if last is None or not last.idle:
            return  # the engine's interlock went first: nothing to add
        reported = {s.axis for s in last.axes}
        for position in positions:
            unseen = sorted(set(position.axes) - reported)
            if unseen:
                raise _AxisUnseen(
                    f"{self.label}: axis {unseen[0]} not reported by 212H before writing "
                    f"{what}: an axis it does not report cannot be seen to be idle; not writing"
                )

    def write_flag(self, number: int, on: bool, old: bool) -> None:
        """Set or clear one global flag with 24BH and confirm it, as :meth:`write_run`."""
        self._confirmed(
            write_flag(number, on),
            None,
            lambda: self.read_flags(number, number)[number],
            on,
            old,
            f"flag {number}",
        )

    def write_strings(self, start: int, row: str, old: str | None) -> None:
        """Write the string variable columns of one row from ``start`` (two hex
        digits a column, as records.yaml keeps it) with one 24EH and confirm it,
        as :meth:`write_run`."""
        codes = [int(row[i : i + 2], 16) for i in range(0, len(row), 2)]
        last = start + len(codes) - 1
        self._confirmed(
            write_strings(start, codes),
            None,
            lambda: self.read_string_rows(start, last)[start],
            row,
            old,
            _numbers("string variable column", "string variable columns", start, len(codes)),
        )

    def write_integers(self, start: int, values: Sequence[int], old: Sequence[int]) -> None:
        """Write consecutive global integer variables with one 24CH and confirm it,
        as :meth:`write_run`."""
        last = start + len(values) - 1
        self._confirmed(
            write_integers(start, values),
            len(values),
            lambda: tuple(self.read_integers(start, last).values()),
            tuple(values),
            tuple(old),
            _numbers("integer variable", "integer variables", start, len(values)),
        )

    def write_reals(self, start: int, values: Sequence[str], old: Sequence[str]) -> None:
        """Write consecutive global real variables (exact text) with one 24DH and
        confirm it, as :meth:`write_run`.  Raises ValueError for NaN or an infinity."""
        last = start + len(values) - 1
        doubles = [real_value(v) for v in values]
        self._confirmed(
            write_reals(start, doubles, order=self.writing_order(start, doubles)),
            len(values),
            lambda: tuple(self.read_reals(start, last).values()),
            tuple(values),
            tuple(old),
            _numbers("real variable", "real variables", start, len(values)),
        )

    def _confirmed(
        self,
        request: Request[int | None],
        count: int | None,
        readback: Callable[[], T],
        wanted: T,
        old: T,
        what: str,
    ) -> None:
        """Send one write, ``count`` items when its reply says how many, and confirm it.

        An ``&`` reply raises WriteRefused (not written) only when the items read
        back exactly as they were; otherwise ControllerError (may or may not have been).
        """
        if request.frame_size > profile.BUFFERS[self.model].receive:
            raise ReplyError(
                f"{request.payload[:12]}...: {request.frame_size} bytes do not fit "
                f"the {self.model}'s receive buffer"
            )

        def sent() -> None:
            try:
                written = self.request(request, what)
            except WriteRefused as refused:
                self._refused_unless_unchanged(refused, readback, old, what)
                raise
            if count is not None and written != count:
                raise ControllerError(
                    str(written),
                    port=self.port,
                    station=self.station,
                    command=f"{request.message_id:03X}H",
                    station_text=f"{self.station:02X}",
                    message=f"{request.message_id:03X}H wrote {written} of {count} ({what})",
                )

        confirmed_write(
            sent,
            readback,
            wanted,
            old,
            before_resend=lambda lost: self._idle_before_resend(request, lost),
            what=what,
        )

    def _refused_unless_unchanged(
        self, refused: WriteRefused, readback: Callable[[], T], old: T, what: str
    ) -> None:
        """Return when ``what`` reads back exactly as before the refused write (it was
        not written); otherwise raise ControllerError: it may or may not have been.

        That the controller applies a write it answers ``&`` to whole or not at all
        is only the profile's assumption for 291H, and not even that for 24CH/24DH:
        the read-back is the evidence.
        """
        try:
            now = readback()
        except HarlsyncError as exc:
            why = f"and it could not be read back ({exc})"
        else:
            if now == old:
                return
            why = "and it no longer reads back as it was before"
        raise ControllerError(
            refused.status,
            port=self.port,
            station=self.station,
            command=refused.command,
            station_text=f"{self.station:02X}",
            message=(
                f"{what} may or may not have been written: the controller refused it "
                f"with error code {refused.status}H ({ERROR_CODE_NOTE}), {why}; pull to "
                "see what the controller holds"
            ),
        ) from refused

    def _idle_before_resend(self, request: Request[int | None], lost: WriteUnconfirmed) -> None:
        """Raise InterlockError unless the status, read now, shows the robot idle."""
        refuse_unless_idle(
            self.status,
            lost,
            where=f"{self.label}, message {request.message_id:03X}H",
            reading="the status",
        )
