"""Type stubs of the native module fcol._fcol (hand-written; checked by
``make stubtest``)."""

from typing import Literal, final

import numpy as np
import numpy.typing as npt

__version__: str
build_profile: Literal["debug", "release"]

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
