"""The floating column (Gordon 2001 §4.2, A.2) against the exact first
ray–surface hit of `fcol.testing.reference` (embreex ray casting refined on the
exact function), plus its API contract and bad input."""

from __future__ import annotations

import numpy as np
import pytest

import fcol
from fcol.testing.reference import compare, height_reference

from floating_surfaces import SURFACES, surface

ALL = ("rgb", "depth", "normal", "uv", "side", "mask")
W, H = 128, 100

CASES = [
    ("sinuv", dict(elevation=30, azimuth=30, view_height=13.0)),
    ("sinuv", dict(elevation=62, azimuth=-50, view_height=13.0)),
    ("sinuv", dict(elevation=30, azimuth=40, projection="perspective", distance=24.0, fov=40.0)),
    ("sinuv", dict(elevation=22, azimuth=-120, projection="perspective", distance=20.0, fov=45.0)),
    ("bump", dict(elevation=40, azimuth=10, view_height=7.0)),
    ("bump", dict(elevation=35, azimuth=20, projection="perspective", distance=10.0, fov=40.0)),
    ("ripples", dict(elevation=45, azimuth=25, view_height=5.0)),
    ("ripples", dict(elevation=55, azimuth=60, projection="perspective", distance=7.0, fov=40.0)),
    ("dem", dict(elevation=35, azimuth=200, view_height=8.5)),
    ("dem", dict(elevation=40, azimuth=30, projection="perspective", distance=14.0, fov=40.0)),
]


def make_view(kw):
    kw = dict(kw)
    proj = kw.pop("projection", "orthographic")
    return fcol.View(kw.pop("elevation"), kw.pop("azimuth"), proj, **kw)


_REFS: dict = {}


def reference(name, kw, w=W, h=H):
    key = (name, tuple(sorted(kw.items())), w, h)
    if key not in _REFS:
        f, grad, domain = SURFACES[name]
        _REFS[key] = height_reference(f, grad, domain, make_view(kw), w, h)
    return _REFS[key]


# The sweep of the default (samples up to 3 pixels apart, every revealed pixel
# solved on its ray from the cubic through its span's samples) and the dense
# sweep (samples at most a pixel apart, as Gordon's §4.2 draws).
MODES = {"default": {}, "dense": dict(step=1.0, max_step=2.0)}


@pytest.mark.parametrize("mode", list(MODES))
@pytest.mark.parametrize("name,kw", CASES, ids=[f"{n}-{i}" for i, (n, _) in enumerate(CASES)])
def test_accuracy_against_exact_reference(name, kw, mode):
    # 3 sin(u cos v) is intricate: at 128 × 100 most of its pixels lie within
    # a pixel of a silhouette, which dominates SSIM; it is tested at 256 × 200.
    w, h = (256, 200) if name == "sinuv" else (W, H)
    view = make_view(kw)
    img = fcol.render(surface(name), view, w, h, outputs=ALL, shading="normal", **MODES[mode])
    ref = reference(name, kw, w, h)
    res = compare(img, ref, view)
    assert res["n_compared"] > 0.2 * w * h, res
    assert res["mask_bad"] == 0, res
    assert res["depth_px_median"] <= 0.02, res
    assert res["depth_px_p99"] <= 0.5, res
    assert res["normal_deg_median"] <= 0.05, res
    assert res["normal_deg_p99"] <= 3.0, res
    assert res["ssim"] >= 0.97, res
    assert res["side_bad"] == 0, res
    # Every pixel is solved on its own ray: far inside those bounds.
    assert res["depth_px_median"] <= 1e-4 and res["depth_px_p99"] <= 1e-3, res
    assert res["normal_deg_median"] <= 1e-3 and res["normal_deg_p99"] <= 0.05, res


@pytest.mark.parametrize("i", [0, 2], ids=["ortho", "persp"])
def test_table1_size_views_match_reference(i):
    # The first two views of CASES at the seed's Table 1 size (480 × 477),
    # where the perspective view has a pixel whose hit lies within a
    # half-footprint of the domain's edge (once left empty by the hole
    # filling's march, which stepped over it).
    name, kw = CASES[i]
    view = make_view(kw)
    img = fcol.render(surface(name), view, 480, 477, outputs=ALL, shading="normal")
    res = compare(img, reference(name, kw, 480, 477), view)
    assert res["mask_bad"] == 0, res
    assert res["side_bad"] == 0, res
    assert res["depth_px_median"] <= 1e-4 and res["depth_px_p99"] <= 1e-3, res
    assert res["normal_deg_median"] <= 1e-3 and res["normal_deg_p99"] <= 0.05, res


# refine=False: the cubic's point (in perspective moved onto the pixel's own
# ray by the tangent plane) and the interpolated normal; exact solves only
# where a span folds or a ray grazes. Depth meets the exact mode's bounds;
# normals carry the interpolation error (largest on the DEM's bilinear kinks).
CHEAP_NORMAL = {"sinuv": (0.2, 5.0), "bump": (0.2, 2.0), "ripples": (2.0, 8.0), "dem": (3.0, 30.0)}


@pytest.mark.parametrize("name,kw", CASES, ids=[f"{n}-{i}" for i, (n, _) in enumerate(CASES)])
def test_accuracy_without_refinement(name, kw):
    w, h = (256, 200) if name == "sinuv" else (W, H)
    view = make_view(kw)
    img = fcol.render(surface(name), view, w, h, outputs=ALL, refine=False)
    res = compare(img, reference(name, kw, w, h), view)
    assert res["n_compared"] > 0.2 * w * h, res
    assert res["mask_bad"] == 0 and res["side_bad"] == 0, res
    # Perspective included: no lateral offset of the pixels' rays.
    assert res["depth_px_median"] <= 0.02, res
    assert res["depth_px_p99"] <= 0.5, res
    med, p99 = CHEAP_NORMAL[name]
    assert res["normal_deg_median"] <= med and res["normal_deg_p99"] <= p99, res
    assert res["ssim"] >= 0.93, res


def test_default_sweep_samples_less_than_the_dense_one():
    """The default's coarser sweep: fewer evaluations than the dense sweep,
    on both projections of the bench surface (counted, not timed)."""
    s = surface("sinuv")
    for kw in (CASES[0][1], CASES[2][1]):
        view = make_view(kw)
        a = fcol.render(s, view, 240, 200, outputs=("rgb", "depth", "normal", "mask"))
        b = fcol.render(s, view, 240, 200, outputs=("rgb", "depth", "normal", "mask"), step=1.0, max_step=2.0)
        assert a.stats["sweep_samples"] < 0.7 * b.stats["sweep_samples"], (a.stats, b.stats)
        assert a.samples < 0.85 * b.samples, (a.samples, b.samples)


def test_gouraud_and_phong_without_refinement_are_close():
    name, kw = CASES[0]
    view = make_view(kw)
    ref = reference(name, kw, 256, 200)
    for shading in ("intensity", "normal"):
        img = fcol.render(surface(name), view, 256, 200, outputs=("rgb", "mask"), shading=shading,
                          refine=False)
        res = compare(img, ref, view)
        assert res["mask_bad"] == 0, res
        assert res["ssim"] >= 0.9, (shading, res)


def test_only_requested_buffers():
    img = fcol.render(surface("bump"), make_view(CASES[4][1]), 40, 30, outputs=("depth",))
    assert img.depth.dtype == np.float32 and img.depth.shape == (30, 40)
    assert img.rgb is None and img.normal is None and img.mask is None
    assert img.samples > 0 and img.elapsed >= 0


def test_buffer_types_and_backgrounds():
    img = fcol.render(surface("bump"), make_view(CASES[4][1]), 40, 30, outputs=ALL + ("intensity",))
    m = img.mask
    assert img.rgb.dtype == np.uint8 and img.rgb.shape == (30, 40, 3)
    assert img.side.dtype == np.int8 and img.normal.shape == (30, 40, 3) and img.uv.shape == (30, 40, 2)
    assert m.any() and (~m).any()
    assert np.isnan(img.depth[~m]).all() and np.isfinite(img.depth[m]).all()
    assert np.isnan(img.intensity[~m]).all()
    assert (img.side[~m] == 0).all() and (img.side[m] != 0).all()
    assert (img.rgb[~m] == 255).all()
    n = np.linalg.norm(img.normal[m], axis=-1)
    assert np.allclose(n, 1, atol=1e-5)


def test_bad_input():
    view = make_view(CASES[4][1])
    s = surface("bump")
    with pytest.raises(TypeError, match="unexpected option"):
        fcol.render(s, view, 10, 10, nonsense=1)
    with pytest.raises(ValueError, match="shading"):
        fcol.render(s, view, 10, 10, shading="flat")
    with pytest.raises(ValueError, match="method"):
        fcol.render(s, view, 10, 10, method="raytrace")
    with pytest.raises(ValueError, match="step"):
        fcol.render(s, view, 10, 10, step=0.0)
    with pytest.raises(ValueError, match="outputs"):
        fcol.render(s, view, 10, 10, outputs=("lines",))
    with pytest.raises(ValueError, match="antialias"):
        fcol.render(s, view, 10, 10, antialias=0)
    with pytest.raises(TypeError, match="surface"):
        fcol.render(object(), view, 10, 10)
    with pytest.raises(ValueError, match="width"):
        fcol.render(s, view, 0, 10)
    with pytest.raises(TypeError, match="refine"):
        fcol.render(s, view, 10, 10, refine="yes")
    for bad in (0.0, -1.0, float("nan"), 4.5):
        with pytest.raises(ValueError, match="bin_width"):
            fcol.render(s, view, 10, 10, bin_width=bad)


@pytest.mark.parametrize("case", [0, 2])
@pytest.mark.parametrize("opts", [{}, dict(refine=False), dict(step=1.0, max_step=2.0)], ids=["default", "cheap", "dense"])
def test_identical_for_any_thread_count(case, opts):
    view = make_view(CASES[case][1])
    a = fcol.render(surface("sinuv"), view, 48, 40, outputs=ALL, threads=1, **opts)
    b = fcol.render(surface("sinuv"), view, 48, 40, outputs=ALL, threads=2, **opts)
    for k in ALL:
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k))
    assert a.samples == b.samples


HARD_VIEWS = [
    dict(elevation=0, azimuth=0, view_height=8.0),
    dict(elevation=0.5, azimuth=33, view_height=8.0),
    dict(elevation=89.9, azimuth=0, view_height=8.0),
    dict(elevation=90, azimuth=17, view_height=8.0),
    dict(elevation=-30, azimuth=45, view_height=8.0),
    dict(elevation=90, azimuth=0, projection="perspective", distance=6.0, fov=60.0),
    dict(elevation=10, azimuth=5, projection="perspective", distance=2.0, fov=60.0),
]


@pytest.mark.parametrize("kw", HARD_VIEWS, ids=[str(i) for i in range(len(HARD_VIEWS))])
def test_hard_views_match_reference(kw):
    """SPEC §5 views (level, grazing, straight down, from below, eye close
    to the surface): the same accuracy where the case is well posed."""
    name = "bump"
    view = make_view(kw)
    img = fcol.render(surface(name), view, 64, 48, outputs=ALL + ("intensity",))
    assert not np.isnan(img.intensity[img.mask]).any()
    ref = reference(name, kw, 64, 48)
    res = compare(img, ref, view)
    assert res["mask_bad"] == 0, res
    if res["n_compared"] > 50:
        assert res["depth_px_median"] <= 0.02 and res["normal_deg_median"] <= 0.05, res
        assert res["side_bad"] == 0, res


@pytest.mark.parametrize("kw", [dict(elevation=30, azimuth=30, view_height=8.0),
                                dict(elevation=5, azimuth=-258, view_height=4.2, target=(0.7, 1.0, 0.3)),
                                dict(elevation=30, azimuth=30, projection="perspective", distance=12.0, fov=40.0)],
                         ids=["ortho", "ortho-low", "persp"])
def test_poles_are_walls_not_endless_sweeps(kw):
    """w = tan(u) over [−3, 3]: at u = ±π/2 the surface runs off to ±∞, a
    sheet that every ray of the column crosses. The sweep reaches the pole
    in a bounded number of steps (it once took 4 million per column,
    stepping by the row rate that grows without bound there, and stopped
    short) and matches the exact first hits."""
    dom = ((-3.0, 3.0), (-2.0, 4.0))
    view = make_view(kw)
    img = fcol.render(fcol.Function("tan(u)", domain=dom), view, 64, 48, outputs=ALL)
    assert img.stats["sweep_samples"] < 20 * 64 * 48, img.stats
    ref = height_reference(lambda u, v: np.tan(u), lambda u, v: (1 / np.cos(u) ** 2, 0 * v), dom, view, 64, 48)
    res = compare(img, ref, view)
    assert res["mask_bad"] == 0 and res["farther_sheet"] == 0, res
    assert res["depth_px_median"] <= 1e-4 and res["depth_px_p99"] <= 1e-3, res
    # The wall pixels beside the poles lie in the scene: in front of the eye,
    # their (u, v) in the domain (once a perspective wall pixel took the
    # chord between heights of ±10¹⁶, which passes behind the eye: depth 0
    # and the eye's (u, v)). (Orthographic depth is measured from the
    # target's plane: any sign.)
    m = img.mask
    assert np.isfinite(img.depth[m]).all()
    if view.projection == "perspective":
        assert (img.depth[m] > 0).all(), np.argwhere(m & ~(img.depth > 0))[:5]
    (u0, u1), (v0, v1) = dom
    uv = img.uv[m]
    assert ((uv[:, 0] >= u0) & (uv[:, 0] <= u1) & (uv[:, 1] >= v0) & (uv[:, 1] <= v1)).all()


@pytest.mark.parametrize("kw", [dict(projection="perspective", distance=4.0, fov=50.0, azimuth=az) for az in (90, 70, 115)]
                         + [dict(projection="perspective", distance=2.5, fov=60.0, azimuth=70),
                            dict(view_height=2.5, azimuth=70)],
                         ids=["persp-90", "persp-70", "persp-115", "persp-near", "ortho"])
def test_wall_pixels_lie_where_their_rays_meet_the_wall(kw):
    """§5.1: w = 0.5 for u > 0, else 0, has a wall at u = 0 that the
    surface does not sample. Each pixel whose ray meets that wall (between
    heights 0.05 and 0.45, a pixel inside its outline) lies where the ray
    meets it: depth exact to 10⁻³ px, u = 0 to 10⁻⁴ (a perspective pixel
    lies up to a bin's half width beside the plane it was swept in: it was
    once placed on the plane's chord across the wall, 0.1–0.3 px off)."""
    from scipy.ndimage import binary_erosion
    from fcol.testing.spec_camera import SpecCamera

    W, H = 96, 72
    view = make_view(dict(kw, elevation=25))
    s = fcol.Function("0.25*(sign(u) + 1)", domain=((-1, 1), (-1, 1)))
    img = fcol.render(s, view, W, H, outputs=("depth", "uv", "mask"))
    assert img.stats["walls"] > 0
    cam = SpecCamera.from_view(view, W, H)
    O, D = cam.rays()
    O, D = np.array(np.broadcast_to(O, D.shape)), np.array(D)
    if not cam.persp:
        O = O - 50 * D  # (an orthographic ray is a whole line)
    lam = -O[..., 0] / D[..., 0]  # where each ray meets the plane u = 0
    P = O + lam[..., None] * D
    wall = (D[..., 0] > 0) & (O[..., 0] < 0) & (P[..., 2] > 0.05) & (P[..., 2] < 0.45) & (np.abs(P[..., 1]) < 0.9)
    wall = binary_erosion(wall)
    assert wall.sum() > 100
    depth = (P - cam.origin) @ cam.d
    pix = depth / cam.F if cam.persp else np.full_like(depth, cam.p)
    assert img.mask[wall].all()
    err = np.abs(img.depth - depth)[wall] / pix[wall]
    assert err.max() <= 1e-3, (np.median(err), err.max())
    assert np.abs(img.uv[wall][:, 0]).max() <= 1e-4


def test_step_constant_nan_and_scales():
    view = fcol.View(35, 20, view_height=3.0)
    step = fcol.Function(lambda u, v: np.where(u > 0, 0.5, 0.0), grad=lambda u, v: (0 * u, 0 * v),
                         domain=((-1, 1), (-1, 1)))
    img = fcol.render(step, view, 60, 40, outputs=("rgb", "intensity", "mask", "depth"))
    assert img.mask.sum() > 300 and not np.isnan(img.intensity[img.mask]).any()
    assert img.stats["walls"] > 0  # the step is seen as a wall (§5.1)
    flat = fcol.Function("0*u + 1.5", domain=((-1, 1), (-1, 1)))
    img = fcol.render(flat, fcol.View(90, 0, view_height=3.0), 30, 30, outputs=("depth", "normal", "mask"))
    m = img.mask
    assert m.sum() == 20 * 20 and np.allclose(img.normal[m], (0, 0, 1))
    holes = fcol.Function(lambda u, v: np.where(u * u + v * v < 0.25, np.nan, 0.1 * u),
                          grad=lambda u, v: (0.1 + 0 * u, 0 * v), domain=((-1, 1), (-1, 1)))
    img = fcol.render(holes, fcol.View(60, 10, view_height=3.0), 40, 40, outputs=("rgb", "mask", "depth"))
    assert not img.mask[20, 20] and img.mask.sum() > 300
    assert np.isnan(img.depth[~img.mask]).all() and np.isfinite(img.depth[img.mask]).all()
    for scale in (1e-6, 1e6):
        s = fcol.Function(f"{scale}*exp(-(u*u + v*v)/({scale}*{scale}))",
                          domain=((-2 * scale, 2 * scale), (-2 * scale, 2 * scale)))
        img = fcol.render(s, fcol.View(40, 20, view_height=5 * scale), 40, 30, outputs=("depth", "mask"))
        assert 200 < img.mask.sum() < 1200 and np.isfinite(img.depth[img.mask]).all()


# Zoomed views (a small view height, a narrow field of view): most of each
# column's or plane's line through the domain lies in front of the picture,
# below it, and the sweep steps over the stretches that the surface's bounds
# over them keep outside the picture.
ZOOMED = [
    ("sinuv", dict(elevation=30, azimuth=30, view_height=0.2, target=(1.0, 0.5, 1.58))),
    ("sinuv", dict(elevation=-25, azimuth=70, view_height=0.3, target=(-1.0, 2.0, 0.0))),
    ("sinuv", dict(elevation=30, azimuth=30, projection="perspective", distance=24.0, fov=1.0,
                   target=(1.0, 0.5, 1.58))),
    ("dem", dict(elevation=35, azimuth=200, view_height=0.3)),
    ("dem", dict(elevation=40, azimuth=30, projection="perspective", distance=14.0, fov=1.5)),
]


@pytest.mark.parametrize("name,kw", ZOOMED, ids=[f"{n}-{i}" for i, (n, _) in enumerate(ZOOMED)])
def test_zoomed_views_skip_what_lies_outside_the_picture(name, kw):
    view = make_view(kw)
    img = fcol.render(surface(name), view, W, H, outputs=ALL, shading="normal")
    res = compare(img, reference(name, kw), view)
    assert res["n_compared"] > 0.5 * W * H, res
    assert res["mask_bad"] == 0 and res["side_bad"] == 0 and res["farther_sheet"] == 0, res
    assert res["depth_px_median"] <= 0.02 and res["depth_px_p99"] <= 0.5, res
    assert res["normal_deg_median"] <= 0.05 and res["normal_deg_p99"] <= 3.0, res
    assert res["ssim"] >= 0.97, res
    # Solved on every pixel's ray (the pixels are small: 1e-4 px of depth
    # is 1e-8 of the domain's size at fov = 1°).
    assert res["depth_px_median"] <= 1e-3 and res["depth_px_p99"] <= 1e-2, res
    assert res["normal_deg_median"] <= 1e-3 and res["normal_deg_p99"] <= 0.05, res
    # Counted, not timed: the sweep's work follows the picture, not the
    # domain (the cargo test skipping_what_lies_outside_the_picture_keeps_it
    # counts the samples with and without the skip).
    assert img.stats["sweep_samples"] <= 2 * W * H, img.stats


# Narrow fields of view far from the vertical: the azimuth bins (at most
# 1.25 px wide at the most sensitive pixel) number in the hundreds of millions
# over the full circle, of which the picture meets a few hundred.
NARROW = [
    dict(elevation=30, azimuth=30, projection="perspective", distance=24.0, fov=1e-3, target=(1.0, 0.5, 1.58)),
    dict(elevation=30, azimuth=30, projection="perspective", distance=24.0, fov=1e-4, target=(1.0, 0.5, 1.58)),
    dict(elevation=-10, azimuth=140, projection="perspective", distance=9.0, fov=1e-4, target=(0.3, -2.0, 0.0)),
]


@pytest.mark.parametrize("kw", NARROW, ids=["fov1e-3", "fov1e-4", "fov1e-4-below"])
def test_narrow_fields_of_view_keep_their_bins_narrow(kw):
    view = make_view(kw)
    ref = reference("sinuv", kw)
    img = fcol.render(surface("sinuv"), view, W, H, outputs=ALL, shading="normal")
    res = compare(img, ref, view)
    assert res["n_compared"] > 0.5 * W * H, res
    assert res["mask_bad"] == 0 and res["side_bad"] == 0, res
    assert res["normal_deg_median"] <= 1e-3 and res["normal_deg_p99"] <= 0.05, res
    assert res["ssim"] >= 0.97, res
    # A pixel here is 1e-7 of the distance: float32 depths round to several
    # pixels, so depth is checked against that rounding, not in pixels.
    both = img.mask & np.asarray(ref.mask, dtype=bool)
    rd = np.asarray(ref.depth, dtype=np.float64)[both]
    err = np.abs(img.depth[both].astype(np.float64) - rd)
    assert np.all(err <= 2 * np.spacing(np.float32(rd)).astype(np.float64)), err.max()
    assert img.stats["sweep_samples"] <= 2 * W * H, img.stats


def test_bench_times_with_numpy_blas_on_one_thread():
    """The bench and the demo time every method with NumPy's BLAS limited
    to one thread (its idle workers would busy-wait on the cores after each
    matrix product), and give the thread count back afterwards."""
    threadpoolctl = pytest.importorskip("threadpoolctl")
    from fcol.bench import quiet_blas

    def blas_threads():
        return [i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"]

    np.ones((4, 4)) @ np.ones((4, 4))  # (NumPy's BLAS loaded)
    before = blas_threads()
    if not before:
        pytest.skip("NumPy reports no BLAS library")
    with quiet_blas() as line:
        assert blas_threads() == [1] * len(before)
        assert "limited to one thread" in line
    assert blas_threads() == before


@pytest.mark.parametrize("vname", ["ortho", "persp"])
def test_lean_mesh_baseline_is_a_true_mesh_cast(vname):
    """The bench's lean mesh baseline (embreex called directly, float32)
    finds the same triangles' hits as the float64 re-intersection of the
    trimesh one, and as a 200² mesh stands against the exact reference
    where the bench says it does (no mask error, sub-pixel depth)."""
    from fcol.bench.floating import DOMAIN, LeanMeshCaster, MeshCaster, f_np, grad_np, views

    view = views()[vname]
    w, h = 120, 119
    lean = LeanMeshCaster(200).cast(view, w, h)
    full = MeshCaster(200).cast(view, w, h)
    both = lean.mask & full.mask
    assert (lean.mask != full.mask).sum() <= 1
    # Same triangles: depths agree to float32's rounding of the hit distance
    # (measured 9e-6 and 1.8e-5 world units).
    assert np.nanmax(np.abs(lean.depth[both] - full.depth[both])) < 5e-5
    res = compare(lean, height_reference(f_np, grad_np, DOMAIN, view, w, h), view)
    assert res["mask_bad"] == 0
    assert res["depth_px_p99"] < 0.05  # measured 0.030 / 0.027
    # Exact vertex normals, interpolated: 0.032° / 0.035° median measured.
    assert res["normal_deg_median"] < 0.05
