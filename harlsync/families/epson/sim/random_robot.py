"""What :meth:`~.state.SimState.generate` fills a realistic robot with, drawn from
one random stream: table entries, the settings a plant leaves (arches, Fine,
Weight, boxes, planes, locals, limits) and points in runs with gaps.

Values are in the controller's wire units (thousandths, JRange in encoder
pulses).  The draws are made in the order :meth:`~.state.SimState.generate`
asks for them, so that a seed always gives the same robot.
"""

from __future__ import annotations

import random
from collections.abc import Iterable

from .point import Point

__all__ = ["Draw"]

_Limits = tuple[int, int]


class Draw:
    """Values drawn from ``rng``, each method a setting's worth."""

    def __init__(self, rng: random.Random) -> None:
        self.rng = rng

    def real(self, low: float, high: float) -> int:
        """A real from ``low`` to ``high``, in thousandths."""
        return self.rng.randint(round(low * 1000), round(high * 1000))

    def some(self, count: tuple[int, int], numbers: Iterable[int]) -> list[int]:
        """Between ``count[0]`` and ``count[1]`` of ``numbers``, in order."""
        pool = list(numbers)
        return sorted(self.rng.sample(pool, self.rng.randint(*count)))

    # --- the six tables: some entries of each registered -----------------------------------

    def percent_pairs(self, count: tuple[int, int]) -> dict[int, tuple[int, int]]:
        rng = self.rng
        return {
            t: (rng.randint(10, 120), rng.randint(10, 120)) for t in self.some(count, range(16))
        }

    def real_pairs(
        self, count: tuple[int, int], low: float, high: float
    ) -> dict[int, tuple[int, int]]:
        return {
            t: (self.real(low, high), self.real(low, high)) for t in self.some(count, range(16))
        }

    def percent_triples(self, count: tuple[int, int]) -> dict[int, tuple[int, int, int]]:
        rng = self.rng
        return {
            t: (rng.randint(1, 100), rng.randint(1, 100), rng.randint(1, 100))
            for t in self.some(count, range(16))
        }

    def real_triples(
        self, count: tuple[int, int], low: float, high: float
    ) -> dict[int, tuple[int, int, int]]:
        r = self.real
        return {t: (r(low, high), r(low, high), r(low, high)) for t in self.some(count, range(16))}

    def reals(self, count: tuple[int, int], low: float, high: float) -> dict[int, int]:
        return {t: self.real(low, high) for t in self.some(count, range(16))}

    # --- the settings ------------------------------------------------------------------------

    def limz(self) -> int:
        return 0 if self.rng.random() < 0.5 else -self.real(0, 80)

    def arches(self) -> dict[int, tuple[int, int]]:
        """Some of Arch 0-6 changed from their defaults."""
        return {a: (self.real(0, 100), self.real(0, 100)) for a in self.some((0, 3), range(7))}

    def fine(self, axes: int) -> tuple[int, ...]:
        return tuple(self.rng.choice((10, 10, 10, 20, 50, 100, 1000)) for _ in range(axes))

    def weight(self, arm_length: bool) -> tuple[int, int]:
        return self.real(0.5, 6), self.real(0, 150) if arm_length else 0

    def inertia(self) -> tuple[int, int]:
        return self.real(0.001, 0.1), self.real(0, 150)

    def box(self) -> tuple[_Limits, _Limits, _Limits]:
        def axis() -> _Limits:
            low = self.rng.randint(-400_000, 300_000)
            return low, low + self.rng.randint(10_000, 300_000)

        return axis(), axis(), axis()

    def frame(self, axes: int) -> tuple[int, ...]:
        """X, Y, Z in thousandths of a mm, then U (V, W) in thousandths of a degree."""
        rng = self.rng
        xyz = tuple(rng.randint(-300_000, 300_000) for _ in range(3))
        return xyz + tuple(
            rng.choice((0, 0, rng.randint(-180_000, 180_000))) for _ in range(axes - 3)
        )

    def frames(self, count: tuple[int, int], axes: int) -> dict[int, tuple[int, ...]]:
        """Some of planes (locals) 1-15 defined."""
        return {n: self.frame(axes) for n in self.some(count, range(1, 16))}

    def xylim(self) -> tuple[_Limits, _Limits, _Limits]:
        """Off more often than not."""
        if self.rng.random() < 0.6:
            return (0, 0), (0, 0), (0, 0)
        real = self.real
        return (
            (-real(100, 600), real(100, 600)),
            (-real(100, 600), real(100, 600)),
            (-real(0, 300), real(0, 100)),
        )

    def jrange(self, axes: int) -> tuple[_Limits, ...]:
        rng = self.rng
        return tuple(
            (-rng.randint(500_000, 4_000_000), rng.randint(500_000, 7_000_000)) for _ in range(axes)
        )

    def base(self, axes: int) -> tuple[int, ...]:
        """All 0 more often than not."""
        return (0,) * axes if self.rng.random() < 0.7 else self.frame(axes)

    # --- points ------------------------------------------------------------------------------

    def points(
        self, axes: int, point_range: tuple[int, int], locals_defined: list[int]
    ) -> dict[int, Point]:
        """Runs of 2 to 20 points with gaps of 1 to 15 over ``point_range``."""
        rng, points = self.rng, {}
        first, last = point_range
        number = first + rng.randrange(3)
        while number <= last:
            for n in range(number, min(number + rng.randint(2, 20), last + 1)):
                points[n] = self.point(axes, locals_defined)
            number = max(points) + 1 + rng.randint(1, 15)
        return points

    def point(self, axes: int, locals_defined: list[int]) -> Point:
        rng = self.rng
        if axes == 4:
            coords: tuple[int, ...] = (
                rng.randint(-500_000, 500_000),
                rng.randint(100_000, 600_000),
                rng.randint(-200_000, 0),
                rng.randint(-180_000, 180_000),
            )
            return Point(
                coords, hand=rng.randint(0, 1), local=rng.choice([0, 0, 0, *locals_defined])
            )
        coords = (
            rng.randint(-700_000, 700_000),
            rng.randint(-700_000, 700_000),
            rng.randint(-100_000, 900_000),
            *(rng.randint(-180_000, 180_000) for _ in range(3)),
        )
        return Point(
            coords,
            hand=rng.randint(0, 1),
            elbow=rng.randint(0, 1),
            wrist=rng.randint(0, 1),
            j4flag=rng.choice((0, 0, 1)),
            j6flag=rng.choice((0, 0, 0, 1, 2)),
            local=rng.choice([0, 0, 0, *locals_defined]),
        )
