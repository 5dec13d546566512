"""The ground-truth references of fcol.testing.reference checked where the
truth is known in closed form (planes, spheres, tori) or by brute force
(a dense march along sampled rays), and the metrics of compare() checked on
synthetic perturbations."""

from __future__ import annotations

import numpy as np
import pytest

import fcol
from fcol.testing.reference import (
    Reference,
    angle_deg,
    compare,
    height_reference,
    oiio_compare,
    shade,
)
from fcol.testing.spec_camera import SpecCamera


def views_for(el, az, persp, target=(0.0, 0.0, 0.0), size=6.0, distance=14.0):
    if persp:
        return fcol.View(el, az, "perspective", target=target, distance=distance, fov=35.0)
    return fcol.View(el, az, target=target, view_height=size)


def exact_first_hit(cam, candidates):
    """Given candidate ray parameters (N, k) (NaN = none) pick the smallest
    valid one per ray."""
    s = np.where(np.isfinite(candidates), candidates, np.inf)
    return s.min(axis=1)


def rays_of(view, W, H):
    cam = SpecCamera.from_view(view, W, H)
    O, D = cam.rays()
    return cam, O.reshape(-1, 3), D.reshape(-1, 3)


def check_against(ref, cam, s, side, normal, edge, W, H, depth_tol_px=1e-7, normal_tol_deg=1e-7):
    """ref agrees with the closed form (ray parameter s, inf = miss) on every
    pixel whose exact hit is not within a hair of the domain edge."""
    O, D = cam.rays()
    O, D = O.reshape(-1, 3), D.reshape(-1, 3)
    hit = np.isfinite(s)
    ok = ~edge
    mask = ref.mask.reshape(-1)
    assert np.array_equal(mask[ok], hit[ok]), f"mask differs at {np.sum(mask[ok] != hit[ok])} pixels"
    P = O[hit] + s[hit, None] * D[hit]
    depth = (P - cam.origin) @ cam.d
    pix = cam.pixel_size(depth)
    sel = ok[hit]
    err_px = np.abs(ref.depth.reshape(-1)[hit] - depth) / pix
    assert err_px[sel].max() < depth_tol_px, err_px[sel].max()
    ang = angle_deg(ref.normal.reshape(-1, 3)[hit], normal)
    assert ang[sel].max() < normal_tol_deg, ang[sel].max()
    assert np.array_equal(ref.side.reshape(-1)[hit][sel], side[sel])
    assert np.allclose(ref.pixel_size.reshape(-1)[hit][sel], pix[sel], rtol=1e-12)
    return err_px[sel], ang[sel]


VIEWS = [(30, 20), (0.5, 10), (89.9, 30), (90, 0), (-30, 200), (12, -135)]


@pytest.mark.parametrize("persp", [False, True], ids=["ortho", "persp"])
@pytest.mark.parametrize("el,az", VIEWS)
def test_tilted_plane(el, az, persp):
    a, b, c = 0.3, -0.2, 0.5
    dom = ((-2.0, 2.0), (-1.5, 2.5))
    W, H = 48, 40
    view = views_for(el, az, persp, target=(0.0, 0.5, 0.5))
    ref = height_reference(lambda u, v: a * u + b * v + c, lambda u, v: (0 * u + a, 0 * v + b), dom, view, W, H, mesh=16)
    cam, O, D = rays_of(view, W, H)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (c + a * O[:, 0] + b * O[:, 1] - O[:, 2]) / (D[:, 2] - a * D[:, 0] - b * D[:, 1])
    P = O + s[:, None] * D
    inside = (P[:, 0] >= -2) & (P[:, 0] <= 2) & (P[:, 1] >= -1.5) & (P[:, 1] <= 2.5)
    if cam.persp:
        inside &= (P - cam.origin) @ cam.d > cam.near
    s = np.where(inside & np.isfinite(s), s, np.inf)
    with np.errstate(invalid="ignore"):
        edge = np.minimum(np.abs(np.abs(P[:, 0]) - 2), np.abs(np.abs(P[:, 1] - 0.5) - 2)) < 1e-9
    n = np.array([-a, -b, 1.0]) / np.linalg.norm([-a, -b, 1.0])
    side = np.where(D @ n < 0, 1, -1)[np.isfinite(s)]
    check_against(ref, cam, s, side, np.broadcast_to(n, (O.shape[0], 3))[np.isfinite(s)], edge, W, H)
    assert ref.mask.sum() >= 40
    if el < 0:
        assert (ref.side[ref.mask] == -1).all()


def cap_closed_form(cam, O, D, R, half):
    """First hit of rays with the upper spherical cap w = sqrt(R² − u² − v²)
    over [−half, half]²."""
    b = np.sum(O * D, 1)
    c = np.sum(O * O, 1) - R * R
    disc = b * b - c
    sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
    cands = np.stack([-b - sq, -b + sq], 1)
    P = O[:, None, :] + cands[..., None] * D[:, None, :]
    valid = (P[..., 2] > 0) & (np.abs(P[..., 0]) <= half) & (np.abs(P[..., 1]) <= half)
    if cam.persp:
        valid &= (P - cam.origin) @ cam.d > cam.near
    s = exact_first_hit(cam, np.where(valid, cands, np.nan))
    hit = np.isfinite(s)
    Ph = O[hit] + s[hit, None] * D[hit]
    edge = np.zeros(O.shape[0], bool)
    edge[hit] = np.abs(np.abs(Ph[:, :2]) - half).min(1) < 1e-9
    n = Ph / R
    side = np.where(np.sum(D[hit] * n, 1) < 0, 1, -1)
    return s, side, n, edge


R_CAP, HALF = 2.5, 1.5


def cap_f(u, v):
    return np.sqrt(R_CAP**2 - u * u - v * v)


def cap_grad(u, v):
    w = cap_f(u, v)
    return -u / w, -v / w


@pytest.mark.parametrize("persp", [False, True], ids=["ortho", "persp"])
@pytest.mark.parametrize("el,az", VIEWS)
def test_spherical_cap(el, az, persp):
    W, H = 56, 50
    view = views_for(el, az, persp, target=(0.0, 0.0, 1.8), size=4.5, distance=9.0)
    ref = height_reference(cap_f, cap_grad, ((-HALF, HALF), (-HALF, HALF)), view, W, H, mesh=24)
    cam, O, D = rays_of(view, W, H)
    s, side, n, edge = cap_closed_form(cam, O, D, R_CAP, HALF)
    err, ang = check_against(ref, cam, s, side, n, edge, W, H)
    assert ref.mask.sum() >= 40
    assert ref.trusted[ref.mask].all()


def crest_f(u, v):
    return 3 * np.sin(u * np.cos(v))


def crest_grad(u, v):
    c = np.cos(u * np.cos(v))
    return 3 * c * np.cos(v), -3 * c * u * np.sin(v)


def brute_force_first_hit(O, D, s0, s1, n=200_000):
    """First root of g = P_w − f(P_u, P_v) along each ray in [s0, s1] by a
    dense uniform march, then bisection."""
    out = np.full(O.shape[0], np.inf)
    for k in range(O.shape[0]):
        s = np.linspace(s0[k], s1[k], n)
        P = O[k] + s[:, None] * D[k]
        g = P[:, 2] - crest_f(P[:, 0], P[:, 1])
        ch = np.nonzero(np.sign(g[:-1]) != np.sign(g[1:]))[0]
        if ch.size == 0:
            continue
        a, b = s[ch[0]], s[ch[0] + 1]
        ga = g[ch[0]]
        for _ in range(80):
            m = 0.5 * (a + b)
            Pm = O[k] + m * D[k]
            gm = Pm[2] - crest_f(Pm[0], Pm[1])
            if np.sign(gm) == np.sign(ga):
                a, ga = m, gm
            else:
                b = m
        out[k] = 0.5 * (a + b)
    return out


@pytest.mark.parametrize("persp", [False, True], ids=["ortho", "persp"])
def test_grazing_crests_against_brute_force(persp):
    W, H = 120, 119
    view = views_for(16, 30, persp, size=15.0, distance=22.0)
    dom = ((-5.0, 5.0), (-5.0, 5.0))
    # A coarse mesh on purpose: the guard march must find what it misses.
    ref = height_reference(crest_f, crest_grad, dom, view, W, H, mesh=40)
    cam, O, D = rays_of(view, W, H)
    # Sampled rays: the hardest ones (next to depth jumps and silhouettes
    # in the reference) and random others.
    from fcol.testing.reference import discontinuity_band, silhouette_band

    hard = np.nonzero((discontinuity_band(ref, view) | silhouette_band(ref.mask)).reshape(-1))[0]
    rng = np.random.default_rng(3)
    pick = np.unique(np.concatenate([rng.choice(hard, 200, replace=False), rng.choice(W * H, 100, replace=False)]))
    from fcol.testing.reference import _slab

    s0, s1 = _slab(O[pick], D[pick], np.array([-5, -5, -3.0]), np.array([5, 5, 3.0]))
    if cam.persp:
        s0 = np.maximum(s0, cam.near / (D[pick] @ cam.d))
    live = s0 < s1
    s = np.full(pick.size, np.inf)
    s[live] = brute_force_first_hit(O[pick][live], D[pick][live], s0[live], s1[live])
    hit = np.isfinite(s)
    mask = ref.mask.reshape(-1)[pick]
    assert np.array_equal(mask, hit), f"{np.sum(mask != hit)} of {pick.size} rays disagree"
    depth = ((O[pick][hit] + s[hit, None] * D[pick][hit]) - cam.origin) @ cam.d
    err = np.abs(ref.depth.reshape(-1)[pick][hit] - depth) / cam.pixel_size(depth)
    # The brute force step bounds its own accuracy; both must find the same root.
    assert err.max() < 1e-6, err.max()
    # The coarse mesh alone misses crests here (hundreds of pixels of depth).
    assert ref.stats["crests_missed_by_mesh"] > 0


def test_compare_metrics_on_perturbations():
    W, H = 64, 60
    view = fcol.View(35, 25, view_height=4.0, target=(0, 0, 1.8))
    ref = height_reference(cap_f, cap_grad, ((-HALF, HALF), (-HALF, HALF)), view, W, H, mesh=24)
    assert ref.mask.sum() > 1000 and (~ref.mask).sum() > 200
    # Exact copy: zero error, SSIM 1.
    _, rgb = shade(ref, view)
    img = fcol.Image(width=W, height=H, mask=ref.mask, depth=ref.depth.astype(np.float32),
                     normal=ref.normal.astype(np.float32), uv=ref.uv.astype(np.float32), side=ref.side, rgb=rgb)
    r0 = compare(img, ref, view)
    assert r0["mask_bad"] == 0 and r0["depth_px_median"] < 1e-3 and r0["normal_deg_median"] < 1e-2
    assert r0["ssim"] == pytest.approx(1.0) and r0["side_bad"] == 0 and r0["n_compared"] > 800
    # Depth shifted by 0.1 pixel.
    img.depth = (ref.depth + 0.1 * ref.pixel_size).astype(np.float64)
    r = compare(img, ref, view)
    assert r["depth_px_median"] == pytest.approx(0.1, abs=1e-6)
    assert r["depth_px_p99"] == pytest.approx(0.1, abs=1e-6)
    # Normals turned by 1 degree about an axis perpendicular to each.
    n = ref.normal
    axis = np.cross(n, np.array([1.0, 0.0, 0.0]))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    t = np.radians(1.0)
    img.normal = n * np.cos(t) + np.cross(axis, n) * np.sin(t)
    r = compare(img, ref, view)
    assert r["normal_deg_median"] == pytest.approx(1.0, abs=1e-6)
    assert r["normal_deg_p99"] == pytest.approx(1.0, abs=1e-6)
    # One wrong mask pixel far from the silhouette, and one inside the band.
    m = ref.mask.copy()
    m[0, 0] = True  # background corner
    assert not ref.mask[:3, :3].any()
    img.mask = m
    assert compare(img, ref, view)["mask_bad"] == 1
    left_edge = ref.mask[:, 1:] & ~ref.mask[:, :-1]
    edge = np.argwhere(left_edge)[0] + (0, 1)
    m[tuple(edge)] = False
    assert compare(img, ref, view)["mask_bad"] == 1
    # A darker image lowers SSIM; OpenImageIO sees the same difference.
    img.rgb = (rgb * 0.8).astype(np.uint8)
    assert compare(img, ref, view)["ssim"] < 0.99
    st = oiio_compare(img.rgb, rgb, failthresh=0.5)
    assert st["maxerror"] > 0 and st["nfail"] == 0
    assert oiio_compare(rgb, rgb)["maxerror"] == 0


def test_shade_matches_formula():
    W, H = 32, 30
    view = fcol.View(50, 10, "perspective", distance=8.0, target=(0, 0, 1.8))
    ref = height_reference(cap_f, cap_grad, ((-HALF, HALF), (-HALF, HALF)), view, W, H, mesh=16)
    inten, rgb = shade(ref, view)
    cam = SpecCamera.from_view(view, W, H)
    i, j = np.argwhere(ref.mask)[len(np.argwhere(ref.mask)) // 2]
    V = cam.E - ref.point[i, j]
    V /= np.linalg.norm(V)
    expect = 0.12 + 0.88 * abs(ref.normal[i, j] @ V)
    assert inten[i, j] == pytest.approx(expect, rel=1e-12)
    assert tuple(rgb[i, j]) == tuple(int(np.floor(c * expect + 0.5)) for c in (235, 200, 120))
    assert np.isnan(inten[~ref.mask]).all() and (rgb[~ref.mask] == 255).all()
