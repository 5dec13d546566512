"""fcol.View against an independent NumPy implementation of SPEC §1."""

from __future__ import annotations

import numpy as np
import pytest

import fcol
from fcol.testing.spec_camera import SpecCamera, basis

VIEWS = [(0, 0), (0.5, 17), (30, 40), (89.9, 0), (90, 0), (90, 33), (-30, 200), (45, 90), (10, -135)]


@pytest.mark.parametrize("el,az", VIEWS)
def test_basis_matches_spec(el, az):
    d, r, up = fcol.View(el, az, view_height=1).basis()
    D, R, U = basis(el, az)
    np.testing.assert_allclose(d, D, atol=1e-15)
    np.testing.assert_allclose(r, R, atol=1e-15)
    np.testing.assert_allclose(up, U, atol=1e-15)


@pytest.mark.parametrize("el,az", VIEWS)
@pytest.mark.parametrize("proj", ["orthographic", "perspective"])
def test_project_and_rays_match_spec(el, az, proj):
    rng = np.random.default_rng(7)
    W, H = 37, 23
    target = (0.3, -1.2, 0.5)
    if proj == "orthographic":
        v = fcol.View(el, az, target=target, view_height=6.0)
        ref = SpecCamera(el, az, target=target, view_height=6.0, width=W, height=H)
    else:
        v = fcol.View(el, az, "perspective", target=target, distance=25.0, fov=35.0)
        ref = SpecCamera(el, az, "perspective", target=target, distance=25.0, fov=35.0, width=W, height=H)
    P = rng.uniform(-3, 3, size=(5, 7, 3)) + np.array(target)
    rows, cols = v.project(P, W, H)
    R, C = ref.project(P)
    assert rows.shape == (5, 7)
    np.testing.assert_allclose(rows, R, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(cols, C, rtol=1e-12, atol=1e-9)
    _, _, z = ref.screen(P)
    np.testing.assert_allclose(v.depth(P, W, H), z, rtol=1e-12, atol=1e-12)
    o, d = v.rays(W, H)
    O, D = ref.rays()
    assert o.shape == (H, W, 3) and d.shape == (H, W, 3)
    assert o.flags.c_contiguous and d.flags.c_contiguous
    np.testing.assert_allclose(o, O, atol=1e-12)
    np.testing.assert_allclose(d, D, atol=1e-12)
    # A point along each ray projects back onto its pixel centre.
    Pr = o + 3.7 * d
    rr, cc = v.project(Pr, W, H)
    ii, jj = np.mgrid[0:H, 0:W]
    np.testing.assert_allclose(rr, ii, atol=1e-9)
    np.testing.assert_allclose(cc, jj, atol=1e-9)


def test_map_view_orientation():
    # α = 90 looks straight down: +u right, +v up at β = 0.
    v = fcol.View(90, 0, view_height=4.0)
    rows, cols = v.project([[1.0, 0, 0], [0, 1.0, 0]], 4, 4)
    assert cols[0] > 1.5 and rows[0] == pytest.approx(1.5)
    assert rows[1] < 1.5 and cols[1] == pytest.approx(1.5)


def test_perspective_behind_eye_is_nan():
    v = fcol.View(0, 0, "perspective", distance=10.0, fov=40)
    rows, cols = v.project([[0, -20.0, 0]], 10, 10)  # behind the eye at v = −10
    assert np.isnan(rows[0]) and np.isnan(cols[0])


@pytest.mark.parametrize(
    "kwargs,arg",
    [
        (dict(elevation=30, azimuth=0), "view_height"),
        (dict(elevation=30, azimuth=0, view_height=-1), "view_height"),
        (dict(elevation=30, azimuth=0, view_height=float("nan")), "view_height"),
        (dict(elevation=float("inf"), azimuth=0, view_height=1), "elevation"),
        (dict(elevation=30, azimuth=0, projection="fisheye", view_height=1), "projection"),
        (dict(elevation=30, azimuth=0, projection="perspective"), "distance"),
        (dict(elevation=30, azimuth=0, projection="perspective", distance=5, fov=180), "fov"),
        (dict(elevation=30, azimuth=0, projection="perspective", distance=0), "distance"),
        (dict(elevation=30, azimuth=0, target=(0, float("nan"), 0), view_height=1), "target"),
    ],
)
def test_bad_views_name_the_argument(kwargs, arg):
    with pytest.raises(ValueError, match=arg):
        fcol.View(**kwargs)


def test_bad_points_and_sizes():
    v = fcol.View(30, 0, view_height=1)
    with pytest.raises(ValueError, match="points"):
        v.project(np.zeros((4, 2)), 10, 10)
    with pytest.raises(ValueError, match="width"):
        v.project(np.zeros((4, 3)), 0, 10)
    with pytest.raises(ValueError, match="pixel budget"):
        v.rays(1 << 16, 1 << 16)
    with pytest.raises((TypeError, ValueError), match="points"):
        v.project("abc", 10, 10)


def test_view_is_immutable_and_comparable():
    v = fcol.View(30, 10, view_height=2)
    assert v == fcol.View(30, 10, view_height=2)
    assert v != fcol.View(30, 11, view_height=2)
    with pytest.raises(AttributeError):
        v.elevation = 3  # type: ignore[misc]
    assert "orthographic" in repr(v)
