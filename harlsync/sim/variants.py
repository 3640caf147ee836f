"""Where a manual is silent, a simulated controller can answer more than one way.

Every choice a family's profile makes where its manual says nothing (the status a
missing table answers, a refusal or an empty reply past a table, word order,
pacing) is a *guess*.  A simulator that only ever makes the profile's guess
checks harlsync against the world it was built from, so each family's simulator
declares a :class:`Variant` per guess, with every way a controller might fill
that silence, the profile's own first.  ``harlsync sim --variant NAME=VALUE``,
the ``sim://`` query (``?NAME=VALUE``) and the test harness choose among them;
docs/profile.md lists them beside the robot.yaml setting that covers each.

A device holds its choice in :attr:`~harlsync.sim.device.Device.variant`
(name -> value, every name present), and its family reads it where it answers.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass

__all__ = ["Variant", "choose", "combinations", "defaults", "parse", "singles"]


@dataclass(frozen=True)
class Variant:
    """One guess a simulator can make differently: its name, the values it can
    take (the family profile's choice first) and what it varies, in a few words."""

    name: str
    values: tuple[str, ...]
    does: str

    @property
    def default(self) -> str:
        return self.values[0]

    def __str__(self) -> str:
        return f"{self.name}={'|'.join(self.values)}"


def defaults(declared: Sequence[Variant]) -> dict[str, str]:
    """Every variant at the profile's choice."""
    return {v.name: v.default for v in declared}


def choose(declared: Sequence[Variant], chosen: Mapping[str, str]) -> dict[str, str]:
    """``chosen`` checked against ``declared`` and completed with the defaults.

    Raises ValueError naming the unknown variant or value and what is allowed.
    """
    by_name = {v.name: v for v in declared}
    result = defaults(declared)
    for name, value in chosen.items():
        key = name.strip().replace("-", "_")
        variant = by_name.get(key)
        if variant is None:
            known = ", ".join(str(v) for v in declared) or "none"
            raise ValueError(f"unknown variant {name} (this family's: {known})")
        if value not in variant.values:
            raise ValueError(f"variant {key}: {value} is not one of {', '.join(variant.values)}")
        result[key] = value
    return result


def parse(text: str) -> dict[str, str]:
    """``"a=1,b=2"`` (the CLI form) as a mapping.  Raises ValueError for a pair
    without ``=``."""
    result: dict[str, str] = {}
    for item in filter(None, (part.strip() for part in text.split(","))):
        name, sep, value = item.partition("=")
        if not sep or not name or not value:
            raise ValueError(f"{item}: give NAME=VALUE")
        result[name.strip()] = value.strip()
    return result


def singles(declared: Sequence[Variant]) -> Iterator[dict[str, str]]:
    """The profile's choices, then each other value of each variant on its own:
    every value appears once (the default test run)."""
    yield {}
    for variant in declared:
        for value in variant.values[1:]:
            yield {variant.name: value}


def combinations(declared: Sequence[Variant]) -> Iterator[dict[str, str]]:
    """Every combination of every variant's values (the full matrix, for slow runs)."""
    names = [v.name for v in declared]
    for values in itertools.product(*(v.values for v in declared)):
        yield dict(zip(names, values))
