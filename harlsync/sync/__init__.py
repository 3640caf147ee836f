"""Pull, diff, plan, push and rollback: knows projects and controllers, not bytes."""

from .engine import (
    Comparison,
    PullResult,
    PushFailed,
    PushOptions,
    PushResult,
    compare,
    plan,
    pull,
    push,
    rollback,
)
from .items import Change, diff
from .plan import Plan, PlannedWrite

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
