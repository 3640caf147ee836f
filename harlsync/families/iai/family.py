"""IAI protocol B as the engine sees it: its catalogue, files, robot and line.

Only the declarations (name, options, schemes, words, stations, help) are made at
import: the catalogue, the files' layout and the protocol are imported when the
family is first used, so ``--help`` and the registry's look-ups stay cheap.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..base import Analysis, Catalogue, Driver, Family, Help, Words
from . import profile

if TYPE_CHECKING:
    from ...project.robot import Robot
    from .catalogue import Key
    from .layout import IaiData

__all__ = ["FAMILY", "IaiFamily"]


class IaiFamily(Family["Key", "IaiData"]):
    name = "iai"
    title = "IAI (protocol B: TTA, X-SEL, SSEL/ASEL/PSEL, TT)"
    directories: tuple[str, ...] = ()
    deploy_notes = (profile.PERSISTENCE_NOTICE,)
    words = Words(state="the task states")
    default_station = profile.DEFAULT_STATION
    #: the default station, then 01-0F (the axis numbers a line of several takes)
    probe_stations = (profile.DEFAULT_STATION, *range(1, 16))
    #: the speeds the controller offers (p.7), the profile's first
    probe_bauds = profile.BAUDRATES
    help = Help(
        stations=f"two hex digits, {profile.DEFAULT_STATION:02X} by default",
        station_list="99,1-F",
        pull="the position table",
        items="position",
        item="'position 3'",
        identity="model code, unit code, version",
        runtime="flags and variables",
        commands="each 291H, field by field",
        order="positions",
        busy="a program running, MANUAL, emergency stop, an axis in use, 215H and 212H",
    )

    @property
    def catalogue(self) -> Catalogue[Key, IaiData]:
        from .catalogue import CATALOGUE

        return CATALOGUE

    @property
    def format(self) -> int:
        from .layout import FORMAT

        return FORMAT

    def analyse(self, files: Mapping[str, bytes]) -> Analysis:
        from .analysis import analyse

        return analyse(files)

    def render_files(self, robot: Robot, data: IaiData) -> dict[str, str]:
        from . import layout

        return layout.render_files(robot, data)

    def data_problems(self, data: IaiData) -> list[str]:
        from .model import VARIABLE_SECTIONS, variable_problem

        problems = [
            f"position {n}: {problem}"
            for n, position in sorted(data.positions.items())
            for problem in position.problems()
        ]
        for section, values in data.variables().items():
            for n, value in sorted(values.items()):
                problem = variable_problem(section, value)
                if problem is not None:  # read so from the controller: say what to do there
                    problems.append(
                        f"{VARIABLE_SECTIONS[section]} {n}: {problem}; change it on "
                        f"the controller or leave it out of robot.yaml "
                        f"controller.{section}"
                    )
        return problems

    def project_files(self, root: Path) -> list[str]:
        from . import layout

        names = [*layout.ROOT_FILES, layout.VARIABLES_FILE, layout.RECORDS_FILE]
        return [name for name in names if (root / name).is_file()]

    def stale_files(
        self, root: Path, texts: Mapping[str, str], robot: Robot, data: IaiData
    ) -> list[str]:
        """variables.yaml when the robot does not keep registers (a robot that keeps
        them but was read without them keeps its file); records.yaml when it keeps
        no read-only records."""
        from . import layout

        stale = []
        if not (layout.VARIABLES_FILE in texts or (robot.keep_registers and not data.variables())):
            stale.append(layout.VARIABLES_FILE)
        if layout.RECORDS_FILE not in texts and not layout.record_ranges(robot):
            stale.append(layout.RECORDS_FILE)
        return [name for name in stale if (root / name).is_file()]

    def robot_text(self, robot: Robot) -> str:
        from . import layout

        return layout.render_robot(robot)

    def schemas(self) -> dict[str, str]:
        from . import layout

        return layout.SCHEMAS.files()

    def new_robot(self, name: str, port: str, station: int | None, **options: object) -> Robot:
        """``options`` are :class:`Robot` fields (``serial``, ``windows``, ``description``,
        ``keep_registers``, ``options``: model, axes, first, last), over the profile's."""
        from ...project.robot import Robot
        from .codec import SETTINGS

        fields: dict[str, Any] = {
            "serial": SETTINGS,
            "options": {
                "model": profile.DEFAULT_MODEL,
                "first": profile.DEFAULT_POSITION_RANGE[0],
                "last": profile.DEFAULT_POSITION_RANGE[1],
            },
        }
        fields.update(options)
        return Robot(
            family=self.name,
            name=name,
            port=port,
            station=profile.DEFAULT_STATION if station is None else station,
            **fields,
        )

    def parse_station(self, text: str) -> int:
        """Two hex digits, as robot.yaml holds them: ``--station 9`` is refused as
        robot.yaml's ``station: "9"`` is."""
        from . import layout

        if not layout.STATION.fullmatch(text):
            raise ValueError(f"{text!r} is not a station (allowed: {profile.STATION_ALLOWED})")
        return int(text, 16)

    def format_station(self, station: int) -> str:
        return f"{station:02X}"

    def connect(
        self,
        robot: Robot,
        port: str | None,
        station: int | None,
        *,
        lock_timeout: float,
        **options: bool,
    ) -> Driver[Key, IaiData]:
        from . import layout
        from .controller import Controller
        from .driver import IaiDriver

        first, last = layout.position_range(robot)
        controller = Controller.from_url(
            port or robot.port,
            station if station is not None else robot.station,
            robot.serial,
            lock_timeout=lock_timeout,
            model=str(robot.options.get("model", profile.DEFAULT_MODEL)),
            axes=robot.options.get("axes"),
            first=first,
            last=last,
            variables=layout.variable_ranges(robot),
            records=layout.record_ranges(robot),
            known_axes=robot.options.get(layout.REPORTED_AXES, ()),
            real_word_order=robot.options.get("real_word_order"),
            recorded_word_order=robot.options.get(layout.RECORDED_WORD_ORDER),
        )
        return IaiDriver(controller)


#: The family, as the registry hands it out.
FAMILY = IaiFamily()
