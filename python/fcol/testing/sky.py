"""NumPy reference for the sky light and sun shadows of a horizon map
(Stewart 1998 §VI), written over whole (s, H, W) arrays.

``fcol.HorizonMap`` computes the same quantities per point in Rust; these
functions keep the direct array formulation as an independent check (and
as the baseline of the horizon benchmark). They take a ``HorizonMap`` and
use only its arrays (``elevation``, ``sector_indices``, ``sectors``, ``z``)
and its NumPy ``normals()``. All angles are radians.

>>> import numpy as np, fcol
>>> from fcol.testing import sky
>>> hm = fcol.horizon_map(np.zeros((6, 6)), sectors=8)
>>> bool(np.allclose(sky.sky_view_factor(hm), 1.0))
True
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

F64 = npt.NDArray[np.float64]


def _full(hm: Any) -> npt.NDArray[Any]:
    if len(hm.sector_indices) != hm.sectors or np.any(hm.sector_indices != np.arange(hm.sectors)):
        raise ValueError("this needs the horizon of every sector; compute without sectors_subset")
    return hm.elevation  # type: ignore[no-any-return]


def effective(hm: Any, normals: F64 | None = None) -> tuple[F64, F64]:
    """Per sector the lower limit of the visible sky: the horizon or the
    point's own tangent plane at the sector's centre azimuth, whichever is
    higher."""
    e = _full(hm).astype(np.float64)
    n = hm.normals() if normals is None else np.asarray(normals, dtype=np.float64)
    phi = hm.azimuths[:, None, None]
    nz = np.maximum(n[..., 2], 1e-12)[None]
    plane = np.arctan(-(n[..., 0][None] * np.cos(phi) + n[..., 1][None] * np.sin(phi)) / nz)
    return np.maximum(e, plane), n


def sky_view_factor(hm: Any, normals: F64 | None = None) -> F64:
    """Cosine-weighted sky-view factor (1/π)∫_V N·u dΩ, closed form per
    sector over the elevations above max(e_i, tangent plane)."""
    e, n = effective(hm, normals)
    s = hm.sectors
    phi0 = 2 * np.pi * np.arange(s) / s
    phi1 = 2 * np.pi * (np.arange(s) + 1) / s
    dphi = 2 * np.pi / s
    cx = (np.sin(phi1) - np.sin(phi0))[:, None, None]
    cy = (np.cos(phi0) - np.cos(phi1))[:, None, None]
    hz = 0.5 * np.cos(e) ** 2 * dphi
    hh = np.pi / 4 - e / 2 - np.sin(2 * e) / 4
    tot = n[..., 2] * hz.sum(0) + n[..., 0] * (cx * hh).sum(0) + n[..., 1] * (cy * hh).sum(0)
    return np.asarray(tot / np.pi)


def illumination(hm: Any, table: npt.ArrayLike, normals: F64 | None = None) -> F64:
    """Direct primary illumination ∫_V L N·u dΩ for an (s, 256) equal-area
    sky table, the band cut by the horizon counted in proportion."""
    table = np.asarray(table, dtype=np.float64)
    e, n = effective(hm, normals)
    s = hm.sectors
    th = np.arcsin(np.arange(257) / 256)  # band borders
    hz = 0.5 * np.sin(th) ** 2 * (2 * np.pi / s)  # ∫ sinθ cosθ dθ dφ
    hh = th / 2 + np.sin(2 * th) / 4  # ∫ cos²θ dθ
    phi0 = 2 * np.pi * np.arange(s) / s
    phi1 = 2 * np.pi * (np.arange(s) + 1) / s
    cx = np.sin(phi1) - np.sin(phi0)
    cy = np.cos(phi0) - np.cos(phi1)
    mz = table * np.diff(hz)[None]
    mh = table * np.diff(hh)[None]
    tz = np.concatenate([np.cumsum(mz[:, ::-1], 1)[:, ::-1], np.zeros((s, 1))], 1)
    th_ = np.concatenate([np.cumsum(mh[:, ::-1], 1)[:, ::-1], np.zeros((s, 1))], 1)
    out = np.zeros(hm.z.shape)
    for i in range(s):
        ei = np.clip(np.nan_to_num(e[i], nan=np.pi / 2), 0.0, np.pi / 2)
        k = np.minimum((np.sin(ei) * 256).astype(np.int64), 255)
        part_z = table[i, k] * (hz[k + 1] - 0.5 * np.sin(ei) ** 2 * (2 * np.pi / s))
        part_h = table[i, k] * (hh[k + 1] - (ei / 2 + np.sin(2 * ei) / 4))
        iz = tz[i, k + 1] + part_z
        ih = th_[i, k + 1] + part_h
        out += n[..., 2] * iz + (n[..., 0] * cx[i] + n[..., 1] * cy[i]) * ih
    out[~np.isfinite(hm.z)] = np.nan
    return out


def radiosity(hm: Any, table: npt.ArrayLike, albedo: float = 0.5, normals: F64 | None = None) -> F64:
    """Stewart–Langer R = ρ(I/π)/(1 − ρ(1 − D))."""
    i = illumination(hm, table, normals)
    d = sky_view_factor(hm, normals)
    return np.asarray(albedo * (i / np.pi) / (1.0 - albedo * (1.0 - d)))


def disc_strip_above(x0: float, x1: float, y0: npt.ArrayLike, r: float) -> F64:
    """Area of the disc x² + y² ≤ r² within x0 ≤ x ≤ x1 and y ≥ y0
    (vectorised in y0, NaN treated as no obstruction)."""
    y = np.nan_to_num(np.asarray(y0, dtype=np.float64), nan=-np.inf)

    def g(x: Any) -> Any:  # antiderivative of sqrt(r² − x²) on [−r, r]
        x = np.clip(x, -r, r)
        return 0.5 * (x * np.sqrt(np.maximum(r * r - x * x, 0.0)) + r * r * np.arcsin(x / r))

    def integral(lo: Any, hi: Any) -> Any:
        lo, hi = np.maximum(lo, x0), np.minimum(hi, x1)
        return np.where(hi > lo, g(hi) - g(lo), 0.0)

    yc = np.clip(y, -r, r)
    a = np.sqrt(np.maximum(r * r - yc * yc, 0.0))
    inner = integral(-a, a) - yc * np.maximum(np.minimum(a, x1) - np.maximum(-a, x0), 0.0)
    outer = 2 * (integral(-r, -a) + integral(a, r))
    area = inner + np.where(yc < 0, outer, 0.0)
    return np.asarray(np.where(y >= r, 0.0, np.where(y <= -r, 2 * integral(-r, r), area)))


def sector_of(azimuth: float, s: int) -> int:
    """Sector holding ``azimuth`` (a border azimuth opens its sector)."""
    return int(math.floor((azimuth % (2 * math.pi)) * s / (2 * math.pi))) % s


def shadow(hm: Any, sun_azimuth: float, sun_elevation: float, sun_radius: float = 0.0) -> F64:
    """Visible fraction of the sun: a point sun against the horizon of its
    sector, or the area of a disc of radius ``sun_radius`` in the sun's
    tangent plane (x = Δazimuth·cos elevation, y = Δelevation) above the
    piecewise-constant horizon, over πr²."""
    s = hm.sectors
    planes = {int(i): k for k, i in enumerate(hm.sector_indices)}

    def plane(i: int) -> F64:
        if i not in planes:
            raise ValueError(f"sectors_subset: the sun needs sector {i}, which was not computed")
        return np.asarray(hm.elevation[planes[i]], dtype=np.float64)

    nan = ~np.isfinite(hm.z)
    if sun_radius == 0:
        out = (sun_elevation > plane(sector_of(sun_azimuth, s))).astype(np.float64)
        out[nan] = np.nan
        return out
    r = sun_radius
    cs = max(math.cos(sun_elevation), 1e-9)
    half = min(r / cs, math.pi)
    area = np.zeros(hm.z.shape)
    w = 2 * math.pi / s
    for i in range(s):
        lo = ((2 * math.pi * i / s - sun_azimuth + math.pi) % (2 * math.pi)) - math.pi
        hi = lo + w
        if hi < -half or lo > half:
            continue
        area += disc_strip_above(lo * cs, hi * cs, plane(i) - sun_elevation, r)
    out = np.clip(area / (math.pi * r * r), 0.0, 1.0)
    out[nan] = np.nan
    return out


def sun(hm: Any, sun_azimuth: float, sun_elevation: float, sun_radius: float = 0.0, normals: F64 | None = None) -> F64:
    """Direct sun irradiance: visible fraction × max(0, N·s)."""
    n = hm.normals() if normals is None else np.asarray(normals, dtype=np.float64)
    d = np.array([math.cos(sun_elevation) * math.cos(sun_azimuth), math.cos(sun_elevation) * math.sin(sun_azimuth), math.sin(sun_elevation)])
    return np.asarray(shadow(hm, sun_azimuth, sun_elevation, sun_radius) * np.maximum(n @ d, 0.0))
