"""The simulated IAI controller (protocol B): the family's codec playing the
controller's side, on the shared simulator framework (:mod:`harlsync.sim`)."""

from . import codes
from .device import SIM_FAMILY, Simulator
from .state import AUTO, DEFAULT_AXES, DEFAULT_VERSION, MANUAL, SimState

__all__ = [
    "AUTO",
    "DEFAULT_AXES",
    "DEFAULT_VERSION",
    "MANUAL",
    "SIM_FAMILY",
    "SimState",
    "Simulator",
    "codes",
]
