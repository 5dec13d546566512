"""Floating horizon and floating column (Gordon 2001) on 3 sin(u cos v) over
[-5, 5]²: time against error, beside a mesh approach (trimesh + embreex on
grid meshes of increasing resolution, two ways), matplotlib's ``plot_surface`` drawn
to an array, and the floor (NumPy evaluating f, f_u, f_v once per pixel).

Rows: every column variant (the default: a sweep with samples up to 3
pixels apart and every pixel solved on its ray; the dense sweep of the
seed's step; shadings, corrections on and off) and the
floating horizon at 480×477 and 1920×1080 with ``x_floor`` (time / NumPy
floor); the mesh at 50² … 800² with its errors, both through trimesh's API
(its vertex normals, the hit re-intersected in float64) and lean (embreex
called directly, its own barycentrics and distances, vertex normals from
the exact gradient: faster and more accurate, the baseline to beat), ``mesh_over_fcol`` (cast
only, mesh prebuilt) and ``mesh_new_over_fcol`` (tessellate + build + cast:
a new function) against the default column; the default column with 1 and
2 rayon workers (``RAYON_NUM_THREADS`` in child processes); nanoseconds per
pixel at both sizes; the seed's Table 1 sample counts beside ours; the §6.4
anti-aliasing variants (``antialias=4``, ``coverage``, both) beside the
plain rgb render (``x_plain``); a 1024² terrain seen from a low eye with and
without the height bound's early exit (``speedup``, pictures identical);
the speed targets as medians of ratios taken round by round (``target``,
``median``, ``low``, ``high``, ``met``), the mesh ones against the lean
mesh at 800² and 3200² (prebuilt; 3200², 20 M triangles, takes about
17 s and 3.4 GB to build, and its normals are still 8-50× less accurate
than the column's: ``error``).

Every other timing runs in this one process, on the same inputs, one after
the other; the ratios are what to read (the machines are shared and noisy).
Errors are against ``fcol.testing.reference`` (the exact first hit)."""

from __future__ import annotations

import functools
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

import fcol
from fcol.bench import median_time

EXPR = "3*sin(u*cos(v))"
DOMAIN = ((-5.0, 5.0), (-5.0, 5.0))

# Gordon 2001, Table 1 (480 × 477): samples per figure.
SEED_SAMPLES = {
    "7 line, perspective": 25281,
    "8 iis, no corrections": 25281,
    "9 iis, supersampling": 86957,
    "10 nis, spline corrections": 25281,
    "11 nis, supersampling": 61149,
    "12 line, perspective": 61533,
    "13 iis, no corrections": 61533,
    "14 iis, supersampling": 289575,
}


def f_np(u, v):
    return 3 * np.sin(u * np.cos(v))


def grad_np(u, v):
    c = 3 * np.cos(u * np.cos(v))
    return c * np.cos(v), -c * u * np.sin(v)


def views() -> dict[str, Any]:
    return {
        "ortho": fcol.View(30, 30, view_height=13.0),
        "persp": fcol.View(30, 40, "perspective", distance=24.0, fov=40.0),
    }


@functools.lru_cache(maxsize=4)
def bench_reference(vname: str, w: int, h: int):
    """The exact reference of bench view ``vname`` at w × h, built once per
    process (the bench's rows, its target rows and its correction rows
    share it)."""
    from fcol.testing.reference import height_reference

    return height_reference(f_np, grad_np, DOMAIN, views()[vname], w, h)


# ---------------------------------------------------------------- baselines


def grid_mesh(n: int):
    (u0, u1), (v0, v1) = DOMAIN
    u = np.linspace(u0, u1, n)
    v = np.linspace(v0, v1, n)
    U, V = np.meshgrid(u, v)
    verts = np.column_stack([U.ravel(), V.ravel(), f_np(U, V).ravel()])
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    faces = np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])
    return verts, faces


def _mesh_rays(view, W: int, H: int, verts) -> tuple[np.ndarray, np.ndarray]:
    """The view's rays, (W·H, 3) each; orthographic rays are whole lines,
    started well behind the mesh's bounding box (embree casts forward
    only)."""
    O, D = view.rays(W, H)
    O = O.reshape(-1, 3)
    D = D.reshape(-1, 3)
    if view.eye is None:
        O = O - (4.0 * float(np.abs(verts).max()) + 1.0) * D
    return O, D


def _mesh_result(view, W: int, H: int, hit, P, n):
    """The cast's buffers from its hit points P and unit normals n (rows
    of the hit rays)."""
    dvec = np.asarray(view.basis()[0])
    origin = np.asarray(view.eye if view.eye is not None else view.target)
    depth = np.full(W * H, np.nan)
    depth[hit] = (P - origin) @ dvec
    normal = np.full((W * H, 3), np.nan)
    normal[hit] = n
    return SimpleNamespace(mask=hit.reshape(H, W), depth=depth.reshape(H, W), normal=normal.reshape(H, W, 3))


class MeshCaster:
    """Tessellate, build, ray-cast with trimesh + embreex, interpolate the
    mesh's vertex normals: what users do today."""

    def __init__(self, n: int):
        import trimesh
        from trimesh.ray.ray_pyembree import RayMeshIntersector

        self.verts, self.faces = grid_mesh(n)
        self.mesh = trimesh.Trimesh(vertices=self.verts, faces=self.faces, process=False)
        self.vn = np.asarray(self.mesh.vertex_normals)
        self.isect = RayMeshIntersector(self.mesh)

    def cast(self, view, W: int, H: int):
        O, D = _mesh_rays(view, W, H, self.verts)
        tri = np.asarray(self.isect.intersects_first(O, D), np.int64)
        hit = tri >= 0
        t = self.faces[tri[hit]]
        a, b, c = self.verts[t[:, 0]], self.verts[t[:, 1]], self.verts[t[:, 2]]
        e1, e2 = b - a, c - a
        d = D[hit]
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        q = O[hit] - a
        qq = np.cross(q, e1)
        with np.errstate(divide="ignore", invalid="ignore"):
            bu = np.einsum("ij,ij->i", q, p) / det
            bv = np.einsum("ij,ij->i", d, qq) / det
            s = np.einsum("ij,ij->i", e2, qq) / det
        P = O[hit] + s[:, None] * d
        n = (1 - bu - bv)[:, None] * self.vn[t[:, 0]] + bu[:, None] * self.vn[t[:, 1]] + bv[:, None] * self.vn[t[:, 2]]
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        n *= np.sign(n[:, 2:3] + 1e-300)  # upper-side normal
        return _mesh_result(view, W, H, hit, P, n)


class LeanMeshCaster:
    """The mesh approach without the conveniences' cost: the grid's vertex
    normals from the exact gradient (what one does for a known function,
    and more accurate than the mesh's own), embreex called directly (its
    float32 scene and its own barycentrics and distances: no second
    intersection in NumPy). The strongest mesh baseline we know to write."""

    def __init__(self, n: int):
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        self.verts, self.faces = grid_mesh(n)
        fu, fv = grad_np(self.verts[:, 0], self.verts[:, 1])
        vn = np.column_stack([-fu, -fv, np.ones_like(fu)])
        self.vn = vn / np.linalg.norm(vn, axis=1, keepdims=True)
        # Offset to the box's corner: float32 keeps relative precision there.
        self.origin = self.verts.min(axis=0)
        self.scene = rtcore_scene.EmbreeScene()
        TriangleMesh(scene=self.scene, vertices=(self.verts - self.origin).astype(np.float32),
                     indices=self.faces.astype(np.int32))

    def cast(self, view, W: int, H: int):
        O, D = _mesh_rays(view, W, H, self.verts)
        r = self.scene.run((O - self.origin).astype(np.float32), D.astype(np.float32), output=1)
        tri = np.asarray(r["primID"], np.int64)
        hit = tri >= 0
        t = self.faces[tri[hit]]
        bu = np.asarray(r["u"])[hit, None]
        bv = np.asarray(r["v"])[hit, None]
        n = (1 - bu - bv) * self.vn[t[:, 0]] + bu * self.vn[t[:, 1]] + bv * self.vn[t[:, 2]]
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        P = O[hit] + np.asarray(r["tfar"], np.float64)[hit, None] * D[hit]
        return _mesh_result(view, W, H, hit, P, n)


# The two mesh baselines: trimesh's own API (its vertex normals, a
# float64 re-intersection of the hit triangle), and the lean one.
MESHES = {
    "trimesh+embreex": MeshCaster,
    "embreex direct, exact vertex normals": LeanMeshCaster,
}


def target_rows(surf, sizes, rounds: int, mesh_ns: tuple[int, ...]) -> list[dict]:
    """The speed targets as ratios taken round by round, each round
    timing the default column beside what it is compared with (one after
    the other, so that the machine's drifts cancel): time / NumPy floor at
    each size, and at 480 × 477 each mesh baseline's cast and build + cast
    over the column (``MESHES``: trimesh + embreex as users call it, the
    targets' baseline, and the lean cast, the strongest we know to write),
    for each mesh resolution of ``mesh_ns`` (n² vertices; each mesh built
    once, its build timed once). Every mesh here has normals far less
    accurate than the column's (the row says how much: its median and
    99th-percentile normal error against the exact reference beside the
    column's), so each ratio is a lower bound of the ratio at equal error;
    the finest mesh gives the tightest bound. Median and range over the
    rounds."""
    from fcol.testing.reference import compare

    outs = ("rgb", "depth", "normal", "mask")
    vs = views()
    got: dict[tuple, list[float]] = {}
    note: dict[tuple, str] = {}
    for _ in range(rounds):
        for (w, h) in sizes:
            fl = numpy_floor(w, h)
            for vname, view in vs.items():
                t = median_time(lambda: fcol.render(surf, view, w, h, outputs=outs), repeat=5)
                got.setdefault(("x_floor", "", 0, vname, w, h), []).append(t / fl)
    w, h = sizes[0]
    col_err = {}
    for vname, view in vs.items():
        ref = bench_reference(vname, w, h)
        res = compare(fcol.render(surf, view, w, h, outputs=outs), ref, view)
        col_err[vname] = (ref, res["normal_deg_median"], res["normal_deg_p99"])
    for kind, caster in MESHES.items():
        for n in mesh_ns:
            t0 = time.perf_counter()
            mc = caster(n)
            t_build = time.perf_counter() - t0
            for vname, view in vs.items():
                ref, c_med, c_p99 = col_err[vname]
                t0 = time.perf_counter()
                res = compare(mc.cast(view, w, h), ref, view)
                t_first = time.perf_counter() - t0
                note[(kind, n, vname)] = (
                    f"mesh normals {res['normal_deg_median']:.2g}° / {res['normal_deg_p99']:.2g}° "
                    f"(median / p99) against the column's {c_med:.2g}° / {c_p99:.2g}°")
                for _ in range(rounds):
                    t_cast = median_time(lambda: mc.cast(view, w, h), repeat=3)
                    t = median_time(lambda: fcol.render(surf, view, w, h, outputs=outs), repeat=5)
                    got.setdefault(("mesh_over_fcol", kind, n, vname, w, h), []).append(t_cast / t)
                    got.setdefault(("mesh_new_over_fcol", kind, n, vname, w, h), []).append(
                        (t_build + t_first) / t)
            del mc
    goals = {"x_floor": ("<=", 0.5), "mesh_over_fcol": (">=", 10.0), "mesh_new_over_fcol": (">=", 20.0)}
    names = {"x_floor": "column default / NumPy floor",
             "mesh_over_fcol": "{kind} {n}² cast / column default",
             "mesh_new_over_fcol": "{kind} {n}² build + cast / column default"}
    rows = []
    for (what, kind, n, vname, w, h), v in got.items():
        med = float(np.median(v))
        op, goal = goals[what]
        rows.append(dict(method=f"target: {names[what].format(kind=kind, n=n)} ({rounds} rounds)",
                         view=vname, size=f"{w}x{h}", target=f"{op} {goal:g}", median=med,
                         low=float(min(v)), high=float(max(v)),
                         met=med <= goal if op == "<=" else med >= goal,
                         error=note.get((kind, n, vname), "")))
    return rows


def matplotlib_plot(n: int, W: int, H: int) -> np.ndarray:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    (u0, u1), (v0, v1) = DOMAIN
    u = np.linspace(u0, u1, n)
    U, V = np.meshgrid(u, np.linspace(v0, v1, n))
    fig = plt.figure(figsize=(W / 100, H / 100), dpi=100)
    ax = fig.add_axes((0, 0, 1, 1), projection="3d")
    ax.plot_surface(U, V, f_np(U, V), rstride=1, cstride=1, linewidth=0, antialiased=False, shade=True)
    ax.view_init(30, -60)
    ax.set_axis_off()
    fig.canvas.draw()
    a = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
    plt.close(fig)
    return a


def numpy_floor(W: int, H: int) -> float:
    """NumPy float64 evaluating f, f_u, f_v once per output pixel, as fast
    as NumPy goes: each transcendental once (cos v, sin v, sin a, cos a),
    every result written into arrays allocated once (``out=``). With
    temporaries instead, the time depends on the allocator's state: fresh
    pages for each temporary cost up to 1.4× as much, and that state
    varies with what the process did before."""
    n = W * H
    u = np.random.default_rng(0).uniform(-5, 5, n)
    v = np.random.default_rng(1).uniform(-5, 5, n)
    cv, sv, a, f, c, fu, fv = (np.empty(n) for _ in range(7))

    def run():
        np.cos(v, out=cv)
        np.sin(v, out=sv)
        np.multiply(u, cv, out=a)
        np.sin(a, out=f)
        np.multiply(f, 3.0, out=f)
        np.cos(a, out=c)
        np.multiply(c, 3.0, out=c)
        np.multiply(c, cv, out=fu)
        np.multiply(c, u, out=fv)
        np.multiply(fv, sv, out=fv)
        np.negative(fv, out=fv)
        return f, fu, fv

    return median_time(run, repeat=5)


# ---------------------------------------------------------------- fcol runs

VARIANTS = {
    "column default (exact, normal)": dict(),
    "column exact, dense sweep (step 1, max_step 2)": dict(step=1.0, max_step=2.0),
    "column nis (Phong, no refine)": dict(shading="normal", refine=False),
    "column iis (Gouraud, no refine)": dict(shading="intensity", refine=False),
    "column iis + ridges/bumps supersample": dict(shading="intensity", refine=False, ridges=True, bumps=True, jumps=True),
    "column nis + ridges spline": dict(shading="normal", refine=False, ridges=True, correction="spline"),
    "column iis step 8 (seed-like)": dict(shading="intensity", refine=False, step=8.0, max_step=8.0),
    "column iis step 8 + supersample": dict(shading="intensity", refine=False, step=8.0, max_step=8.0, ridges=True, bumps=True, jumps=True),
}


CHILD = """
import json, fcol
from fcol.bench import median_time
from fcol.bench.floating import EXPR, DOMAIN, views
surf = fcol.Function(EXPR, domain=DOMAIN)
view = views()[{view!r}]
outs = ("rgb", "depth", "normal", "mask")
t = median_time(lambda: fcol.render(surf, view, {w}, {h}, outputs=outs), repeat={repeat})
print(json.dumps(dict(seconds=t)))
"""


def _child_time(view: str, w: int, h: int, threads: int, repeat: int) -> float:
    """Median time of the default floating column in a child process whose
    rayon pool has ``threads`` workers (RAYON_NUM_THREADS)."""
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    code = CHILD.format(view=view, w=w, h=h, repeat=repeat)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    return float(json.loads(out.strip().splitlines()[-1])["seconds"])


AA_VARIANTS = {
    "column rgb, antialias=4": dict(antialias=4),
    "column rgb, coverage": dict(coverage=True),
    "column rgb, antialias=4 + coverage": dict(antialias=4, coverage=True),
}


def aa_timings(surf, view, vname: str, w: int, h: int, repeat: int) -> list[dict]:
    """The §6.4 anti-aliasing variants (rgb only) and the plain rgb render,
    timed one after the other; ``x_plain`` = time / plain time. ``coverage``
    is orthographic only (perspective rows are skipped)."""
    persp = view.projection == "perspective"
    plain = median_time(lambda: fcol.render(surf, view, w, h), repeat=repeat)
    rows = [dict(method="column rgb, plain", view=vname, size=f"{w}x{h}", ms=1e3 * plain, x_plain=1.0)]
    for label, opts in AA_VARIANTS.items():
        if persp and opts.get("coverage"):
            continue
        t = median_time(lambda: fcol.render(surf, view, w, h, **opts), repeat=repeat)
        rows.append(dict(method=label, view=vname, size=f"{w}x{h}", ms=1e3 * t, x_plain=t / plain))
    return rows


def fractal_dem(n: int = 1024, seed: int = 3, relief: float = 600.0) -> np.ndarray:
    """A synthetic terrain: random-phase noise with a power-law spectrum
    (|k|^-2.2, like real relief), scaled to 0 … ``relief``."""
    rng = np.random.default_rng(seed)
    k2 = np.fft.fftfreq(n)[:, None] ** 2 + np.fft.fftfreq(n)[None, :] ** 2
    k2[0, 0] = 1.0
    spec = (rng.normal(size=(n, n)) + 1j * rng.normal(size=(n, n))) * k2**-1.1
    spec[0, 0] = 0.0
    z = np.real(np.fft.ifft2(spec))
    return relief * (z - z.min()) / (z.max() - z.min())


def landscape_rows(repeat: int) -> list[dict]:
    """A 1024² terrain over 10 km seen in perspective (960 × 540) from 40 m
    above its southern edge, looking north: the perspective sweeps with the
    height bound's early exit (a grid's block maxima along each plane) and
    without it, timed alternately; the pictures must be identical."""
    import math

    z = fractal_dem()
    g = fcol.HeightGrid(z, extent=(0, 10000, 0, 10000))
    u0, v0 = 5000.0, 300.0
    ez = float(z[round(v0 / 10000 * 1023), round(u0 / 10000 * 1023)]) + 40.0
    rows = []
    outs = ("rgb", "depth", "normal", "mask")
    for el in (1.0, 3.0):
        d = 2000.0
        target = (u0, v0 + d * math.cos(math.radians(el)), ez - d * math.sin(math.radians(el)))
        view = fcol.View(el, 0.0, "perspective", distance=d, fov=50.0, target=target)
        a = fcol.render(g, view, 960, 540, outputs=outs)
        b = fcol.render(g, view, 960, 540, outputs=outs, height_bound=False)
        same = all(np.array_equal(getattr(a, k), getattr(b, k), equal_nan=True) for k in outs)
        ta, tb = [], []
        for _ in range(repeat):
            for hb, acc in ((True, ta), (False, tb)):
                t0 = time.perf_counter()
                fcol.render(g, view, 960, 540, outputs=outs, height_bound=hb)
                acc.append(time.perf_counter() - t0)
        for hb, img, t in ((True, a, ta), (False, b, tb)):
            rows.append(dict(method=f"landscape 1024² DEM, eye 40 m up, elevation {el:g}°, height_bound={hb}",
                             size="960x540", ms=1e3 * float(np.median(t)),
                             sweep_samples=int(img.stats["sweep_samples"]),
                             early_exits=int(img.stats["early_exits"]), identical=same,
                             speedup=float(np.median(np.array(tb) / np.array(ta))) if hb else None))
    return rows


# The §5 corrections at the seed's sampling (its artifacts need it).
SEEDLIKE = dict(step=8.0, max_step=8.0, refine=False, specular=0.0)
CORRECTIONS = {
    "ridges, supersample": dict(ridges=True, rate=16),
    "ridges, spline": dict(ridges=True, correction="spline"),
    "jumps, supersample": dict(jumps=True, rate=16),
    "bumps, supersample": dict(bumps=True, rate=16),
    "bumps, spline": dict(bumps=True, correction="spline"),
    "all three, supersample": dict(ridges=True, jumps=True, bumps=True, rate=16),
}


def correction_rows(surf, w: int, h: int) -> list[dict]:
    """Each §5 correction against the exact hit, on the pixels it changes
    (``fcol.testing.reference.correction_effect``): the shading error
    without and with it under each shading, the crest's geometry (mask
    differences, worst depth error), and the samples taken, on the bench
    views with the seed's sampling (samples up to 8 pixels apart, no exact
    solve)."""
    from fcol.testing.reference import correction_effect

    outs = ("intensity", "depth", "mask")
    rows = []
    for vname, view in views().items():
        ref = bench_reference(vname, w, h)
        for shading in ("intensity", "normal"):
            base = fcol.render(surf, view, w, h, outputs=outs, shading=shading, **SEEDLIKE)
            for name, kw in CORRECTIONS.items():
                fixed = fcol.render(surf, view, w, h, outputs=outs, shading=shading, **SEEDLIKE, **kw)
                e = correction_effect(base, fixed, ref, view)
                rows.append(dict(method=f"correction {name}, {shading} shading, step 8", view=vname,
                                 size=f"{w}x{h}", samples=fixed.samples, samples_without=base.samples,
                                 changed_px=e["changed"],
                                 inten_mean_without=e["intensity_mean_before"],
                                 inten_mean_with=e["intensity_mean_after"],
                                 inten_p99_without=e["intensity_p99_before"],
                                 inten_p99_with=e["intensity_p99_after"],
                                 mask_diff_without=e["mask_diff_before"], mask_diff_with=e["mask_diff_after"],
                                 depth_max_without=e["depth_max_before"], depth_max_with=e["depth_max_after"]))
    return rows


def run(out_dir: Path, quick: bool) -> list[dict]:
    from fcol.testing.reference import compare

    surf = fcol.Function(EXPR, domain=DOMAIN)
    rows: list[dict] = []
    plot: list[tuple[str, float, float]] = []
    W, H = 480, 477
    repeat = 3 if quick else 5
    sizes = [(W, H)] if quick else [(W, H), (1920, 1080)]
    outs = ("rgb", "depth", "normal", "mask")
    floor: dict[tuple[int, int], float] = {}
    default: dict[tuple[str, int, int], float] = {}
    normal_p99: dict[str, float] = {}
    for (w, h) in sizes:
        floor[(w, h)] = numpy_floor(w, h)
        rows.append(dict(method="numpy floor (f, f_u, f_v per pixel)", size=f"{w}x{h}", ms=1e3 * floor[(w, h)]))
        for vname, view in views().items():
            ref = None
            if (w, h) == (W, H):
                t0 = time.perf_counter()
                ref = bench_reference(vname, w, h)
                rows.append(dict(method="reference (exact hit)", view=vname, size=f"{w}x{h}",
                                 ms=1e3 * (time.perf_counter() - t0)))
            for label, opts in VARIANTS.items():
                img = fcol.render(surf, view, w, h, outputs=outs, **opts)
                t = median_time(lambda: fcol.render(surf, view, w, h, outputs=outs, **opts), repeat=repeat)
                row = dict(method=label, view=vname, size=f"{w}x{h}", ms=1e3 * t, samples=img.samples,
                           sweep_samples=int(img.stats["sweep_samples"]), x_floor=t / floor[(w, h)])
                if ref is not None:
                    res = compare(img, ref, view)
                    row.update(mask_bad=res.get("mask_bad"), depth_p99=res.get("depth_px_p99"),
                               normal_med=res.get("normal_deg_median"), normal_p99=res.get("normal_deg_p99"),
                               ssim=res.get("ssim"))
                    plot.append((f"fcol {label} ({vname})", t, res.get("normal_deg_p99", np.nan)))
                    if not opts:
                        normal_p99[vname] = float(res.get("normal_deg_p99", np.nan))
                if not opts:
                    default[(vname, w, h)] = t
                rows.append(row)
            # §6.4 anti-aliasing (rgb only), timed beside the plain render.
            aa_rows = aa_timings(surf, view, vname, w, h, repeat)
            rows.extend(aa_rows)
            # Floating horizon (lines only: time and samples).
            hz = dict(method="floating_horizon", outputs=("lines",))
            img = fcol.render(surf, view, w, h, **hz)
            t = median_time(lambda: fcol.render(surf, view, w, h, **hz), repeat=repeat)
            rows.append(dict(method="horizon (lines, 80 planes)", view=vname, size=f"{w}x{h}", ms=1e3 * t,
                             samples=img.samples, x_floor=t / floor[(w, h)]))
            if ref is None:
                continue
            # The mesh approach at increasing resolution (prebuilt: cast
            # only; new function: tessellate + build + cast).
            base = default[(vname, w, h)]
            for kind, caster in MESHES.items():
                for n in ((100, 200) if quick else (50, 100, 200, 400, 800)):
                    tb0 = time.perf_counter()
                    mc = caster(n)
                    got = mc.cast(view, w, h)
                    t_new = time.perf_counter() - tb0
                    t_cast = median_time(lambda: mc.cast(view, w, h), repeat=3)
                    res = compare(got, ref, view)
                    rows.append(dict(method=f"mesh {n}x{n} ({kind})", view=vname, size=f"{w}x{h}",
                                     ms=1e3 * t_cast, ms_with_build=1e3 * t_new, mask_bad=res.get("mask_bad"),
                                     depth_p99=res.get("depth_px_p99"), normal_med=res.get("normal_deg_median"),
                                     normal_p99=res.get("normal_deg_p99"),
                                     mesh_over_fcol=t_cast / base, mesh_new_over_fcol=t_new / base))
                    plot.append((f"mesh {n}² {kind} ({vname})", t_cast, res.get("normal_deg_p99", np.nan)))
    # The speed targets, round by round.
    rows.extend(target_rows(surf, sizes, 2 if quick else 5, (200,) if quick else (800, 3200)))
    # The §5 corrections, each with and without, at the seed's sampling.
    rows.extend(correction_rows(surf, W, H))
    # A landscape from a low eye: the height bound's early exit.
    rows.extend(landscape_rows(3 if quick else 7))
    # matplotlib plot_surface to an array (its own camera: time only).
    for n in (50, 100):
        t = median_time(lambda: matplotlib_plot(n, W, H), repeat=3, min_time=0.0)
        rows.append(dict(method=f"matplotlib plot_surface {n}x{n}", size=f"{W}x{H}", ms=1e3 * t,
                         mpl_over_fcol=t / default[("ortho", W, H)]))
    # Threads: the default column in child processes, 1 and 2 rayon workers.
    for (w, h) in sizes:
        for vname in views():
            t1 = _child_time(vname, w, h, 1, repeat)
            t2 = _child_time(vname, w, h, 2, repeat)
            rows.append(dict(method="column default, RAYON_NUM_THREADS=1 / 2", view=vname, size=f"{w}x{h}",
                             ms=1e3 * t2, ms_1thread=1e3 * t1, speedup_2threads=t1 / t2))
    # Scaling with image size: time per pixel of the default column.
    for (w, h) in sizes:
        for vname in views():
            t = default[(vname, w, h)]
            rows.append(dict(method="column default: ns per pixel", view=vname, size=f"{w}x{h}",
                             ns_per_px=1e9 * t / (w * h), x_floor=t / floor[(w, h)]))
    # The seed's Table 1 sample counts beside ours (480 × 477).
    for fig, n in SEED_SAMPLES.items():
        rows.append(dict(method=f"seed Table 1: Fig. {fig}", size="480x477", samples=n))
    _plot(plot, out_dir / "floating_time_vs_error.png")
    _table(rows, out_dir / "floating.md")
    return rows


def _plot(points, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 6), dpi=100)
    for label, t, e in points:
        if not np.isfinite(e):
            continue
        marker = "s" if label.startswith("mesh") else "o"
        ax.loglog(1e3 * t, max(e, 1e-4), marker, label=label)
    ax.set_xlabel("time per view (ms), 480 × 477")
    ax.set_ylabel("normal error, 99th percentile (degrees)")
    ax.set_title("3 sin(u cos v): floating column vs mesh ray casting")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6, loc="best")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _table(rows, path: Path) -> None:
    cols = list(dict.fromkeys(k for r in rows for k in r))
    fmt = lambda v: f"{v:.4g}" if isinstance(v, float) else ("" if v is None else str(v))  # noqa: E731
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        lines.append("| " + " | ".join(fmt(r.get(c)) for c in cols) + " |")
    path.write_text("\n".join(lines) + "\n")
