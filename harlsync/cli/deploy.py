"""The commands that plan and write: ``plan``, ``push``, ``adopt``, ``rollback``."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import (
    PartlyWritten,
    partly_words,
)
from ..terminal import Feedback

if TYPE_CHECKING:
    from ..sync.deploy import PushOptions, PushResult
    from ..sync.plan import Plan, PlannedWrite


from .common import (
    EXIT_OK,
    _connect_options,
    _connection_args,
    _per_family,
    _print,
    _project_dir,
    _warn,
)


def _add_plan(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "plan",
        help="print what a push would write, and write nothing",
        description="Read the whole robot, compare it with the project and print, in push "
        "order, what a push would write, item by item as diff shows it, and how many "
        "items in how many writes; with -v also the exact command of each write ("
        + _per_family("commands")
        + "). Nothing is written. Warns when the robot is not idle: a push would be "
        "refused now. --out saves the plan "
        "with a fingerprint of the robot and the project; push --plan refuses it "
        "if either changed since. The plan file is not part of the project: "
        "delete it after the push, or keep it outside the repository.",
    )
    p.add_argument("dir", metavar="DIR", help="robot project directory")
    _connection_args(p)
    p.add_argument("--out", metavar="PLANFILE", help="save the plan to this file")
    p.add_argument(
        "--registers",
        action="store_true",
        help="include runtime data (" + _per_family("runtime") + ")",
    )
    p.set_defaults(func=_cmd_plan)


def _show_plan(the_plan: Plan[Any], verbose: int = 0) -> None:
    """What a push of ``the_plan`` writes, as ``diff`` shows it, item by item; with -v
    each write's wire command too."""
    from ..sync.items import render_text

    for line in the_plan.unwritable:
        _print(f"# cannot write: {line}")
    if the_plan.reconfiguration_note:
        _print(f"# {the_plan.reconfiguration_note}")
    for note in the_plan.notes:
        _print(f"# note: {note}")
    if the_plan.items:
        for line in render_text(the_plan.items, "", "").splitlines()[2:]:
            _print(line)
    for name, said in the_plan.reverts.items():
        _print(f"# {name}: {said}")
    if verbose:
        for write in the_plan.writes:
            flag = "  # unsafe in automatic operation" if write.unsafe else ""
            _print(f"# {write.name}: {write.command}{flag}")
    _print(f"# {_counted(the_plan)} to {the_plan.robot} ({the_plan.target})")


def _counted(the_plan: Plan[Any]) -> str:
    """``5 item(s) in 2 write(s)``: the items as diff counts them, and the commands."""
    items, writes = len(the_plan.items), len(the_plan.writes)
    return f"{items} item(s) in {writes} write(s)" if items != writes else f"{items} item(s)"


def _cmd_plan(args: argparse.Namespace) -> int:
    from ..sync import comparison
    from ..sync.items import differ_words

    progress = Feedback("plan")
    try:
        found = comparison.compare(
            args.dir,
            port=args.port,
            station=args.station,
            progress=progress,
            registers=args.registers,
            lock_timeout=args.lock_timeout,
            idle_check=True,
            connect_options=_connect_options(args),
            command="plan",
        )
    finally:
        progress.close()
    _warn(found.warnings)
    the_plan = found.plan()
    _show_plan(the_plan, args.verbose)
    if args.out:
        the_plan.save(args.out)
        _print(f"# plan saved to {args.out}")
    progress.summary(found.project.robot.name, found.contents, differ_words(found.changes))
    from ..sync.plan import policy_refusals

    # Every reason a push would be refused now, not only the first it would meet.
    reasons = policy_refusals(Path(args.dir), found.project.robot)
    if found.busy is not None:  # a push reads the state before anything else
        reasons.append(
            f"robot {found.project.robot.name} ({found.target}) is not idle: {found.busy}"
        )
    _warn([f"a push would be refused now: {reason}" for reason in reasons])
    return EXIT_OK


def _push_args(p: argparse.ArgumentParser) -> None:
    _connection_args(p)
    p.add_argument("--yes", action="store_true", help="do not ask before writing")
    p.add_argument("--reason", metavar="TEXT", help="why, for the audit log")
    p.add_argument(
        "--outside-window",
        metavar="REASON",
        help="allow a write outside the robot's maintenance windows, saying why",
    )
    p.add_argument(
        "--allow-reconfigure",
        action="store_true",
        help="allow a program configuration change (SNX), which destroys every "
        "program; all of them are rewritten after it",
    )
    p.add_argument(
        "--allow-live-tuning",
        action="store_true",
        help="write what the family allows while the robot runs ("
        + _per_family("live_tuning")
        + "); nothing else",
    )
    p.add_argument(
        "--registers",
        action="store_true",
        help="write runtime data too (" + _per_family("runtime") + "; the project must keep it)",
    )


def _confirm(the_plan: Plan[Any], verbose: int = 0) -> bool:
    """Show the plan and ask on the terminal (only given when stdin is one)."""
    _show_plan(the_plan, verbose)
    answer = input(f"Write these {_counted(the_plan)} to {the_plan.robot}? [y/N] ")
    return answer.strip().lower() in ("y", "yes")


def _add_push(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "push",
        help="write what differs to the robot, safely",
        description="Read the whole robot and write only what differs, in the family's safe "
        "order (" + _per_family("order") + "). "
        "Refuses a project that is invalid, has "
        "uncommitted changes, or is outside its maintenance window; stops before "
        "any write while the robot runs (" + _per_family("busy") + "; read before "
        "every write and after the last: a robot started while a write was on the "
        "wire is named in a warning); verifies each write by reading it back; "
        "snapshots the robot "
        "first (see rollback) and records everything in the audit log, each write "
        "before it is sent, so the next push or diff can name what a push killed "
        "part way had written. Without a terminal to ask on, --yes is needed (it is "
        "refused before the robot is read). Exit 0 done, 2 failed, 3 refused for "
        "safety, 130 interrupted (what was written is listed and audited).",
    )
    p.add_argument("dir", metavar="DIR", help="robot project directory")
    _push_args(p)
    p.add_argument(
        "--allow-dirty", action="store_true", help="push a project with uncommitted changes"
    )
    p.add_argument(
        "--plan",
        metavar="PLANFILE",
        help="push only if the robot and project are as when this plan was made",
    )
    p.set_defaults(func=_cmd_push)


def _push_options(args: argparse.Namespace, progress: Feedback) -> PushOptions:
    from ..sync.deploy import PushOptions

    return PushOptions(
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


def _partly_text(partly: PartlyWritten) -> str:
    """``x, y went out; z, hand not sent``."""
    return partly_words(partly.sent, partly.unknown, partly.left)


def _report(action: str, run: Callable[[], PushResult], progress: Feedback) -> int:
    from ..sync.deploy import PushFailed

    try:
        result = run()
    except PushFailed as failed:
        progress.close()
        r = failed.result
        _warn(r.warnings)
        if r.plan is not None and (r.written or r.failed):
            print(
                f"harlsync: {action} stopped: wrote {len(r.written)} of "
                f"{len(r.plan.writes)} item(s)",
                file=sys.stderr,
            )
            verbose = logging.getLogger().isEnabledFor(logging.INFO)  # -v: the wire too

            def said(w: PlannedWrite[Any]) -> str:
                return f"{w.name} ({w.command})" if verbose else w.name

            for w in r.written:
                print(f"  written:     {said(w)}", file=sys.stderr)
            if r.failed is not None and r.partly_written is not None:
                print(
                    f"  partly written: {r.failed.name}: {_partly_text(r.partly_written)}",
                    file=sys.stderr,
                )
            elif r.failed is not None:
                print(
                    f"  unknown:     {said(r.failed)} (may or may not have been written)",
                    file=sys.stderr,
                )
            for w in r.not_written:
                if w is not r.failed:
                    print(f"  not written: {said(w)}", file=sys.stderr)
            print(f"harlsync: run the same {action} again to finish", file=sys.stderr)
        for note in r.notes:
            print(f"harlsync: note: {note}", file=sys.stderr)
        if isinstance(failed.__cause__, KeyboardInterrupt):
            raise KeyboardInterrupt from failed  # exit 130, as any command interrupted
        raise failed.cause from failed
    finally:  # Ctrl-C too: no bar left on the screen
        progress.close()
    _warn(result.warnings)
    if result.plan is None or result.plan.empty:
        _print(f"{action}: robot already matches; nothing written")
    else:
        _print(
            f"{action}: wrote and verified {len(result.written)} item(s); "
            f"snapshot {result.snapshot}; audit {result.audit_log}"
        )
    for note in result.notes:
        _print(f"note: {note}")
    return EXIT_OK


def _cmd_push(args: argparse.Namespace) -> int:
    from ..sync import deploy

    progress = Feedback("read")
    opts = _push_options(args, progress)
    return _report(
        "push", lambda: deploy.push(args.dir, opts, port=args.port, station=args.station), progress
    )


def _add_adopt(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "adopt",
        help="write changes made on the robot, as the last backup kept them, into the project",
        description="Write into the project the items the last backup read (kept on the "
        "branch harlsync/backup) where the robot differs from the project: the ITEMs "
        "named (as status and backup name them, e.g. 'MAIN program 0 step 2'), or every "
        "item the robot changed since the last push or rollback (drift). Nothing is "
        "committed and no robot is contacted: review the change (git diff) and commit "
        "it; then the robot's change is approved. Refuses uncommitted edits (exit 3) "
        "unless --allow-dirty.",
    )
    p.add_argument("dir", metavar="DIR", help="robot project directory")
    p.add_argument("items", nargs="*", metavar="ITEM", help="an item to adopt (default: the drift)")
    p.add_argument(
        "--allow-dirty",
        action="store_true",
        help="adopt even over uncommitted edits in DIR (they are overwritten)",
    )
    p.set_defaults(func=_cmd_adopt)


def _cmd_adopt(args: argparse.Namespace) -> int:
    from ..sync.adopt import adopt
    from ..sync.states import date_of

    found = adopt(_project_dir(args.dir), args.items, allow_dirty=args.allow_dirty)
    source = f"the backup of {date_of(found.time)} (commit {found.commit[:10]})"
    if not found.items:
        _print(f"nothing to adopt: the project already holds what {source} read")
        return EXIT_OK
    _print(f"adopted {len(found.items)} item(s) from {source}:")
    for item in found.items:
        _print(f"  {item}")
    _print(f"review with 'git diff {args.dir}' and commit: {', '.join(found.files)}")
    return EXIT_OK


def _add_rollback(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "rollback",
        help="restore the snapshot taken before the last push",
        description="Write back the robot's state as it was before the last push (or the "
        "snapshot named by --snapshot), under the same interlocks, verification "
        "and audit as push. The project in git then still holds what was pushed: "
        "revert that commit, or push again once fixed.",
    )
    p.add_argument("dir", metavar="DIR", help="robot project directory")
    _push_args(p)
    p.add_argument(
        "--snapshot",
        metavar="N",
        help="the snapshot to restore: its number as 'harlsync snapshots DIR' shows it, "
        "or its directory (default: the one taken before the last push)",
    )
    p.set_defaults(func=_cmd_rollback)


def _cmd_rollback(args: argparse.Namespace) -> int:
    from ..sync import deploy
    from ..sync.revisions import snapshot_path

    chosen = snapshot_path(_project_dir(args.dir), args.snapshot) if args.snapshot else None
    progress = Feedback("read")
    opts = _push_options(args, progress)
    return _report(
        "rollback",
        lambda: deploy.rollback(
            args.dir, opts, snapshot=chosen, port=args.port, station=args.station
        ),
        progress,
    )
