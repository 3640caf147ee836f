"""How fast the sans-I/O codec encodes and decodes HARL-U2 frames, and what decoding holds.

    python bench/codec.py                  100,000 frames, best of 3
    python bench/codec.py --frames 20000 --repeat 1

Prints frames/s for encode_frame and for FrameDecoder fed three ways: the whole
buffer at once, one frame per feed (a reply arriving whole, as the link sees it
on a quiet line) and one byte per feed (a slow line, or a pty read per byte);
then the tracemalloc peak of decoding all the frames.  A figure, not a test: see
bench/README.md.
"""

from __future__ import annotations

import argparse
import gc
import time
import tracemalloc
from collections.abc import Callable

from machine import describe, peak_rss_mib

from harlsync.families.harl_u2.protocol import FrameDecoder, encode_frame

#: The frames of a pull, in about the proportions a pull sends them: mostly step
#: reads and their replies, some empty steps, a few long replies (LNE, LNR, LNL).
MIX = [
    (1, "LNM 2 3"),
    (1, "3 MOVE P010 S50"),
    (1, "LNM 2 4"),
    (1, "4 CALLS S03"),
    (1, "LNM 2 5"),
    (1, "5"),
    (1, "LNS 1 17"),
    (1, "17 WAIT DI12 ON"),
    (1, "LNT 3"),
    (1, "0.50"),
    (1, "LNL 7"),
    (1, "-123.45 6.00 0.00 250.00 0.00 0.00 12 3"),
    (1, "LNE"),
    (1, "104 1 0 20.00 20.00 30.00 30.00 40.00 40.00 50 0 0.00 0"),
    (1, "LNR"),
    (1, "0 START 0 0 1 MAIN 2 14 0 START 0 0 0 START 0 0 0 START 0 0"),
]


def frames(count: int) -> list[bytes]:
    return [encode_frame(*MIX[i % len(MIX)]) for i in range(count)]


def best(repeat: int, run: Callable[[], object]) -> float:
    """The shortest wall time of ``repeat`` runs (the least disturbed one)."""
    times = []
    for _ in range(repeat):
        gc.collect()
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


def decode_whole(buffer: bytes) -> int:
    decoder = FrameDecoder()
    decoder.feed(buffer)
    count = 0
    while decoder.next_frame() is not None:
        count += 1
    return count


def decode_per_frame(pieces: list[bytes]) -> int:
    decoder = FrameDecoder()
    count = 0
    for piece in pieces:
        decoder.feed(piece)
        while decoder.next_frame() is not None:
            count += 1
    return count


def decode_per_byte(buffer: bytes) -> int:
    decoder = FrameDecoder()
    count = 0
    for i in range(len(buffer)):
        decoder.feed(buffer[i : i + 1])
        if decoder.next_frame() is not None:
            count += 1
    return count


def decode_streaming(buffer: bytes, read_size: int = 4096) -> int:
    decoder = FrameDecoder()
    count = 0
    for i in range(0, len(buffer), read_size):
        decoder.feed(buffer[i : i + read_size])
        while decoder.next_frame() is not None:
            count += 1
    return count


def decode_keeping(buffer: bytes) -> int:
    decoder = FrameDecoder()
    decoder.feed(buffer)
    kept = []
    while (frame := decoder.next_frame()) is not None:
        kept.append(frame)
    return len(kept)


def traced_peak(run: Callable[[], object]) -> int:
    gc.collect()
    tracemalloc.start()
    try:
        run()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=100_000, help="frames per run")
    parser.add_argument("--repeat", type=int, default=3, help="runs per figure; best is shown")
    parser.add_argument(
        "--byte-frames",
        type=int,
        default=20_000,
        help="frames for the byte-by-byte run (it is the slow one)",
    )
    args = parser.parse_args()

    pieces = frames(args.frames)
    buffer = b"".join(pieces)
    size = len(buffer)
    slow = b"".join(pieces[: args.byte_frames])
    print(f"harlsync codec bench: {describe()}")
    print(f"{args.frames:,} frames, {size:,} bytes ({size / args.frames:.1f} bytes/frame)")
    print()

    rows: list[tuple[str, int, int, float]] = []  # name, frames, bytes, seconds
    mix = [MIX[i % len(MIX)] for i in range(args.frames)]
    encode_seconds = best(args.repeat, lambda: [encode_frame(*m) for m in mix])
    rows.append(("encode_frame", args.frames, size, encode_seconds))
    checks = {
        "decode, whole buffer": (args.frames, size, lambda: decode_whole(buffer)),
        "decode, one frame per feed": (args.frames, size, lambda: decode_per_frame(pieces)),
        "decode, one byte per feed": (args.byte_frames, len(slow), lambda: decode_per_byte(slow)),
    }
    for name, (count, nbytes, run) in checks.items():
        assert run() == count, f"{name}: frame count"
        rows.append((name, count, nbytes, best(args.repeat, run)))

    print(f"{'':28} {'frames/s':>10} {'MB/s':>7} {'us/frame':>9}")
    for name, count, nbytes, seconds in rows:
        print(
            f"{name:28} {count / seconds:>10,.0f} {nbytes / seconds / 1e6:>7.2f} "
            f"{seconds / count * 1e6:>9.2f}"
        )

    line_rate = 9600 / 10  # bytes/s of a 9600 8N1 line
    print(
        f"(a 9600-baud line carries {line_rate:.0f} bytes/s: "
        f"{line_rate / (size / args.frames):.0f} of these frames/s)"
    )
    print()
    print(f"tracemalloc peak, decoding {args.frames:,} frames ({size / 2**20:.1f} MiB of input):")
    for name, run in (
        ("4 KiB reads, frames dropped", lambda: decode_streaming(buffer)),
        ("whole buffer, frames dropped", lambda: decode_whole(buffer)),
        ("whole buffer, frames kept", lambda: decode_keeping(buffer)),
    ):
        peak = traced_peak(run)
        print(f"  {name:30} {peak / 2**20:>8.2f} MiB  ({peak / args.frames:.1f} bytes/frame)")
    print(f"peak RSS of this process: {peak_rss_mib():.1f} MiB")


if __name__ == "__main__":
    main()
