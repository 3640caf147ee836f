"""A test-only controller family: its own codec, simulator, catalogue, driver,
files and schema, joining harlsync from outside it (no edit of harlsync).

:func:`register` adds it to the registry; the conformance suite does so for each
of its tests, so that the rest of the suite sees only the real families.
"""

from harlsync import families

NAME = "toy"


def register() -> None:
    families.register(NAME, __name__)
