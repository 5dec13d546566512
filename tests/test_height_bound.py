"""Height bounds of function surfaces (interval arithmetic on expressions, a
grid's range) and the perspective sweep's early exit they allow: checked
against dense NumPy sampling, against the same render without the bound
(every buffer identical) and against the exact first hit of
`fcol.testing.reference` on landscape views from a low eye."""

from __future__ import annotations

import numpy as np
import pytest

import fcol
from fcol.testing.reference import compare, height_reference

from floating_surfaces import DEM_EXTENT, SURFACES, dem_grid, surface

ALL = ("rgb", "intensity", "depth", "normal", "uv", "side", "mask")

EXPRS = [
    ("3*sin(u*cos(v))", lambda u, v: 3 * np.sin(u * np.cos(v))),
    ("exp(-(u*u + v*v)) * cos(3*u) + 0.1*v", lambda u, v: np.exp(-(u * u + v * v)) * np.cos(3 * u) + 0.1 * v),
    ("sqrt(abs(u*v)) - log(1 + u**2)", lambda u, v: np.sqrt(np.abs(u * v)) - np.log(1 + u**2)),
    ("atan2(v, u) + tanh(u - v)", lambda u, v: np.arctan2(v, u) + np.tanh(u - v)),
]


@pytest.mark.parametrize("expr,f", EXPRS, ids=[e for e, _ in EXPRS])
def test_expression_bound_contains_every_value(expr, f):
    dom = ((-2.0, 3.0), (-1.5, 2.5))
    s = fcol.Function(expr, domain=dom)
    lo, hi = s.height_bound
    u, v = np.meshgrid(np.linspace(*dom[0], 401), np.linspace(*dom[1], 401))
    z = f(u, v)
    assert lo <= z.min() and z.max() <= hi
    # fcol's own values too (its kernels round differently from NumPy's).
    zf = np.asarray(s(u.ravel(), v.ravel()))
    assert lo <= np.nanmin(zf) and np.nanmax(zf) <= hi


def test_bounds_tight_callables_none_grids_their_range():
    lo, hi = fcol.Function("3*sin(u*cos(v))", domain=((-5, 5), (-5, 5))).height_bound
    assert (round(lo, 9), round(hi, 9)) == (-3.0, 3.0)
    assert fcol.Function(lambda u, v: u * v, domain=((0, 1), (0, 1))).height_bound is None
    z = dem_grid()
    z[3, 4] = np.nan
    lo, hi = fcol.HeightGrid(z, extent=DEM_EXTENT).height_bound
    assert lo == pytest.approx(np.nanmin(z), abs=1e-9) and hi == pytest.approx(np.nanmax(z), abs=1e-9)
    assert lo <= np.nanmin(z) and hi >= np.nanmax(z)
    g = fcol.HeightGrid(z, extent=DEM_EXTENT, interpolation="bicubic")
    lo, hi = g.height_bound
    u, v = np.meshgrid(np.linspace(-4, 4, 500), np.linspace(-4, 4, 500))
    zz = np.asarray(g(u.ravel(), v.ravel()))
    assert lo <= np.nanmin(zz) and np.nanmax(zz) <= hi
    assert fcol.HeightGrid(np.full((3, 3), np.nan), extent=(0, 1, 0, 1)).height_bound is None


# Landscapes from a low eye over the DEM (heights 0 … 2.9 over [−4, 4]²) and
# over 3 sin(u cos v): near hills hide much of what lies behind them.
LANDSCAPES = [
    ("dem", dict(elevation=2.0, azimuth=20.0, distance=2.5, fov=50.0, target=(0.0, -1.0, 1.3))),
    ("dem", dict(elevation=6.0, azimuth=200.0, distance=2.5, fov=60.0, target=(0.5, 1.5, 1.8))),
    ("sinuv", dict(elevation=5.0, azimuth=30.0, distance=12.0, fov=40.0)),
    ("sinuv", dict(elevation=1.0, azimuth=-70.0, distance=7.0, fov=50.0, target=(0.0, 0.0, 0.5))),
]


def landscape_view(kw):
    return fcol.View(kw["elevation"], kw["azimuth"], "perspective", distance=kw["distance"], fov=kw["fov"],
                     target=kw.get("target", (0.0, 0.0, 0.0)))


@pytest.mark.parametrize("name,kw", LANDSCAPES, ids=[f"{n}-{i}" for i, (n, _) in enumerate(LANDSCAPES)])
def test_early_exit_changes_no_pixel_and_matches_the_exact_hit(name, kw):
    view = landscape_view(kw)
    s = surface(name)
    w, h = 160, 120
    a = fcol.render(s, view, w, h, outputs=ALL)
    b = fcol.render(s, view, w, h, outputs=ALL, height_bound=False)
    for k in ALL:
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    assert a.stats["sweep_samples"] <= b.stats["sweep_samples"], (a.stats, b.stats)
    if name != "dem" or kw["elevation"] < 5:
        # (the second DEM view looks down on hills higher than its eye from
        # close by: the bound's elevation stays above them and stops nothing)
        assert a.stats["sweep_samples"] < b.stats["sweep_samples"], (a.stats, b.stats)
        assert a.stats["early_exits"] > b.stats["early_exits"], (a.stats, b.stats)
    res = _compare(name, kw, a)
    assert res["n_compared"] > 0.2 * w * h, res
    assert res["mask_bad"] == 0, res
    assert res["depth_px_median"] <= 1e-4 and res["depth_px_p99"] <= 1e-3, res
    assert res["normal_deg_median"] <= 1e-3 and res["normal_deg_p99"] <= 0.05, res
    assert res["ssim"] >= 0.97, res


_RES: dict = {}


def _compare(name, kw, img):
    key = (name, tuple(sorted(kw.items())))
    if key not in _RES:
        view = landscape_view(kw)
        f, grad, domain = SURFACES[name]
        h, w = img.mask.shape
        _RES[key] = compare(img, height_reference(f, grad, domain, view, w, h), view)
    return _RES[key]


# (Two pixels of these views once took a crest's far, under side: a DEM
# terrace that Newton stepped over beside its plane, and a sliver of
# surface at the domain's edge that the ray crosses before its hit.)
@pytest.mark.parametrize("case", range(len(LANDSCAPES)))
def test_landscape_sides_match_the_exact_hit(case):
    name, kw = LANDSCAPES[case]
    img = fcol.render(surface(name), landscape_view(kw), 160, 120, outputs=ALL)
    res = _compare(name, kw, img)
    assert res["side_bad"] == 0, res


def test_sky_only_view_samples_nothing():
    """Looking up from above the surface's bound: every plane's rays pass
    above it, so no sweep samples the domain."""
    s = surface("sinuv")
    view = fcol.View(-30.0, 10.0, "perspective", distance=3.0, fov=40.0, target=(0.0, 0.0, 6.0))
    a = fcol.render(s, view, 64, 48, outputs=ALL)
    b = fcol.render(s, view, 64, 48, outputs=ALL, height_bound=False)
    assert not a.mask.any() and not b.mask.any()
    assert a.stats["sweep_samples"] == 0 < b.stats["sweep_samples"]


def test_height_bound_option_type():
    with pytest.raises(TypeError, match="height_bound"):
        fcol.render(surface("bump"), landscape_view(LANDSCAPES[2][1]), 10, 10, height_bound="no")
