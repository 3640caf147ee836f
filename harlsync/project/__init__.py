"""The robot project on disk, for every family: robot.yaml, atomic saves with a
journal, YAML I/O and the schema validator.

::

    projects/<name>/
        robot.yaml            family, identity, connection, maintenance windows (user-edited)
        ...                   the family's files, laid out by its package under
                              harlsync/families/<name>/
        .schemas/             copies of the family's JSON Schemas, for editors

See docs/project-format.md for the format and how it evolves.
"""

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
