"""What the probe past the position table costs an IAI pull (issue 20), and the
probes around the kept flags and variables (review finding 3, issue 29): extra
exchanges, bytes on the line and seconds.

    python bench/iai_probe.py                    TTA and TT, 9600 and 115200 baud (~2 min)
    python bench/iai_probe.py --baud 9600 --model TTA --repeat 3

A simulator process (bench/simserver.py, the ``iai-mix`` table: 1,000 positions
defined, 1-1000, with wire-time emulation at the baud rate) is read by a
:class:`~harlsync.families.iai.controller.Controller` in this process, the way a
pull reads it: the whole table (``read_all``, which ends with the probe), then
the table and its probe again (``read_position_table``: the probe is what it
asks beyond the table's reads; past 1000, position 1001 alone and one 22DH for
every number from the range's first; the range starts at 1, so there is none
below it), then the profile's flag, integer and real ranges with their probes
(``read_section``: each read, then below it down to the lowest number and past it
up to the last its message names, 65535 flags and 4095 variables, in queries of
the read size; nothing set there; issue 29).  The simulator counts the exchanges
and the bytes both ways; the seconds are this process's monotonic clock.  The
probe's exchanges, bytes and seconds are the table read with the probe less its
pages read alone (``read_positions``); the share is the probe's time over the
whole read's.
"""

from __future__ import annotations

import argparse
import time

from machine import SimProcess, describe

from harlsync.families.iai.controller import Controller
from harlsync.settings import SerialSettings

TABLES = {"TTA": "iai-mix", "TT": "iai-mix-tt"}


def measure(model: str, baud: int, repeat: int) -> dict[str, float]:
    sim = SimProcess(TABLES[model], baud=baud)
    try:
        settings = SerialSettings(baudrate=baud, timeout=0.5, retries=3)
        c = Controller.from_url(sim.ports[0], 0x99, settings, model=model, first=1, last=1000)
        try:
            best_all = best_probe = best_vars = float("inf")
            for _ in range(repeat):
                sim.reset()
                start = time.monotonic()
                data = c.read_all()
                best_all = min(best_all, time.monotonic() - start)
                whole = sim.stats()[0]
                sim.reset()
                start = time.monotonic()
                c.read_positions(1, 1000)  # the table's pages alone
                pages_seconds = time.monotonic() - start
                pages = sim.stats()[0]
                sim.reset()
                start = time.monotonic()
                c.read_position_table()  # the pages and the probe
                best_probe = min(best_probe, max(0.0, time.monotonic() - start - pages_seconds))
                table = sim.stats()[0]
                probe = {
                    key: table[key] - pages[key] for key in ("exchanges", "bytes_in", "bytes_out")
                }
                sim.reset()
                start = time.monotonic()
                for section in ("flags", "integers", "reals"):
                    c.read_section(section)
                best_vars = min(best_vars, time.monotonic() - start)
                variables = sim.stats()[0]
            assert len(data.positions) == 1000
        finally:
            c.close()
    finally:
        sim.close()
    return {
        "exchanges": whole["exchanges"],
        "probe_exchanges": probe["exchanges"],
        "bytes": whole["bytes_in"] + whole["bytes_out"],
        "probe_bytes": probe["bytes_in"] + probe["bytes_out"],
        "seconds": best_all,
        "probe_seconds": best_probe,
        "vars_exchanges": variables["exchanges"],
        "vars_bytes": variables["bytes_in"] + variables["bytes_out"],
        "vars_seconds": best_vars,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--baud", default="9600,115200")
    parser.add_argument("--model", default="TTA,TT")
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    print(f"harlsync IAI probe bench: {describe()}")
    print(
        f"{'model':6} {'baud':>6} {'exchanges':>9} {'+probe':>6} {'bytes':>7} {'+probe':>6} "
        f"{'read s':>7} {'probe s':>7} {'share':>6} {'vars ex':>7} {'vars B':>7} {'vars s':>6}"
    )
    for model in args.model.split(","):
        for baud in (int(b) for b in args.baud.split(",")):
            m = measure(model, baud, args.repeat)
            print(
                f"{model:6} {baud:>6} {m['exchanges']:>9} {m['probe_exchanges']:>6} "
                f"{m['bytes']:>7} {m['probe_bytes']:>6} {m['seconds']:>7.2f} "
                f"{m['probe_seconds']:>7.3f} {m['probe_seconds'] / m['seconds']:>6.1%} "
                f"{m['vars_exchanges']:>7} {m['vars_bytes']:>7} {m['vars_seconds']:>6.2f}"
            )


if __name__ == "__main__":
    main()
