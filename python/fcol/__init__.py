"""fcol: render mathematical surfaces straight from their definitions.

Function surfaces w = f(u, v) by the floating horizon and floating column
algorithms, terrain horizon maps with their sky light and shadows, and
parametric surfaces by a Newton-tracked scan line — no triangle mesh in
between. Every render reports its time and sample count; the benchmarks
(``python -m fcol.bench``) report time against error.
"""

from __future__ import annotations

from . import horizon, raster
from ._fcol import (
    ExpressionError,
    Function,
    HeightGrid,
    Parametric,
    View,
    __version__,
    build_features,
    build_profile,
)
from .horizon import HorizonMap, horizon_map, horizon_points, shade_terrain
from .image import Image
from .render import render

__all__ = [
    "ExpressionError",
    "Function",
    "HeightGrid",
    "HorizonMap",
    "Image",
    "Parametric",
    "View",
    "__version__",
    "build_features",
    "build_profile",
    "horizon",
    "horizon_map",
    "horizon_points",
    "raster",
    "render",
    "shade_terrain",
]
