"""Gallery section ``raster``: the raster primitives every renderer draws with."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

import fcol
from fcol import raster
from fcol.image import png_bytes


def _hue(t: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """A simple colour wheel, t in [0, 1) -> RGB in [0, 1]."""
    k = (t[..., None] * 6 + np.array([0.0, 4.0, 2.0])) % 6
    return np.clip(np.minimum(k, 4 - k), 0, 1)


def _save(out_dir: Path, name: str, pixels: npt.NDArray[np.uint8]) -> str:
    (out_dir / name).write_bytes(png_bytes(pixels))
    return name


def _row(file: str, img: npt.ArrayLike, seconds: float, samples: int, note: str) -> dict[str, Any]:
    a = np.asarray(img)
    return {
        "section": "raster",
        "file": file,
        "size": f"{a.shape[1]}x{a.shape[0]}",
        "ms": round(seconds * 1e3, 2),
        "samples": samples,
        "note": note,
    }


def _fan_ends(n: int, size: int) -> list[tuple[int, int, int, int]]:
    c = size // 2
    t = 2 * np.pi * (np.arange(n) + 0.37) / n  # off the axes: every octant, no symmetry
    rad = 0.46 * size
    return [(c, c, int(round(c - rad * np.sin(a))), int(round(c + rad * np.cos(a)))) for a in t]


def _line_fan(out_dir: Path) -> dict[str, Any]:
    size, n = 512, 96
    img = np.full((size, size, 3), 255, np.uint8)
    ends = _fan_ends(n, size)
    t0 = time.perf_counter()
    segs = [raster.line(*e) for e in ends]
    dt = time.perf_counter() - t0
    for k, (rr, cc) in enumerate(segs):
        img[rr, cc] = (255 * (1 - _hue(np.array(k / n)))).astype(np.uint8)
    pixels = sum(len(rr) for rr, _ in segs)
    return _row(_save(out_dir, "raster_line_fan.png", img), img, dt, pixels, f"{n} midpoint lines, all octants")


def _aa_fan(out_dir: Path) -> dict[str, Any]:
    size, n = 512, 96
    ink = np.zeros((size, size))
    ends = _fan_ends(n, size)
    t0 = time.perf_counter()
    segs = [raster.line_aa(*e) for e in ends]
    dt = time.perf_counter() - t0
    for rr, cc, val in segs:
        np.maximum.at(ink, (rr, cc), val)
    img = (255 * (1 - ink)).astype(np.uint8)
    pixels = sum(len(rr) for rr, _, _ in segs)
    return _row(_save(out_dir, "raster_line_aa_fan.png", img), img, dt, pixels, f"{n} anti-aliased lines (Wu)")


def _stars(out_dir: Path) -> dict[str, Any]:
    h, w = 300, 600
    img = np.full((h, w, 3), 255, np.uint8)
    total, pixels = 0.0, 0
    for k, rule in enumerate(("evenodd", "nonzero")):
        for p, q, cx, cy, rad in ((5, 2, 150, 150, 130), (7, 3, 150, 150, 70)):
            t = np.pi * (0.5 + 2 * q * np.arange(p) / p)
            rows, cols = cy - rad * np.sin(t), k * 300 + cx + rad * np.cos(t)
            t0 = time.perf_counter()
            rr, cc = raster.polygon(rows, cols, (h, w), rule=rule)  # type: ignore[arg-type]
            total += time.perf_counter() - t0
            img[rr, cc] = (40, 90, 180) if p == 5 else (230, 120, 30)
            pixels += len(rr)
    return _row(
        _save(out_dir, "raster_polygon_rules.png", img),
        img,
        total,
        pixels,
        "{5/2} and {7/3} stars: even-odd (left), non-zero (right)",
    )


def _torus_mesh(n_major: int, n_minor: int, big: float, small: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices, counter-clockwise faces (seen from outside) and unit normals."""
    a = 2 * np.pi * np.arange(n_major) / n_major
    b = 2 * np.pi * np.arange(n_minor) / n_minor
    A, B = np.meshgrid(a, b, indexing="ij")
    normal = np.stack([np.cos(A) * np.cos(B), np.sin(A) * np.cos(B), np.sin(B)], -1)
    centre = np.stack([big * np.cos(A), big * np.sin(A), np.zeros_like(A)], -1)
    verts = (centre + small * normal).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n_major), np.arange(n_minor), indexing="ij")
    v00 = i * n_minor + j
    v10 = ((i + 1) % n_major) * n_minor + j
    v01 = i * n_minor + (j + 1) % n_minor
    v11 = ((i + 1) % n_major) * n_minor + (j + 1) % n_minor
    faces = np.concatenate([np.stack([v00, v10, v11], -1).reshape(-1, 3), np.stack([v00, v11, v01], -1).reshape(-1, 3)])
    return verts, faces, normal.reshape(-1, 3)


def _tori(out_dir: Path) -> dict[str, Any]:
    h, w = 360, 480
    v1, f1, n1 = _torus_mesh(96, 48, 1.0, 0.35)
    # A second torus linked through the first: the z-buffer resolves the
    # interpenetration pixel by pixel.
    rot = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    v2 = v1 @ rot.T + [1.0, 0, 0]
    n2 = n1 @ rot.T
    verts = np.concatenate([v1, v2])
    faces = np.concatenate([f1, f1 + len(v1)])
    normals = np.concatenate([n1, n2])
    view = fcol.View(30, 35, "perspective", target=(0.5, 0, 0), distance=6.0, fov=40.0)
    rows, cols = view.project(verts, w, h)
    depth = view.depth(verts, w, h)
    d, _, _ = view.basis()
    shade = np.abs(normals @ np.asarray(d))  # headlight, two-sided
    colour = np.where(np.arange(len(verts))[:, None] < len(v1), [0.9, 0.55, 0.2], [0.25, 0.5, 0.9])
    values = colour * (0.15 + 0.85 * shade[:, None])
    t0 = time.perf_counter()
    z, rgb, _ = raster.triangles(
        np.stack([rows, cols, depth], 1),
        faces,
        values,
        (h, w),
        cull_backfaces=True,
        perspective_correct=True,
        return_face=True,
    )
    dt = time.perf_counter() - t0
    assert rgb is not None
    img = np.where(np.isnan(z)[..., None], 1.0, rgb)
    img8 = (255 * np.clip(img, 0, 1)).astype(np.uint8)
    return _row(
        _save(out_dir, "raster_triangles_tori.png", img8),
        img8,
        dt,
        int(np.sum(~np.isnan(z))),
        f"two linked tori, {len(faces)} faces, z-buffer + Gouraud, perspective-correct",
    )


def gallery(out_dir: Path) -> list[dict[str, Any]]:
    out_dir = Path(out_dir)
    return [_line_fan(out_dir), _aa_fan(out_dir), _stars(out_dir), _tori(out_dir)]
