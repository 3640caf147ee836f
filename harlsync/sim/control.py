"""Mode control of a running simulator, one text command at a time.

``harlsync sim`` reads these from its standard input, so a person or a test can
put a robot into automatic operation while a client is connected::

    auto [STATION [TASK]]       task in execution (automatic operation)
    suspend [STATION [TASK]]    task suspended
    stop [STATION]              every task stopped: the robot is idle
    auto-after-writes N         switch to automatic after N more SN writes
    status                      one line per station: idle / automatic, writes received
"""

from __future__ import annotations

from ..families.harl_u2.sim.device import Simulator

__all__ = ["apply_command", "describe"]


def describe(sim: Simulator) -> str:
    with sim.lock:
        return "; ".join(
            f"station {n}: {'automatic' if s.automatic else 'idle'}"
            for n, s in sorted(sim.stations.items())
        ) + f"; {sim.writes} writes received"


def apply_command(sim: Simulator, line: str) -> str:
    """Carry out one control command; return what to show.  Raises ValueError."""
    words = line.split()
    if not words:
        return ""
    verb, args = words[0].lower(), [int(w) for w in words[1:]]
    with sim.lock:
        if verb == "status":
            return describe(sim)
        if verb == "auto-after-writes":
            (count,) = args
            sim.auto_after_writes = sim.writes + count
            return f"automatic after {count} more writes"
        station = args[0] if args else min(sim.stations)
        if station not in sim.stations:
            raise ValueError(f"no station {station}")
        state = sim.stations[station]
        task = args[1] if len(args) > 1 else 0
        if verb == "auto":
            state.start_task(task)
        elif verb == "suspend":
            state.suspend_task(task)
        elif verb == "stop":
            state.stop_all()
        else:
            raise ValueError(f"unknown command {verb!r} (auto, suspend, stop, auto-after-writes, status)")
    return describe(sim)
