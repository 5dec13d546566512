"""`fcol.Image`: the buffers of one render, with its sample count and time.

Only the buffers asked for exist; the others are ``None``. Arrays are
C-contiguous NumPy arrays, row 0 on top (SPEC §2)."""

from __future__ import annotations

import os
import struct
import zlib
from typing import Any, Mapping

import numpy as np
import numpy.typing as npt

BUFFERS = ("rgb", "intensity", "depth", "normal", "uv", "side", "mask", "lines")


def png_bytes(pixels: npt.NDArray[np.uint8]) -> bytes:
    """Encode an (H, W) grey or (H, W, 3) / (H, W, 4) uint8 array as PNG."""
    a = np.ascontiguousarray(pixels, dtype=np.uint8)
    if a.ndim == 2:
        colour_type, channels = 0, 1
    elif a.ndim == 3 and a.shape[2] in (3, 4):
        colour_type, channels = (2 if a.shape[2] == 3 else 6), a.shape[2]
    else:
        raise ValueError(f"pixels: expected (H, W), (H, W, 3) or (H, W, 4), got {a.shape}")
    h, w = a.shape[:2]
    if h == 0 or w == 0:
        raise ValueError("pixels: image is empty")
    raw = np.empty((h, 1 + w * channels), dtype=np.uint8)
    raw[:, 0] = 0  # filter type None
    raw[:, 1:] = a.reshape(h, w * channels)

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", w, h, 8, colour_type, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw.tobytes(), 6)) + chunk(b"IEND", b"")


def to_display(name: str, a: npt.NDArray[Any]) -> npt.NDArray[np.uint8]:
    """An 8-bit picture of any buffer: colour as is, lines and masks as
    black on white, float buffers scaled to their finite range (NaN white)."""
    if name == "rgb":
        return np.ascontiguousarray(a, dtype=np.uint8)
    if name == "lines":
        return (255 - a).astype(np.uint8)
    if name == "mask":
        return np.where(a, 0, 255).astype(np.uint8)
    if name == "side":
        out = np.full(a.shape + (3,), 255, np.uint8)
        out[a > 0] = (235, 200, 120)
        out[a < 0] = (110, 150, 230)
        return out
    f = np.asarray(a, dtype=np.float64)
    if name == "normal":
        out = np.where(np.isfinite(f), (f * 0.5 + 0.5) * 255, 255)
        return np.clip(out, 0, 255).astype(np.uint8)
    if name == "uv":
        f = np.concatenate([f, np.zeros(f.shape[:2] + (1,))], axis=2)
    finite = np.isfinite(f)
    if not finite.any():
        return np.full(f.shape, 255, np.uint8)
    lo, hi = np.nanmin(f[finite]), np.nanmax(f[finite])
    scale = 1.0 / (hi - lo) if hi > lo else 0.0
    g = np.where(finite, (f - lo) * scale * 255, 255)
    return np.clip(g, 0, 255).astype(np.uint8)


class Image:
    """The result of a render.

    Attributes: one per buffer of SPEC §2 (``rgb``, ``intensity``, ``depth``,
    ``normal``, ``uv``, ``side``, ``mask``, ``lines``; ``None`` if not asked
    for), ``width``, ``height``, ``samples`` (function evaluations),
    ``elapsed`` (seconds) and ``stats`` (renderer counters).

    >>> import numpy as np, fcol
    >>> img = fcol.Image(width=2, height=1, mask=np.array([[True, False]]))
    >>> img.buffers
    ('mask',)
    >>> img.to_png()[:4]
    b'\\x89PNG'
    """

    rgb: npt.NDArray[np.uint8] | None
    intensity: npt.NDArray[np.float32] | None
    depth: npt.NDArray[np.float32] | None
    normal: npt.NDArray[np.float32] | None
    uv: npt.NDArray[np.float32] | None
    side: npt.NDArray[np.int8] | None
    mask: npt.NDArray[np.bool_] | None
    lines: npt.NDArray[np.uint8] | None

    def __init__(
        self,
        *,
        width: int,
        height: int,
        samples: int = 0,
        elapsed: float = 0.0,
        stats: Mapping[str, float] | None = None,
        **buffers: npt.NDArray[Any],
    ) -> None:
        self.width = int(width)
        self.height = int(height)
        self.samples = int(samples)
        self.elapsed = float(elapsed)
        self.stats = dict(stats or {})
        for name in buffers:
            if name not in BUFFERS:
                raise TypeError(f"Image: unknown buffer {name!r}; buffers are {BUFFERS}")
        for name in BUFFERS:
            a = buffers.get(name)
            if a is not None and a.shape[:2] != (self.height, self.width):
                raise ValueError(f"{name}: shape {a.shape} does not match {self.height}x{self.width}")
            setattr(self, name, a)

    @property
    def buffers(self) -> tuple[str, ...]:
        """Names of the buffers this image holds."""
        return tuple(n for n in BUFFERS if getattr(self, n) is not None)

    def __getitem__(self, name: str) -> npt.NDArray[Any]:
        if name not in BUFFERS:
            raise KeyError(f"{name!r} is not a buffer; buffers are {BUFFERS}")
        a = getattr(self, name)
        if a is None:
            raise KeyError(f"buffer {name!r} was not rendered; pass outputs=(..., {name!r})")
        return a  # type: ignore[no-any-return]

    def __repr__(self) -> str:
        return (
            f"<fcol.Image {self.width}x{self.height} buffers={list(self.buffers)} "
            f"samples={self.samples} elapsed={self.elapsed * 1e3:.2f} ms>"
        )

    def _display_buffer(self) -> str:
        for name in ("rgb", "lines", "intensity", "mask", "depth", "normal", "side", "uv"):
            if getattr(self, name) is not None:
                return name
        raise ValueError("image holds no buffer")

    def to_png(self, buffer: str | None = None) -> bytes:
        """PNG bytes of a buffer (default: the first of rgb, lines,
        intensity, mask, depth, …)."""
        name = buffer or self._display_buffer()
        return png_bytes(to_display(name, self[name]))

    def _repr_png_(self) -> bytes:
        return self.to_png()

    def save(self, path: str | os.PathLike[str], buffer: str | None = None) -> None:
        """Write a buffer to a file. ``.png`` (colour or an 8-bit picture of
        any buffer) works everywhere; ``.exr``, ``.tif`` and other formats
        need OpenImageIO, which writes float buffers at full precision."""
        path = os.fspath(path)
        name = buffer or self._display_buffer()
        a = self[name]
        ext = os.path.splitext(path)[1].lower()
        try:
            import OpenImageIO as oiio  # type: ignore[import-not-found]
        except ImportError:
            oiio = None
        if oiio is None:
            if ext != ".png":
                raise ValueError(f"path: writing {ext!r} needs OpenImageIO (pip install openimageio); use .png")
            with open(path, "wb") as f:
                f.write(self.to_png(name))
            return
        if ext == ".png" or ext in (".jpg", ".jpeg"):
            pix = to_display(name, a)
        else:
            pix = np.ascontiguousarray(a)
            if pix.dtype == np.bool_:
                pix = pix.astype(np.uint8) * 255
            elif pix.dtype == np.int8:
                pix = pix.astype(np.float32)
        if pix.ndim == 2:
            pix = pix[:, :, None]
        out = oiio.ImageOutput.create(path)
        if out is None:
            raise ValueError(f"path: OpenImageIO cannot write {path!r}: {oiio.geterror()}")
        fmt = {np.dtype(np.uint8): oiio.UINT8, np.dtype(np.float32): oiio.FLOAT}.get(pix.dtype, oiio.FLOAT)
        spec = oiio.ImageSpec(pix.shape[1], pix.shape[0], pix.shape[2], fmt)
        try:
            if not out.open(path, spec):
                raise ValueError(f"path: cannot open {path!r}: {out.geterror()}")
            if not out.write_image(pix):
                raise ValueError(f"path: cannot write {path!r}: {out.geterror()}")
        finally:
            out.close()
