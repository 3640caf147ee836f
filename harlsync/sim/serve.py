"""Serving a :class:`~harlsync.sim.Simulator` of any family over a real pty and a
real TCP socket.

The simulator decides what to answer and when (:meth:`Simulator.receive` returns
``(delay, bytes)`` chunks); these servers only move bytes and honour the delays,
so a client sees the same timing, fragments and noise on every transport.  With
wire-time emulation (``Simulator.baudrate``) the :class:`ReplyScheduler` also
paces each reply's bytes at the line's character rate.
"""

from __future__ import annotations

import logging
import os
import select
import socket
import threading
import time
import tty
from collections import deque
from collections.abc import Callable
from typing import Any

from ..timers import precise_timers
from .device import Simulator

__all__ = ["PtyServer", "ReplyScheduler", "TcpServer"]

log = logging.getLogger(__name__)

#: Reply bytes due within this many seconds of each other go out in one write.
TICK = 0.001
#: The scheduler sleeps until this long before a deadline, then spins to it.
SPIN = 0.0002


class ReplyScheduler:
    """Writes reply bytes when they fall due, in order, from one thread.

    ``put`` takes chunks as ``(delay, bytes)``: the delay after which the chunk's
    *last* byte is due.  With ``char_time`` (seconds per character on the
    emulated line) the bytes before it are paced too, one character time apart,
    as a UART sends them; bytes due within one ``tick`` of each other go out in
    one write (a 16550's FIFO or a USB adapter's latency timer groups them the
    same way, and it keeps the writes per second bounded at any baud rate).  The
    last byte of every chunk goes out at its own deadline, so the time a reply
    is complete is exact whatever the tick.  A chunk never starts before the one
    before it has finished: one line, one byte at a time.

    Deadlines are absolute, so lateness never accumulates; the thread waits
    until :data:`SPIN` before a deadline and spins the rest, with the kernel's
    timer slack lowered, so a reply is late by microseconds, not the 50-100 us a
    plain ``time.sleep`` or ``Condition.wait`` oversleeps.  Without pacing or
    delay (an un-throttled simulator) a chunk is written at once by the caller.
    """

    def __init__(
        self,
        write: Callable[[bytes], object],
        char_time: float = 0.0,
        tick: float | None = None,
    ) -> None:
        self._write = write
        self._char_time = char_time
        self._tick = TICK if tick is None else tick
        self._queue: deque[tuple[float, bytes]] = deque()  # (due, bytes), due ascending
        self._cond = threading.Condition()
        self._closed = False
        self._line_free = 0.0  # when the last byte queued so far has crossed the line
        #: paced writes made, and by how many seconds they missed their deadline in
        #: total and at worst: what the emulation itself adds to a measurement
        self.writes = 0
        self.late_total = 0.0
        self.late_worst = 0.0
        self._thread = threading.Thread(target=self._run, name="sim-replies", daemon=True)
        self._thread.start()

    def put(self, chunks: list[tuple[float, bytes]], since: float | None = None) -> None:
        """Queue ``chunks``; their delays count from ``since`` (default: now).

        Pass the time the request was read, so that the simulator's own time to
        answer is not added to the line's.
        """
        if not chunks:
            return
        now = time.monotonic()
        start = now if since is None else since
        with self._cond:
            for delay, data in chunks:
                end = max(start + delay, self._line_free + len(data) * self._char_time)
                self._line_free = end
                if end <= now and not self._queue:
                    self._send(data)
                    continue
                self._queue.extend(self._paced(data, end))
            self._cond.notify()

    def _paced(self, data: bytes, end: float) -> list[tuple[float, bytes]]:
        """``data`` as writes ``(due, bytes)``: byte i due (n-1-i) characters before ``end``."""
        step = self._char_time
        if not step or len(data) == 1:
            return [(end, data)]
        per_write = max(1, int(self._tick / step))
        out = []
        n = len(data)
        for stop in range(n % per_write or per_write, n + 1, per_write):
            out.append(
                (end - (n - stop) * step, data[stop - per_write if stop >= per_write else 0 : stop])
            )
        return out

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify()
        self._thread.join(timeout=2)

    def _send(self, data: bytes) -> None:
        try:
            self._write(data)
        except OSError as exc:
            log.debug("sim: reply not delivered: %s", exc)

    def _run(self) -> None:
        precise_timers()
        with self._cond:
            while not self._closed:
                if not self._queue:
                    self._cond.wait()
                    continue
                due, data = self._queue[0]
                wait = due - time.monotonic()
                if wait > SPIN:
                    self._cond.wait(wait - SPIN)
                    continue
                now = time.monotonic()
                while now < due:  # at most SPIN: cheaper than oversleeping
                    now = time.monotonic()
                self._queue.popleft()
                self._send(data)
                self.writes += 1
                self.late_total += now - due
                self.late_worst = max(self.late_worst, now - due)


class PtyServer:
    """The simulator behind a pseudo-terminal; clients open :attr:`device`.

    The server keeps its own handle on the slave side open, so a client can close
    and reopen the device while the simulator keeps running.
    """

    def __init__(self, sim: Simulator[Any, Any]) -> None:
        self.sim = sim
        self.device = ""
        self._master = self._slave = -1
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._replies: ReplyScheduler | None = None

    def start(self) -> str:
        """Open the pty and serve it; return the device path."""
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.device = os.ttyname(self._slave)
        self._replies = ReplyScheduler(
            lambda data: os.write(self._master, data), self.sim.char_time
        )
        self._thread = threading.Thread(target=self._serve, name="sim-pty", daemon=True)
        self._thread.start()
        log.info("sim: serving on %s", self.device)
        return self.device

    def _serve(self) -> None:
        assert self._replies is not None
        while not self._stop.is_set():
            ready, _, _ = select.select([self._master], [], [], 0.05)
            if not ready:
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:
                continue
            received = time.monotonic()
            self._replies.put(self.sim.receive(data, client="pty"), received)

    @property
    def replies(self) -> ReplyScheduler | None:
        """The scheduler writing the replies (its lateness figures), once started."""
        return self._replies

    def stop(self) -> None:
        self._stop.set()
        if self._thread:
            self._thread.join(timeout=2)
        if self._replies:
            self._replies.close()
        for fd in (self._master, self._slave):
            if fd >= 0:
                os.close(fd)
        self._master = self._slave = -1

    def __enter__(self) -> PtyServer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


class TcpServer:
    """The simulator behind a TCP socket, as a serial device server would be.

    Clients connect to :attr:`url` (``socket://host:port``).  Each connection has
    its own framing state; all share the one simulated line.
    """

    def __init__(self, sim: Simulator[Any, Any], host: str = "127.0.0.1", port: int = 0) -> None:
        self.sim = sim
        self._sock = socket.create_server((host, port))
        self.host, self.port = self._sock.getsockname()[:2]
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []

    @property
    def url(self) -> str:
        return f"socket://{self.host}:{self.port}"

    def start(self) -> str:
        """Accept connections in the background; return the ``socket://`` URL."""
        thread = threading.Thread(target=self._accept, name="sim-tcp", daemon=True)
        thread.start()
        self._threads.append(thread)
        log.info("sim: listening on %s", self.url)
        return self.url

    def serve_forever(self) -> None:
        self._accept()

    def _accept(self) -> None:
        self._sock.settimeout(0.1)
        while not self._stop.is_set():
            try:
                conn, peer = self._sock.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            log.info("sim: client %s connected", peer)
            client = f"{peer[0]}:{peer[1]}"
            thread = threading.Thread(target=self._serve, args=(conn, client), daemon=True)
            thread.start()
            self._threads.append(thread)

    def _serve(self, conn: socket.socket, client: str) -> None:
        decoder = self.sim.new_decoder()
        # Paced replies are small writes: Nagle would hold them back for the client's ACK.
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        replies = ReplyScheduler(conn.sendall, self.sim.char_time)
        conn.settimeout(0.1)
        try:
            while not self._stop.is_set():
                try:
                    data = conn.recv(4096)
                except TimeoutError:
                    continue
                except OSError:
                    break
                if not data:
                    break
                received = time.monotonic()
                replies.put(self.sim.receive(data, decoder, client), received)
        finally:
            replies.close()
            conn.close()

    def stop(self) -> None:
        self._stop.set()
        self._sock.close()
        for thread in self._threads:
            thread.join(timeout=2)

    def __enter__(self) -> TcpServer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
