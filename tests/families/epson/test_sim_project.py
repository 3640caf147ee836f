"""The Epson simulator loaded from a project: the project's settings and points, its
manipulator type and model, on the unit and with the register map robot.yaml names;
a pull from it gives the project back, and ``harlsync sim --project`` serves it."""

from __future__ import annotations

from pathlib import Path

import pytest
from simprocess import harlsync_sim

from harlsync import families
from harlsync.errors import ProjectError
from harlsync.families.epson.controller import Controller
from harlsync.families.epson.handshake import Handshake
from harlsync.families.epson.map_form import map_to_dict
from harlsync.families.epson.profile import RegisterMap
from harlsync.families.epson.sim import SIM_FAMILY, SimState
from harlsync.families.epson.transport import ModbusLink
from harlsync.project import Project, save_project

from .sample import sample_data


def project_of(
    tmp_path: Path,
    *,
    axes: int = 4,
    unit: int | None = None,
    register_map: RegisterMap | None = None,
) -> Path:
    robot = families.get("epson").new_robot("cell-3", "modbus://10.0.0.5", unit)
    if register_map is not None:
        robot.options["map"] = map_to_dict(register_map)
    path = tmp_path / "cell-3"
    save_project(path, Project(path, robot, sample_data(axes)))
    return path


def pull(url: str, register_map: RegisterMap, unit: int = 1) -> dict[object, object]:
    with ModbusLink(url, unit=unit) as link:
        data = Controller(Handshake(link, register_map), first=0, last=99).read_all()
    return dict(data.items)


@pytest.mark.parametrize("axes", [4, 6])
def test_a_simulator_from_a_project_holds_its_settings_and_points(
    tmp_path: Path, axes: int
) -> None:
    sim = SIM_FAMILY.from_project(project_of(tmp_path, axes=axes), None)
    assert list(sim.stations) == [1]
    state = sim.stations[1]
    assert state == SimState.from_data(sample_data(axes))
    assert (state.robot_type, state.model) == ((3, "LS6-B602S") if axes == 4 else (5, "C4-A601S"))
    assert state.accel_s == {3: (100123, 200000)}
    assert state.boxes == {5: ((-10000, 10000), (-20000, 20000), (0, 50000))}
    assert state.limz == -10000 and sorted(state.points) == [0, 12, 13]
    assert state.points[13].local == 1 and state.points[13].j6flag == 5
    with sim.serve() as server:
        assert pull(server.url, sim.register_map) == sample_data(axes).items
    assert sim.function_errors == [] and sim.off_list() == []


def test_a_simulator_from_a_project_sits_on_its_unit_with_its_register_map(tmp_path: Path) -> None:
    moved = RegisterMap(command_words=6)
    sim = SIM_FAMILY.from_project(project_of(tmp_path, unit=7, register_map=moved), None)
    assert list(sim.stations) == [7] and sim.register_map == moved
    with sim.serve() as server:
        assert pull(server.url, moved, unit=7) == sample_data().items
    assert sim.function_errors == [] and sim.off_list() == []
    again = SIM_FAMILY.from_project(project_of(tmp_path / "b"), [2, 3])
    assert list(again.stations) == [2, 3]
    assert again.stations[2] == again.stations[3] and again.stations[2] is not again.stations[3]


def test_a_project_of_another_family_or_a_broken_one_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ProjectError):
        SIM_FAMILY.from_project(tmp_path / "none", None)


def test_harlsync_sim_serves_an_epson_project(tmp_path: Path) -> None:
    project = project_of(tmp_path)
    with harlsync_sim(
        "--family", "epson", "--listen", "127.0.0.1:0", "--project", str(project), lines=2
    ) as (_, lines):
        assert pull(lines["tcp"], RegisterMap()) == sample_data().items
