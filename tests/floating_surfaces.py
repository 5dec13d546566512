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


class _Callable:
    """A surface object called as s(u, v) -> (w, f_u, f_v)."""

    def __init__(self, f, grad, domain):
        self.f, self.grad, self.domain = f, grad, domain

    def __call__(self, u, v):
        gu, gv = self.grad(u, v)
        return self.f(u, v), gu, gv


def surface(name: str):
    """The fcol surface of a test surface: an expression when this build has
    `fcol.Function`, else a callable object."""
    f, grad, domain = SURFACES[name]
    if hasattr(fcol, "Function"):
        return fcol.Function(EXPRESSIONS[name], domain=domain)
    return _Callable(f, grad, domain)
