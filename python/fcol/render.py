"""`fcol.render`: one entry point for every surface renderer."""

from __future__ import annotations

from typing import Any, Sequence

from . import _fcol
from ._fcol import View
from .image import Image


def render(
    surface: Any,
    view: View,
    width: int = 640,
    height: int = 480,
    *,
    method: str | None = None,
    outputs: str | Sequence[str] = ("rgb",),
    **options: Any,
) -> Image:
    """Render ``surface`` seen through ``view`` into a ``width`` × ``height``
    image holding only the buffers named in ``outputs`` (SPEC §2).

    Function surfaces (``fcol.Function``, ``fcol.HeightGrid``) take
    ``method="floating_column"`` (default) or ``"floating_horizon"``;
    parametric surfaces (``fcol.Parametric``) take ``method="scanline"``.
    Shading options shared by all: ``light`` (None = headlight, or a
    direction (u, v, w) towards the light), ``ambient``, ``diffuse``,
    ``specular``, ``shininess``, ``upper_color``, ``under_color``,
    ``background``. Each method documents its own further options; an
    unknown option is a ``TypeError`` naming it.

    ``texture=T`` (floating column): an (H, W) array over the surface's
    domain, laid out like a height grid's z (row i along v, column j along
    u; over a ``HeightGrid``'s extent, so a north-up grid's texture is
    north-up too) — e.g. ``HorizonMap.sun(...)`` or ``sky_view_factor()``
    of the same grid. Each pixel's intensity and rgb are multiplied by T
    sampled bilinearly at the pixel's (u, v) (rgb rounded and clamped to
    0–255; background pixels unchanged). Non-finite texels count as 0 (a
    dark pixel, never a NaN colour). The pixels' (u, v) are computed even
    when ``outputs`` does not name ``"uv"``; with ``antialias`` > 1 the
    texture is sampled at the pixel centre.

    Anti-aliasing (floating column, §6.4; rgb and intensity only — depth,
    normal, uv, side and mask stay per pixel centre, equal to a render
    without it): ``antialias=k``
    averages k sub-columns per pixel column (perspective views: k passes on
    sub-pixel rays in an n-rooks pattern — sub-column m at sub-row
    q·m mod k, q coprime to k near k/φ — so both directions are sampled);
    ``coverage=True``
    blends each pixel crossed by a silhouette against
    the background (a span's outer end, the domain edge or a hole, at the
    sweep's floating-point rows) with the background by the covered
    fraction of its row extent (perspective views: of its extent along its
    sweep's vertical plane, in elevation) — intensity is the surface's times that
    fraction, NaN where nothing is covered. Both together anti-alias both
    directions. Default: neither (``antialias=1``, ``coverage=False``).

    A flat square seen at 80° elevation spans rows 0.03 … 3.97 of a 5-row
    image: its first and last rows are 47 % covered.

    >>> import fcol
    >>> s = fcol.Function("0*u", domain=((-0.5, 0.5), (-0.5, 0.5)))
    >>> v80 = fcol.View(80, 0, view_height=1.25)
    >>> flat = dict(ambient=1.0, diffuse=0.0, specular=0.0)
    >>> img = fcol.render(s, v80, 4, 5, outputs="intensity", coverage=True, **flat)
    >>> [round(float(x), 2) for x in img.intensity[:, 0]]
    [0.47, 1.0, 1.0, 1.0, 0.47]

    >>> import numpy as np, fcol
    >>> g = fcol.HeightGrid(np.zeros((3, 3)), extent=(0, 1, 0, 1))
    >>> half = np.full((3, 3), 0.5)
    >>> v = fcol.View(90, 0, view_height=1.2)
    >>> a = fcol.render(g, v, 8, 8, outputs="intensity")
    >>> b = fcol.render(g, v, 8, 8, outputs="intensity", texture=half)
    >>> bool(np.allclose(b.intensity, 0.5 * a.intensity, equal_nan=True))
    True
    """
    if not isinstance(view, View):
        raise TypeError(f"view: expected fcol.View, got {type(view).__name__}")
    for name, n in (("width", width), ("height", height)):
        if isinstance(n, bool) or not isinstance(n, int):
            raise TypeError(f"{name}: expected an int, got {type(n).__name__}")
    parametric = getattr(_fcol, "Parametric", None)
    if parametric is not None and isinstance(surface, parametric):
        native = getattr(_fcol, "render_parametric")
        method = method or "scanline"
    else:
        native = getattr(_fcol, "render_height", None)
        if native is None:
            raise NotImplementedError("this build of fcol has no function-surface renderer")
        method = method or "floating_column"
    return Image(**native(surface, view, width, height, method, outputs, options))
