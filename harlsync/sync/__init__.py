"""Pull, diff, plan, push and rollback: knows projects and controllers, not bytes."""

from .driver import Driver, HarlU2Driver
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
    "Driver",
    "HarlU2Driver",
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
