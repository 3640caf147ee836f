"""The toy controller, simulated on the shared framework (:mod:`harlsync.sim`)."""

from __future__ import annotations

import json
import random
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from harlsync.errors import ProjectError
from harlsync.sim import device
from harlsync.sim.family import Verb
from harlsync.sim.variants import Variant

from .codec import SLOTS, Decoder, Frame, corrupt, encode

VERSION = "TOY 1.0"


@dataclass
class SimState:
    slots: dict[int, int] = field(default_factory=dict)
    running: bool = False

    @classmethod
    def generate(cls, seed: int) -> SimState:
        rng = random.Random(seed)
        return cls({n: rng.randrange(10000) for n in range(SLOTS) if rng.random() < 0.8})


class ToySimFamily:
    name = "toy"
    verbs = (Verb("run", "[STATION]", "running a program"), Verb("stop", "[STATION]", "idle"))
    busy_verb = "run"
    default_station = 1
    #: how it may fill its manual's silences (harlsync.sim.variants); the profile's first
    variants: tuple[Variant, ...] = ()

    def decoder(self) -> Decoder:
        return Decoder()

    def generate(self, seed: int, stations: Sequence[int]) -> Simulator:
        return Simulator({n: SimState.generate(seed + i) for i, n in enumerate(stations)})

    def from_project(self, project: Path, stations: Sequence[int] | None) -> Simulator:
        from harlsync.project import load_project

        loaded = load_project(project)
        slots = dict(loaded.data.slots)
        return Simulator({n: SimState(dict(slots)) for n in stations or [loaded.robot.station]})


SIM_FAMILY = ToySimFamily()


class Simulator(device.Simulator[SimState, Frame]):
    family = SIM_FAMILY

    def respond(self, station: int, state: SimState, frame: Frame) -> bytes | None:
        words = frame.payload.split()
        if not words:
            return None
        verb, args = words[0], words[1:]
        if verb == "S":
            reply = "RUN" if state.running else "IDLE"
        elif verb == "V":
            reply = VERSION
        elif verb == "R" and len(args) == 1 and args[0].isdigit() and int(args[0]) < SLOTS:
            n = int(args[0])
            reply = f"= {n} {state.slots[n]}" if n in state.slots else f"= {n} -"
        elif verb == "W" and len(args) == 2 and all(a.isdigit() for a in args):
            if state.running:
                reply = "ERR BUSY"  # the controller's own interlock
            else:
                state.slots[int(args[0])] = int(args[1])
                self.wrote(state)
                reply = "OK"
        else:
            return None
        return encode(station, reply)

    def is_write(self, frame: Frame) -> bool:
        return frame.payload.startswith("W ")

    def command(self, frame: Frame) -> str:
        return frame.payload.split()[0] if frame.payload else ""

    def busy(self, state: SimState) -> bool:
        return state.running

    def corrupt_checksum(self, frame: bytes) -> bytes:
        return corrupt(frame)

    def control(self, verb: str, state: SimState, args: Sequence[str]) -> None:
        if verb not in ("run", "stop"):
            raise ValueError(f"unknown verb {verb!r}")
        state.running = verb == "run"

    def describe(self, state: SimState) -> str:
        return "running" if state.running else "idle"

    def save_station(self, station: int, directory: Path) -> None:
        directory.mkdir(parents=True, exist_ok=True)
        (directory / "slots.json").write_text(json.dumps(self.stations[station].slots))

    def load_station(self, station: int, directory: Path) -> bool:
        path = directory / "slots.json"
        if not path.exists():
            return False
        try:
            slots = {int(k): int(v) for k, v in json.loads(path.read_text()).items()}
        except ValueError as exc:
            raise ProjectError(f"{path}: {exc}") from exc
        self.stations[station] = SimState(slots)
        return True
