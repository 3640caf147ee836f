"""The simulator framework: one simulated line for every controller family, served
over a pty, TCP and ``sim://``, with mode control, battery-backed memory, and
replay of captures.

A family's simulated controller lives in its own package
(``harlsync.families.<name>.sim``): a :class:`Simulator` subclass and the
:class:`SimFamily` the framework reaches it through.
"""

from .device import Decoder, Faults, Received, Refused, RequestFrame, Simulator
from .family import SimFamily, Verb, project_family, sim_family

__all__ = [
    "Decoder",
    "Faults",
    "Received",
    "Refused",
    "RequestFrame",
    "SimFamily",
    "Simulator",
    "Verb",
    "project_family",
    "sim_family",
]
