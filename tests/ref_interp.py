"""Independent NumPy references for grid interpolation: Keys' cubic
convolution (a = -0.5) written from the piecewise kernel W(x) of Keys (1981),
with his boundary extension z[-1] = 3 z[0] - 3 z[1] + z[2]."""

from __future__ import annotations

import numpy as np

A = -0.5


def W(x):
    x = np.abs(x)
    return np.where(
        x <= 1,
        (A + 2) * x**3 - (A + 3) * x**2 + 1,
        np.where(x < 2, A * x**3 - 5 * A * x**2 + 8 * A * x - 4 * A, 0.0),
    )


def dW(x):
    s = np.sign(x)
    x = np.abs(x)
    return s * np.where(
        x <= 1,
        3 * (A + 2) * x**2 - 2 * (A + 3) * x,
        np.where(x < 2, 3 * A * x**2 - 10 * A * x + 8 * A, 0.0),
    )


def _pad(z):
    """Extend by one sample on each side along both axes (Keys' rule, or
    linear extrapolation for two samples)."""

    def ext(a, axis):
        a = np.moveaxis(a, axis, 0)
        if a.shape[0] >= 3:
            lo = 3 * a[0] - 3 * a[1] + a[2]
            hi = 3 * a[-1] - 3 * a[-2] + a[-3]
        else:
            lo = 2 * a[0] - a[1]
            hi = 2 * a[-1] - a[-2]
        return np.moveaxis(np.concatenate([lo[None], a, hi[None]]), 0, axis)

    return ext(ext(z, 1), 0)


def bicubic(z, u0, du, v0, dv, u, v):
    """(f, f_u, f_v) of Keys' interpolant of z[i, j] at (u0 + j du, v0 + i dv)."""
    z = np.asarray(z, float)
    zp = _pad(z)
    s = (np.asarray(u, float) - u0) / du
    t = (np.asarray(v, float) - v0) / dv
    j = np.clip(np.floor(s).astype(int), 0, z.shape[1] - 2)
    i = np.clip(np.floor(t).astype(int), 0, z.shape[0] - 2)
    f = np.zeros_like(s)
    fs = np.zeros_like(s)
    ft = np.zeros_like(s)
    for k in range(-1, 3):
        for m in range(-1, 3):
            zz = zp[i + k + 1, j + m + 1]
            f += zz * W(t - (i + k)) * W(s - (j + m))
            fs += zz * W(t - (i + k)) * dW(s - (j + m))
            ft += zz * dW(t - (i + k)) * W(s - (j + m))
    return f, fs / du, ft / dv
