"""What the interlock property tests of every family share
(tests/families/harl_u2/test_interlock_property.py for the HARL-U2, tests/families/iai/test_interlock_property.py
for IAI): the seeds, an operator's schedule and a line that goes bad, running a push
through the command, and the checks whose logic is the same for every family.

Each family's test keeps what only it knows: its robots and their random diffs, what
its operator does to a controller, which requests clear a write, how a write is read
back, and what converged means.
"""

from __future__ import annotations

import os
import random
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import pytest

from harlsync import cli
from harlsync.errors import InterlockError, PolicyError, StalePlanError
from harlsync.link import exchange
from harlsync.sim import Faults, Received, protocol_sim
from harlsync.sync import PushFailed, PushResult, deploy
from harlsync.sync import audit as audit_log
from harlsync.sync import git as sync_git
from harlsync.sync.plan import PlannedWrite

PER_CHUNK = 100
#: How many chunks the default run pushes (100 seeded cases a family); the slow run
#: (``pytest -m slow``) pushes the other nine, for the full 1,000.
FAST_CHUNKS = 1
#: The chunk parameters of a family's property test: ``parametrize("chunk", CHUNKS)``.
#: Each chunk checks its own coverage, so the fast ones meet every kind of case too.
CHUNKS = [
    pytest.param(chunk, id=str(chunk), marks=() if chunk < FAST_CHUNKS else pytest.mark.slow)
    for chunk in range(10)
]
#: ``HARLSYNC_PROPERTY_SEEDS=7,8,9`` runs only those seeds (a failure names its seed).
ONLY = [int(s) for s in os.environ.get("HARLSYNC_PROPERTY_SEEDS", "").split(",") if s.strip()]

#: A story line, the case's seed and how to replay it: what a failing check says.
Why = Callable[[str], str]
#: What an operator does to a simulated controller: ``change(sim, state)`` says what it did.
Change = Callable[[Any, Any], str]


def base(default: int) -> int:
    """The first seed: ``HARLSYNC_PROPERTY_BASE`` moves every chunk."""
    return int(os.environ.get("HARLSYNC_PROPERTY_BASE", str(default)))


def seeds(chunk: int, first: int) -> Iterator[int]:
    """The seeds of one chunk (all of :data:`ONLY` in chunk 0 when it is set)."""
    if ONLY:
        yield from (ONLY if chunk == 0 else [])
        return
    yield from range(first + chunk * PER_CHUNK, first + (chunk + 1) * PER_CHUNK)


def explain(seed: int, story: list[str], message: str) -> str:
    return (
        f"case seed {seed} (HARLSYNC_PROPERTY_SEEDS={seed} to replay): "
        f"{message}\n  " + "\n  ".join(story)
    )


# --- the operator and the line --------------------------------------------------------------


class Scheduled:
    """Mixed into a family's simulator: a schedule of changes, each made after the
    controller has answered the k-th request, and a line that goes bad.

    The family's subclass calls :meth:`on_the_way_in` on the bytes a request
    arrives as, :meth:`before_request` before carrying one out, and :meth:`act`
    once it is carried out (its reply made, not yet on the wire).
    """

    faults: Faults
    #: The family simulator's own: the frame with a wrong checksum.
    corrupt_checksum: Callable[[bytes], bytes]

    def start_schedule(
        self,
        schedule: list[tuple[int, Change]],
        *,
        seed: int,
        deadline: float,
        lose_writes: set[int] | None = None,
    ) -> None:
        self.schedule = sorted(schedule, key=lambda entry: entry[0])
        #: What the operator did, after which request: the end of a failing case's story.
        self.done: list[str] = []
        #: The rate of requests garbled on their way in (never carried out, never answered).
        self.lose = 0.0
        #: Which write requests (0: the first one sent) are garbled on their way in.
        self.lose_writes = lose_writes or set()
        self.writes_sent = 0
        self.lost_writes = 0
        #: The chance that the reply to the request after which the operator acts is
        #: late, lost or garbled: the operator acts while it is on the wire.
        self.hiccup = 0.4
        #: The reply deadline a late reply is measured against.
        self.deadline = deadline
        self._restore: Faults | None = None
        self._rng = random.Random(seed)

    def mend(self) -> None:
        """No more changes, and the line is clean."""
        self.schedule, self.lose_writes = [], set()
        self.faults, self._restore, self.lose, self.hiccup = Faults(), None, 0.0, 0.0

    def on_the_way_in(self, data: bytes, write: bool) -> bytes:
        """The request as it reaches the controller: garbled (a bad checksum, so the
        controller drops it) at the rate :attr:`lose`, or when it is a write named in
        :attr:`lose_writes`."""
        lost = self.lose and self._rng.random() < self.lose
        if write:
            lost = lost or self.writes_sent in self.lose_writes
            self.writes_sent += 1
        if data and lost:
            data = self.corrupt_checksum(data)
            self.lost_writes += write
        return data

    def before_request(self) -> None:
        """The faults of the reply before this one (a hiccup) are over."""
        if self._restore is not None:
            self.faults, self._restore = self._restore, None

    def make(self, change: Change, state: Any) -> str:
        """Make one change; what it did, for the story."""
        return change(self, state)

    def act(self, state: Any, index: int, what: str) -> None:
        """Make the changes due after request ``index`` (``what`` it was, for the story)."""
        acted = False
        while self.schedule and self.schedule[0][0] <= index:
            _, change = self.schedule.pop(0)
            self.done.append(f"after request {index} ({what}): {self.make(change, state)}")
            acted = True
        if acted and self._rng.random() < self.hiccup:
            self._restore = self.faults
            # Late within the link's late window (a reply later than that is beyond
            # what any link without sequence numbers can place).
            self.faults = self._rng.choice(
                [
                    Faults(slow=1.0, slow_delay=self.deadline * 1.5),
                    Faults(drop=1.0),
                    Faults(bad_checksum=1.0),
                ]
            )
            self.done.append(f"  and the reply to it: {self.faults}")


def line(faults: Faults, lose: float) -> Change:
    def change(sim: Any, state: Any) -> str:
        assert isinstance(sim, Scheduled)
        sim.faults, sim.lose = faults, lose
        return f"faults now {faults}, requests lost {lose}"

    return change


def random_faults(rng: random.Random, deadline: float) -> tuple[Faults, float]:
    """Faults on the replies, and the rate of requests lost on the way in."""
    faults = Faults(
        noise=rng.choice([0.0, 0.02, 0.1]),
        drop=rng.choice([0.0, 0.005, 0.01, 0.03]),
        bad_checksum=rng.choice([0.0, 0.005, 0.01, 0.03]),
        fragment=rng.choice([0.0, 0.05, 0.2]),
        slow=rng.choice([0.0, 0.005, 0.01, 0.03]),
        slow_delay=deadline * rng.choice([1.2, 1.8]),
        fragment_gap=0.001,
        seed=rng.randrange(2**32),
    )
    return faults, rng.choice([0.0, 0.005, 0.01, 0.03])


def line_changes(
    rng: random.Random, moment: Callable[[], int], deadline: float
) -> list[tuple[int, Change]]:
    """The line going bad at random moments: often for good, sometimes a short burst."""
    out: list[tuple[int, Change]] = []
    if rng.random() < 0.6:
        out.append((moment(), line(*random_faults(rng, deadline))))
    if rng.random() < 0.15:
        at = moment()
        bad = Faults(
            drop=rng.choice([0.2, 0.5]),
            bad_checksum=0.1,
            slow=0.1,
            noise=0.2,
            slow_delay=deadline * 1.5,
            seed=rng.randrange(2**32),
        )
        out += [
            (at, line(bad, rng.choice([0.2, 0.4]))),
            (at + rng.randint(2, 5), line(Faults(), 0.0)),
        ]
    return out


# --- time ------------------------------------------------------------------------------------


class FakeTime:
    """The clock of an in-memory line (``sim://``: the link and the simulated port in
    one thread), moved only by the waiting itself: a wait for a reply that is due
    later moves the clock to it, a deadline passes when nothing else is due first.
    A case then goes the same way on any machine, under any load: what is late, lost
    or in time is the schedule's and the faults' doing, never the machine's speed.
    Stands in for the :mod:`time` module of ``harlsync.link.exchange`` and
    ``harlsync.sim.protocol_sim``, and for the simulated port's condition."""

    def __init__(self) -> None:
        self.now = 1000.0

    def monotonic(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += max(0.0, seconds)

    def Condition(self) -> FakeTime:
        return self

    def __enter__(self) -> FakeTime:
        return self

    def __exit__(self, *exc: object) -> None:
        pass

    def wait(self, timeout: float | None = None) -> bool:
        assert timeout is not None, "an in-memory line waited for ever"
        self.sleep(timeout)
        return False

    def notify_all(self) -> None:
        pass

    def __getattr__(self, name: str) -> Any:  # the rest of the time module
        return getattr(time, name)


def fake_time(monkeypatch: pytest.MonkeyPatch) -> FakeTime:
    """Put the in-memory line (the link and ``sim://`` ports opened from now on) on a
    :class:`FakeTime`; returns it."""
    clock = FakeTime()
    monkeypatch.setattr(exchange, "time", clock)
    monkeypatch.setattr(protocol_sim, "time", clock)
    monkeypatch.setattr(protocol_sim, "threading", clock)
    return clock


# --- running a push -----------------------------------------------------------------------


@dataclass
class Outcome:
    result: PushResult
    failed: PushFailed | None
    received: list[Received]
    #: the robot's data in the snapshot taken before the first write
    snapshot: Any
    #: where this push's requests start in the controller's record
    first: int = 0


def keep_snapshots(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Keep each snapshot a push takes in memory (in this list) instead of saving it.

    Every push held in memory starts here, so this also puts its line on a
    :class:`FakeTime` (:func:`fake_time`): the same case gives the same outcome
    under any load."""
    fake_time(monkeypatch)
    taken: list[Any] = []

    def keep(path: Any, robot: object, live: Any, action: str) -> Any:
        taken.append(live)
        return path / "snapshot"

    monkeypatch.setattr(deploy, "save_snapshot", keep)
    return taken


class WithoutFsync:
    """The :mod:`os` module as the audit log sees it, with ``fsync`` a no-op."""

    def __getattr__(self, name: str) -> Any:
        return getattr(os, name)

    @staticmethod
    def fsync(fd: int) -> None:
        pass


def off_the_disk(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """:func:`keep_snapshots`, and the rest of what only the disk has for a push whose
    project is held in memory: the audit log's fsync (each case keeps its own log,
    which the checks read back) and git asked for the commit of a project that is
    not in a repository.  Returns the snapshots taken."""
    taken = keep_snapshots(monkeypatch)
    monkeypatch.setattr(sync_git, "head", lambda path: None)  # deploy asks it
    monkeypatch.setattr(audit_log, "os", WithoutFsync())
    return taken


def spy_on_push(monkeypatch: pytest.MonkeyPatch) -> list[PushResult | PushFailed]:
    """What each ``deploy.push`` returned or raised, in order.

    Every push through the command starts here, on a ``sim://`` line in this process
    like a push held in memory, so this too puts the line on a :class:`FakeTime`."""
    fake_time(monkeypatch)
    real = deploy.push
    seen: list[PushResult | PushFailed] = []

    def spy(*args: Any, **kwargs: Any) -> PushResult:
        try:
            result = real(*args, **kwargs)
        except PushFailed as exc:
            seen.append(exc)
            raise
        seen.append(result)
        return result

    monkeypatch.setattr(deploy, "push", spy)
    return seen


def push_command(
    why: Why,
    argv: list[str],
    seen: list[PushResult | PushFailed],
    capsys: pytest.CaptureFixture[str],
) -> tuple[PushResult, PushFailed | None]:
    """Run ``harlsync push``; check its exit status and that what it printed names the
    cause and every write made or unknown.  Returns what ``deploy.push`` gave."""
    capsys.readouterr()
    code = cli.main(argv)
    printed = capsys.readouterr().err
    outcome = seen.pop()
    failed = outcome if isinstance(outcome, PushFailed) else None
    result = outcome.result if isinstance(outcome, PushFailed) else outcome
    refused = failed is not None and isinstance(
        failed.cause, InterlockError | PolicyError | StalePlanError
    )
    assert code == (0 if failed is None else 3 if refused else 2), why(
        f"exit status {code}: {printed}"
    )
    if failed is not None:
        # As a person reads it: a wire frame named by its size, commands only with -v.
        cause = audit_log.shorten(str(failed.cause)) or ""
        assert cause in printed, why(f"cause not shown: {printed}")
        for w in result.written:
            assert f"written:     {w.name}\n" in printed, why(printed)
        if result.failed is not None:
            assert f"unknown:     {result.failed.name} (may or may not" in printed, why(printed)
    return result, failed


# --- the checks -------------------------------------------------------------------------------


@dataclass
class Tally:
    cases: int = 0
    ok: int = 0
    failed: int = 0
    refused_before_writing: int = 0
    race: int = 0
    lost_writes: int = 0
    causes: dict[str, int] = field(default_factory=dict)


def check_sent(
    why: Why,
    got: Outcome,
    wire: Callable[[PlannedWrite[Any]], str],
    reads_back: Callable[[str, list[Received]], bool],
    *,
    refused: Callable[[list[Received]], bool] | None = None,
) -> list[Received]:
    """The result names exactly the writes the controller received (each one written,
    or the one whose outcome is unknown), and none was sent twice without being read
    back in between.  Returns the writes received.

    ``wire`` gives the payload a planned write arrives as; ``reads_back`` whether
    the requests between two sends of a write read back all it wrote.  With
    ``refused``, a write the result names as not written may have arrived when
    ``refused(its arrivals)`` says the controller refused it (the caller checks
    that its items hold their old values).
    """
    result = got.result
    sent = [r for r in got.received if r.is_write]
    written = {wire(w) for w in result.written}
    maybe = written | ({wire(result.failed)} if result.failed else set())
    if refused is not None:
        for w in result.not_written:
            arrivals = [r for r in sent if r.payload == wire(w)]
            if arrivals and refused(arrivals):
                maybe.add(wire(w))
    for r in sent:
        assert r.payload in maybe, why(
            f"the controller received {r.payload!r}, which the result does not name as "
            "written or unknown"
        )
    payloads = [r.payload for r in sent]
    for payload in written:
        assert payload in payloads, why(f"reported written but never sent: {payload!r}")
    for payload in set(payloads):
        at = [i for i, r in enumerate(got.received) if r.payload == payload]
        assert len(at) <= 2, why(f"{payload!r} sent {len(at)} times")
        if len(at) == 2:
            between = got.received[at[0] + 1 : at[1]]
            assert reads_back(payload, between), why(
                f"{payload!r} sent twice without reading it back in between"
            )
    return sent


def check_failure(why: Why, got: Outcome) -> None:
    """A push that failed says why in one line; its result covers the plan and its
    audit record names what it wrote."""
    assert got.failed is not None
    message = str(got.failed)
    assert message and "\n" not in message, why(f"not one line: {message!r}")
    result = got.result
    plan = result.plan
    if plan is not None:
        # written, the one unknown, and not written: the plan, each write once.
        named = [w.command for w in result.written] + [w.command for w in result.not_written]
        assert sorted(named) == sorted(plan.commands), why("result does not cover the plan")
        if result.failed is not None:
            assert result.failed in result.not_written, why("unknown write not listed")
    record = audit_log.read()[-1]
    assert record.error == result.error, why("audit record is not this push's")
    assert [w.command for w in record.done] == [w.command for w in result.written]
    assert record.failed_item == (result.failed.name if result.failed else None)


def check_wrote_nothing(why: Why, got: Outcome) -> None:
    """A push refused by policy sent no write."""
    assert not [r for r in got.received if r.is_write], why("refused, yet wrote")


def check_rerun(why: Why, again: Outcome, *, refused: bool) -> None:
    """The same push once the robot is stopped and the line is clean: it finishes, or
    (``refused``: no push of the case may write) is refused again and writes nothing."""
    if refused:
        assert again.failed is not None and isinstance(again.failed.cause, PolicyError), why(
            f"the re-run was not refused: {again.failed}"
        )
        check_wrote_nothing(why, again)
    else:
        assert again.failed is None, why(f"the re-run failed: {again.failed}")


def count_failure(tally: Tally, got: Outcome) -> None:
    tally.failed += 1
    assert got.failed is not None
    cause = type(got.failed.cause).__name__
    tally.causes[cause] = tally.causes.get(cause, 0) + 1
    if not [r for r in got.received if r.is_write]:
        tally.refused_before_writing += 1
