"""Expression evaluation speed: fcol's compiled tape (f, f_u, f_v by
automatic differentiation) against NumPy (float64) evaluating the same f,
f_u, f_v written out by hand, on the 480×477 grid of the floating column
seed's Table 1 (and 1920×1080 unless ``quick``). Both run in this process,
interleaved, on the same points; the table gives medians and ratios
(fcol time / NumPy time: below 1 is faster)."""

from __future__ import annotations

import json
import statistics
from pathlib import Path
from typing import Any, Callable

import numpy as np

import fcol
from fcol import _fcol
from fcol.bench import median_time

DOM = ((-5.0, 5.0), (-5.0, 5.0))


def _numpy_cases() -> list[tuple[str, Callable[[np.ndarray, np.ndarray], tuple]]]:
    def sin_ucosv(u, v):
        c = np.cos(v)
        w = u * c
        cw = np.cos(w)
        return 3 * np.sin(w), 3 * cw * c, -3 * cw * u * np.sin(v)

    def bump(u, v):
        g = np.exp(-(u * u + v * v) / 4)
        c, s = np.cos(3 * u), np.sin(3 * u)
        f = g * c
        return f, -0.5 * u * f - 3 * g * s, -0.5 * v * f

    def ripple(u, v):
        r = np.sqrt(u * u + v * v + 1)
        c = np.cos(4 * r)
        k = -4 * np.sin(4 * r) / r
        return c, k * u, k * v

    def poly(u, v):
        return u**3 - 3 * u * v**2, 3 * u**2 - 3 * v**2, -6 * u * v

    return [
        ("3*sin(u*cos(v))", sin_ucosv),
        ("exp(-(u*u + v*v)/4)*cos(3*u)", bump),
        ("cos(4*sqrt(u*u + v*v + 1))", ripple),
        ("u**3 - 3*u*v**2", poly),
    ]


def _grid(w: int, h: int) -> tuple[np.ndarray, np.ndarray]:
    u, v = np.meshgrid(np.linspace(-5, 5, w), np.linspace(-5, 5, h))
    return u.ravel(), v.ravel()


def _torus_numpy(u, v, R=2.0, r=0.5):
    """P and its first and second derivatives of a torus, by hand."""
    cu, su, cv, sv = np.cos(u), np.sin(u), np.cos(v), np.sin(v)
    w = R + r * cv
    z = np.zeros_like(u)
    P = (w * cu, w * su, r * sv)
    Pu = (-w * su, w * cu, z)
    Pv = (-r * sv * cu, -r * sv * su, r * cv)
    Puu = (-w * cu, -w * su, z)
    Puv = (r * sv * su, -r * sv * cu, z)
    Pvv = (-r * cv * cu, -r * cv * su, -r * sv)
    return P, Pu, Pv, Puu, Puv, Pvv


def _parametric_rows(rounds: int) -> list[dict[str, Any]]:
    """Second-order parametric evaluation (what Newton trackers need): a
    torus from three expressions against NumPy."""
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 480), np.linspace(0, 2 * np.pi, 477))
    u, v = u.ravel(), v.ravel()
    n = u.size
    S = fcol.Parametric("(2 + 0.5*cos(v))*cos(u)", "(2 + 0.5*cos(v))*sin(u)", "0.5*sin(v)",
                        domain=((0, 2 * np.pi), (0, 2 * np.pi)))
    ref = _torus_numpy(u, v)
    got = S.hessian(u, v)
    err = max(np.abs(np.stack(ref[3 + k], -1) - got[k]).max() for k in range(3))
    t_np, t_b, t_p = [], [], []
    for _ in range(rounds):
        t_np.append(median_time(lambda: _torus_numpy(u, v), repeat=3) / n * 1e9)
        t_b.append(_fcol._time_parametric(S, u, v, "second", 3))
        t_p.append(_fcol._time_parametric(S, u, v, "point", 3))
    np_ns, b, p = (statistics.median(x) for x in (t_np, t_b, t_p))
    return [
        dict(expr="torus P, Pu, Pv, Puu, Puv, Pvv", size="480x477", numpy_ms=np_ns * n / 1e6,
             numpy_ns_pt=np_ns, batch_ns_pt=b, batch_ratio=b / np_ns, point_ns_pt=p,
             point_ratio=p / np_ns, rel_diff=float(err / 2.5))
    ]


def run(out_dir: Path, quick: bool) -> list[dict[str, Any]]:
    sizes = [(480, 477)] if quick else [(480, 477), (1920, 1080)]
    rounds = 3 if quick else 5
    rows: list[dict[str, Any]] = []
    for w, h in sizes:
        u, v = _grid(w, h)
        n = u.size
        for src, ref in _numpy_cases():
            f = fcol.Function(src, domain=DOM)
            # accuracy of the tape against NumPy on the same points
            rf, rfu, rfv = ref(u, v)
            gf = f(u, v)
            gu, gv = f.gradient(u, v)
            scale = max(np.abs(rf).max(), np.abs(rfu).max(), np.abs(rfv).max())
            err = max(np.abs(gf - rf).max(), np.abs(gu - rfu).max(), np.abs(gv - rfv).max()) / scale
            t_np, t_b, t_p, t_v = [], [], [], []
            for _ in range(rounds):  # interleaved rounds, medians of medians
                t_np.append(median_time(lambda: ref(u, v), repeat=3) / n * 1e9)
                t_b.append(_fcol._time_height(f, u, v, "batch", 3))
                t_p.append(_fcol._time_height(f, u, v, "point", 3))
                t_v.append(_fcol._time_height(f, u, v, "value", 3))
            np_ns = statistics.median(t_np)
            b, p, val = statistics.median(t_b), statistics.median(t_p), statistics.median(t_v)
            rows.append(
                dict(
                    expr=src,
                    size=f"{w}x{h}",
                    numpy_ms=np_ns * n / 1e6,
                    numpy_ns_pt=np_ns,
                    batch_ns_pt=b,
                    batch_ratio=b / np_ns,
                    point_ns_pt=p,
                    point_ratio=p / np_ns,
                    value_ns_pt=val,
                    rel_diff=float(err),
                )
            )
        if (w, h) == (480, 477):
            # a NumPy-vectorised Python callable through the same path
            # (central differences: one call on 5n points per batch)
            fn = fcol.Function(lambda uu, vv: 3 * np.sin(uu * np.cos(vv)), domain=DOM)
            sin_ref = _numpy_cases()[0][1]
            t_np = median_time(lambda: sin_ref(u, v), repeat=3) / n * 1e9
            t_c = _fcol._time_height(fn, u, v, "batch", 3)
            rows.append(
                dict(expr="callable 3*sin(u*cos(v)), central differences", size=f"{w}x{h}",
                     numpy_ms=t_np * n / 1e6, numpy_ns_pt=t_np, batch_ns_pt=t_c, batch_ratio=t_c / t_np)
            )
    rows.extend(_parametric_rows(rounds))
    (out_dir / "expr.json").write_text(json.dumps(rows, indent=1))
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        sel = [r for r in rows if r["size"] == "480x477" and "value_ns_pt" in r]
        fig, ax = plt.subplots(figsize=(8, 3.5))
        x = np.arange(len(sel))
        for k, (key, label) in enumerate(
            [("numpy_ns_pt", "NumPy f, f_u, f_v"), ("batch_ns_pt", "fcol batch"),
             ("point_ns_pt", "fcol one point"), ("value_ns_pt", "fcol f only")]
        ):
            ax.bar(x + 0.2 * k - 0.3, [r[key] for r in sel], 0.2, label=label)
        ax.set_xticks(x, [r["expr"] for r in sel], fontsize=7)
        ax.set_ylabel("ns per point")
        ax.set_title("Evaluating f, f_u, f_v at 480×477 points (one thread)")
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out_dir / "expr.png", dpi=110)
        plt.close(fig)
    except ImportError:
        pass
    return rows
