"""Test surfaces for the floating renderers, as NumPy callables with exact
gradients (for the references) and as fcol surfaces (for the renderers)."""

from __future__ import annotations

import numpy as np

import fcol


def _sinuv(u, v):
    return 3 * np.sin(u * np.cos(v))


def _sinuv_grad(u, v):
    c = 3 * np.cos(u * np.cos(v))
    return c * np.cos(v), -c * u * np.sin(v)


def _bump(u, v):
    return 1.5 * np.exp(-(u * u + v * v) / 2)


def _bump_grad(u, v):
    e = 1.5 * np.exp(-(u * u + v * v) / 2)
    return -u * e, -v * e


def _ripples(u, v):
    return 0.15 * np.sin(6 * u) * np.cos(5 * v)


def _ripples_grad(u, v):
    return 0.9 * np.cos(6 * u) * np.cos(5 * v), -0.75 * np.sin(6 * u) * np.sin(5 * v)


SURFACES = {
    "sinuv": (_sinuv, _sinuv_grad, ((-5.0, 5.0), (-5.0, 5.0))),
    "bump": (_bump, _bump_grad, ((-3.0, 3.0), (-3.0, 3.0))),
    "ripples": (_ripples, _ripples_grad, ((-2.0, 2.0), (-2.0, 2.0))),
}

EXPRESSIONS = {
    "sinuv": "3*sin(u*cos(v))",
    "bump": "1.5*exp(-(u*u + v*v)/2)",
    "ripples": "0.15*sin(6*u)*cos(5*v)",
}


def surface(name: str):
    """The fcol surface of a test surface: an expression when this build has
    `fcol.Function`, else a callable object."""
    if name == "dem":
        return _surface_dem()
    f, grad, domain = SURFACES[name]
    return fcol.Function(EXPRESSIONS[name], domain=domain)


def dem_grid(n: int = 33, seed: int = 7) -> np.ndarray:
    """A synthetic digital elevation model: smooth random hills plus a ridge,
    rounded to 0.05 (integer-like plateaus), n × n samples."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0, 1, n)
    X, Y = np.meshgrid(x, x)
    z = np.zeros_like(X)
    for _ in range(6):
        cx, cy, s, a = rng.uniform(0, 1), rng.uniform(0, 1), rng.uniform(0.08, 0.25), rng.uniform(0.3, 1.0)
        z += a * np.exp(-((X - cx) ** 2 + (Y - cy) ** 2) / (2 * s * s))
    z += 0.4 * np.exp(-((X - Y - 0.1) ** 2) / 0.005)
    return np.round(z * 2.0 / 0.05) * 0.05


DEM_EXTENT = (-4.0, 4.0, -4.0, 4.0)


class Bilinear:
    """Bilinear interpolation of a grid z[i, j] at u_j, v_i (SPEC §1), with
    the interpolant's exact derivatives."""

    def __init__(self, z, extent):
        self.z = np.asarray(z, float)
        self.u0, self.u1, self.v0, self.v1 = extent
        self.ny, self.nx = self.z.shape
        self.du = (self.u1 - self.u0) / (self.nx - 1)
        self.dv = (self.v1 - self.v0) / (self.ny - 1)

    def _cell(self, u, v):
        x = (np.asarray(u, float) - self.u0) / self.du
        y = (np.asarray(v, float) - self.v0) / self.dv
        j = np.clip(np.floor(x).astype(int), 0, self.nx - 2)
        i = np.clip(np.floor(y).astype(int), 0, self.ny - 2)
        fx, fy = x - j, y - i
        z = self.z
        return fx, fy, z[i, j], z[i, j + 1], z[i + 1, j], z[i + 1, j + 1]

    def f(self, u, v):
        fx, fy, a, b, c, d = self._cell(u, v)
        return a * (1 - fx) * (1 - fy) + b * fx * (1 - fy) + c * (1 - fx) * fy + d * fx * fy

    def grad(self, u, v):
        fx, fy, a, b, c, d = self._cell(u, v)
        gu = ((b - a) * (1 - fy) + (d - c) * fy) / self.du
        gv = ((c - a) * (1 - fx) + (d - b) * fx) / self.dv
        return gu, gv


_DEM = Bilinear(dem_grid(), DEM_EXTENT)
SURFACES["dem"] = (_DEM.f, _DEM.grad, ((DEM_EXTENT[0], DEM_EXTENT[1]), (DEM_EXTENT[2], DEM_EXTENT[3])))


def _surface_dem():
    if hasattr(fcol, "HeightGrid"):
        return fcol.HeightGrid(_DEM.z, extent=DEM_EXTENT, interpolation="bilinear")
    f, grad, domain = SURFACES["dem"]
    return fcol.Function(f, grad=grad, domain=domain)
