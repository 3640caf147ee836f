"""The reads a backup makes, each in the smallest form the controller falls back to,
and so the fewest response words a register map must give for a backup to work.

:class:`~harlsync.families.epson.controller.Controller` asks for the most a command
answers within the map's words, and for the two halves of it (60 and 61 for 59) when
RC+ assigned fewer: the halves are what a map of few words must still carry.  A read
with no halves (Weight, 302) is its own smallest form.  tests/families/epson/test_e2e.py pulls
through a map of exactly :func:`fewest_response_words` words, so a read added to the
controller and not here fails there.
"""

from __future__ import annotations

from typing import get_args

from .areas import (
    read_base,
    read_box_lower,
    read_box_upper,
    read_jrange_lower,
    read_jrange_upper,
    read_limz,
    read_local,
    read_plane,
    read_xylim_lower,
    read_xylim_upper,
)
from .points import PointAttribute, read_point_attribute, read_point_coord, read_point_j1angle
from .request import Request
from .robot import read_model_name_char, read_robot_type
from .tables import (
    read_accel,
    read_accel_r_accel,
    read_accel_r_decel,
    read_accel_s_accel,
    read_accel_s_decel,
    read_arch_approach,
    read_arch_depart,
    read_fine_123,
    read_fine_456,
    read_inertia_eccentricity,
    read_inertia_load,
    read_speed,
    read_speed_r,
    read_speed_s_approach,
    read_speed_s_speed_depart,
    read_tool,
    read_weight,
)

__all__ = ["fewest_response_words", "smallest_reads"]


def smallest_reads() -> tuple[Request[object], ...]:
    """Every read of a backup, of any manipulator, in its smallest form (table,
    area and point numbers do not change a read's size: each is shown once)."""
    return (
        read_robot_type(),
        read_model_name_char(True),
        read_accel(0),
        read_accel_s_accel(0),
        read_accel_s_decel(0),
        read_accel_r_accel(0),
        read_accel_r_decel(0),
        read_speed(0),
        read_speed_s_speed_depart(0),
        read_speed_s_approach(0),
        read_speed_r(0),
        read_weight(),
        read_inertia_load(),
        read_inertia_eccentricity(),
        read_arch_depart(0),
        read_arch_approach(0),
        read_fine_123(),
        read_fine_456(4),
        read_fine_456(6),
        read_tool(),
        read_box_lower(1, 0),
        read_box_upper(1, 0),
        read_plane(1, 0),
        read_local(1, 0),
        read_xylim_lower(0),
        read_xylim_upper(0),
        read_jrange_lower(1),
        read_jrange_upper(1),
        read_base(0),
        read_limz(),
        read_point_coord(0, 0),
        *(read_point_attribute(name, 0) for name in get_args(PointAttribute)),
        read_point_j1angle(0),
    )


def fewest_response_words() -> Request[object]:
    """The read that needs the most response words in its smallest form: a map with
    fewer cannot back the robot up (``.response_words`` is how many)."""
    return max(smallest_reads(), key=lambda request: request.response_words)
