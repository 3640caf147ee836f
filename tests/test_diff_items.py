"""items.diff_items (issue 24: a pull again works its changes out once, and sorts
only the items that differ) against the rule it keeps: every key of either side
whose values differ, ``None`` standing for a key one side does not have, in the
catalogue's push order."""

from __future__ import annotations

from typing import Any

from conftest import examples
from hypothesis import given, settings
from hypothesis import strategies as st

from harlsync.families.harl_u2.catalogue import CATALOGUE, NumberKey
from harlsync.sync.items import diff_items

keys = st.builds(NumberKey, st.sampled_from(["timer", "offset", "register"]), st.integers(0, 20))
values = st.one_of(st.none(), st.sampled_from(["0.30", "0.50", "1.00"]))
side = st.dictionaries(keys, values, max_size=15)


def _by_the_rule(a: dict[Any, Any], b: dict[Any, Any]) -> list[tuple[Any, Any, Any]]:
    every = sorted(a.keys() | b.keys(), key=CATALOGUE.order)
    return [(k, a.get(k), b.get(k)) for k in every if a.get(k) != b.get(k)]


@settings(max_examples=examples(300))
@given(side, side)
def test_diff_items_is_the_rule_item_by_item(a: dict[Any, Any], b: dict[Any, Any]) -> None:
    got = [(c.key, c.old, c.new) for c in diff_items(CATALOGUE, a, b)]
    assert got == _by_the_rule(a, b)
