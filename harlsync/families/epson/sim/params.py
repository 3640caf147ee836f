"""A command's words as the manual lays them out (§10): its parameters, read and
range-checked (:class:`Params`), and 32-bit values as the response words that
carry them, two a value, high first.

Only the two's complement word conversions are shared with the codec
(:func:`~harlsync.families.epson.protocol.int32_from_words`, ``int32_to_words``).
"""

from __future__ import annotations

from collections.abc import Sequence

from .. import profile
from ..protocol import int32_from_words, int32_to_words
from .codes import PARAMETER, Refused

__all__ = ["Params", "words_of", "words_of_all"]


class Params:
    """The parameters of one command (word 1 on), read as the manual lays them out."""

    def __init__(self, words: Sequence[int]) -> None:
        self.words = words

    def word(self, i: int) -> int:
        return self.words[i] if i < len(self.words) else 0

    def number(self, i: int, low: int, high: int) -> int:
        value = self.word(i)
        if not low <= value <= high:
            raise Refused(PARAMETER)
        return value

    def table(self, i: int = 1) -> int:
        """A speed/accel table number: over 15 answers 2005 (the profile)."""
        value = self.word(i)
        if value > 15:
            raise Refused(profile.TABLE_OUT_OF_RANGE)
        return value

    def int32(self, i: int) -> int:
        """Parameters ``i`` (high word) and ``i + 1`` as a 32-bit two's complement integer."""
        return int32_from_words(self.word(i), self.word(i + 1))

    def at_least(self, i: int, low: int) -> int:
        value = self.int32(i)
        if value < low:
            raise Refused(PARAMETER)
        return value


def words_of(value: int) -> tuple[int, int]:
    """A 32-bit value as its two response words, high first."""
    return int32_to_words(value)


def words_of_all(values: tuple[int, ...], which: slice = slice(None)) -> tuple[int, ...]:
    """Some of ``values`` (32-bit each) as their response words, two a value."""
    return tuple(w for value in values[which] for w in words_of(value))
