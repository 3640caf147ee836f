"""The commands on one robot: ``pull``, ``diff``, ``plan``, ``push``, ``rollback``, ``adopt``."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from .. import families
from ..families import DEFAULT
from ..terminal import Feedback
from .common import (
    EXIT_NO,
    EXIT_OK,
    Sub,
    _add,
    _command,
    _connect_options,
    _connection_args,
    _dir_arg,
    _family_arg,
    _format_arg,
    _json,
    _line,
    _lines,
    _phrases,
    _print,
    _usage,
    _warn,
)

if TYPE_CHECKING:
    from ..families.base import K
    from ..sync.comparison import Comparison
    from ..sync.deploy import PushOptions, PushResult
    from ..sync.items import Differences
    from ..sync.plan import Plan


def _add_pull(sub: Sub) -> None:
    p = _command(
        sub,
        "pull",
        _cmd_pull,
        help="read everything from the robot into a project directory",
        description="Read everything the robot holds that the project keeps ("
        + families.help_phrases("pull")
        + "; runtime data if the project keeps it) and write the project atomically: a pull "
        "that fails leaves the previous files as they were. DIR is created if missing; a first "
        "pull needs --port (or the robot.yaml harlsync probe --write DIR makes), and one that "
        "gets no answer points to harlsync probe. A controller that does not look like the robot "
        "backed up in DIR (another identity"
        + _phrases("identity", " ({})")
        + ", or most of the backup would change) is refused (exit 3) until --new-robot; so is a pull that would overwrite changes "
        "the project's branch approved and no push deployed yet (pending) until --discard-pending.",
    )
    _dir_arg(p)
    _connection_args(p)
    _family_arg(
        p,
        f"the controller family of a first pull (default {DEFAULT}, or the family whose own URL "
        "scheme --port has); later commands read it from robot.yaml",
    )
    _add(p, _PULL)


#: pull's options after the connection's and --family.
_PULL = {
    "--commit": "commit the change to git, with a message that says what changed",
    "--allow-dirty": "pull even over uncommitted edits in DIR (they are overwritten)",
    "--discard-pending": "pull even over changes the project's branch approved and no push has "
    "deployed yet (pending: they are overwritten in the working tree)",
    "--new-robot": "accept a controller that does not look like the robot backed up in DIR "
    "(another identity, or most of the backup changed): a replaced, "
    "reconfigured or updated robot",
}


def _cmd_pull(args: argparse.Namespace) -> int:
    from ..sync import pulling

    progress = Feedback("pull")
    try:
        result = pulling.pull(
            args.dir,
            commit=args.commit,
            progress=progress,
            allow_dirty=args.allow_dirty,
            family=families.get(args.family) if args.family else None,
            new_robot=args.new_robot,
            discard_pending=args.discard_pending,
            **_line(args),
        )
    finally:
        progress.close()
    progress.summary(result.robot.name, result.contents)
    if result.commit or sys.stdout.isatty():  # a commit is always said: cron logs it
        committed = f", committed {result.commit[:10]}" if result.commit else ""
        _print(f"{result.robot.name}: {result.summary}{committed}")
    return EXIT_OK


def _add_diff(sub: Sub) -> None:
    p = _command(
        sub,
        "diff",
        _cmd_diff,
        help="compare the project with the live robot, or two versions of it (--rev)",
        description="Read the whole robot, as a pull does, and compare it with the project, "
        "item by item ("
        + families.help_phrases("items")
        + "). '-' lines are the robot, '+' lines the "
        "project. On a terminal it ends with what was read, how long it took and how many items "
        "differ. Warns when the audit log shows an earlier push to this robot that never "
        "finished (killed part way). Exit 0 identical, 1 different, 2 error.",
    )
    _dir_arg(p)
    _connection_args(p)
    _format_arg(p)
    _add(p, {"--registers": f"compare runtime data too ({families.help_phrases('runtime')})"})
    p.add_argument(
        "--rev",
        action="append",
        metavar="REV",
        help="compare versions of the project, not the robot: a git revision (HEAD~1, a "
        "commit, a tag) or a snapshot number as 'harlsync snapshots' lists it; once: that "
        "version against the project on disk, twice: the first against the second. No robot "
        "is contacted",
    )


def _cmd_diff(args: argparse.Namespace) -> int:
    if args.rev and len(args.rev) > 2:
        return _usage("diff: --rev at most twice (the old version, then the new one)")
    if args.rev and (args.port or args.station is not None):
        return _usage("diff: --rev compares versions of the project: no --port or --station")
    found = _versions(args) if args.rev else _live(args)
    if args.format == "json":
        _json(found.to_json())
    else:
        sys.stdout.write(found.render())
    return EXIT_NO if found.changes else EXIT_OK


def _versions(args: argparse.Namespace) -> Differences:
    """``diff DIR --rev A [--rev B]``: two versions of the project, no robot."""
    from ..sync.revisions import compare_versions

    new = args.rev[1] if len(args.rev) == 2 else None
    return compare_versions(args.dir, args.rev[0], new, registers=args.registers)


def _live(args: argparse.Namespace) -> Differences:
    from ..sync.items import differ_words

    found, progress = _compare(args, "diff")
    progress.summary(found.project.robot.name, found.contents, differ_words(found.changes))
    return found.differences()


def _compare(args: argparse.Namespace, command: str) -> tuple[Comparison[Any, Any], Feedback]:
    """The live robot against the project, for ``diff`` or ``plan`` (which also asks
    whether the robot is idle); the warnings said."""
    from ..sync import comparison

    progress = Feedback(command)
    try:
        found = comparison.compare(
            args.dir,
            progress=progress,
            registers=args.registers,
            idle_check=command == "plan",
            command=command,
            **_line(args),
        )
    finally:
        progress.close()
    _warn(found.warnings)
    return found, progress


def _add_plan(sub: Sub) -> None:
    p = _command(
        sub,
        "plan",
        _cmd_plan,
        help="print what a push would write, and write nothing",
        description="Read the whole robot, compare it with the project and print, in push "
        "order, what a push would write, item by item as diff shows it, and how many items in "
        "how many writes; with -v also the exact command of each write ("
        + families.help_phrases("commands")
        + "). Nothing is written. Warns when the robot is not idle: a push would be refused "
        "now. --out saves the plan with a fingerprint of the robot and the project; push --plan "
        "refuses it if either changed since. The plan file is not part of the project: delete "
        "it after the push, or keep it outside the repository.",
    )
    _dir_arg(p)
    _connection_args(p)
    runtime = families.help_phrases("runtime")
    _add(
        p,
        {
            "--out PLANFILE": "save the plan to this file",
            "--registers": f"include runtime data ({runtime})",
        },
    )


def _cmd_plan(args: argparse.Namespace) -> int:
    from ..sync.items import differ_words

    found, progress = _compare(args, "plan")
    the_plan = found.plan()
    _lines(the_plan.lines(args.verbose))
    if args.out:
        the_plan.save(args.out)
        _print(f"# plan saved to {args.out}")
    progress.summary(found.project.robot.name, found.contents, differ_words(found.changes))
    _warn([f"a push would be refused now: {reason}" for reason in found.refusals()])
    return EXIT_OK


def _push_args(p: argparse.ArgumentParser) -> None:
    """What push and rollback are told, after the connection's options."""
    _connection_args(p)
    live, runtime = families.help_phrases("live_tuning"), families.help_phrases("runtime")
    reconfigure = _phrases("reconfigure", " ({})")
    _add(
        p,
        {
            "--yes": "do not ask before writing",
            "--reason TEXT": "why, for the audit log",
            "--outside-window REASON": "allow a write outside the robot's maintenance windows, "
            "saying why",
            "--allow-reconfigure": "allow a write that reconfigures the controller and clears "
            f"what it holds{reconfigure}; all that it cleared is written again after it",
            "--allow-live-tuning": f"write what the family allows while the robot runs ({live}); "
            "nothing else",
            "--registers": f"write runtime data too ({runtime}; the project must keep it)",
        },
    )


def _confirm(the_plan: Plan[K], verbose: int = 0) -> bool:
    """Show the plan and ask on the terminal (only given when stdin is one)."""
    _lines(the_plan.lines(verbose))
    answer = input(f"Write these {the_plan.counted} to {the_plan.robot}? [y/N] ")
    return answer.strip().lower() in ("y", "yes")


def _add_push(sub: Sub) -> None:
    p = _command(
        sub,
        "push",
        _cmd_push,
        help="write what differs to the robot, safely",
        description="Read the whole robot and write only what differs, in the family's safe "
        "order (" + families.help_phrases("order") + "). Refuses a project that is invalid, has "
        "uncommitted changes, or is outside its maintenance window; stops before any write "
        "while the robot runs ("
        + families.help_phrases("busy")
        + "; read before every write and after "
        "the last: a robot started while a write was on the wire is named in a warning); "
        "verifies each write by reading it back; snapshots the robot first (see rollback) and "
        "records everything in the audit log, each write before it is sent, so the next push "
        "or diff can name what a push killed part way had written. Without a terminal to ask "
        "on, --yes is needed (it is refused before the robot is read). Exit 0 done, 2 failed, "
        "3 refused for safety, 130 interrupted (what was written is listed and audited).",
    )
    _dir_arg(p)
    _push_args(p)
    _add(p, _PUSH)


#: push's options after those it shares with rollback.
_PUSH = {
    "--allow-dirty": "push a project with uncommitted changes",
    "--plan PLANFILE": "push only if the robot and project are as when this plan was made",
}


def _write(args: argparse.Namespace, action: str, run: Callable[[PushOptions], PushResult]) -> int:
    """Run a push or rollback with the options given, and say what it did."""
    from ..sync.deploy import PushFailed, PushOptions

    progress = Feedback("read")
    opts = PushOptions(
        yes=args.yes,
        confirm=(lambda plan: _confirm(plan, args.verbose)) if sys.stdin.isatty() else None,
        reason=args.reason,
        allow_dirty=getattr(args, "allow_dirty", False),
        outside_window=args.outside_window,
        allow_reconfigure=args.allow_reconfigure,
        allow_live_tuning=args.allow_live_tuning,
        registers=args.registers,
        plan_file=getattr(args, "plan", None),
        lock_timeout=args.lock_timeout,
        progress=progress,
        connect_options=_connect_options(args),
        told=lambda line: print(f"harlsync: {line}", file=sys.stderr),
    )
    try:
        result = run(opts)
    except PushFailed as failed:
        progress.close()
        _warn(failed.result.warnings)
        verbose = logging.getLogger().isEnabledFor(logging.INFO)  # -v: the wire too
        for line in failed.result.stopped(action, verbose):
            print(line, file=sys.stderr)
        if isinstance(failed.__cause__, KeyboardInterrupt):
            raise KeyboardInterrupt from failed  # exit 130, as any command interrupted
        raise failed.cause from failed
    finally:  # Ctrl-C too: no bar left on the screen
        progress.close()
    _warn(result.warnings)
    _print(result.summary(action))
    _lines([f"note: {note}" for note in result.notes])
    return EXIT_OK


def _cmd_push(args: argparse.Namespace) -> int:
    from ..sync import deploy

    where = {"port": args.port, "station": args.station}
    return _write(args, "push", lambda opts: deploy.push(args.dir, opts, **where))


def _add_rollback(sub: Sub) -> None:
    p = _command(
        sub,
        "rollback",
        _cmd_rollback,
        help="restore the snapshot taken before the last push",
        description="Write back the robot's state as it was before the last push (or the "
        "snapshot named by --snapshot), under the same interlocks, verification and audit as "
        "push. The project in git then still holds what was pushed: revert that commit, or "
        "push again once fixed.",
    )
    _dir_arg(p)
    _push_args(p)
    _add(p, _ROLLBACK)


#: rollback's options after those it shares with push.
_ROLLBACK = {
    "--snapshot N": "the snapshot to restore: its number as 'harlsync snapshots DIR' shows it, "
    "or its directory (default: the one taken before the last push)",
}


def _cmd_rollback(args: argparse.Namespace) -> int:
    from ..sync import deploy
    from ..sync.revisions import snapshot_path

    chosen = snapshot_path(args.dir, args.snapshot) if args.snapshot else None
    where = {"port": args.port, "station": args.station}
    return _write(
        args, "rollback", lambda opts: deploy.rollback(args.dir, opts, snapshot=chosen, **where)
    )


def _add_adopt(sub: Sub) -> None:
    p = _command(
        sub,
        "adopt",
        _cmd_adopt,
        help="write changes made on the robot, as the last backup kept them, into the project",
        description="Write into the project the items the last backup read (kept on the branch "
        "harlsync/backup) where the robot differs from the project: the ITEMs named (as status "
        "and backup name them" + _phrases("item", ", e.g. {}") + "), or every item the robot "
        "changed "
        "since the last push or rollback (drift). Nothing is committed and no robot is "
        "contacted: review the change (git diff) and commit it; then the robot's change is "
        "approved. Refuses uncommitted edits (exit 3) unless --allow-dirty.",
    )
    _dir_arg(p)
    p.add_argument("items", nargs="*", metavar="ITEM", help="an item to adopt (default: the drift)")
    _add(p, {"--allow-dirty": "adopt even over uncommitted edits in DIR (they are overwritten)"})


def _cmd_adopt(args: argparse.Namespace) -> int:
    from ..sync.adopt import adopt
    from ..sync.states import date_of

    found = adopt(args.dir, args.items, allow_dirty=args.allow_dirty)
    source = f"the backup of {date_of(found.time)} (commit {found.commit[:10]})"
    if not found.items:
        _print(f"nothing to adopt: the project already holds what {source} read")
        return EXIT_OK
    _print(f"adopted {len(found.items)} item(s) from {source}:")
    _lines([f"  {item}" for item in found.items])
    _print(f"review with 'git diff {args.dir}' and commit: {', '.join(found.files)}")
    return EXIT_OK
