"""Scaled spark-ignition engine (numba): full-load torque, fuel and emission rates, best-efficiency line.

A design's engine is the base map scaled by ``s = P_design / P_base`` at a fixed speed axis: torque
limits and every rate multiply by ``s`` and the maps are read at the normalised torque ``T / s``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from hevlib.lookup import blend, cell, interp1, interp_uniform
from hevlib.scaling import base_torque, scaled


class EngineArrays(NamedTuple):
    """Base (unscaled) engine tables as the kernels see them, on uniform grids (speed ``w0 + dw i``,
    torque ``dt j`` from 0); rates in g/s."""

    w0: float  # speed grid, rad/s
    dw: float
    dt: float  # torque grid step from 0, N m
    t_max: np.ndarray  # full-load torque on the speed grid, N m
    fuel: np.ndarray  # g/s
    hc: np.ndarray
    co: np.ndarray
    nox: np.ndarray
    line_p: np.ndarray  # best-efficiency line: shaft power, W (uniform grid from 0)
    line_w: np.ndarray  # ... and the speed that burns least fuel at that power, rad/s
    line_t: np.ndarray  # ... and its torque (line_p / line_w), N m, increasing with power
    t_drag: np.ndarray  # closed-throttle (motored, fuel cut) torque on the speed grid, N m, <= 0


@njit(cache=True, inline="always")
def max_torque(w: float, s: float, e: EngineArrays) -> float:
    i, f = cell(w, e.w0, e.dw, e.t_max.shape[0])
    return scaled(e.t_max[i] + f * (e.t_max[i + 1] - e.t_max[i]), s)


@njit(cache=True, inline="always")
def drag_torque(w: float, s: float, e: EngineArrays) -> float:
    """Torque (<= 0) of the engine scaled by ``s`` when it is spun with its fuel cut (closed throttle)."""
    i, f = cell(w, e.w0, e.dw, e.t_drag.shape[0])
    return scaled(e.t_drag[i] + f * (e.t_drag[i + 1] - e.t_drag[i]), s)


@njit(cache=True, inline="always")
def line_speed(p_w: float, s: float, e: EngineArrays) -> float:
    """Speed of least fuel for shaft power ``p_w`` of the engine scaled by ``s``."""
    return interp_uniform(p_w / s, 0.0, e.line_p[1], e.line_w)  # power scales as torque


@njit(cache=True, inline="always")
def line_power_for_torque(t: float, s: float, e: EngineArrays) -> float:
    """Shaft power on the best-efficiency line where the scaled engine gives torque ``t``."""
    return scaled(interp1(base_torque(t, s), e.line_t, e.line_p), s)


@njit(cache=True, inline="always")
def rates(w: float, t: float, s: float, e: EngineArrays) -> tuple[float, float, float, float]:
    """(fuel, hc, co, nox) in g/s at speed ``w`` and torque ``t`` (>= 0) of the engine scaled by ``s``."""
    i, fx = cell(w, e.w0, e.dw, e.fuel.shape[0])
    j, fy = cell(base_torque(t, s), 0.0, e.dt, e.fuel.shape[1])
    return (
        scaled(blend(e.fuel, i, j, fx, fy), s),
        scaled(blend(e.hc, i, j, fx, fy), s),
        scaled(blend(e.co, i, j, fx, fy), s),
        scaled(blend(e.nox, i, j, fx, fy), s),
    )
