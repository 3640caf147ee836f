"""The robot project on disk: YAML files, their schemas, validation, load and save.

::

    projects/<name>/
        robot.yaml            identity, connection, maintenance windows (user-edited)
        controller.yaml       version and program configuration (LNV, LNX)
        parameters.yaml       the 13 expanded parameters (LNE)
        offsets.yaml          offset tables 0-99, one per line (LNL)
        timers.yaml           timer values, one per line (LNT)
        registers.yaml        register values, only with keep_registers (LND)
        programs/start.yaml   one file per program: main-00.yaml, sub-03.yaml, hand-01.yaml ...
        .schemas/             copies of the JSON Schemas, for editors

See docs/project-format.md for the format and how it evolves.
"""

from ..families.harl_u2.layout import FORMAT, program_key, program_path, render_files, render_program
from .robot import DAYS, Robot, Window, new_robot
from .store import Project, load_project, load_robot, save_project, validate_project
from .yamlio import Number

__all__ = [
    "DAYS",
    "FORMAT",
    "Number",
    "Project",
    "Robot",
    "Window",
    "load_project",
    "load_robot",
    "new_robot",
    "program_key",
    "program_path",
    "render_files",
    "render_program",
    "save_project",
    "validate_project",
]
