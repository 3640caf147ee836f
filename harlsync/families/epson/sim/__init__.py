"""The simulated Epson controller: a Modbus TCP server whose registers are the
controller's Remote I/O, driving the §6 handshake and the Remote Control
command set on a simulated robot, on the shared simulator framework.

Its modules, by job::

    device      the Simulator and its family: stations, record, serving, hooks
      variants  how it fills the manual's silences;  verbs: the control verbs
      server    the Modbus TCP server;  remote: the §6 handshake, per station
      commands  a command carried out through the table of
        settings, points, status    the handlers, each with its command numbers
        session, params, codes      what a handler is given and answers with
    state       the robot a controller holds;  point: one point
      random_robot  a realistic robot from a seed;  memory: what a power cycle keeps
"""

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
