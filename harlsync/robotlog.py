"""Which robot a log line is about, when several are worked on at once.

``harlsync backup`` pulls the robots of separate lines in parallel threads, and
the link's lines (``opened /dev/ttyUSB0 ...``) name a port, not a robot.  Code
working on one robot runs inside :func:`about`; a handler that carries
:class:`RobotFilter` then has ``%(robot)s`` in its records: ``"press-1: "``, or
``""`` outside any robot::

    handler.addFilter(RobotFilter())
    handler.setFormatter(logging.Formatter("%(robot)s%(message)s"))
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

__all__ = ["RobotFilter", "about", "current"]

_robot: ContextVar[str | None] = ContextVar("harlsync_robot", default=None)


@contextmanager
def about(name: str) -> Iterator[None]:
    """Every log record made in this thread meanwhile is about robot ``name``."""
    token = _robot.set(name)
    try:
        yield
    finally:
        _robot.reset(token)


class RobotFilter(logging.Filter):
    """Sets ``record.robot`` to ``"NAME: "`` inside :func:`about`, else ``""``."""

    def filter(self, record: logging.LogRecord) -> bool:
        name = _robot.get()
        record.robot = f"{name}: " if name else ""
        return True


def current() -> str | None:
    """The robot this thread's log records are about now, if any (see :func:`about`)."""
    return _robot.get()
