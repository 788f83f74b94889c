"""Benchmarks: each compares against the alternatives in the same run and
writes JSON and a chart under docs/bench/ (see `argand bench --help`)."""

from __future__ import annotations

import os
import platform
import time
from datetime import datetime, timezone


def machine_info() -> dict:
    return {
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        # Other work on the machine skews absolute times (ratios less so).
        "load_average_1_5_15_min": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }


def median_time(fn, repeats: int) -> float:
    """Median wall time of fn() over `repeats` runs (seconds), after one
    untimed warm-up run (first-touch page faults, caches)."""
    fn()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    times.sort()
    return times[len(times) // 2]
