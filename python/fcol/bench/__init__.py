"""Benchmarks: ``python -m fcol.bench [section ...] --out bench-out``.

Each section (one module of this package, with a ``run(out_dir, quick)``
function returning table rows) runs fcol and its baselines in one process on
the same inputs, reports medians and ratios, and writes a time-against-error
plot. Speed is measured here, never in tests."""

from __future__ import annotations

import statistics
import time
from typing import Any, Callable


def median_time(fn: Callable[[], Any], repeat: int = 7, min_time: float = 0.05) -> float:
    """Median wall time of ``fn()`` in seconds over ``repeat`` runs, each
    run looping until it lasts ``min_time`` (to time fast calls)."""
    fn()  # warm up
    times = []
    for _ in range(repeat):
        n, t0 = 0, time.perf_counter()
        while True:
            fn()
            n += 1
            t = time.perf_counter() - t0
            if t >= min_time:
                break
        times.append(t / n)
    return statistics.median(times)
