"""Sky light and sun shadows of horizon maps (Stewart §VI): the per-point
Rust implementation against the whole-array NumPy reference in
``fcol.testing.sky``, to 1e-9 relative (1e-12 absolute near zero), on
grids with NaN holes, anisotropic and negative spacing, sector subsets,
every kind of sky, suns on sector borders, below the horizon, of radius 0
and large."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest

import fcol
from fcol import horizon as hz
from fcol.testing import sky as ref

RTOL, ATOL = 1e-9, 1e-12
TAU = 2 * math.pi


def assert_close(got: np.ndarray, want: np.ndarray) -> None:
    assert got.dtype == np.float64 and got.shape == want.shape
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    np.testing.assert_allclose(got, want, rtol=RTOL, atol=ATOL)


def _terrain(shape: tuple[int, int], seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w]
    z = 4 * np.sin(xx / 3.0) * np.cos(yy / 4.0) + rng.random(shape) * 2
    z[h // 3, w // 4] = np.nan  # a lone hole
    z[h // 2: h // 2 + 3, w - 6: w - 3] = np.nan  # a block of no data
    return z


CASES = {
    "square": ((24, 30), (1.0, 1.0)),
    "anisotropic-north-up": ((26, 22), (0.7, -1.3)),
    "negative-du": ((20, 28), (-2.0, 0.5)),
}


@pytest.fixture(scope="module", params=list(CASES), ids=list(CASES))
def hmap(request: pytest.FixtureRequest) -> hz.HorizonMap:
    shape, spacing = CASES[request.param]
    return fcol.horizon_map(_terrain(shape, 3), spacing, sectors=24)


def test_sky_view_factor_matches_reference(hmap: hz.HorizonMap) -> None:
    got = hmap.sky_view_factor()
    assert_close(got, ref.sky_view_factor(hmap))
    assert np.isnan(got[~np.isfinite(hmap.z)]).all()
    assert np.nanmin(got) > 0 and np.nanmax(got) <= 1 + 1e-12


def _skies(s: int) -> dict[str, object]:
    rng = np.random.default_rng(5)
    return {
        "uniform": 1.0,
        "uniform-3": 3.0,
        "mars": hz.mars_sky(1.0, 0.4),
        "mars-low-sun": hz.mars_sky(2.0, -0.05, power=8.0),
        "table": rng.random((s, 256)) * 2,
        "callable-zenith": lambda az, el: np.sin(el) ** 2,
        "dark": 0.0,
    }


@pytest.mark.parametrize("kind", list(_skies(3)))
def test_illumination_and_radiosity_match_reference(hmap: hz.HorizonMap, kind: str) -> None:
    sky = _skies(hmap.sectors)[kind]
    table = hmap._table(sky)  # type: ignore[arg-type]
    assert_close(hmap.illumination(sky), ref.illumination(hmap, table))  # type: ignore[arg-type]
    for albedo in (0.0, 0.35, 0.9):
        assert_close(hmap.radiosity(sky, albedo=albedo), ref.radiosity(hmap, table, albedo))  # type: ignore[arg-type]


def test_given_normals_and_float64_planes(hmap: hz.HorizonMap) -> None:
    rng = np.random.default_rng(2)
    n = rng.normal(size=hmap.z.shape + (3,))
    n[..., 2] = np.abs(n[..., 2]) + 0.2
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    n[1, 1] = np.nan
    table = hmap._table(hz.mars_sky(0.5, 0.9))
    assert_close(hmap.sky_view_factor(n), ref.sky_view_factor(hmap, n))
    assert_close(hmap.illumination(table, n), ref.illumination(hmap, table, n))
    assert_close(hmap.sun(2.0, 0.3, 0.05, normals=n), ref.sun(hmap, 2.0, 0.3, 0.05, normals=n))
    # a map whose planes are float64 (e.g. built by hand) is used as is
    h64 = hz.HorizonMap(hmap.elevation.astype(np.float64) + 1e-3, hmap.sector_indices, hmap.sectors, hmap.z, hmap.spacing, "given", 0.0)
    assert_close(h64.sky_view_factor(), ref.sky_view_factor(h64))
    assert_close(h64.shadow(0.3, 0.2, 0.1), ref.shadow(h64, 0.3, 0.2, 0.1))


SUNS = [
    (1.0, 0.3, 0.0),
    (1.0, 0.3, math.radians(0.27)),
    (-2.5, 0.05, 0.02),
    (4.0, 1.2, 0.2),  # high sun, wide disc
    (0.5, 0.4, 1.0),  # large radius
    (0.5, 0.4, 3.0),  # larger than a half-turn: clipped to one turn
    (0.2, -0.1, 0.0),  # below the horizontal
    (0.2, -0.1, 0.05),
    (3.0, -1.0, 0.3),  # well below
    (0.0, math.pi / 2, 0.0),  # zenith
    (0.0, math.pi / 2 - 1e-3, 0.01),
]


@pytest.mark.parametrize("az,el,r", SUNS)
def test_shadow_and_sun_match_reference(hmap: hz.HorizonMap, az: float, el: float, r: float) -> None:
    sh = hmap.shadow(az, el, r)
    assert_close(sh, ref.shadow(hmap, az, el, r))
    assert np.nanmin(sh) >= 0 and np.nanmax(sh) <= 1
    assert_close(hmap.sun(az, el, r), ref.sun(hmap, az, el, r))


@pytest.mark.parametrize("k", [0, 1, 5, 12, 23, 24, -3])
def test_point_sun_on_a_sector_border(hmap: hz.HorizonMap, k: int) -> None:
    s = hmap.sectors
    az = TAU * k / s  # exactly on the border: belongs to the sector it opens
    assert hmap.sector_of(az) == ref.sector_of(az, s) == k % s
    for el in (-0.05, 0.1, 0.35):
        assert_close(hmap.shadow(az, el), ref.shadow(hmap, az, el))
        plane = hmap.elevation[k % s].astype(np.float64)
        ok = np.isfinite(hmap.z)
        np.testing.assert_array_equal(hmap.shadow(az, el)[ok], (el > plane[ok]).astype(float))
    # a soft sun centred on the border spans both sectors
    assert_close(hmap.shadow(az, 0.2, 0.03), ref.shadow(hmap, az, 0.2, 0.03))


def test_sectors_subset_serves_the_sun() -> None:
    z = _terrain((22, 26), 9)
    s = 32
    full = fcol.horizon_map(z, (1.0, 1.5), sectors=s)
    az, el, r = 1.3, 0.25, 0.05
    k = full.sector_of(az)
    sub = fcol.horizon_map(z, (1.0, 1.5), sectors=s, sectors_subset=[k + 1, k - 1, k])
    for rr in (0.0, r):
        np.testing.assert_array_equal(sub.shadow(az, el, rr), full.shadow(az, el, rr))
        assert_close(sub.sun(az, el, rr), ref.sun(sub, az, el, rr))
    with pytest.raises(ValueError, match="sectors_subset"):
        sub.shadow(az, el, 0.5)  # the disc reaches sectors not computed
    with pytest.raises(ValueError, match="sectors_subset"):
        sub.shadow(az + math.pi, el)
    with pytest.raises(ValueError, match="every sector"):
        sub.sky_view_factor()
    with pytest.raises(ValueError, match="every sector"):
        sub.illumination(1.0)


def test_known_values() -> None:
    # a uniform horizon e0 on a flat point: D = cos² e0, I(L=1) = π D
    s = 32
    for e0 in (0.0, 0.3, 1.0):
        el = np.full((s, 3, 4), e0, np.float32)
        m = hz.HorizonMap(el, range(s), s, np.zeros((3, 4)), (1.0, 1.0), "given", 0.0)
        np.testing.assert_allclose(m.sky_view_factor(), np.cos(np.float64(np.float32(e0))) ** 2, rtol=1e-12)
        np.testing.assert_allclose(m.illumination(1.0), np.pi * np.cos(np.float64(np.float32(e0))) ** 2, rtol=1e-12)
        d = np.cos(np.float64(np.float32(e0))) ** 2
        np.testing.assert_allclose(m.radiosity(2.0, albedo=0.4), 0.4 * 2 * d / (1 - 0.4 * (1 - d)), rtol=1e-12)
    # half of a disc centred on the horizon is visible
    el = np.full((s, 2, 2), 0.5, np.float32)
    m = hz.HorizonMap(el, range(s), s, np.zeros((2, 2)), (1.0, 1.0), "given", 0.0)
    np.testing.assert_allclose(m.shadow(1.0, float(np.float32(0.5)), 0.01), 0.5, atol=1e-12)
    # a sun below the horizontal on an open plane: no sun term
    flat = fcol.horizon_map(np.zeros((6, 6)), sectors=16)
    assert (flat.sun(0.3, -0.1) == 0).all() and (flat.sun(0.3, -0.1, 0.05) == 0).all()


def test_bad_input(hmap: hz.HorizonMap) -> None:
    for kw, name in (({"sun_radius": -0.1}, "sun_radius"), ({"sun_radius": math.nan}, "sun_radius"),
                     ({"sun_azimuth": math.inf}, "sun_azimuth"), ({"sun_elevation": math.nan}, "sun_elevation")):
        args = {"sun_azimuth": 1.0, "sun_elevation": 0.3, "sun_radius": 0.0, **kw}
        with pytest.raises(ValueError, match=name):
            hmap.shadow(**args)
    with pytest.raises(TypeError, match="sun_elevation"):
        hmap.shadow(1.0, "high")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="normals"):
        hmap.sky_view_factor(np.zeros((3, 3, 3)))
    with pytest.raises(ValueError, match="normals"):
        hmap.sun(1.0, 0.3, normals=np.zeros(hmap.z.shape + (2,)))
    with pytest.raises(ValueError, match="albedo"):
        hmap.radiosity(1.0, albedo=1.0)
    with pytest.raises(ValueError, match="albedo"):
        hmap.radiosity(1.0, albedo=math.nan)
    with pytest.raises(ValueError, match="sky"):
        hmap.illumination(np.ones((3, 256)))
    with pytest.raises(ValueError, match="sky"):
        hmap.illumination(-1.0)
    with pytest.raises(ValueError, match="sky"):
        hmap.illumination(lambda az, el: np.full(az.shape, np.nan))


def test_thread_count_does_not_change_results() -> None:
    code = (
        "import numpy as np, sys, fcol\n"
        "from fcol import horizon as hz\n"
        "z = np.random.default_rng(4).random((33, 41)) * 9; z[3, 4] = np.nan\n"
        "m = fcol.horizon_map(z, (1.0, -0.8), sectors=20)\n"
        "out = [m.sky_view_factor(), m.illumination(hz.mars_sky(1.0, 0.3)), m.radiosity(2.0, 0.3),\n"
        "       m.shadow(0.7, 0.2, 0.1), m.sun(2.0, 0.4, 0.0)]\n"
        "sys.stdout.buffer.write(b''.join(a.tobytes() for a in out))\n"
    )
    outs = []
    for threads in ("1", "3"):
        env = dict(os.environ, RAYON_NUM_THREADS=threads)
        outs.append(subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, check=True).stdout)
    assert len(outs[0]) > 0 and outs[0] == outs[1]


def test_shade_terrain_uses_the_same_light() -> None:
    z = _terrain((18, 20), 1)
    hm = fcol.horizon_map(z, (1.0, 1.0), sectors=16)
    img = fcol.shade_terrain(horizon=hm, sun_azimuth=2.0, sun_elevation=0.4, sun_radius=0.01, sky=hz.mars_sky(1.0, 0.5), outputs="intensity")
    want = 0.75 * ref.sun(hm, 2.0, 0.4, 0.01) + 0.25 * ref.illumination(hm, hm.sky_table(hz.mars_sky(1.0, 0.5))) / np.pi
    want = np.where(np.isfinite(want), want, np.nan).astype(np.float32)[::-1]
    np.testing.assert_allclose(img.intensity, want, rtol=1e-6, equal_nan=True)
