"""Timing helpers for the benchmarks: medians over many runs, and the machine they ran on."""

from __future__ import annotations

import os
import platform
import time
from typing import Callable

import numpy as np


def median_us(fn: Callable[[], object], runs: int = 2000, warmup: int = 100) -> float:
    """Median wall time of ``fn()`` [µs] over ``runs`` calls after ``warmup`` calls."""
    for _ in range(warmup):
        fn()
    samples = np.empty(runs)
    clock = time.perf_counter_ns
    for i in range(runs):
        start = clock()
        fn()
        samples[i] = clock() - start
    return float(np.median(samples) / 1e3)


def machine_description() -> str:
    """One line: CPU model, core count, Python and numpy versions."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return (
        f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, "
        f"numpy {np.__version__}, {platform.system()} {platform.release()}"
    )
