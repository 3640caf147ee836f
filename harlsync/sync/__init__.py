"""Pull, diff, plan, push and rollback: knows projects and controllers, not bytes."""

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
