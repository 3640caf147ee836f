"""What the bench scripts print first: when, on what, with which Python."""

from __future__ import annotations

import os
import platform
import resource
from datetime import datetime


def describe() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as info:
            cpu = next(
                line.split(":", 1)[1].strip() for line in info if line.startswith("model name")
            )
    except (OSError, StopIteration):
        pass
    return (
        f"{datetime.now():%Y-%m-%d %H:%M}, {platform.system()} {platform.release()}, "
        f"{os.cpu_count()} cores ({cpu}), Python {platform.python_version()}"
    )


def peak_rss_mib() -> float:
    """This process's peak resident set size so far, in MiB (Linux reports KiB)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / (1024 * 1024 if platform.system() == "Darwin" else 1024)
