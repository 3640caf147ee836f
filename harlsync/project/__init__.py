"""The robot project on disk, for every family: robot.yaml, atomic saves with a
journal, YAML I/O and the schema validator.

::

    projects/<name>/
        robot.yaml            family, identity, connection, maintenance windows (user-edited)
        ...                   the family's files, laid out by its package under
                              harlsync/families/<name>/
        .schemas/             copies of the family's JSON Schemas, for editors

See docs/project-format.md for the format and how it evolves.

The names below are imported when first asked for (PEP 562), not with the package:
:mod:`.robot` (the Robot a line is opened for) does not bring the store, YAML and
the schemas with it, which ``harlsync pull`` needs only after its first request
(issue 24).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..lazy import attributes

if TYPE_CHECKING:
    from .robot import DAYS, Robot, Window, new_robot
    from .store import (
        Project,
        family_of,
        load_project,
        load_robot,
        migrate_project,
        project_notes,
        save_project,
        validate_project,
    )
    from .yamlio import Number

__all__ = [
    "DAYS",
    "Number",
    "Project",
    "Robot",
    "Window",
    "family_of",
    "load_project",
    "load_robot",
    "migrate_project",
    "new_robot",
    "project_notes",
    "save_project",
    "validate_project",
]

#: each public name -> the module of this package that defines it
_HOME = {
    "DAYS": "robot",
    "Robot": "robot",
    "Window": "robot",
    "new_robot": "robot",
    "Project": "store",
    "family_of": "store",
    "load_project": "store",
    "load_robot": "store",
    "migrate_project": "store",
    "project_notes": "store",
    "save_project": "store",
    "validate_project": "store",
    "Number": "yamlio",
}


__getattr__ = attributes(__name__, _HOME)
