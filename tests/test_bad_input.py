"""Bad input: every mistake in a project file or on the line ends in ONE line on
stderr that says what is wrong and where (file and line; port and station), a
non-zero exit, no write to the controller and not one byte changed in the project.

Everything goes through the real CLI (``harlsync.cli.main``, and the installed
``harlsync`` executable for two cases) against a simulator served over a real TCP
socket or pty.  "No write" is asserted on what the simulator received: for a
broken project not even a read (the port is never opened), for a broken line no
SN command.  "Not one byte changed" compares every file of the project, the
hidden ``.harlsync/`` included, before and after.

Exit codes: 2 for every error.  ``validate`` answers 1 (its documented "invalid").
A push whose very first LNR is answered with an E status or with garbage exits 3,
refused for safety, as the README documents (a robot answered and its state is
unknown); a line where nothing answers at all (wrong station) is an error, 2.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from conftest import git
from fsfaults import disk_full, read_only
from simline import SMALL, ScriptedSim

from harlsync.cli import main
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.sim.serve import PtyServer, TcpServer
from harlsync.sync import engine

SEED = 11


@pytest.fixture(scope="module")
def golden(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """A committed backup of the simulated robot, with a short reply deadline."""
    repo = tmp_path_factory.mktemp("golden") / "plant"
    repo.mkdir()
    git(repo, "init", "-q")
    with (
        pytest.MonkeyPatch.context() as env,
        TcpServer(Simulator(SimState.generate(SEED, SMALL))) as server,
    ):
        env.setenv("HARLSYNC_LOCK_DIR", str(repo.parent / "locks"))
        engine.pull(repo / "cell", port=server.url)
    robot_yaml = repo / "cell" / "robot.yaml"
    robot_yaml.write_text(
        robot_yaml.read_text()
        .replace("timeout: 1.0", "timeout: 0.2")
        .replace("retries: 3", "retries: 1")
    )
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "backup")
    yield repo
    shutil.rmtree(repo.parent, ignore_errors=True)


@pytest.fixture
def project(golden: Path, tmp_path: Path) -> Path:
    repo = tmp_path / "plant"
    shutil.copytree(golden, repo)
    return repo / "cell"


@pytest.fixture
def sim() -> Iterator[tuple[ScriptedSim, str]]:
    """The robot the project was pulled from (identical to it), over TCP."""
    robot = ScriptedSim(SimState.generate(SEED, SMALL))
    with TcpServer(robot) as server:
        yield robot, server.url


def tree(root: Path) -> dict[str, bytes]:
    """Every file of the project (``.git`` aside), by path: what must not change."""
    return {
        str(p.relative_to(root)): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file() and ".git" not in p.relative_to(root).parts
    }


def cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    capsys.readouterr()
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def one_line(err: str) -> str:
    """The only line on stderr (fails when there are more, or none)."""
    assert err.endswith("\n") and err.count("\n") == 1, f"not one line: {err!r}"
    assert "Traceback" not in err
    return err[:-1]


# --- project files: file x defect -------------------------------------------------------------

#: (file, defect) -> (text in the file, replacement, "file:line", what the message says)
DEFECTS: dict[tuple[str, str], tuple[str, str, str, str]] = {
    ("robot.yaml", "malformed"): (
        "  station: 1\n",
        "  station: [1\n",
        "robot.yaml:7",
        "YAML syntax error: ",
    ),
    ("robot.yaml", "wrong type"): (
        "  station: 1\n",
        "  station: one\n",
        "robot.yaml:6",
        "connection.station: 'one' is not an integer (allowed: 1-99)",
    ),
    ("robot.yaml", "out of range"): (
        "  station: 1\n",
        "  station: 100\n",
        "robot.yaml:6",
        "connection.station: 100 is out of range (allowed: 1-99)",
    ),
    ("robot.yaml", "unknown key"): (
        "  station: 1\n",
        "  station: 1\n  speed: 3\n",
        "robot.yaml:7",
        "connection.speed: unknown key (allowed: port, station, ",
    ),
    # Issue 34 item 11: more digits than Python converts to an int (4,300) crashed a
    # pull in the quick reader; pull, push, diff and plan say it as validate does.
    ("robot.yaml", "issue 34: a number of 5000 digits"): (
        "  station: 1\n",
        f"  station: {'9' * 5000}\n",
        "robot.yaml:6",
        f"connection.station: {'9' * 77}... is out of range (allowed: 1-99)",
    ),
    ("robot.yaml", "issue 34: a format of 5000 digits"): (
        "format: 2\n",
        f"format: {'3' * 5000}\n",
        "robot.yaml:2",
        f"format {'3' * 77}... is newer than this harlsync understands (2): upgrade harlsync",
    ),
    ("controller.yaml", "malformed"): (
        "timers: 4\n",
        "timers: {4\n",
        "controller.yaml:10",
        "YAML syntax error: ",
    ),
    ("controller.yaml", "wrong type"): (
        "timers: 4\n",
        "timers: four\n",
        "controller.yaml:9",
        "timers: 'four' is not an integer (allowed: 0-9999)",
    ),
    ("controller.yaml", "out of range"): (
        "main: {count: 2,",
        "main: {count: 101,",
        "controller.yaml:6",
        "programs.main.count: 101 is out of range (allowed: 0-100)",
    ),
    ("controller.yaml", "unknown key"): (
        "timers: 4\n",
        "timers: 4\nspeed: 3\n",
        "controller.yaml:10",
        "speed: unknown key (allowed: format, version, ",
    ),
    ("parameters.yaml", "malformed"): (
        "pull_rate: 50\n",
        "pull_rate: [50\n",
        "parameters.yaml:13",
        "YAML syntax error: ",
    ),
    ("parameters.yaml", "wrong type"): (
        "pull_rate: 50\n",
        "pull_rate: [50]\n",
        "parameters.yaml:12",
        "pull_rate: a list is not a number or text (allowed: one token",
    ),
    ("parameters.yaml", "out of range"): (
        "pull_rate: 50\n",
        "pull_rate: 'a b'\n",
        "parameters.yaml:12",
        "pull_rate: 'a b' is not allowed (allowed: one token",
    ),
    ("parameters.yaml", "unknown key"): (
        "format: 2\n",
        "format: 2\nspeed: 3\n",
        "parameters.yaml:3",
        "speed: unknown key (allowed: format, pull_limit, ",
    ),
    ("offsets.yaml", "malformed"): (
        "  3: {x: 0.00,",
        "  3: {x: 0.00,,",
        "offsets.yaml:7",
        "YAML syntax error: ",
    ),
    ("offsets.yaml", "wrong type"): (
        "  3: {x: 0.00,",
        "  3: {x: abc,",
        "offsets.yaml:7",
        "tables.3.x: 'abc' is not a number (allowed: -9999.99..9999.99",
    ),
    ("offsets.yaml", "out of range"): (
        "  3: {x: 0.00,",
        "  3: {x: 10000.00,",
        "offsets.yaml:7",
        "tables.3.x: 10000.00 is out of range (allowed: -9999.99..9999.99",
    ),
    ("offsets.yaml", "unknown key"): (
        "format: 2\n",
        "format: 2\nspeed: 3\n",
        "offsets.yaml:3",
        "speed: unknown key (allowed: format, tables)",
    ),
    ("timers.yaml", "malformed"): (
        "  3: 0.00\n",
        "  3: [0.00\n",
        "timers.yaml:8",
        "YAML syntax error: ",
    ),
    ("timers.yaml", "wrong type"): (
        "  3: 0.00\n",
        "  3: abc\n",
        "timers.yaml:7",
        "timers.3: 'abc' is not a number (allowed: 0.00-9.99, two decimals)",
    ),
    ("timers.yaml", "out of range"): (
        "  3: 0.00\n",
        "  3: 12.50\n",
        "timers.yaml:7",
        "timers.3: 12.50 is out of range (allowed: 0.00-9.99, two decimals)",
    ),
    ("timers.yaml", "unknown key"): (
        "format: 2\n",
        "format: 2\nspeed: 3\n",
        "timers.yaml:3",
        "speed: unknown key (allowed: format, timers)",
    ),
    ("timers.yaml", "outside the configuration"): (
        "  3: 0.00\n",
        "  3: 0.00\n  4: 1.00\n",
        "timers.yaml:8",
        "timers.4: timer 4 is outside the configuration (allowed: 0-3)",
    ),
    ("programs/main-00.yaml", "malformed"): (
        "  - CALLS S00\n",
        "  - CALLS: S00: x\n",
        "programs/main-00.yaml:8",
        "YAML syntax error: ",
    ),
    ("programs/main-00.yaml", "wrong type"): (
        "  - CALLS S00\n",
        "  - [1, 2]\n",
        "programs/main-00.yaml:8",
        "steps.2: a list is not text or nothing (allowed: a command and at most 4",
    ),
    ("programs/main-00.yaml", "out of range"): (
        "number: 0\n",
        "number: 100\n",
        "programs/main-00.yaml:4",
        "number: 100 is out of range (allowed: 0-99 (START: 0))",
    ),
    ("programs/main-00.yaml", "unknown key"): (
        "format: 2\n",
        "format: 2\nspeed: 3\n",
        "programs/main-00.yaml:3",
        "speed: unknown key (allowed: format, type, number, steps)",
    ),
    ("programs/main-00.yaml", "outside the configuration"): (
        "  - END\n",
        "  - END\n  - END\n",
        "programs/main-00.yaml:14",
        "steps.8: step 8 is outside the configuration (allowed: 0-7, controller.yaml ",
    ),
    # Issue 11: values the schemas let through, but the wire cannot carry or give back.
    ("parameters.yaml", "read back as an error status"): (
        "format: 2\npull_limit: ",
        "format: 2\npull_limit: E",
        "parameters.yaml:3",
        (
            "would begin the LNE reply with 'E', which reads as an error status: the robot "
            "could not be read again (allowed: one token not beginning with 'E')"
        ),
    ),
    ("programs/main-00.yaml", "longer than a frame"): (
        "  - CALLS S00\n",
        "  - CALLS S" + "0" * 600 + "\n",
        "programs/main-00.yaml:8",
        "steps.2: 607 characters are more than a frame carries (allowed: at most 500 in this",
    ),
    ("offsets.yaml", "not as the controller gives it back"): (
        "  3: {x: 0.00,",
        "  3: {x: -0000.00,",
        "offsets.yaml:7",
        "tables.3.x: -0000.00 is not written in its one form (write 0.00: ",
    ),
}
FILES = [
    "robot.yaml",
    "controller.yaml",
    "parameters.yaml",
    "offsets.yaml",
    "timers.yaml",
    "programs/main-00.yaml",
]
for _file in FILES:
    DEFECTS[(_file, "newer format")] = (
        "format: 2\n",
        "format: 3\n",
        f"{_file}:2",
        "format 3 is newer than this harlsync understands (2): upgrade harlsync",
    )
    # Issue 11: the same key, spelled as JSON spells it, is the same newer format.
    DEFECTS[(_file, "newer format, quoted key")] = (
        "format: 2\n",
        '"format": 3\n',
        f"{_file}:2",
        "format 3 is newer than this harlsync understands (2): upgrade harlsync",
    )


def break_file(project: Path, file: str, old: str, new: str) -> None:
    path = project / file
    text = path.read_text()
    assert old in text, f"{old!r} not in {file}"
    path.write_text(text.replace(old, new, 1))
    git(project.parent, "add", "-A")
    git(project.parent, "commit", "-qm", f"break {file}")


@pytest.mark.parametrize(("file", "defect"), list(DEFECTS), ids=[f"{f}-{d}" for f, d in DEFECTS])
def test_a_broken_project_file_is_one_line_naming_file_and_line_and_nothing_is_sent(
    project: Path,
    sim: tuple[ScriptedSim, str],
    capsys: pytest.CaptureFixture[str],
    file: str,
    defect: str,
) -> None:
    robot, url = sim
    old, new, where, says = DEFECTS[(file, defect)]
    break_file(project, file, old, new)
    before = tree(project)
    for command in (["push", "--yes"], ["diff"], ["plan"]):
        code, _, err = cli(capsys, command[0], str(project), "--port", url, *command[1:])
        line = one_line(err)
        assert code == 2, (command, line)
        assert line.startswith(f"harlsync: error: {where}: "), line
        assert says in line, line
    assert robot.received == []  # the port was never opened
    assert tree(project) == before

    code, out, err = cli(capsys, "validate", str(project))
    assert code == 1
    assert out.startswith(f"{where}: ") and says in out.splitlines()[0]
    assert one_line(err) == f"harlsync: {project}: {len(out.splitlines())} problem(s)"


@pytest.mark.parametrize(
    ("file", "defect"),
    [k for k in DEFECTS if k[0] == "robot.yaml" or k[1].startswith("newer format")],
    ids=[f"{f}-{d}" for f, d in DEFECTS if f == "robot.yaml" or d.startswith("newer format")],
)
def test_a_pull_into_a_project_it_cannot_read_or_must_not_overwrite_changes_nothing(
    project: Path,
    sim: tuple[ScriptedSim, str],
    capsys: pytest.CaptureFixture[str],
    file: str,
    defect: str,
) -> None:
    # A pull rewrites a broken controller.yaml or timers.yaml: that is how a backup is
    # repaired.  It cannot do without robot.yaml, and never overwrites a newer format.
    robot, url = sim
    old, new, where, says = DEFECTS[(file, defect)]
    break_file(project, file, old, new)
    before = tree(project)
    code, _, err = cli(capsys, "pull", str(project), "--port", url)
    line = one_line(err)
    assert code == 2
    assert line.startswith(f"harlsync: error: {where}: ") and says in line, line
    if file == "robot.yaml":
        assert robot.received == []
    assert robot.writes_received() == []
    assert tree(project) == before


def test_a_program_outside_the_configuration_is_refused_naming_the_program_file(
    project: Path, sim: tuple[ScriptedSim, str], capsys: pytest.CaptureFixture[str]
) -> None:
    extra = project / "programs" / "main-02.yaml"  # MAIN programs 0-1 are configured
    extra.write_text(
        (project / "programs" / "main-01.yaml").read_text().replace("number: 1", "number: 2")
    )
    git(project.parent, "add", "-A")
    git(project.parent, "commit", "-qm", "a third MAIN program")
    robot, url = sim
    before = tree(project)
    code, _, err = cli(capsys, "push", str(project), "--port", url, "--yes")
    assert code == 2
    assert one_line(err) == (
        "harlsync: error: programs/main-02.yaml:4: number: MAIN program 2 is outside the "
        "configuration (allowed: 0-1, controller.yaml programs.main.count)"
    )
    assert robot.received == []
    assert tree(project) == before


# --- what no commit holds --------------------------------------------------------------------


def link_out(project: Path, name: str) -> str:
    """Move ``name`` (a file or ``programs``) out of the repository, leave a symbolic
    link in its place and commit the link: git status stays clean whatever the
    target holds.  The message names the link and where it leads."""
    elsewhere = project.parent.parent / "elsewhere"
    elsewhere.mkdir()
    (project / name).rename(elsewhere / name)
    (project / name).symlink_to(elsewhere / name)
    git(project.parent, "add", "-A")
    git(project.parent, "commit", "-qm", f"{name} lives elsewhere")
    return (
        f"{project / name} is a symbolic link to {(elsewhere / name).resolve()}, outside "
        f"the git repository {project.parent.resolve()}, so no commit holds what a push "
        "reads there: move it into the repository and commit it, or give --allow-dirty"
    )


def ignore(project: Path, pattern: str) -> str:
    """Take what ``pattern`` names out of git and ignore it (.gitignore)."""
    repo = project.parent
    (repo / ".gitignore").write_text(pattern + "\n")
    git(repo, "rm", "-r", "-q", "--cached", "cell" if pattern == "cell/" else f"cell/{pattern}")
    git(repo, "add", ".gitignore")
    git(repo, "commit", "-qm", f"ignore {pattern}")
    first = "robot.yaml" if pattern == "cell/" else pattern
    return (
        f"{project / first} is ignored by git (.gitignore), so no commit holds it: "
        "git add -f it and commit it"
    )


def hide_changes(project: Path) -> str:
    """Tell git to stop looking at timers.yaml (skip-worktree): git status stays clean."""
    git(project.parent, "update-index", "--skip-worktree", "cell/timers.yaml")
    return f"{project / 'timers.yaml'} differs from commit "


def link_in_repository(project: Path) -> str:
    """timers.yaml links to a committed file elsewhere in the repository."""
    shared = project.parent / "shared"
    shared.mkdir()
    (project / "timers.yaml").rename(shared / "timers.yaml")
    (project / "timers.yaml").symlink_to("../shared/timers.yaml")
    git(project.parent, "add", "-A")
    git(project.parent, "commit", "-qm", "timers shared")
    return f"{project / 'timers.yaml'} (shared/timers.yaml in the repository) differs from commit "


#: how the project hides an edit from git status -> (set it up: the message, the file edited)
HIDDEN: dict[str, tuple[Callable[[Path], str], str]] = {
    "programs/ linked out of the repository": (
        lambda p: link_out(p, "programs"),
        "programs/main-00.yaml",
    ),
    "a file linked out of the repository": (lambda p: link_out(p, "timers.yaml"), "timers.yaml"),
    "the project directory ignored": (lambda p: ignore(p, "cell/"), "timers.yaml"),
    "a file ignored": (lambda p: ignore(p, "timers.yaml"), "timers.yaml"),
    "a file git was told to skip": (hide_changes, "timers.yaml"),
    "a file linked elsewhere in the repository": (link_in_repository, "timers.yaml"),
}
#: file -> an edit that gives the push something to write
EDITS = {
    "timers.yaml": ("  3: 0.00\n", "  3: 0.50\n"),
    "programs/main-00.yaml": ("  2: CALLS S00\n", "  2: CALLS S01\n"),
}


@pytest.mark.parametrize("how", list(HIDDEN))
def test_issue_11_a_push_sends_only_what_the_commit_holds_whatever_hides_an_edit_from_git(
    project: Path, sim: tuple[ScriptedSim, str], capsys: pytest.CaptureFixture[str], how: str
) -> None:
    # Issue 11: a programs/ directory linked out of the repository, or a directory
    # .gitignore names, hid an edit from git status: push sent it, and the audit named
    # a commit that does not hold it.
    robot, url = sim
    setup, edited = HIDDEN[how]
    says = setup(project)
    old, new = EDITS[edited]
    (project / edited).write_text((project / edited).read_text().replace(old, new, 1))
    assert git(project.parent, "status", "--porcelain", "--", "cell") == ""  # hidden
    elsewhere = project.parent.parent / "elsewhere"
    before = tree(project.parent), tree(elsewhere)  # the repository, and what it links to
    code, _, err = cli(capsys, "push", str(project), "--port", url, "--yes")
    line = one_line(err)
    assert code == 3, line
    assert line.startswith(f"harlsync: refused: {says}"), line
    assert robot.received == []  # the port was never opened
    assert (tree(project.parent), tree(elsewhere)) == before


# --- the project's own disk -------------------------------------------------------------------

#: what the disk does -> what the one line says about it
DISKS = {
    "read-only": "(Read-only file system): it is on a read-only file system: mount it read-write",
    "full": "(No space left on device): free some space on that file system (df -h)",
}


@pytest.mark.parametrize("command", ["pull", "push"])
@pytest.mark.parametrize("disk", list(DISKS))
def test_a_project_on_a_disk_that_refuses_writes_is_one_line_and_nothing_is_sent_or_left(
    project: Path,
    sim: tuple[ScriptedSim, str],
    capsys: pytest.CaptureFixture[str],
    disk: str,
    command: str,
) -> None:
    # Issue 11: a read-only project directory, or a disk that fills up while the pull
    # saves (or the push saves its snapshot), gave a traceback and left a temporary.
    robot, url = sim
    if command == "pull":
        robot.stations[1].data.timers[1] = "9.99"  # something to save
    else:
        break_file(project, "timers.yaml", "  3: 0.00\n", "  3: 0.50\n")  # something to write
    before = tree(project)
    with pytest.MonkeyPatch.context() as fs:
        (read_only if disk == "read-only" else disk_full)(fs, project)
        argv = [command, str(project), "--port", url, *(["--yes"] if command == "push" else [])]
        code, _, err = cli(capsys, *argv)
    line = one_line(err)
    assert code == 2
    assert line.startswith(f"harlsync: error: {project}") and DISKS[disk] in line, line
    assert robot.writes_received() == []
    assert tree(project) == before  # nothing changed, no temporary left


#: ``python -c`` this with a project directory: it holds the project's lock, as a
#: pull that is saving it does, says "held", and lets go at a line on its input.
HOLD_PROJECT = """
import sys
from harlsync.project.lock import project_lock
with project_lock(sys.argv[1], command="pull"):
    print("held", flush=True)
    sys.stdin.readline()
"""


@pytest.mark.parametrize("command", ["pull", "push", "backup"])
def test_a_project_another_harlsync_is_saving_is_one_line_naming_it_and_nothing_is_sent(
    project: Path, sim: tuple[ScriptedSim, str], capsys: pytest.CaptureFixture[str], command: str
) -> None:
    # Issue 11: two commands that save one directory (two pulls over two lines) mixed it.
    robot, url = sim
    robot.stations[1].data.timers[1] = "9.99"  # a pull has something to save, a push to write
    argv = {
        "pull": ["pull", str(project), "--port", url, "--lock-timeout", "0"],
        "push": ["push", str(project), "--port", url, "--yes", "--lock-timeout", "0"],
        "backup": ["backup", str(project), "--lock-timeout", "0", "--attempts", "1"],
    }[command]
    before = tree(project)
    with subprocess.Popen(
        [sys.executable, "-c", HOLD_PROJECT, str(project)],
        text=True,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
    ) as holder:
        assert holder.stdout is not None and holder.stdout.readline() == "held\n"
        code, out, err = cli(capsys, *argv)
        holder.communicate("\n", timeout=60)
    says = (
        f"project {project} is in use by pid {holder.pid} (harlsync pull); wait for it to "
        "finish and run again"
    )
    if command == "backup":
        assert code == 1 and err == ""
        [row] = [line for line in out.splitlines() if line.startswith("cell ")]
        assert row.split()[1] == "FAILED" and says in row
    else:
        assert code == 2
        assert one_line(err).startswith(f"harlsync: error: {says}")
    assert robot.received == []  # the port was never opened
    assert tree(project) == before


# --- the line ---------------------------------------------------------------------------------


def not_a_port(kind: str, tmp_path: Path) -> tuple[str, str]:
    """A --port value of this kind and what the message says about it."""
    if kind == "missing":
        return str(tmp_path / "ttyUSB9"), "no such device; check that the USB-serial adapter"
    if kind == "/dev/null":
        return (
            "/dev/null",
            "not a serial port (a device that is not a terminal); give the serial device",
        )
    if kind == "regular file":
        path = tmp_path / "ttyUSB0.txt"
        path.write_bytes(b"not a port\n")
        return str(path), "not a serial port (a regular file); give the serial device"
    path = tmp_path / "ports"
    path.mkdir()
    return str(path), "not a serial port (a directory); give the serial device"


@pytest.mark.parametrize("command", ["push", "diff", "pull"])
@pytest.mark.parametrize("kind", ["missing", "/dev/null", "regular file", "directory"])
def test_a_port_that_is_missing_or_not_a_serial_device_is_one_line_naming_it(
    project: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], kind: str, command: str
) -> None:
    port, says = not_a_port(kind, tmp_path)
    path = Path(port)
    port_before = path.read_bytes() if path.is_file() else None
    before = tree(project)
    code, _, err = cli(
        capsys, command, str(project), "--port", port, *(["--yes"] if command == "push" else [])
    )
    assert code == 2
    assert one_line(err).startswith(f"harlsync: error: port {port}: {says}")
    assert tree(project) == before
    if port_before is not None:
        assert path.read_bytes() == port_before


class Garbage(Simulator):
    """A controller that answers every request with a well-formed frame of nonsense."""

    def handle(self, state: SimState, payload: str) -> str:
        return "?? 7 garbage"


class Refusing(Simulator):
    """A controller that answers every request with an error status."""

    def handle(self, state: SimState, payload: str) -> str:
        return "E99"


#: controller -> (--station, exit code of push, what the line says)
LINES = {
    "wrong station": (
        3,
        2,
        "station 3, command LNR: no valid reply after 2 attempt(s) (last: no reply",
    ),
    "garbage": (1, 3, "cannot read the task states before reading the robot (port "),
    "error status": (1, 3, "command LNR: controller answered error status E99); not writing"),
}
READS = {
    "wrong station": (
        "station 3, command LNX: no valid reply after 2 attempt(s) (last: no reply within "
        "0.2 s); check the station number"
    ),
    "garbage": (
        "station 1, command LNX: no valid reply after 2 attempt(s) (last: reply does not fit: "
        "LNX: bad reply '?? 7 garbage'"
    ),
    "error status": "station 1, command LNX: controller answered error status E99",
}


def controller(kind: str) -> Simulator:
    state = SimState.generate(SEED, SMALL)
    if kind == "garbage":
        return Garbage(state)
    if kind == "error status":
        return Refusing(state)
    return Simulator(state)


@pytest.mark.parametrize("command", ["push", "diff", "pull"])
@pytest.mark.parametrize("kind", list(LINES))
def test_a_controller_that_is_silent_or_answers_nonsense_gets_no_write_and_the_backup_stays(
    project: Path, capsys: pytest.CaptureFixture[str], kind: str, command: str
) -> None:
    station, push_exit, refused = LINES[kind]
    target = controller(kind)
    before = tree(project)
    with TcpServer(target) as server:
        argv = [command, str(project), "--port", server.url, "--station", str(station)]
        code, _, err = cli(capsys, *argv, *(["--yes"] if command == "push" else []))
    line = one_line(err)
    if command == "push" and push_exit == 3:
        assert code == 3
        assert line.startswith(f"harlsync: refused: robot cell (port {server.url} station 1): ")
        assert refused in line
    else:
        assert code == 2
        first = "LNR" if command == "push" else "LNX"
        assert line.startswith(f"harlsync: error: port {server.url}, ")
        assert READS[kind].replace("LNX", first) in line, line
    assert target.writes_received() == []
    assert tree(project) == before  # a failed pull leaves the previous backup as it was


def test_a_pull_over_a_pty_from_a_garbage_controller_leaves_the_backup_byte_identical(
    project: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = Garbage(SimState.generate(SEED, SMALL))
    before = tree(project)
    with PtyServer(target) as server:
        code, _, err = cli(capsys, "pull", str(project), "--port", server.device)
    assert code == 2
    assert one_line(err).startswith(f"harlsync: error: port {server.device}, {READS['garbage']}")
    assert target.writes_received() == []
    assert tree(project) == before


# --- the installed command, with its real logging and stderr ------------------------------------


def harlsync(*argv: str) -> subprocess.CompletedProcess[str]:
    exe = Path(sys.executable).with_name("harlsync")
    return subprocess.run(
        [str(exe), *argv], capture_output=True, text=True, timeout=60, check=False
    )


def test_the_installed_command_prints_one_line_for_a_broken_file_and_a_silent_line(
    project: Path, sim: tuple[ScriptedSim, str]
) -> None:
    robot, url = sim
    done = harlsync("push", str(project), "--port", url, "--station", "3", "--yes")
    assert done.returncode == 2
    assert one_line(done.stderr).startswith(
        f"harlsync: error: port {url}, station 3, command LNR: "
    )
    assert robot.writes_received() == []

    break_file(project, "timers.yaml", "  3: 0.00\n", "  3: [0.00\n")
    done = harlsync("push", str(project), "--port", url, "--yes")
    assert done.returncode == 2
    assert one_line(done.stderr).startswith("harlsync: error: timers.yaml:8: YAML syntax error: ")
    assert robot.writes_received() == []


def test_an_error_naming_a_path_with_a_newline_is_still_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    odd = tmp_path / "cell\n2"
    code, _, err = cli(capsys, "push", str(odd), "--yes")
    assert code == 2
    assert one_line(err).startswith("harlsync: error: ")
    assert "not a project directory" in err


# --- options out of range: one line, before any robot is read (issue 34) -----------------------


@pytest.mark.parametrize("attempts", ["0", "-1"])
def test_issue_34_item_3_backup_attempts_below_one_is_one_line_and_no_robot_is_tried(
    project: Path, capsys: pytest.CaptureFixture[str], attempts: str
) -> None:
    before = tree(project)
    code, out, err = cli(capsys, "backup", str(project), "--attempts", attempts)
    assert code == 2 and out == ""
    assert one_line(err) == f"harlsync backup: --attempts {attempts}: give 1 or more tries"
    assert tree(project) == before  # no robot tried, none recorded as a failed attempt


@pytest.mark.parametrize("command", ["status", "backup"])
@pytest.mark.parametrize("hours", ["inf", "nan", "1e12", "-1"])
def test_issue_34_item_10_stale_after_out_of_range_is_one_line_naming_the_option_and_range(
    project: Path, capsys: pytest.CaptureFixture[str], command: str, hours: str
) -> None:
    before = tree(project)
    code, out, err = cli(capsys, command, str(project), "--stale-after", hours)
    assert code == 2 and out == ""
    line = one_line(err)
    assert line.startswith(f"harlsync {command}: --stale-after ")
    assert line.endswith(": give 0 to 87600 hours (ten years)")
    assert tree(project) == before
