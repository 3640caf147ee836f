"""An IAI controller as the engine's :class:`~harlsync.families.base.Driver`: read
everything, read or write an item or a run (291H positions, 24BH a flag, 24CH/24DH
integer and real variables, 24EH a row of string variable columns), status (212H
then 215H)."""

from __future__ import annotations

from typing import Any

from ..base import Driver, Progress, Status
from ..survey import Extent, Findings, Guess, Survey, surveyed
from .catalogue import Key, PositionKey, RecordKey, Run, VariableKey, identity_of
from .controller import Controller
from .interlock import IaiStatus
from .layout import IaiData
from .model import Version, real_value
from .profile import DEFAULT_POSITION_RANGE, STRING_ROW
from .protocol import (
    position_fields,
    write_flag,
    write_integers,
    write_positions,
    write_reals,
    write_strings,
)

__all__ = ["IaiDriver"]

#: An item kind (a flag, an integer, a real) -> the section the controller reads it by.
_SECTIONS = {"flag": "flags", "integer": "integers", "real": "reals"}


class IaiDriver(Driver[Key, IaiData]):
    def __init__(self, controller: Controller) -> None:
        self.controller = controller
        self.label = controller.label
        self._version: Version | None = None

    def identity(self) -> dict[str, str]:
        """201H, the first request of a read: kept for :meth:`read_all`."""
        self._version = self.controller.version()
        return identity_of(self._version)

    def survey(self) -> Survey:
        """201H (the identity), the position table read to where the controller's
        replies say it ends (:meth:`Controller.read_position_table`), and the
        status (212H, 215H): reads only."""

        def explore() -> Findings:
            positions, covered = self.controller.read_position_table()
            guessed = DEFAULT_POSITION_RANGE[1]
            last = covered.end if covered.end is not None else covered.last
            reply = covered.past or "nothing past it up to the last number a query may name"
            options: dict[str, object] = {}
            if covered.end is not None and covered.end != guessed:
                options["last"] = covered.end
            return Findings(
                extents=[
                    Extent(
                        "positions",
                        last,
                        reply,
                        ("controller.first_position", "controller.last_position"),
                        counted=f"the last position number; {len(positions)} defined",
                    )
                ],
                guesses=[
                    Guess(
                        "the position table's last number",
                        str(guessed),
                        str(last),
                        "controller.last_position",
                    )
                ],
                options=options,
                # None: as many exchanges as this read of the positions, and the identity
                # and status around them, for a pull of the positions (variables are kept
                # only with keep_registers)
                pull_exchanges=None,
            )

        return surveyed(self.controller.link.stats, self.identity, explore, self.status)

    def read_all(
        self, *, registers: bool, progress: Progress | None = None, whole: bool = False
    ) -> IaiData:
        version, self._version = self._version, None
        return self.controller.read_all(progress, variables=registers, whole=whole, version=version)

    def status(self) -> IaiStatus:
        return self.controller.status()

    def advice(self, status: Status) -> str:
        """The advice of the reason 212H or 215H refused (see :class:`IaiStatus`)."""
        if isinstance(status, IaiStatus) and status.advice is not None:
            return status.advice
        return super().advice(status)

    def read(self, key: Key) -> object:
        c = self.controller
        if isinstance(key, PositionKey):
            return c.read_run(key.number, 1)[0]
        if isinstance(key, VariableKey):
            return c.read_variables(_SECTIONS[key.kind], key.number, key.number)[key.number]
        if isinstance(key, RecordKey):
            if key.kind == "string":
                last = c.records.get("strings", (key.number, key.number))[1]
                row = min(last, key.number + STRING_ROW - 1)
                return c.read_string_rows(key.number, row)[key.number]
            section = f"{key.kind}_coordinates"
            return c.read_coordinate_systems(section, key.number, key.number)[key.number]
        if key.kind == "positions":
            return c.read_run(key.start, key.size)
        last = key.start + key.size - 1
        return tuple(c.read_variables(key.kind, key.start, last).values())

    def write(self, key: Key, value: Any, old: Any = None, *, needs_idle: bool = True) -> None:
        if old is None:
            old = self.read(key)
        c = self.controller
        if isinstance(key, VariableKey) and key.kind == "flag":
            c.write_flag(key.number, value, old)
        elif isinstance(key, Run) and key.kind == "positions":
            c.write_run(key.start, value, old)
        elif isinstance(key, Run) and key.kind == "integers":
            c.write_integers(key.start, value, old)
        elif isinstance(key, Run) and key.kind == "reals":
            c.write_reals(key.start, value, old)
        elif isinstance(key, RecordKey) and key.kind == "string":
            c.write_strings(key.number, value, old)
        else:
            raise TypeError(f"no write for item {key}: positions and variables are written in runs")

    def command(self, key: Key, value: Any) -> str:
        """The command a write sends, its fields spaced and its records or values split
        by ``|`` so a person can read it: ``291H 00 0004 0002 | 07 001D 001D 03E8 ... 00
        | ...``, ``24BH 00 0258 1``, ``24CH 00 0C8 02 | FFFFFC18 | 00000005``."""
        # Each request is built first: it refuses what the wire cannot carry.
        if isinstance(key, VariableKey) and key.kind == "flag":
            data = write_flag(key.number, value).data  # program, flag, change type
            return f"24BH {data[:2]} {data[2:6]} {data[6:]}"
        if isinstance(key, Run) and key.kind == "positions":
            write_positions(key.start, value)
            # The plan's positions name axes the robot has: the 212H before each
            # write must report them, from the first write on.
            self.controller.note_axes(value)
            head = f"291H 00 {key.start:04X} {len(value):04X}"
            return " | ".join(
                [head, *(" ".join(position_fields(p, numbered=False)) for p in value)]
            )
        if isinstance(key, RecordKey) and key.kind == "string":
            codes = [int(value[i : i + 2], 16) for i in range(0, len(value), 2)]
            data = write_strings(key.number, codes).data  # program, start, count, codes
            return f"24EH {data[:2]} {data[2:5]} {data[5:7]} | {data[7:]}"
        if isinstance(key, Run) and key.kind == "integers":
            request, width = write_integers(key.start, value), 8
        elif isinstance(key, Run) and key.kind == "reals":
            doubles = [real_value(v) for v in value]
            order = self.controller.writing_order(key.start, doubles)
            request = write_reals(key.start, doubles, order=order)
            width = 16
        else:
            raise TypeError(f"no write for item {key}: positions and variables are written in runs")
        data = request.data  # program, start, count, then the values
        head = f"{request.message_id:03X}H {data[:2]} {data[2:5]} {data[5:7]}"
        return " | ".join([head, *(data[i : i + width] for i in range(7, len(data), width))])

    def unsafe(self, key: Key) -> bool:
        return True  # every IAI write needs an idle robot

    def close(self) -> None:
        self.controller.close()
