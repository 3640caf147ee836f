"""Property test of the push interlock (issue 6, "Prove the promises").

Over 1,000 random pushes (100 in every run, the rest in ``pytest -m slow``; plus 40
more through the CLI, on disk),
each case drawn from one seed, it proves, from the simulator's own record of
what arrived and of the task states when it arrived (``Simulator.received``),
never from what harlsync believed:

1. every SN that needs an idle robot arrived straight after ``IDLE_READS`` (two)
   LNRs in a row that each found every task idle.  Without ``allow_live_tuning``
   that is every SN; with it,
   every SN but SNT (timers) and SNL (offset tables), and a plan that holds any
   other write finds the robot idle before its first write;
2. hence no such SN arrived while a task was in execution or suspended, except
   in the one window no client can close (below);
3. a push that returns has made the robot equal the project (converged);
4. a push that raises PushFailed says why in one line; its result, its audit
   record and (on disk) what ``harlsync push`` prints name exactly the writes the
   simulator received; the robot holds, for each planned item, its old or its
   new value (the new one for every write reported written); no item outside
   the plan changed; no write was sent twice without reading the item back;
5. the snapshot taken before the first write is what the robot held;
6. once the robot is stopped and the line is clean, the same push converges (or
   is refused again, writing nothing, when it needs --allow-reconfigure or
   changes what SNX cannot write).

A case is: a small random robot (``SimState.generate``); a project made from it
by a random diff (steps changed, added and cleared, timers, offset tables,
parameters, registers, sometimes the program configuration, rarely the timer
count); random options (live tuning, registers, reconfiguration allowed); and,
at random moments (after the simulator has answered the k-th request, most of
them while the push writes), an operator who starts, suspends or stops tasks or
sets odd task states, and a line that goes bad: faults on the replies (noise,
drops, bad LRC, fragments, late replies), requests lost on their way in, one
write request lost, a short burst of faults.  The reply to the request after
which the operator acts is often late, lost or garbled: the operator acts while
it is on the wire.  An LNR reply, too, may arrive not well formed (a program
type that is none of the four, a signed step, a task missing), or corrupted in a
way the LRC cannot see (two flipped bits in one bit column: ``1 MAIN 3 7`` as
``0 MAIN 3 6``), one reply at a time: the second LNR before each write is there
so that one such reply cannot clear a write (issue 19).

The window no client can close: the operator starting the robot after the LNR
that found it idle has been answered and before the write it cleared arrives.
Such a write is counted (``race``), and checks 3-6 still hold for its case;
a push stops at its next LNR.

To replay or explore: ``HARLSYNC_PROPERTY_SEEDS=7,8,9`` runs only those seeds
(a failure names its seed); ``HARLSYNC_PROPERTY_BASE=N`` moves every chunk.
"""

from __future__ import annotations

import json
import random
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import pytest
from pushproperty import (
    CHUNKS,
    ONLY,
    Change,
    Outcome,
    Scheduled,
    base,
    check_failure,
    check_rerun,
    check_sent,
    check_wrote_nothing,
    count_failure,
    explain,
    keep_snapshots,
    line_changes,
    push_command,
    seeds,
    spy_on_push,
)
from pushproperty import Tally as BaseTally

from harlsync.errors import PolicyError
from harlsync.families.harl_u2.catalogue import CATALOGUE, Key
from harlsync.families.harl_u2.model import (
    OFFSET_TABLE_COUNT,
    Config,
    OffsetTable,
    ProgramArea,
    RobotData,
    Step,
)
from harlsync.families.harl_u2.protocol import Frame, lrc
from harlsync.families.harl_u2.protocol.profile import IDLE_READS
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.link import SerialSettings
from harlsync.project import Project, load_project, new_robot, save_project
from harlsync.sim import Received
from harlsync.sim.device import Decoder
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import PushFailed, PushOptions, engine
from harlsync.sync import items as sync_items
from harlsync.sync.plan import PlannedWrite

BASE = base(600000)

#: The reply deadline while faults are on: short, so a lost reply costs little.
FAST = SerialSettings(timeout=0.02, retries=2)
#: The deadline for the re-run on a clean line: long, so a busy CI machine is no fault.
CALM = SerialSettings(timeout=1.0, retries=3)
#: Writes that allow_live_tuning lets through during automatic operation.
LIVE = ("SNT", "SNL")


# --- the operator at the pendant ------------------------------------------------------------


class Operator(Scheduled, Simulator):
    """A simulator with a schedule (:class:`pushproperty.Scheduled`): after answering
    the k-th request, make a change.

    A change puts tasks into or out of automatic operation, or changes the line's
    faults.  :attr:`received` records the task states when each request arrived,
    so a change made after request k shows from request k+1 on.
    """

    def __init__(
        self,
        state: SimState,
        schedule: list[tuple[int, Change]],
        *,
        seed: int,
        lose_writes: set[int] | None = None,
    ) -> None:
        super().__init__(state)
        self.start_schedule(schedule, seed=seed, deadline=FAST.timeout, lose_writes=lose_writes)

    def calm(self) -> None:
        """The operator stops the robot and leaves it alone; the line is mended."""
        self.mend()
        self.lnr_fault = None
        for state in self.stations.values():
            state.stop_all()

    def receive(
        self, data: bytes, decoder: Decoder[Frame] | None = None, client: str = ""
    ) -> list[tuple[float, bytes]]:
        # A bad LRC: the robot drops it.
        return super().receive(self.on_the_way_in(data, b" SN" in data), decoder, client)

    #: What happens to the next LNR reply: "idle" (bits flipped so that it reads
    #: idle and still passes the LRC: the next reply of a running robot), "malformed",
    #: or None.
    lnr_fault: str | None = None
    #: LNR replies still to go clean after one corrupted past the LRC: every attempt
    #: (1 + retries) of the client's next reading, since two corrupted readings in a
    #: row is the risk the second read leaves (its square).
    _clean_left = 0
    #: Whether the last LNR fault made the reply not well formed (not a false idle).
    lnr_malformed = False

    @property
    def fooled_at(self) -> set[int]:
        """The requests (their index in :attr:`received`) whose LNR reply was
        corrupted past the LRC."""
        if not hasattr(self, "_fooled_at"):
            self._fooled_at: set[int] = set()
        return self._fooled_at

    def handle(self, state: SimState, payload: str) -> str:
        self.before_request()
        handled = len(self.received)  # this request's index in the record
        reply = super().handle(state, payload)
        if payload == "LNR":
            fooled = self.on_lnr(reply)
            if fooled != reply and not self.lnr_malformed:
                self.fooled_at.add(handled)
            reply = fooled
        self.act(state, handled, payload)
        return reply

    def on_lnr(self, reply: str) -> str:
        fault, self.lnr_fault = self.lnr_fault, None
        self.lnr_malformed = fault == "malformed"
        if fault == "malformed":
            return malformed(reply, self._rng)
        if fault == "idle" and not self._clean_left:
            fooled = reads_idle_past_the_lrc(reply)
            if fooled == reply:
                self.lnr_fault = fault  # waits for a reply of a running robot
            else:
                self._clean_left = 1 + FAST.retries
            return fooled
        self._clean_left = max(0, self._clean_left - 1)
        return reply


def reads_idle_past_the_lrc(reply: str) -> str:
    """The LNR reply with each running or suspended task's status bit flipped off,
    and for each flip the same bit flipped in a digit of a program number or step:
    the XOR of the frame, its LRC, is unchanged.  The reply itself when no digit
    can take the compensating flip."""
    fields = reply.split(" ")
    digits = [
        (f, j)
        for task in range(0, len(fields), 4)
        for f in (task + 2, task + 3)
        for j in range(len(fields[f]))
    ]
    out = [list(f) for f in fields]
    for i in range(0, len(fields), 4):
        status = int(fields[i]) if fields[i].isdigit() else 0
        for bit in (1, 2):
            if not status & bit:
                continue
            spot = next(((f, j) for f, j in digits if chr(ord(out[f][j]) ^ bit).isdigit()), None)
            if spot is None:
                return reply
            digits.remove(spot)
            f, j = spot
            out[i][0] = chr(ord(out[i][0]) ^ bit)
            out[f][j] = chr(ord(out[f][j]) ^ bit)
    fooled = " ".join("".join(f) for f in out)
    assert lrc(fooled.encode()) == lrc(reply.encode())
    return fooled


def malformed(reply: str, rng: random.Random) -> str:
    """The LNR reply with one field not well formed, or a task missing."""
    fields = reply.split(" ")
    task = rng.randrange(len(fields) // 4) * 4
    how = rng.choice(["type", "step", "program", "status", "missing"])
    if how == "missing":
        return " ".join(fields[:task] + fields[task + 4 :])
    spot, text = {
        "type": (1, "MAIM"),
        "step": (3, "+" + fields[task + 3]),
        "program": (2, "1_0"),
        "status": (0, "+" + fields[task]),
    }[how]
    fields[task + spot] = text
    return " ".join(fields)


def start(task: int, ptype: str, program: int, step: int) -> Change:
    def change(sim: Simulator, state: SimState) -> str:
        state.start_task(task, ptype, program, step)
        return f"task {task} in execution"

    return change


def suspend(task: int) -> Change:
    def change(sim: Simulator, state: SimState) -> str:
        state.suspend_task(task)
        return f"task {task} suspended"

    return change


def set_status(task: int, status: int) -> Change:
    def change(sim: Simulator, state: SimState) -> str:
        state.tasks[task] = replace(state.tasks[task], status=status)
        return f"task {task} status {status}"

    return change


def stop_all(sim: Simulator, state: SimState) -> str:
    state.stop_all()
    return "all tasks stopped"


def start_unseen(task: int, ptype: str, step: int) -> Change:
    """The operator starts a task, and the next LNR reply reads idle past the LRC."""

    def change(sim: Operator, state: SimState) -> str:
        state.start_task(task, ptype, 0, step)
        sim.lnr_fault = "idle"
        return f"task {task} in execution; the next LNR reply reads idle past the LRC"

    return change


def lnr_fault(kind: str) -> Change:
    def change(sim: Operator, state: SimState) -> str:
        sim.lnr_fault = kind
        return {"idle": "the next LNR reply reads idle past the LRC"}.get(
            kind, "the next LNR reply is not well formed"
        )

    return change


# --- one random case ------------------------------------------------------------------------


@dataclass
class Case:
    seed: int
    before: RobotData
    target: RobotData
    opts: PushOptions
    sim: Operator
    story: list[str] = field(default_factory=list)

    def why(self, message: str) -> str:
        return explain(self.seed, self.story + self.sim.done, message)


def copy_data(data: RobotData) -> RobotData:
    return RobotData(
        version=data.version,
        config=data.config,
        parameters=data.parameters,
        programs={k: dict(v) for k, v in data.programs.items()},
        offsets=dict(data.offsets),
        timers=dict(data.timers),
        registers=None if data.registers is None else dict(data.registers),
    )


def random_step(rng: random.Random) -> Step:
    return Step.parse(
        rng.choice(
            [
                f"MOVE P{rng.randrange(1000):03d} S{rng.choice([20, 50, 80, 100])}",
                f"WAIT DI{rng.randrange(64)} {rng.choice(['ON', 'OFF'])}",
                f"OUT DO{rng.randrange(32)} {rng.choice(['ON', 'OFF'])}",
                f"TIMER T{rng.randrange(4):02d}",
                "END",
            ]
        )
    )


def random_config(rng: random.Random) -> Config:
    def area(counts: tuple[int, ...]) -> ProgramArea:
        return ProgramArea(rng.choice(counts), rng.choice((3, 4, 6)))

    return Config(area((1,)), area((1, 2)), area((1, 2)), area((1,)), 4, 16, 4)


def random_target(rng: random.Random, live: RobotData, story: list[str]) -> RobotData:
    """``live`` with a random diff applied."""
    data = copy_data(live)
    cfg = data.config
    if rng.random() < 0.12:
        new = random_config(rng)
        if not new.same_programs(cfg):
            story.append(f"configuration {cfg.numbers()} -> {new.numbers()}")
            data.config = new
            data.programs = {
                key: {
                    n: s
                    for n, s in data.programs.get(key, {}).items()
                    if n < new.area(key[0]).steps
                }
                for key in new.programs()
            }
            cfg = new
    if rng.random() < 0.02:
        story.append("timer count changed (no write can do it)")
        data.config = replace(cfg, timers=cfg.timers + 1)
        data.timers[cfg.timers] = "1.00"
    if rng.random() < 0.7:
        keys = list(cfg.programs())
        for _ in range(rng.randint(1, 5)):
            key = rng.choice(keys)
            step = rng.randrange(cfg.area(key[0]).steps)
            if rng.random() < 0.25:
                data.programs[key].pop(step, None)
            else:
                data.programs[key][step] = random_step(rng)
        story.append("steps edited")
    if rng.random() < 0.4:
        for n in rng.sample(range(cfg.timers), k=rng.randint(1, cfg.timers)):
            data.timers[n] = f"{rng.randrange(1000) / 100:.2f}"
        story.append("timers edited")
    if rng.random() < 0.3:
        for n in rng.sample(range(OFFSET_TABLE_COUNT), k=rng.randint(1, 3)):
            data.offsets[n] = OffsetTable.from_values(
                [f"{rng.uniform(-500, 500):.2f}" for _ in range(6)]
                + [str(rng.randrange(100)), str(rng.randrange(100))]
            )
        story.append("offset tables edited")
    if rng.random() < 0.15:
        data.parameters = replace(data.parameters, pull_rate=str(rng.randrange(1, 100)))
        story.append("parameters edited")
    if rng.random() < 0.25:
        assert data.registers is not None
        for n in rng.sample(range(cfg.registers), k=rng.randint(1, 2)):
            data.registers[n] = f"{rng.randrange(10000):04d}"
        story.append("registers edited")
    return data


def random_schedule(
    rng: random.Random, reads: int, horizon: int, deadline: float
) -> list[tuple[int, Change]]:
    """Mode changes and line faults at random moments: most of them while the push
    writes (request ``reads`` on), the rest at any time.  A lost reply costs two
    deadlines, so the line is clean for most of the long read before the writes."""

    def moment() -> int:
        return rng.randrange(horizon) if rng.random() < 0.15 else rng.randrange(reads, horizon)

    out: list[tuple[int, Change]] = []
    for _ in range(rng.choice([0, 1, 1, 2, 2, 3, 5])):
        task = rng.randrange(5)
        change = rng.choices(
            [
                start(task, rng.choice(["START", "MAIN", "SUB"]), 0, rng.randrange(4)),
                suspend(task),
                stop_all,
                set_status(task, rng.choice([0, 4, 8])),
                set_status(task, rng.choice([3, 16])),
                start_unseen(task, rng.choice(["MAIN", "SUB"]), rng.randrange(1, 8)),
                lnr_fault("idle"),
                lnr_fault("malformed"),
            ],
            weights=[4, 2, 3, 1, 1, 2, 1, 1],
        )[0]
        out.append((moment(), change))
    return out + line_changes(rng, moment, deadline)


def make_case(seed: int) -> Case:
    rng = random.Random(seed)
    state = SimState.generate(rng.randrange(2**31), random_config(rng))
    before = copy_data(state.data)
    story: list[str] = []
    target = random_target(rng, before, story)
    opts = PushOptions(
        yes=True,
        allow_dirty=True,
        allow_live_tuning=rng.random() < 0.5,
        allow_reconfigure=rng.random() < 0.7,
        registers=rng.random() < 0.3,
    )
    story.append(
        f"options: live tuning {opts.allow_live_tuning}, registers {opts.registers}, "
        f"reconfigure {opts.allow_reconfigure}"
    )
    if rng.random() < 0.08:
        state.start_task(rng.randrange(5), "MAIN", 0, 0)
        story.append("the robot runs when the push starts")
    cfg = before.config
    reads = 4 + cfg.step_count + OFFSET_TABLE_COUNT + cfg.timers + cfg.registers * opts.registers
    horizon = reads + 4 * len(sync_items.diff(CATALOGUE, before, target, registers=True)) + 8
    writes = len(sync_items.diff(CATALOGUE, before, target, registers=opts.registers))
    lose_writes = {rng.randrange(writes)} if writes and rng.random() < 0.3 else set()
    if lose_writes:
        story.append(f"write requests lost on the way in: {sorted(lose_writes)}")
    schedule = random_schedule(rng, reads, horizon, FAST.timeout)
    sim = Operator(state, schedule, seed=rng.randrange(2**32), lose_writes=lose_writes)
    return Case(seed, before, target, opts, sim, story)


# --- running it -----------------------------------------------------------------------------


Deploy = Callable[[Case, SerialSettings], Outcome]


@pytest.fixture
def in_memory(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Deploy:
    """Push a case with its project held in memory and its snapshot kept in memory.

    Writing the project, reading it back and writing the snapshot cost three times
    the rest of a case; :func:`test_the_cli_on_a_project_on_disk_keeps_the_same_promises`
    shows that they change nothing the checks look at.
    """
    taken = keep_snapshots(monkeypatch)

    def deploy(case: Case, settings: SerialSettings) -> Outcome:
        url = register(case.sim)
        try:
            robot = new_robot(
                f"case-{case.seed}", url, 1, serial=settings, keep_registers=case.opts.registers
            )
            project = Project(tmp_path / f"case-{case.seed}", robot, case.target)
            first, before = len(case.sim.received), len(taken)
            try:
                result = engine._deploy("push", project, case.target, case.opts, None, None)
                failed = None
            except PushFailed as exc:
                result, failed = exc.result, exc
            snapshot = taken[before] if len(taken) > before else None
            return Outcome(result, failed, case.sim.received[first:], snapshot, first)
        finally:
            unregister(url)

    return deploy


@pytest.fixture
def on_disk(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> Deploy:
    """Push a case as a person does: the project on disk, ``harlsync push DIR --yes``,
    the snapshot written and read back; the exit status and what the command printed
    are checked here (the result is taken from ``engine.push`` on its way out)."""
    seen = spy_on_push(monkeypatch)

    def deploy(case: Case, settings: SerialSettings) -> Outcome:
        url = register(case.sim)
        try:
            path = tmp_path / f"case-{case.seed}"
            robot = new_robot(
                f"case-{case.seed}", url, 1, serial=settings, keep_registers=case.opts.registers
            )
            save_project(path, Project(path, robot, case.target), rewrite_robot=True)
            flags = [
                flag
                for flag, on in (
                    ("--allow-live-tuning", case.opts.allow_live_tuning),
                    ("--allow-reconfigure", case.opts.allow_reconfigure),
                    ("--registers", case.opts.registers),
                )
                if on
            ]
            first = len(case.sim.received)
            result, failed = push_command(
                case.why, ["push", str(path), "--yes", "--allow-dirty", *flags], seen, capsys
            )
            snapshot = load_project(result.snapshot).data if result.snapshot else None
            return Outcome(result, failed, case.sim.received[first:], snapshot, first)
        finally:
            unregister(url)

    return deploy


def needs_idle(letters: str, opts: PushOptions) -> bool:
    """Whether the engine promises an idle robot for this SN (its docstring and README)."""
    return not (opts.allow_live_tuning and letters in LIVE)


def readback_letters(letters: str) -> str:
    return "LN" + letters[2:]


@dataclass
class Tally(BaseTally):
    live_in_automatic: int = 0
    #: LNR replies of a running robot corrupted to read idle past the LRC
    fooled: int = 0


def lnr_run(received: list[Received], end: int) -> list[int]:
    """The indices of the LNR requests in a row just before request ``end``."""
    start = end
    while start and received[start - 1].command == "LNR":
        start -= 1
    return list(range(start, end))


def cleared(case: Case, got: Outcome, run: list[int]) -> bool:
    """Whether a run of LNR requests let a write go, as the interlock promises: at
    least ``IDLE_READS`` of them, the robot idle at one of them, and at the last one
    idle or its reply corrupted past the LRC.

    Some of a run's requests are retries (a reply lost or garbled), so which were
    the client's two readings the record cannot say.  What it can say: a robot busy
    at every one of them was never written to (one reply corrupted to read idle
    could not clear the write), and a robot that started in between was idle at an
    earlier reading: the window no client can close, counted as a race by the write.
    """
    received = got.received
    if len(run) < IDLE_READS:
        return False
    last = run[-1]
    if received[last].busy and got.first + last not in case.sim.fooled_at:
        return False
    return any(not received[k].busy for k in run)


def check_interlock(case: Case, got: Outcome, tally: Tally) -> None:
    opts, received = case.opts, got.received
    for i, r in enumerate(received):
        if not r.is_write or not needs_idle(r.command, opts):
            tally.live_in_automatic += r.is_write and r.busy
            continue
        before = lnr_run(received, i)
        assert cleared(case, got, before), case.why(
            f"{r.payload!r} (request {i}) did not follow {IDLE_READS} LNRs in a row that "
            f"found the robot idle (before it: {[received[k] for k in before]})"
        )
        if r.busy:
            tally.race += 1  # started between that LNR and this write: see the docstring
    plan = got.result.plan
    if (
        opts.allow_live_tuning
        and plan is not None
        and any(needs_idle(w.command.split(" ")[0], opts) for w in plan.writes)
    ):
        writes = [i for i, r in enumerate(received) if r.is_write]
        if writes:
            gate = [i for i, r in enumerate(received[: writes[0]]) if r.command == "LNR"]
            assert gate and cleared(case, got, lnr_run(received, gate[-1] + 1)), case.why(
                "a live-tuning plan with unsafe writes did not find the robot idle "
                "before its first write"
            )


def wire(write: PlannedWrite[Key]) -> str:
    """The payload a write arrives as: its command is the wire's."""
    return write.command


def reads_back(payload: str, between: list[Received]) -> bool:
    readback = readback_letters(payload.split(" ")[0])
    return any(r.command == readback for r in between)


def check_writes(case: Case, got: Outcome, final: RobotData) -> None:
    """The result names exactly what the simulator received; the robot holds old or new."""
    result = got.result
    sent = check_sent(case.why, got, wire, reads_back)
    plan = result.plan
    if plan is None:
        assert not sent, case.why("writes without a plan")
        return
    old, now = CATALOGUE.items(case.before, registers=True), CATALOGUE.items(final, registers=True)
    wiped = plan.reconfigure and final.config.same_programs(case.target.config)
    planned = {w.key: w for w in plan.writes}
    done = {w.key for w in result.written}
    for key in old.keys() | now.keys() | planned.keys():
        was = None if wiped and key[0] == "step" else old.get(key)
        w = planned.get(key)
        if key in done:
            assert w is not None and now.get(key) == w.new, case.why(
                f"{key} was reported written but holds {now.get(key)!r}"
            )
        elif result.failed is not None and key == result.failed.key:
            assert now.get(key) in (was, result.failed.new), case.why(
                f"{key}, whose write failed, holds {now.get(key)!r}: neither old nor new"
            )
        else:
            assert now.get(key) == was, case.why(
                f"{key} was not written but changed from {was!r} to {now.get(key)!r}"
            )


def check_converged(case: Case, final: RobotData) -> None:
    left = sync_items.diff(CATALOGUE, final, case.target, registers=case.opts.registers)
    assert not left, case.why(f"push returned but the robot still differs: {left[:3]}")


def check_case(case: Case, deploy: Deploy, tally: Tally) -> None:
    try:
        check_pushes(case, deploy, tally)
    finally:
        tally.fooled += len(case.sim.fooled_at)


def check_pushes(case: Case, deploy: Deploy, tally: Tally) -> None:
    got = deploy(case, FAST)
    final = case.sim.stations[1].data
    tally.cases += 1
    tally.lost_writes += case.sim.lost_writes
    check_interlock(case, got, tally)
    check_writes(case, got, final)
    if got.snapshot is not None:
        assert not sync_items.diff(
            CATALOGUE, got.snapshot, case.before, registers=case.opts.registers
        ), case.why("the snapshot is not what the robot held before the push")
    if got.failed is None:
        tally.ok += 1
        check_converged(case, final)
        return
    count_failure(tally, got)
    check_failure(case.why, got)
    if isinstance(got.failed.cause, PolicyError):
        check_wrote_nothing(case.why, got)
        return
    # The operator stops the robot and the line is mended: the same push finishes.
    case.sim.calm()
    case.before = copy_data(final)
    again = deploy(case, CALM)
    check_interlock(case, again, tally)
    check_writes(case, again, final)
    refused = refused_by_policy(case)
    check_rerun(case.why, again, refused=refused)
    if not refused:
        check_converged(case, final)


def refused_by_policy(case: Case) -> bool:
    """Whether no push of this case may write: SNX not allowed, or what SNX cannot write."""
    live, target = case.before.config, case.target.config
    if live.timers != target.timers:
        return True
    return not live.same_programs(target) and not case.opts.allow_reconfigure


@pytest.mark.parametrize("chunk", CHUNKS)
def test_no_unsafe_write_reaches_a_running_robot_and_every_push_converges_or_names_its_writes(
    chunk: int, in_memory: Deploy
) -> None:
    tally = Tally()
    for seed in seeds(chunk, BASE):
        check_case(make_case(seed), in_memory, tally)
    print(json.dumps(tally.__dict__))
    if not ONLY:  # the cases still reach what they are meant to (a generator can rot)
        assert tally.ok >= 25 and tally.failed - tally.refused_before_writing >= 10, tally
        assert tally.lost_writes >= 5, tally
        assert tally.fooled >= 3, tally


#: Seeds for the on-disk run: enough to meet every kind of outcome, few enough to be quick.
ON_DISK = range(BASE - 40, BASE)


def test_the_cli_on_a_project_on_disk_keeps_the_same_promises(on_disk: Deploy) -> None:
    tally = Tally()
    for seed in ONLY or ON_DISK:
        check_case(make_case(seed), on_disk, tally)
    print(json.dumps(tally.__dict__))
