"""Epson RC+ Remote Control as the engine sees it: its catalogue, files, robot and line."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ...project.robot import Robot
from ..base import Analysis, Driver
from . import layout, profile
from .catalogue import CATALOGUE
from .model import KINDS, EpsonData, SettingKey

__all__ = ["FAMILY", "EpsonFamily"]


class EpsonFamily:
    name = "epson"
    title = "Epson (RC+ Remote Control over Modbus TCP)"
    catalogue = CATALOGUE
    format = layout.FORMAT
    directories: tuple[str, ...] = ()
    #: What a push writes is named by its plan (the memory card, points): see
    #: :meth:`~.catalogue.EpsonCatalogue.plan`.
    deploy_notes: tuple[str, ...] = ()
    connect_options = frozenset({"reset_function"})
    #: the port URL schemes only this family reads: a first pull with one needs no --family
    port_schemes = ("modbus",)

    def analyse(self, files: Mapping[str, bytes]) -> Analysis:
        return layout.analyse(files)

    def render_files(self, robot: Robot, data: EpsonData) -> dict[str, str]:
        return layout.render_files(robot, data)

    def data_problems(self, data: EpsonData) -> list[str]:
        """A setting the data lacks (a controller never leaves one out)."""
        return [
            f"{kind.name}: not read"
            for kind in KINDS.values()
            if not kind.numbered and SettingKey(kind.key) not in data.items
        ]

    def project_files(self, root: Path) -> list[str]:
        return [name for name in layout.ROOT_FILES if (root / name).is_file()]

    def stale_files(
        self, root: Path, texts: Mapping[str, str], robot: Robot, data: EpsonData
    ) -> list[str]:
        return []

    def schemas(self) -> dict[str, str]:
        return layout.SCHEMAS.files()

    def new_robot(self, name: str, port: str, station: int | None, **options: Any) -> Robot:
        return Robot(
            family=self.name,
            name=name,
            port=port,
            station=profile.DEFAULT_UNIT if station is None else station,
            options=layout.new_options(),
            **options,
        )

    def parse_station(self, text: str) -> int:
        """The Modbus unit id, decimal."""
        unit = int(text) if text.isdigit() and len(text) <= 3 else -1
        if not 0 <= unit <= 255:
            raise ValueError(
                f"unit id {text!r} is out of range (allowed: a Modbus unit id, "
                f"0-255; {profile.DEFAULT_UNIT} by default)"
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
        **options: Any,
    ) -> Driver:
        """``options``: ``reset_function`` resets a Remote Control function found in
        use or halted (§6.5.2), on a robot that is not Running."""
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
            robot_type=robot.options.get("type"),
            axes=robot.options.get("axes"),
            first=first,
            last=last,
        )
        return EpsonDriver(controller)


#: The family, as the registry hands it out.
FAMILY = EpsonFamily()
