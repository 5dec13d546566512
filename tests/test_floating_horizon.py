"""The floating horizon (Gordon 2001 §4.1, A.1) against a brute-force
reading of its definition: the curves cut from the surface by the sampling
planes of constant t, sampled densely, each point visible when its screen row
lies outside the rows covered, in its pixel column, by the curves of all
earlier (nearer) planes. Rows and columns come from the independent NumPy SPEC
camera, never from fcol."""

from __future__ import annotations

import numpy as np
import pytest

import fcol
from fcol.testing.spec_camera import SpecCamera

from floating_surfaces import SURFACES, surface


def plane_ts(cam: SpecCamera, domain, planes: int) -> np.ndarray:
    """t of the sampling planes: t is the coordinate along the horizontal part
    of the view direction (pointing into the scene), measured from the target
    (orthographic) or the eye (perspective)."""
    e = np.array([cam.d[0], cam.d[1]])
    if np.linalg.norm(e) < 1e-12:
        e = np.array([cam.up[0], cam.up[1]])
    e = e / np.linalg.norm(e)
    o = cam.E if cam.persp else cam.T
    (u0, u1), (v0, v1) = domain
    corners = np.array([(u0, v0), (u1, v0), (u0, v1), (u1, v1)]) - o[:2]
    ts = corners @ e
    t = np.linspace(ts.min(), ts.max(), planes)
    if cam.persp:
        t = t[t > 0]
    return t, e, o


def brute_visible(f, domain, cam: SpecCamera, planes: int, dense: int = 24):
    """Dense points of every plane's curve and whether each is visible."""
    t, e, o = plane_ts(cam, domain, planes)
    r = np.array([cam.r[0], cam.r[1]])
    (u0, u1), (v0, v1) = domain
    span = np.hypot(u1 - u0, v1 - v0) + np.linalg.norm(o[:2])
    lo = np.full(cam.W, np.inf)
    hi = np.full(cam.W, -np.inf)
    pts = []
    for tk in t:
        s = np.linspace(-span, span, dense * cam.W * 4)
        uv = o[:2] + s[:, None] * r + tk * e
        inside = (uv[:, 0] >= u0) & (uv[:, 0] <= u1) & (uv[:, 1] >= v0) & (uv[:, 1] <= v1)
        uv = uv[inside]
        if len(uv) == 0:
            continue
        w = f(uv[:, 0], uv[:, 1])
        P = np.column_stack([uv, w])
        row, col = cam.project(P)
        ok = np.isfinite(row) & np.isfinite(col)
        if cam.persp:
            ok &= cam.screen(P)[2] > 0
        row, col = row[ok], col[ok]
        jc = np.round(col).astype(int)
        ir = np.round(row)
        onscreen = (jc >= 0) & (jc < cam.W)
        vis = np.ones(len(row), bool)
        vis[onscreen] = (ir[onscreen] < lo[jc[onscreen]]) | (ir[onscreen] > hi[jc[onscreen]])
        pts.append((ir[onscreen], jc[onscreen], vis[onscreen]))
        np.minimum.at(lo, jc[onscreen], ir[onscreen])
        np.maximum.at(hi, jc[onscreen], ir[onscreen])
    rows = np.concatenate([p[0] for p in pts])
    cols = np.concatenate([p[1] for p in pts])
    vis = np.concatenate([p[2] for p in pts])
    return rows, cols, vis


def dilate(m: np.ndarray, k: int) -> np.ndarray:
    out = m.copy()
    for di in range(-k, k + 1):
        for dj in range(-k, k + 1):
            out |= np.roll(np.roll(m, di, 0), dj, 1)
    return out


VIEWS = [
    dict(elevation=30, azimuth=20, view_height=18.0),
    dict(elevation=55, azimuth=-35, view_height=18.0),
    dict(elevation=25, azimuth=30, projection="perspective", distance=32.0, fov=40.0),
]


@pytest.mark.parametrize("kw", VIEWS, ids=["ortho30", "ortho55", "persp25"])
def test_lines_match_the_definition(kw):
    W, H, planes = 96, 80, 40
    name = "sinuv"
    f, grad, domain = SURFACES[name]
    view = fcol.View(**{k: v for k, v in kw.items() if k not in ("projection",)},
                     **({"projection": kw["projection"]} if "projection" in kw else {}))
    img = fcol.render(surface(name), view, W, H, method="floating_horizon",
                      outputs=("lines",), planes=planes)
    lines = img.lines == 255
    assert img.lines.dtype == np.uint8 and lines.sum() > 300
    cam = SpecCamera(view.elevation, view.azimuth, view.projection, view.target,
                     view_height=view.view_height, distance=view.distance,
                     fov=view.fov or 40.0, width=W, height=H)
    rows, cols, vis = brute_visible(f, domain, cam, planes)
    inside = (rows >= 0) & (rows < H)
    r, c = rows[vis & inside].astype(int), cols[vis & inside]
    # Recall: visible curve points are drawn (within a pixel).
    near_line = dilate(lines, 1)
    recall = near_line[r, c].mean()
    # Precision: drawn pixels lie on a visible part of some curve.
    vis_img = np.zeros((H, W), bool)
    vis_img[r, c] = True
    precision = dilate(vis_img, 1)[lines].mean()
    assert recall > 0.98, recall
    assert precision > 0.97, precision


def test_horizon_bad_outputs():
    view = fcol.View(30, 0, view_height=12.0)
    with pytest.raises(ValueError, match="outputs"):
        fcol.render(surface("bump"), view, 20, 20, method="floating_horizon", outputs=("rgb",))
    with pytest.raises(ValueError, match="planes"):
        fcol.render(surface("bump"), view, 20, 20, method="floating_horizon",
                    outputs=("lines",), planes=1)
