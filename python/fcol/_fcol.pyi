"""Type stubs of the native module fcol._fcol (hand-written; checked by
``make stubtest``)."""

from typing import Any, Callable, Literal, Mapping, Sequence, final

import numpy as np
import numpy.typing as npt

__version__: str
build_profile: Literal["debug", "release"]
#: Instruction sets the extension was compiled for beyond its target's
#: baseline, space-separated (e.g. "sse4.2 avx2 fma avx512f"; "" for a
#: portable build).
build_features: str

class ExpressionError(ValueError): ...

_Vec3 = tuple[float, float, float]

@final
class View:
    def __new__(
        cls,
        elevation: float,
        azimuth: float,
        projection: Literal["orthographic", "perspective"] = "orthographic",
        *,
        target: _Vec3 = (0.0, 0.0, 0.0),
        view_height: float | None = None,
        distance: float | None = None,
        fov: float | None = None,
    ) -> View: ...
    @property
    def elevation(self) -> float: ...
    @property
    def azimuth(self) -> float: ...
    @property
    def projection(self) -> Literal["orthographic", "perspective"]: ...
    @property
    def target(self) -> _Vec3: ...
    @property
    def view_height(self) -> float | None: ...
    @property
    def distance(self) -> float | None: ...
    @property
    def fov(self) -> float | None: ...
    @property
    def eye(self) -> _Vec3 | None: ...
    def basis(self) -> tuple[_Vec3, _Vec3, _Vec3]: ...
    def project(
        self, points: npt.ArrayLike, width: int, height: int
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def depth(self, points: npt.ArrayLike, width: int, height: int) -> npt.NDArray[np.float64]: ...
    def rays(
        self, width: int, height: int
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def __eq__(self, value: object, /) -> bool: ...

# --- surfaces: expressions, height grids, callables -------------------------

_Domain = tuple[tuple[float, float], tuple[float, float]]
_Arr = npt.NDArray[np.float64]

@final
class Function:
    def __new__(
        cls,
        f: str | Callable[..., npt.ArrayLike],
        grad: Callable[..., tuple[npt.ArrayLike, npt.ArrayLike]] | None = None,
        domain: _Domain | None = None,
        params: Mapping[str, float] | None = None,
        *,
        t: float | None = None,
    ) -> Function: ...
    def __call__(self, u: npt.ArrayLike, v: npt.ArrayLike) -> Any: ...
    def gradient(self, u: npt.ArrayLike, v: npt.ArrayLike) -> tuple[Any, Any]: ...
    def with_params(self, **kwargs: float) -> Function: ...
    @property
    def domain(self) -> _Domain: ...
    @property
    def height_bound(self) -> tuple[float, float] | None: ...
    @property
    def expr(self) -> str | None: ...
    @property
    def params(self) -> dict[str, float]: ...
    @property
    def t(self) -> float | None: ...
    @property
    def calls(self) -> int: ...

@final
class Parametric:
    def __new__(
        cls,
        x: str | Callable[..., npt.ArrayLike],
        y: str | Callable[..., npt.ArrayLike],
        z: str | Callable[..., npt.ArrayLike],
        domain: _Domain | None = None,
        params: Mapping[str, float] | None = None,
        *,
        jac: Callable[..., tuple[npt.ArrayLike, npt.ArrayLike]] | None = None,
        t: float | None = None,
    ) -> Parametric: ...
    def __call__(self, u: npt.ArrayLike, v: npt.ArrayLike) -> tuple[Any, Any, Any]: ...
    def jacobian(self, u: npt.ArrayLike, v: npt.ArrayLike) -> tuple[_Arr, _Arr]: ...
    def hessian(self, u: npt.ArrayLike, v: npt.ArrayLike) -> tuple[_Arr, _Arr, _Arr]: ...
    def with_params(self, **kwargs: float) -> Parametric: ...
    @property
    def domain(self) -> _Domain: ...
    @property
    def exprs(self) -> tuple[str, str, str] | None: ...
    @property
    def params(self) -> dict[str, float]: ...
    @property
    def t(self) -> float | None: ...
    @property
    def calls(self) -> int: ...

@final
class HeightGrid:
    def __new__(
        cls,
        z: npt.ArrayLike,
        extent: tuple[float, float, float, float] | None = None,
        *,
        spacing: tuple[float, float] | None = None,
        origin: tuple[float, float] | None = None,
        interpolation: Literal["bilinear", "bicubic"] = "bilinear",
    ) -> HeightGrid: ...
    def __call__(self, u: npt.ArrayLike, v: npt.ArrayLike) -> Any: ...
    def gradient(self, u: npt.ArrayLike, v: npt.ArrayLike) -> tuple[Any, Any]: ...
    @property
    def shape(self) -> tuple[int, int]: ...
    @property
    def extent(self) -> tuple[float, float, float, float]: ...
    @property
    def spacing(self) -> tuple[float, float]: ...
    @property
    def interpolation(self) -> Literal["bilinear", "bicubic"]: ...
    @property
    def domain(self) -> _Domain: ...
    @property
    def height_bound(self) -> tuple[float, float] | None: ...

def _eval_height(
    surface: Function | HeightGrid, u: npt.ArrayLike, v: npt.ArrayLike, chunk: int = 256
) -> tuple[_Arr, _Arr, _Arr]: ...
def _time_height(
    surface: Function | HeightGrid,
    u: npt.ArrayLike,
    v: npt.ArrayLike,
    mode: Literal["batch", "point", "value"] = "batch",
    repeat: int = 7,
) -> float: ...
def _time_parametric(
    surface: Parametric,
    u: npt.ArrayLike,
    v: npt.ArrayLike,
    mode: Literal["second", "first", "point"] = "second",
    repeat: int = 7,
) -> float: ...

# raster

def raster_line(
    r0: int, c0: int, r1: int, c1: int
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]: ...
def raster_line_aa(
    r0: int, c0: int, r1: int, c1: int
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.float64]]: ...
def raster_polygon(
    rows: npt.NDArray[np.float64],
    cols: npt.NDArray[np.float64],
    shape: tuple[int, int] | None = None,
    rule: str = "evenodd",
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]: ...
def raster_triangles(
    vertices: npt.NDArray[np.float64],
    faces: npt.NDArray[np.int64],
    values: npt.NDArray[np.float64] | None,
    height: int,
    width: int,
    cull_backfaces: bool = False,
    perspective_correct: bool = False,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64] | None, npt.NDArray[np.int32]]: ...

# -- horizon maps (fcol.horizon) -------------------------------------------
def horizon_grid(
    z: npt.NDArray[np.float64],
    du: float,
    dv: float,
    sectors: int,
    method: str,
    subset: list[int] | None = None,
    max_distance: float | None = None,
    curvature: float = 0.0,
    near_vertex: bool = False,
    progress: object | None = None,
    out: npt.NDArray[np.float32] | None = None,
) -> tuple[npt.NDArray[np.float32], float]: ...
def horizon_points(
    x: npt.NDArray[np.float64],
    y: npt.NDArray[np.float64],
    z: npt.NDArray[np.float64],
    sectors: int,
    method: str,
    subset: list[int] | None = None,
    max_distance: float | None = None,
    progress: object | None = None,
) -> tuple[npt.NDArray[np.float32], float]: ...
def horizon_hull_stats(
    z: npt.NDArray[np.float64], du: float, dv: float, sectors: int, sector: int
) -> tuple[float, int]: ...
def horizon_sky(
    elevation: npt.NDArray[np.float32] | npt.NDArray[np.float64],
    sectors: int,
    z: npt.NDArray[np.float64],
    normals: npt.NDArray[np.float64],
    quantity: Literal["sky_view_factor", "illumination", "radiosity"],
    table: npt.NDArray[np.float64] | None = None,
    albedo: float = 0.5,
) -> npt.NDArray[np.float64]: ...
def horizon_sun(
    elevation: npt.NDArray[np.float32] | npt.NDArray[np.float64],
    sector_indices: list[int],
    sectors: int,
    z: npt.NDArray[np.float64],
    sun_azimuth: float,
    sun_elevation: float,
    sun_radius: float,
    normals: npt.NDArray[np.float64] | None = None,
) -> npt.NDArray[np.float64]: ...
# --- floating horizon and floating column (function surfaces) -------------

def render_height(
    surface: Function,
    view: View,
    width: int,
    height: int,
    method: Literal["floating_column", "floating_horizon"],
    outputs: str | tuple[str, ...] | list[str],
    options: dict[str, Any] | None = None,
) -> dict[str, Any]: ...

# parametric scan line (Blinn 1978)

def render_parametric(
    surface: Parametric | Literal["sphere", "torus", "monkey_saddle", "helicoid", "enneper", "bezier"],
    view: View,
    width: int,
    height: int,
    method: Literal["scanline"],
    outputs: str | Sequence[str],
    options: Mapping[str, Any] | None = None,
) -> dict[str, Any]: ...
