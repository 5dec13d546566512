"""Illumination as a texture of the floating column renderer:
``fcol.render(..., texture=T)`` multiplies each pixel's intensity and rgb
by T sampled bilinearly at the pixel's (u, v); checked against a NumPy
bilinear lookup on the returned uv buffer."""

from __future__ import annotations

import math

import numpy as np
import pytest

import fcol


def numpy_lookup(tex: np.ndarray, uv: np.ndarray, extent: tuple[float, float, float, float]) -> np.ndarray:
    """Bilinear value of ``tex`` (rows along v, columns along u, first and
    last texels at the extent's ends) at each (u, v); NaN texels as 0, NaN
    where uv is NaN."""
    t = np.nan_to_num(np.asarray(tex, np.float64), nan=0.0, posinf=0.0, neginf=0.0)
    u0, u1, v0, v1 = extent
    u = uv[..., 0].astype(np.float64)
    v = uv[..., 1].astype(np.float64)

    def locate(x: np.ndarray, a: float, b: float, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if n == 1:
            z = np.zeros(x.shape, np.int64)
            return z, z, np.zeros(x.shape)
        f = np.clip((x - a) / (b - a) * (n - 1), 0, n - 1)
        i0 = np.minimum(np.floor(np.nan_to_num(f)), n - 2).astype(np.int64)
        return i0, i0 + 1, f - i0

    h, w = t.shape
    j0, j1, fx = locate(u, u0, u1, w)
    i0, i1, fy = locate(v, v0, v1, h)
    top = (1 - fx) * t[i0, j0] + fx * t[i0, j1]
    bottom = (1 - fx) * t[i1, j0] + fx * t[i1, j1]
    out = (1 - fy) * top + fy * bottom
    return np.where(np.isfinite(u) & np.isfinite(v), out, np.nan)


def rust_round(x: np.ndarray) -> np.ndarray:
    return np.floor(x + 0.5)  # half away from zero for x >= 0


def check_textured(plain: fcol.Image, textured: fcol.Image, fac: np.ndarray) -> None:
    on = np.isfinite(fac)
    assert on.sum() > 50
    # intensity: multiplied in f64, stored as float32
    want_i = np.where(on, (plain.intensity.astype(np.float64) * np.where(on, fac, 1)).astype(np.float32), plain.intensity)
    np.testing.assert_allclose(textured.intensity, want_i, rtol=2.4e-7, atol=1e-30, equal_nan=True)
    np.testing.assert_array_equal(np.isnan(textured.intensity), np.isnan(plain.intensity))
    # rgb: multiplied, rounded, clamped; background untouched
    x = plain.rgb.astype(np.float64) * np.where(on, fac, 1)[..., None]
    want = np.where(on[..., None], np.clip(rust_round(x), 0, 255), plain.rgb).astype(np.uint8)
    tie = on[..., None] & (np.abs(x - np.floor(x) - 0.5) < 1e-9)
    assert (textured.rgb == want)[~tie].all()
    assert (np.abs(textured.rgb.astype(int) - want) <= 1).all()


def _terrain() -> np.ndarray:
    yy, xx = np.mgrid[0:40, 0:50]
    return 30 * np.sin(xx / 7.0) * np.cos(yy / 9.0) + 0.5 * xx


@pytest.mark.parametrize("extent", [(0.0, 980.0, 0.0, 780.0), (500.0, 1480.0, 780.0, 0.0)], ids=["south-up", "north-up"])
@pytest.mark.parametrize("view", [
    fcol.View(35, 20, "perspective", target=(600, 400, 0), distance=1800, fov=45),
    fcol.View(50, -30, view_height=1300),
], ids=["perspective", "orthographic"])
def test_texture_is_a_bilinear_lookup_at_the_pixel_uv(extent, view) -> None:
    z = _terrain()
    g = fcol.HeightGrid(z, extent=extent)
    u0, u1, v0, v1 = extent
    view = fcol.View(view.elevation, view.azimuth, view.projection, target=(0.5 * (u0 + u1), 0.5 * (v0 + v1), 0),
                     **({"distance": 1800, "fov": 45} if view.projection == "perspective" else {"view_height": 1300}))
    tex = np.random.default_rng(0).random((17, 23)) * 1.5  # any shape; values above 1 brighten
    outs = ("rgb", "intensity", "uv", "mask")
    plain = fcol.render(g, view, 96, 72, outputs=outs)
    textured = fcol.render(g, view, 96, 72, outputs=outs, texture=tex)
    np.testing.assert_array_equal(textured.uv, plain.uv)
    np.testing.assert_array_equal(textured.mask, plain.mask)
    check_textured(plain, textured, numpy_lookup(tex, textured.uv, g.extent))


def test_uv_is_computed_internally_and_dropped() -> None:
    g = fcol.HeightGrid(_terrain(), extent=(0, 49, 0, 39))
    view = fcol.View(40, 30, view_height=60)
    tex = np.linspace(0, 1, 40 * 50).reshape(40, 50)
    only = fcol.render(g, view, 64, 48, outputs="rgb", texture=tex)
    assert only.uv is None and only.intensity is None
    full = fcol.render(g, view, 64, 48, outputs=("rgb", "uv"), texture=tex)
    np.testing.assert_array_equal(only.rgb, full.rgb)
    # intensity-interpolation shading without refinement: the lookup still
    # uses the pixels' uv
    plain = fcol.render(g, view, 64, 48, outputs=("rgb", "intensity", "uv"), shading="intensity")
    tx = fcol.render(g, view, 64, 48, outputs=("rgb", "intensity", "uv"), shading="intensity", texture=tex)
    check_textured(plain, tx, numpy_lookup(tex, tx.uv, g.extent))


def test_function_surface_and_non_finite_texels() -> None:
    s = fcol.Function("0.3*sin(3*u)*cos(2*v)", domain=((-1, 2), (0, 1.5)))
    view = fcol.View(60, 10, view_height=3.5)
    tex = 1 + 0.1 * np.random.default_rng(1).random((9, 12))  # >= 1 but for the non-finite texels
    tex[2, 3] = np.nan
    tex[6, 7:9] = np.inf
    tex[0, 0] = -np.inf
    outs = ("rgb", "intensity", "uv")
    plain = fcol.render(s, view, 80, 60, outputs=outs)
    tx = fcol.render(s, view, 80, 60, outputs=outs, texture=tex)
    fac = numpy_lookup(tex, tx.uv, (-1.0, 2.0, 0.0, 1.5))
    check_textured(plain, tx, fac)
    on = np.isfinite(tx.uv[..., 0])
    assert np.isfinite(tx.intensity[on]).all()
    assert (fac[on] < 0.5).any()  # only pixels next to a non-finite texel (as 0) dim


def test_one_row_texture_and_integer_dtype() -> None:
    s = fcol.Function("u*v", domain=((0, 1), (0, 1)))
    view = fcol.View(90, 0, view_height=1.2)
    row = np.array([[0, 1, 2]], np.int16)
    plain = fcol.render(s, view, 40, 40, outputs=("intensity", "uv"))
    tx = fcol.render(s, view, 40, 40, outputs=("intensity", "uv"), texture=row)
    fac = numpy_lookup(row, tx.uv, (0.0, 1.0, 0.0, 1.0))
    np.testing.assert_allclose(fac[np.isfinite(fac)], 2 * tx.uv[..., 0][np.isfinite(fac)], rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(tx.intensity, (plain.intensity * fac).astype(np.float32), rtol=2.4e-7, equal_nan=True)


def test_bad_texture() -> None:
    s = fcol.Function("u*v", domain=((0, 1), (0, 1)))
    view = fcol.View(60, 0, view_height=2)
    for bad in (np.zeros(5), np.zeros((2, 3, 4)), np.zeros((0, 3)), 1.0):
        with pytest.raises(ValueError, match="texture"):
            fcol.render(s, view, 16, 16, texture=bad)
    for bad in (np.array([["a", "b"]]), np.zeros((2, 2), complex), [[object()]]):
        with pytest.raises(TypeError, match="texture"):
            fcol.render(s, view, 16, 16, texture=bad)
    with pytest.raises(ValueError, match="texture"):
        fcol.render(s, view, 16, 16, method="floating_horizon", outputs="lines", texture=np.ones((2, 2)))


def test_horizon_light_as_texture() -> None:
    z = _terrain()
    z[10:13, 20:24] = np.nan
    ext = (0.0, 490.0, 390.0, 0.0)  # north-up, 10 m cells
    hm = fcol.horizon_map(z, extent=ext, sectors=32)
    light = 0.7 * hm.sun(math.radians(200), math.radians(25), math.radians(0.27)) + 0.3 * hm.sky_view_factor()
    g = fcol.HeightGrid(z, extent=ext)
    view = fcol.View(40, 200, "perspective", target=(245, 195, 0), distance=900, fov=50)
    outs = ("rgb", "intensity", "uv")
    plain = fcol.render(g, view, 90, 70, outputs=outs)
    tx = fcol.render(g, view, 90, 70, outputs=outs, texture=light)
    check_textured(plain, tx, numpy_lookup(light, tx.uv, g.extent))
    assert np.isfinite(tx.intensity[np.isfinite(tx.uv[..., 0])]).all()
