"""A simulated Epson controller's battery-backed memory: what survives a power
cycle (everything but the six tables and LimZ, §9.1, §10.26), as a JSON
document (:func:`memory_of`, :func:`from_memory`) kept in a station's state
directory (:func:`save`, :func:`load`)::

    {"robot_type": 3, "model": "G6-551S", "arch": {"0": [30000, 30000], ...},
     "fine": [10, 10, 10, 10], "weight": [2000, 0], ..., "points": {"0":
     {"coords": [...], "hand": 1, ...}}}

Values are as the controller carries them on the wire (thousandths, JRange in
pulses); numbered entries are keyed by their number as text.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path

from .point import Point
from .state import Limits, SimState, three_axes

__all__ = ["MEMORY_FILE", "from_memory", "load", "memory_of", "save"]

#: The file a station's battery-backed memory is kept in, in its state directory.
MEMORY_FILE = "memory.json"


def memory_of(state: SimState) -> dict[str, object]:
    """What survives a power cycle, as JSON data (the tables and LimZ do not)."""
    return {
        "robot_type": state.robot_type,
        "model": state.model,
        "arch": {str(n): list(v) for n, v in sorted(state.arch.items())},
        "fine": list(state.fine),
        "weight": list(state.weight),
        "inertia": list(state.inertia),
        "tool": state.tool,
        "boxes": {str(n): [list(a) for a in v] for n, v in sorted(state.boxes.items())},
        "planes": {str(n): list(v) for n, v in sorted(state.planes.items())},
        "locals": {str(n): list(v) for n, v in sorted(state.locals.items())},
        "xylim": [list(a) for a in state.xylim],
        "jrange": [list(a) for a in state.jrange],
        "base": list(state.base),
        "points": {str(n): _point_memory(p) for n, p in sorted(state.points.items())},
    }


def _point_memory(point: Point) -> dict[str, object]:
    return {
        "coords": list(point.coords),
        "hand": point.hand,
        "elbow": point.elbow,
        "wrist": point.wrist,
        "j4flag": point.j4flag,
        "j6flag": point.j6flag,
        "local": point.local,
        "j1flag": point.j1flag,
        "j2flag": point.j2flag,
        "j1angle": point.j1angle,
    }


def from_memory(doc: Mapping[str, object]) -> SimState:
    """The controller :func:`memory_of` kept, as it comes up after a power cycle:
    tables empty, LimZ 0, idle.  Raises ValueError, KeyError or TypeError for
    a document that is not one."""

    def mapping(key: str) -> Mapping[str, object]:
        value = doc[key]
        if not isinstance(value, Mapping):
            raise TypeError(f"{key} is not a mapping")
        return value

    points = {int(n): _point_from_memory(n, item) for n, item in mapping("points").items()}
    return SimState(
        robot_type=_integer(doc["robot_type"]),
        model=str(doc["model"]),
        arch={int(n): _pair(_ints(v)) for n, v in mapping("arch").items()},
        fine=_ints(doc["fine"]),
        weight=_pair(_ints(doc["weight"])),
        inertia=_pair(_ints(doc["inertia"])),
        tool=_integer(doc["tool"]),
        boxes={int(n): three_axes(_pairs(v)) for n, v in mapping("boxes").items()},
        planes={int(n): _ints(v) for n, v in mapping("planes").items()},
        locals={int(n): _ints(v) for n, v in mapping("locals").items()},
        xylim=three_axes(_pairs(doc["xylim"])),
        jrange=_pairs(doc["jrange"]),
        base=_ints(doc["base"]),
        points=points,
    )


def _point_from_memory(number: str, item: object) -> Point:
    if not isinstance(item, Mapping):
        raise TypeError(f"point {number} is not a mapping")
    return Point(
        _ints(item["coords"]),
        *(_integer(item[k]) for k in ("hand", "elbow", "wrist", "j4flag", "j6flag", "local")),
        # kept by a simulator since issue 20; an older memory file has none
        *(_integer(item.get(k, 0)) for k in ("j1flag", "j2flag", "j1angle")),
    )


def save(state: SimState, directory: Path) -> None:
    """Write what ``state`` keeps over a power cycle to ``directory/memory.json``
    (a new file renamed over the old one: a kill never leaves half of it)."""
    directory.mkdir(parents=True, exist_ok=True)
    temp = directory / f".{MEMORY_FILE}.{os.getpid()}"
    temp.write_text(json.dumps(memory_of(state), indent=1) + "\n")
    os.replace(temp, directory / MEMORY_FILE)


def load(path: Path) -> SimState:
    """The controller the memory file at ``path`` kept, as it comes up after a power
    cycle.  Raises OSError, ValueError, KeyError or TypeError for a file that cannot
    be read or is not a simulator memory."""
    return from_memory(json.loads(path.read_text(encoding="utf-8")))


def _integer(value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"{value!r} is not a whole number")
    return value


def _ints(value: object) -> tuple[int, ...]:
    if not isinstance(value, list):
        raise TypeError(f"{value!r} is not a list")
    return tuple(_integer(v) for v in value)


def _pairs(value: object) -> tuple[Limits, ...]:
    if not isinstance(value, list):
        raise TypeError(f"{value!r} is not a list")
    return tuple(_pair(_ints(v)) for v in value)


def _pair(values: tuple[int, ...]) -> tuple[int, int]:
    if len(values) != 2:
        raise ValueError(f"{list(values)} is not a pair")
    return values[0], values[1]
