"""A simulated controller assembled and served as ``harlsync sim`` serves it, for the
command line and for any Python caller: the simulator, its options (faults,
variants, schedule, record, battery-backed memory) and its servers (a pty and TCP,
or the family's own server).

:func:`start` raises ValueError, naming the option, for anything it cannot do;
the servers are listening when it returns; :meth:`Running.serve` then takes control
commands and waits for the end.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any, TextIO, TypeVar

from .. import families
from .control import apply_command
from .device import Device, Faults, Received, S, Simulator
from .family import ServedFamily, SimServer, project_family
from .protocol_sim import build_simulator
from .serve import PtyServer, TcpServer
from .variants import parse as parse_variants

__all__ = ["Running", "SimOptions", "listen_address", "start"]

T = TypeVar("T")


@dataclass
class SimOptions:
    """What ``harlsync sim`` is asked for, as its options give it (texts unparsed)."""

    family: str | None = None
    project: str | None = None
    seed: int = 0
    #: stations in the family's notation, comma-separated
    stations: str | None = None
    #: ``HOST:PORT`` to serve over TCP
    listen: str | None = None
    pty: bool = True
    baud: int | None = 9600
    turnaround: float = 0.0
    faults: str = ""
    variant: str = ""
    busy: bool = False
    busy_after_writes: int = 0
    #: append every request received to this file as JSON lines
    record: str | None = None
    #: keep each station's battery-backed memory in this directory
    state: str | None = None


@dataclass
class Running:
    """A simulated controller being served: stop it with :meth:`stop`."""

    sim: Device[Any]
    servers: list[PtyServer | TcpServer | SimServer] = field(default_factory=list)
    #: what a client connects to, one line each: ``pty: /dev/pts/4``, ``tcp: socket://...``
    said: list[str] = field(default_factory=list)
    _record: TextIO | None = None

    def serve(
        self,
        done: threading.Event,
        commands: Iterable[str] | None = None,
        answer: Callable[[str], None] = print,
        ended: Callable[[], None] | None = None,
    ) -> None:
        """Serve until ``done`` is set (SIGTERM), Ctrl-C, or the end of ``commands``
        (each a control command, :func:`~.control.apply_command`, its answer given to
        ``answer``; ``ended`` is told of their end), then :meth:`stop`."""

        def read_commands(lines: Iterable[str]) -> None:
            for line in lines:
                try:
                    said = apply_command(self.sim, line)
                except (ValueError, IndexError) as exc:
                    said = f"error: {exc}"
                if said:
                    answer(said)
            if ended is not None:
                ended()
            done.set()

        if commands is not None:
            threading.Thread(target=read_commands, args=(commands,), daemon=True).start()
        try:
            done.wait()
        except KeyboardInterrupt:
            pass
        self.stop()

    def stop(self) -> None:
        for server in self.servers:
            server.stop()
        if self._record is not None:
            self._record.close()


def listen_address(text: str) -> tuple[str, int]:
    """``HOST:PORT`` (``:PORT`` is 127.0.0.1) as a socket address.  Raises ValueError."""
    host, sep, port = text.rpartition(":")
    if not sep or not (port.isascii() and port.isdigit()) or int(port) > 65535:
        raise ValueError(
            f"{text!r} is not HOST:PORT (e.g. 127.0.0.1:5020; port 0 picks a free one)"
        )
    return host or "127.0.0.1", int(port)


def _option(name: str, parse: Callable[[], T]) -> T:
    try:
        return parse()
    except ValueError as exc:
        raise ValueError(f"{name}: {exc}") from None


def _build(opts: SimOptions) -> Device[Any]:
    faults = _option("--faults", lambda: Faults.parse(opts.faults))
    variant = _option("--variant", lambda: parse_variants(opts.variant))
    stations = None
    if opts.stations:
        notation = families.get(
            opts.family or (project_family(opts.project) if opts.project else None)
        )
        texts = opts.stations.split(",")
        stations = _option("--stations", lambda: [notation.parse_station(s) for s in texts])
    return _option(
        "--variant",  # the one ValueError building it raises: a variant the family lacks
        lambda: build_simulator(
            family=opts.family,
            project=opts.project,
            seed=opts.seed,
            stations=stations,
            baudrate=opts.baud or None,
            turnaround=opts.turnaround,
            faults=faults,
            busy_after_writes=opts.busy_after_writes,
            variant=variant,
        ),
    )


def _recorder(sim: Device[S], path: str) -> TextIO:
    record = open(path, "a", encoding="utf-8")  # noqa: SIM115 - closed by Running.stop

    def log_request(r: Received) -> None:
        fields = {"station": r.station, "payload": r.payload, "busy": r.busy, "client": r.client}
        record.write(json.dumps(fields) + "\n")
        record.flush()

    sim.listeners.append(log_request)
    return record


def start(opts: SimOptions) -> Running:
    """Build the simulated controller ``opts`` asks for and serve it.

    Raises ValueError naming the option at fault (``--listen ...: cannot listen
    there``), with nothing left serving; ProjectError for an unreadable project.
    """
    if not opts.pty and not opts.listen:
        raise ValueError("--no-pty needs --listen HOST:PORT")
    where = opts.listen
    listen = _option("--listen", lambda: listen_address(where)) if where else None
    sim = _build(opts)
    if opts.state:
        from .memory import keep_state

        keep_state(sim, opts.state)
    if opts.busy:
        for state in sim.stations.values():
            sim.control(sim.family.busy_verb, state, ())
    running = Running(sim)
    tcp: TcpServer | SimServer | None = None
    try:  # before the pty: an address in use is one line, with nothing left serving
        if isinstance(sim.family, ServedFamily):  # its own protocol and server
            if listen is None:
                raise ValueError(
                    f"the {sim.family.name} simulator is served over TCP only: "
                    "give --listen HOST:PORT"
                )
            tcp = sim.family.serve(sim, *listen)
        elif listen is not None:
            assert isinstance(sim, Simulator)  # a line family's simulator is a serial line
            tcp = TcpServer(sim, *listen)
    except OSError as exc:
        # socket.create_server appends the address we already name to strerror
        why = (exc.strerror or str(exc)).split(" (while attempting")[0]
        raise ValueError(f"--listen {opts.listen}: cannot listen there: {why}") from None
    if opts.record:
        running._record = _recorder(sim, opts.record)
    if isinstance(sim, Simulator) and opts.pty:
        pty = PtyServer(sim)
        running.said.append(f"pty: {pty.start()}")
        running.servers.append(pty)
    if tcp is not None:
        running.said.append(f"tcp: {tcp.start() if isinstance(tcp, TcpServer) else tcp.url}")
        running.servers.append(tcp)
    running.said.append(f"stations: {', '.join(sim.show_station(n) for n in sorted(sim.stations))}")
    return running
