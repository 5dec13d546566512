"""Bench section ``parametric``: Blinn's scan line (exact and sampled X
scans) against tessellate + trimesh/embreex ray casting and tessellate +
``fcol.raster.triangles``, time against error.

Every method runs in this process on the same surface (``fcol.Parametric``
expressions with exact derivatives) and view; errors are measured against
``fcol.testing.reference.parametric_reference``. ``per_line_ms`` is the
scan-line time per image row the surface covers (the seed reports 0.4 s per
scan line for a sphere); ``newton_upd`` is the mean number of Newton
corrections per tracker update (full precision) and ``newton_upd_0.1px``
the number larger than a tenth of a pixel (the seed's stopping rule: 2.5
plain, under 1 with extrapolation); ``net_added`` counts the trackers the
safety net had to add. The ``callables`` rows draw the same surface given
as three NumPy-vectorised callables (``calls``: Python calls, one per
callable and batch). For the sampled X scan ``theta_upd``
and ``theta_upd_plain`` are the Newton corrections per update of its
normal-angle trackers with and without the §3.5 extrapolation.

The ``equal error`` rows pair each X scan (exact and sampled) with the
coarsest tessellation (for ``fcol.raster.triangles`` and for embree) whose
normal error (99th percentile) is at most the scan's, and give the time
ratio ``speedup`` = tessellation time / scan time (> 1: the scan is
faster); where no tessellation tried is as accurate (``vs none of``), the
row gives the finest one's time and (larger) error beside the scan's."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

import fcol
from fcol.bench import median_time

PI = np.pi

SURFACES = {
    "sphere": (("cos(v)*cos(u)", "cos(v)*sin(u)", "sin(v)"), ((0, 2 * PI), (-PI / 2, PI / 2)), (True, False),
               fcol.View(30, 20, view_height=2.4)),
    "torus": (("(1 + 0.4*cos(v))*cos(u)", "(1 + 0.4*cos(v))*sin(u)", "0.4*sin(v)"), ((0, 2 * PI), (0, 2 * PI)),
              (True, True), fcol.View(35, 30, "perspective", distance=5, fov=40)),
}


def _numpy_fns(surf: Any):
    def xyz(u, v):
        return surf(np.asarray(u, float), np.asarray(v, float))

    def jac(u, v):
        pu, pv = surf.jacobian(np.asarray(u, float), np.asarray(v, float))
        return np.asarray(pu), np.asarray(pv)

    return xyz, jac


def _raster_triangles(surf: Any, dom, view: Any, n: int, px: int):
    """Tessellate n × n, project, rasterise with fcol.raster.triangles,
    normals interpolated from the exact vertex normals."""
    from fcol import raster

    (u0, u1), (v0, v1) = dom
    uu, vv = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n))
    X, Y, Z = surf(uu, vv)
    P = np.stack([X, Y, Z], -1).reshape(-1, 3)
    Pu, Pv = surf.jacobian(uu, vv)
    N = np.cross(np.asarray(Pu), np.asarray(Pv)).reshape(-1, 3)
    with np.errstate(all="ignore"):
        N /= np.linalg.norm(N, axis=-1, keepdims=True)
    N = np.nan_to_num(N)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    rr, cc = view.project(P, px, px)
    zz = view.depth(P, px, px)
    persp = view.projection == "perspective"
    depth, vals = raster.triangles(np.stack([rr, cc, zz], 1), faces, N, (px, px), perspective_correct=persp)
    return depth, vals


def run(out_dir: Path, quick: bool) -> list[dict[str, Any]]:
    from fcol.testing.mesh import build_intersector, cast_parametric_mesh, mesh_parametric
    from fcol.testing.reference import compare, parametric_reference

    px = 256 if quick else 512
    repeat = 3 if quick else 5
    rows: list[dict[str, Any]] = []
    curves: dict[str, list[tuple[float, float]]] = {}
    for name, ((x, y, z), dom, periodic, view) in SURFACES.items():
        surf = fcol.Parametric(x, y, z, domain=dom)
        xyz, jac = _numpy_fns(surf)
        t0 = time.perf_counter()
        ref = parametric_reference(xyz, jac, dom, view, px, px, periodic=periodic)
        t_ref = time.perf_counter() - t0

        def row(method: str, t: float, m: dict, **extra: Any) -> dict[str, Any]:
            r = {"surface": name, "view": view.projection, "size": f"{px}²", "method": method, "ms": t * 1e3,
                 "normal_med_deg": m.get("normal_deg_median", float("nan")),
                 "normal_p99_deg": m.get("normal_deg_p99", float("nan")),
                 "depth_med_px": m.get("depth_px_median", float("nan")), "mask_bad": m.get("mask_bad", "")}
            if "ssim" in m:
                r["ssim"] = m["ssim"]
            r.update(extra)
            words = method.split(" ")
            curve = " ".join(words[:2]) if words[0] == "scanline" else words[0]
            curves.setdefault(f"{name}: {curve}", []).append((t, r["normal_p99_deg"]))
            return r

        # Exact X scan.
        outs = ("rgb", "depth", "normal", "mask")
        t = median_time(lambda: fcol.render(surf, view, px, px, outputs=("rgb",)), repeat=repeat, min_time=0.0)  # noqa: B023
        img = fcol.render(surf, view, px, px, outputs=outs)
        m = compare(img, ref, view)
        lines = int(img.mask.any(1).sum())
        plain = fcol.render(surf, view, px, px, outputs=("mask",), extrapolate=False).stats
        s = img.stats
        rows.append(row("scanline newton", t, m, per_line_ms=t * 1e3 / max(lines, 1),
                        newton_upd=s["newton_per_update"], **{"newton_upd_0.1px": s["newton_per_update_tenth_px"],
                        "plain_upd_0.1px": plain["newton_per_update_tenth_px"]},
                        newton_px=s["newton_per_pixel"], samples=img.samples,
                        failures=s["convergence_failures"], net_added=s["net_added"],
                        curtain_folds=s["curtain_folds"], note=f"reference {t_ref:.1f} s"))
        newton_row = rows[-1]
        # The same surface as three NumPy-vectorised callables (exact X
        # scan, a smaller image): Python calls and time.
        cpx = 64
        ns = {"cos": np.cos, "sin": np.sin}
        fns = [lambda u, v, e=e: eval(e, ns, {"u": u, "v": v}) + 0 * u for e in (x, y, z)]  # noqa: S307
        csurf = fcol.Parametric(*fns, domain=dom)
        c0 = csurf.calls
        t0 = time.perf_counter()
        cimg = fcol.render(csurf, view, cpx, cpx, outputs=("depth", "mask"))
        tc = time.perf_counter() - t0
        calls = csurf.calls - c0
        eimg = fcol.render(surf, view, cpx, cpx, outputs=("depth", "mask"))
        rows.append({"surface": name, "view": view.projection, "size": f"{cpx}²", "method": "scanline newton, callables",
                     "ms": tc * 1e3, "calls": calls, "samples": cimg.samples,
                     "points_per_call": 3 * cimg.samples / max(calls, 1),
                     "mask_bad": int((cimg.mask != eimg.mask).sum()),
                     "note": "three NumPy callables; mask_bad against the expression render"})
        # Sampled X scan: the seed's fixed 16 per turn, and error-driven.
        sampled_rows = []
        for label, opts in (("scanline sampled 16/turn", dict(samples_per_turn=16, max_normal_error=90.0)),
                            ("scanline sampled 0.5°", dict()), ("scanline sampled 2°", dict(max_normal_error=2.0))):
            t = median_time(lambda: fcol.render(surf, view, px, px, outputs=("rgb",), x_scan="sampled", **opts),  # noqa: B023
                            repeat=repeat, min_time=0.0)
            img = fcol.render(surf, view, px, px, outputs=outs, x_scan="sampled", **opts)
            m = compare(img, ref, view)
            lines = int(img.mask.any(1).sum())
            s = img.stats
            plain = fcol.render(surf, view, px, px, outputs=("mask",), x_scan="sampled", extrapolate=False,
                                **opts).stats
            rows.append(row(label, t, m, per_line_ms=t * 1e3 / max(lines, 1), samples=img.samples,
                            x_samples=s["x_samples"], theta_upd=s["theta_newton_per_update_extrapolated"],
                            theta_upd_plain=plain["theta_newton_per_update_plain"],
                            created=s["theta_trackers_created"], deleted=s["theta_trackers_deleted"],
                            lost=s["theta_trackers_lost"], failures=s["convergence_failures"]))
            sampled_rows.append(rows[-1])
        # Tessellate + trimesh/embreex ray casting (normals interpolated
        # from exact vertex normals), BVH build included.
        for n in ((16, 32, 64, 128) if quick else (16, 24, 32, 48, 64, 96, 128, 256)):
            def cast(n=n):
                mesh = mesh_parametric(xyz, dom, n, jac=jac)
                return cast_parametric_mesh(mesh, view, px, px)[0]

            t = median_time(cast, repeat=1 if n >= 256 else repeat, min_time=0.0)
            m = compare(cast(), ref, view)
            rows.append(row(f"embreex {n}²", t, m, note="tessellate + build + cast"))
            mesh = mesh_parametric(xyz, dom, n, jac=jac)
            it = build_intersector(mesh)
            t2 = median_time(lambda: cast_parametric_mesh(mesh, view, px, px, intersector=it), repeat=repeat,  # noqa: B023
                             min_time=0.0)
            rows[-1]["cast_only_ms"] = t2 * 1e3
        # Tessellate + fcol.raster.triangles.
        for n in ((16, 32, 64, 128) if quick else (16, 24, 32, 48, 64, 96, 128, 192, 256)):
            t = median_time(lambda: _raster_triangles(surf, dom, view, n, px), repeat=repeat, min_time=0.0)  # noqa: B023
            depth, nrm = _raster_triangles(surf, dom, view, n, px)

            class _Img:
                pass

            im = _Img()
            im.mask = np.isfinite(depth)
            im.depth = depth.astype(np.float32)
            with np.errstate(all="ignore"):
                im.normal = (nrm / np.linalg.norm(nrm, axis=-1, keepdims=True)).astype(np.float32)
            m = compare(im, ref, view)
            rows.append(row(f"raster.triangles {n}²", t, m, note="tessellate + project + z-buffer"))
        # Equal error: the coarsest tessellation at least as accurate as
        # each sampled scan.
        for sr in [newton_row, *sampled_rows]:
            for kind in ("raster.triangles", "embreex"):
                tess = [r for r in rows if r["surface"] == name and r["method"].startswith(kind)
                        and r["normal_p99_deg"] <= sr["normal_p99_deg"]]
                if not tess:
                    # no tessellation tried is as accurate: compare with the finest
                    finest = max((r for r in rows if r["surface"] == name and r["method"].startswith(kind)),
                                 key=lambda r: int(r["method"].split(" ")[1].rstrip("²")))
                    rows.append({"surface": name, "view": view.projection, "size": f"{px}²",
                                 "method": f"equal error: {sr['method'].split('scanline ')[1]} vs none of {kind}",
                                 "ms": sr["ms"], "normal_p99_deg": sr["normal_p99_deg"],
                                 "note": f"finest {finest['method']} {finest['ms']:.1f} ms still at p99 "
                                         f"{finest['normal_p99_deg']:.3g}°",
                                 "speedup": finest["ms"] / sr["ms"]})
                    continue
                best = min(tess, key=lambda r: int(r["method"].split(" ")[1].rstrip("²")))
                rows.append({"surface": name, "view": view.projection, "size": f"{px}²",
                             "method": f"equal error: {sr['method'].split('scanline ')[1]} vs {best['method']}",
                             "ms": sr["ms"], "normal_p99_deg": sr["normal_p99_deg"],
                             "note": f"{kind} {best['ms']:.1f} ms at p99 {best['normal_p99_deg']:.3g}°",
                             "speedup": best["ms"] / sr["ms"]})

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 5))
        for label, pts in curves.items():
            pts = sorted(pts)
            ax.plot([p[0] * 1e3 for p in pts], [p[1] for p in pts], "o-" if len(pts) > 1 else "s", label=label)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("time (ms)")
        ax.set_ylabel("normal error, 99th percentile (degrees)")
        ax.set_title(f"parametric surfaces, {px}²: time against error")
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(Path(out_dir) / "parametric.png", dpi=120)
        plt.close(fig)
    except ImportError:
        pass
    return rows
