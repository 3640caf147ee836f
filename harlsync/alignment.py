"""Aligning a sequence of items (a program's steps) as the robot holds it with the
project's, so that a step inserted at 4 of 17 is one insertion and what moved along
with it is the same content at another number, never a change of its own.

Diff and plan use it for the sequences a family's catalogue names
(:meth:`~harlsync.families.base.Catalogue.position`); it knows no family.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Protocol, TypeVar

__all__ = ["Kinded", "Sequences", "Shift", "align", "spans", "text_of"]


class Kinded(Protocol):
    """An item's key as aligning reads it: its ``kind`` is what the family calls an
    item of the sequence (``step``), the word a :class:`Shift` says."""

    @property
    def kind(self) -> str: ...


K_contra = TypeVar("K_contra", contravariant=True)
K = TypeVar("K", bound=Kinded)


class Sequences(Protocol[K_contra]):
    """What aligning asks of a family's catalogue: where an item sits in a sequence."""

    def position(self, key: K_contra) -> tuple[str, int] | None: ...


def text_of(value: object) -> str | None:
    """An item's value as its files write it: ``.text`` when it has one, else str()."""
    if value is None:
        return None
    text = getattr(value, "text", None)
    return text if isinstance(text, str) else str(value)


@dataclass(frozen=True)
class Shift:
    """Items inserted, deleted or moved in a sequence (a program's steps), found by
    aligning the robot's sequence with the project's: what moved along with them is
    the same content at another number, never a change of its own.

    ``lines`` are the diff lines of what really differs (``("+", 4, "WAIT DI05 ON")``);
    ``rewrites`` the positions a push writes because of it (their content changed).
    """

    group: str
    #: ``insert at 4``, ``delete at 6``, ``move 3 to 9``, joined with ``, ``
    what: str
    #: ``steps 4-16 move to 5-17``: what moved along, robot's numbers to the project's
    moved: list[str]
    lines: list[tuple[str, int, str]]
    rewrites: list[int]


def spans(numbers: Iterable[int]) -> str:
    """``[4, 5, 6, 9]`` -> ``"4-6, 9"``."""
    parts: list[str] = []
    run: list[int] = []
    for n in [*sorted(set(numbers)), None]:
        if run and (n is None or n != run[-1] + 1):
            parts.append(str(run[0]) if len(run) == 1 else f"{run[0]}-{run[-1]}")
            run = []
        if n is not None:
            run.append(n)
    return ", ".join(parts)


def _tokens(texts: dict[int, str | None], lo: int, hi: int) -> list[tuple[str, object]]:
    """Positions lo..hi of one side as tokens: a changed item its text, an unchanged
    one a placeholder equal only to itself on the other side; empty items past the
    side's last used one left out (the sequence ends there)."""
    out: list[tuple[str, object]] = []
    for n in range(lo, hi + 1):
        if n not in texts:
            out.append(("=", n))
        else:
            out.append(("t", texts[n]))
    while out and out[-1] == ("t", None):
        out.pop()
    return out


def align(catalogue: Sequences[K], changes: Iterable[tuple[K, object, object]]) -> list[Shift]:
    """The insertions, deletions and moves among ``changes`` in each of the family's
    sequences (``Catalogue.position``), one :class:`Shift` per stretch of items
    they move along: an alignment of the changed stretch (difflib), so that a step
    inserted at 4 of 17 is one insertion, not 14 changed steps.  A shift names the
    sequence's items by their keys' ``kind``, as the family does."""
    import difflib  # not at import: every command imports this module

    groups: dict[str, tuple[dict[int, str | None], dict[int, str | None]]] = {}
    words: dict[str, str] = {}
    for key, old, new in changes:
        where = catalogue.position(key)
        if where is not None:
            olds, news = groups.setdefault(where[0], ({}, {}))
            olds[where[1]], news[where[1]] = text_of(old), text_of(new)
            words.setdefault(where[0], key.kind)
    out: list[Shift] = []
    for group, (olds, news) in groups.items():
        word = words[group]
        lo, hi = min(olds), max(olds)
        a, b = _tokens(olds, lo, hi), _tokens(news, lo, hi)
        ops = difflib.SequenceMatcher(None, a, b, autojunk=False).get_opcodes()
        region: list[tuple[str, int, int, int, int]] = []
        for op in ops:
            tag, i1, i2, j1, j2 = op
            if tag != "equal" or j1 != i1 or region:
                region.append(op)
            if region and j2 - i2 == 0:
                shift = _shift(group, region, a, b, lo, hi, olds, word)
                if shift is not None:
                    out.append(shift)
                region = []
        if region:
            shift = _shift(group, region, a, b, lo, hi, olds, word)
            if shift is not None:
                out.append(shift)
    return out


def _shift(
    group: str,
    region: list[tuple[str, int, int, int, int]],
    a: list[tuple[str, object]],
    b: list[tuple[str, object]],
    lo: int,
    hi: int,
    olds: dict[int, str | None],
    word: str,
) -> Shift | None:
    """One stretch of opcodes whose items are out of step, or None when nothing in it
    moves along (a plain change, or an item added or cleared at the end: the ordinary
    diff says it)."""
    if all(tag in ("equal", "replace") and i2 - i1 == j2 - j1 for tag, i1, i2, j1, j2 in region):
        return None
    lines: list[tuple[str, int, str]] = []
    said: list[_Op] = []
    moved: list[str] = []
    for tag, i1, i2, j1, j2 in region:
        if tag == "equal":
            if i1 != j1:
                moved.append(_moved(word, lo + i1, lo + i2 - 1, lo + j1, lo + j2 - 1))
            continue
        for i in range(i1, i2):
            if a[i][0] == "t" and a[i][1] is not None:
                lines.append(("-", lo + i, str(a[i][1])))
        for j in range(j1, j2):
            if b[j][0] == "t" and b[j][1] is not None:
                lines.append(("+", lo + j, str(b[j][1])))
        if tag == "insert":
            said.append(_Op("insert", lo + j1, tuple(b[j1:j2])))
        elif tag == "delete":
            said.append(_Op("delete", lo + i1, tuple(a[i1:i2])))
        else:
            said.append(_Op("replace", lo + i1, span=(lo + i2 - 1, lo + j1, lo + j2 - 1)))
    if not moved:
        return None  # an item added or cleared at the end: nothing moves along
    what = _what(said, word)
    first = lo + min(min(i1, j1) for _, i1, _, j1, _ in region)
    last = lo + max(max(i2, j2) for _, _, i2, _, j2 in region) - 1
    if region[-1][4] - region[-1][2] != 0:
        last = hi  # nothing brings the rest back in step: it shifts to the end
    rewrites = [n for n in olds if first <= n <= last]
    return Shift(group, what, moved, lines, sorted(rewrites))


def _moved(word: str, i1: int, i2: int, j1: int, j2: int) -> str:
    if i1 == i2:
        return f"{word} {i1} moves to {j1}"
    return f"{word}s {i1}-{i2} move to {j1}-{j2}"


@dataclass(frozen=True)
class _Op:
    kind: str  # "insert" | "delete" | "replace"
    at: int
    items: tuple[tuple[str, object], ...] = ()
    #: a replace: the robot's last position, the project's first and last
    span: tuple[int, int, int] = (0, 0, 0)


def _what(said: list[_Op], word: str) -> str:
    parts: list[tuple[int, str]] = []
    rest = list(said)
    # A deletion and an insertion of the same one item: a move.
    for d in [s for s in said if s.kind == "delete" and len(s.items) == 1]:
        match = next((s for s in rest if s.kind == "insert" and s.items == d.items), None)
        if match is not None and d in rest:
            rest.remove(d)
            rest.remove(match)
            parts.append((d.at, f"move {d.at} to {match.at}"))
    for op in rest:
        if op.kind == "replace":
            end, j1, j2 = op.span
            said_ = f"replace {spans(range(op.at, end + 1))} with {spans(range(j1, j2 + 1))}"
            parts.append((op.at, said_))
            continue
        n = len(op.items)
        parts.append(
            (op.at, f"{op.kind} at {op.at}" if n == 1 else f"{op.kind} {n} {word}s at {op.at}")
        )
    return ", ".join(text for _, text in sorted(parts))
