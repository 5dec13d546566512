"""fcol.Image: buffers, PNG for notebooks, saving through OpenImageIO."""

from __future__ import annotations

import numpy as np
import pytest

import fcol


def make():
    rng = np.random.default_rng(0)
    return fcol.Image(
        width=5, height=3, samples=12, elapsed=0.5,
        rgb=rng.integers(0, 255, (3, 5, 3), dtype=np.uint8),
        depth=rng.random((3, 5)).astype(np.float32),
        mask=np.ones((3, 5), bool),
    )


def test_buffers_and_access():
    img = make()
    assert img.buffers == ("rgb", "depth", "mask")
    assert img.normal is None
    with pytest.raises(KeyError, match="outputs"):
        img["normal"]
    with pytest.raises(KeyError):
        img["nope"]
    with pytest.raises(ValueError, match="shape"):
        fcol.Image(width=2, height=2, depth=np.zeros((3, 3), np.float32))
    assert "5x3" in repr(img)


def test_png_round_trip_with_oiio(tmp_path):
    oiio = pytest.importorskip("OpenImageIO")
    img = make()
    png = img._repr_png_()
    assert png.startswith(b"\x89PNG")
    p = tmp_path / "a.png"
    p.write_bytes(png)
    buf = oiio.ImageBuf(str(p))
    np.testing.assert_array_equal(buf.get_pixels(oiio.UINT8), img.rgb)


def test_exr_keeps_float_depth(tmp_path):
    oiio = pytest.importorskip("OpenImageIO")
    img = make()
    p = tmp_path / "d.exr"
    img.save(p, "depth")
    back = oiio.ImageBuf(str(p)).get_pixels(oiio.FLOAT)[:, :, 0]
    np.testing.assert_array_equal(back, img.depth)
