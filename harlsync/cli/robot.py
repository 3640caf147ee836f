"""The robot's reading commands: ``pull`` and ``diff``."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .. import families
from ..families import DEFAULT
from ..terminal import Feedback
from .common import (
    EXIT_NO,
    EXIT_OK,
    _connect_options,
    _connection_args,
    _family_names,
    _format_arg,
    _per_family,
    _print,
    _project_dir,
    _usage,
    _warn,
)


def _add_pull(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "pull",
        help="read everything from the robot into a project directory",
        description="Read everything the robot holds that the project keeps ("
        + _per_family("pull")
        + "; runtime data if the project keeps it) and write the project atomically: a pull that fails leaves the "
        "previous files as they were. DIR is created if missing; a first pull needs "
        "--port (or the robot.yaml harlsync probe --write DIR makes), and one that gets no "
        "answer points to harlsync probe. A controller that does not look like the robot backed up in DIR "
        "(another version or program configuration, or most of the backup would "
        "change) is refused (exit 3) until --new-robot; so is a pull that would overwrite "
        "changes the project's branch approved and no push deployed yet (pending) until "
        "--discard-pending.",
    )
    p.add_argument("dir", metavar="DIR", help="robot project directory")
    _connection_args(p)
    p.add_argument(
        "--family",
        choices=_family_names(),
        default=None,
        help=f"the controller family of a first pull (default {DEFAULT}, or the family "
        "whose own URL scheme --port has); later commands read it from robot.yaml",
    )
    p.add_argument(
        "--commit",
        action="store_true",
        help="commit the change to git, with a message that says what changed",
    )
    p.add_argument(
        "--allow-dirty",
        action="store_true",
        help="pull even over uncommitted edits in DIR (they are overwritten)",
    )
    p.add_argument(
        "--discard-pending",
        action="store_true",
        help="pull even over changes the project's branch approved and no push has "
        "deployed yet (pending: they are overwritten in the working tree)",
    )
    p.add_argument(
        "--new-robot",
        action="store_true",
        help="accept a controller that does not look like the robot backed up in "
        "DIR (another version or program configuration, or most of the "
        "backup changed): a replaced, reconfigured or updated robot",
    )
    p.set_defaults(func=_cmd_pull)


def _cmd_pull(args: argparse.Namespace) -> int:
    from ..sync import pulling

    if args.family is None and not (Path(args.dir) / "robot.yaml").exists():
        args.family = families.of_port(args.port)
    progress = Feedback("pull")
    try:
        result = pulling.pull(
            args.dir,
            port=args.port,
            station=args.station,
            commit=args.commit,
            progress=progress,
            lock_timeout=args.lock_timeout,
            allow_dirty=args.allow_dirty,
            family=families.get(args.family) if args.family else None,
            new_robot=args.new_robot,
            connect_options=_connect_options(args),
            discard_pending=args.discard_pending,
        )
    finally:
        progress.close()
    progress.summary(result.robot.name, result.contents)
    if result.commit or sys.stdout.isatty():  # a commit is always said: cron logs it
        committed = f", committed {result.commit[:10]}" if result.commit else ""
        _print(f"{result.robot.name}: {result.summary}{committed}")
    return EXIT_OK


def _add_diff(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "diff",
        help="compare the project with the live robot, or two versions of it (--rev)",
        description="Read the whole robot, as a pull does, and compare it with the project, "
        "item by item (" + _per_family("items") + "). '-' "
        "lines are the robot, '+' lines the project. On a terminal it ends with "
        "what was read, how long it took and how many items differ. "
        "Warns when the audit log shows an earlier push to this robot that never "
        "finished (killed part way). Exit 0 identical, 1 different, 2 error.",
    )
    p.add_argument("dir", metavar="DIR", help="robot project directory")
    _connection_args(p)
    _format_arg(p)
    p.add_argument(
        "--registers",
        action="store_true",
        help="compare runtime data too (" + _per_family("runtime") + ")",
    )
    p.add_argument(
        "--rev",
        action="append",
        metavar="REV",
        help="compare versions of the project, not the robot: a git revision (HEAD~1, a "
        "commit, a tag) or a snapshot number as 'harlsync snapshots' lists it; once: "
        "that version against the project on disk, twice: the first against the second. "
        "No robot is contacted",
    )
    p.set_defaults(func=_cmd_diff)


def _cmd_diff(args: argparse.Namespace) -> int:
    from ..sync import comparison
    from ..sync.items import changes_json, differ_words, render_text

    if args.rev:
        return _diff_versions(args)
    progress = Feedback("diff")
    try:
        result = comparison.compare(
            args.dir,
            port=args.port,
            station=args.station,
            progress=progress,
            registers=args.registers,
            lock_timeout=args.lock_timeout,
            connect_options=_connect_options(args),
        )
    finally:
        progress.close()
    _warn(result.warnings)
    progress.summary(result.project.robot.name, result.contents, differ_words(result.changes))
    if args.format == "json":
        _print(
            json.dumps(
                changes_json(
                    result.changes,
                    robot=result.project.robot.name,
                    target=result.target,
                    project=str(result.project.path),
                ),
                indent=2,
            )
        )
    elif result.changes:
        sys.stdout.write(
            render_text(result.changes, f"robot {result.target}", f"project {result.project.path}")
        )
    return EXIT_NO if result.changes else EXIT_OK


def _diff_versions(args: argparse.Namespace) -> int:
    """``diff DIR --rev A [--rev B]``: two versions of the project, no robot."""
    from ..sync.items import changes_json, render_text
    from ..sync.revisions import compare_versions

    if len(args.rev) > 2:
        return _usage("diff: --rev at most twice (the old version, then the new one)")
    if args.port or args.station is not None:
        return _usage("diff: --rev compares versions of the project: no --port or --station")
    old, new = args.rev[0], args.rev[1] if len(args.rev) == 2 else None
    a, b, changes = compare_versions(_project_dir(args.dir), old, new, registers=args.registers)
    if args.format == "json":
        _print(
            json.dumps(
                changes_json(changes, robot=b.project.robot.name, old=a.label, new=b.label),
                indent=2,
            )
        )
    elif changes:
        sys.stdout.write(render_text(changes, a.label, b.label))
    return EXIT_NO if changes else EXIT_OK
