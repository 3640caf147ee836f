"""Epson Remote Control command and response words, sans I/O.

How this works::

    command words: holding registers command_base .. +7, written in one write
      word   0        1         2         3      ...  7
             number   param 1   param 2   param 3     param 7     unused words 0
             003BH    000FH     0000H     0000H       0000H       59: AccelS table 15

    response words: input registers response_base .. +7, read in one read
      word   0        1           2           3      4      5
             003BH    000FH       0001H 871BH        0003H 0D40H   echo, table, accel, decel
             echo     Response 1  Response 2                       set/register: 0000H, 0000H
             echo     code        detail      ExtCmdResult 1: an error, always 3 words (§7)

    a real value: round(x * 1000) as a 32-bit two's complement integer in two
    words, high word first
             100.123  -> 0001H 871BH          -100.003 -> FFFEH 795DH

Word 0 of a command is its number; word 0 of the response echoes it, and a
response that does not is an error (:class:`~harlsync.errors.ReplyError`).
Real values are exact decimal text with three decimals (``"100.123"``),
converted with integer arithmetic only, never a float.

A :class:`Request` is one command and knows its reply type: ``decode`` turns
the response words into a typed value, or an :class:`ErrorReply` when the
controller set ExtCmdResult (Response 1 and 2 kept raw, with the §7.1
meaning).  A write is a :class:`WriteSequence`: one command, or a split write
(S1/S2, R1/R2) or an Rn sequence (one coordinate a command), whose commands go
out back to back: the controller applies them at the last one and cancels them
silently if any other command comes in between.  Where the map has too few
command words for the one-command form, the split form is chosen.

The allow-list: :data:`COMMANDS` holds every command this family sends, the
backup reads and the deploy writes, each a subset of the digest's lists.
:func:`encode` refuses any other number (motion, jog, teach, power, motor,
reset, outputs, memory I/O, the point-overwriting 554-557, 2051, 2052 ...), and
so does :class:`Request`: nothing off the two lists can be put on the wire.

Requests, one builder per command (backup reads, then deploy writes)::

    read_accel 3        read_accel_s 59 (60, 61)    read_accel_r 109 (110, 111)
    read_speed 153      read_speed_s 209 (210, 211) read_speed_r 253
    read_weight 302     read_inertia 353 (354, 355) read_arch 403 (404, 405)
    read_fine 453 (454, 455)  read_tool 501   read_box 603 (604, 605)
    read_plane 651      read_local 701   read_xylim 753 (754, 755)
    read_jrange 803 (804, 805)  read_base 851  read_limz 1251
    read_robot_type 2153  read_model_name_char 2154
    read_controller_error 2155  read_control_device 2156 (the interlock's)
    read_point_coord 1222  read_point_attribute 1215-1220, 1224, 1226
    read_point_j1angle 1228

    register_accel 1    register_accel_s 53 | 54+55  register_accel_r 103 | 104+105
    register_speed 151  register_speed_s 203 | 204+205  register_speed_r 251
    set_weight 300 | 301  set_inertia 350 | 351+352  set_arch 400 | 401+402
    set_fine 450 | 451+452  select_tool 500  set_box 600 xyz | 601 xyz + 602 xyz
    set_plane 650 x..w  set_local 700 x..w  set_xylim 750 xyz | 751 xyz + 752 xyz
    set_jrange 800 | 801+802  set_base 850 x..w  set_limz 1250
    set_point_coord 1204  set_point_attribute 1206-1214, 1223, 1225
    set_point_j1angle 1227

The package, a module a job: :mod:`.numbers` (real values and words),
:mod:`.codes` (response codes, the error reply), :mod:`.allowlist` (what may and
must never be sent), :mod:`.request` (commands, requests, write sequences), and
the builders by manual section: :mod:`.tables` (§10.1-10.11), :mod:`.areas`
(§10.13-10.18, §10.26), :mod:`.robot` (§8.5) and :mod:`.points` (§10.25).
"""

from .allowlist import BACKUP_READS, COMMANDS, DEPLOY_WRITES, NEVER_SEND, CommandSpec, refusal
from .areas import (
    Limits,
    PulseLimits,
    read_base,
    read_box,
    read_box_lower,
    read_box_upper,
    read_jrange,
    read_jrange_lower,
    read_jrange_upper,
    read_limz,
    read_local,
    read_plane,
    read_xylim,
    read_xylim_lower,
    read_xylim_upper,
    set_base,
    set_box,
    set_jrange,
    set_limz,
    set_local,
    set_plane,
    set_xylim,
)
from .codes import (
    FUNCTION_ERROR,
    FUNCTION_ERROR_DETAILS,
    RESPONSE_CODES,
    ErrorReply,
    ResponseCode,
    describe_code,
)
from .numbers import (
    COORDINATES,
    MAX_WORDS,
    REAL_MAX,
    REAL_MIN,
    canonical_real,
    int32_from_words,
    int32_to_words,
    real_from_words,
    real_text,
    real_to_words,
    real_units,
)
from .points import (
    POINT_ATTRIBUTES,
    PointAttribute,
    read_point_attribute,
    read_point_coord,
    read_point_j1angle,
    set_point_attribute,
    set_point_coord,
    set_point_j1angle,
)
from .request import Command, Request, WriteSequence, encode
from .robot import (
    CONTROL_DEVICES,
    REMOTE_IO,
    ROBOT_TYPES,
    NameChar,
    read_control_device,
    read_controller_error,
    read_model_name_char,
    read_robot_type,
)
from .tables import (
    AccelPercent,
    AccelReal,
    Distances,
    Inertia,
    SpeedPercent,
    SpeedReal,
    Weight,
    read_accel,
    read_accel_r,
    read_accel_r_accel,
    read_accel_r_decel,
    read_accel_s,
    read_accel_s_accel,
    read_accel_s_decel,
    read_arch,
    read_arch_approach,
    read_arch_depart,
    read_fine,
    read_fine_123,
    read_fine_456,
    read_inertia,
    read_inertia_eccentricity,
    read_inertia_load,
    read_speed,
    read_speed_r,
    read_speed_s,
    read_speed_s_approach,
    read_speed_s_speed_depart,
    read_tool,
    read_weight,
    register_accel,
    register_accel_r,
    register_accel_s,
    register_speed,
    register_speed_r,
    register_speed_s,
    select_tool,
    set_arch,
    set_fine,
    set_inertia,
    set_weight,
)

__all__ = [
    "BACKUP_READS",
    "COMMANDS",
    "CONTROL_DEVICES",
    "COORDINATES",
    "DEPLOY_WRITES",
    "FUNCTION_ERROR",
    "FUNCTION_ERROR_DETAILS",
    "MAX_WORDS",
    "NEVER_SEND",
    "POINT_ATTRIBUTES",
    "REAL_MAX",
    "REAL_MIN",
    "REMOTE_IO",
    "RESPONSE_CODES",
    "ROBOT_TYPES",
    "AccelPercent",
    "AccelReal",
    "Command",
    "CommandSpec",
    "Distances",
    "ErrorReply",
    "Inertia",
    "Limits",
    "NameChar",
    "PointAttribute",
    "PulseLimits",
    "Request",
    "ResponseCode",
    "SpeedPercent",
    "SpeedReal",
    "Weight",
    "WriteSequence",
    "canonical_real",
    "describe_code",
    "encode",
    "int32_from_words",
    "int32_to_words",
    "read_accel",
    "read_accel_r",
    "read_accel_r_accel",
    "read_accel_r_decel",
    "read_accel_s",
    "read_accel_s_accel",
    "read_accel_s_decel",
    "read_arch",
    "read_arch_approach",
    "read_arch_depart",
    "read_base",
    "read_box",
    "read_box_lower",
    "read_box_upper",
    "read_control_device",
    "read_controller_error",
    "read_fine",
    "read_fine_123",
    "read_fine_456",
    "read_inertia",
    "read_inertia_eccentricity",
    "read_inertia_load",
    "read_jrange",
    "read_jrange_lower",
    "read_jrange_upper",
    "read_limz",
    "read_local",
    "read_model_name_char",
    "read_plane",
    "read_point_attribute",
    "read_point_coord",
    "read_point_j1angle",
    "read_robot_type",
    "read_speed",
    "read_speed_r",
    "read_speed_s",
    "read_speed_s_approach",
    "read_speed_s_speed_depart",
    "read_tool",
    "read_weight",
    "read_xylim",
    "read_xylim_lower",
    "read_xylim_upper",
    "real_from_words",
    "real_text",
    "real_to_words",
    "real_units",
    "refusal",
    "register_accel",
    "register_accel_r",
    "register_accel_s",
    "register_speed",
    "register_speed_r",
    "register_speed_s",
    "select_tool",
    "set_arch",
    "set_base",
    "set_box",
    "set_fine",
    "set_inertia",
    "set_jrange",
    "set_limz",
    "set_local",
    "set_plane",
    "set_point_attribute",
    "set_point_coord",
    "set_point_j1angle",
    "set_weight",
    "set_xylim",
]
