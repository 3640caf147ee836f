"""Pull, diff, plan, push and rollback: knows projects and controllers, not bytes.

The names below are imported when first asked for (PEP 562), not with the package:
``harlsync pull`` imports :mod:`.pulling` and what it needs, and none of the push,
plan and comparison machinery, before its first request (issue 24).
"""

from __future__ import annotations

import sys
from types import ModuleType
from typing import TYPE_CHECKING

from ..lazy import attributes

if TYPE_CHECKING:
    from .comparison import Comparison, compare, plan
    from .deploy import PushFailed, PushOptions, PushResult, push, rollback
    from .items import Change, diff
    from .plan import Plan, PlannedWrite
    from .pulling import PullResult, pull

__all__ = [
    "Change",
    "Comparison",
    "Plan",
    "PlannedWrite",
    "PullResult",
    "PushFailed",
    "PushOptions",
    "PushResult",
    "compare",
    "diff",
    "plan",
    "pull",
    "push",
    "rollback",
]

#: each public name -> the module of this package that defines it
_HOME = {
    "Comparison": "comparison",
    "compare": "comparison",
    "plan": "comparison",
    "PushFailed": "deploy",
    "PushOptions": "deploy",
    "PushResult": "deploy",
    "push": "deploy",
    "rollback": "deploy",
    "Change": "items",
    "diff": "items",
    "Plan": "plan",
    "PlannedWrite": "plan",
    "PullResult": "pulling",
    "pull": "pulling",
}


__getattr__ = attributes(__name__, _HOME)


class _Package(ModuleType):
    """This package, whose ``plan`` stays :func:`.comparison.plan` when the submodule
    ``plan`` is imported (the import system sets a submodule on its package as it
    loads it; the eager ``__init__`` this replaces bound the function after)."""

    def __setattr__(self, name: str, value: object) -> None:
        if name == "plan" and isinstance(value, ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
