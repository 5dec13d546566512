"""Horizon maps of a terrain and the sky light and shadows they give
(Stewart 1998, "Fast horizon computation at all points of a terrain with
visibility and shading applications").

``fcol.horizon_map(z, spacing)`` computes, at every sample of a height grid,
the horizon in ``sectors`` azimuth sectors. Sector i holds the azimuths
[2πi/s, 2π(i+1)/s] (closed; counted counter-clockwise from +u towards +v);
its horizon e_i is the largest elevation, measured in the vertical plane of
the sector's centre line, of **all** samples falling in the sector:
Θ = atan2(z_q − z_p, (q − p)·r_i) with r_i the unit centre direction.
A sector that holds no sample gives −π/2; no-data points (NaN) give NaN and
never cast a horizon. The terrain ends at the grid's border: nothing beyond
it casts a horizon.

From one horizon map, without recomputing it: the sky-view factor, the direct
primary illumination under any sky (a function of azimuth and elevation or a
table of s × 256 equal-area regions, §VI-A), the Stewart–Langer approximate
radiosity, and hard or soft sun shadows for any sun position (Fig. 10).
``fcol.shade_terrain`` renders the result seen from above as an
``fcol.Image``. All angles of this module are in radians.

>>> import numpy as np, fcol
>>> z = np.zeros((20, 20)); z[10, 10] = 5.0
>>> hm = fcol.horizon_map(z, spacing=1.0, sectors=8)
>>> hm.elevation.shape, hm.elevation.dtype
((8, 20, 20), dtype('float32'))
>>> bool(hm.elevation[0, 10, 5] > 0)   # the peak, seen from 5 cells to its -u side
True
"""

from __future__ import annotations

import math
import sys
from typing import Any, Callable, Sequence

import numpy as np
import numpy.typing as npt

from . import _fcol
from .image import Image

EARTH_RADIUS = 6_371_008.8  # mean Earth radius, metres
METHODS = ("stewart", "cms", "brute", "sweep")

Sky = Callable[[npt.NDArray[np.float64], npt.NDArray[np.float64]], Any]


def _text_bar() -> Callable[[int, int], None]:
    state = {"last": -1}

    def bar(done: int, total: int) -> None:
        pct = 100 * done // max(total, 1)
        if pct != state["last"]:
            state["last"] = pct
            n = pct // 4
            sys.stderr.write(f"\rhorizon [{'#' * n}{'.' * (25 - n)}] {pct:3d}%")
            if done >= total:
                sys.stderr.write("\n")
            sys.stderr.flush()

    return bar


def _progress(progress: Any) -> Callable[[int, int], None] | None:
    if progress is None or progress is False:
        return None
    if progress is True:
        return _text_bar()
    if callable(progress):
        return progress  # type: ignore[no-any-return]
    raise TypeError("progress: expected None, True (a text bar on stderr) or a callable(done, total)")


def _as_height(z: Any) -> npt.NDArray[np.float64]:
    a = np.asarray(z)
    if a.dtype == object or not (np.issubdtype(a.dtype, np.number) or a.dtype == np.bool_):
        raise TypeError(f"z: expected a real numeric array, got dtype {a.dtype}")
    if np.iscomplexobj(a):
        raise TypeError("z: complex heights are not supported; pass the real part")
    if a.ndim != 2:
        raise ValueError(f"z: expected a 2-D height grid (H, W), got shape {a.shape}")
    if a.size == 0:
        raise ValueError("z: the grid is empty")
    out = np.ascontiguousarray(a, dtype=np.float64)
    return np.where(np.isfinite(out), out, np.nan)


def _spacing(
    shape: tuple[int, int],
    spacing: Any,
    extent: Any,
    geographic: bool,
    latitude: float | None,
) -> tuple[float, float, float | None]:
    h, w = shape
    if spacing is not None and extent is not None:
        raise TypeError("give spacing=(du, dv) or extent=(u0, u1, v0, v1), not both")
    lat = latitude
    if extent is not None:
        try:
            u0, u1, v0, v1 = (float(x) for x in extent)
        except (TypeError, ValueError):
            raise TypeError("extent: expected four numbers (u0, u1, v0, v1)") from None
        if w < 2 or h < 2:
            raise ValueError("extent: needs at least 2 samples along each axis; use spacing=")
        du, dv = (u1 - u0) / (w - 1), (v1 - v0) / (h - 1)
        if lat is None:
            lat = 0.5 * (v0 + v1)
    else:
        if spacing is None:
            spacing = (1.0, 1.0)
        if np.ndim(spacing) == 0:
            du = dv = float(spacing)
        else:
            try:
                du, dv = (float(x) for x in spacing)
            except (TypeError, ValueError):
                raise TypeError("spacing: expected a number or a pair (du, dv)") from None
    for name, d in (("du", du), ("dv", dv)):
        if not math.isfinite(d) or d == 0.0:
            raise ValueError(f"spacing: {name} must be finite and non-zero, got {d}")
    if geographic:
        if lat is None:
            raise ValueError("latitude: a geographic grid given by spacing needs latitude= (degrees)")
        if not -90.0 < lat < 90.0:
            raise ValueError(f"latitude: must lie strictly between -90 and 90 degrees, got {lat}")
        m = EARTH_RADIUS * math.pi / 180.0
        du, dv = du * m * math.cos(math.radians(lat)), dv * m
    return du, dv, lat


class HorizonMap:
    """The horizons of every sample of a terrain.

    Attributes
    ----------
    elevation : float32 (k, H, W)
        Horizon elevation in radians of each computed sector (all ``sectors``
        unless ``sectors_subset`` was given): −π/2 where a sector holds no
        sample, NaN at no-data points.
    sector_indices : int (k,)
        The sector index of each plane of ``elevation``.
    azimuths : float64 (k,)
        Centre azimuth 2π(i + ½)/s of each plane, radians, counter-clockwise
        from +u towards +v.
    sectors : int
        s, the number of sectors of the full circle.
    z : float64 (H, W)
        The heights (NaN = no data); ``spacing`` the metric (du, dv).
    method, elapsed
        The algorithm and its wall time in seconds.
    """

    def __init__(
        self,
        elevation: npt.NDArray[np.float32],
        sector_indices: Sequence[int],
        sectors: int,
        z: npt.NDArray[np.float64],
        spacing: tuple[float, float],
        method: str,
        elapsed: float,
    ) -> None:
        self.elevation = elevation
        self.sector_indices = np.asarray(sector_indices, dtype=np.int64)
        self.sectors = int(sectors)
        self.azimuths = 2.0 * np.pi * (self.sector_indices + 0.5) / self.sectors
        self.z = z
        self.spacing = spacing
        self.method = method
        self.elapsed = float(elapsed)
        self._normals: npt.NDArray[np.float64] | None = None
        self._svf: npt.NDArray[np.float64] | None = None

    def __repr__(self) -> str:
        k, h, w = self.elevation.shape
        return f"<fcol.HorizonMap {h}x{w} sectors={self.sectors} computed={k} method={self.method!r} elapsed={self.elapsed:.3f} s>"

    # -- geometry ---------------------------------------------------------
    def _full(self) -> npt.NDArray[np.float32]:
        if len(self.sector_indices) != self.sectors or np.any(self.sector_indices != np.arange(self.sectors)):
            raise ValueError("this needs the horizon of every sector; compute without sectors_subset")
        return self.elevation

    def sector_of(self, azimuth: float) -> int:
        """Index of the sector holding ``azimuth`` (radians; a border azimuth
        goes to the sector it opens)."""
        s = self.sectors
        return int(math.floor((azimuth % (2 * math.pi)) * s / (2 * math.pi))) % s

    def normals(self) -> npt.NDArray[np.float64]:
        """Unit upper normals (H, W, 3) in world axes (u, v, w) from central
        differences of ``z`` (one-sided at the border, NaN next to no data);
        computed once and returned read-only."""
        if self._normals is not None:
            return self._normals
        du, dv = self.spacing
        h, w = self.z.shape
        fu = np.gradient(self.z, du, axis=1) if w > 1 else np.zeros_like(self.z)
        fv = np.gradient(self.z, dv, axis=0) if h > 1 else np.zeros_like(self.z)
        n = np.stack([-fu, -fv, np.ones_like(self.z)], axis=-1)
        self._normals = n / np.linalg.norm(n, axis=-1, keepdims=True)
        self._normals.flags.writeable = False
        return self._normals

    # -- arguments of the native sky functions ---------------------------
    def _planes(self) -> npt.NDArray[Any]:
        e = self.elevation
        if e.dtype not in (np.float32, np.float64):
            e = e.astype(np.float64)
        return np.ascontiguousarray(e)

    def _heights(self) -> npt.NDArray[np.float64]:
        return np.ascontiguousarray(self.z, dtype=np.float64)

    def _normals_arg(self, normals: npt.ArrayLike | None) -> npt.NDArray[np.float64]:
        if normals is None:
            return np.ascontiguousarray(self.normals())
        n = np.asarray(normals)
        if not (np.issubdtype(n.dtype, np.number) or n.dtype == np.bool_) or np.iscomplexobj(n):
            raise TypeError(f"normals: expected a real array, got dtype {n.dtype}")
        if n.shape != self.z.shape + (3,):
            raise ValueError(f"normals: expected shape {self.z.shape + (3,)}, got {n.shape}")
        return np.ascontiguousarray(n, dtype=np.float64)

    def _sky(self, quantity: str, normals: npt.ArrayLike | None, table: npt.NDArray[np.float64] | None = None, albedo: float = 0.5) -> npt.NDArray[np.float64]:
        self._full()
        t = None if table is None else np.ascontiguousarray(table, dtype=np.float64)
        out = _fcol.horizon_sky(self._planes(), self.sectors, self._heights(), self._normals_arg(normals), quantity, t, float(albedo))
        return out  # type: ignore[no-any-return]

    # -- sky light (§VI) --------------------------------------------------
    def sky_view_factor(self, normals: npt.NDArray[np.float64] | None = None) -> npt.NDArray[np.float64]:
        """Cosine-weighted sky-view factor (1/π)∫_V N·u dΩ (Stewart–Langer's
        D; Dozier and Frew's V_d): 1 on an open plane, NaN at no data.

        Each sector contributes in closed form over the elevations above
        max(e_i, the point's tangent plane at the sector's centre azimuth).
        Computed per point in Rust (all cores, Ctrl-C interrupts), float64.

        >>> import numpy as np, fcol
        >>> hm = fcol.horizon_map(np.zeros((8, 8)), sectors=16)
        >>> bool(np.allclose(hm.sky_view_factor(), 1.0))
        True
        """
        if normals is None and self._svf is not None:
            return self._svf.copy()
        svf = self._sky("sky_view_factor", normals)
        if normals is None:
            self._svf = svf.copy()
        return svf

    def sky_table(self, sky: Sky | npt.ArrayLike) -> npt.NDArray[np.float64]:
        """The sky as an (s, 256) table of radiances over equal-area regions:
        sector i by the sine of the elevation in 256 equal steps (§VI-A). A
        callable ``sky(azimuth, elevation)`` (radians, vectorised) is sampled
        once at the regions' centres; an array must already have shape (s, 256)."""
        s = self.sectors
        if callable(sky):
            az = (2 * np.pi * (np.arange(s) + 0.5) / s)[:, None] * np.ones((1, 256))
            el = np.arcsin((np.arange(256) + 0.5) / 256)[None, :] * np.ones((s, 1))
            t = np.asarray(sky(az, el), dtype=np.float64)
            t = np.broadcast_to(t, (s, 256)).copy()
        else:
            t = np.asarray(sky, dtype=np.float64)
            if t.shape != (s, 256):
                raise ValueError(f"sky: expected a callable or an array of shape ({s}, 256), got {t.shape}")
        if not np.all(np.isfinite(t)) or np.any(t < 0):
            raise ValueError("sky: radiances must be finite and non-negative")
        return t

    def _table(self, sky: Sky | npt.ArrayLike) -> npt.NDArray[np.float64]:
        if not callable(sky) and np.ndim(sky) == 0:
            sky = np.full((self.sectors, 256), float(sky))  # type: ignore[arg-type]
        return self.sky_table(sky)

    def illumination(self, sky: Sky | npt.ArrayLike = 1.0, normals: npt.NDArray[np.float64] | None = None) -> npt.NDArray[np.float64]:
        """Direct primary illumination ∫_V L(u) N·u dΩ of every point for a
        sky of radiance L (a number: uniform sky; a callable of (azimuth,
        elevation), sampled once on the (s, 256) regions; or an (s, 256)
        table), regions partly under the horizon counted in proportion.
        Uniform L = 1 gives π × the sky-view factor (up to the sky below the
        horizontal, which this hemisphere omits). Per point in Rust, float64,
        NaN at no data.

        >>> import numpy as np, fcol
        >>> hm = fcol.horizon_map(np.zeros((8, 8)), sectors=16)
        >>> bool(np.allclose(hm.illumination(1.0), np.pi))
        True
        """
        return self._sky("illumination", normals, self._table(sky))

    def radiosity(self, sky: Sky | npt.ArrayLike = 1.0, albedo: float = 0.5, normals: npt.NDArray[np.float64] | None = None) -> npt.NDArray[np.float64]:
        """Stewart–Langer approximate radiosity
        R = ρ·(I/π) / (1 − ρ(1 − D)) with I the direct primary illumination,
        D the sky-view factor and ρ the albedo (each point is assumed to see
        terrain of its own radiance where the sky is hidden).

        >>> import numpy as np, fcol
        >>> hm = fcol.horizon_map(np.zeros((8, 8)), sectors=16)
        >>> bool(np.allclose(hm.radiosity(1.0, albedo=0.5), 0.5))
        True
        """
        if not 0.0 <= albedo < 1.0:
            raise ValueError(f"albedo: must lie in [0, 1), got {albedo}")
        return self._sky("radiosity", normals, self._table(sky), albedo)

    # -- the sun ----------------------------------------------------------
    def _sun(self, sun_azimuth: float, sun_elevation: float, sun_radius: float, normals: npt.NDArray[np.float64] | None) -> npt.NDArray[np.float64]:
        args = {"sun_azimuth": sun_azimuth, "sun_elevation": sun_elevation, "sun_radius": sun_radius}
        vals = []
        for name, v in args.items():
            try:
                vals.append(float(v))
            except (TypeError, ValueError):
                raise TypeError(f"{name}: expected a number, got {type(v).__name__}") from None
        out = _fcol.horizon_sun(self._planes(), [int(i) for i in self.sector_indices], self.sectors, self._heights(), *vals, normals)
        return out  # type: ignore[no-any-return]

    def shadow(self, sun_azimuth: float, sun_elevation: float, sun_radius: float = 0.0) -> npt.NDArray[np.float64]:
        """Fraction of the sun visible from each point, in [0, 1] (1 = lit),
        NaN at no data. With ``sun_radius`` = 0 (radians) the sun is a point,
        lit when its elevation exceeds the horizon of the sector holding its
        azimuth (a border azimuth belongs to the sector it opens); otherwise
        the fraction of the disc's area above the piecewise-constant horizon,
        the disc taken in the sun's local tangent plane (x = Δazimuth ·
        cos(elevation), y = Δelevation). That flat model suits a real sun
        (0.27°) away from the zenith; a disc reaching past the zenith or
        wider than a half-turn of azimuth is clipped to one turn and may not
        reach 1. Only the sectors the disc covers are needed (a
        ``sectors_subset`` horizon map will do). Per point in Rust, float64.

        >>> import numpy as np, fcol
        >>> z = np.zeros((9, 9)); z[4, 8] = 3.0
        >>> hm = fcol.horizon_map(z, sectors=8)
        >>> float(hm.shadow(0.1, 0.2)[4, 0]), float(hm.shadow(0.1, 0.5)[4, 0])
        (0.0, 1.0)
        """
        return self._sun(sun_azimuth, sun_elevation, sun_radius, None)

    def sun(self, sun_azimuth: float, sun_elevation: float, sun_radius: float = 0.0, normals: npt.NDArray[np.float64] | None = None) -> npt.NDArray[np.float64]:
        """Direct sun irradiance (sun radiance 1 per unit of cos): the visible
        fraction of the disc (:meth:`shadow`) times max(0, N·s), float64
        (H, W) in grid order, usable as a ``texture=`` of ``fcol.render``.

        >>> import numpy as np, fcol
        >>> hm = fcol.horizon_map(np.zeros((4, 4)), sectors=8)
        >>> bool(np.isclose(hm.sun(0.0, 0.5)[0, 0], np.sin(0.5)))
        True
        """
        return self._sun(sun_azimuth, sun_elevation, sun_radius, self._normals_arg(normals))


def mars_sky(sun_azimuth: float, sun_elevation: float, r_sun: float = 1.0, power: float = 20.0) -> Sky:
    """The seed's Martian sky (Stewart §VI-B, Fig. 9): radiance
    R_sun·cos^power(θ), θ the angle between the sun and the view direction
    (zero beyond 90°)."""
    sd = np.array([math.cos(sun_elevation) * math.cos(sun_azimuth), math.cos(sun_elevation) * math.sin(sun_azimuth), math.sin(sun_elevation)])

    def sky(az: npt.NDArray[np.float64], el: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        c = np.cos(el) * np.cos(az) * sd[0] + np.cos(el) * np.sin(az) * sd[1] + np.sin(el) * sd[2]
        return np.asarray(r_sun * np.maximum(c, 0.0) ** power)

    return sky


def horizon_map(
    z: npt.ArrayLike,
    spacing: float | tuple[float, float] | None = None,
    *,
    extent: tuple[float, float, float, float] | None = None,
    sectors: int = 64,
    method: str = "stewart",
    max_distance: float | None = None,
    sectors_subset: Sequence[int] | None = None,
    geographic: bool = False,
    latitude: float | None = None,
    earth_curvature: bool | None = None,
    refraction: float = 0.13,
    earth_radius: float = EARTH_RADIUS,
    near_vertex: bool = False,
    progress: bool | Callable[[int, int], None] | None = None,
    out: npt.NDArray[np.float32] | None = None,
) -> HorizonMap:
    """Horizon of every sample of the height grid ``z`` in ``sectors`` sectors.

    Parameters
    ----------
    z : array (H, W) of any real dtype
        Heights; z[i, j] lies at (j·du, i·dv). NaN (or ±inf) = no data.
    spacing : du or (du, dv), default 1
        Sample spacing; a negative dv describes a north-up raster (row 0 at
        the largest v). Or ``extent=(u0, u1, v0, v1)``: the positions of the
        first and last samples along each axis.
    sectors : int ≥ 3
    method : "stewart" | "cms" | "brute" | "sweep"
        ``stewart``: exact sector maxima by Stewart's hull tree (§IV),
        O(s n (log² n + s)); equal bit for bit to ``brute``, the O(n²)
        definition. ``cms``: samples along each sector's centre line only
        (Max; Cabral, Max and Springmeyer). ``sweep``: the exact horizon
        along each centre direction on digital lines through the grid,
        O(n) per direction.
    max_distance : float, optional
        Ignore terrain farther than this (metres; horizontal distance for
        stewart and brute, along the line for cms and sweep).
    sectors_subset : sequence of int, optional
        Compute only these sectors (e.g. the one where the sun sets), each
        named once; the planes of ``elevation`` follow this order.
    geographic : bool
        ``spacing``/``extent`` are in degrees (longitude, latitude); they are
        converted to metres at the grid's latitude (the extent's centre, or
        ``latitude=``) on a sphere of ``earth_radius``.
    earth_curvature : bool, default: on for geographic grids
        Lower distant terrain by (1 − refraction)·t²/(2R), t the distance in
        the sector's vertical plane.
    near_vertex : bool
        Stewart §IV-E: also take the centre-line samples within
        d / sin(2π/s) of each point (d the larger spacing), which narrow
        sectors may otherwise miss. Off by default (the §III definition).
    progress : None, True or callable(done, total)
        Silent by default; True prints a bar on stderr.
    out : float32 array (k, H, W), optional
        Write the elevations into this array instead of a new one (k the
        number of sectors computed: ``sectors``, or the length of
        ``sectors_subset``); it must be writable and C-contiguous, and
        becomes the map's ``elevation``. Reusing one array over many calls
        (days, parameters) saves allocating and faulting in fresh memory
        each time. Its old contents are ignored: every value is written.

    Returns a :class:`HorizonMap`. Ctrl-C interrupts the computation.

    >>> import numpy as np, fcol
    >>> z = np.random.default_rng(0).random((16, 16))
    >>> a = fcol.horizon_map(z, sectors=8, method="stewart").elevation
    >>> b = fcol.horizon_map(z, sectors=8, method="brute").elevation
    >>> bool(np.array_equal(a, b))
    True
    >>> buf = np.empty((8, 16, 16), dtype=np.float32)
    >>> hm = fcol.horizon_map(z, sectors=8, method="sweep", out=buf)
    >>> hm.elevation is buf
    True
    >>> hm = fcol.horizon_map(z * 2, sectors=8, method="sweep", out=buf)  # reused
    >>> bool(np.array_equal(buf, fcol.horizon_map(z * 2, sectors=8, method="sweep").elevation))
    True
    """
    if method not in METHODS:
        raise ValueError(f"method: unknown {method!r}; choose one of {METHODS}")
    if isinstance(sectors, bool) or not isinstance(sectors, (int, np.integer)):
        raise TypeError(f"sectors: expected an int, got {type(sectors).__name__}")
    zz = _as_height(z)
    du, dv, _ = _spacing(zz.shape, spacing, extent, bool(geographic), latitude)
    if earth_curvature is None:
        earth_curvature = bool(geographic)
    curv = 0.0
    if earth_curvature:
        if not (math.isfinite(earth_radius) and earth_radius > 0):
            raise ValueError("earth_radius: must be positive")
        if not (math.isfinite(refraction) and 0.0 <= refraction < 1.0):
            raise ValueError(f"refraction: must lie in [0, 1), got {refraction}")
        curv = (1.0 - refraction) / (2.0 * earth_radius)
    subset = None
    if sectors_subset is not None:
        subset = [int(i) for i in np.atleast_1d(np.asarray(sectors_subset))]
        if any(i < 0 for i in subset):
            raise ValueError("sectors_subset: sector indices must be >= 0")
    if max_distance is not None:
        max_distance = float(max_distance)
    elev, elapsed = _fcol.horizon_grid(zz, du, dv, int(sectors), method, subset, max_distance, curv, bool(near_vertex), _progress(progress), out)
    idx = subset if subset is not None else list(range(int(sectors)))
    return HorizonMap(elev, idx, int(sectors), zz, (du, dv), method, elapsed)


def horizon_points(
    x: npt.ArrayLike,
    y: npt.ArrayLike,
    z: npt.ArrayLike,
    *,
    sectors: int = 64,
    method: str = "stewart",
    sectors_subset: Sequence[int] | None = None,
    max_distance: float | None = None,
    progress: bool | Callable[[int, int], None] | None = None,
) -> npt.NDArray[np.float32]:
    """Horizons of scattered sample points (Stewart §III needs no grid):
    float32 (k, n) radians; ``method`` "stewart" or "brute". Points must
    have distinct (x, y).

    >>> import numpy as np, fcol
    >>> e = fcol.horizon_points([0, 1, 2], [0, 0, 0], [0, 1, 0], sectors=4)
    >>> # sector 0 (azimuths 0..90°) of the first point holds (1, 0, 1); its
    >>> # elevation is measured in the plane of the 45° centre line, where
    >>> # the point lies cos 45° away: atan(1 / 0.7071) = 54.74°
    >>> round(float(np.degrees(e[0, 0])), 2)
    54.74
    """
    if method not in ("stewart", "brute"):
        raise ValueError(f"method: scattered points take 'stewart' or 'brute', got {method!r}")
    arrs = []
    for name, a in (("x", x), ("y", y), ("z", z)):
        v = np.asarray(a)
        if v.ndim != 1 or not (np.issubdtype(v.dtype, np.number) or v.dtype == np.bool_) or np.iscomplexobj(v):
            raise TypeError(f"{name}: expected a 1-D real array")
        arrs.append(np.ascontiguousarray(v, dtype=np.float64))
    subset = None if sectors_subset is None else [int(i) for i in sectors_subset]
    e, _ = _fcol.horizon_points(arrs[0], arrs[1], np.where(np.isfinite(arrs[2]), arrs[2], np.nan), int(sectors), method, subset, max_distance, _progress(progress))
    return e  # type: ignore[no-any-return]


def shade_terrain(
    z: npt.ArrayLike | None = None,
    spacing: float | tuple[float, float] | None = None,
    *,
    horizon: HorizonMap | None = None,
    sun_azimuth: float = math.radians(135.0),
    sun_elevation: float = math.radians(30.0),
    sun_radius: float = math.radians(0.27),
    sky: Sky | npt.ArrayLike | None = None,
    sun_weight: float = 0.75,
    sky_weight: float = 0.25,
    color: tuple[float, float, float] = (235.0, 200.0, 120.0),
    background: tuple[int, int, int] = (255, 255, 255),
    outputs: str | Sequence[str] = ("rgb",),
    **horizon_options: Any,
) -> Image:
    """Shade a terrain from its horizons and render it seen from above
    (SPEC §1 elevation 90°, azimuth 0: +u right, +v up), one pixel per
    sample.

    intensity = sun_weight · (visible fraction of the sun disc) · max(0, N·s)
    + sky_weight · (sky-view factor, or the illumination of ``sky`` divided
    by π). Pass ``horizon=`` to reuse a horizon map for many sun positions
    (Fig. 10: a day from one map); otherwise it is computed from ``z``,
    ``spacing`` and ``horizon_options`` (see :func:`horizon_map`). Buffers:
    rgb, intensity, depth (−w: the camera looks down from above the target
    (0, 0, 0)), normal, uv, side, mask. The (H, W) intensity in grid order,
    usable as ``fcol.render(..., texture=...)`` of a ``HeightGrid`` of the
    same z and extent, is ``HorizonMap.sun(...)`` / ``sky_view_factor()``.

    >>> import numpy as np, fcol
    >>> z = np.add.outer(np.zeros(12), np.linspace(0, 3, 12))
    >>> img = fcol.shade_terrain(z, 1.0, sectors=16, outputs=("rgb", "intensity"))
    >>> img.rgb.shape
    (12, 12, 3)
    """
    names = [outputs] if isinstance(outputs, str) else list(outputs)
    known = ("rgb", "intensity", "depth", "normal", "uv", "side", "mask")
    for nme in names:
        if nme not in known:
            raise ValueError(f"outputs: unknown or unsupported buffer {nme!r}; choose from {known}")
    if not names:
        raise ValueError("outputs: ask for at least one buffer")
    if horizon is None:
        if z is None:
            raise TypeError("shade_terrain: give z (and spacing) or horizon=")
        horizon = horizon_map(z, spacing, **horizon_options)
    elif horizon_options or z is not None:
        raise TypeError("shade_terrain: with horizon=, give no z or horizon options")
    n = horizon.normals()
    sun = horizon.sun(sun_azimuth, sun_elevation, sun_radius, normals=n)
    if sky is None:
        amb = horizon.sky_view_factor()
    else:
        amb = horizon.illumination(sky, normals=n) / np.pi
    inten = sun_weight * sun + sky_weight * amb
    zz = horizon.z
    mask = np.isfinite(zz) & np.isfinite(inten)
    du, dv = horizon.spacing
    h, w = zz.shape

    def view(a: npt.NDArray[Any]) -> npt.NDArray[Any]:
        # grid (i, j) -> image row/column seen from above
        if dv > 0:
            a = a[::-1]
        if du < 0:
            a = a[:, ::-1]
        return np.ascontiguousarray(a)

    bufs: dict[str, Any] = {}
    if "intensity" in names:
        bufs["intensity"] = view(np.where(mask, inten, np.nan).astype(np.float32))
    if "rgb" in names:
        c = np.asarray(color, dtype=np.float64)
        rgb = np.clip(inten[..., None] * c, 0, 255)
        rgb = np.where(mask[..., None], rgb, np.asarray(background, dtype=np.float64))
        bufs["rgb"] = view(np.round(rgb).astype(np.uint8))
    if "depth" in names:
        bufs["depth"] = view(np.where(mask, -zz, np.nan).astype(np.float32))
    if "normal" in names:
        bufs["normal"] = view(np.where(mask[..., None], n, np.nan).astype(np.float32))
    if "uv" in names:
        jj, ii = np.meshgrid(np.arange(w) * du, np.arange(h) * dv)
        bufs["uv"] = view(np.where(mask[..., None], np.stack([jj, ii], -1), np.nan).astype(np.float32))
    if "side" in names:
        bufs["side"] = view(mask.astype(np.int8))
    if "mask" in names:
        bufs["mask"] = view(mask)
    return Image(width=w, height=h, samples=int(mask.sum()), elapsed=horizon.elapsed, stats={"horizon_seconds": horizon.elapsed}, **bufs)
