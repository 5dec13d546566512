"""fcol.raster lines and polygons against scikit-image and brute force."""

from __future__ import annotations

import doctest

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skimage import draw

import fcol
from fcol import raster

# ---------------------------------------------------------------- line


def _same_line(seg: tuple[int, int, int, int]) -> None:
    rs, cs = draw.line(*seg)
    rf, cf = raster.line(*seg)
    assert rf.dtype == np.int64 and cf.dtype == np.int64
    np.testing.assert_array_equal(rf, rs)
    np.testing.assert_array_equal(cf, cs)


def test_line_equals_skimage_on_10000_random_segments() -> None:
    rng = np.random.default_rng(1)
    segs = rng.integers(-300, 300, size=(10_000, 4))
    # Bias a quarter towards short segments and exact diagonals/axes.
    segs[:1000] = rng.integers(-3, 4, size=(1000, 4))
    segs[1000:1500, 2] = segs[1000:1500, 0] + (segs[1000:1500, 3] - segs[1000:1500, 1])
    segs[1500:2000, 2] = segs[1500:2000, 0]
    segs[2000:2500, 3] = segs[2000:2500, 1]
    checked = 0
    for seg in segs.tolist():
        _same_line(tuple(seg))
        checked += 1
    assert checked == 10_000


@settings(max_examples=500, deadline=None)
@given(st.tuples(*[st.integers(-10_000, 10_000)] * 2, *[st.integers(-60, 60)] * 2))
def test_line_equals_skimage_property(t: tuple[int, int, int, int]) -> None:
    r0, c0, dr, dc = t
    seg = (r0, c0, r0 + dr, c0 + dc)
    _same_line(seg)


def test_line_octants_and_degenerate() -> None:
    for seg in [(0, 0, 0, 0), (3, 3, 3, 9), (3, 9, 3, 3), (1, 4, 9, 4), (9, 4, 1, 4)]:
        _same_line(seg)
    rr, cc = raster.line(7, -2, 7, -2)
    assert rr.tolist() == [7] and cc.tolist() == [-2]
    # All eight octants from the origin, both directions.
    for dr, dc in [(2, 5), (5, 2), (-2, 5), (-5, 2), (2, -5), (5, -2), (-2, -5), (-5, -2)]:
        _same_line((0, 0, dr, dc))
        _same_line((dr, dc, 0, 0))


def test_line_tie_rule_is_direction_dependent() -> None:
    # (0,0)->(1,2): the ideal line passes through the midpoint (0.5, 1):
    # the step is diagonal from the start, so reversing the direction moves
    # the middle pixel (documented tie rule, as scikit-image).
    assert raster.line(0, 0, 1, 2)[0].tolist() == [0, 1, 1]
    assert raster.line(1, 2, 0, 0)[0].tolist() == [1, 0, 0]


# ---------------------------------------------------------------- line_aa


def _minor_offset(seg: tuple[int, int, int, int], r: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, int, float]:
    """Signed offset of pixels from the ideal line along the minor axis."""
    r0, c0, r1, c1 = seg
    dr, dc = r1 - r0, c1 - c0
    n = max(abs(dr), abs(dc))
    if abs(dr) > abs(dc):
        delta = c - (c0 + dc * (r - r0) / dr)
    else:
        delta = r - (r0 + dr * (c - c0) / dc)
    return delta, n, float(np.hypot(dr, dc))


def test_line_aa_against_skimage() -> None:
    """Exact relation to scikit-image's line_aa (Zingl), pixel by pixel.

    With delta the minor-axis offset of a pixel from the ideal line, n the
    major extent and L the length: fcol gives 1 - |delta| to the two pixels
    straddling the line (|delta| < 1), scikit-image gives 1 - |delta| n / L to
    those and to some pixels with 1 <= |delta| < L / n. Hence (a) fcol's
    pixels are a subset of scikit-image's, (b) on shared pixels
    1 - sk = (1 - fcol) n / L, (c) the extra pixels have |delta| >= 1, and
    (d) totals: fcol = n + 1 <= sk <= (n + 1)(3 - 2 n / L).
    """
    rng = np.random.default_rng(2)
    segs = rng.integers(-80, 80, size=(1500, 4))
    segs[:300, 2] = segs[:300, 0] + (segs[:300, 3] - segs[:300, 1])  # diagonals
    segs[300:400, 2] = segs[300:400, 0]  # horizontal
    for seg in map(tuple, segs.tolist()):
        rf, cf, vf = raster.line_aa(*seg)
        rs, cs, vs = draw.line_aa(*seg)
        n = max(abs(seg[2] - seg[0]), abs(seg[3] - seg[1]))
        assert abs(vf.sum() - (n + 1)) <= 1e-9 * (n + 1)
        assert np.all((vf > 0) & (vf <= 1))
        if n == 0:
            assert (rf.tolist(), cf.tolist(), vf.tolist()) == ([seg[0]], [seg[1]], [1.0])
            continue
        key_s = rs * 100_000 + cs
        key_f = rf * 100_000 + cf
        assert len(np.unique(key_s)) == len(key_s) and len(np.unique(key_f)) == len(key_f)
        shared = np.isin(key_s, key_f)
        assert shared.sum() == len(key_f)  # (a)
        order = np.argsort(key_s[shared])
        fo = np.argsort(key_f)
        _, n_, L = _minor_offset(seg, rf, cf)
        np.testing.assert_allclose(1 - vs[shared][order], (1 - vf[fo]) * n_ / L, rtol=0, atol=1e-12)  # (b)
        d_extra, _, _ = _minor_offset(seg, rs[~shared], cs[~shared])
        assert np.all(np.abs(d_extra) >= 1 - 1e-12)  # (c)
        np.testing.assert_allclose(vs[~shared], 1 - np.abs(d_extra) * n_ / L, rtol=0, atol=1e-12)
        assert n + 1 - 1e-9 <= vs.sum() <= (n + 1) * (3 - 2 * n / L) + 1e-9  # (d)


# ---------------------------------------------------------------- polygon


def _star_polygon(rng: np.random.Generator, m: int, centre: float, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """A random simple (star-shaped, generally concave) polygon."""
    t = np.sort(rng.uniform(0, 2 * np.pi, m))
    rad = radius * rng.uniform(0.2, 1.0, m)
    return centre + rad * np.sin(t), centre + rad * np.cos(t)


def _pairs(r: np.ndarray, c: np.ndarray) -> np.ndarray:
    return np.stack([r, c], axis=1)


def test_polygon_equals_skimage_on_random_simple_polygons() -> None:
    rng = np.random.default_rng(3)
    for k in range(400):
        m = int(rng.integers(3, 12))
        rows, cols = _star_polygon(rng, m, rng.uniform(-5, 40), rng.uniform(1, 30))
        if k % 4 == 0:  # convex
            t = np.sort(rng.uniform(0, 2 * np.pi, m))
            rows, cols = 20 + 15 * np.sin(t), 20 + 15 * np.cos(t)
        shape = None if k % 3 else (int(rng.integers(5, 40)), int(rng.integers(5, 40)))
        rf, cf = raster.polygon(rows, cols, shape)
        rs, cs = draw.polygon(rows, cols, shape)
        np.testing.assert_array_equal(_pairs(rf, cf), _pairs(rs, cs))
        rn, cn = raster.polygon(rows, cols, shape, rule="nonzero")
        np.testing.assert_array_equal(_pairs(rn, cn), _pairs(rf, cf))  # simple: rules agree


def _on_segment(pr: np.ndarray, pc: np.ndarray, a: tuple[int, int], b: tuple[int, int]) -> np.ndarray:
    """Exact (integer) test of pixel centres lying on segment a-b."""
    cross = (b[0] - a[0]) * (pc - a[1]) - (b[1] - a[1]) * (pr - a[0])
    within = (
        (np.minimum(a[0], b[0]) <= pr) & (pr <= np.maximum(a[0], b[0]))
        & (np.minimum(a[1], b[1]) <= pc) & (pc <= np.maximum(a[1], b[1]))
    )
    return (cross == 0) & within


def test_polygon_integer_vertices_differ_from_skimage_only_on_the_boundary() -> None:
    """scikit-image fills the closed polygon (centres on any edge are in);
    fcol follows the notes (interior centres, plus those on top and left
    edges). Exactly: skimage = fcol ∪ (centres on the outline)."""
    rng = np.random.default_rng(4)
    tested = 0
    for _ in range(200):
        m = int(rng.integers(3, 9))
        rows, cols = _star_polygon(rng, m, 15.0, 12.0)
        rows, cols = np.round(rows).astype(np.int64), np.round(cols).astype(np.int64)
        # Rounding can fold the outline back on itself (a repeated vertex or
        # an edge doubling back): no longer simple, skip it.
        e = np.stack([rows - np.roll(rows, 1), cols - np.roll(cols, 1)], 1)
        en = np.roll(e, -1, axis=0)
        cross = e[:, 0] * en[:, 1] - e[:, 1] * en[:, 0]
        dot = (e * en).sum(1)
        if len(set(zip(rows.tolist(), cols.tolist()))) < m or np.any((cross == 0) & (dot < 0)):
            continue
        tested += 1
        rf, cf = raster.polygon(rows, cols)
        rs, cs = draw.polygon(rows, cols)
        gr, gc = np.mgrid[0:40, 0:40]
        gr, gc = gr.ravel(), gc.ravel()
        on = np.zeros(gr.shape, bool)
        for i in range(m):
            on |= _on_segment(gr, gc, (rows[i - 1], cols[i - 1]), (rows[i], cols[i]))
        img_f = np.zeros((40, 40), bool)
        img_f[rf, cf] = True
        img_s = np.zeros((40, 40), bool)
        img_s[rs, cs] = True
        img_on = on.reshape(40, 40)
        np.testing.assert_array_equal(img_s, img_f | img_on)
    assert tested >= 100


def test_polygon_square_boundary_rule() -> None:
    # Centres on the top and left edges are in, on bottom and right out.
    rr, cc = raster.polygon([1, 1, 3, 3], [1, 3, 3, 1])
    assert _pairs(rr, cc).tolist() == [[1, 1], [1, 2], [2, 1], [2, 2]]


def _winding_brute_force(rows: np.ndarray, cols: np.ndarray, h: int, w: int) -> np.ndarray:
    """Winding number of every pixel centre by a ray towards +col, one edge
    at a time (edges cover rows y0 <= y < y1; crossings strictly right)."""
    y, x = np.mgrid[0:h, 0:w].astype(float)
    wind = np.zeros((h, w), np.int64)
    for i in range(len(rows)):
        r0, c0, r1, c1 = rows[i - 1], cols[i - 1], rows[i], cols[i]
        if r0 == r1:
            continue
        lo, hi = min(r0, r1), max(r0, r1)
        spans = (lo <= y) & (y < hi)
        xc = c0 + (c1 - c0) * (y - r0) / (r1 - r0)
        wind += np.where(spans & (xc > x), 1 if r1 > r0 else -1, 0)
    return wind


@pytest.mark.parametrize("seed", range(6))
def test_polygon_fill_rules_against_winding_number(seed: int) -> None:
    rng = np.random.default_rng(10 + seed)
    m = 5 + seed
    rows, cols = rng.uniform(0, 60, m), rng.uniform(0, 60, m)  # self-crossing
    wind = _winding_brute_force(rows, cols, 61, 61)
    for rule, expect in [("evenodd", wind % 2 != 0), ("nonzero", wind != 0)]:
        img = np.zeros((61, 61), bool)
        rr, cc = raster.polygon(rows, cols, rule=rule)
        img[rr, cc] = True
        np.testing.assert_array_equal(img, expect, err_msg=rule)


def test_pentagram_nonzero_fills_the_centre() -> None:
    t = np.pi * (0.5 + 0.8 * np.arange(5))
    rows, cols = 50 - 40 * np.sin(t), 50 + 40 * np.cos(t)
    wind = _winding_brute_force(rows, cols, 101, 101)
    assert wind[50, 50] in (2, -2)
    eo = np.zeros((101, 101), bool)
    nz = np.zeros((101, 101), bool)
    eo[raster.polygon(rows, cols)] = True
    nz[raster.polygon(rows, cols, rule="nonzero")] = True
    assert nz[50, 50] and not eo[50, 50]
    np.testing.assert_array_equal(nz & ~eo, np.abs(wind) == 2)  # exactly the pentagon
    np.testing.assert_array_equal(eo, wind % 2 != 0)


def test_polygon_clipping_and_negative_coordinates() -> None:
    rows, cols = np.array([-10.0, -10, 30, 30]), np.array([-10.0, 50, 50, -10])
    rr, cc = raster.polygon(rows, cols)
    assert rr.min() == 0 and cc.min() == 0 and rr.max() == 29 and cc.max() == 49
    rr, cc = raster.polygon(rows, cols, shape=(8, 9, 3))
    assert rr.max() == 7 and cc.max() == 8 and len(rr) == 72
    rs, cs = draw.polygon(rows, cols, (8, 9, 3))
    np.testing.assert_array_equal(_pairs(rr, cc), _pairs(rs, cs))


# ---------------------------------------------------------------- bad input


def test_line_bad_input() -> None:
    with pytest.raises(ValueError, match="budget"):
        raster.line(0, 0, 0, 10**12)
    with pytest.raises(ValueError, match="budget"):
        raster.line_aa(-(2**62), 0, 2**62, 5)
    with pytest.raises(TypeError, match="r1"):
        raster.line(0, 0, float("nan"), 3)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="c0"):
        raster.line_aa(0, 1.5, 2, 3)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="r0"):
        raster.line(True, 0, 2, 3)
    with pytest.raises(ValueError, match="r1"):
        raster.line(0, 0, 2**70, 3)
    # NumPy integers are fine.
    assert raster.line(np.int32(0), np.int64(0), np.uint8(2), 2)[0].tolist() == [0, 1, 2]


def test_polygon_bad_input() -> None:
    with pytest.raises(ValueError, match="rows"):
        raster.polygon([0, 1, np.nan], [0, 1, 2])
    with pytest.raises(ValueError, match="cols"):
        raster.polygon([0, 1, 2], [0, 1, np.inf])
    with pytest.raises(ValueError, match="cols"):
        raster.polygon([0, 1, 2], [0, 1])
    with pytest.raises(ValueError, match="rows"):
        raster.polygon(np.zeros((3, 2)), np.zeros(3))
    with pytest.raises(TypeError, match="rows"):
        raster.polygon(np.array([1j, 2, 3]), [0, 1, 2])
    with pytest.raises(TypeError, match="cols"):
        raster.polygon([0, 1, 2], ["a", "b", "c"])
    with pytest.raises(ValueError, match="rule"):
        raster.polygon([0, 1, 2], [0, 1, 2], rule="winding")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="shape"):
        raster.polygon([0, 1, 2], [0, 1, 2], shape=(5,))
    with pytest.raises(TypeError, match="shape"):
        raster.polygon([0, 1, 2], [0, 1, 2], shape=(5.5, 3))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="budget"):
        raster.polygon([0, 1e9, 1e9], [0, 0, 1e9])
    # Huge but clipped: fine, and fast.
    rr, cc = raster.polygon([0, 1e9, 1e9], [0, 0, 1e9], shape=(10, 10))
    assert len(rr) == 45  # the diagonal is a right edge: its centres are out
    # Empty and degenerate polygons enclose nothing.
    for r, c in [([], []), ([1.0], [2.0]), ([1.0, 2], [2.0, 3]), ([0, 5, 10], [0, 5, 10])]:
        rr, cc = raster.polygon(r, c)
        assert rr.shape == (0,) and cc.shape == (0,) and rr.dtype == np.int64


def test_polygon_accepts_any_real_dtype_and_strides() -> None:
    base = np.array([[1, 1, 8, 8], [1, 9, 9, 1]], dtype=np.int16)
    ref = raster.polygon(base[0].astype(float), base[1].astype(float))
    big = np.zeros((2, 8), np.float32)
    big[:, ::2] = base
    assert not big[0, ::2].flags.c_contiguous
    for r, c in [(base[0], base[1]), (big[0, ::2], big[1, ::2]), (base[0].tolist(), base[1].astype(np.uint8))]:
        got = raster.polygon(r, c)
        np.testing.assert_array_equal(_pairs(*got), _pairs(*ref))


def test_docstring_examples_run() -> None:
    res = doctest.testmod(raster, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert res.attempted >= 10 and res.failed == 0


def test_public_api() -> None:
    assert fcol.raster is raster
    assert raster.MAX_PIXELS == 1 << 27
