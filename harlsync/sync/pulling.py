"""Pull: read everything from the robot and save it as the project's backup,
refusing a controller that does not look like the robot backed up there."""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import partial
from operator import attrgetter
from pathlib import Path
from typing import TYPE_CHECKING, Any, Generic

from .. import families, lookup
from ..errors import LinkTimeout, PolicyError, ProjectError
from ..families.base import AnyFamily, Catalogue, D, Family, K, Progress
from ..project.lock import holding_project
from ..project.robot import Robot
from . import git
from .live import LiveRead, Station, read_live, station_number

if TYPE_CHECKING:
    from .items import Change

log = logging.getLogger(__name__)

__all__ = ["FEW_ITEMS", "MOST", "PullResult", "pull"]


@dataclass
class PullResult:
    path: Path
    robot: Robot
    changes: list[Change[Any]] | None  # None: there was no valid previous backup
    commit: str | None = None
    #: Files an earlier pull saved and nobody touched since, still uncommitted (its
    #: commit failed or was killed): this pull's save and commit take them over.
    earlier: list[str] = field(default_factory=list)
    #: What was read, in the family's words (Catalogue.contents).
    contents: str = ""
    #: Every file the save wrote or removed (relative to the project).
    written: list[str] = field(default_factory=list)
    #: Those of them an older format had written: the save wrote them in the
    #: current one, ``formats`` (the oldest found, the current).
    migrated: list[str] = field(default_factory=list)
    formats: tuple[int, int] = (0, 0)

    @property
    def changed(self) -> bool:
        """Whether the backup in git changes: a first backup, a change, files the save
        rewrote (a migration to the current format), or an earlier pull's files still
        to commit."""
        return (
            self.changes is None or bool(self.changes) or bool(self.written) or bool(self.earlier)
        )

    @property
    def summary(self) -> str:
        from .items import change_summary  # not before the first request (issue 24)
        from .policy import listed

        said = "first backup" if self.changes is None else change_summary(self.changes)
        if self.migrated:
            count = len(self.migrated)
            said += (
                f"; {count} file{'s' * (count != 1)} migrated from format {self.formats[0]} "
                f"to format {self.formats[1]}"
            )
        elif self.changes == [] and self.written:
            said += f"; rewritten as this harlsync writes them: {listed(self.written)}"
        if self.earlier:
            said += f"; with an earlier pull's backup, never committed ({listed(self.earlier)})"
        return said


def _robot_for(
    path: Path, port: str | None, station: Station, family: AnyFamily | None
) -> tuple[AnyFamily, Robot]:
    """The project's family and robot: robot.yaml's (:func:`_read_robot`), or a first
    pull's (``family``, by default the one whose own URL scheme ``port`` has, else
    the default family)."""
    if (path / "robot.yaml").exists():
        return _read_robot(path, family)
    if not port:
        raise ProjectError(
            f"{path}: no robot.yaml here; give --port (and --station) for a first pull"
        )
    # no robot.yaml: the family whose own URL scheme the port has, else the default
    family = family or lookup.family(families.of_port(port))
    return (
        family,
        family.new_robot(
            path.resolve().name, _absolute_sim_path(port), station_number(family, station)
        ),
    )


def _read_robot(path: Path, family: AnyFamily | None) -> tuple[AnyFamily, Robot]:
    """robot.yaml read by the project store, its one reader (which first finishes an
    interrupted save): its family and robot, or its problems raised, before the line
    opens.  What the first request waits for: PyYAML (its C parser where built) and
    the robot schema's compiled check; jsonschema only for a file that check refuses."""
    from ..project.store import family_of, load_robot

    found = family_of(path)
    if family is not None and family.name != found.name:
        raise ProjectError(
            f"{path / 'robot.yaml'}: the robot is of family {found.name}, not "
            f"{family.name}; drop --family (it is only for a first pull) or pull "
            "into another directory"
        )
    return found, load_robot(path, found)


def _absolute_sim_path(port: str) -> str:
    """``sim://projects/x`` as ``sim:///abs/projects/x``: robot.yaml works from any directory."""
    if not port.startswith("sim://"):
        return port
    rest = port[len("sim://") :]
    path, sep, query = rest.partition("?")
    if not path or path.startswith(("@", "/")):
        return port
    return f"sim://{Path(path).resolve()}{sep}{query}"


@holding_project("pull")
def pull(
    path: str | Path,
    *,
    port: str | None = None,
    station: Station = None,
    commit: bool = False,
    progress: Progress | None = None,
    lock_timeout: float = 10.0,
    allow_dirty: bool = False,
    family: AnyFamily | None = None,
    new_robot: bool = False,
    connect_options: Mapping[str, bool] | None = None,
    noted: Callable[[str], None] | None = None,
    discard_pending: bool = False,
) -> PullResult:
    """Read everything from the robot and write the project, atomically.

    A controller that does not look like the robot of the backup in ``path``
    (another version or program configuration, or most of the backup would
    change) is refused with PolicyError and the backup left as it was, unless
    ``new_robot`` (see :func:`_same_robot`).

    A pull that fails leaves the previous files untouched.  A project with
    uncommitted edits (other than robot.yaml, which a pull never rewrites) is
    refused unless ``allow_dirty``: the pull would overwrite them.  So is a project
    whose branch approved changes no push deployed yet and the robot does not hold
    (pending, :mod:`.states`), unless ``discard_pending``.  Files an
    earlier pull saved, untouched since, are not edits: this pull takes them over
    (:attr:`PullResult.earlier`) and commits them with its own.  ``family``
    is the controller family of a first pull (default: its port's scheme's, or the default);
    ``connect_options`` are the connection's (see :func:`connect`).  What the
    connection recovered on its own goes to the audit log and to ``noted``, one
    note a call, even when the pull then fails.
    """
    path = Path(path)
    family, robot = _robot_for(path, port, station, family)
    station = station_number(family, station)
    # git's answer on uncommitted edits, asked now and taken before the family
    # connects, or, for a family whose connection only reads (Family.connect_writes
    # False), once the line is open: its processes run meanwhile (issue 24).  Either
    # way a dirty project is refused before anything is written or saved.
    asked = None if allow_dirty else git.Asked(path)
    first = not (path / "robot.yaml").exists()
    pulling = _Pulling(path, family, robot, asked, port, station, new_robot)
    try:
        read = pulling.read(progress, lock_timeout, connect_options, noted)
        return pulling.save(read, commit=commit, discard_pending=discard_pending)
    except LinkTimeout as exc:
        if not first:
            raise
        at = robot.station if station is None else station
        raise _not_this_family(exc, family, at, port) from exc
    finally:
        if asked is not None:
            asked.close()


def _not_this_family(
    exc: LinkTimeout, family: AnyFamily, station: int, port: str | None
) -> LinkTimeout:
    """A first pull's timeout, saying what else it may mean: it guessed the family (or
    was told it) and its station, and a line that does not answer so may hold another
    family's controller (issue 31)."""
    return LinkTimeout(
        f"{exc.message}; or this is not a {family.title} at station "
        f"{family.format_station(station)}: harlsync probe --port {port} tells "
        "which controller answers there, and writes its robot.yaml (--write)",
        port=exc.port,
        station=exc.station,
        command=exc.command,
        station_text=exc.station_text,
    )


@dataclass
class _Pulling(Generic[K, D]):
    """One pull once robot.yaml is read and git asked (``asked``; None:
    ``allow_dirty``): the read, then the save, with what waits for the line to be
    open (git's answer, the backup loaded) done once, when first needed."""

    path: Path
    family: Family[K, D]
    robot: Robot
    asked: git.Asked | None
    port: str | None
    station: int | None
    new_robot: bool
    earlier: list[str] = field(default_factory=list)
    settled: bool = False
    loaded: list[D | None] = field(default_factory=list)
    #: the backup's files, as loaded
    read_from: dict[str, bytes] = field(default_factory=dict)

    def settle(self) -> None:
        """What waits for the line to be open, done once, before anything else is
        read or saved: git's answer."""
        if self.settled:
            return
        self.settled = True
        if self.asked is not None:
            from .policy import earlier_pull_and_edits

            self.earlier, dirty = earlier_pull_and_edits(self.path, self.family, self.asked)
            if dirty:
                raise PolicyError(
                    f"{self.path}: uncommitted changes a pull would overwrite ({dirty}); "
                    "commit or stash them, or overwrite them with "
                    f"'harlsync pull {self.path} --allow-dirty'"
                )

    def backup(self) -> D | None:
        """The backup in ``path`` (None: none), loaded once the line is open: the
        first request need not wait for it (issue 15)."""
        if not self.loaded:
            from ..project.store import read_project

            try:
                project, files = read_project(self.path, self.family)
                self.loaded.append(project.data)
                self.read_from.update(files)
            except ProjectError:
                self.loaded.append(None)
        return self.loaded[0]

    def same_identity(self, now: Mapping[str, str], where: str) -> None:
        """A swapped controller is refused at its first exchanges, not after a whole read."""
        self.settle()
        previous = self.backup()
        if previous is not None and not self.new_robot:
            differ = _identity_differs(self.family.catalogue.robot_identity(previous), now)
            if differ:
                raise _not_this_robot(self.path, where, differ)

    def read(
        self,
        progress: Progress | None,
        lock_timeout: float,
        connect_options: Mapping[str, bool] | None,
        noted: Callable[[str], None] | None,
    ) -> LiveRead[K, D]:
        """Everything the robot holds, a dirty project refused before anything is
        sent (or, for a family that cannot tell its identity first, after the read)."""
        if self.family.connect_writes:  # a dirty project refused before anything is sent
            self.settle()
        path, robot, port, station = self.path, self.robot, self.port, self.station
        read = read_live(
            self.family,
            robot,
            port,
            station,
            registers=robot.keep_registers,
            progress=progress,
            lock_timeout=lock_timeout,
            options=connect_options,
            whole=True,  # a backup finds out how far each table goes
            noted=partial(_record_notes, path, robot, port, station, noted),  # whatever follows
            identified=self.same_identity,
            command="pull",
        )
        self.settle()  # a family that cannot tell its identity first: after the read
        return read

    def save(self, read: LiveRead[K, D], *, commit: bool, discard_pending: bool) -> PullResult:
        """Save what was read as the backup, once it looks like the robot backed up
        here, and record (and, with ``commit``, commit) the pull."""
        from ..project.store import Project, save_project
        from .items import diff

        path, robot, things, live = self.path, self.robot, self.family.catalogue, read.live
        previous = self.backup()
        compared = None  # the changes without runtime data, when _same_robot found them
        if previous is not None and not self.new_robot:
            compared = _same_robot(path, things, previous, live, read.driver.label)
        if not discard_pending:
            _refuse_pending(path, things, live)
        written = save_project(path, Project(path, robot, live, self.family))
        if previous is None:
            changes = None
        elif compared is not None and not robot.keep_registers:
            changes = compared
        else:
            changes = diff(things, previous, live, registers=robot.keep_registers)
        result = PullResult(
            path,
            robot,
            changes,
            earlier=self.earlier,
            contents=things.contents(live, registers=robot.keep_registers),
            written=written,
        )
        _migrated(result, self.read_from, self.family.format)
        _record_pull(path, robot, result, commit=commit)
        return result


def _refuse_pending(path: Path, things: Catalogue[K, D], live: D) -> None:
    """Raise PolicyError when the project holds approved changes not yet on the
    robot, which the pull would overwrite."""
    from .policy import listed
    from .states import check_pending

    pending = check_pending(path, things, live)
    if pending:
        raise PolicyError(
            f"{path}: approved changes not yet on the robot that a pull would overwrite "
            f"({listed(pending)}); push them, or overwrite them with "
            f"'harlsync pull {path} --discard-pending'"
        )


def _record_pull(path: Path, robot: Robot, result: PullResult, *, commit: bool) -> None:
    """Record the pull in the robot's history and, with ``commit``, commit what it
    changed (naming the pushes since the last backup), noting the commit in
    ``result``."""
    from . import audit, auditindex, history

    since = history.read(path).get("last_success")
    history.record(path, ok=True, changed=result.changed, changes=result.summary)
    if commit and result.changed:
        message = history.commit_message(
            f"pull {robot.name}",
            result.summary,
            audit.changed_names(result.changes or []),
            auditindex.pushes_since(robot.port, robot.station, path, since),
        )
        result.commit = git.commit([path], message)
        if result.commit:
            history.committed(path, result.commit)


def _migrated(result: PullResult, was: Mapping[str, bytes], current: int) -> None:
    """Note in ``result`` the files it wrote that ``was`` (the backup as loaded) had in
    a format older than ``current``: a migration, which the pull says and commits."""
    from ..project.files import older_format

    found = {
        name: number
        for name in result.written
        if name in was and (number := older_format(was[name], current)) is not None
    }
    if found:
        result.migrated = sorted(found)
        result.formats = (min(found.values()), current)


def _record_notes(
    path: Path,
    robot: Robot,
    port: str | None,
    station: int | None,
    noted: Callable[[str], None] | None,
    notes: Sequence[str],
) -> None:
    """What a connection recovered on its own, in the audit log (event ``recover``,
    which :func:`.audit.results` leaves out: it is no push or rollback), and told
    to ``noted``."""
    from . import audit

    for note in notes:
        if noted is not None:
            noted(note)
        record = audit.base_record("recover")
        record.event = "recover"
        record.robot = audit.RecordedRobot(
            robot.name, port or robot.port, station if station is not None else robot.station
        )
        record.project = str(path.resolve())
        record.note = note
        try:
            audit.append(record)
        except OSError as exc:
            log.error("cannot write the audit log's record of %s: %s", note, exc)


#: A pull that would change more than this share of the items of one kind (steps,
#: positions...) looks like another robot ...
MOST = 0.5


#: ... when there are at least this many: a small table re-taught is the same robot.
FEW_ITEMS = 10


def _same_robot(
    path: Path, things: Catalogue[K, D], backup: D, live: D, where: str
) -> list[Change[K]]:
    """Raise PolicyError unless the controller read (``live``) looks like the robot
    backed up in ``path``: the same identity (the family's: version, configuration,
    model), nothing else the family tells from a whole read
    (:meth:`~harlsync.families.base.Catalogue.other_robot`), and not most items of a
    kind changed at once (runtime data aside), which a wrong port or station, a
    swapped controller or a lost memory would do.

    Each kind is judged alone: a hundred tables, most of them unused and alike
    on every robot, must not hide that every program step changed.

    Returns the changes, runtime data aside (``diff(things, backup, live)``): the
    pull need not work them out again."""
    from .items import change_summary, diff_items

    differ = _identity_differs(things.robot_identity(backup), things.robot_identity(live))
    if not differ:  # what only a whole read tells (the "not there" replies it found)
        why = things.other_robot(live, backup)
        differ = [why] if why is not None else []
    changes: list[Change[K]] = []
    if not differ:
        was, now = things.items(backup, registers=False), things.items(live, registers=False)
        changes = diff_items(things, was, now)
        held = Counter(map(attrgetter("kind"), was.keys() | now.keys()))
        for kind in sorted(held):
            of_kind = [c for c in changes if c.key.kind == kind]
            count = held[kind]
            if count >= FEW_ITEMS and len(of_kind) > MOST * count:
                differ = [
                    (
                        f"{change_summary(of_kind)} would change, {len(of_kind)} of the "
                        f"{count} items of that kind: it looks like another robot, or one "
                        "whose memory was lost"
                    )
                ]
                break
    if differ:
        raise _not_this_robot(path, where, differ)
    return changes


def _identity_differs(was: Mapping[str, str], now: Mapping[str, str]) -> list[str]:
    """Each part of the robot's identity that differs from the backup's, for a message."""
    return [
        f"{name} {_quoted(now.get(name))} (the backup has {_quoted(value)})"
        for name, value in was.items()
        if now.get(name) != value
    ]


def _quoted(value: str | None) -> str:
    """A part of an identity in a person's words: in quotes, or "none" when the
    controller did not give it (never Python's None or its string escapes)."""
    return "none" if value is None else f"'{value}'"


def _not_this_robot(path: Path, where: str, differ: list[str]) -> PolicyError:
    return PolicyError(
        f"{path}: the controller at {where} does not look like the robot backed up "
        f"here: {'; '.join(differ)}. The backup was left as it was. If this is the "
        f"robot (replaced, reconfigured, updated), accept it with "
        f"'harlsync pull {path} --new-robot'"
    )
