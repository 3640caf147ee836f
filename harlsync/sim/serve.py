"""Serving a :class:`~harlsync.sim.Simulator` over a real pty and a real TCP socket.

The simulator decides what to answer and when (:meth:`Simulator.receive` returns
``(delay, bytes)`` chunks); these servers only move bytes and honour the delays,
so a client sees the same timing, fragments and noise on every transport.
"""

from __future__ import annotations

import heapq
import itertools
import logging
import os
import select
import socket
import threading
import time
import tty
from collections.abc import Callable

from ..protocol import FrameDecoder
from .device import Simulator

__all__ = ["PtyServer", "ReplyScheduler", "TcpServer"]

log = logging.getLogger(__name__)


class ReplyScheduler:
    """Writes reply chunks when they fall due, in order, from one thread."""

    def __init__(self, write: Callable[[bytes], object]) -> None:
        self._write = write
        self._heap: list[tuple[float, int, bytes]] = []
        self._seq = itertools.count()
        self._cond = threading.Condition()
        self._closed = False
        self._last_due = 0.0
        self._thread = threading.Thread(target=self._run, name="sim-replies", daemon=True)
        self._thread.start()

    def put(self, chunks: list[tuple[float, bytes]]) -> None:
        now = time.monotonic()
        with self._cond:
            for delay, data in chunks:
                # Never let a later chunk overtake an earlier one on the wire.
                due = max(now + delay, self._last_due)
                self._last_due = due
                heapq.heappush(self._heap, (due, next(self._seq), data))
            self._cond.notify()

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify()
        self._thread.join(timeout=2)

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._closed and (
                    not self._heap or self._heap[0][0] > time.monotonic()
                ):
                    timeout = self._heap[0][0] - time.monotonic() if self._heap else None
                    self._cond.wait(timeout)
                if self._closed:
                    return
                _, _, data = heapq.heappop(self._heap)
            try:
                self._write(data)
            except OSError as exc:
                log.debug("sim: reply not delivered: %s", exc)


class PtyServer:
    """The simulator behind a pseudo-terminal; clients open :attr:`device`.

    The server keeps its own handle on the slave side open, so a client can close
    and reopen the device while the simulator keeps running.
    """

    def __init__(self, sim: Simulator) -> None:
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
        self._replies = ReplyScheduler(lambda data: os.write(self._master, data))
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
            self._replies.put(self.sim.receive(data, client="pty"))

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

    def __init__(self, sim: Simulator, host: str = "127.0.0.1", port: int = 0) -> None:
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
        decoder = FrameDecoder()
        replies = ReplyScheduler(conn.sendall)
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
                replies.put(self.sim.receive(data, decoder, client))
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
