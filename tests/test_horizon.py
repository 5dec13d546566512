"""Horizon maps: exactness of Stewart's algorithm against the O(n²)
definition, independent NumPy references for brute, cms and sweep, and the
edge cases of SPEC §5 (borders, narrow sectors, a lone spike, NaN holes)."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest

import fcol
from fcol import horizon as hz

TAU = 2 * np.pi


def bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float32).view(np.int32)


def assert_bit_equal(a: np.ndarray, b: np.ndarray) -> None:
    assert a.shape == b.shape
    same = bits(a) == bits(b)
    assert same.all(), f"{(~same).sum()} of {same.size} values differ"


# ---------------------------------------------------------------- references
def numpy_brute(z: np.ndarray, s: int, du: float = 1.0, dv: float = 1.0) -> np.ndarray:
    """§III word by word on an integer-index grid: sector by azimuth (a
    direction exactly on a shared border, possible only at multiples of 45°
    with |du| = |dv| or 90°, belongs to both sectors), elevation atan2(dz,
    (q − p)·r_i), maximum over every point of the sector."""
    h, w = z.shape
    ii, jj = np.mgrid[0:h, 0:w]
    ii, jj, zz = ii.ravel(), jj.ravel(), z.ravel().astype(np.float64)
    out = np.full((s, h * w), -np.pi / 2)
    cen = TAU * (np.arange(s) + 0.5) / s
    for p in range(h * w):
        if not np.isfinite(zz[p]):
            out[:, p] = np.nan
            continue
        di, dj = ii - ii[p], jj - jj[p]
        dx, dy = dj * du, di * dv
        ok = np.isfinite(zz) & ((di != 0) | (dj != 0))
        az = np.mod(np.arctan2(dy, dx), TAU)
        u = az * s / TAU
        sec = np.floor(u).astype(np.int64) % s
        # exact border: direction a multiple of 45° in world axes
        axis = (dx == 0) | (dy == 0)
        diag = np.abs(dx) == np.abs(dy)
        octant = np.rint(az / (np.pi / 4)).astype(np.int64) % 8
        on_border = (axis | diag) & ((octant * s) % 8 == 0)
        bidx = (octant * s // 8) % s
        for i in range(s):
            member = ok & (((sec == i) & ~on_border) | (on_border & ((bidx == i) | ((bidx - 1) % s == i))))
            if member.any():
                t = dx[member] * math.cos(cen[i]) + dy[member] * math.sin(cen[i])
                out[i, p] = np.max(np.arctan2(zz[member] - zz[p], t))
    return out.reshape(s, h, w)


def per_point_map(z: np.ndarray, s: int, value) -> np.ndarray:
    """The (s, h, w) map of ``value(rx, ry, i0, j0)`` (None: −π/2) for every
    sector (centre direction (rx, ry)) and point with data; NaN elsewhere."""
    h, w = z.shape
    out = np.full((s, h, w), -np.pi / 2)
    for i in range(s):
        g = TAU * (i + 0.5) / s
        rx, ry = math.cos(g), math.sin(g)
        for i0 in range(h):
            for j0 in range(w):
                if not np.isfinite(z[i0, j0]):
                    out[i, i0, j0] = np.nan
                    continue
                e = value(rx, ry, i0, j0)
                if e is not None:
                    out[i, i0, j0] = e
    return out


def column_crossings(z: np.ndarray, i0: int, j0: int, gc: float, gr: float) -> np.ndarray:
    """Elevations seen from (i0, j0) where the line stepping gc columns and
    gr rows per unit distance crosses the column lines of z (linear
    interpolation between the two samples bordering each crossing)."""
    h, w = z.shape
    if gc == 0:
        return np.array([])
    k = np.arange(1, w + 1)
    j = j0 + k * np.sign(gc)
    rho = i0 + k * (gr / abs(gc))
    good = (j >= 0) & (j < w) & (rho >= 0) & (rho <= h - 1)
    stop = np.argmin(good) if not good.all() else len(good)
    k, j, rho = k[:stop], j[:stop].astype(int), rho[:stop]
    r0 = np.floor(rho).astype(int)
    fr = rho - r0
    r1 = np.minimum(r0 + 1, h - 1)
    hh = np.where(fr == 0, z[r0, j], z[r0, j] * (1 - fr) + z[r1, j] * fr)
    t = k / abs(gc)
    return np.arctan2(hh - z[i0, j0], t)[np.isfinite(hh)]


def numpy_cms(z: np.ndarray, s: int, du: float, dv: float) -> np.ndarray:
    """Centre-line sampler: crossings with column and row lines (the column
    lines of z.T), linear interpolation between the two samples bordering
    each crossing."""

    def value(rx: float, ry: float, i0: int, j0: int) -> float | None:
        gc, gr = rx / du, ry / dv
        b = np.concatenate(
            [column_crossings(z, i0, j0, gc, gr), column_crossings(z.T, j0, i0, gr, gc)]
        )
        return b.max() if b.size else None

    return per_point_map(z, s, value)


def rust_round(x: np.ndarray) -> np.ndarray:
    return np.sign(x) * np.floor(np.abs(x) + 0.5)


def numpy_sweep(z: np.ndarray, s: int, du: float, dv: float) -> np.ndarray:
    """The documented line model by direct maximisation: the cells of the
    digital line (c + round(m·j), j) (or rows and columns swapped) ahead of
    each cell, at their distances w = (u, v)·r."""
    h, w = z.shape

    def value(rx: float, ry: float, i0: int, j0: int) -> float | None:
        gc, gr = rx / du, ry / dv
        if abs(gc) >= abs(gr):
            m = gr / gc
            line = i0 - rust_round(np.array(m * j0))
            jj = np.arange(w)
            rr = (line + rust_round(m * jj)).astype(int)
            ahead = (jj > j0) if gc > 0 else (jj < j0)
            cc = jj
        else:
            m = gc / gr
            line = j0 - rust_round(np.array(m * i0))
            rr = np.arange(h)
            cc = (line + rust_round(m * rr)).astype(int)
            ahead = (rr > i0) if gr > 0 else (rr < i0)
        sel = ahead & (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
        rr, cc = rr[sel], cc[sel]
        hq = z[rr, cc]
        ok = np.isfinite(hq)
        if not ok.any():
            return None
        t = (cc[ok] - j0) * du * rx + (rr[ok] - i0) * dv * ry
        return np.max(np.arctan(((hq[ok] - z[i0, j0]) / t)))

    return per_point_map(z, s, value)


# ---------------------------------------------------------------- exactness
@pytest.fixture(scope="module")
def grid64() -> np.ndarray:
    return np.random.default_rng(1).normal(size=(64, 64)).cumsum(0).cumsum(1)


@pytest.mark.parametrize("s", [8, 64, 256])
def test_stewart_equals_brute_grid64(grid64: np.ndarray, s: int) -> None:
    a = fcol.horizon_map(grid64, 1.0, sectors=s, method="stewart").elevation
    b = fcol.horizon_map(grid64, 1.0, sectors=s, method="brute").elevation
    assert_bit_equal(a, b)


@pytest.mark.parametrize("s", [8, 64, 256])
def test_stewart_equals_brute_integer_dem_plateaus(s: int) -> None:
    # Integer heights with plateaus: exact ties of elevation and many points
    # exactly on sector borders (0°, 45°, 90°, ... are borders for these s).
    rng = np.random.default_rng(s)
    z = (rng.integers(0, 4, size=(40, 40)).cumsum(0) // 3).astype(np.int16)
    z[10:20, 5:15] = 7
    a = fcol.horizon_map(z, sectors=s, method="stewart").elevation
    b = fcol.horizon_map(z, sectors=s, method="brute").elevation
    assert_bit_equal(a, b)


@pytest.mark.parametrize("s", [8, 64, 256])
def test_stewart_equals_brute_random_points(s: int) -> None:
    rng = np.random.default_rng(100 + s)
    pts = rng.choice(60 * 60, size=700, replace=False)
    x, y = (pts % 60).astype(float), (pts // 60).astype(float)
    z = rng.integers(0, 5, size=700).astype(float)
    a = fcol.horizon_points(x, y, z, sectors=s, method="stewart")
    b = fcol.horizon_points(x, y, z, sectors=s, method="brute")
    assert_bit_equal(a, b)
    # and at irrational positions
    x2, y2 = rng.random(500) * 10, rng.random(500) * 7
    z2 = rng.random(500)
    assert_bit_equal(
        fcol.horizon_points(x2, y2, z2, sectors=s, method="stewart"),
        fcol.horizon_points(x2, y2, z2, sectors=s, method="brute"),
    )


def test_stewart_equals_brute_anisotropic_north_up_nan_curvature() -> None:
    rng = np.random.default_rng(5)
    z = rng.random((30, 41)) * 100
    z[5:9, 10:13] = np.nan
    kw = dict(spacing=(30.0, -20.0), sectors=64, earth_curvature=True, earth_radius=5e3)
    a = fcol.horizon_map(z, method="stewart", **kw).elevation
    b = fcol.horizon_map(z, method="brute", **kw).elevation
    assert_bit_equal(a, b)
    assert np.isnan(a[:, 5:9, 10:13]).all()
    assert not np.isnan(np.delete(a.reshape(64, -1), np.flatnonzero(np.isnan(z)), axis=1)).any()


def test_brute_follows_the_definition() -> None:
    rng = np.random.default_rng(9)
    z = rng.integers(0, 6, size=(14, 13)).astype(float)
    z[3, 4] = np.nan
    for s in (8, 12):
        ref = numpy_brute(z, s)
        got = fcol.horizon_map(z, sectors=s, method="brute").elevation
        np.testing.assert_allclose(got, ref.astype(np.float32), rtol=0, atol=2e-7)
        assert (np.isnan(got) == np.isnan(ref)).all()


def test_spike_shadows_its_whole_sector() -> None:
    # Stewart Fig. 8: 100×100 flat, one sample of height 50 near a corner.
    n, s = 100, 64
    z = np.zeros((n, n))
    si, sj = n - 6, 5
    z[si, sj] = 50.0
    st = fcol.horizon_map(z, sectors=s, method="stewart").elevation
    cm = fcol.horizon_map(z, sectors=s, method="cms").elevation
    ii, jj = np.mgrid[0:n, 0:n]
    dx, dy = sj - jj, si - ii
    az = np.mod(np.arctan2(dy, dx), TAU)
    sec = np.floor(az * s / TAU).astype(int) % s
    away = (dx != 0) | (dy != 0)
    e_st = np.take_along_axis(st, sec[None], 0)[0]
    e_cm = np.take_along_axis(cm, sec[None], 0)[0]
    spike = np.arctan2(50.0, np.hypot(dx, dy))
    # the wedge maximum sees the spike from every point of its sector
    assert (e_st[away] > 0).all()
    seen_cms = (e_cm[away] > 0).mean()
    assert seen_cms < 0.9  # the centre line misses it for many points
    # nothing else is higher than the flat plane
    assert (e_st[away] <= spike[away] / np.cos(np.pi / s) + 1e-6).all()


def test_flat_plane_and_border_rule() -> None:
    z = np.full((12, 15), 3.5)
    for m in ("stewart", "brute", "cms", "sweep"):
        e = fcol.horizon_map(z, (2.0, 1.0), sectors=8, method=m).elevation
        inner = e[:, 1:-1, 1:-1]
        assert (inner == 0).all(), m
        # no terrain beyond the grid: sector 0 (0°..45°) of the last column
        # and sector 2 (90°..135°) of the top row look off the grid
        assert (e[0, :, -1] == np.float32(-np.pi / 2)).all(), m
        assert (e[2, -1, :] == np.float32(-np.pi / 2)).all(), m


def test_nan_is_never_a_source() -> None:
    rng = np.random.default_rng(2)
    z = rng.random((20, 20))
    zn = z.copy()
    zn[10, 10] = np.nan
    zlow = z.copy()
    zlow[10, 10] = -1e9  # a pit casts nothing either
    for m in ("stewart", "cms", "sweep"):
        a = fcol.horizon_map(zn, sectors=16, method=m).elevation
        b = fcol.horizon_map(zlow, sectors=16, method=m).elevation
        mask = np.ones((20, 20), bool)
        mask[9:12, 9:12] = False  # cms/sweep interpolate next to the hole
        if m == "stewart":
            mask = np.isfinite(zn)
        np.testing.assert_array_equal(a[:, mask], b[:, mask])
        assert np.isnan(a[:, 10, 10]).all()


@pytest.mark.parametrize(
    "method, reference, seed, shape, scale, hole, cases, atol",
    [
        # cms: the NumPy centre-line sampler
        ("cms", numpy_cms, 4, (17, 21), 5, (4, 6), ((8, (1.0, 1.0)), (12, (1.5, -0.7))), 3e-7),
        # sweep: the line model
        ("sweep", numpy_sweep, 6, (15, 19), 3, (7, 3), ((8, (1.0, 1.0)), (10, (0.6, -1.3))), 5e-7),
    ],
    ids=["cms", "sweep"],
)
def test_grid_method_matches_numpy_reference(
    method, reference, seed, shape, scale, hole, cases, atol
) -> None:
    rng = np.random.default_rng(seed)
    z = rng.random(shape) * scale
    z[hole] = np.nan
    for s, (du, dv) in cases:
        got = fcol.horizon_map(z, (du, dv), sectors=s, method=method).elevation
        ref = reference(z, s, du, dv)
        np.testing.assert_allclose(got, ref.astype(np.float32), rtol=0, atol=atol)


def test_sweep_is_exact_on_the_centre_line() -> None:
    # Along the grid axes the digital lines are the centre lines themselves,
    # so sweep and cms see the same samples.
    rng = np.random.default_rng(8)
    z = rng.random((25, 25))
    sw = fcol.horizon_map(z, sectors=4, method="sweep").elevation
    cm = fcol.horizon_map(z, sectors=4, method="cms").elevation
    # sectors=4 centres are diagonals: the centre line hits nodes only
    np.testing.assert_allclose(sw, cm, atol=3e-7)


def test_near_vertex_adds_centre_line_samples() -> None:
    rng = np.random.default_rng(10)
    z = rng.random((24, 24)) * 4
    s = 256
    plain = fcol.horizon_map(z, sectors=s, method="stewart").elevation
    nv = fcol.horizon_map(z, sectors=s, method="stewart", near_vertex=True).elevation
    nvb = fcol.horizon_map(z, sectors=s, method="brute", near_vertex=True).elevation
    assert_bit_equal(nv, nvb)
    assert (nv >= plain).all() and (nv > plain).any()
    cms = fcol.horizon_map(z, sectors=s, method="cms").elevation
    assert (nv <= np.maximum(plain, cms)).all()


def test_sectors_subset_and_geographic_dem() -> None:
    cbook = pytest.importorskip("matplotlib.cbook")
    dem = cbook.get_sample_data("jacksboro_fault_dem.npz")
    z = dem["elevation"][::4, ::4]
    ext = (dem["xmin"], dem["xmax"], dem["ymin"], dem["ymax"])
    full = fcol.horizon_map(z, extent=ext, geographic=True, sectors=16, method="sweep")
    sub = fcol.horizon_map(z, extent=ext, geographic=True, sectors=16, method="sweep", sectors_subset=[3, 11])
    assert_bit_equal(sub.elevation, full.elevation[[3, 11]])
    du, dv = full.spacing
    assert 250 < du < 320 and -380 < dv < -360  # metres at 36.6° N, north-up
    flat_earth = fcol.horizon_map(z, extent=ext, geographic=True, sectors=16, method="sweep", earth_curvature=False)
    assert (full.elevation <= flat_earth.elevation + 1e-7).all()
    svf = full.sky_view_factor()
    assert 0.5 < np.nanmin(svf) and np.nanmax(svf) <= 1.0 + 1e-9


def test_any_real_dtype() -> None:
    z = (np.arange(36).reshape(6, 6) % 5).astype(np.uint8)
    ref = fcol.horizon_map(z.astype(np.float64), sectors=8).elevation
    for dt in (np.int32, np.float32, np.int64, np.uint16):
        assert_bit_equal(fcol.horizon_map(z.astype(dt), sectors=8).elevation, ref)


def test_bad_input() -> None:
    z = np.zeros((5, 5))
    with pytest.raises(ValueError, match="sectors"):
        fcol.horizon_map(z, sectors=2)
    with pytest.raises(ValueError, match="method"):
        fcol.horizon_map(z, method="fast")
    with pytest.raises(TypeError, match="z"):
        fcol.horizon_map(z.astype(complex))
    with pytest.raises(ValueError, match="z"):
        fcol.horizon_map(np.zeros((2, 2, 2)))
    with pytest.raises(ValueError, match="max_distance"):
        fcol.horizon_map(z, method="stewart", max_distance=-3.0)
    with pytest.raises(ValueError, match="spacing"):
        fcol.horizon_map(z, spacing=(0.0, 1.0))
    with pytest.raises(ValueError, match="sectors_subset"):
        fcol.horizon_map(z, sectors=8, sectors_subset=[8])
    for method in ("stewart", "cms", "brute", "sweep"):
        with pytest.raises(ValueError, match="sectors_subset: sector 2 is named twice"):
            fcol.horizon_map(z, sectors=8, method=method, sectors_subset=[2, 5, 2])
    with pytest.raises(ValueError, match="latitude"):
        fcol.horizon_map(z, spacing=1e-3, geographic=True)
    with pytest.raises(TypeError, match="progress"):
        fcol.horizon_map(z, progress="yes")


def test_max_distance() -> None:
    z = np.zeros((30, 30))
    z[:, 25] = 10.0  # a wall
    for m in ("stewart", "brute", "cms", "sweep"):
        near = fcol.horizon_map(z, sectors=8, method=m, max_distance=5.0).elevation
        far = fcol.horizon_map(z, sectors=8, method=m).elevation
        assert far[0, 15, 10] > 0 and near[0, 15, 10] == 0.0, m
        assert near[0, 15, 22] > 0, m


@pytest.mark.parametrize("s", [8, 64])
def test_stewart_max_distance_equals_brute(s: int) -> None:
    rng = np.random.default_rng(5)
    z = np.cumsum(rng.normal(size=(21, 26)), axis=1) + rng.integers(0, 4, size=(21, 26))
    z[3, 4] = np.nan
    for d in (1.0, 2.5, 7.0, 40.0):
        kw = dict(spacing=(1.0, -1.5), sectors=s, max_distance=d)
        a = fcol.horizon_map(z, method="stewart", **kw).elevation
        b = fcol.horizon_map(z, method="brute", **kw).elevation
        assert_bit_equal(a, b)
    x, y = rng.integers(0, 30, size=(2, 200)).astype(float)
    keep = np.unique(x * 100 + y, return_index=True)[1]
    x, y = x[keep], y[keep]
    zp = rng.integers(0, 6, size=x.size).astype(float)
    for d in (1.5, 4.0, 12.0):
        a = fcol.horizon_points(x, y, zp, sectors=s, method="stewart", max_distance=d)
        b = fcol.horizon_points(x, y, zp, sectors=s, method="brute", max_distance=d)
        assert_bit_equal(a, b)


def test_progress_callback_and_silence(capsys: pytest.CaptureFixture[str]) -> None:
    calls = []
    fcol.horizon_map(np.zeros((40, 40)), sectors=8, progress=lambda d, t: calls.append((d, t)))
    assert calls and calls[-1][0] == calls[-1][1] == 8 * 1600
    fcol.horizon_map(np.zeros((40, 40)), sectors=8)
    out = capsys.readouterr()
    assert out.out == "" and out.err == ""


def test_thread_count_does_not_change_results(tmp_path: "os.PathLike[str]") -> None:
    code = (
        "import numpy as np, fcol, sys;"
        "z=np.random.default_rng(3).random((40,40));"
        "sys.stdout.buffer.write(fcol.horizon_map(z,sectors=16).elevation.tobytes())"
    )
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    one = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, check=True).stdout
    z = np.random.default_rng(3).random((40, 40))
    assert one == fcol.horizon_map(z, sectors=16).elevation.tobytes()


@pytest.mark.parametrize("method", ["stewart", "cms", "brute", "sweep"])
def test_out_receives_the_map(method: str) -> None:
    # Into a given array, bit for bit the allocating call's values, whatever
    # the array held (NaN, an earlier map); with sectors_subset, max_distance,
    # curvature and no-data cells too.
    rng = np.random.default_rng(12)
    z = rng.random((14, 17)) * 4
    z[3, 5] = np.nan
    cases = [
        dict(sectors=8),
        dict(sectors=12, sectors_subset=[7, 2, 11], max_distance=5.0),
        dict(sectors=8, spacing=(1.0, -1.5), earth_curvature=True, refraction=0.1, earth_radius=50.0),
    ]
    for kw in cases:
        want = fcol.horizon_map(z, method=method, **kw).elevation
        for fill in (np.nan, 9.0):
            buf = np.full(want.shape, fill, np.float32)
            hm = fcol.horizon_map(z, method=method, out=buf, **kw)
            assert hm.elevation is buf
            assert_bit_equal(buf, want)
        # the same buffer again, holding the map of other heights
        fcol.horizon_map(z[::-1].copy(), method=method, out=buf, **kw)
        assert not np.array_equal(buf, want, equal_nan=True)
        fcol.horizon_map(z, method=method, out=buf, **kw)
        assert_bit_equal(buf, want)


def test_out_bad_arrays_raise() -> None:
    z = np.random.default_rng(13).random((6, 7))
    good = np.zeros((8, 6, 7), np.float32)
    for bad, exc, what in [
        ([[[0.0] * 7] * 6] * 8, TypeError, "list"),
        (np.zeros((8, 6, 7), np.float64), TypeError, "dtype"),
        (np.zeros((8, 6, 7), np.int32), TypeError, "dtype"),
        (np.zeros((4, 6, 7), np.float32), ValueError, "shape"),
        (np.zeros((8, 7, 6), np.float32), ValueError, "shape"),
        (np.zeros((8, 42), np.float32), ValueError, "shape"),
        (np.zeros((8, 6, 14), np.float32)[:, :, ::2], ValueError, "C-contiguous"),
        (np.zeros((7, 6, 8), np.float32).transpose(2, 1, 0), ValueError, "C-contiguous"),
    ]:
        with pytest.raises(exc, match=f"out: .*{what}"):
            fcol.horizon_map(z, sectors=8, out=bad)
    ro = good.copy()
    ro.flags.writeable = False
    with pytest.raises(ValueError, match="out: must be writable"):
        fcol.horizon_map(z, sectors=8, out=ro)
    assert (ro == 0).all()
    # the shape follows sectors_subset
    with pytest.raises(ValueError, match="out: .*shape"):
        fcol.horizon_map(z, sectors=8, sectors_subset=[1, 2], out=good)
    view = good[:2]  # a C-contiguous view will do
    hm = fcol.horizon_map(z, sectors=8, sectors_subset=[1, 2], out=view)
    assert hm.elevation is view
    assert_bit_equal(good[:2], fcol.horizon_map(z, sectors=8, sectors_subset=[1, 2]).elevation)
    assert (good[2:] == 0).all()


# ---------------------------------------------------------------- light (§VI)
def _uniform_map(e0: float, s: int = 32, shape=(4, 5)) -> hz.HorizonMap:
    el = np.full((s,) + shape, e0, np.float32)
    return hz.HorizonMap(el, range(s), s, np.zeros(shape), (1.0, 1.0), "given", 0.0)


def test_sky_view_factor_closed_form() -> None:
    for e0 in (0.0, 0.3, 1.0):
        svf = _uniform_map(e0).sky_view_factor()
        np.testing.assert_allclose(svf, np.cos(np.float32(e0)) ** 2, rtol=1e-6)
    # an open plane: sectors looking off the grid count as open sky
    z = np.zeros((10, 10))
    svf = fcol.horizon_map(z, sectors=16).sky_view_factor()
    np.testing.assert_allclose(svf, 1.0)


def test_illumination_uniform_and_tables() -> None:
    hmap = _uniform_map(0.4)
    i = hmap.illumination(1.0)
    np.testing.assert_allclose(i, np.pi * hmap.sky_view_factor(), rtol=1e-5)
    # a table equal to the sampled callable gives the same light
    sky = hz.mars_sky(1.0, 0.5)
    np.testing.assert_allclose(hmap.illumination(sky), hmap.illumination(hmap.sky_table(sky)))
    # the sun-centred Mars sky is brighter where the sun's sector is open
    el = np.zeros((32, 1, 2), np.float32)
    k = hmap.sector_of(1.0)
    el[[(k + d) % 32 for d in range(-2, 3)], 0, 1] = 1.2  # hide the sun's lobe
    two = hz.HorizonMap(el, range(32), 32, np.zeros((1, 2)), (1.0, 1.0), "given", 0.0)
    lit = two.illumination(sky)
    assert lit[0, 0] > 1.5 * lit[0, 1]
    r = two.radiosity(1.0, albedo=0.4)
    assert (r > 0).all() and r[0, 0] > r[0, 1]


def test_shadows_hard_and_soft() -> None:
    hmap = _uniform_map(0.5)
    assert (hmap.shadow(1.0, 0.6) == 1).all() and (hmap.shadow(1.0, 0.4) == 0).all()
    # sun centred on the horizon: half its disc is visible
    np.testing.assert_allclose(hmap.shadow(1.0, np.float32(0.5), sun_radius=0.01), 0.5, atol=1e-6)
    np.testing.assert_allclose(hmap.shadow(1.0, 0.52, sun_radius=0.01), 1.0)
    mid = hmap.shadow(1.0, 0.505, sun_radius=0.01)
    # circular segment of height 0.005 below the horizon on a disc of radius 0.01
    d = 0.005 - (0.5 - np.float32(0.5))
    seg = (0.01**2 * math.acos(d / 0.01) - d * math.sqrt(0.01**2 - d**2)) / (math.pi * 0.01**2)
    np.testing.assert_allclose(mid, 1 - seg, rtol=1e-4)


def test_spike_shadow_from_horizons() -> None:
    z = np.zeros((40, 40))
    z[30, 8] = 20.0
    hmap = fcol.horizon_map(z, sectors=64)
    # sun low in the direction of the spike from the far corner
    az = math.atan2(30 - 2, 8 - 35)
    sh = hmap.shadow(az, math.radians(10))
    assert sh[2, 35] == 0.0 and sh[35, 2] == 1.0


def test_shade_terrain_from_above() -> None:
    z = np.add.outer(np.linspace(0, 5, 16), np.zeros(12))  # rises towards +v
    img = fcol.shade_terrain(z, (1.0, 2.0), sectors=16, outputs=("rgb", "intensity", "uv", "mask"), sun_azimuth=math.pi / 2, sun_elevation=0.3)
    assert isinstance(img, fcol.Image) and img.rgb.shape == (16, 12, 3)
    # row 0 is the largest v (seen from above, +v up)
    assert img.uv[0, 0, 1] == pytest.approx(30.0) and img.uv[-1, 0, 1] == 0.0
    hmap = fcol.horizon_map(z, (1.0, 2.0), sectors=16)
    again = fcol.shade_terrain(horizon=hmap, sun_azimuth=math.pi / 2, sun_elevation=0.3, outputs="intensity")
    np.testing.assert_array_equal(again.intensity, img.intensity)
    assert img.mask.all()


@pytest.mark.parametrize("scale", [1e-6, 0.1, 1e6])
def test_scale_invariance_and_diagonal_borders(scale: float) -> None:
    # Samples on grid diagonals lie exactly on the 45° sector borders for any
    # spacing (j·0.1 − i·0.1 is not exact in floating point, the membership
    # keys are), so which sectors are empty does not depend on the scale.
    z = np.random.default_rng(0).random((20, 20))
    ref = fcol.horizon_map(z, 1.0, sectors=64).elevation
    got = fcol.horizon_map(z * scale, scale, sectors=64).elevation
    np.testing.assert_array_equal(got == np.float32(-np.pi / 2), ref == np.float32(-np.pi / 2))
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-6)
    assert_bit_equal(got, fcol.horizon_map(z * scale, scale, sectors=64, method="brute").elevation)
