"""The simulated HARL-U2 controller: same codec, playing the device's side."""

from .device import Faults, Received, Simulator
from .state import DEFAULT_CONFIG, SimState

__all__ = ["DEFAULT_CONFIG", "Faults", "Received", "SimState", "Simulator"]
