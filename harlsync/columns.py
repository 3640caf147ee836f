"""Text in the columns of a terminal: how wide a cell shows, and padding or cutting it
to a column, so that a table stays aligned whatever its cells hold.

``len()`` counts characters, a terminal shows columns: a robot named ``プレス1`` is
four characters and seven columns.  East Asian wide and fullwidth characters take
two columns, combining marks and zero-width characters none, every other one.
"""

from __future__ import annotations

import unicodedata

__all__ = ["fit", "ljust", "rjust", "width"]


def _columns(char: str) -> int:
    if unicodedata.combining(char) or unicodedata.category(char) in ("Mn", "Me", "Cf"):
        return 0
    return 2 if unicodedata.east_asian_width(char) in ("W", "F") else 1


def width(text: str) -> int:
    """The terminal columns ``text`` takes."""
    if text.isascii():
        return len(text)
    return sum(_columns(c) for c in text)


def ljust(text: str, columns: int) -> str:
    """``text`` padded with spaces on the right to ``columns`` columns."""
    return text + " " * max(0, columns - width(text))


def rjust(text: str, columns: int) -> str:
    """``text`` padded with spaces on the left to ``columns`` columns."""
    return " " * max(0, columns - width(text)) + text


def fit(text: str, columns: int) -> str:
    """``text`` padded to ``columns`` columns, or cut to them with an ellipsis."""
    if width(text) <= columns:
        return ljust(text, columns)
    out, used = [], 0
    for char in text:
        wide = _columns(char)
        if used + wide > columns - 1:
            break
        out.append(char)
        used += wide
    return ljust("".join(out) + "…", columns)
