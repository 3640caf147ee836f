"""Epson RC+ Remote Control as the engine sees it: its catalogue, files, robot and line.

Only the declarations (name, options, schemes, words, stations, help) are made at
import: the catalogue, the files' layout and the protocol are imported when the
family is first used, so ``--help`` and the registry's look-ups stay cheap.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..base import Analysis, Catalogue, Driver, Family, Help, Option, Scheme, Words
from ..survey import Survey
from . import declared

if TYPE_CHECKING:
    from ...project.robot import Robot
    from .catalogue import Key
    from .model import EpsonData

__all__ = ["FAMILY", "EpsonFamily"]


class EpsonFamily(Family["Key", "EpsonData"]):
    name = "epson"
    title = "Epson (RC+ Remote Control over Modbus TCP)"
    directories: tuple[str, ...] = ()
    #: What a push writes is named by its plan (the memory card, points): see
    #: :meth:`~.catalogue.EpsonCatalogue.plan`.
    deploy_notes: tuple[str, ...] = ()
    options = (
        Option(
            "reset_function",
            "Epson: when the Remote Control function is found in use or halted "
            "(a command left unanswered, a function error), reset it first "
            "(section 6.5.2), and only while the robot is not Running; other "
            "families refuse it",
        ),
    )
    schemes = (
        Scheme(
            "modbus",
            declared.DEFAULT_PORT,
            "an Epson controller's Modbus TCP slave: modbus://HOST[:PORT]",
        ),
    )
    #: a nightly backup: a function left in use by a harlsync that is gone is reset on
    #: an idle robot, and said (Driver.notes)
    engine_options = frozenset({"unattended"})
    words = Words(state="the Remote Control status")
    stations = range(256)
    default_station = declared.DEFAULT_UNIT
    help = Help(
        stations=f"the Modbus unit id, 0-255, {declared.DEFAULT_UNIT} by default",
        pull="the settings, the tables and the points",
        items="setting, table entry, point",
        item="'P12'",
        identity="robot type, axes, model",
        commands="each Remote Control command's words in hex",
        order="load, limits, frames, tool, arch, fine, LimZ, tables, points",
        busy="Running, Paused, EStopOn, Error or the Remote Control function in use",
    )
    #: pymodbus logs its own ERROR lines (a refused connection, a timeout) above the
    #: one line harlsync says of the same failure.
    loggers = ("pymodbus",)

    @property
    def catalogue(self) -> Catalogue[Key, EpsonData]:
        from .catalogue import CATALOGUE

        return CATALOGUE

    @property
    def format(self) -> int:
        from .layout import FORMAT

        return FORMAT

    def analyse(self, files: Mapping[str, bytes]) -> Analysis:
        from .analysis import analyse

        return analyse(files)

    def render_files(self, robot: Robot, data: EpsonData) -> dict[str, str]:
        from .render import render_files

        return render_files(robot, data)

    def data_problems(self, data: EpsonData) -> list[str]:
        """A setting the data lacks (a controller never leaves one out)."""
        from .model import KINDS, SettingKey

        return [
            f"{kind.name}: not read"
            for kind in KINDS.values()
            if not kind.numbered and SettingKey(kind.key) not in data.items
        ]

    def project_files(self, root: Path) -> list[str]:
        from . import layout

        names = [*layout.ROOT_FILES, layout.CONTROLLER_FILE]
        return [name for name in names if (root / name).is_file()]

    def stale_files(
        self, root: Path, texts: Mapping[str, str], robot: Robot, data: EpsonData
    ) -> list[str]:
        return []

    def survey(self, robot: Robot, *, lock_timeout: float) -> Survey:
        """The Remote I/O map and the controller's outputs, read with Modbus reads
        alone: the Remote Control function is not taken (its handshake drives input
        signals), so the manipulator and the point table, which only its commands
        read, are left to the first pull."""
        import time

        from . import layout
        from .handshake import Handshake
        from .transport import ModbusLink

        line = layout.connection(robot)
        link = ModbusLink(
            robot.port, robot.station, timeout=line.timeout, retries=0, lock_timeout=lock_timeout
        )
        try:
            handshake = Handshake(link, line.register_map, block_write_whole=line.writes_whole)
            started = time.perf_counter()
            status = handshake.status()  # one read of the outputs, no command
            turnaround = time.perf_counter() - started
        finally:
            link.close()
        signals = ", ".join(
            f"{name} {int(bool(value))}"
            for name, value in status.signals.items()
            if value is not None
        )
        return Survey(
            identity={"Remote I/O outputs": signals or "none mapped"},
            status=status.describe(),
            idle=status.idle,
            turnaround=turnaround,
        )

    def robot_text(self, robot: Robot) -> str:
        from .render import render_robot

        return render_robot(robot)

    def schemas(self) -> dict[str, str]:
        from . import layout

        return layout.SCHEMAS.files()

    def new_robot(self, name: str, port: str, station: int | None, **options: Any) -> Robot:
        from ...project.robot import Robot
        from . import layout

        return Robot(
            family=self.name,
            name=name,
            port=port,
            station=declared.DEFAULT_UNIT if station is None else station,
            options=layout.new_options(),
            **options,
        )

    def parse_station(self, text: str) -> int:
        """The Modbus unit id, decimal."""
        unit = int(text) if text.isdigit() and len(text) <= 3 else -1
        if not 0 <= unit <= 255:
            raise ValueError(
                f"unit id {text!r} is out of range (allowed: a Modbus unit id, "
                f"0-255; {declared.DEFAULT_UNIT} by default)"
            )
        return unit

    def format_station(self, station: int) -> str:
        return str(station)

    def connect(
        self,
        robot: Robot,
        port: str | None,
        station: int | None,
        *,
        lock_timeout: float,
        **options: bool,
    ) -> Driver[Key, EpsonData]:
        """``options``: ``reset_function`` resets a Remote Control function found in
        use or halted (§6.5.2), on a robot that is not Running."""
        from . import layout
        from .controller import Controller
        from .driver import EpsonDriver

        first, last = layout.point_range(robot)
        if set(options) - self.connect_options:
            raise TypeError(f"unknown connect options {sorted(options)}")
        controller = Controller.open(
            port or robot.port,
            station if station is not None else robot.station,
            layout.connection(robot),
            lock_timeout=lock_timeout,
            reset_function=bool(options.pop("reset_function", False)),
            unattended=bool(options.pop("unattended", False)),
            robot_type=robot.options.get("type"),
            axes=robot.options.get("axes"),
            first=first,
            last=last,
            table_end=layout.point_table_end(robot),
            first_pull=bool(robot.options.get(layout.FIRST_PULL)),
        )
        return EpsonDriver(controller)


#: The family, as the registry hands it out.
FAMILY = EpsonFamily()
