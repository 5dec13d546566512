"""Parametric surfaces by Blinn's scan line (exact X scan): accuracy against
an independent ray-cast reference, SPEC §5 hard cases, bad input, stats."""

from __future__ import annotations

import numpy as np
import pytest

import fcol
from fcol import _fcol

from test_parametric_support import compare, reference

W, H = 96, 72
ALL = ("depth", "normal", "mask", "uv", "side")


def render(shape, view, width=W, height=H, outputs=ALL, **options):
    return fcol.Image(**_fcol.render_parametric(shape, view, width, height, "scanline", outputs, options))


SIZE = dict(sphere=2.6, torus=3.2, monkey_saddle=3.5, bezier=5.0, helicoid=3.5, enneper=9.0)

CASES = [
    ("sphere", fcol.View(30, 20, view_height=2.6)),
    ("sphere", fcol.View(-35, 200, "perspective", distance=5, fov=35)),
    ("torus", fcol.View(35, 30, view_height=3.2)),
    ("torus", fcol.View(20, 120, "perspective", distance=5, fov=45)),
    ("monkey_saddle", fcol.View(30, 30, view_height=3.5)),
    ("monkey_saddle", fcol.View(50, 250, "perspective", distance=6, fov=40)),
    ("bezier", fcol.View(35, 60, "perspective", distance=9, fov=40)),
    ("bezier", fcol.View(-25, 10, view_height=5)),
    ("helicoid", fcol.View(25, 40, view_height=3.5)),
    ("enneper", fcol.View(40, 30, view_height=9)),
    ("enneper", fcol.View(15, 100, "perspective", distance=18, fov=40)),
]


def _check(m):
    assert m["mask_bad"] == 0, m
    assert m["farther_sheet"] == 0, m
    assert m["n_compared"] > 50, m
    assert m["depth_px_median"] <= 1e-3, m
    assert m["normal_deg_median"] <= 0.05, m
    assert m["normal_deg_p99"] <= 0.5, m


@pytest.mark.parametrize("shape,view", CASES, ids=[f"{s}-{v.projection[:5]}-{v.elevation:g}" for s, v in CASES])
def test_exact_x_scan_matches_reference(shape, view):
    img = render(shape, view)
    m = compare(img, reference(shape, view, W, H))
    _check(m)
    assert img.stats["convergence_failures"] == 0


HARD = [
    ("sphere", fcol.View(90, 0, view_height=2.6)),  # pole straight ahead
    ("sphere", fcol.View(0.5, 33, view_height=2.6)),  # poles on the silhouette
    ("torus", fcol.View(0, 0, view_height=3.2)),  # inner silhouettes edge-on
    ("torus", fcol.View(89.9, 0, view_height=3.2)),  # scan lines tangent to the hole
    ("torus", fcol.View(90, 0, view_height=3.2)),  # saddles exactly on scan lines
    ("torus", fcol.View(90, 33, view_height=3.2)),
    ("torus", fcol.View(10, 10, "perspective", distance=0.8, fov=70)),  # eye inside the ring
    ("monkey_saddle", fcol.View(90, 33, view_height=3.5)),  # monkey saddle head-on
    ("sphere", fcol.View(10, 10, "perspective", distance=0.65, fov=70)),  # eye inside
    ("helicoid", fcol.View(-30, 33, view_height=3.5)),
    ("enneper", fcol.View(-30, 0, view_height=9)),  # self-intersection seen from below
    ("bezier", fcol.View(10, 10, "perspective", distance=1.25, fov=70)),  # eye almost on the surface
]


@pytest.mark.parametrize("shape,view", HARD, ids=[f"{s}-{v.elevation:g}-{v.azimuth:g}" for s, v in HARD])
def test_hard_cases_have_no_holes(shape, view):
    img = render(shape, view, outputs=("depth", "normal", "mask"))
    _check(compare(img, reference(shape, view, W, H)))


def test_side_and_buffers():
    v = fcol.View(35, 30, view_height=3.2)
    img = render("torus", v, outputs=("rgb", "side", "normal", "intensity"))
    assert img.depth is None and img.mask is None
    assert img.rgb.shape == (H, W, 3) and img.rgb.dtype == np.uint8
    assert img.side.dtype == np.int8 and img.intensity.dtype == np.float32
    seen = img.side != 0
    assert np.array_equal(seen, np.isfinite(img.intensity))
    # side +1 exactly where P_u × P_v faces the (orthographic) viewer.
    d = -np.array([np.cos(np.radians(35)) * np.sin(np.radians(30)), np.cos(np.radians(35)) * np.cos(np.radians(30)),
                   -np.sin(np.radians(35))])
    facing = img.normal[seen] @ d
    assert np.all((facing >= 0) == (img.side[seen] > 0))
    # A closed surface seen from outside shows only its outer side; from an
    # eye inside the sphere every pixel sees the inner (under) side.
    assert (img.side == 1).sum() > 100 and not (img.side == -1).any()
    inside = render("sphere", fcol.View(20, 30, "perspective", distance=0.3, fov=60), outputs=("side",))
    assert (inside.side == -1).all()


def test_stats_are_reported():
    img = render("sphere", fcol.View(30, 20, view_height=2.6))
    s = img.stats
    for key in ("maxima", "newton_per_update", "newton_per_update_tenth_px", "net_added", "trackers_lost",
                "convergence_failures", "newton_per_pixel", "pixel_solves", "fold_walks"):
        assert key in s, key
    assert 0.5 < s["newton_per_update"] < 6
    assert s["newton_per_update_tenth_px"] < s["newton_per_update"]
    # The sphere's visible disc: one maximum of y at its top.
    assert s["maxima"] >= 1
    assert img.samples > W  # evaluations counted
    plain = render("sphere", fcol.View(30, 20, view_height=2.6), extrapolate=False).stats
    assert plain["newton_per_update_tenth_px"] > s["newton_per_update_tenth_px"]


def test_background_is_empty():
    img = render("sphere", fcol.View(30, 20, view_height=2.6), outputs=("depth", "uv", "mask", "side"))
    bg = ~img.mask
    assert bg.any() and np.isnan(img.depth[bg]).all() and np.isnan(img.uv[bg]).all()
    assert (img.side[bg] == 0).all()
    # A view that misses the surface entirely.
    far = render("sphere", fcol.View(30, 20, target=(50, 0, 0), view_height=2.6), outputs=("mask",))
    assert not far.mask.any()


@pytest.mark.parametrize(
    "kwargs,exc,word",
    [
        (dict(shape=3), TypeError, "surface"),
        (dict(shape="klein"), ValueError, "surface"),
        (dict(width=0), ValueError, "width"),
        (dict(height=-3), ValueError, "height"),
        (dict(method="floating_column"), ValueError, "method"),
        (dict(outputs=("lines",)), ValueError, "outputs"),
        (dict(outputs=("bogus",)), ValueError, "outputs"),
        (dict(options=dict(x_scan="fast")), ValueError, "x_scan"),
        (dict(options=dict(grid=2)), ValueError, "grid"),
        (dict(options=dict(samples_per_turn=8)), ValueError, "samples_per_turn"),
        (dict(options=dict(x_scan="sampled", samples_per_turn=2)), ValueError, "samples_per_turn"),
        (dict(options=dict(x_scan="sampled", max_normal_error=-1.0)), ValueError, "max_normal_error"),
        (dict(options=dict(colour=(1, 2, 3))), TypeError, "colour"),
        (dict(options=dict(ambient=float("nan"))), ValueError, "ambient"),
    ],
)
def test_bad_input(kwargs, exc, word):
    args = dict(shape="sphere", width=16, height=12, method="scanline", outputs=("mask",), options={})
    args.update(kwargs)
    with pytest.raises(exc, match=word):
        _fcol.render_parametric(args["shape"], fcol.View(30, 20, view_height=2.6), args["width"], args["height"],
                                args["method"], args["outputs"], args["options"])


def test_docstring_example():
    import doctest

    runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE)
    tests = doctest.DocTestFinder().find(_fcol.render_parametric.__doc__, "render_parametric", globs={})
    assert tests and tests[0].examples
    for t in tests:
        runner.run(t)
    assert runner.summarize(verbose=False).failed == 0


def test_view_is_checked():
    with pytest.raises(TypeError):
        _fcol.render_parametric("sphere", "not a view", 16, 12, "scanline", ("mask",), {})


# Where the Y scan still needs the safety net (see the README): a pole on
# the silhouette, where P_u = 0 and the silhouette trackers' Newton
# iteration is singular; and a corner of the Bézier patch where a
# silhouette begins at the corner itself.
NEEDS_NET = {("sphere", 0.5, 33.0), ("bezier", -25.0, 10.0)}


@pytest.mark.parametrize("shape,view", [c for c in CASES + HARD if (c[0], c[1].elevation, c[1].azimuth) not in NEEDS_NET],
                         ids=[f"{s}-{v.projection[:5]}-{v.elevation:g}-{v.azimuth:g}" for s, v in CASES + HARD
                              if (s, v.elevation, v.azimuth) not in NEEDS_NET])
def test_tracking_alone_finds_every_curve(shape, view):
    """Trackers made at maxima (interior, along edges, at edge ends and
    corners), saddles, curtain folds, folded edges, seams and the left
    image border find every level-curve piece: with the safety net off the
    mask has no error."""
    img = render(shape, view, outputs=("depth", "normal", "mask"), safety_net=False)
    _check(compare(img, reference(shape, view, W, H)))
    assert img.stats["net_added"] == 0
