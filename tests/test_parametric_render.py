"""fcol.render on fcol.Parametric (expressions with exact derivatives) by
the scan line, checked against fcol.testing.reference; both X scans."""

from __future__ import annotations

import numpy as np
import pytest

import fcol
from fcol.testing.reference import compare, parametric_reference, shade

from test_parametric_support import SHAPES

PI = np.pi
W, H = 96, 72

EXPR = {
    "sphere": (("cos(v)*cos(u)", "cos(v)*sin(u)", "sin(v)"), ((0, 2 * PI), (-PI / 2, PI / 2)), (True, False)),
    "torus": (("(1 + 0.4*cos(v))*cos(u)", "(1 + 0.4*cos(v))*sin(u)", "0.4*sin(v)"), ((0, 2 * PI), (0, 2 * PI)),
              (True, True)),
    "enneper": (("u - u**3/3 + u*v**2", "v - v**3/3 + v*u**2", "u**2 - v**2"), ((-2, 2), (-2, 2)), (False, False)),
}

VIEWS = [
    ("sphere", fcol.View(30, 20, view_height=2.6)),
    ("torus", fcol.View(20, 120, "perspective", distance=5, fov=45)),
    ("enneper", fcol.View(40, 30, view_height=9)),
]


def _ref(shape, view):
    f, dom = SHAPES[shape]
    periodic = EXPR[shape][2]

    def xyz(u, v):
        P = f(np.asarray(u, float), np.asarray(v, float))[0]
        return P[..., 0], P[..., 1], P[..., 2]

    def jac(u, v):
        _, Pu, Pv = f(np.asarray(u, float), np.asarray(v, float))
        return Pu, Pv

    return parametric_reference(xyz, jac, dom, view, W, H, periodic=periodic)


def _surface(shape):
    (x, y, z), dom, _ = EXPR[shape]
    return fcol.Parametric(x, y, z, domain=dom)


@pytest.mark.parametrize("shape,view", VIEWS, ids=[s for s, _ in VIEWS])
def test_render_parametric_exact_and_sampled(shape, view):
    ref = _ref(shape, view)
    surf = _surface(shape)
    exact = fcol.render(surf, view, W, H, outputs=("rgb", "depth", "normal", "mask"))
    m = compare(exact, ref, view)
    assert m["mask_bad"] == 0, m
    assert m["depth_px_median"] <= 1e-3, m
    assert m["normal_deg_median"] <= 0.05 and m["normal_deg_p99"] <= 0.5, m
    sampled = fcol.render(surf, view, W, H, outputs=("rgb", "normal", "mask"), x_scan="sampled")
    ms = compare(sampled, ref, view)
    assert ms["mask_bad"] == 0, ms
    assert ms["normal_deg_median"] <= 0.5 and ms["normal_deg_p99"] <= 3.0, ms
    assert ms["ssim"] >= 0.97, ms
    assert sampled.stats["x_samples"] > 0


def test_sampled_beats_fixed_sixteen_per_turn():
    """More normal-angle samples where the error demands: the default error
    bound is far more accurate than the seed's fixed 16 samples per turn."""
    view = fcol.View(30, 20, view_height=2.2)
    surf = _surface("sphere")
    ref = _ref("sphere", view)
    fixed = compare(fcol.render(surf, view, W, H, outputs=("normal", "mask"), x_scan="sampled",
                                samples_per_turn=16, max_normal_error=90.0), ref, view)
    adaptive = compare(fcol.render(surf, view, W, H, outputs=("normal", "mask"), x_scan="sampled"), ref, view)
    assert adaptive["normal_deg_p99"] < fixed["normal_deg_p99"]
    assert adaptive["normal_deg_p99"] <= 3.0


def test_shade_matches_reference_shading():
    view = fcol.View(35, 30, view_height=3.2)
    ref = _ref("torus", view)
    img = fcol.render(_surface("torus"), view, W, H, outputs=("intensity",))
    inten, _ = shade(ref, view)
    both = ref.mask & np.isfinite(img.intensity) & ref.trusted
    assert np.median(np.abs(img.intensity[both] - inten[both])) < 1e-4


def test_callable_surface_errors_propagate():
    armed = []

    def boom(u, v):
        if armed:  # the constructor's own probe passes
            raise RuntimeError("bad surface")
        return u

    surf = fcol.Parametric(boom, lambda u, v: u, lambda u, v: v, domain=((0, 1), (0, 1)))
    armed.append(True)
    with pytest.raises(RuntimeError, match="bad surface"):
        fcol.render(surf, fcol.View(30, 20, view_height=2), 8, 6, outputs=("mask",))


@pytest.mark.parametrize("view", [
    fcol.View(0, 90, view_height=3.0),  # the ridge is a horizontal line in the image
    fcol.View(0, 90, target=(0, 0, 1 - 20.5 / 24), view_height=3.0),  # ridge exactly on a row centre
    fcol.View(20, 75, "perspective", distance=5, fov=40),
], ids=["ortho-ridge", "ortho-ridge-on-row", "persp"])
def test_parabolic_cylinder_top(view):
    """A ridge of maxima (y_uu y_vv − y_uv² = 0, §3.4): four boundary
    trackers instead of two silhouette trackers below it."""
    surf = fcol.Parametric("u", "v", "1 - u**2", domain=((-1, 1), (-1, 1)))

    def xyz(u, v):
        u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
        return u, v, 1 - u**2

    def jac(u, v):
        u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
        z = np.zeros_like(u)
        return np.stack([1 + z, z, -2 * u], -1), np.stack([z, 1 + z, z], -1)

    ref = parametric_reference(xyz, jac, ((-1, 1), (-1, 1)), view, W, H)
    img = fcol.render(surf, view, W, H, outputs=("depth", "normal", "mask"))
    m = compare(img, ref, view)
    assert m["mask_bad"] == 0, m
    assert m["depth_px_median"] <= 1e-3 and m["normal_deg_p99"] <= 0.5, m
    assert img.stats["convergence_failures"] == 0


@pytest.mark.parametrize("k", [1e-6, 1e6])
def test_tiny_and_huge_parameter_domains(k):
    """The same torus with its parameters scaled by k: the same picture."""
    view = fcol.View(35, 30, "perspective", distance=5, fov=40)
    x, y, z = "(1 + 0.4*cos(v/k))*cos(u/k)", "(1 + 0.4*cos(v/k))*sin(u/k)", "0.4*sin(v/k)"
    base = fcol.render(fcol.Parametric(x, y, z, domain=((0, 2 * PI), (0, 2 * PI)), params={"k": 1.0}),
                       view, W, H, outputs=("depth", "mask"))
    scaled = fcol.render(fcol.Parametric(x, y, z, domain=((0, 2 * PI * k), (0, 2 * PI * k)), params={"k": k}),
                         view, W, H, outputs=("depth", "mask", "uv"))
    assert np.array_equal(base.mask, scaled.mask)
    m = base.mask
    assert np.nanmax(np.abs(base.depth[m] - scaled.depth[m])) < 1e-5
    assert np.nanmax(scaled.uv[m]) > 6 * k
    assert scaled.stats["convergence_failures"] == 0


def _ridge(u, v):
    u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
    return u - 0.3 * v**2


@pytest.mark.parametrize("view", [
    fcol.View(0, 90, view_height=3.0),
    fcol.View(0, 90, target=(0, 0, 1 - 20.5 / 24), view_height=3.0),  # ridge exactly on a row centre
], ids=["side-on", "side-on-on-row"])
@pytest.mark.parametrize("x_scan", ["newton", "sampled"])
def test_curved_parabolic_ridge_without_safety_net(view, x_scan):
    """A curved ridge of equal maxima z = 1 − (u − 0.3 v²)² seen side-on
    (§3.4 parabolic cylinder: y_uu y_vv − y_uv² = 0 all along it). Below it
    the level curve is two curves running from edge v = −1 to edge v = 1:
    four boundary trackers, started at the maxima of y along those edges.
    With the safety net off the tracking alone draws the surface."""
    surf = fcol.Parametric("u", "v", "1 - (u - 0.3*v**2)**2", domain=((-1, 1), (-1, 1)))

    def xyz(u, v):
        g = _ridge(u, v)
        u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
        return u, v, 1 - g**2

    def jac(u, v):
        g = _ridge(u, v)
        u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
        z = np.zeros_like(u)
        return np.stack([1 + z, z, -2 * g], -1), np.stack([z, 1 + z, 1.2 * g * v], -1)

    ref = parametric_reference(xyz, jac, ((-1, 1), (-1, 1)), view, W, H)
    img = fcol.render(surf, view, W, H, outputs=("depth", "normal", "mask"), x_scan=x_scan, safety_net=False)
    m = compare(img, ref, view)
    assert m["mask_bad"] == 0, m
    s = img.stats
    assert s["parabolic_maxima"] > 0 and s["created_at_maxima"] >= 4, s
    assert s["net_added"] == 0
    if x_scan == "newton":
        assert m["depth_px_median"] <= 1e-3 and m["normal_deg_p99"] <= 0.5, m
    else:
        assert m["normal_deg_median"] <= 0.5 and m["normal_deg_p99"] <= 3.0, m


@pytest.mark.parametrize("view", [
    fcol.View(40, 30, view_height=9),
    fcol.View(-30, 0, view_height=9),
], ids=["above", "below"])
def test_curtain_folds_without_safety_net(view):
    """Enneper's surface: silhouette arcs that begin at curtain folds
    (§3.4), points where the silhouette J = 0 is tangent to a level curve
    of y without y being stationary. The pre-scan finds them and starts two
    silhouette trackers below each; with the safety net off the picture
    still matches the reference, and with it on the net adds nothing."""
    ref = _ref("enneper", view)
    surf = _surface("enneper")
    for x_scan in ("newton", "sampled"):
        img = fcol.render(surf, view, W, H, outputs=("depth", "normal", "mask"), x_scan=x_scan, safety_net=False)
        m = compare(img, ref, view)
        assert m["mask_bad"] == 0, (x_scan, m)
        s = img.stats
        assert s["curtain_folds"] >= 2 and s["created_at_curtain_folds"] >= 2, s
        on = fcol.render(surf, view, W, H, outputs=("mask",), x_scan=x_scan)
        assert on.stats["net_added"] == 0
        assert np.array_equal(on.mask, img.mask)


def test_safety_net_option_is_checked():
    with pytest.raises(TypeError, match="safety_net"):
        fcol.render(_surface("sphere"), fcol.View(30, 20, view_height=2.6), 8, 6, outputs=("mask",),
                    safety_net="no")


def test_callable_surface_batches_pixel_solves():
    """Three NumPy-vectorised callables: the exact X scan solves runs of
    pixels together (one call per callable and Newton round), so the render
    makes fewer calls per callable than points evaluated, and draws the picture
    of the same surface given as expressions."""
    view = fcol.View(20, 120, "perspective", distance=5, fov=45)
    (x, y, z), dom, _ = EXPR["torus"]
    fns = [lambda u, v: (1 + 0.4 * np.cos(v)) * np.cos(u), lambda u, v: (1 + 0.4 * np.cos(v)) * np.sin(u),
           lambda u, v: 0.4 * np.sin(v) + 0 * u]
    surf = fcol.Parametric(*fns, domain=dom)
    before = surf.calls
    img = fcol.render(surf, view, W, H, outputs=("depth", "mask"))
    calls = surf.calls - before
    # One call per callable and batch; without batching each point
    # evaluated costs about one call per callable.
    assert calls / 3 < 0.75 * img.samples, (calls, img.samples)
    ex = fcol.render(_surface("torus"), view, W, H, outputs=("depth", "mask"))
    assert np.array_equal(img.mask, ex.mask)
    assert np.nanmax(np.abs(img.depth - ex.depth)) < 1e-4
