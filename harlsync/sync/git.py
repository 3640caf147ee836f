"""The few git operations harlsync needs, through the ``git`` command.

Shelling out to git keeps the user's own configuration (identity, hooks, signing)
in force and adds no dependency.
"""

from __future__ import annotations

import getpass
import os
import socket
import subprocess
import threading
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import NamedTuple

from ..errors import SyncError

__all__ = [
    "Asked",
    "Commit",
    "changed_files",
    "commit",
    "files_at",
    "head",
    "identity",
    "log",
    "not_in_commit",
    "push",
    "read_blobs",
    "repo_root",
    "resolve",
    "run",
    "show",
]


def _git(
    cwd: Path,
    *args: str,
    check: bool = True,
    ok: tuple[int, ...] = (0,),
    stdin: str | None = None,
    env: Mapping[str, str] | None = None,
) -> subprocess.CompletedProcess[str]:
    """Run git in ``cwd``; with ``check``, an exit status not in ``ok`` raises SyncError."""
    try:
        result = subprocess.run(
            ["git", *args],
            cwd=cwd,
            env=env,
            capture_output=True,
            text=True,
            check=False,
            input=stdin,
            errors="surrogateescape",  # file names as os.listdir gives them, whatever bytes
        )
    except FileNotFoundError as exc:
        raise _not_installed() from exc
    if check and result.returncode not in ok:
        raise _failed(cwd, args, result)
    return result


def _not_installed() -> SyncError:
    return SyncError("git is not installed: install git or run without --commit")


def _failed(
    cwd: Path, args: tuple[str, ...], result: subprocess.CompletedProcess[str]
) -> SyncError:
    """The one line saying that git ``args`` failed in ``cwd``, with git's own reason."""
    lines = [ln.strip() for ln in (result.stderr or result.stdout).splitlines() if ln.strip()]
    detail = next((ln for ln in lines if ln.startswith(("fatal:", "error:"))), None)
    detail = detail or (lines[0] if lines else f"exit status {result.returncode}")
    if "index.lock" in detail:  # left by a git that was killed or crashed
        detail += " (if no git is running there, remove that file)"
    # The subcommand only: the paths of a backup's add would fill the line.
    command = next(a for a in args if not a.startswith("-"))
    return SyncError(f"git {command} failed in {cwd}: {detail}")


def _where(path: Path) -> Path:
    """The directory git runs in for ``path`` (resolved): itself, or the nearest
    directory above it that exists."""
    cwd = path if path.is_dir() else path.parent
    while not cwd.exists():
        cwd = cwd.parent
    return cwd


def repo_root(path: str | Path) -> Path | None:
    """The top of the git work tree that holds ``path``, or None outside any."""
    result = _git(_where(Path(path).resolve()), "rev-parse", "--show-toplevel", check=False)
    return Path(result.stdout.strip()) if result.returncode == 0 else None


def changed_files(path: str | Path) -> list[str]:
    """Files under ``path`` with uncommitted changes, relative to the repository
    (none outside a repository, and none for a path that does not exist yet)."""
    root = repo_root(path)
    if root is None or not Path(path).exists():
        return []
    status = _git(
        root, "status", "--porcelain", "--untracked-files=all", "--", str(Path(path).resolve())
    )
    return [line[3:] for line in status.stdout.splitlines() if line.strip()]


class Asked:
    """What :func:`changed_files` and :func:`repo_root` say of ``path``, asked now
    and answered when :meth:`changed_files` is called: their two git processes run
    meanwhile (a pull opens its line and reads its robot; issue 24), started by a
    thread of their own, so that the caller does not wait for either to start.
    :meth:`close` ends them if the answer is never taken.

    ``git status --porcelain`` names files relative to the top of the repository
    from any directory in it, so both start at once, in the directory of ``path``.
    The answer raises SyncError as :func:`changed_files` does (git not installed,
    git status failing).
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._runs: list[tuple[tuple[str, ...], subprocess.Popen[str]]] = []
        self._failed: SyncError | None = None
        self._answer: tuple[Path | None, list[str]] | None = None
        self._starting = threading.Thread(target=self._start, name="git status", daemon=True)
        self._starting.start()

    def _start(self) -> None:
        resolved = self.path.resolve()
        cwd = _where(resolved)
        asks: list[tuple[str, ...]] = [("rev-parse", "--show-toplevel")]
        if self.path.exists():  # a path that does not exist yet has no changes
            asks.append(("status", "--porcelain", "--untracked-files=all", "--", str(resolved)))
        for args in asks:
            try:
                process = subprocess.Popen(
                    ["git", *args],
                    cwd=cwd,
                    stdin=subprocess.DEVNULL,
                    stdout=subprocess.PIPE,
                    stderr=subprocess.PIPE,
                    text=True,
                    errors="surrogateescape",  # file names as os.listdir gives them
                )
            except FileNotFoundError as exc:
                self._failed = _not_installed()
                self._failed.__cause__ = exc
                return
            except OSError as exc:  # not executable, no process left (EAGAIN): one line
                self._failed = SyncError(
                    f"git could not be started ({exc.strerror or exc}): check the git on "
                    "PATH, or pull with --allow-dirty"
                )
                self._failed.__cause__ = exc
                return
            self._runs.append((args, process))

    def _take(self) -> tuple[Path | None, list[str]]:
        if self._answer is None:
            self._starting.join()
            if self._failed is not None:
                raise self._failed
            done = []
            for args, process in self._runs:
                out, err = process.communicate()
                done.append((args, subprocess.CompletedProcess(args, process.returncode, out, err)))
            self._runs = []
            if not done:  # the thread ended before it started one: a failure it did not name
                raise SyncError("git could not be started: check the git on PATH")
            top = Path(done[0][1].stdout.strip()) if done[0][1].returncode == 0 else None
            changed: list[str] = []
            if top is not None and len(done) > 1:
                args, status = done[1]
                if status.returncode != 0:
                    raise _failed(top, args, status)
                changed = [line[3:] for line in status.stdout.splitlines() if line.strip()]
            self._answer = top, changed
        return self._answer

    def root(self) -> Path | None:
        """As :func:`repo_root` of ``path``."""
        return self._take()[0]

    def changed_files(self) -> list[str]:
        """As :func:`changed_files` of ``path``: raises SyncError as it does."""
        return self._take()[1]

    def close(self) -> None:
        """End the processes whose answer was not taken (nothing once it was)."""
        self._starting.join()
        runs, self._runs = self._runs, []
        for _, process in runs:
            if process.poll() is None:
                process.kill()
            process.communicate()


def head(path: str | Path) -> str | None:
    """The commit checked out where ``path`` lives, or None."""
    root = repo_root(path)
    if root is None:
        return None
    result = _git(root, "rev-parse", "HEAD", check=False)
    return result.stdout.strip() if result.returncode == 0 else None


def not_in_commit(root: Path, rev: str | None, files: Mapping[str, bytes]) -> dict[str, str]:
    """Which of ``files`` the commit ``rev`` does not hold byte for byte.

    ``files`` maps paths relative to the work tree ``root`` to the bytes read from
    them.  Returns path -> ``"differs"`` (the commit has other bytes there),
    ``"ignored"`` (the commit has no such file, and .gitignore names it) or
    ``"missing"`` (the commit has no such file); paths the commit holds as they are
    read are left out.  ``rev`` None (no commit yet) holds nothing.
    """
    found: dict[str, str] = {}  # path -> object id, for the blobs the commit has
    if rev is not None and files:
        listing = _git(
            root, "--literal-pathspecs", "ls-tree", "-r", "-z", "--full-tree", rev, "--", *files
        ).stdout
        for entry in filter(None, listing.split("\0")):
            meta, _, name = entry.partition("\t")
            _mode, kind, oid = meta.split(" ")
            if kind == "blob":
                found[name] = oid
    out = {
        name: "differs"
        for name, oid in found.items()
        if name in files and _blob_id(files[name], oid) != oid
    }
    missing = [name for name in files if name not in found]
    if missing:
        ignored = _git(
            root,
            "check-ignore",
            "-z",
            "--stdin",
            ok=(0, 1),  # 1: none is
            stdin="\0".join(missing) + "\0",
        )
        names = set(filter(None, ignored.stdout.split("\0")))
        out.update({name: "ignored" if name in names else "missing" for name in missing})
    return out


def _blob_id(data: bytes, like: str) -> str:
    """The id git gives ``data`` as a blob, in the hash of the object id ``like``
    (SHA-1, or SHA-256 in a repository made with ``--object-format=sha256``)."""
    import hashlib

    digest = hashlib.sha256 if len(like) == 64 else hashlib.sha1
    return digest(b"blob %d\0" % len(data) + data).hexdigest()


def _never_committed() -> tuple[str, ...]:
    """What a save in progress leaves beside the files (harlsync.project.store): a
    commit made meanwhile by another process must not take it."""
    from ..project.store import IN_PROGRESS  # not at import: a pull asks git first

    return tuple(f":(exclude,glob)**/{pattern}" for pattern in IN_PROGRESS)


def commit(paths: list[Path], message: str) -> str | None:
    """Stage ``paths`` and commit them; the new commit, or None when nothing changed.

    Raises SyncError when the paths are not in one git repository.
    """
    roots = {repo_root(p) for p in paths}
    if None in roots or len(roots) != 1:
        raise SyncError(
            f"{', '.join(str(p) for p in paths)}: not inside one git repository; "
            "run 'git init' there first or drop --commit"
        )
    root = roots.pop()
    assert root is not None
    specs = [str(Path(p).resolve()) for p in paths]
    _git(root, "add", "--all", "--", *specs, *_never_committed())
    staged = _git(root, "diff", "--cached", "--quiet", "--", *specs, check=False)
    if staged.returncode == 0:
        return None
    _git(root, "commit", "--quiet", "-m", message, "--", *specs, env=identity(root))
    return _git(root, "rev-parse", "HEAD").stdout.strip()


def identity(root: Path) -> dict[str, str] | None:
    """The environment a commit in ``root`` needs when git knows nobody to commit as
    (cron and systemd: no HOME, no ~/.gitconfig); None when it does.

    git's own identity always wins: ``user.name``/``user.email`` in the repository's,
    the user's or the system's configuration, or ``GIT_AUTHOR_*``/``GIT_COMMITTER_*``
    in the environment.  Without one, harlsync commits as ``harlsync (USER@HOST)
    <USER@HOST>``: the account and machine that ran it.
    """
    if all(
        _git(root, "var", ident, check=False).returncode == 0
        for ident in ("GIT_AUTHOR_IDENT", "GIT_COMMITTER_IDENT")
    ):
        return None
    try:
        user = getpass.getuser()
    except (KeyError, OSError):
        user = "harlsync"
    host = socket.gethostname() or "localhost"
    env = dict(os.environ)
    for who in ("AUTHOR", "COMMITTER"):
        env.setdefault(f"GIT_{who}_NAME", f"harlsync ({user}@{host})")
        env.setdefault(f"GIT_{who}_EMAIL", f"{user}@{host}")
    return env


def push(path: str | Path, remote: str | None = None) -> None:
    """Push the current branch.  Raises SyncError with git's reason."""
    root = repo_root(path)
    if root is None:
        raise SyncError(f"{path}: not inside a git repository")
    _git(root, "push", *([remote] if remote else []))


class Commit(NamedTuple):
    """One commit, as a history shows it."""

    sha: str
    time: str  # the committer's, ISO 8601
    subject: str


def log(path: str | Path, limit: int = 10) -> list[Commit]:
    """The commits that changed files under ``path``, newest first (none outside git
    or before the first commit).

    One git process, run where ``path`` is: git finds the repository itself, and
    fails outside one (a pull that changed nothing asks this after the read)."""
    path = Path(path).resolve()
    cwd = path if path.is_dir() else path.parent
    while not cwd.exists():
        cwd = cwd.parent
    result = _git(
        cwd,
        "log",
        f"-n{limit}",
        "--format=%H%x1f%cI%x1f%s",
        "--",
        str(path),
        check=False,
    )
    if result.returncode != 0:
        return []
    return [Commit(*line.split("\x1f", 2)) for line in result.stdout.splitlines() if line]


def show(commit: str, path: str | Path) -> str:
    """The diff ``commit`` made to the files under ``path``, as git prints it ('' when
    it made none, or git cannot tell)."""
    root = repo_root(path)
    if root is None:
        return ""
    result = _git(
        root,
        "show",
        "--format=",
        "--no-color",
        "--no-ext-diff",
        commit,
        "--",
        str(Path(path).resolve()),
        check=False,
    )
    return result.stdout if result.returncode == 0 else ""


def resolve(root: Path, rev: str) -> str | None:
    """The commit ``rev`` names in the repository at ``root`` (None: no such commit)."""
    if rev.startswith("-"):  # never an option to git
        return None
    result = _git(root, "rev-parse", "--verify", "--quiet", f"{rev}^{{commit}}", check=False)
    return result.stdout.strip() if result.returncode == 0 else None


def files_at(root: Path, commit: str, where: str) -> dict[str, bytes]:
    """Every file under ``where`` (relative to ``root``) in ``commit``, by its path
    relative to ``where``, with its bytes."""
    listing = _git(root, "ls-tree", "-r", "-z", "--full-tree", commit, "--", where).stdout
    oids: dict[str, str] = {}
    prefix = f"{where}/" if where not in ("", ".") else ""
    for entry in filter(None, listing.split("\0")):
        meta, _, name = entry.partition("\t")
        _mode, kind, oid = meta.split(" ")
        if kind == "blob" and name.startswith(prefix):
            oids[name[len(prefix) :]] = oid
    blobs = read_blobs(root, oids.values())
    return {name: blobs[oid] for name, oid in oids.items()}


def read_blobs(root: Path, oids: Iterable[str]) -> dict[str, bytes]:
    """The bytes of each blob ``oids`` names, read by one ``git cat-file --batch``
    (a process a file made a robot of a hundred programs slow to read from git).
    Raises SyncError when git cannot give one of them."""
    wanted = list(dict.fromkeys(oids))
    if not wanted:
        return {}
    try:
        done = subprocess.run(
            ["git", "cat-file", "--batch"],
            cwd=root,
            input="".join(f"{oid}\n" for oid in wanted).encode("ascii"),
            capture_output=True,
            check=False,
        )
    except FileNotFoundError as exc:
        raise _not_installed() from exc
    out, found, at = done.stdout, {}, 0
    for oid in wanted:
        end = out.find(b"\n", at)
        header = out[at:end].split(b" ") if end >= 0 else []
        if done.returncode != 0 or len(header) != 3 or header[1] != b"blob":
            raise SyncError(f"git cat-file failed in {root} for the object {oid}")
        size = int(header[2])
        found[oid] = out[end + 1 : end + 1 + size]
        at = end + 1 + size + 1  # the content, then a newline
    return found


def run(
    root: Path,
    *args: str,
    stdin: str | None = None,
    env: Mapping[str, str] | None = None,
    ok: tuple[int, ...] = (0,),
) -> str:
    """git ``args`` in ``root``: its standard output.  Raises SyncError naming the
    subcommand and git's reason when its exit status is not in ``ok`` (the plumbing
    of :mod:`.backupref`)."""
    return _git(root, *args, stdin=stdin, env=env, ok=ok).stdout
