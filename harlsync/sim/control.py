"""Mode control of a running simulator, one text command at a time.

``harlsync sim`` reads these from its standard input, so a person or a test can
make a robot busy while a client is connected.  Every family takes::

    status                      one line per station: its mode, the writes carried out,
                                and the BUSY-after-writes schedule when one is armed
    BUSY-after-writes N         make the written station busy after N more writes, once
                                (BUSY is the family's busy verb: auto-after-writes, run-after-writes)
    stop [STATION]              every family's verb for idle; it disarms the schedule too

and its own verbs (:attr:`~harlsync.sim.SimFamily.verbs`), each with the
station first (the family's notation; default: the lowest station), e.g.
``auto [STATION [TASK]]`` or ``manual [STATION]``.
"""

from __future__ import annotations

from .device import Device, S

__all__ = ["IDLE_VERB", "after_writes_verb", "apply_command", "describe"]

#: Every family's verb that makes a station idle; it disarms ``BUSY-after-writes``.
IDLE_VERB = "stop"


def after_writes_verb(busy_verb: str) -> str:
    """The schedule's verb for a family whose busy verb is ``busy_verb``."""
    return f"{busy_verb}-after-writes"


def describe(sim: Device[S]) -> str:
    with sim.lock:
        armed = sim.armed
        schedule = "" if armed is None else f"; {sim.family.busy_verb} after {armed} more writes"
        return (
            "; ".join(
                f"station {sim.show_station(n)}: {sim.describe(s)}"
                for n, s in sorted(sim.stations.items())
            )
            + f"; {sim.writes} writes received{schedule}"
        )


def apply_command(sim: Device[S], line: str) -> str:
    """Carry out one control command; return what to show.  Raises ValueError."""
    words = line.split()
    if not words:
        return ""
    family = sim.family
    verb, args = words[0].lower(), words[1:]
    schedule = after_writes_verb(family.busy_verb)
    with sim.lock:
        if verb == "status":
            return describe(sim)
        if verb == schedule:
            (count,) = (int(a) for a in args)
            sim.busy_after_writes = sim.writes + count
            return f"{family.busy_verb} after {count} more writes"
        if verb not in {v.name for v in family.verbs}:
            known = ", ".join([*(v.name for v in family.verbs), schedule, "status"])
            raise ValueError(f"unknown command {verb!r} ({known})")
        station = sim.parse_station(args[0]) if args else min(sim.stations)
        if station not in sim.stations:
            raise ValueError(f"no station {sim.show_station(station)}")
        sim.control(verb, sim.stations[station], args[1:])
        if verb == IDLE_VERB:  # idle means idle: no switch to busy scheduled behind it
            sim.busy_after_writes = 0
    return describe(sim)
