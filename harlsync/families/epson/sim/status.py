"""The controller's side of the status reads (§8.5): what it says of its robot
(2153 the manipulator type, 2154 the model name) and of itself (2155 its error
code, 2156 its control device), and the table of their command numbers
(:data:`READ_COMMANDS`) that :mod:`.commands` carries out."""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from .codes import PARAMETER, Refused
from .params import Params
from .session import Handler, Session, WordCount
from .state import SimState

__all__ = ["READ_COMMANDS"]


def _robot_type(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    return (st.robot_type,)


def _model_name(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    """2154: one character a call; status 1 more follow, 0 the last, 2 done."""
    word = p.word(1)
    if word & ~1:  # bits 15-1 reserved: 0
        raise Refused(PARAMETER)
    at = 0 if word & 1 else s.name_at
    if at is None or at >= len(st.model):
        s.name_at = len(st.model)
        return (2, 0)
    s.name_at = at + 1
    return (1 if at + 1 < len(st.model) else 0, ord(st.model[at]))


def _controller_error(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    """2155: the error code, 0000H in the normal state."""
    return (st.error_code,)


def _control_device(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    """2156: the control device, 22 (Remote I/O) in the normal state."""
    return (st.control_device,)


#: number -> (command words, word 0 included; handler)
READ_COMMANDS: Mapping[int, tuple[WordCount, Handler]] = MappingProxyType(
    {
        2153: (1, _robot_type),
        2154: (2, _model_name),
        2155: (1, _controller_error),
        2156: (1, _control_device),
    }
)
