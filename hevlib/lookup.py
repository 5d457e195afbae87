"""Clamped 1-D and bilinear table lookups (numba), the building block of every map.

The kernels read maps resampled onto uniform grids (:func:`uniform_axis`, :func:`resample`), so
finding the cell is one division (:func:`cell`). A grid that contains every breakpoint of the source
axis reproduces a piecewise-(bi)linear table exactly. :func:`bracket` (a linear scan, for the few
non-uniform tables) is kept for those. Values outside an axis are clamped to its ends (ADVISOR's
convention).
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
def cell(x: float, x0: float, dx: float, n: int) -> tuple[int, float]:
    """(i, f) on the uniform grid ``x0 + dx * i`` of ``n`` points (clamped at the ends)."""
    u = (x - x0) / dx
    if u <= 0.0:
        return 0, 0.0
    if u >= n - 1:
        return n - 2, 1.0
    i = int(u)
    return i, u - i


@njit(cache=True, inline="always")
def interp1(x: float, xs: np.ndarray, ys: np.ndarray) -> float:
    """Linear interpolation of ys(xs) at x, clamped to the end values."""
    i, f = bracket(x, xs)
    return ys[i] + f * (ys[i + 1] - ys[i])


@njit(cache=True, inline="always")
def interp1_np(x: float, xs: np.ndarray, ys: np.ndarray) -> float:
    """:func:`interp1` with numpy's arithmetic (``np.interp``: slope times offset), bit for bit, without
    the array numba's ``np.interp`` allocates for a scalar argument."""
    n = xs.shape[0]
    if x <= xs[0]:
        return ys[0]
    if x >= xs[n - 1]:
        return ys[n - 1]
    i = 0
    while xs[i + 1] <= x:
        i += 1
    if x == xs[i]:
        return ys[i]
    slope = (ys[i + 1] - ys[i]) / (xs[i + 1] - xs[i])
    return slope * (x - xs[i]) + ys[i]


@njit(cache=True, inline="always")
def blend(z: np.ndarray, i: int, j: int, fx: float, fy: float) -> float:
    """Bilinear blend of z around cell (i, j) with fractions (fx, fy) from :func:`bracket`."""
    return (1.0 - fx) * ((1.0 - fy) * z[i, j] + fy * z[i, j + 1]) + fx * (
        (1.0 - fy) * z[i + 1, j] + fy * z[i + 1, j + 1]
    )


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


def uniform_axis(axis: np.ndarray, *, max_points: int = 256, rtol: float = 1e-9) -> np.ndarray:
    """A uniform grid over ``axis`` that contains every breakpoint if one with at most ``max_points``
    exists (its step divides every breakpoint offset); otherwise the finest grid of ``max_points``."""
    axis = np.asarray(axis, dtype=float)
    span = axis[-1] - axis[0]
    offsets = axis - axis[0]
    for n_steps in range(1, max_points):
        step = span / n_steps
        k = offsets / step
        if np.allclose(k, np.round(k), rtol=0.0, atol=rtol * n_steps):
            return axis[0] + step * np.arange(n_steps + 1)
    return np.linspace(axis[0], axis[-1], max_points)


def resample(
    xs: np.ndarray, ys: np.ndarray | None, z: np.ndarray, gx: np.ndarray, gy: np.ndarray | None = None
) -> np.ndarray:
    """Table ``z`` on axes (xs[, ys]) re-read (linearly / bilinearly, clamped) on the grid (gx[, gy])."""
    if ys is None:
        return np.interp(gx, xs, z)
    return interp_map(xs, ys, z, gx[:, None], gy[None, :])


def interp_map(xs: np.ndarray, ys: np.ndarray, z: np.ndarray, x, y) -> np.ndarray:
    """Bilinear interpolation of ``z[i, j] = f(xs[i], ys[j])`` at ``(x, y)`` (broadcast), clamped to the grid.

    The vectorised twin of :func:`interp2` (same clamping), for analysis, plots and resampling.
    """
    x = np.clip(np.asarray(x, dtype=float), xs[0], xs[-1])
    y = np.clip(np.asarray(y, dtype=float), ys[0], ys[-1])
    i = np.clip(np.searchsorted(xs, x, side="right") - 1, 0, len(xs) - 2)
    j = np.clip(np.searchsorted(ys, y, side="right") - 1, 0, len(ys) - 2)
    fx = (x - xs[i]) / (xs[i + 1] - xs[i])
    fy = (y - ys[j]) / (ys[j + 1] - ys[j])
    return (1 - fx) * ((1 - fy) * z[i, j] + fy * z[i, j + 1]) + fx * ((1 - fy) * z[i + 1, j] + fy * z[i + 1, j + 1])
