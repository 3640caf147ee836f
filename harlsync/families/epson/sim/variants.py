"""How the simulated Epson controller fills its manual's silences: the variants
it declares to the framework (:mod:`harlsync.sim.variants`; the profile's choice
first) and what each chosen value makes it do."""

from __future__ import annotations

from collections.abc import Mapping

from ....sim.variants import Variant
from .codes import EXECUTION, PARAMETER, PointAnswers

__all__ = [
    "CARD_WRITES",
    "UNDEFINED_POINT_DETAIL",
    "VARIANTS",
    "card_write_time",
    "point_answers",
    "whole_writes",
]

#: The commands that write the controller's memory card (digest §2: Weight,
#: Inertia, Tool, Box, Plane, XYLim, JRange, Base): the ``write_time`` variant
#: makes them slow.
CARD_WRITES = frozenset(
    {300, 301, 350, 351, 352, 500, 502, 600, 601, 602, 650, 750, 751, 752, 800, 801, 802, 850}
)
#: Command execution error 200A's Response 2 for a point not defined, in the
#: ``undefined_point=200A`` variant: a controller error code (the manual sends the
#: reader to its separate error list); this one is made up, as a real one would be.
UNDEFINED_POINT_DETAIL = 7103
#: The variants' answers: value -> (Response 1, Response 2).
_UNDEFINED_POINT = {
    "2004": (PARAMETER, 0),
    "200A": (0x200A, UNDEFINED_POINT_DETAIL),
    "2000": (EXECUTION, 0),
}
_PAST_POINTS = {"2004": (PARAMETER, 0), "2005": (0x2005, 0)}
_WRITE_TIMES = {"2ms": None, "300ms": 0.3}

VARIANTS: tuple[Variant, ...] = (
    Variant(
        "undefined_point",
        tuple(_UNDEFINED_POINT),
        "what a point not defined answers (1222, 1215-1220): 2004 parameter error, "
        f"200A command execution error with a controller error code ({UNDEFINED_POINT_DETAIL}), "
        "or 2000 execution error",
    ),
    Variant(
        "past_points",
        tuple(_PAST_POINTS),
        "what a point number past the controller's point table (P1000) answers: 2004 "
        "parameter error or 2005 out of range",
    ),
    Variant(
        "write_time",
        tuple(_WRITE_TIMES),
        "how long a command that writes the memory card runs (Weight, Tool, Box ...): "
        "2 ms as every other, or 300 ms",
    ),
    Variant(
        "modbus_writes",
        ("whole", "per-register"),
        "whether the Modbus slave hands a write of several registers to the Remote "
        "inputs whole, or a register at a time in address order",
    ),
)


def point_answers(chosen: Mapping[str, str], last: int) -> PointAnswers:
    """How points not there are answered, as the ``chosen`` variants say, on a
    point table that ends at ``last``."""
    return PointAnswers(
        _UNDEFINED_POINT[chosen["undefined_point"]], _PAST_POINTS[chosen["past_points"]], last
    )


def card_write_time(chosen: Mapping[str, str], number: int) -> float | None:
    """The seconds command ``number`` runs when it writes the memory card and the
    ``write_time`` variant makes that slow; None: as any other command."""
    card = _WRITE_TIMES[chosen["write_time"]]
    return card if number in CARD_WRITES else None


def whole_writes(chosen: Mapping[str, str]) -> bool:
    """Whether the Modbus slave hands a write of several registers over whole."""
    return chosen["modbus_writes"] == "whole"
