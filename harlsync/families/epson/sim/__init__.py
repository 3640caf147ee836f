"""The simulated Epson controller: a Modbus TCP server whose registers are the
controller's Remote I/O, driving the §6 handshake and the Remote Control
command set on a simulated robot, on the shared simulator framework."""

from . import commands
from .device import DEFAULT_EXECUTION_TIME, SIM_FAMILY, CommandReceived, Simulator
from .point import Point
from .remote import Event, FunctionFault, Phase, RemoteIO
from .server import ModbusServer, RegisterBank
from .state import SCARA, SIX_AXIS, SimState

__all__ = [
    "DEFAULT_EXECUTION_TIME",
    "SCARA",
    "SIM_FAMILY",
    "SIX_AXIS",
    "CommandReceived",
    "Event",
    "FunctionFault",
    "ModbusServer",
    "Phase",
    "Point",
    "RegisterBank",
    "RemoteIO",
    "SimState",
    "Simulator",
    "commands",
]
