"""The simulator framework: one simulated line for every controller family, served
over a pty, TCP and ``sim://``, with mode control, battery-backed memory, and
replay of captures.

A family's simulated controller lives in its own package
(``harlsync.families.<name>.sim``): a :class:`Simulator` subclass (a serial
line) or a :class:`Device` subclass it serves itself, and the
:class:`SimFamily` the framework reaches it through.
"""

from .device import Decoder, Device, Faults, Received, Refused, RequestFrame, Simulator
from .family import (
    LineFamily,
    ServedFamily,
    SimFamily,
    SimServer,
    Verb,
    line_family,
    project_family,
    sim_family,
)
from .variants import Variant

__all__ = [
    "Decoder",
    "Device",
    "Faults",
    "LineFamily",
    "Received",
    "Refused",
    "RequestFrame",
    "ServedFamily",
    "SimFamily",
    "SimServer",
    "Simulator",
    "Variant",
    "Verb",
    "line_family",
    "project_family",
    "sim_family",
]
