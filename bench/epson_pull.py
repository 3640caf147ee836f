"""An Epson pull of every setting and the points P0-P99 against the Epson simulator over
Modbus TCP: Modbus round trips per item, against the minimum the handshake allows, and
the time per command against the simulator's execution time.

    python bench/epson_pull.py                    a SCARA and a six-axis robot, 3 runs each (~30 s)
    python bench/epson_pull.py --exec 0,0.002,0.010 --repeat 1
    python bench/epson_pull.py --probe --repeat 3  the probe past the point range (issue 20)

The robots are ``SimState.generate`` robots (seeds 5 and 6, points spread over P0-P119,
so part of P0-P99 is defined and part is not).  Each is served by ``harlsync sim
--family epson --listen 127.0.0.1:0`` in a process of its own, except that the
simulator is started here in a child process with the execution time asked for
(``--exec``: seconds from ExtCmdGet to ExtRespSet; the default 0.002 is the
simulator's own).  The pull is the family's Controller.read_all over its ModbusLink
and Handshake, as ``harlsync pull`` runs it, with the link wrapped to count its
requests.

The minimum the §6.3 handshake allows for one command, when the controller is quick
enough that every poll finds what it waits for at the first read: the step-1 status
read, the command words with ExtCmdSet 1 in one write (steps 2-3, issue 24), one read
for ExtCmdGet (step 4), ExtCmdSet 0, one read for ExtRespSet with the response (steps
6-8), ExtRespGet 1, one read for ExtRespSet 0 (step 9), ExtRespGet 0: 8 round trips
(4 writes, 4 reads); 9 when the words and ExtCmdSet are two writes (``--split``, what
harlsync did before issue 24, and what it does where the map or the slave does not
allow one).  harlsync adds one: it reads its own control register back before each
command's step 1 (a restarted controller has it at 0 again), so 9 is its floor (10
split).  The simulator counts the register accesses it answers too: its figure is
printed beside the client's.  Items: a table entry
is read by one command (two for AccelS/AccelR/SpeedS, which need more response
words than some maps have: the profile's 8 words read them whole), a Box, XYLim in
Rn sequences of one command an axis; an undefined point costs one command (its first
coordinate answers 2004), a defined one a command a coordinate and attribute.

``--split`` also runs every pull with the words and ExtCmdSet in two writes
(``Handshake(block_write_whole=False)`` on the profile's map), alternating with the
default one, so both are measured under the same load.

``--probe``: the same pull of P0-P119 (every point the generated robots have) with
and without the probe a pull makes past the range (one 1222 read of each point
P120-P999, the profile's POINT_PROBE_END): its cost, in seconds and per point.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import statistics
import time
from collections import Counter
from collections.abc import Sequence
from typing import Any

from harlsync.families.epson.controller import Controller
from harlsync.families.epson.handshake import Handshake
from harlsync.families.epson.sim import SimState, Simulator
from harlsync.families.epson.transport import ModbusLink

#: round trips a command: the §6.3 handshake's least, with steps 2-3 in one write
MINIMUM = 8
#: and with them in two (--split)
MINIMUM_SPLIT = MINIMUM + 1
#: harlsync reads its control register back before each command
READ_BACK = 1


def serve(seed: int, robot_type: int, execution: float, conn: Any) -> None:
    sim = Simulator(SimState.generate(seed, robot_type=robot_type), execution_time=execution)
    with sim.serve("127.0.0.1", 0) as server:
        conn.send(server.url)
        conn.recv()  # until the parent is done
        conn.send((len(sim.commands()), sum(sim.accesses().values()), sim.stale_requests))


class Counting:
    """A RegisterAccess that counts the requests of each command."""

    def __init__(self, link: ModbusLink) -> None:
        self.link, self.label = link, link.label
        self.requests = 0
        self.reads = 0
        self.writes = 0

    def read_holding(self, address: int, count: int) -> list[int]:
        self.requests += 1
        self.reads += 1
        return self.link.read_holding(address, count)

    def read_input(self, address: int, count: int) -> list[int]:
        self.requests += 1
        self.reads += 1
        return self.link.read_input(address, count)

    def write_holding(self, address: int, values: Sequence[int]) -> None:
        self.requests += 1
        self.writes += 1
        self.link.write_holding(address, values)


def one_pull(
    seed: int,
    robot_type: int,
    execution: float,
    *,
    last: int = 99,
    probe: bool = False,
    split: bool = False,
) -> dict[str, Any]:
    parent, child = mp.Pipe()
    proc = mp.Process(target=serve, args=(seed, robot_type, execution, child), daemon=True)
    proc.start()
    url = parent.recv()
    try:
        with ModbusLink(url, lock_dir=None) as link:
            counting = Counting(link)
            hs = Handshake(counting, block_write_whole=not split)
            commands = Counter[str]()
            execute = hs.execute

            def counted(request: Any) -> Any:
                commands["all"] += 1
                return execute(request)

            hs.execute = counted  # type: ignore[method-assign]
            controller = Controller(hs, first=0, last=last)
            start = time.perf_counter()
            data = controller.read_all(probe=probe)
            took = time.perf_counter() - start
        parent.send("done")
        served, sim_accesses, stale = parent.recv()
    finally:
        proc.join(5)
    n = commands["all"]
    items = len(data.items)
    points = len(data.points())
    return {
        "robot": f"type {data.robot_type} ({data.axes} axes)",
        "writes_of_steps_2_3": 2 if split else 1,
        "execution_s": execution,
        "items": items,
        "points_defined": points,
        "probe": probe,
        "keys_read": items + (last + 1 - points),
        "commands": n,
        "commands_served": served,
        "round_trips": counting.requests,
        "round_trips_sim_counted": sim_accesses,
        "stale_requests": len(stale),
        "reads": counting.reads,
        "writes": counting.writes,
        "round_trips_per_command": round(counting.requests / n, 2),
        "round_trips_per_key": round(counting.requests / (items + last + 1 - points), 2),
        "seconds": round(took, 3),
        "ms_per_command": round(took / n * 1000, 3),
        "ms_per_round_trip": round(took / counting.requests * 1000, 3),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--exec", default="0.002", help="execution times, seconds, comma-separated")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--probe", action="store_true", help="the cost of the probe past P119")
    ap.add_argument(
        "--split",
        action="store_true",
        help="also pull with the command words and ExtCmdSet in two writes, alternating",
    )
    args = ap.parse_args()
    mp.set_start_method("spawn")
    if args.probe:
        probe_cost(float(args.exec.split(",")[0]), args.repeat)
        return
    print(
        f"minimum per command (§6.3): {MINIMUM} round trips with steps 2-3 in one write "
        f"({MINIMUM_SPLIT} in two); harlsync's floor {MINIMUM + READ_BACK} "
        f"({MINIMUM_SPLIT + READ_BACK}): the control register read back before step 1"
    )
    layouts = (False, True) if args.split else (False,)
    for execution in (float(x) for x in args.exec.split(",")):
        for seed, robot_type in ((5, 3), (6, 5)):
            runs: dict[bool, list[dict[str, Any]]] = {split: [] for split in layouts}
            for _ in range(args.repeat):
                for split in layouts:  # alternating: both under the same load
                    runs[split].append(one_pull(seed, robot_type, execution, split=split))
            for split in layouts:
                best = min(runs[split], key=lambda r: r["seconds"])
                median = statistics.median(r["seconds"] for r in runs[split])
                best["seconds_median"] = round(median, 3)
                best["ms_per_command_median"] = round(median / best["commands"] * 1000, 3)
                best["execution_share"] = round(execution * best["commands"] / best["seconds"], 3)
                floor = (MINIMUM_SPLIT if split else MINIMUM) + READ_BACK
                best["round_trips_over_floor"] = round(best["round_trips_per_command"] - floor, 2)
                print(json.dumps(best))


def probe_cost(execution: float, repeat: int) -> None:
    """A pull of P0-P119 with and without the probe of P120-P999, medians of ``repeat``."""
    from harlsync.families.epson.profile import POINT_PROBE_END

    probed = POINT_PROBE_END - 119
    for seed, robot_type in ((5, 3), (6, 5)):
        got = {}
        for probe in (False, True):
            runs = [
                one_pull(seed, robot_type, execution, last=119, probe=probe) for _ in range(repeat)
            ]
            got[probe] = {
                "seconds": statistics.median(r["seconds"] for r in runs),
                "commands": runs[0]["commands"],
                "round_trips": runs[0]["round_trips"],
            }
        extra = got[True]["seconds"] - got[False]["seconds"]
        print(
            json.dumps(
                {
                    "robot": f"seed {seed} type {robot_type}",
                    "execution_s": execution,
                    "pull_s": round(got[False]["seconds"], 3),
                    "pull_with_probe_s": round(got[True]["seconds"], 3),
                    "probe_s": round(extra, 3),
                    "points_probed": probed,
                    "probe_commands": got[True]["commands"] - got[False]["commands"],
                    "probe_round_trips": got[True]["round_trips"] - got[False]["round_trips"],
                    "ms_per_point_probed": round(extra / probed * 1000, 3),
                }
            )
        )


if __name__ == "__main__":
    main()
