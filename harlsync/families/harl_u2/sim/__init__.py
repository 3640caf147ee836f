"""The simulated HARL-U2 controller: the family's codec playing the device's side,
on the shared simulator framework (:mod:`harlsync.sim`)."""

from .device import SIM_FAMILY, Simulator
from .state import DEFAULT_CONFIG, SimState

__all__ = ["DEFAULT_CONFIG", "SIM_FAMILY", "SimState", "Simulator"]
