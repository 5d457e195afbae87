"""Clamped 1-D and bilinear table lookups (numba), the building block of every map.

Tables are small (7-23 points per axis), so a linear scan for the bracketing interval beats a
binary search. Values outside an axis are clamped to its ends (ADVISOR's convention).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def bracket(x: float, xs: np.ndarray) -> tuple[int, float]:
    """(i, f): x lies between xs[i] and xs[i + 1] at fraction f in [0, 1] (clamped at the ends)."""
    n = xs.shape[0]
    if x <= xs[0]:
        return 0, 0.0
    if x >= xs[n - 1]:
        return n - 2, 1.0
    i = 0
    while xs[i + 1] < x:
        i += 1
    return i, (x - xs[i]) / (xs[i + 1] - xs[i])


@njit(cache=True, inline="always")
def interp1(x: float, xs: np.ndarray, ys: np.ndarray) -> float:
    """Linear interpolation of ys(xs) at x, clamped to the end values."""
    i, f = bracket(x, xs)
    return ys[i] + f * (ys[i + 1] - ys[i])


@njit(cache=True, inline="always")
def blend(z: np.ndarray, i: int, j: int, fx: float, fy: float) -> float:
    """Bilinear blend of z around cell (i, j) with fractions (fx, fy) from :func:`bracket`."""
    return ((1.0 - fx) * ((1.0 - fy) * z[i, j] + fy * z[i, j + 1])
            + fx * ((1.0 - fy) * z[i + 1, j] + fy * z[i + 1, j + 1]))


@njit(cache=True, inline="always")
def interp2(x: float, y: float, xs: np.ndarray, ys: np.ndarray, z: np.ndarray) -> float:
    """Bilinear interpolation of z[i, j] = f(xs[i], ys[j]) at (x, y), clamped to the grid."""
    i, fx = bracket(x, xs)
    j, fy = bracket(y, ys)
    return blend(z, i, j, fx, fy)


@njit(cache=True, inline="always")
def interp_uniform(x: float, x0: float, dx: float, ys: np.ndarray) -> float:
    """Linear interpolation on the uniform grid ``x0 + dx * i`` (O(1)), clamped to the end values."""
    n = ys.shape[0]
    u = (x - x0) / dx
    if u <= 0.0:
        return ys[0]
    if u >= n - 1:
        return ys[n - 1]
    i = int(u)
    f = u - i
    return ys[i] + f * (ys[i + 1] - ys[i])
