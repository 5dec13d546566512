"""Benchmarks: ``python -m fcol.bench [section ...] --out bench-out``.

Each section (one module of this package, with a ``run(out_dir, quick)``
function returning table rows) runs fcol and its baselines in one process on
the same inputs, reports medians and ratios, and writes a time-against-error
plot. Speed is measured here, never in tests."""

from __future__ import annotations

import contextlib
import statistics
import time
from typing import Any, Callable, Iterator


@contextlib.contextmanager
def quiet_blas() -> Iterator[str]:
    """NumPy's BLAS limited to one thread while timing (yields a line that
    says whether it could be). OpenBLAS's worker threads busy-wait for a
    while after each matrix product (about 0.1-0.2 s here) and take the
    cores a multi-threaded method is timed on: a render right after a
    product can take twice as long. The limit (threadpoolctl) makes the
    workers sleep, for every method timed alike; the baselines' own BLAS
    calls are small products (a depth per hit), single-threaded as fast."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        yield "BLAS threads not limited (threadpoolctl not installed): timings may vary after matrix products"
        return
    with threadpool_limits(limits=1, user_api="blas"):
        yield "BLAS limited to one thread while timing (threadpoolctl)"


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
