"""Ctrl-C: every long call stops soon after the interrupt and leaves its
inputs usable. The interrupt is raised at a known point of the call (from
inside a Python callable or a progress callback, as a user's Ctrl-C may land
there), so the tests do not depend on when another thread is scheduled."""

from __future__ import annotations

import _thread
import time

import numpy as np
import pytest

import fcol


def _interrupting(after_calls: int, fired: list[float], slow: float):
    calls = [0]

    def f(u, v):
        calls[0] += 1
        if not fired and calls[0] > after_calls:
            fired.append(time.perf_counter())
            _thread.interrupt_main()
        time.sleep(slow)
        return np.sin(u) * np.cos(v)

    return f


def test_floating_column_with_a_slow_callable_stops_on_ctrl_c():
    fired: list[float] = []
    surf = fcol.Function(_interrupting(20, fired, 2e-3), domain=((-3, 3), (-3, 3)))
    view = fcol.View(30, 40, view_height=8.0)
    with pytest.raises(KeyboardInterrupt):
        fcol.render(surf, view, 320, 240, outputs=("depth",))
    assert fired, "the render ended before the interrupt was raised"
    assert time.perf_counter() - fired[0] < 1.5  # within about a second


def test_a_callable_surface_renders_again_after_ctrl_c():
    """The interrupt does not leave the surface marked as failed: the next
    render of the same object equals the render of a fresh one."""
    fired: list[float] = []
    f = _interrupting(5, fired, 0.0)
    surf = fcol.Function(f, domain=((-3, 3), (-3, 3)))
    view = fcol.View(30, 40, view_height=8.0)
    with pytest.raises(KeyboardInterrupt):
        # long enough that the main thread sees the interrupt before the end
        for _ in range(200):
            fcol.render(surf, view, 96, 64, outputs=("depth",))
    again = fcol.render(surf, view, 96, 64, outputs=("depth",))
    fresh = fcol.render(fcol.Function(lambda u, v: np.sin(u) * np.cos(v), domain=((-3, 3), (-3, 3))),
                        view, 96, 64, outputs=("depth",))
    np.testing.assert_array_equal(again.depth, fresh.depth)
    assert np.isfinite(again.depth).sum() > 1000


def test_horizon_map_stops_on_ctrl_c():
    fired: list[float] = []

    def progress(done: int, total: int) -> None:
        if not fired and done > 0:
            fired.append(time.perf_counter())
            _thread.interrupt_main()

    z = np.random.default_rng(1).random((160, 160)).cumsum(0)
    with pytest.raises(KeyboardInterrupt):
        fcol.horizon_map(z, spacing=(1, 1), sectors=64, method="brute", progress=progress)
    assert fired, "the computation ended before the interrupt was raised"
    assert time.perf_counter() - fired[0] < 1.5
