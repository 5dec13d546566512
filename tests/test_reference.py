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
    parametric_reference,
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
    check_against(ref, cam, s, side, n, edge, W, H)
    assert ref.mask.sum() > 0.05 * W * H
    assert ref.trusted[ref.mask].all()


@pytest.mark.parametrize("scale", [1e-6, 1e6])
@pytest.mark.parametrize("persp", [False, True], ids=["ortho", "persp"])
def test_spherical_cap_tiny_and_huge(scale, persp):
    W, H = 40, 36
    R, half = R_CAP * scale, HALF * scale

    def f(u, v):
        return np.sqrt(R * R - u * u - v * v)

    def grad(u, v):
        w = f(u, v)
        return -u / w, -v / w

    view = views_for(40, 30, persp, target=(0.0, 0.0, 1.8 * scale), size=4.5 * scale, distance=9.0 * scale)
    ref = height_reference(f, grad, ((-half, half), (-half, half)), view, W, H, mesh=24)
    cam, O, D = rays_of(view, W, H)
    s, side, n, edge = cap_closed_form(cam, O, D, R, half)
    # Relative rounding of the closed form itself grows with the offset of
    # the target from the origin; 1e-6 pixel is still far below any metric.
    check_against(ref, cam, s, side, n, edge, W, H, depth_tol_px=1e-6, normal_tol_deg=1e-6)
    assert ref.mask.sum() > 0.1 * W * H


def test_nan_hole_and_step():
    # A plane with a NaN disc: no surface (and no wall) in the hole.
    a, b, c = 0.3, -0.2, 0.5

    def f(u, v):
        return np.where(u * u + v * v < 1.0, np.nan, a * u + b * v + c)

    def grad(u, v):
        return 0 * u + a, 0 * v + b

    W, H = 60, 50
    view = fcol.View(40, 25, view_height=5.0)
    ref = height_reference(f, grad, ((-2, 2), (-2, 2)), view, W, H, mesh=32)
    cam, O, D = rays_of(view, W, H)
    s = (c + a * O[:, 0] + b * O[:, 1] - O[:, 2]) / (D[:, 2] - a * D[:, 0] - b * D[:, 1])
    P = O + s[:, None] * D
    r2 = P[:, 0] ** 2 + P[:, 1] ** 2
    inside = (np.abs(P[:, 0]) <= 2) & (np.abs(P[:, 1]) <= 2) & (r2 >= 1)
    edge = (np.abs(r2 - 1) < 1e-9) | (np.abs(np.abs(P[:, :2]) - 2).min(1) < 1e-9)
    m = ref.mask.reshape(-1)
    assert np.array_equal(m[~edge], inside[~edge])
    assert (~inside).sum() > 200 and np.isfinite(ref.depth.reshape(-1)[inside]).all()
    depth = (P[inside] - cam.origin) @ cam.d
    assert np.abs(ref.depth.reshape(-1)[inside] - depth).max() / cam.p < 1e-7
    # A step: rays that meet its vertical wall are hits but not trusted.
    step = height_reference(lambda u, v: np.where(u > 0.3, 1.0, 0.0) + 0 * v, lambda u, v: (0 * u, 0 * v),
                            ((-2, 2), (-2, 2)), fcol.View(30, 70, view_height=5.0), 60, 50, mesh=32)
    assert step.stats["walls"] > 0
    walls = step.mask & ~step.trusted
    assert walls.sum() == step.stats["walls"]
    u = step.uv[..., 0][walls]
    assert np.allclose(u, 0.3, atol=1e-9)


def crest_f(u, v):
    return 3 * np.sin(u * np.cos(v))


def crest_grad(u, v):
    c = np.cos(u * np.cos(v))
    return 3 * c * np.cos(v), -3 * c * u * np.sin(v)


def brute_force_first_hit(O, D, s0, s1, n=100_000):
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
    pick = np.unique(np.concatenate([rng.choice(hard, 160, replace=False), rng.choice(W * H, 80, replace=False)]))
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


# --------------------------------------------------------------------------
# Parametric references against closed-form ray–sphere / ray–torus hits

PI = np.pi
RS = 1.5  # sphere radius
RT, rt = 2.0, 0.7  # torus radii


def sphere_xyz(u, v):
    return RS * np.cos(v) * np.cos(u), RS * np.cos(v) * np.sin(u), RS * np.sin(v)


def sphere_jac(u, v):
    cu, su, cv, sv = np.cos(u), np.sin(u), np.cos(v), np.sin(v)
    Pu = np.stack([-RS * cv * su, RS * cv * cu, 0 * u], -1)
    Pv = np.stack([-RS * sv * cu, -RS * sv * su, RS * cv], -1)
    return Pu, Pv


def torus_xyz(u, v):
    a = RT + rt * np.cos(v)
    return a * np.cos(u), a * np.sin(u), rt * np.sin(v)


def torus_jac(u, v):
    cu, su, cv, sv = np.cos(u), np.sin(u), np.cos(v), np.sin(v)
    a = RT + rt * cv
    Pu = np.stack([-a * su, a * cu, 0 * u], -1)
    Pv = np.stack([-rt * sv * cu, -rt * sv * su, rt * cv], -1)
    return Pu, Pv


def sphere_closed_form(cam, O, D):
    b = np.sum(O * D, 1)
    c = np.sum(O * O, 1) - RS * RS
    disc = b * b - c
    sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
    cands = np.stack([-b - sq, -b + sq], 1)
    if cam.persp:
        cands = np.where(((O[:, None, :] + cands[..., None] * D[:, None, :]) - cam.origin) @ cam.d > cam.near, cands, np.nan)
    s = exact_first_hit(cam, cands)
    hit = np.isfinite(s)
    P = O[hit] + s[hit, None] * D[hit]
    tangent = np.zeros(O.shape[0], bool)
    tangent[disc >= 0] = np.sqrt(disc[disc >= 0]) < 1e-6 * RS
    return s, P / RS, tangent


def torus_closed_form(cam, O, D):
    """Quartic (|P|² + R² − r²)² = 4R²(P_x² + P_y²) per ray with numpy.roots,
    real roots polished by Newton on the implicit function."""
    s_out = np.full(O.shape[0], np.inf)
    tangent = np.zeros(O.shape[0], bool)

    def F(o, d, s):
        P = o + s[:, None] * d
        q = np.sum(P * P, 1) + RT**2 - rt**2
        return q * q - 4 * RT**2 * (P[:, 0] ** 2 + P[:, 1] ** 2), P

    for k in range(O.shape[0]):
        o, d = O[k], D[k]
        b = o @ d
        kk = o @ o + RT**2 - rt**2
        a2, a1, a0 = d[0] ** 2 + d[1] ** 2, o[0] * d[0] + o[1] * d[1], o[0] ** 2 + o[1] ** 2
        r = np.roots([1.0, 4 * b, 4 * b * b + 2 * kk - 4 * RT**2 * a2, 4 * b * kk - 8 * RT**2 * a1, kk * kk - 4 * RT**2 * a0])
        real = np.sort(r[np.abs(r.imag) < 1e-5].real)
        if real.size == 0:
            continue
        if np.any(np.diff(real) < 1e-4):
            tangent[k] = True
        for _ in range(6):  # Newton polish (derivative by the chain rule)
            f, P = F(o[None], d[None], real)
            q = np.sum(P * P, 1) + RT**2 - rt**2
            fp = 2 * q * 2 * (P @ d) - 8 * RT**2 * (P[:, 0] * d[0] + P[:, 1] * d[1])
            real = real - np.where(fp != 0, f / fp, 0)
        if cam.persp:
            real = real[(o + real[:, None] * d - cam.origin) @ cam.d > cam.near]
        if real.size:
            s_out[k] = real.min()
    hit = np.isfinite(s_out)
    P = O[hit] + s_out[hit, None] * D[hit]
    rho = np.hypot(P[:, 0], P[:, 1])
    C = np.stack([RT * P[:, 0] / rho, RT * P[:, 1] / rho, 0 * rho], 1)
    n = (P - C) / rt
    return s_out, n, tangent


PARAM_VIEWS = [(30, 20, False), (30, 20, True), (90, 0, False), (-30, 200, True), (2, 45, False)]


@pytest.mark.parametrize("el,az,persp", PARAM_VIEWS)
@pytest.mark.parametrize("surface", ["sphere", "torus"])
def test_parametric_against_closed_form(surface, el, az, persp):
    W = H = 64
    if surface == "sphere":
        xyz, jac, dom, cf = sphere_xyz, sphere_jac, ((-PI, PI), (-PI / 2, PI / 2)), sphere_closed_form
        size, dist = 4.0, 8.0
    else:
        xyz, jac, dom, cf = torus_xyz, torus_jac, ((-PI, PI), (-PI, PI)), torus_closed_form
        size, dist = 6.5, 11.0
    view = views_for(el, az, persp, size=size, distance=dist)
    ref = parametric_reference(xyz, jac, dom, view, W, H, periodic=(True, surface == "torus"))
    cam, O, D = rays_of(view, W, H)
    # Closed form on a few hundred rays: every ray near the reference's
    # silhouettes and depth jumps (the hard ones), plus random ones.
    from fcol.testing.reference import discontinuity_band, silhouette_band

    rng = np.random.default_rng(11)
    hard = np.nonzero((silhouette_band(ref.mask) | discontinuity_band(ref, view)).reshape(-1))[0]
    pick = np.unique(np.concatenate([rng.choice(hard, min(hard.size, 250), replace=False), rng.choice(W * H, 250, replace=False)]))
    s, n, tangent = cf(cam, O[pick], D[pick])
    hit = np.isfinite(s)
    assert np.array_equal(ref.mask.reshape(-1)[pick][~tangent], hit[~tangent])
    P = O[pick][hit] + s[hit, None] * D[pick][hit]
    depth = (P - cam.origin) @ cam.d
    err = np.abs(ref.depth.reshape(-1)[pick][hit] - depth) / cam.pixel_size(depth)
    assert err.max() < 1e-7, err.max()
    assert angle_deg(ref.normal.reshape(-1, 3)[pick][hit], n).max() < 1e-6
    side = np.where(np.sum(D[pick][hit] * n, 1) < 0, 1, -1)
    assert np.array_equal(ref.side.reshape(-1)[pick][hit], side)
    assert ref.trusted.mean() > 0.99, ref.stats
    assert ref.mask.sum() > 0.1 * W * H


def test_docstring_examples_run():
    import doctest

    import fcol.testing.mesh as mesh_mod
    import fcol.testing.reference as ref_mod

    for mod in (ref_mod, mesh_mod):
        res = doctest.testmod(mod)
        assert res.attempted > 0 and res.failed == 0


def test_mesh_baseline_exact_on_a_plane_and_not_on_crests():
    from fcol.testing.mesh import build_intersector, cast_height_mesh, mesh_height

    a, b, c = 0.3, -0.2, 0.5
    view = fcol.View(35, 25, view_height=5.0)
    W, H = 48, 40
    plane = mesh_height(lambda u, v: a * u + b * v + c, ((-2, 2), (-2, 2)), 9)
    ref = height_reference(lambda u, v: a * u + b * v + c, lambda u, v: (0 * u + a, 0 * v + b), ((-2, 2), (-2, 2)), view, W, H, mesh=9)
    got, t = cast_height_mesh(plane, view, W, H, intersector=build_intersector(plane))
    assert set(t) == {"build", "rays", "cast", "normals", "total"}
    img = fcol.Image(width=W, height=H, mask=got.mask, depth=got.depth, normal=got.normal, side=got.side)
    r = compare(img, ref, view)
    # embree works in float32: exact up to its rounding.
    assert r["mask_bad"] == 0 and r["depth_px_max"] < 1e-3 and r["normal_deg_max"] < 1e-4 and r["side_bad"] == 0
    # On 3 sin(u cos v) a coarse mesh misses crests by many pixels of depth.
    dom = ((-5.0, 5.0), (-5.0, 5.0))
    view = fcol.View(16, 30, view_height=15.0)
    W, H = 120, 119
    m = mesh_height(crest_f, dom, 40, grad=crest_grad)
    got, _ = cast_height_mesh(m, view, W, H)
    ref = height_reference(crest_f, crest_grad, dom, view, W, H, mesh=40)
    both = got.mask & ref.mask
    assert np.nanmax(np.abs(got.depth - ref.depth)[both] / ref.pixel_size[both]) > 20
