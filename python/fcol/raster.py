"""Raster primitives: lines, anti-aliased lines, polygon fill and z-buffered
triangles (``fcol.raster``).

Coordinates are ``(row, col)`` with pixel centres at integers and row 0 on
top, as in NumPy indexing, so results index images directly::

    img[rr, cc] = 1

Every primitive refuses work beyond ``MAX_PIXELS`` pixels with a
``ValueError`` instead of attempting a huge allocation, and raises a
``ValueError``/``TypeError`` naming the argument on bad input. The heavy work
runs in Rust with the GIL released.

>>> import numpy as np
>>> from fcol import raster
>>> img = np.zeros((5, 8), dtype=np.uint8)
>>> rr, cc = raster.line(1, 0, 3, 7)
>>> img[rr, cc] = 1
>>> img
array([[0, 0, 0, 0, 0, 0, 0, 0],
       [1, 1, 0, 0, 0, 0, 0, 0],
       [0, 0, 1, 1, 1, 1, 0, 0],
       [0, 0, 0, 0, 0, 0, 1, 1],
       [0, 0, 0, 0, 0, 0, 0, 0]], dtype=uint8)
"""

from __future__ import annotations

import operator
from typing import Literal, overload

import numpy as np
import numpy.typing as npt

from . import _fcol

__all__ = ["MAX_PIXELS", "line", "line_aa", "polygon", "triangles"]

#: The pixel budget of every primitive (and of every fcol image).
MAX_PIXELS: int = 1 << 27

_IntArray = npt.NDArray[np.int64]
_FloatArray = npt.NDArray[np.float64]


def _int(name: str, x: object) -> int:
    if isinstance(x, (bool, np.bool_)):
        raise TypeError(f"{name}: expected an integer pixel coordinate, got a bool")
    try:
        v = operator.index(x)  # type: ignore[arg-type]
    except TypeError:
        raise TypeError(
            f"{name}: expected an integer pixel coordinate, got {type(x).__name__} {x!r}; "
            "round it first (e.g. int(round(x)))"
        ) from None
    if not -(2**63) <= v < 2**63:
        raise ValueError(f"{name}: {v} is outside the 64-bit coordinate range")
    return v


def _real_array(name: str, x: npt.ArrayLike, dtype: type = np.float64) -> np.ndarray:
    try:
        a = np.asarray(x)
    except Exception as e:  # ragged lists and the like
        raise ValueError(f"{name}: not an array of numbers ({e})") from None
    if a.dtype.kind not in "biuf":
        raise TypeError(f"{name}: expected real numbers, got an array of dtype {a.dtype}")
    return np.ascontiguousarray(a, dtype=dtype)


def line(r0: int, c0: int, r1: int, c1: int) -> tuple[_IntArray, _IntArray]:
    """Pixels of the line from ``(r0, c0)`` to ``(r1, c1)``, both included.

    The integer midpoint (Bresenham) algorithm in all eight octants: one pixel
    per step along the major axis (the column axis when both extents are
    equal), stepping along the minor axis when the decision variable is
    ``d >= 0``. At an exact tie (the ideal line passes through the midpoint
    of the two candidates) the step is diagonal; steps run from the first
    point towards the second. The result equals ``skimage.draw.line`` pixel
    for pixel.

    Returns ``(rr, cc)``, int64 arrays of length ``max(|r1-r0|, |c1-c0|) + 1``.
    Raises ``ValueError`` beyond ``MAX_PIXELS`` pixels and ``TypeError`` for
    non-integer coordinates.

    >>> rr, cc = line(0, 0, 2, -4)
    >>> rr.tolist(), cc.tolist()
    ([0, 1, 1, 2, 2], [0, -1, -2, -3, -4])
    """
    return _fcol.raster_line(_int("r0", r0), _int("c0", c0), _int("r1", r1), _int("c1", c1))


def line_aa(r0: int, c0: int, r1: int, c1: int) -> tuple[_IntArray, _IntArray, _FloatArray]:
    """Pixels and coverage of the anti-aliased line from ``(r0, c0)`` to
    ``(r1, c1)``.

    The anti-aliased Bresenham line of the notes (Wu's "virtual pixels"): at
    each of the ``n + 1`` steps along the major axis the ideal line crosses
    the minor axis at ``m + e`` (integer ``m``, ``0 <= e < 1``), and pixel
    ``m`` gets ``1 - e``, pixel ``m + 1`` gets ``e``; ``e`` is kept as an exact
    integer fraction. Each step carries intensity 1, so the total is
    ``n + 1``; pixels of zero weight are left out.

    Compared with ``skimage.draw.line_aa`` (Zingl's algorithm, whose values
    are ``1 - distance``): both give a pixel at minor-axis distance ``e`` from
    the line the values ``1 - e`` (fcol) and ``1 - e * n / L`` (scikit-image,
    ``L`` the Euclidean length), and scikit-image also touches some pixels at
    distance exactly 1, where fcol's weight is 0.

    Returns ``(rr, cc, val)`` with ``val`` in ``(0, 1]``.

    >>> rr, cc, val = line_aa(0, 0, 1, 4)
    >>> rr.tolist(), cc.tolist(), val.tolist()
    ([0, 0, 1, 0, 1, 0, 1, 1], [0, 1, 1, 2, 2, 3, 3, 4], [1.0, 0.75, 0.25, 0.5, 0.5, 0.25, 0.75, 1.0])
    """
    return _fcol.raster_line_aa(_int("r0", r0), _int("c0", c0), _int("r1", r1), _int("c1", c1))


def polygon(
    rows: npt.ArrayLike,
    cols: npt.ArrayLike,
    shape: tuple[int, ...] | None = None,
    rule: Literal["evenodd", "nonzero"] = "evenodd",
) -> tuple[_IntArray, _IntArray]:
    """Pixels whose centres lie inside the polygon with vertices
    ``(rows[k], cols[k])``, in row-major order.

    A scan-line fill with an edge table and an active edge table, with the
    fill rules of the notes: pixel centres interior to the polygon only (a
    centre exactly on a left edge is in, on a right edge out: round up on the
    left, down on the right), an edge covers the scan lines
    ``y_low <= y < y_high`` (horizontal edges are skipped, local extrema
    count twice). ``rule="evenodd"`` fills where a ray to the right crosses
    the outline an odd number of times, ``rule="nonzero"`` where the winding
    number is not zero; they differ only for self-crossing outlines (the
    centre of a pentagram).

    Compared with ``skimage.draw.polygon``: the same pixels, except centres
    lying exactly on the outline, which scikit-image always fills and fcol
    fills only on top and left edges (so two polygons sharing an edge never
    both fill its pixels). For vertices in general position no centre lies
    on the outline and the results are identical.

    ``shape`` (height, width, ...) clips the result to an image; pixels with
    negative coordinates are never returned. Fewer than three vertices give
    empty arrays. The bounding box (after clipping) must not exceed
    ``MAX_PIXELS``.

    >>> rr, cc = polygon([0.5, 0.5, 3.5], [0.5, 3.5, 0.5])
    >>> rr.tolist(), cc.tolist()
    ([1, 1, 2], [1, 2, 1])
    """
    r = _real_array("rows", rows)
    c = _real_array("cols", cols)
    if r.ndim != 1:
        raise ValueError(f"rows: expected a 1-D array of vertex rows, got shape {r.shape}")
    if c.ndim != 1:
        raise ValueError(f"cols: expected a 1-D array of vertex columns, got shape {c.shape}")
    if r.shape != c.shape:
        raise ValueError(f"cols: rows and cols must have the same length, got {r.size} and {c.size}")
    hw: tuple[int, int] | None = None
    if shape is not None:
        try:
            s = tuple(operator.index(x) for x in shape)  # type: ignore[arg-type]
        except TypeError:
            raise TypeError(f"shape: expected a tuple of integers such as (height, width), got {shape!r}") from None
        if len(s) < 2 or s[0] < 0 or s[1] < 0:
            raise ValueError(f"shape: expected (height, width, ...) with non-negative sizes, got {shape!r}")
        hw = (s[0], s[1])
    if rule not in ("evenodd", "nonzero"):
        raise ValueError(f'rule: unknown fill rule {rule!r}; use "evenodd" or "nonzero"')
    return _fcol.raster_polygon(r, c, hw, rule)


@overload
def triangles(
    vertices: npt.ArrayLike,
    faces: npt.ArrayLike,
    values: npt.ArrayLike | None = ...,
    shape: tuple[int, int] = ...,
    *,
    cull_backfaces: bool = ...,
    perspective_correct: bool = ...,
    return_face: Literal[False] = ...,
) -> tuple[_FloatArray, _FloatArray | None]: ...
@overload
def triangles(
    vertices: npt.ArrayLike,
    faces: npt.ArrayLike,
    values: npt.ArrayLike | None = ...,
    shape: tuple[int, int] = ...,
    *,
    cull_backfaces: bool = ...,
    perspective_correct: bool = ...,
    return_face: Literal[True],
) -> tuple[_FloatArray, _FloatArray | None, npt.NDArray[np.int32]]: ...
def triangles(
    vertices: npt.ArrayLike,
    faces: npt.ArrayLike,
    values: npt.ArrayLike | None = None,
    shape: tuple[int, int] | None = None,
    *,
    cull_backfaces: bool = False,
    perspective_correct: bool = False,
    return_face: bool = False,
) -> (
    tuple[_FloatArray, _FloatArray | None]
    | tuple[_FloatArray, _FloatArray | None, npt.NDArray[np.int32]]
):
    """Z-buffered Gouraud rasterisation of a triangle mesh in screen space.

    ``vertices`` (N, 3) are ``(row, col, depth)`` in continuous pixel
    coordinates (pixel centres at integers, as ``fcol.View.project`` returns
    them, with depth from ``fcol.View.depth``); ``faces`` (M, 3) are vertex
    indices; ``values`` (N,) or (N, K) are interpolated across each face;
    ``shape`` is ``(height, width)``.

    A pixel belongs to a face when its centre is inside it or on a top or
    left edge (the top-left rule: neighbouring faces never both cover, nor
    both miss, a pixel on their shared edge). The nearest face (smallest
    depth) wins, at equal depth the first listed. Depth and values are
    interpolated linearly on screen (exact for an orthographic view), or with
    ``perspective_correct=True`` through 1/depth (exact for a perspective
    view: depths must then be positive). ``cull_backfaces=True`` drops faces
    whose vertices run clockwise on screen (faces counter-clockwise seen
    from outside face away). Faces with a NaN or infinite vertex are holes.
    Values are computed only for the visible face of each pixel. The work
    runs in parallel over bands of rows; the result does not depend on the
    number of threads.

    Returns ``(depth, values_out)``: float64 (H, W) depth, NaN where no face,
    and float64 (H, W) or (H, W, K) values (NaN where no face; ``None``
    without ``values``); with ``return_face=True`` also the int32 (H, W)
    index of the visible face (-1 where none).

    >>> v = [[0, 0, 1.0], [0, 4, 2.0], [4, 0, 3.0]]
    >>> depth, val = triangles(v, [[0, 1, 2]], values=[0.0, 1.0, 2.0], shape=(3, 4))
    >>> depth
    array([[1.  , 1.25, 1.5 , 1.75],
           [1.5 , 1.75, 2.  ,  nan],
           [2.  , 2.25,  nan,  nan]])
    >>> val[1].tolist()
    [0.5, 0.75, 1.0, nan]
    """
    v = _real_array("vertices", vertices)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"vertices: expected shape (N, 3) of (row, col, depth), got {v.shape}")
    try:
        f0 = np.asarray(faces)
    except Exception as e:
        raise ValueError(f"faces: not an array of integers ({e})") from None
    if f0.size == 0 and f0.ndim <= 2:
        f0 = np.zeros((0, 3), dtype=np.int64)  # no faces: an empty image
    if f0.dtype.kind not in "iu":
        raise TypeError(f"faces: expected integer vertex indices, got an array of dtype {f0.dtype}")
    if f0.ndim != 2 or f0.shape[1] != 3:
        raise ValueError(f"faces: expected shape (M, 3) of vertex indices, got {f0.shape}")
    if f0.dtype == np.uint64 and f0.size and int(f0.max()) > np.iinfo(np.int64).max:
        raise ValueError("faces: vertex index out of range")
    f = np.ascontiguousarray(f0, dtype=np.int64)
    vals = None
    one_channel = False
    if values is not None:
        vals = _real_array("values", values)
        if vals.ndim == 1:
            one_channel = True
            vals = vals[:, None]
        if vals.ndim != 2 or vals.shape[0] != v.shape[0] or vals.shape[1] == 0:
            raise ValueError(
                f"values: expected shape ({v.shape[0]},) or ({v.shape[0]}, K), one per vertex, got {np.shape(values)}"
            )
    if shape is None:
        raise TypeError("shape: required, the (height, width) of the image")
    try:
        h, w = (operator.index(x) for x in shape)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise TypeError(f"shape: expected (height, width) integers, got {shape!r}") from None
    if h < 1 or w < 1:
        raise ValueError(f"shape: height and width must be at least 1, got {shape!r}")
    if h * w > MAX_PIXELS:
        raise ValueError(f"shape: {h}x{w} exceeds the pixel budget of {MAX_PIXELS} pixels; render smaller tiles")
    depth, out, face = _fcol.raster_triangles(
        v, f, vals, h, w, cull_backfaces=bool(cull_backfaces), perspective_correct=bool(perspective_correct)
    )
    if out is not None and one_channel:
        out = out[:, :, 0]
    if return_face:
        return depth, out, face
    return depth, out
