"""Ctrl-C: every long call stops soon after a real SIGINT and leaves its
inputs usable.

Each case runs in a fresh interpreter, which is sent SIGINT once the long
call is under way (the child says when), as a terminal's Ctrl-C would be.
The child reports whether the call raised KeyboardInterrupt and how long
after the signal it returned."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import textwrap
import time

import pytest

PRELUDE = """
import json, sys, time, _thread
import numpy as np
import fcol

def started():
    print("started", flush=True)

# Say "started", run the long call, report whether it raised
# KeyboardInterrupt, when it returned, and what after() finds then.
def attempt(call, after=None):
    started()
    out = {"raised": False}
    try:
        call()
    except KeyboardInterrupt:
        out["raised"] = True
    out["returned"] = time.time()
    if out["raised"] and after is not None:
        out.update(after())
    print(json.dumps(out), flush=True)
"""


def interrupt(body: str, delay: float = 0.3, timeout: float = 300.0) -> tuple[dict, float]:
    """Run PRELUDE + body in a child; send SIGINT `delay` seconds after it
    prints "started"; return the child's JSON report and the time of the
    signal."""
    code = PRELUDE + textwrap.dedent(body)
    child = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert child.stdout is not None
    line = child.stdout.readline()
    assert line.strip() == "started", line + child.stderr.read()
    time.sleep(delay)
    sent = time.time()
    child.send_signal(signal.SIGINT)
    out, err = child.communicate(timeout=timeout)
    assert child.returncode == 0, err
    return json.loads(out.strip().splitlines()[-1]), sent


def _check(report: dict, sent: float) -> None:
    assert report["raised"], "the call ran to its end: SIGINT was ignored"
    assert report["returned"] - sent < 1.5  # honoured within about a second


def test_floating_column_with_a_slow_callable():
    report, sent = interrupt("""
        def f(u, v):
            time.sleep(2e-3)  # a slow surface: the render would take minutes
            return np.sin(u) * np.cos(v)
        surf = fcol.Function(f, domain=((-3, 3), (-3, 3)))
        attempt(lambda: fcol.render(surf, fcol.View(30, 40, view_height=8.0), 320, 240, outputs=("depth",)))
    """)
    _check(report, sent)


def test_parametric_scanline_with_a_slow_callable():
    report, sent = interrupt("""
        def x(u, v):
            time.sleep(2e-4)
            return np.cos(v) * np.cos(u)
        surf = fcol.Parametric(x, lambda u, v: np.cos(v) * np.sin(u), lambda u, v: np.sin(v),
                               domain=((0, 2 * np.pi), (-np.pi / 2, np.pi / 2)))
        attempt(lambda: fcol.render(surf, fcol.View(30, 20, view_height=2.6), 400, 300, outputs=("mask",)))
    """)
    _check(report, sent)


def test_a_callable_surface_renders_again_after_ctrl_c():
    """The interrupt does not leave the surface marked as failed: the next
    render of the same object equals the render of a fresh one."""
    report, sent = interrupt("""
        f = lambda u, v: np.sin(u) * np.cos(v)
        surf = fcol.Function(lambda u, v: (time.sleep(1e-3), f(u, v))[1], domain=((-3, 3), (-3, 3)))
        view = fcol.View(30, 40, view_height=8.0)

        def after():
            again = fcol.render(surf, view, 96, 64, outputs=("depth",)).depth
            fresh = fcol.render(fcol.Function(f, domain=((-3, 3), (-3, 3))), view, 96, 64, outputs=("depth",)).depth
            return {"same": bool(np.array_equal(again, fresh, equal_nan=True)), "finite": int(np.isfinite(again).sum())}

        attempt(lambda: fcol.render(surf, view, 320, 240, outputs=("depth",)), after)
    """)
    _check(report, sent)
    assert report["same"]
    assert report["finite"] > 1000


def test_horizon_map():
    report, sent = interrupt("""
        z = np.random.default_rng(1).random((200, 200)).cumsum(0)
        attempt(lambda: fcol.horizon_map(z, spacing=(1, 1), sectors=64, method="brute"))
    """)
    _check(report, sent)


def test_sky_integrals():
    report, sent = interrupt("""
        from fcol import horizon as hz
        s, n = 64, 512
        el = np.random.default_rng(0).random((s, n, n)).astype(np.float32)
        m = hz.HorizonMap(el, range(s), s, np.zeros((n, n)), (1.0, 1.0), "given", 0.0)
        m.normals()
        sky = hz.mars_sky(1.0, 0.4)
        attempt(lambda: [m.radiosity(sky, albedo=0.3) for _ in range(20)])
    """, delay=1.0)
    _check(report, sent)
