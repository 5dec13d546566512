"""Gallery: matplotlib's Jacksboro fault DEM lit through a day from one
horizon map (Stewart Fig. 10), the same afternoon light draped as a
texture over a floating-column perspective view of the DEM, and the spike
test (Fig. 8) for Stewart's exact sector maxima against centre-line
sampling (CMS)."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np

import fcol
from fcol.image import png_bytes


def _grid(tiles: list[np.ndarray], cols: int, pad: int = 4) -> np.ndarray:
    h, w = tiles[0].shape[:2]
    rows = (len(tiles) + cols - 1) // cols
    out = np.full((rows * (h + pad) + pad, cols * (w + pad) + pad, 3), 255, np.uint8)
    for k, t in enumerate(tiles):
        r, c = divmod(k, cols)
        out[pad + r * (h + pad): pad + r * (h + pad) + h, pad + c * (w + pad): pad + c * (w + pad) + w] = t
    return out


def _sun_at(hour: float) -> tuple[float, float]:
    """(azimuth, elevation) of the demo's sun: rises in the east (+u),
    culminates to the south (−v), sets in the west."""
    ha = (hour - 12) / 12 * math.pi
    el = math.radians(62) * math.cos(ha * 0.9) - math.radians(8)
    return -math.pi / 2 - ha * 0.95, max(el, math.radians(2))


def _perspective(out_dir: Path, z: np.ndarray, hm: fcol.HorizonMap, t_h: float) -> dict[str, Any]:
    """The DEM in perspective (HeightGrid in metres, 2x vertical
    exaggeration) with the horizon map's late-afternoon light as its texture:
    0.75 · sun (soft shadows, N·s) + 0.25 · sky-view factor, exposed so
    that the brightest 0.5 % saturate."""
    du, dv = hm.spacing
    h, w = z.shape
    v0 = 0.0 if dv > 0 else -(h - 1) * dv  # row 0 is north: the largest v
    ext = (0.0, (w - 1) * du, v0, v0 + (h - 1) * dv)
    ve = 2.0
    grid = fcol.HeightGrid(np.asarray(z, np.float64) * ve, extent=ext)
    az, el = _sun_at(17.0)
    t0 = time.perf_counter()
    light = 0.75 * hm.sun(az, el, math.radians(0.27)) + 0.25 * hm.sky_view_factor()
    t_light = time.perf_counter() - t0
    light /= np.nanpercentile(light, 99.5)  # exposure: the brightest 0.5% saturate
    cu, cv = 0.5 * (ext[0] + ext[1]), 0.5 * (ext[2] + ext[3])
    view = fcol.View(28, -25, "perspective", target=(cu, cv, float(np.mean(z)) * ve), distance=1.3 * (w - 1) * du, fov=46)
    # ambient 1, diffuse 0: the intensity is the horizon map's light itself
    img = fcol.render(grid, view, 900, 560, outputs="rgb", texture=light, ambient=1.0, diffuse=0.0,
                      upper_color=(235, 215, 170), under_color=(120, 120, 120), background=(200, 220, 240))
    assert img.rgb is not None
    (out_dir / "horizon_jacksboro_perspective.png").write_bytes(png_bytes(img.rgb))
    return {
        "section": "horizon", "file": "horizon_jacksboro_perspective.png", "size": "900x560",
        "ms": round((t_light + img.elapsed) * 1e3, 1), "samples": int(img.samples),
        "note": f"floating column, perspective, texture = 0.75 sun (17:00, soft shadows) + 0.25 sky-view factor from the {hm.sectors}-sector map "
                f"(map {t_h:.2f} s once; light {t_light * 1e3:.0f} ms; render {img.elapsed * 1e3:.0f} ms)",
    }


def gallery(out_dir: Path) -> list[dict[str, Any]]:
    out_dir = Path(out_dir)
    rows: list[dict[str, Any]] = []
    try:
        from matplotlib.cbook import get_sample_data

        dem: Any = get_sample_data("jacksboro_fault_dem.npz")
    except Exception:  # pragma: no cover - matplotlib missing
        dem = None
    if dem is not None:
        z = dem["elevation"]
        ext = (float(dem["xmin"]), float(dem["xmax"]), float(dem["ymin"]), float(dem["ymax"]))
        t0 = time.perf_counter()
        hm = fcol.horizon_map(z, extent=ext, geographic=True, sectors=64, method="stewart")
        t_h = time.perf_counter() - t0
        tiles: list[np.ndarray] = []
        t0 = time.perf_counter()
        # the sun rises in the east (+u), culminates to the south (−v), sets west
        for hour in (7, 8.5, 10, 12, 14, 15.5, 17, 18.5):
            az, el = _sun_at(hour)  # east at dawn, south at noon, west at dusk
            img = fcol.shade_terrain(horizon=hm, sun_azimuth=az, sun_elevation=el, sun_radius=math.radians(0.27), outputs="rgb")
            assert img.rgb is not None
            tiles.append(img.rgb)
        t_s = time.perf_counter() - t0
        pic = _grid(tiles, 4)
        (out_dir / "horizon_jacksboro_day.png").write_bytes(png_bytes(pic))
        rows.append({
            "section": "horizon", "file": "horizon_jacksboro_day.png", "size": f"{pic.shape[1]}x{pic.shape[0]}",
            "ms": round((t_h + t_s) * 1e3, 1), "samples": int(z.size),
            "note": f"Jacksboro DEM {z.shape[1]}x{z.shape[0]}, 64-sector stewart horizons once ({t_h:.2f} s), 8 sun positions with soft shadows ({t_s:.2f} s)",
        })
        svf = hm.sky_view_factor()
        gf = np.clip((svf - np.nanpercentile(svf, 1)) / (1 - np.nanpercentile(svf, 1)), 0, 1)
        g8 = (np.where(np.isfinite(gf), gf, 1) * 255).astype(np.uint8)
        g8 = np.ascontiguousarray(g8[::-1] if hm.spacing[1] > 0 else g8)
        (out_dir / "horizon_jacksboro_svf.png").write_bytes(png_bytes(g8))
        rows.append({"section": "horizon", "file": "horizon_jacksboro_svf.png", "size": f"{g8.shape[1]}x{g8.shape[0]}", "ms": 0.0, "samples": int(z.size), "note": "sky-view factor from the same horizon map"})

        rows.append(_perspective(out_dir, z, hm, t_h))

    # Fig. 8: 100x100 flat, one sample of height 50 in the upper-left corner,
    # an area light 30° above the horizon, seen from above.
    n = 100
    z = np.zeros((n, n))
    z[n - 6, 5] = 50.0
    tiles = []
    t0 = time.perf_counter()
    notes = []
    for s in (64, 125, 250):
        for m in ("cms", "stewart"):
            hm = fcol.horizon_map(z, 1.0, sectors=s, method=m)
            # an area light towards the upper left (azimuth 140°), where the
            # spike stands as seen from the rest of the terrain
            sh = hm.shadow(math.radians(140), math.radians(30), sun_radius=math.radians(12))
            gs = (np.clip(0.25 + 0.75 * sh, 0, 1) * 255).astype(np.uint8)[::-1]
            tiles.append(np.repeat(np.kron(gs, np.ones((2, 2), np.uint8))[..., None], 3, axis=2))
            notes.append(f"{m}@{s}: shadowed {float((sh < 0.999).mean()) * 100:.1f}%")
    ms = (time.perf_counter() - t0) * 1e3
    pic = _grid(tiles, 2)
    (out_dir / "horizon_spike.png").write_bytes(png_bytes(pic))
    rows.append({"section": "horizon", "file": "horizon_spike.png", "size": f"{pic.shape[1]}x{pic.shape[0]}", "ms": round(ms, 1), "samples": n * n,
                 "note": "spike test (Stewart Fig. 8), columns cms | stewart, rows s = 64, 125, 250; " + ", ".join(notes)})
    return rows
