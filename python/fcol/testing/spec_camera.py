"""An independent NumPy implementation of SPEC §1 (the camera), written from
the contract's text alone, for tests to compare fcol against."""

from __future__ import annotations

import numpy as np


def basis(elevation: float, azimuth: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    a, b = np.radians(elevation), np.radians(azimuth)
    d = np.array([np.cos(a) * np.sin(b), np.cos(a) * np.cos(b), -np.sin(a)])
    r = np.array([np.cos(b), -np.sin(b), 0.0])
    up = np.array([np.sin(a) * np.sin(b), np.sin(a) * np.cos(b), np.cos(a)])
    return d, r, up


class SpecCamera:
    def __init__(self, elevation, azimuth, projection="orthographic", target=(0, 0, 0),
                 view_height=None, distance=None, fov=40.0, width=64, height=48):
        self.d, self.r, self.up = basis(elevation, azimuth)
        self.T = np.asarray(target, float)
        self.persp = projection == "perspective"
        self.W, self.H = width, height
        if self.persp:
            self.E = self.T - distance * self.d
            self.F = (height / 2) / np.tan(np.radians(fov) / 2)
        else:
            self.p = view_height / height

    def screen(self, P):
        """x_pix, y_pix, depth of points (..., 3)."""
        P = np.asarray(P, float)
        if self.persp:
            Q = P - self.E
            z = Q @ self.d
            return self.F * (Q @ self.r) / z, self.F * (Q @ self.up) / z, z
        Q = P - self.T
        return (Q @ self.r) / self.p, (Q @ self.up) / self.p, Q @ self.d

    def project(self, P):
        """Continuous (row, col), pixel centres at integers."""
        x, y, _ = self.screen(P)
        # x_pix = j + 0.5 − W/2  →  j = x_pix − 0.5 + W/2
        return self.H / 2 - 0.5 - y, x - 0.5 + self.W / 2

    def rays(self):
        j, i = np.meshgrid(np.arange(self.W), np.arange(self.H))
        x = j + 0.5 - self.W / 2
        y = self.H / 2 - i - 0.5
        if self.persp:
            dirs = self.F * self.d + x[..., None] * self.r + y[..., None] * self.up
            dirs /= np.linalg.norm(dirs, axis=-1, keepdims=True)
            return np.broadcast_to(self.E, dirs.shape), dirs
        orig = self.T + (x[..., None] * self.p) * self.r + (y[..., None] * self.p) * self.up
        return orig, np.broadcast_to(self.d, orig.shape)

    @classmethod
    def from_view(cls, view, width: int, height: int) -> "SpecCamera":
        """The camera of an ``fcol.View`` (reads only its numbers)."""
        if view.projection == "perspective":
            return cls(view.elevation, view.azimuth, "perspective", target=view.target,
                       distance=view.distance, fov=view.fov, width=width, height=height)
        return cls(view.elevation, view.azimuth, "orthographic", target=view.target,
                   view_height=view.view_height, width=width, height=height)

    @property
    def origin(self) -> np.ndarray:
        """Point of depth 0: the eye (perspective) or the target (orthographic)."""
        return self.E if self.persp else self.T

    def depth_of(self, P):
        """SPEC depth z of points (..., 3)."""
        return (np.asarray(P, float) - self.origin) @ self.d

    def pixel_size(self, depth):
        """World size of one pixel at camera depth ``depth``."""
        depth = np.asarray(depth, float)
        if self.persp:
            return depth / self.F
        return np.full(depth.shape, self.p)

    @property
    def near(self) -> float:
        """Perspective points with depth ≤ near are not drawn (−inf orthographic)."""
        if self.persp:
            return 1e-9 * float(np.linalg.norm(self.T - self.E))
        return -np.inf
