"""The Hirata HARL-U2 as the engine sees it: its catalogue, files, robot and line.

Only the declarations (name, words, stations, help) are made at import: the
catalogue, the files' layout and the protocol are imported when the family is
first used, so ``--help`` and the registry's look-ups stay cheap.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..base import Analysis, Catalogue, Driver, Family, Help, Words
from .declared import FIRST_STATION, LAST_STATION, PROGRAMS_DIR, STATION_ALLOWED

if TYPE_CHECKING:
    from ...project.robot import Robot
    from .catalogue import Key
    from .model import RobotData

__all__ = ["FAMILY", "HarlU2Family"]


class HarlU2Family(Family["Key", "RobotData"]):
    name = "harl-u2"
    title = "Hirata HARL-U2"
    directories = (PROGRAMS_DIR,)
    deploy_notes: tuple[str, ...] = ()
    words = Words(state="the task states")
    stations = range(FIRST_STATION, LAST_STATION + 1)
    #: the connection reads LNX and LNV; its codec cannot send anything but a read
    #: before an interlock check (protocol/commands.py)
    connect_writes = False
    #: the stations the manual gives as defaults, set on the pendant (2.2, p. 2-2)
    probe_stations = (1, 2, 3, 4)
    help = Help(
        stations=f"{STATION_ALLOWED}, as set on the pendant",
        station_list="1-4",
        pull="the configuration, every program step, the parameters, the offset tables "
        "and the timers",
        items="program, step, table, field, timer",
        item="'MAIN program 0 step 2'",
        identity="version, program configuration",
        runtime="registers",
        commands="SN commands",
        order="configuration, parameters, tables, timers, programs",
        busy="a task in execution or suspended, LNR",
        live_tuning="timers and offset tables (the manual allows it); programs, "
        "parameters, configuration and registers never",
        reconfigure="SNX, a program configuration change: every program",
    )

    @property
    def catalogue(self) -> Catalogue[Key, RobotData]:
        from .catalogue import CATALOGUE

        return CATALOGUE

    @property
    def format(self) -> int:
        from .layout import FORMAT

        return FORMAT

    def analyse(self, files: Mapping[str, bytes]) -> Analysis:
        from . import analysis

        return analysis.analyse(files)

    def render_files(self, robot: Robot, data: RobotData) -> dict[str, str]:
        from . import layout

        return layout.render_files(robot, data)

    def data_problems(self, data: RobotData) -> list[str]:
        # Step.problems() first: the YAML rendering cannot show every one of them
        # (a step with data but no command renders as empty).
        return [
            f"program {key[0].value} {key[1]} step {n}: {problem}"
            for key, steps in data.programs.items()
            for n, step in steps.items()
            for problem in step.problems()
        ]

    def project_files(self, root: Path) -> list[str]:
        from . import layout

        names = [name for name in layout.ROOT_FILES if (root / name).is_file()]
        programs = root / layout.PROGRAMS_DIR
        if programs.is_dir():
            names += sorted(
                f"{layout.PROGRAMS_DIR}/{p.name}"
                for p in programs.iterdir()
                if p.is_file() and p.suffix in (".yaml", ".yml") and not p.name.startswith(".")
            )
        return names

    def stale_files(
        self, root: Path, texts: Mapping[str, str], robot: Robot, data: RobotData
    ) -> list[str]:
        from . import layout

        stale = []
        keep_registers_file = robot.keep_registers and data.registers is None
        unwanted = "registers.yaml" not in texts and not keep_registers_file
        if unwanted and (root / "registers.yaml").is_file():
            stale.append("registers.yaml")
        programs = root / layout.PROGRAMS_DIR
        if programs.is_dir():
            for p in sorted(programs.iterdir()):
                name = f"{layout.PROGRAMS_DIR}/{p.name}"
                if p.is_file() and layout.program_key(name) is not None and name not in texts:
                    stale.append(name)
        return stale

    def schemas(self) -> dict[str, str]:
        from . import layout

        return layout.SCHEMAS.files()

    def robot_text(self, robot: Robot) -> str:
        from . import layout

        return layout.render_robot(robot)

    def new_robot(self, name: str, port: str, station: int | None, **options: Any) -> Robot:
        from ...project.robot import Robot

        return Robot(
            family=self.name,
            name=name,
            port=port,
            station=1 if station is None else station,
            **options,
        )

    def parse_station(self, text: str) -> int:
        """Decimal digits in robot.yaml's range, with its message (its schema's
        ``x-allowed``): ``0 is out of range (allowed: 1-99)``."""
        if not (text.isascii() and text.isdigit()):
            raise ValueError(f"{text!r} is not a station (allowed: {STATION_ALLOWED})")
        station = int(text)
        if not FIRST_STATION <= station <= LAST_STATION:
            raise ValueError(f"{station} is out of range (allowed: {STATION_ALLOWED})")
        return station

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
    ) -> Driver[Key, RobotData]:
        from .controller import Controller
        from .driver import HarlU2Driver
        from .model import no_such_table, offset_tables

        controller = Controller.from_url(
            port or robot.port,
            station if station is not None else robot.station,
            robot.serial,
            lock_timeout=lock_timeout,
        )
        return HarlU2Driver(
            controller,
            offset_tables=offset_tables(robot),
            no_such_table=no_such_table(robot),
        )


#: The family, as the registry hands it out.
FAMILY = HarlU2Family()
