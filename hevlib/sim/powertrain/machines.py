"""Scaled electric machines with their inverters (numba): torque limits and electrical power.

Sign convention: ``t`` is the torque the machine applies to its shaft, ``w`` the shaft speed; ``t*w > 0``
is motoring (electrical power drawn, ``P_e = P_m / eta``), ``t*w < 0`` generating (``P_e = P_m * eta``).
Efficiency is read on (|w|, |t| / s) of the base map; torque limits scale with ``s``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from hevlib.lookup import blend, cell
from hevlib.scaling import base_torque, scaled


class MachineArrays(NamedTuple):
    """Base machine tables on uniform grids from 0: |speed| ``dw i``, |torque| ``dt j``."""

    dw: float  # rad/s
    dt: float  # N m
    eff: np.ndarray  # (w, t) combined machine + inverter efficiency
    t_max: np.ndarray  # |torque| limit on the speed grid, N m


@njit(cache=True, inline="always")
def torque_limit(w: float, s: float, m: MachineArrays) -> float:
    i, f = cell(abs(w), 0.0, m.dw, m.t_max.shape[0])
    return scaled(m.t_max[i] + f * (m.t_max[i + 1] - m.t_max[i]), s)


@njit(cache=True, inline="always")
def _power_at(t: float, w: float, s: float, i: int, fx: float, m: MachineArrays) -> float:
    """Electrical power for torque ``t`` at speed ``w`` whose bracket on the speed axis is ``(i, fx)``."""
    p_m = t * w
    if p_m == 0.0:
        return 0.0
    j, fy = cell(base_torque(abs(t), s), 0.0, m.dt, m.eff.shape[1])
    eta = blend(m.eff, i, j, fx, fy)
    return p_m / eta if p_m > 0.0 else p_m * eta


@njit(cache=True, inline="always")
def electric_power(t: float, w: float, s: float, m: MachineArrays) -> float:
    """Electrical power in W (+ drawn from the bus) for shaft torque ``t`` at speed ``w``."""
    i, fx = cell(abs(w), 0.0, m.dw, m.eff.shape[0])
    return _power_at(t, w, s, i, fx, m)


@njit(cache=True)
def torque_for_power(p_e: float, w: float, s: float, t_cap: float, m: MachineArrays) -> float:
    """Largest |torque| (<= t_cap) whose electrical power stays within budget ``p_e``.

    ``p_e > 0``: motoring budget (torque >= 0 returned); ``p_e < 0``: most generating torque allowed
    when the bus can absorb at most ``-p_e`` (torque <= 0 returned). ``w`` must be > 0.
    """
    if w <= 0.0:
        return t_cap if p_e >= 0.0 else -t_cap
    sign = 1.0 if p_e >= 0.0 else -1.0
    i, fx = cell(w, 0.0, m.dw, m.eff.shape[0])
    t = t_cap
    if abs(_power_at(sign * t, w, s, i, fx, m)) <= abs(p_e):
        return sign * t
    # fixed point on t = |p_e| * eta / w (motoring) or |p_e| / (eta w) (generating); eta varies slowly
    for _ in range(3):
        j, fy = cell(base_torque(t, s), 0.0, m.dt, m.eff.shape[1])
        eta = blend(m.eff, i, j, fx, fy)
        t = abs(p_e) * eta / w if sign > 0.0 else abs(p_e) / (eta * w)
        if t > t_cap:
            t = t_cap
    # guarantee the budget: shrink until within it (P_e is near-proportional to t)
    for _ in range(8):
        p = abs(_power_at(sign * t, w, s, i, fx, m))
        if p <= abs(p_e) * (1.0 + 1e-12):
            break
        t *= abs(p_e) / p * (1.0 - 1e-9)
    return sign * t
