"""§6.4 anti-aliasing of the floating column: sub-pixel silhouette coverage
(``coverage=True``) and column supersampling (``antialias=k``, orthographic
and perspective) against supersampled exact ray hits of
`fcol.testing.reference` (a pixel's coverage is the fraction of its
sub-pixel rays that hit the surface).

With ``ambient=1`` and no diffuse or specular term every surface pixel has
intensity 1, so the rendered intensity (NaN → 0) is the pixel's coverage."""

from __future__ import annotations

import numpy as np
import pytest
from skimage.metrics import structural_similarity

import fcol
from fcol.testing.reference import height_reference

from floating_surfaces import SURFACES, surface

FLAT = dict(ambient=1.0, diffuse=0.0, specular=0.0)
# The sweep `coverage=True` uses by default.
DENSE = dict(step=1.0, max_step=2.0)
W, H = 48, 40

_REFS: dict = {}


def sub_mask(name, view, s):
    """Exact hits on the s×s sub-pixel centres of each pixel, (H, s, W, s)."""
    key = (name, repr(view), s)
    if key not in _REFS:
        f, grad, domain = SURFACES[name]
        ref = height_reference(f, grad, domain, view, W * s, H * s)
        _REFS[key] = ref.mask.reshape(H, s, W, s).astype(float)
    return _REFS[key]


def coverage(img):
    return np.nan_to_num(img.intensity.astype(float), nan=0.0)


def silhouette_errors(got, want):
    band = ((want > 0) & (want < 1)) | ((got > 0) & (got < 1))
    return np.abs(got - want)[band]


ORTHO = [
    ("bump", fcol.View(25, 20, view_height=7.0)),
    ("sinuv", fcol.View(30, 30, view_height=13.0)),
]


@pytest.mark.parametrize("name,view", ORTHO, ids=[n for n, _ in ORTHO])
def test_coverage_matches_exact_column_coverage(name, view):
    # Column direction only: 15 sub-rows on the pixel's centre column (the
    # middle one of 15 sub-columns); the reference is exact to 1/15.
    s = 15
    want = sub_mask(name, view, s)[:, :, :, s // 2].mean(axis=1)
    img = fcol.render(surface(name), view, W, H, outputs=("intensity",), coverage=True, **FLAT)
    err = silhouette_errors(coverage(img), want)
    assert err.size > 40
    # Measured: median ≈ 0.015, p99 ≈ 0.035 (the reference's own step is
    # 1/15 ≈ 0.067); a 0/1 mask gives median ≈ 0.27, p99 ≥ 0.45.
    assert np.median(err) <= 0.04, (np.median(err), np.quantile(err, 0.99))
    assert np.quantile(err, 0.99) <= 0.1, (np.median(err), np.quantile(err, 0.99))
    plain = fcol.render(surface(name), view, W, H, outputs=("intensity",), **FLAT)
    err0 = silhouette_errors(coverage(plain), want)
    assert np.median(err0) > 3 * np.median(err)


def test_coverage_and_supersampling_give_both_directions():
    name, view = ORTHO[1]
    s = 5
    want = sub_mask(name, view, s).mean(axis=(1, 3))
    plain = coverage(fcol.render(surface(name), view, W, H, outputs=("intensity",), **FLAT))
    aa = coverage(fcol.render(surface(name), view, W, H, outputs=("intensity",), antialias=s,
                              coverage=True, **FLAT))
    e0, e1 = np.abs(plain - want).mean(), np.abs(aa - want).mean()
    s0 = structural_similarity(plain, want, data_range=1.0)
    s1 = structural_similarity(aa, want, data_range=1.0)
    # Measured: mean error 0.0216 → 0.0012, SSIM 0.923 → 0.9995.
    assert e1 < 0.005 and e1 < 0.2 * e0, (e0, e1)
    assert s1 > 0.995 and s1 > s0, (s0, s1)


PERSP = ("sinuv", fcol.View(30, 40, "perspective", distance=24.0, fov=40.0))


def test_perspective_supersampling_against_reference():
    name, view = PERSP
    s = 5
    want = sub_mask(name, view, s).mean(axis=(1, 3))
    plain = coverage(fcol.render(surface(name), view, W, H, outputs=("intensity",), **FLAT))
    aa = coverage(fcol.render(surface(name), view, W, H, outputs=("intensity",), antialias=s, **FLAT))
    e0, e1 = np.abs(plain - want).mean(), np.abs(aa - want).mean()
    s0 = structural_similarity(plain, want, data_range=1.0)
    s1 = structural_similarity(aa, want, data_range=1.0)
    # 5 n-rooks samples against a 5×5 box. Measured: mean error
    # 0.0196 → 0.0109, SSIM 0.903 → 0.949.
    assert e1 < 0.7 * e0, (e0, e1)
    assert s1 > s0 + 0.02, (s0, s1)


def test_perspective_supersampling_samples_are_exact_rays():
    # Each pass is a full render on shifted rays: with antialias=5 the pass
    # of sub-column m samples sub-pixel (row 3m mod 5, column m) of the 5×5
    # grid (an n-rooks pattern), so the coverage is the mean of those 5 of
    # the reference's 25 hits, each pass as exact as a plain render (whose
    # mask misses a few silhouette pixels of this view: measured 24 of 1920).
    name, view = PERSP
    k = 5
    sub = sub_mask(name, view, k)
    aa = coverage(fcol.render(surface(name), view, W, H, outputs=("intensity",), antialias=k, **FLAT))
    rooks = np.mean([sub[:, (3 * m) % k, :, m] for m in range(k)], axis=0)
    wrong_samples = np.abs(aa - rooks).sum() * k
    plain = fcol.render(surface(name), view, W, H, outputs=("mask",))
    plain_wrong = (plain.mask != (sub[:, k // 2, :, k // 2] > 0)).sum()
    # Measured: 100 wrong sub-samples of 9600, plain 24 wrong of 1920.
    assert wrong_samples <= 1.25 * k * max(plain_wrong, 4), (wrong_samples, plain_wrong)


def test_defaults_unchanged_and_geometry_per_pixel_centre():
    name, view = ORTHO[1]
    outs = ("rgb", "intensity", "depth", "normal", "mask", "side")
    a = fcol.render(surface(name), view, W, H, outputs=outs)
    b = fcol.render(surface(name), view, W, H, outputs=outs, coverage=False)
    c = fcol.render(surface(name), view, W, H, outputs=outs, coverage=True)
    for k in outs:
        assert np.array_equal(getattr(a, k), getattr(b, k), equal_nan=k not in ("mask", "side", "rgb"))
    # Coverage samples densely by default (its sub-pixel silhouettes come
    # from the cubic between samples): the same geometry as the plain
    # render of that sweep.
    a = fcol.render(surface(name), view, W, H, outputs=outs, **DENSE)
    c2 = fcol.render(surface(name), view, W, H, outputs=outs, coverage=True, **DENSE)
    for k in outs:
        assert np.array_equal(getattr(c, k), getattr(c2, k), equal_nan=k not in ("mask", "side", "rgb"))
    for k in ("depth", "normal", "mask", "side"):
        assert np.array_equal(getattr(a, k), getattr(c, k), equal_nan=k not in ("mask", "side"))
    # Only silhouette pixels change colour, and some do.
    diff = np.any(a.rgb != c.rgb, axis=2)
    assert diff.any()
    assert diff.sum() < 0.2 * W * H


@pytest.mark.parametrize("kw", [
    dict(coverage=True),
    dict(coverage=True, antialias=3),
])
def test_thread_count_identity_ortho(kw):
    name, view = ORTHO[1]
    outs = ("rgb", "intensity", "depth")
    a = fcol.render(surface(name), view, W, H, outputs=outs, threads=1, **kw)
    b = fcol.render(surface(name), view, W, H, outputs=outs, threads=3, **kw)
    for k in outs:
        assert np.array_equal(getattr(a, k), getattr(b, k), equal_nan=k != "rgb")


def test_thread_count_identity_perspective():
    name, view = PERSP
    outs = ("rgb", "intensity", "depth", "mask")
    a = fcol.render(surface(name), view, W, H, outputs=outs, threads=1, antialias=3)
    b = fcol.render(surface(name), view, W, H, outputs=outs, threads=3, antialias=3)
    for k in outs:
        assert np.array_equal(getattr(a, k), getattr(b, k), equal_nan=k in ("intensity", "depth"))
    plain = fcol.render(surface(name), view, W, H, outputs=("depth", "mask"))
    assert np.array_equal(a.mask, plain.mask)
    assert np.array_equal(a.depth, plain.depth, equal_nan=True)


PERSP_COV = [
    ("bump", fcol.View(25, 20, "perspective", distance=14.0, fov=45.0)),
    ("sinuv", fcol.View(40, 15, "perspective", distance=20.0, fov=50.0)),
]


@pytest.mark.parametrize("name,view", PERSP_COV, ids=[n for n, _ in PERSP_COV])
def test_perspective_coverage_matches_exact_column_coverage(name, view):
    # As the orthographic test: 15 sub-rows on the pixel's centre column.
    # A perspective sweep runs in its bin's vertical plane, up to half a
    # pixel beside the pixel centre, so pixels where the silhouette runs
    # steeply across the screen keep that lateral error (plain renders
    # too): the median measures the coverage, p90 the bulk of the band.
    s = 15
    want = sub_mask(name, view, s)[:, :, :, s // 2].mean(axis=1)
    img = fcol.render(surface(name), view, W, H, outputs=("intensity",), coverage=True, **FLAT)
    err = silhouette_errors(coverage(img), want)
    plain = fcol.render(surface(name), view, W, H, outputs=("intensity",), **FLAT)
    err0 = silhouette_errors(coverage(plain), want)
    stats = (np.median(err), np.quantile(err, 0.9), np.quantile(err, 0.99),
             np.median(err0), np.quantile(err0, 0.9))
    assert err.size > 40, stats
    # Measured (median, p90, p99): bump 0.037, 0.147, 0.48; sinuv 0.066,
    # 0.259, 0.75. A 0/1 mask: median 0.27 and 0.33, p90 0.47 and 0.47.
    assert np.median(err) <= 0.08, stats
    assert np.quantile(err, 0.9) <= 0.35, stats
    assert np.median(err0) > 3 * np.median(err), stats


def test_perspective_coverage_geometry_unchanged():
    name, view = PERSP
    outs = ("rgb", "intensity", "depth", "normal", "uv", "mask", "side")
    # (the sweeps coverage makes: dense, on bins a pixel wide)
    a = fcol.render(surface(name), view, W, H, outputs=outs, bin_width=1.0, **DENSE)
    c = fcol.render(surface(name), view, W, H, outputs=outs, coverage=True)
    for k in ("depth", "normal", "uv", "mask", "side"):
        assert np.array_equal(getattr(a, k), getattr(c, k), equal_nan=k not in ("mask", "side")), k
    # Only silhouette pixels change colour, and some do.
    diff = np.any(a.rgb != c.rgb, axis=2)
    assert diff.any()
    assert diff.sum() < 0.2 * W * H
    ia, ic = coverage(a), coverage(c)
    assert np.array_equal(ia[~diff & a.mask], ic[~diff & a.mask])


@pytest.mark.parametrize("kw", [
    dict(coverage=True),
    dict(coverage=True, antialias=3),
])
def test_thread_count_identity_perspective_coverage(kw):
    name, view = PERSP
    outs = ("rgb", "intensity", "depth", "mask")
    a = fcol.render(surface(name), view, W, H, outputs=outs, threads=1, **kw)
    b = fcol.render(surface(name), view, W, H, outputs=outs, threads=3, **kw)
    for k in outs:
        assert np.array_equal(getattr(a, k), getattr(b, k), equal_nan=k in ("intensity", "depth"))


def test_coverage_bad_input():
    with pytest.raises(TypeError):
        fcol.render(surface("bump"), ORTHO[0][1], W, H, coverage="yes")


# Pixels the exact hit sees that the default render leaves unset, and
# pixels both see where the render shows a farther sheet than the first hit
# (a crest in front that the bin's plane passes over), at 48 × 40 and
# 160 × 120. Measured: missing (8, 10), (0, 1), (3, 9); farther (8, 15),
# (0, 0), (2, 0) (with steps of 5 local pixels held within 0.05 of their
# chord, not 8 and 0.2: farther (9, 15), (0, 0), (4, 0)). With 3-pixel
# steps, no bend and no crest samples: missing (11, 10), (0, 1), (3, 9);
# farther (9, 15), (0, 0), (5, 1). Without the searches on the mask's edge
# (bins a pixel wide) 16 were missing at 48 × 40 on the first view; without
# the search for nearer sheets, farther (24, 54), (0, 1), (28, 46).
EDGE_CASES = [
    (PERSP, ((8, 8), (10, 15))),
    (PERSP_COV[0], ((0, 0), (1, 0))),
    (PERSP_COV[1], ((3, 2), (9, 0))),
]


def check_edges(case, measured, near, far):
    """The default render of `case` against the exact hit at 48 × 40 and
    160 × 120, `measured` the (missing, farther) counts of each size; a
    pixel is nearer (farther) than the first hit where its depth is below
    near(rd, h) (above far(rd, h))."""
    name, view = case
    f, g, dom = SURFACES[name]
    for (w, h), (missing, farther) in zip(((W, H), (160, 120)), measured):
        ref = height_reference(f, g, dom, view, w, h)
        img = fcol.render(surface(name), view, w, h, outputs=("rgb", "mask", "depth"))
        rm, m = np.asarray(ref.mask, bool), img.mask.astype(bool)
        both = rm & m
        rd, d = np.asarray(ref.depth), img.depth
        # A solved pixel is a crossing of its own ray: never one the exact
        # hit does not see, never nearer than its first hit. (+2: a
        # silhouette pixel or two may move with the platform's rounding)
        assert (m & ~rm).sum() == 0, (w, h)
        assert (both & (d < near(rd, h))).sum() == 0, (w, h)
        assert (rm & ~m).sum() <= missing + 2, (w, h, (rm & ~m).sum())
        assert (both & (d > far(rd, h))).sum() <= farther + 2, (w, h, (both & (d > far(rd, h))).sum())


@pytest.mark.parametrize("case,measured", EDGE_CASES, ids=["sinuv-24", "bump", "sinuv-20"])
def test_perspective_edges_against_exact_hit(case, measured):
    check_edges(case, measured, lambda rd, h: rd * (1 - 1e-3), lambda rd, h: rd * (1 + 1e-3))


# The same for orthographic views: every set pixel is a crossing of its own
# ray (an unsolved one is marched over its span's bracket, else left for the
# searches after the columns), and the pixels beside set ones are searched
# on their own rays; crests between a column's samples get a sample of
# their own, and its steps are held to a bend. Measured at 48 × 40 and
# 160 × 120: missing (0, 0), (0, 0), (1, 0), (0, 0), (0, 0); farther
# (0, 2), (2, 2), (4, 5), (5, 2), (0, 0) (with one largest step deep in
# the covered rows, not up to two: (0, 5), (2, 3), (4, 5), (5, 2),
# (0, 0)). With 3-pixel steps, no bend and
# no crest samples: missing (2, 1), (2, 2), (1, 1), (0, 0), (0, 0); farther
# (8, 17), (4, 8), (9, 5), (5, 10), (0, 0). Before the searches and the
# march (then): missing (12, 32), (14, 19),
# (2, 6), (1, 7), (0, 0); farther (31, 53), (16, 44), (23, 22), (15, 38),
# (2, 0); and up to 11 pixels nearer than the first hit (interpolated where
# the exact solve failed).
ORTHO_EDGE_CASES = [
    (("sinuv", fcol.View(30, 30, view_height=13.0)), ((0, 0), (0, 2))),
    (("sinuv", fcol.View(55, 310, view_height=12.0)), ((0, 2), (0, 2))),
    (("ripples", fcol.View(20, 75, view_height=9.0)), ((1, 4), (0, 5))),
    (("dem", fcol.View(35, 120, view_height=10.0)), ((0, 5), (0, 2))),
    (("bump", fcol.View(25, 20, view_height=7.0)), ((0, 0), (0, 0))),
]


@pytest.mark.parametrize(
    "case,measured", ORTHO_EDGE_CASES, ids=["sinuv-30", "sinuv-55", "ripples", "dem", "bump"]
)
def test_orthographic_edges_against_exact_hit(case, measured):
    # (orthographic depths are signed: a tolerance of 0.05 pixel)
    px = case[1].view_height
    check_edges(case, measured, lambda rd, h: rd - 0.05 * px / h, lambda rd, h: rd + 0.05 * px / h)


GEOMETRY = ("depth", "normal", "uv", "side", "mask")


@pytest.mark.parametrize("cov", [False, True], ids=["plain", "coverage"])
@pytest.mark.parametrize("name,view", [ORTHO[0], ORTHO[1], PERSP], ids=["ortho0", "ortho1", "persp"])
def test_supersampled_shading_keeps_the_plain_geometry(name, view, cov):
    """With ``antialias=k`` only the colours are supersampled: the geometry
    buffers are a plain render's, the searches at the mask's edge and the
    depth steps included (orthographic views had the centre column's
    unsearched pixels before: on the bench view 80 silhouette pixels missed
    instead of 3, 144 on a farther sheet instead of 27, one nearer than the
    first hit)."""
    kw = dict(coverage=True) if cov else {}
    outs = ("rgb", "intensity") + GEOMETRY
    plain = fcol.render(surface(name), view, W, H, outputs=outs, **kw)
    aa = fcol.render(surface(name), view, W, H, outputs=outs, antialias=3, **kw)
    for k in GEOMETRY:
        assert np.array_equal(getattr(plain, k), getattr(aa, k), equal_nan=k not in ("side", "mask")), k
    # The colours are supersampled: silhouette pixels differ, and some do.
    assert np.any(plain.rgb != aa.rgb)
