"""The Epson Remote Control codec: golden words written by hand from the manual's
examples, the allow-list, two's complement at its edges, and decoding that never
fails but with a ReplyError."""

from __future__ import annotations

import inspect
from collections.abc import Callable
from functools import partial
from typing import Any

import pytest
from conftest import examples
from hypothesis import given, settings
from hypothesis import strategies as st

from harlsync.errors import ReplyError
from harlsync.families.epson import protocol as p
from harlsync.families.epson.protocol import (
    AccelPercent,
    AccelReal,
    Command,
    Distances,
    ErrorReply,
    Inertia,
    Limits,
    NameChar,
    PulseLimits,
    Request,
    SpeedPercent,
    SpeedReal,
    Weight,
    WriteSequence,
)

H = int  # a word as the manual prints it: 0x871B is "871BH"

# --- golden reads ---------------------------------------------------------------------
# (request, the command words, the response words from word 0, the value).  Each
# row is the manual's own example where it is right (the section is named), or,
# where the digest lists the example as wrong, the same values written by hand
# from the command's word table (marked "fixed").  None is made by our encoder.
ACCEL_VALUES = AccelReal("100.123", "200.000")
READS: list[tuple[str, Request[Any], tuple[H, ...], tuple[H, ...], object]] = [
    # §10.1 command 3: the manual prints 0004H for 100 (fixed)
    (
        "3 fixed",
        p.read_accel(1),
        (0x0003, 0x0001),
        (0x0003, 0x0001, 0x0064, 0x0050),
        AccelPercent(100, 80),
    ),
    # §10.2 commands 59, 60; 61's command is printed 003CH (fixed), its response is right
    (
        "59",
        p.read_accel_s(15),
        (0x003B, 0x000F),
        (0x003B, 0x000F, 0x0001, 0x871B, 0x0003, 0x0D40),
        ACCEL_VALUES,
    ),
    ("60", p.read_accel_s_accel(15), (0x003C, 0x000F), (0x003C, 0x000F, 0x0001, 0x871B), "100.123"),
    (
        "61 fixed",
        p.read_accel_s_decel(15),
        (0x003D, 0x000F),
        (0x003D, 0x000F, 0x0003, 0x0D40),
        "200.000",
    ),
    # §10.3 commands 110, 111 (109's example lost a word in the OCR: fixed)
    (
        "109 fixed",
        p.read_accel_r(1),
        (0x006D, 0x0001),
        (0x006D, 0x0001, 0x0001, 0x871B, 0x0003, 0x0D40),
        ACCEL_VALUES,
    ),
    ("110", p.read_accel_r_accel(1), (0x006E, 0x0001), (0x006E, 0x0001, 0x0001, 0x871B), "100.123"),
    ("111", p.read_accel_r_decel(1), (0x006F, 0x0001), (0x006F, 0x0001, 0x0003, 0x0D40), "200.000"),
    # §10.4 command 153
    (
        "153",
        p.read_speed(1),
        (0x0099, 0x0001),
        (0x0099, 0x0001, 0x0064, 0x0050, 0x0032),
        SpeedPercent(100, 80, 50),
    ),
    # §10.5 commands 210, 211 ("00001H" read as 0001H); 209's example lost a word (fixed)
    (
        "209 fixed",
        p.read_speed_s(1),
        (0x00D1, 0x0001),
        (0x00D1, 0x0001, 0x0001, 0x86A1, 0x0000, 0xC352, 0x0000, 0xEA63),
        SpeedReal("100.001", "50.002", "60.003"),
    ),
    (
        "210",
        p.read_speed_s_speed_depart(1),
        (0x00D2, 0x0001),
        (0x00D2, 0x0001, 0x0001, 0x86A1, 0x0000, 0xC352),
        ("100.001", "50.002"),
    ),
    (
        "211",
        p.read_speed_s_approach(1),
        (0x00D3, 0x0001),
        (0x00D3, 0x0001, 0x0000, 0xEA63),
        "60.003",
    ),
    # §10.6 command 253
    ("253", p.read_speed_r(1), (0x00FD, 0x0001), (0x00FD, 0x0001, 0x000F, 0x4240), "1000.000"),
    # §10.7 command 302, §10.8 commands 353-355 (354 headed "Command 353")
    (
        "302",
        p.read_weight(),
        (0x012E,),
        (0x012E, 0x0000, 0x1400, 0x0001, 0xD4C1),
        Weight("5.120", "120.001"),
    ),
    (
        "353",
        p.read_inertia(),
        (0x0161,),
        (0x0161, 0x0000, 0x1400, 0x0001, 0xD4C1),
        Inertia("5.120", "120.001"),
    ),
    ("354", p.read_inertia_load(), (0x0162,), (0x0162, 0x0000, 0x1400), "5.120"),
    ("355", p.read_inertia_eccentricity(), (0x0163,), (0x0163, 0x0001, 0xD4C1), "120.001"),
    # §10.9: 403's response echoes 0190H (fixed); 404 is right
    (
        "403 fixed",
        p.read_arch(3),
        (0x0193, 0x0003),
        (0x0193, 0x0003, 0x0000, 0x278B, 0x0000, 0x4E9B),
        Distances("10.123", "20.123"),
    ),
    ("404", p.read_arch_depart(3), (0x0194, 0x0003), (0x0194, 0x0003, 0x0000, 0x278B), "10.123"),
    # §10.10 command 453 (6-axis)
    (
        "453",
        p.read_fine(6),
        (0x01C5,),
        (0x01C5, 0x0064, 0x00C8, 0x012C, 0x0190, 0x01F4, 0x0258),
        (100, 200, 300, 400, 500, 600),
    ),
    # §10.11 command 501
    ("501", p.read_tool(), (0x01F5,), (0x01F5, 0x0005), 5),
    # §10.13 commands 603-605, area 1
    (
        "603 X",
        p.read_box(1, 0),
        (0x025B, 0x0001, 0x0000),
        (0x025B, 0x0001, 0x0000, 0x0000, 0x0000, 0x0003, 0x0D40),
        Limits("0.000", "200.000"),
    ),
    (
        "603 Y",
        p.read_box(1, 1),
        (0x025B, 0x0001, 0x0001),
        (0x025B, 0x0001, 0x0001, 0x0001, 0x86A0, 0x0001, 0x86A0),
        Limits("100.000", "100.000"),
    ),
    (
        "603 Z",
        p.read_box(1, 2),
        (0x025B, 0x0001, 0x0002),
        (0x025B, 0x0001, 0x0002, 0x0000, 0x0000, 0x0001, 0x86A0),
        Limits("0.000", "100.000"),
    ),
    (
        "604 Y",
        p.read_box_lower(1, 1),
        (0x025C, 0x0001, 0x0001),
        (0x025C, 0x0001, 0x0001, 0x0001, 0x86A0),
        "100.000",
    ),
    (
        "605 X",
        p.read_box_upper(1, 0),
        (0x025D, 0x0001, 0x0000),
        (0x025D, 0x0001, 0x0000, 0x0003, 0x0D40),
        "200.000",
    ),
    # §10.14 command 651 and §10.15 command 701: plane / local 1, X..W = 100.123..600.123
    *[
        (f"651 {c}", p.read_plane(1, i), (0x028B, 0x0001, i), (0x028B, 0x0001, i, hi, lo), v)
        for i, (c, hi, lo, v) in enumerate(
            [
                ("X", 0x0001, 0x871B, "100.123"),
                ("Y", 0x0003, 0x0DBB, "200.123"),
                ("Z", 0x0004, 0x945B, "300.123"),
                ("U", 0x0006, 0x1AFB, "400.123"),
                ("V", 0x0007, 0xA19B, "500.123"),
                ("W", 0x0009, 0x283B, "600.123"),
            ]
        )
    ],
    (
        "701 Z",
        p.read_local(1, 2),
        (0x02BD, 0x0001, 0x0002),
        (0x02BD, 0x0001, 0x0002, 0x0004, 0x945B),
        "300.123",
    ),
    # §10.16: the 753-755 examples encode 10 without x1000 (fixed: lower 10, upper 200)
    (
        "753 fixed",
        p.read_xylim(0),
        (0x02F1, 0x0000),
        (0x02F1, 0x0000, 0x0000, 0x2710, 0x0003, 0x0D40),
        Limits("10.000", "200.000"),
    ),
    # §10.17 commands 803-805: joint 1, -6000 and 7000 pulses
    (
        "803",
        p.read_jrange(1),
        (0x0323, 0x0001),
        (0x0323, 0x0001, 0xFFFF, 0xE890, 0x0000, 0x1B58),
        PulseLimits(-6000, 7000),
    ),
    ("804", p.read_jrange_lower(1), (0x0324, 0x0001), (0x0324, 0x0001, 0xFFFF, 0xE890), -6000),
    ("805", p.read_jrange_upper(1), (0x0325, 0x0001), (0x0325, 0x0001, 0x0000, 0x1B58), 7000),
    # §10.18 command 851: X = 100 mm, Y = 100 mm
    ("851 X", p.read_base(0), (0x0353, 0x0000), (0x0353, 0x0000, 0x0001, 0x86A0), "100.000"),
    ("851 Y", p.read_base(1), (0x0353, 0x0001), (0x0353, 0x0001, 0x0001, 0x86A0), "100.000"),
    # §10.26: the 1250/1251 examples give +100 for -100 (fixed)
    ("1251 fixed", p.read_limz(), (0x04E3,), (0x04E3, 0xFFFE, 0x7960), "-100.000"),
    # §8.5 command 2153: a 6-AXIS
    ("2153", p.read_robot_type(), (0x0869,), (0x0869, 0x0005), 5),
    # §8.5 commands 2155 and 2156 (no example: by hand): no error; Remote I/O (22)
    ("2155", p.read_controller_error(), (0x086B,), (0x086B, 0x0000), 0),
    ("2156", p.read_control_device(), (0x086C,), (0x086C, 0x0016), 22),
    # §10.25: 1222 (its command omits the axis word: the command is fixed, the
    # response is the manual's: P1 Y = 495.336) and 1215-1220 of P0
    (
        "1222",
        p.read_point_coord(1, 1),
        (0x04C6, 0x0001, 0x0001),
        (0x04C6, 0x0007, 0x8EE8),
        "495.336",
    ),
    # §10.25 1224, 1226 (P1 /J1F1, /J2F1) and 1228 (P1 J1Angle 1.002), the manual's words
    ("1224", p.read_point_attribute("j1flag", 1), (0x04C8, 0x0001), (0x04C8, 0x0001), 1),
    ("1226", p.read_point_attribute("j2flag", 1), (0x04CA, 0x0001), (0x04CA, 0x0001), 1),
    ("1228", p.read_point_j1angle(1), (0x04CC, 0x0001), (0x04CC, 0x0000, 0x03EA), "1.002"),
    ("1215", p.read_point_attribute("hand", 0), (0x04BF, 0x0000), (0x04BF, 0x0001), 1),
    ("1216", p.read_point_attribute("elbow", 0), (0x04C0, 0x0000), (0x04C0, 0x0001), 1),
    ("1217", p.read_point_attribute("wrist", 0), (0x04C1, 0x0000), (0x04C1, 0x0001), 1),
    ("1218", p.read_point_attribute("j4flag", 0), (0x04C2, 0x0000), (0x04C2, 0x0001), 1),
    ("1219", p.read_point_attribute("j6flag", 0), (0x04C3, 0x0000), (0x04C3, 0x007F), 127),
    ("1220", p.read_point_attribute("local", 0), (0x04C4, 0x0000), (0x04C4, 0x000F), 15),
]

# --- golden writes ------------------------------------------------------------------
# (write, its commands' words in order).  Every normal response is [echo, 0000H, 0000H].
WRITES: list[tuple[str, WriteSequence, list[tuple[H, ...]]]] = [
    # §10.1 command 1 (its example answers 0000H 0000H 0000H, no echo: the command is right)
    ("1", p.register_accel(5, 100, 80), [(0x0001, 0x0005, 0x0064, 0x0050)]),
    # §10.2 commands 53, 54+55: table 15, 100.123 and 200.000
    (
        "53",
        p.register_accel_s(15, ACCEL_VALUES),
        [(0x0035, 0x000F, 0x0001, 0x871B, 0x0003, 0x0D40)],
    ),
    (
        "54+55",
        p.register_accel_s(15, ACCEL_VALUES, command_words=4),
        [(0x0036, 0x000F, 0x0001, 0x871B), (0x0037, 0x000F, 0x0003, 0x0D40)],
    ),
    # §10.3 commands 103, 104+105: table 1
    (
        "103",
        p.register_accel_r(1, ACCEL_VALUES),
        [(0x0067, 0x0001, 0x0001, 0x871B, 0x0003, 0x0D40)],
    ),
    (
        "104+105",
        p.register_accel_r(1, ACCEL_VALUES, command_words=5),
        [(0x0068, 0x0001, 0x0001, 0x871B), (0x0069, 0x0001, 0x0003, 0x0D40)],
    ),
    # §10.4 command 151
    (
        "151",
        p.register_speed(1, SpeedPercent(100, 80, 50)),
        [(0x0097, 0x0001, 0x0064, 0x0050, 0x0032)],
    ),
    # §10.5 commands 203, 204+205
    (
        "203",
        p.register_speed_s(1, SpeedReal("100.001", "50.002", "60.003")),
        [(0x00CB, 0x0001, 0x0001, 0x86A1, 0x0000, 0xC352, 0x0000, 0xEA63)],
    ),
    (
        "204+205",
        p.register_speed_s(1, SpeedReal("100.001", "50.002", "60.003"), command_words=7),
        [(0x00CC, 0x0001, 0x0001, 0x86A1, 0x0000, 0xC352), (0x00CD, 0x0001, 0x0000, 0xEA63)],
    ),
    # §10.6 command 251 ("00001H" read as 0001H)
    ("251", p.register_speed_r(1, "1000"), [(0x00FB, 0x0001, 0x000F, 0x4240)]),
    # §10.7 commands 300 and 301 (300 headed "Command 253")
    ("300", p.set_weight("5.12", "120.001"), [(0x012C, 0x0000, 0x1400, 0x0001, 0xD4C1)]),
    ("301", p.set_weight("5.12"), [(0x012D, 0x0000, 0x1400)]),
    # §10.8 commands 350 (5 words, the §8 list says 3), 351+352
    ("350", p.set_inertia(Inertia("5.12", "120.001")), [(0x015E, 0x0000, 0x1400, 0x0001, 0xD4C1)]),
    (
        "351+352",
        p.set_inertia(Inertia("5.12", "120.001"), command_words=4),
        [(0x015F, 0x0000, 0x1400), (0x0160, 0x0001, 0xD4C1)],
    ),
    # §10.9 commands 400 (6 words, the list says 4), 401+402: arch 3
    (
        "400",
        p.set_arch(3, Distances("10.123", "20.123")),
        [(0x0190, 0x0003, 0x0000, 0x278B, 0x0000, 0x4E9B)],
    ),
    (
        "401+402",
        p.set_arch(3, Distances("10.123", "20.123"), command_words=5),
        [(0x0191, 0x0003, 0x0000, 0x278B), (0x0192, 0x0003, 0x0000, 0x4E9B)],
    ),
    # §10.10 commands 450, 451+452 (6-axis)
    (
        "450",
        p.set_fine((100, 200, 300, 400, 500, 600)),
        [(0x01C2, 0x0064, 0x00C8, 0x012C, 0x0190, 0x01F4, 0x0258)],
    ),
    (
        "451+452",
        p.set_fine((100, 200, 300, 400, 500, 600), command_words=6),
        [(0x01C3, 0x0064, 0x00C8, 0x012C), (0x01C4, 0x0190, 0x01F4, 0x0258)],
    ),
    # §10.11 command 500
    ("500", p.select_tool(5), [(0x01F4, 0x0005)]),
    # §10.13 command 600 (Rn X, Y, Z) and 601 X, Y, Z + 602 X, Y, Z: area 1
    (
        "600",
        p.set_box(1, [Limits("0", "200"), Limits("100", "100"), Limits("0", "100")]),
        [
            (0x0258, 0x0001, 0x0000, 0x0000, 0x0000, 0x0003, 0x0D40),
            (0x0258, 0x0001, 0x0001, 0x0001, 0x86A0, 0x0001, 0x86A0),
            (0x0258, 0x0001, 0x0002, 0x0000, 0x0000, 0x0001, 0x86A0),
        ],
    ),
    (
        "601+602",
        p.set_box(
            1, [Limits("0", "200"), Limits("100", "100"), Limits("0", "100")], command_words=6
        ),
        [
            (0x0259, 0x0001, 0x0000, 0x0000, 0x0000),
            (0x0259, 0x0001, 0x0001, 0x0001, 0x86A0),
            (0x0259, 0x0001, 0x0002, 0x0000, 0x0000),
            (0x025A, 0x0001, 0x0000, 0x0003, 0x0D40),
            (0x025A, 0x0001, 0x0001, 0x0001, 0x86A0),
            (0x025A, 0x0001, 0x0002, 0x0001, 0x86A0),
        ],
    ),
    # §10.14 command 650 and §10.15 command 700: X..W = 100.123..600.123
    (
        "650",
        p.set_plane(1, ["100.123", "200.123", "300.123", "400.123", "500.123", "600.123"]),
        [
            (0x028A, 0x0001, 0x0000, 0x0001, 0x871B),
            (0x028A, 0x0001, 0x0001, 0x0003, 0x0DBB),
            (0x028A, 0x0001, 0x0002, 0x0004, 0x945B),
            (0x028A, 0x0001, 0x0003, 0x0006, 0x1AFB),
            (0x028A, 0x0001, 0x0004, 0x0007, 0xA19B),
            (0x028A, 0x0001, 0x0005, 0x0009, 0x283B),
        ],
    ),
    (
        "700 4-axis",
        p.set_local(1, ["100.123", "200.123", "300.123", "400.123"]),
        [
            (0x02BC, 0x0001, 0x0000, 0x0001, 0x871B),
            (0x02BC, 0x0001, 0x0001, 0x0003, 0x0DBB),
            (0x02BC, 0x0001, 0x0002, 0x0004, 0x945B),
            (0x02BC, 0x0001, 0x0003, 0x0006, 0x1AFB),
        ],
    ),
    # §10.16: the 750-752 examples are unscaled (fixed): lower 10, 20, 30, upper 200, 100, 100
    (
        "750 fixed",
        p.set_xylim([Limits("10", "200"), Limits("20", "100"), Limits("30", "100")]),
        [
            (0x02EE, 0x0000, 0x0000, 0x2710, 0x0003, 0x0D40),
            (0x02EE, 0x0001, 0x0000, 0x4E20, 0x0001, 0x86A0),
            (0x02EE, 0x0002, 0x0000, 0x7530, 0x0001, 0x86A0),
        ],
    ),
    (
        "751+752 fixed",
        p.set_xylim(
            [Limits("10", "200"), Limits("20", "100"), Limits("30", "100")], command_words=5
        ),
        [
            (0x02EF, 0x0000, 0x0000, 0x2710),
            (0x02EF, 0x0001, 0x0000, 0x4E20),
            (0x02EF, 0x0002, 0x0000, 0x7530),
            (0x02F0, 0x0000, 0x0003, 0x0D40),
            (0x02F0, 0x0001, 0x0001, 0x86A0),
            (0x02F0, 0x0002, 0x0001, 0x86A0),
        ],
    ),
    # §10.17 commands 800, 801+802: joint 1, -6000 and 7000 pulses
    (
        "800",
        p.set_jrange(1, PulseLimits(-6000, 7000)),
        [(0x0320, 0x0001, 0xFFFF, 0xE890, 0x0000, 0x1B58)],
    ),
    (
        "801+802",
        p.set_jrange(1, PulseLimits(-6000, 7000), command_words=4),
        [(0x0321, 0x0001, 0xFFFF, 0xE890), (0x0322, 0x0001, 0x0000, 0x1B58)],
    ),
    # §10.18 command 850: X = 100, Y = 100, the rest 0 (Rn, X..W)
    (
        "850",
        p.set_base(["100", "100", "0", "0", "0", "0"]),
        [
            (0x0352, 0x0000, 0x0001, 0x86A0),
            (0x0352, 0x0001, 0x0001, 0x86A0),
            (0x0352, 0x0002, 0x0000, 0x0000),
            (0x0352, 0x0003, 0x0000, 0x0000),
            (0x0352, 0x0004, 0x0000, 0x0000),
            (0x0352, 0x0005, 0x0000, 0x0000),
        ],
    ),
    # §10.26: the 1250 example sends +100 for -100 (fixed)
    ("1250 fixed", p.set_limz("-100"), [(0x04E2, 0xFFFE, 0x7960)]),
    # §10.25: 1204's example omits the axis word (fixed: P1 Y = -100.003); 1206-1214 of P10, P1
    ("1204 fixed", p.set_point_coord(1, 1, "-100.003"), [(0x04B4, 0x0001, 0x0001, 0xFFFE, 0x795D)]),
    ("1206", p.set_point_attribute("hand", 10, 1), [(0x04B6, 0x000A)]),
    ("1207", p.set_point_attribute("hand", 10, 0), [(0x04B7, 0x000A)]),
    ("1208", p.set_point_attribute("elbow", 10, 0), [(0x04B8, 0x000A)]),
    ("1209", p.set_point_attribute("elbow", 10, 1), [(0x04B9, 0x000A)]),
    ("1210", p.set_point_attribute("wrist", 10, 1), [(0x04BA, 0x000A)]),
    ("1211", p.set_point_attribute("wrist", 10, 0), [(0x04BB, 0x000A)]),
    ("1212", p.set_point_attribute("j4flag", 10, 1), [(0x04BC, 0x000A, 0x0001)]),
    ("1213", p.set_point_attribute("j6flag", 10, 127), [(0x04BD, 0x000A, 0x007F)]),
    ("1214", p.set_point_attribute("local", 1, 15), [(0x04BE, 0x0001, 0x000F)]),
    # §10.25: /J1F1 and /J2F1 to P1, the manual's words
    ("1223", p.set_point_attribute("j1flag", 1, 1), [(0x04C7, 0x0001, 0x0001)]),
    ("1225", p.set_point_attribute("j2flag", 1, 1), [(0x04C9, 0x0001, 0x0001)]),
    # 1227's two examples are the same words (the OCR): "use" 2.001 for P1, by hand
    ("1227 by hand", p.set_point_j1angle(1, "2.001"), [(0x04CB, 0x0001, 0x0001, 0x0000, 0x07D1)]),
]

# §8.5 command 2154, the model name "G6-551S-II" one character a call.
MODEL_NAME = [
    ((0x086A, 0x0001), (0x086A, 0x0001, 0x0047)),
    ((0x086A, 0x0000), (0x086A, 0x0001, 0x0036)),
    ((0x086A, 0x0000), (0x086A, 0x0001, 0x002D)),
    ((0x086A, 0x0000), (0x086A, 0x0001, 0x0035)),
    ((0x086A, 0x0000), (0x086A, 0x0001, 0x0035)),
    ((0x086A, 0x0000), (0x086A, 0x0001, 0x0031)),
    ((0x086A, 0x0000), (0x086A, 0x0001, 0x0053)),
    ((0x086A, 0x0000), (0x086A, 0x0001, 0x002D)),
    ((0x086A, 0x0000), (0x086A, 0x0001, 0x0049)),
    ((0x086A, 0x0000), (0x086A, 0x0000, 0x0049)),
]


def padded(words: tuple[int, ...], width: int = 8) -> tuple[int, ...]:
    return words + (0,) * (width - len(words))


@pytest.mark.parametrize(
    ("name", "request_", "command", "response", "value"), READS, ids=[r[0] for r in READS]
)
def test_each_read_encodes_and_decodes_its_golden_words(
    name: str,
    request_: Request[Any],
    command: tuple[int, ...],
    response: tuple[int, ...],
    value: object,
) -> None:
    assert request_.encode() == padded(command)
    assert request_.command.words == command
    assert request_.decode(response) == value
    # words past the layout are stale data of earlier responses: never read
    assert request_.decode(response + (0xEEEE,) * (8 - len(response))) == value
    assert not request_.is_write


@pytest.mark.parametrize(("name", "sequence", "commands"), WRITES, ids=[w[0] for w in WRITES])
def test_each_write_encodes_its_golden_words_in_order(
    name: str, sequence: WriteSequence, commands: list[tuple[int, ...]]
) -> None:
    assert [r.command.words for r in sequence] == commands
    assert [r.encode() for r in sequence] == [padded(c) for c in commands]
    for request_ in sequence:
        assert request_.is_write
        assert request_.decode((request_.number, 0x0000, 0x0000)) is None


def test_the_model_name_comes_one_character_a_call_until_status_0() -> None:
    chars = []
    for i, (command, response) in enumerate(MODEL_NAME):
        request_ = p.read_model_name_char(start=i == 0)
        assert request_.command.words == command
        char = request_.decode(response)
        assert isinstance(char, NameChar)
        chars.append(char)
    assert "".join(c.char for c in chars) == "G6-551S-II"
    assert [c.status for c in chars] == [1] * 9 + [0]
    assert p.read_model_name_char(False).decode((0x086A, 0x0002, 0x0000)) == NameChar(2, "")


def test_a_split_form_is_chosen_only_when_the_map_has_too_few_command_words() -> None:
    assert len(p.register_speed_s(1, SpeedReal("1", "2", "3"), command_words=8)) == 1
    assert [r.number for r in p.register_speed_s(1, SpeedReal("1", "2", "3"), command_words=6)] == [
        204,
        205,
    ]
    with pytest.raises(ValueError, match="needs 6 command words, the map has 5"):
        p.register_speed_s(1, SpeedReal("1", "2", "3"), command_words=5)
    with pytest.raises(ValueError, match="needs 4 command words, the map has 3"):
        p.set_jrange(1, PulseLimits(0, 1), command_words=3)


def test_a_4_axis_fine_is_4_words_and_its_split_sends_joint_4_alone() -> None:
    assert [r.command.words for r in p.set_fine((1, 2, 3, 4), command_words=4)] == [
        (0x01C3, 1, 2, 3),
        (0x01C4, 4),
    ]
    assert p.read_fine(4).decode((0x01C5, 1, 2, 3, 4, 0xEEEE, 0xEEEE)) == (1, 2, 3, 4)
    assert p.read_fine_456(4).decode((0x01C7, 4, 0xEEEE)) == (4,)


# --- error responses -------------------------------------------------------------------


def test_an_error_response_keeps_both_codes_raw_and_says_what_they_mean() -> None:
    reply = p.read_accel_s(3).decode((0x003B, 0x2006, 0x0000), error=True)
    assert reply == ErrorReply(59, 0x2006, 0x0000)
    assert isinstance(reply, ErrorReply)
    assert reply.meaning.startswith("table registration error")
    assert str(reply) == (
        "command 59: error 2006 table registration error: the table is not registered"
    )
    rc = p.read_tool().decode((0x01F5, 0x3000, 0x1234), error=True)
    assert isinstance(rc, ErrorReply)
    assert (rc.code, rc.detail) == (0x3000, 0x1234)
    assert "detail 1234" in str(rc)
    assert rc.remedy == "look the code up in the controller manual"


def test_every_response_1_code_of_section_7_1_has_its_meaning() -> None:
    codes = {
        0x0000,
        0x1000,
        0x1002,
        0x2000,
        0x2001,
        0x2002,
        0x2003,
        0x2004,
        0x2005,
        0x2006,
        0x2007,
        0x2008,
        0x2009,
        0x200A,
        0x200B,
        0x3000,
        0x9999,
    }
    assert set(p.RESPONSE_CODES) == codes
    assert p.describe_code(0x9999, 0x0001).endswith(
        "a command was requested while another was executing"
    )
    assert "caused by the controller" in p.describe_code(0x9999, 0x9901)
    assert p.describe_code(0x4321) == "4321 unknown response code"


def test_a_response_that_does_not_echo_the_command_number_is_an_error() -> None:
    # the manual's own example of 403, which echoes 0190H
    with pytest.raises(ReplyError, match="0190H, not the command number 0193H"):
        p.read_arch(3).decode((0x0190, 0x0003, 0x0000, 0x278B, 0x0000, 0x4E9B))
    # the manual's example of 1 answers 0000H 0000H 0000H: no echo
    with pytest.raises(ReplyError, match="0000H, not the command number 0001H"):
        p.register_accel(5, 100, 80).requests[0].decode((0x0000, 0x0000, 0x0000))
    # the manual's 1209 example answers 04B8H
    with pytest.raises(ReplyError, match="not the command number"):
        p.set_point_attribute("elbow", 10, 1).requests[0].decode((0x04B8, 0, 0))
    with pytest.raises(ReplyError, match="not the command number"):
        p.read_tool().decode((0x01F4, 0x2004, 0x0000), error=True)


def test_a_response_for_another_table_axis_or_joint_is_an_error() -> None:
    with pytest.raises(ReplyError, match="table number 14, asked for 15"):
        p.read_accel_s(15).decode((0x003B, 0x000E, 0, 0, 0, 0))
    with pytest.raises(ReplyError, match="axis 2, asked for 1"):
        p.read_box(1, 1).decode((0x025B, 0x0001, 0x0002, 0, 0, 0, 0))
    with pytest.raises(ReplyError, match="joint 2, asked for 1"):
        p.read_jrange(1).decode((0x0323, 0x0002, 0, 0, 0, 0))
    with pytest.raises(ReplyError, match="3 response words, 6 needed"):
        p.read_accel_s(15).decode((0x003B, 0x000F, 0x0001))
    with pytest.raises(ReplyError, match="ExtCmdResult 0"):
        p.select_tool(5).requests[0].decode((0x01F4, 0x2004, 0x0000))
    with pytest.raises(ReplyError, match="tool number 16 out of range"):
        p.read_tool().decode((0x01F5, 16))


# --- the allow-list ---------------------------------------------------------------------

#: Sample arguments for every public builder, to see every command they can make.
_TABLE = AccelReal("1", "2")
BUILDERS: dict[str, list[Callable[[], Request[Any] | WriteSequence]]] = {
    "read_accel": [lambda: p.read_accel(0)],
    "read_accel_s": [lambda: p.read_accel_s(0)],
    "read_accel_s_accel": [lambda: p.read_accel_s_accel(0)],
    "read_accel_s_decel": [lambda: p.read_accel_s_decel(0)],
    "read_accel_r": [lambda: p.read_accel_r(0)],
    "read_accel_r_accel": [lambda: p.read_accel_r_accel(0)],
    "read_accel_r_decel": [lambda: p.read_accel_r_decel(0)],
    "read_speed": [lambda: p.read_speed(0)],
    "read_speed_s": [lambda: p.read_speed_s(0)],
    "read_speed_s_speed_depart": [lambda: p.read_speed_s_speed_depart(0)],
    "read_speed_s_approach": [lambda: p.read_speed_s_approach(0)],
    "read_speed_r": [lambda: p.read_speed_r(0)],
    "read_weight": [p.read_weight],
    "read_inertia": [p.read_inertia],
    "read_inertia_load": [p.read_inertia_load],
    "read_inertia_eccentricity": [p.read_inertia_eccentricity],
    "read_arch": [lambda: p.read_arch(0)],
    "read_arch_depart": [lambda: p.read_arch_depart(0)],
    "read_arch_approach": [lambda: p.read_arch_approach(0)],
    "read_fine": [lambda: p.read_fine(6)],
    "read_fine_123": [p.read_fine_123],
    "read_fine_456": [lambda: p.read_fine_456(6)],
    "read_tool": [p.read_tool],
    "read_box": [lambda: p.read_box(1, 0)],
    "read_box_lower": [lambda: p.read_box_lower(1, 0)],
    "read_box_upper": [lambda: p.read_box_upper(1, 0)],
    "read_plane": [lambda: p.read_plane(1, 0)],
    "read_local": [lambda: p.read_local(1, 0)],
    "read_xylim": [lambda: p.read_xylim(0)],
    "read_xylim_lower": [lambda: p.read_xylim_lower(0)],
    "read_xylim_upper": [lambda: p.read_xylim_upper(0)],
    "read_jrange": [lambda: p.read_jrange(1)],
    "read_jrange_lower": [lambda: p.read_jrange_lower(1)],
    "read_jrange_upper": [lambda: p.read_jrange_upper(1)],
    "read_base": [lambda: p.read_base(0)],
    "read_limz": [p.read_limz],
    "read_robot_type": [p.read_robot_type],
    "read_controller_error": [p.read_controller_error],
    "read_control_device": [p.read_control_device],
    "read_model_name_char": [lambda: p.read_model_name_char(True)],
    "read_point_coord": [lambda: p.read_point_coord(0, 0)],
    "read_point_attribute": [
        partial(p.read_point_attribute, a, 0)  # type: ignore[arg-type]
        for a in p.POINT_ATTRIBUTES
    ],
    "register_accel": [lambda: p.register_accel(0, 1, 1)],
    "register_accel_s": [partial(p.register_accel_s, 0, _TABLE, command_words=w) for w in (4, 8)],
    "register_accel_r": [partial(p.register_accel_r, 0, _TABLE, command_words=w) for w in (4, 8)],
    "register_speed": [lambda: p.register_speed(0, SpeedPercent(1, 1, 1))],
    "register_speed_s": [
        partial(p.register_speed_s, 0, SpeedReal("1", "1", "1"), command_words=w) for w in (6, 8)
    ],
    "register_speed_r": [lambda: p.register_speed_r(0, "1")],
    "set_weight": [lambda: p.set_weight("1", "1"), lambda: p.set_weight("1")],
    "set_inertia": [partial(p.set_inertia, Inertia("1", "1"), command_words=w) for w in (3, 8)],
    "set_arch": [partial(p.set_arch, 0, Distances("1", "1"), command_words=w) for w in (4, 8)],
    "set_fine": [partial(p.set_fine, (1,) * 6, command_words=w) for w in (4, 8)],
    "select_tool": [lambda: p.select_tool(0)],
    "set_box": [partial(p.set_box, 1, [Limits("0", "0")] * 3, command_words=w) for w in (5, 8)],
    "set_plane": [lambda: p.set_plane(1, ["0"] * 6)],
    "set_local": [lambda: p.set_local(1, ["0"] * 6)],
    "set_xylim": [partial(p.set_xylim, [Limits("0", "0")] * 3, command_words=w) for w in (4, 8)],
    "set_jrange": [partial(p.set_jrange, 1, PulseLimits(0, 0), command_words=w) for w in (4, 8)],
    "set_base": [lambda: p.set_base(["0"] * 6)],
    "set_limz": [lambda: p.set_limz("0")],
    "set_point_coord": [lambda: p.set_point_coord(0, 0, "0")],
    "read_point_j1angle": [lambda: p.read_point_j1angle(0)],
    "set_point_j1angle": [lambda: p.set_point_j1angle(0, "0")],
    "set_point_attribute": [
        partial(p.set_point_attribute, a, 1, v)  # type: ignore[arg-type]
        for a in p.POINT_ATTRIBUTES
        for v in (0, 1)
        if (a, v) != ("local", 0)
    ],
}


def _numbers(made: Request[Any] | WriteSequence) -> list[int]:
    return [made.number] if isinstance(made, Request) else [r.number for r in made]


def test_every_public_builder_is_covered_and_makes_only_allowed_commands() -> None:
    public = {
        name for name in p.__all__ if name.startswith(("read_", "register_", "set_", "select_"))
    }
    assert public == set(BUILDERS)
    made = {n for builders in BUILDERS.values() for build in builders for n in _numbers(build())}
    assert made == set(p.COMMANDS)  # and the allow-list holds nothing no builder makes
    assert made.isdisjoint(p.NEVER_SEND)


#: The digest's safe-read whitelist (§4).
SAFE_READS = frozenset(
    {
        2,
        3,
        *range(56, 62),
        *range(106, 112),
        152,
        153,
        *range(206, 212),
        252,
        253,
        302,
        353,
        354,
        355,
        403,
        404,
        405,
        453,
        454,
        455,
        501,
        558,
        603,
        604,
        605,
        651,
        701,
        753,
        754,
        755,
        803,
        804,
        805,
        851,
        901,
        951,
        952,
        1001,
        1002,
        1051,
        1052,
        1101,
        1151,
        *range(1215, 1221),
        1222,
        1224,
        1226,
        1228,
        1251,
        1301,
        1304,
        1401,
        2054,
        2100,
        2101,
        2104,
        2107,
        2108,
        2111,
        2114,
        *range(2150, 2158),
    }
)


def test_the_allow_list_is_inside_the_digests_two_lists() -> None:
    # the digest's safe-read whitelist (§4) and each item's write (§2)
    safe_reads = SAFE_READS
    assert p.BACKUP_READS <= safe_reads
    assert p.DEPLOY_WRITES.isdisjoint(safe_reads)
    assert all(not p.COMMANDS[n].is_write for n in p.BACKUP_READS)
    assert all(p.COMMANDS[n].is_write for n in p.DEPLOY_WRITES)


NEVER = sorted(
    {
        2000,
        2001,
        2002,
        2003,
        2005,
        2006,
        2007,  # motion
        2050,
        2051,
        2052,
        2053,  # jog, teach, save points, excitation
        1150,
        1400,
        1450,  # power, motor, reset
        2102,
        2103,
        2105,
        2106,  # outputs
        2109,
        2110,
        2112,
        2113,  # memory I/O writes
        554,
        555,
        556,
        557,
    }
)  # pallet reads that overwrite points


@pytest.mark.parametrize("number", NEVER)
def test_the_encoder_refuses_every_never_send_command_made_by_hand(number: int) -> None:
    assert number in p.NEVER_SEND
    for params in [(), (0,), (0, 0), (1, 0, 0, 0, 0)]:
        with pytest.raises(ValueError, match=f"command {number} is not on the Epson allow-list"):
            p.encode(Command(number, params))
        with pytest.raises(ValueError, match="never sends it"):
            Request(Command(number, params), "by hand", lambda w: None)


def test_no_builder_is_named_for_anything_the_family_never_does() -> None:
    words = {
        "move",
        "go",
        "jump",
        "jump3",
        "arc",
        "arc3",
        "jog",
        "teach",
        "power",
        "motor",
        "excitation",
        "reset",
        "output",
        "outputs",
        "memory",
        "io",
        "pallet",
        "save",
        "position",
        "halt",
    }
    names = [name for name, obj in inspect.getmembers(p, callable) if not name.startswith("_")]
    assert not [n for n in names if words & set(n.lower().split("_"))]


def test_the_encoder_refuses_unknown_numbers_wrong_parameter_counts_and_non_words() -> None:
    with pytest.raises(ValueError, match="only the backup reads and deploy writes"):
        p.encode(Command(0))  # 0 sets the current Accel: not a deploy item
    with pytest.raises(ValueError, match=r"takes 1 parameters, not 0"):
        p.encode(Command(59))
    with pytest.raises(ValueError, match="parameter 2: 65536 is not a 16-bit word"):
        p.encode(Command(1, (1, 0x10000, 1)))
    with pytest.raises(ValueError, match="parameter 1: -1 is not a 16-bit word"):
        p.encode(Command(3, (-1,)))
    with pytest.raises(ValueError, match="needs 8 command words, the map has 7"):
        p.encode(Command(203, (1,) * 7), width=7)


def test_builders_refuse_values_out_of_range() -> None:
    with pytest.raises(ValueError, match="table number 16 out of range"):
        p.read_accel(16)
    with pytest.raises(ValueError, match="arch number 7"):
        p.read_arch(7)
    with pytest.raises(ValueError, match="Box area 0"):
        p.read_box(0, 0)
    with pytest.raises(ValueError, match="speed 101"):
        p.register_speed(0, SpeedPercent(101, 1, 1))
    with pytest.raises(ValueError, match="local 0 out of range"):
        p.set_point_attribute("local", 1, 0)
    with pytest.raises(ValueError, match="X, Y and Z needed"):
        p.set_box(1, [Limits("0", "0")] * 2)
    with pytest.raises(ValueError, match="4-axis"):
        p.set_plane(1, ["0"] * 5)
    with pytest.raises(ValueError, match="more than three decimals"):
        p.set_limz("1.0005")


# --- numbers ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "words", "canonical"),
    [
        ("100.123", (0x0001, 0x871B), "100.123"),  # §10.2 and §3 of the digest
        ("-100.003", (0xFFFE, 0x795D), "-100.003"),  # digest §3
        ("0", (0x0000, 0x0000), "0.000"),
        ("-0.000", (0x0000, 0x0000), "0.000"),
        ("-0.001", (0xFFFF, 0xFFFF), "-0.001"),
        ("0.001", (0x0000, 0x0001), "0.001"),
        ("65.535", (0x0000, 0xFFFF), "65.535"),
        ("65.536", (0x0001, 0x0000), "65.536"),
        ("-65.536", (0xFFFF, 0x0000), "-65.536"),
        ("-65.537", (0xFFFE, 0xFFFF), "-65.537"),
        ("2147483.647", (0x7FFF, 0xFFFF), "2147483.647"),
        ("-2147483.648", (0x8000, 0x0000), "-2147483.648"),
        ("+5.5", (0x0000, 0x157C), "5.500"),
        (".5", (0x0000, 0x01F4), "0.500"),
        ("7.", (0x0000, 0x1B58), "7.000"),
        ("1.2000000", (0x0000, 0x04B0), "1.200"),
    ],
)
def test_real_values_are_thousandths_in_two_words_high_first(
    text: str, words: tuple[int, int], canonical: str
) -> None:
    assert p.real_to_words(text) == words
    assert p.real_from_words(*words) == canonical
    assert p.canonical_real(text) == canonical


@pytest.mark.parametrize(
    "text",
    [
        "2147483.648",
        "-2147483.649",
        "1.0001",
        "1e3",
        "",
        ".",
        "-",
        " 1",
        "1 ",
        "1,5",
        "0x10",
        "nan",
        "1.2.3",
        "++1",
    ],
)
def test_text_that_is_not_an_exact_32_bit_real_is_refused(text: str) -> None:
    with pytest.raises(ValueError):
        p.real_to_words(text)


def test_pulses_are_raw_32_bit_twos_complement() -> None:
    assert p.int32_to_words(-6000) == (0xFFFF, 0xE890)
    assert p.int32_to_words(-1) == (0xFFFF, 0xFFFF)
    assert p.int32_to_words(-(2**31)) == (0x8000, 0x0000)
    assert p.int32_to_words(2**31 - 1) == (0x7FFF, 0xFFFF)
    assert p.int32_from_words(0x8000, 0x0000) == -(2**31)
    assert p.int32_from_words(0x7FFF, 0xFFFF) == 2**31 - 1
    for bad in (2**31, -(2**31) - 1):
        with pytest.raises(ValueError, match="does not fit 32 bits"):
            p.int32_to_words(bad)


@given(st.integers(min_value=p.REAL_MIN, max_value=p.REAL_MAX))
def test_any_32_bit_value_survives_text_and_words(units: int) -> None:
    text = p.real_text(units)
    assert p.real_units(text) == units
    high, low = p.real_to_words(text)
    assert 0 <= high <= 0xFFFF and 0 <= low <= 0xFFFF
    assert p.real_from_words(high, low) == text


_ALL_REQUESTS: list[Request[Any]] = (
    [r for _, r, _, _, _ in READS]
    + [r for _, seq, _ in WRITES for r in seq]
    + [p.read_model_name_char(True)]
)


@settings(max_examples=examples(300))
@given(
    st.sampled_from(_ALL_REQUESTS),
    st.lists(st.integers(min_value=0, max_value=0xFFFF), max_size=8),
    st.booleans(),
    st.booleans(),
)
def test_any_response_words_decode_to_a_value_an_error_reply_or_a_reply_error(
    request_: Request[Any], words: list[int], error: bool, echo: bool
) -> None:
    if echo and words:
        words[0] = request_.number
    try:
        request_.decode(words, error=error)
    except ReplyError:
        pass


# §8's list: (command words, response words) including word 0, as printed.
SECTION_8 = {
    1: (4, 3),
    3: (2, 4),
    53: (6, 3),
    54: (4, 3),
    55: (4, 3),
    59: (2, 6),
    60: (2, 4),
    61: (2, 4),
    103: (6, 3),
    104: (4, 3),
    105: (4, 3),
    109: (2, 6),
    110: (2, 4),
    111: (2, 4),
    151: (5, 3),
    153: (2, 5),
    203: (8, 3),
    204: (6, 3),
    205: (4, 3),
    209: (2, 8),
    210: (2, 6),
    211: (2, 4),
    251: (4, 3),
    253: (2, 4),
    300: (5, 3),
    301: (3, 3),
    302: (1, 5),
    350: (3, 3),
    351: (3, 3),
    352: (3, 3),
    353: (1, 5),
    354: (1, 3),
    355: (1, 3),
    400: (4, 3),
    401: (4, 3),
    402: (4, 3),
    403: (2, 6),
    404: (2, 4),
    405: (2, 4),
    450: (7, 3),
    451: (4, 3),
    452: (4, 3),
    453: (1, 7),
    454: (1, 4),
    455: (1, 4),
    500: (2, 3),
    501: (1, 3),
    600: (7, 3),
    601: (5, 3),
    602: (5, 3),
    603: (3, 7),
    604: (3, 5),
    605: (3, 5),
    650: (5, 3),
    651: (3, 5),
    700: (5, 3),
    701: (3, 5),
    750: (6, 3),
    751: (4, 3),
    752: (4, 3),
    753: (2, 6),
    754: (2, 4),
    755: (2, 4),
    800: (6, 3),
    801: (4, 3),
    802: (4, 3),
    803: (2, 6),
    804: (2, 4),
    805: (2, 4),
    850: (4, 3),
    851: (2, 4),
    1204: (5, 3),
    **dict.fromkeys(range(1206, 1212), (2, 3)),
    1212: (3, 3),
    1213: (3, 3),
    1214: (3, 3),
    **dict.fromkeys(range(1215, 1221), (2, 3)),
    1222: (3, 3),
    1223: (3, 3),
    1224: (2, 3),
    1225: (3, 3),
    1226: (2, 3),
    1227: (5, 3),
    1228: (2, 3),
    1250: (3, 3),
    1251: (1, 3),
    2153: (1, 3),
    2154: (2, 3),
    2155: (1, 2),
    2156: (1, 2),
}
#: The digest's known defects of the list: the bodies of 350 and 400 have 5 and 6 words.
SECTION_8_DEFECTS = {350: 5, 400: 6}
#: Reads whose answer the list gives as 2 words: harlsync asks for 3, since an error
#: response, which it must read too, is 3 words (§7).
SECTION_8_ERROR_WORDS = {2155: 3, 2156: 3}


def test_word_counts_match_the_section_8_list_but_for_its_known_defects() -> None:
    assert set(SECTION_8) == set(p.COMMANDS)
    for builders in BUILDERS.values():
        for build in builders:
            made = build()
            for request_ in [made] if isinstance(made, Request) else list(made):
                command, response = SECTION_8[request_.number]
                command = SECTION_8_DEFECTS.get(request_.number, command)
                response = SECTION_8_ERROR_WORDS.get(request_.number, response)
                assert request_.command_words == command, request_  # 450, 452: 6-axis here
                assert request_.response_words == response, request_
