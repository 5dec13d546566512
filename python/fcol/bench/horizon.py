"""Horizon maps: Stewart's Table I and Fig. 7 on this machine (time against
the number of points n at s = 64 for stewart, cms, sweep and brute, with the
fitted growth exponents), the fastest line-sampling tool that installs
(topocalc's ``horizon``, at the same number of directions) in the same run
at 1024², each timed in a fresh process with the machine's load average
beside it, the speed-up on all cores against one, peak memory, hull sizes, the spike test's share
of points that see the spike, and the sky-view factor of matplotlib's
``jacksboro_fault_dem.npz`` against topocalc's ``viewf``; and the sky
light and sun shadows of ``HorizonMap`` (Rust, per point) against their
NumPy reference on that DEM and at 1024², s = 64 (``sky_rows``; alone:
``python -m fcol.bench.horizon --sky-only``)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import fcol

S = 64


def _terrain(side: int, seed: int = 0) -> np.ndarray:
    """A fractal-ish terrain: smoothed noise at several scales (metres)."""
    rng = np.random.default_rng(seed)
    z = np.zeros((side, side))
    k = 1
    while k < side:
        coarse = rng.normal(size=(side // k + 2, side // k + 2)) * k
        z += np.kron(coarse, np.ones((k, k)))[:side, :side]
        k *= 2
    return z


def _time(fn: Any, budget: float) -> float:
    """Wall time of one call (several calls for fast ones, median)."""
    return _time_cpu(fn, budget)[0]


def _time_cpu(fn: Any, budget: float) -> tuple[float, float]:
    """Wall and CPU time (all threads of this process) of one call; fast
    calls are repeated and the medians taken."""
    walls, cpus = [], []
    while True:
        c0, t0 = time.process_time(), time.perf_counter()
        fn()
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
        if len(walls) >= 4 or walls[0] * 3 >= budget:
            return float(np.median(walls)), float(np.median(cpus))


def _topocalc() -> Any:
    try:
        import topocalc.horizon as th  # type: ignore[import-not-found,import-untyped,unused-ignore]

        return th
    except Exception:
        return None


def _topocalc_all(th: Any, z: np.ndarray, spacing: float, n: int) -> list[np.ndarray]:
    return [th.horizon(a, z, spacing) for a in np.linspace(-180, 180, num=n, endpoint=False)]


def _child(code: str, threads: int | None = None) -> dict[str, Any]:
    env = dict(os.environ)
    env["RAYON_NUM_THREADS"] = str(threads if threads is not None else os.cpu_count() or 1)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])  # type: ignore[no-any-return]


# One timed call in a fresh process: wall and CPU seconds (all threads),
# peak resident memory (VmHWM), and the 1-minute load average before and
# after (other work on the machine inflates the wall time).
CHILD = """
import json, os, time, numpy as np, fcol
from fcol.bench.horizon import _terrain, _topocalc, _topocalc_all
z = _terrain({side})
th = _topocalc() if {method!r} == "topocalc" else None
load0 = os.getloadavg()[0]
c0 = time.process_time(); t0 = time.perf_counter()
if th is not None:
    _topocalc_all(th, z, 1.0, {s})
else:
    fcol.horizon_map(z, 1.0, sectors={s}, method={method!r})
t = time.perf_counter() - t0; c = time.process_time() - c0
hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM")]
peak = int(hwm[0].split()[1]) / 1024 if hwm else float("nan")
print(json.dumps(dict(seconds=t, cpu=c, maxrss_mb=peak, load=[load0, os.getloadavg()[0]])))
"""


def _in_child(method: str, side: int, threads: int | None = None) -> dict[str, Any]:
    return _child(CHILD.format(side=side, s=S, method=method), threads)


def run(out_dir: Path, quick: bool) -> list[dict[str, Any]]:
    out_dir = Path(out_dir)
    rows: list[dict[str, Any]] = []
    # brute stops at n = 3136 (n = 1e4 takes ~20 s) and cms at n = 31684
    # (~20 s), so that the section stays near five minutes.
    sides = [32, 56, 100, 178, 316, 512, 1024] if not quick else [32, 56, 100, 178, 256]
    limits = {"brute": 56, "cms": 178 if not quick else 100, "stewart": 1024, "sweep": 1024}
    times: dict[str, list[tuple[int, float]]] = {m: [] for m in limits}
    cpus: dict[str, list[tuple[int, float]]] = {m: [] for m in limits}
    for side in sides:
        z = _terrain(side)
        n = side * side
        for m in ("sweep", "stewart", "cms", "brute"):
            if side > limits[m]:
                continue
            t, cpu = _time_cpu(lambda: fcol.horizon_map(z, 1.0, sectors=S, method=m), budget=2.0)
            times[m].append((n, t))
            cpus[m].append((n, cpu))
            rows.append({"table": "I", "n": n, "method": m, "seconds": t, "cpu_seconds": cpu, "ns_per_point_dir": t * 1e9 / (n * S)})

    def fit(pts: list[tuple[int, float]]) -> float | None:
        big = [(n, t) for n, t in pts if n >= 3000] or pts
        if len(big) < 2:
            return None
        return float(np.polyfit(np.log([p[0] for p in big]), np.log([p[1] for p in big]), 1)[0])

    fits = {}
    for m in times:
        k = fit(times[m])
        if k is not None:
            fits[m] = k
            rows.append({"table": "Fig7", "method": m, "growth_exponent": k, "growth_exponent_cpu": fit(cpus[m]), "seed": {"stewart": 1.1, "cms": 1.6, "brute": 2.0}.get(m, "")})
    # crossover stewart vs cms
    st_t, cm_t = dict(times["stewart"]), dict(times["cms"])
    common = sorted(set(st_t) & set(cm_t))
    cross = next((n for n in common if st_t[n] < cm_t[n]), None)
    rows.append({"table": "Fig7", "method": "stewart<cms from n", "growth_exponent": cross if cross is not None else "beyond range"})

    # The line-sampling tool beside stewart and sweep, each timed in a fresh
    # process (RAYON_NUM_THREADS = all cores for fcol; topocalc is one
    # thread), interleaved stewart, topocalc, stewart so that a change in
    # the machine's load shows as a spread between the two stewart runs; the
    # ratios use their mean. CPU-time ratios are less sensitive to other
    # work on the machine than wall-time ratios.
    th = _topocalc()
    side = 1024 if not quick else 256
    n = side * side
    st = [_in_child("stewart", side)]
    tc = _in_child("topocalc", side) if th is not None else None
    st.append(_in_child("stewart", side))
    sw = _in_child("sweep", side)
    t_st, c_st = (float(np.mean([r[k] for r in st])) for k in ("seconds", "cpu"))
    rec: dict[str, Any] = {
        "table": "vs-topocalc", "n": n, "directions": S, "threads": os.cpu_count(),
        "stewart_s": t_st, "stewart_s_runs": [r["seconds"] for r in st], "stewart_cpu_s": c_st,
        "sweep_s": sw["seconds"], "sweep_cpu_s": sw["cpu"],
        "stewart_peak_mb": max(r["maxrss_mb"] for r in st), "sweep_peak_mb": sw["maxrss_mb"],
        "load_1min": [round(r["load"][0], 2) for r in st[:1] + ([tc] if tc else []) + st[1:] + [sw]],
    }
    if tc is not None:
        rec.update(
            topocalc_s=tc["seconds"], topocalc_cpu_s=tc["cpu"], topocalc_peak_mb=tc["maxrss_mb"],
            topocalc_ns_per_point_dir=tc["seconds"] * 1e9 / (n * S),
            stewart_speedup=tc["seconds"] / t_st, sweep_speedup=tc["seconds"] / sw["seconds"],
            stewart_cpu_ratio=tc["cpu"] / c_st, sweep_cpu_ratio=tc["cpu"] / sw["cpu"],
        )
    else:
        rec["topocalc_s"] = "not installed"
    rows.append(rec)

    # 1 thread against all cores, CPU per point and direction (fresh
    # processes; the all-core runs are the ones above)
    for m, alln in (("sweep", sw), ("stewart", st[0])):
        one = _in_child(m, side, threads=1)
        rows.append({
            "table": "cores", "method": m, "n": n, "threads": os.cpu_count(),
            "seconds_1_thread": one["seconds"], "seconds_all": alln["seconds"],
            "speedup": one["seconds"] / alln["seconds"],
            "cpu_ns_per_point_dir_1_thread": one["cpu"] * 1e9 / (n * S),
            "cpu_ns_per_point_dir_all": alln["cpu"] * 1e9 / (n * S),
            "peak_rss_mb_1_thread": one["maxrss_mb"], "peak_rss_mb_all": alln["maxrss_mb"],
            "load_1min": round(one["load"][0], 2),
        })
    side = 512 if not quick else 256
    mean_h, max_h = fcol._fcol.horizon_hull_stats(_terrain(side), 1.0, 1.0, S, 5)
    rows.append({"table": "hulls", "n": side * side, "mean_points_per_hull": mean_h, "max_points": max_h})

    # spike test (Fig. 8): share of points whose sector holding the spike sees it
    nn = 100
    z = np.zeros((nn, nn))
    si, sj = nn - 6, 5
    z[si, sj] = 50.0
    ii, jj = np.mgrid[0:nn, 0:nn]
    az = np.mod(np.arctan2(si - ii, sj - jj), 2 * np.pi)
    sec = np.floor(az * S / (2 * np.pi)).astype(int) % S
    away = (ii != si) | (jj != sj)
    for m in ("stewart", "brute", "cms", "sweep"):
        e = fcol.horizon_map(z, 1.0, sectors=S, method=m).elevation
        seen = np.take_along_axis(e, sec[None], 0)[0][away] > 0
        rows.append({"table": "spike", "method": m, "share_seeing_spike": float(seen.mean())})

    # sky-view factor on the real DEM against topocalc.viewf
    try:
        from matplotlib.cbook import get_sample_data

        dem: Any = get_sample_data("jacksboro_fault_dem.npz")
        zdem = dem["elevation"].astype(np.float64)
        ext = (float(dem["xmin"]), float(dem["xmax"]), float(dem["ymin"]), float(dem["ymax"]))
        hm = fcol.horizon_map(zdem, extent=ext, geographic=True, earth_curvature=False, sectors=72, method="stewart")
        svf = hm.sky_view_factor()
        rec = {"table": "svf-jacksboro", "fcol_stewart_mean": float(np.nanmean(svf)), "horizon_s": hm.elapsed}
        hs = fcol.horizon_map(zdem, extent=ext, geographic=True, earth_curvature=False, sectors=72, method="sweep")
        rec["fcol_sweep_mean"] = float(np.nanmean(hs.sky_view_factor()))
        if th is not None:
            import topocalc.viewf as tv  # type: ignore[import-not-found,import-untyped,unused-ignore]

            spacing = float(np.sqrt(abs(hm.spacing[0] * hm.spacing[1])))
            t0 = time.perf_counter()
            tsvf, _ = tv.viewf(zdem, spacing, nangles=72)
            rec["topocalc_s"] = time.perf_counter() - t0
            rec["topocalc_mean"] = float(np.mean(tsvf))
            rec["mean_abs_diff_stewart"] = float(np.nanmean(np.abs(svf - tsvf)))
            rec["mean_abs_diff_sweep"] = float(np.nanmean(np.abs(hs.sky_view_factor() - tsvf)))
            rec["corr_stewart"] = float(np.corrcoef(svf.ravel(), tsvf.ravel())[0, 1])
        rows.append(rec)
    except Exception as exc:  # pragma: no cover - optional data
        rows.append({"table": "svf-jacksboro", "error": repr(exc)})

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6, 4.5))
        for m, pts in times.items():
            if pts:
                ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=f"{m} (k={fits.get(m, float('nan')):.2f})")
        ax.set_xlabel("points n")
        ax.set_ylabel("seconds (s = 64, wall, all cores)")
        ax.set_title("Horizon maps: time against terrain size (Stewart Fig. 7)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(out_dir / "horizon_fig7.png", dpi=110)
        plt.close(fig)
    except Exception:  # pragma: no cover
        pass
    rows.extend(sky_rows(quick))
    with open(out_dir / "horizon_table.json", "w") as f:
        json.dump(rows, f, indent=1, default=str)
    return rows


def _jacksboro_map(sectors: int) -> Any:
    from matplotlib.cbook import get_sample_data

    dem: Any = get_sample_data("jacksboro_fault_dem.npz")
    ext = (float(dem["xmin"]), float(dem["xmax"]), float(dem["ymin"]), float(dem["ymax"]))
    return fcol.horizon_map(dem["elevation"], extent=ext, geographic=True, sectors=sectors, method="stewart")


def sky_rows(quick: bool) -> list[dict[str, Any]]:
    """Sky light and sun shadows from one horizon map: the per-point Rust
    functions of ``HorizonMap`` against the whole-array NumPy reference
    (``fcol.testing.sky``), same map, same normals, same sky table, one
    after the other; wall seconds (median of repeats for fast calls), the
    speed-up, the largest relative difference, and the reference's peak
    NumPy memory (tracemalloc; the Rust side allocates the (H, W) result
    and O(W) per row)."""
    import tracemalloc

    from fcol import horizon as hz
    from fcol.testing import sky as ref

    cases: list[tuple[str, Any]] = []
    try:
        cases.append(("jacksboro 403x344", lambda: _jacksboro_map(S)))
    except Exception:  # pragma: no cover - matplotlib missing
        pass
    side = 512 if quick else 1024
    cases.append((f"terrain {side}x{side}", lambda: fcol.horizon_map(_terrain(side), 1.0, sectors=S, method="sweep")))
    rows: list[dict[str, Any]] = []
    for name, make in cases:
        hm = make()
        hm.normals()  # shared, computed once
        az, el, r = math.radians(220), math.radians(20), math.radians(0.27)
        table = hm.sky_table(hz.mars_sky(az, math.radians(35)))

        def svf_rust() -> Any:
            hm._svf = None  # no cache: time the computation
            return hm.sky_view_factor()

        pairs = {
            "sky_view_factor": (svf_rust, lambda: ref.sky_view_factor(hm)),
            "illumination (Mars sky table)": (lambda: hm.illumination(table), lambda: ref.illumination(hm, table)),
            "radiosity (albedo 0.4)": (lambda: hm.radiosity(table, 0.4), lambda: ref.radiosity(hm, table, 0.4)),
            "shadow, point sun": (lambda: hm.shadow(az, el), lambda: ref.shadow(hm, az, el)),
            "sun, disc 0.27 deg": (lambda: hm.sun(az, el, r), lambda: ref.sun(hm, az, el, r)),
        }
        for what, (rust, numpy_ref) in pairs.items():
            a, b = rust(), numpy_ref()
            ok = np.isfinite(b)
            rel = float(np.max(np.abs(a[ok] - b[ok]) / np.maximum(np.abs(b[ok]), 1e-12))) if ok.any() else 0.0
            t_rust = _time(rust, 2.0)
            t_np = _time(numpy_ref, 2.0)
            tracemalloc.start()
            numpy_ref()
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            rows.append({
                "table": "sky", "grid": name, "sectors": hm.sectors, "quantity": what,
                "rust_s": t_rust, "numpy_s": t_np, "speedup": t_np / t_rust,
                "max_rel_diff": rel, "numpy_peak_mb": peak / 2**20,
            })
        del hm
    return rows


if __name__ == "__main__":  # pragma: no cover
    # python -m fcol.bench.horizon [out] [--quick] [--sky-only]
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if "--sky-only" in sys.argv:
        for r in sky_rows("--quick" in sys.argv):
            print(r)
    else:
        for r in run(Path(args[0] if args else "bench-out"), "--quick" in sys.argv):
            print(r)
    _ = math
