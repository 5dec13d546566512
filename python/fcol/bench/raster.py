"""Bench section ``raster``: fcol's primitives against scikit-image's
``draw`` functions, a NumPy z-buffer and embreex ray casting.

Both sides run in this process, one after the other, on the same inputs;
times are medians (``fcol.bench.median_time``) and ``speedup`` is
baseline time / fcol time. ``mismatch`` counts pixels where the two
results differ (see the notes column for why they may)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import numpy as np
import numpy.typing as npt

import fcol
from fcol import raster
from fcol.bench import median_time


def numpy_zbuffer(
    vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64], shape: tuple[int, int]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """A plain NumPy z-buffer: for each triangle, barycentric coordinates of
    the pixel centres of its bounding box (vectorised), inside where all
    three are >= 0 (no tie rule), depth interpolated linearly."""
    h, w = shape
    zbuf = np.full(shape, np.inf)
    fbuf = np.full(shape, -1, np.int64)
    tri = vertices[faces]  # (M, 3, 3) of (row, col, depth)
    lo = np.maximum(np.ceil(tri[:, :, :2].min(1)), 0).astype(np.int64)
    hi = np.minimum(np.floor(tri[:, :, :2].max(1)), [h - 1, w - 1]).astype(np.int64)
    for k in range(len(faces)):
        (r0, c0), (r1, c1) = lo[k], hi[k]
        if r1 < r0 or c1 < c0:
            continue
        (ya, xa, za), (yb, xb, zb), (yc, xc, zc) = tri[k]
        det = (xb - xa) * (yc - ya) - (yb - ya) * (xc - xa)
        if det == 0:
            continue
        y, x = np.mgrid[r0 : r1 + 1, c0 : c1 + 1].astype(np.float64)
        l1 = ((x - xa) * (yc - ya) - (y - ya) * (xc - xa)) / det
        l2 = ((xb - xa) * (y - ya) - (yb - ya) * (x - xa)) / det
        l0 = 1 - l1 - l2
        inside = (l0 >= 0) & (l1 >= 0) & (l2 >= 0)
        z = l0 * za + l1 * zb + l2 * zc
        win = sub = zbuf[r0 : r1 + 1, c0 : c1 + 1]
        win = inside & (z < sub)
        sub[win] = z[win]
        fbuf[r0 : r1 + 1, c0 : c1 + 1][win] = k
    zbuf[np.isinf(zbuf)] = np.nan
    return zbuf, fbuf


def _torus(n_major: int, n_minor: int) -> tuple[np.ndarray, np.ndarray]:
    a = 2 * np.pi * np.arange(n_major) / n_major
    b = 2 * np.pi * np.arange(n_minor) / n_minor
    A, B = np.meshgrid(a, b, indexing="ij")
    verts = np.stack(
        [(1 + 0.4 * np.cos(B)) * np.cos(A), (1 + 0.4 * np.cos(B)) * np.sin(A), 0.4 * np.sin(B)], -1
    ).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n_major), np.arange(n_minor), indexing="ij")
    v00 = i * n_minor + j
    v10 = ((i + 1) % n_major) * n_minor + j
    v01 = i * n_minor + (j + 1) % n_minor
    v11 = ((i + 1) % n_major) * n_minor + (j + 1) % n_minor
    faces = np.concatenate([np.stack([v00, v10, v11], -1).reshape(-1, 3), np.stack([v00, v11, v01], -1).reshape(-1, 3)])
    return verts, faces


def _row(
    primitive: str,
    workload: str,
    t_fcol: float,
    baseline: str,
    t_base: float,
    mismatch: int | str,
    note: str = "",
) -> dict[str, Any]:
    return {
        "primitive": primitive,
        "workload": workload,
        "fcol_ms": t_fcol * 1e3,
        "baseline": baseline,
        "baseline_ms": t_base * 1e3,
        "speedup": t_base / t_fcol,
        "mismatch": mismatch,
        "note": note,
    }


def run(out_dir: Path, quick: bool) -> list[dict[str, Any]]:
    from skimage import draw

    rng = np.random.default_rng(0)
    repeat = 3 if quick else 7
    tm: Callable[[Callable[[], Any]], float] = lambda f: median_time(f, repeat=repeat, min_time=0.02 if quick else 0.1)  # noqa: E731
    rows: list[dict[str, Any]] = []

    # Lines: many short calls (per-call overhead) and one long line (throughput).
    segs = rng.integers(0, 512, size=(200 if quick else 1000, 4)).tolist()
    long_seg = (0, 0, 70_000, 200_000)
    for name, ours, theirs in (("line", raster.line, draw.line), ("line_aa", raster.line_aa, draw.line_aa)):
        t_f = tm(lambda: [ours(*s) for s in segs])  # noqa: B023
        t_s = tm(lambda: [theirs(*s) for s in segs])  # noqa: B023
        diff = sum(
            int(np.any(np.asarray(ours(*s)[0]) != np.asarray(theirs(*s)[0])))
            if name == "line"
            else 0
            for s in segs[:100]
        )
        rows.append(_row(name, f"{len(segs)} random segments in 512²", t_f, "skimage.draw", t_s, diff if name == "line" else "n/a",
                         "per-call overhead dominates" if name == "line" else "different AA filters (see docs)"))
        t_f = tm(lambda: ours(*long_seg))  # noqa: B023
        t_s = tm(lambda: theirs(*long_seg))  # noqa: B023
        rows.append(_row(name, "one line of 200,001 px", t_f, "skimage.draw", t_s, "n/a" if name == "line_aa" else
                         int(np.sum(ours(*long_seg)[0] != theirs(*long_seg)[0]))))

    # Polygons: scikit-image tests every pixel of the bounding box against
    # every edge; the scan line touches only crossings.
    for m, rad in ((8, 60), (64, 200)) if not quick else ((16, 60),):
        t = np.sort(rng.uniform(0, 2 * np.pi, m))
        r = rad * rng.uniform(0.3, 1.0, m)
        prow, pcol = 256 + r * np.sin(t), 256 + r * np.cos(t)
        t_f = tm(lambda: raster.polygon(prow, pcol, (512, 512)))  # noqa: B023
        t_s = tm(lambda: draw.polygon(prow, pcol, (512, 512)))  # noqa: B023
        a = np.zeros((512, 512), bool)
        b = np.zeros((512, 512), bool)
        a[raster.polygon(prow, pcol, (512, 512))] = True
        b[draw.polygon(prow, pcol, (512, 512))] = True
        rows.append(_row("polygon", f"{m} vertices, radius {rad}", t_f, "skimage.draw", t_s, int(np.sum(a != b)),
                         "skimage also fills centres on the outline"))

    # Triangles: a projected torus, against a NumPy z-buffer and embree rays.
    sizes = [((48, 24), 256)] if quick else [((48, 24), 256), ((160, 80), 512)]
    for (nm, nn), px in sizes:
        verts, faces = _torus(nm, nn)
        view = fcol.View(35, 20, view_height=3.2)
        rr, cc = view.project(verts, px, px)
        zz = view.depth(verts, px, px) + 10.0
        scr = np.stack([rr, cc, zz], 1)
        shape = (px, px)
        t_f = tm(lambda: raster.triangles(scr, faces, None, shape))  # noqa: B023
        t_n = median_time(lambda: numpy_zbuffer(scr, faces, shape), repeat=1 if not quick else 1, min_time=0.0)  # noqa: B023
        d_f, _, f_f = raster.triangles(scr, faces, None, shape, return_face=True)
        d_n, f_n = numpy_zbuffer(scr, faces, shape)
        work = f"torus {len(faces)} faces, {px}²"
        rows.append(_row("triangles", work, t_f, "numpy z-buffer", t_n, int(np.sum(np.isnan(d_f) != np.isnan(d_n))),
                         "numpy: no tie rule (edge centres counted twice)"))
        try:
            import trimesh
            from trimesh.ray.ray_pyembree import RayMeshIntersector
        except ImportError:  # pragma: no cover - optional baseline
            continue
        ri = RayMeshIntersector(trimesh.Trimesh(scr[:, [1, 0, 2]], faces, process=False))
        jj, ii = np.meshgrid(np.arange(px, dtype=float), np.arange(px, dtype=float))
        orig = np.stack([jj.ravel(), ii.ravel(), np.full(px * px, zz.min() - 1)], 1)
        dirs = np.tile([0.0, 0.0, 1.0], (px * px, 1))
        t_e = median_time(lambda: ri.intersects_first(orig, dirs), repeat=3, min_time=0.0)  # noqa: B023
        tri = ri.intersects_first(orig, dirs).reshape(px, px)
        rows.append(_row("triangles", work, t_f, "embree rays", t_e, int(np.sum((tri >= 0) != (f_f >= 0))),
                         "one ray per pixel, BVH prebuilt"))
    _plot(out_dir, rows)
    return rows


def _plot(out_dir: Path, rows: list[dict[str, Any]]) -> None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # pragma: no cover
        return
    fig, ax = plt.subplots(figsize=(8, 0.45 * len(rows) + 1))
    labels = [f"{r['primitive']}: {r['workload']} vs {r['baseline']}" for r in rows]
    y = np.arange(len(rows))
    ax.barh(y, [r["speedup"] for r in rows], color="tab:blue")
    ax.set_yticks(y, labels, fontsize=7)
    ax.set_xscale("log")
    ax.axvline(1, color="k", lw=0.8)
    ax.set_xlabel("speed-up of fcol (baseline time / fcol time)")
    ax.set_title(f"raster primitives (fcol {fcol.__version__}, {fcol.build_profile})")
    fig.tight_layout()
    fig.savefig(Path(out_dir) / "raster.png", dpi=110)
    plt.close(fig)
