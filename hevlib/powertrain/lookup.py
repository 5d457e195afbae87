"""Clamped 1-D and bilinear table lookups (numba), the building block of every map."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def interp1(x: float, xs: np.ndarray, ys: np.ndarray) -> float:
    """Linear interpolation of ys(xs) at x, clamped to the end values."""
    n = xs.shape[0]
    if x <= xs[0]:
        return ys[0]
    if x >= xs[n - 1]:
        return ys[n - 1]
    i = np.searchsorted(xs, x) - 1
    f = (x - xs[i]) / (xs[i + 1] - xs[i])
    return ys[i] + f * (ys[i + 1] - ys[i])


@njit(cache=True, inline="always")
def interp2(x: float, y: float, xs: np.ndarray, ys: np.ndarray, z: np.ndarray) -> float:
    """Bilinear interpolation of z[i, j] = f(xs[i], ys[j]) at (x, y), clamped to the grid."""
    nx, ny = xs.shape[0], ys.shape[0]
    if x <= xs[0]:
        i, fx = 0, 0.0
    elif x >= xs[nx - 1]:
        i, fx = nx - 2, 1.0
    else:
        i = np.searchsorted(xs, x) - 1
        fx = (x - xs[i]) / (xs[i + 1] - xs[i])
    if y <= ys[0]:
        j, fy = 0, 0.0
    elif y >= ys[ny - 1]:
        j, fy = ny - 2, 1.0
    else:
        j = np.searchsorted(ys, y) - 1
        fy = (y - ys[j]) / (ys[j + 1] - ys[j])
    z00, z01, z10, z11 = z[i, j], z[i, j + 1], z[i + 1, j], z[i + 1, j + 1]
    return (1.0 - fx) * ((1.0 - fy) * z00 + fy * z01) + fx * ((1.0 - fy) * z10 + fy * z11)
