"""Faults a simulated line injects into its replies: noise, drops, bad checksums,
fragments and delays, each a rate per reply drawn from one seeded generator, so a
run with the same seed injects the same faults (pymodbus's ``NullModem``
manipulator is the model)."""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields

__all__ = ["Faults"]


#: The bytes line noise is drawn from: no CR or LF (which end the frames of a
#: family that ends them so) and no STX (which starts them in another), so noise
#: is always dropped whole.
_NOISE = b"\x00\x7f\xff#*?!ZQ\x03 "


@dataclass
class Faults:
    """Fault injection on replies: each rate is a probability per reply (0-1).

    ``noise`` prefixes random bytes, ``drop`` sends nothing, ``bad_checksum``
    corrupts the checksum (wherever the family's sits), ``fragment`` splits the
    reply into pieces sent with gaps, ``slow`` delays it by ``slow_delay``
    seconds (longer than the client's deadline by default).
    """

    noise: float = 0.0
    drop: float = 0.0
    bad_checksum: float = 0.0
    fragment: float = 0.0
    slow: float = 0.0
    slow_delay: float = 1.5
    fragment_gap: float = 0.002
    seed: int | None = None
    _rng: random.Random = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        self._rng = random.Random(self.seed)

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The settings a user can give: the rates, the timings and the seed."""
        return tuple(f.name for f in fields(cls) if f.init)

    @classmethod
    def from_settings(cls, settings: Mapping[str, str]) -> Faults:
        """From name -> text (``{"noise": "0.1", "seed": "3"}``).  Raises ValueError."""
        named = dict(settings)
        unknown = set(named) - set(cls.names())
        if unknown:
            raise ValueError(
                f"unknown fault {', '.join(sorted(unknown))} (known: {', '.join(cls.names())})"
            )
        return cls(
            **{  # type: ignore[arg-type]
                name: int(value) if name == "seed" else float(value)
                for name, value in named.items()
            }
        )

    @classmethod
    def parse(cls, text: str) -> Faults:
        """From ``"noise=0.1,drop=0.05,seed=3"`` (the CLI form).  Raises ValueError."""
        pairs = (item.partition("=") for item in filter(None, text.split(",")))
        return cls.from_settings({k.strip().replace("-", "_"): v for k, _, v in pairs})

    def chance(self, rate: float) -> bool:
        """One draw from the seeded generator: True with probability ``rate``
        (for a family that applies a fault its own way)."""
        return bool(rate) and self._rng.random() < rate

    def shape(self, frame: bytes, corrupt: Callable[[bytes], bytes]) -> list[tuple[float, bytes]]:
        """The reply as chunks ``(extra delay, bytes)``; empty when dropped.

        ``corrupt`` returns the frame with a wrong checksum (the family knows where
        its checksum sits).
        """
        rng = self._rng
        if self.drop and rng.random() < self.drop:
            return []
        data = bytearray(frame)
        if self.bad_checksum and rng.random() < self.bad_checksum:
            data = bytearray(corrupt(bytes(data)))
        if self.noise and rng.random() < self.noise:
            data[:0] = bytes(rng.choice(_NOISE) for _ in range(rng.randrange(1, 8)))
        delay = self.slow_delay if self.slow and rng.random() < self.slow else 0.0
        if self.fragment and rng.random() < self.fragment and len(data) > 2:
            cuts = sorted(rng.sample(range(1, len(data)), k=min(3, len(data) - 1)))
            pieces = [bytes(data[a:b]) for a, b in zip([0, *cuts], [*cuts, len(data)])]
            return [(delay + i * self.fragment_gap, p) for i, p in enumerate(pieces)]
        return [(delay, bytes(data))]
