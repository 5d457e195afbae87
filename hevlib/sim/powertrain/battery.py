"""Rint battery pack of ``n_bat`` series modules: terminal power, current and limits (numba)."""

from __future__ import annotations

import math
from typing import NamedTuple

from numba import njit


@njit(cache=True, inline="always")
def current_for_power(p_w: float, voc: float, r_dis: float, r_chg: float) -> float:
    """Pack current (A, + discharge) that delivers terminal power ``p_w`` (W, + discharge).

    Discharge: P = V I - R I^2 (smaller root); charge: P = V I - R I^2 with I < 0.
    """
    if p_w >= 0.0:
        disc = voc * voc - 4.0 * r_dis * p_w
        if disc < 0.0:
            disc = 0.0
        return (voc - math.sqrt(disc)) / (2.0 * r_dis)
    disc = voc * voc - 4.0 * r_chg * p_w  # p_w < 0 so disc > voc^2
    return (voc - math.sqrt(disc)) / (2.0 * r_chg)


@njit(cache=True, inline="always")
def charge_drawn(p_batt: float, ocv: float, r_d: float, r_c: float, h: float, eta_c: float) -> float:
    """Charge the pack gives at terminal power ``p_batt`` over ``h`` seconds (negative: taken, at the coulombic
    efficiency ``eta_c``), A s."""
    if h <= 0.0:
        return 0.0
    i_a = current_for_power(p_batt, ocv, r_d, r_c)
    return i_a * h if i_a >= 0.0 else eta_c * i_a * h


class PackLimits(NamedTuple):
    """What bounds the pack's power over one step besides its state (:func:`power_limits`)."""

    v_min_v: float  # terminal voltage window of the pack
    v_max_v: float
    i_max_a: float  # most current either way
    soc_min: float  # SOC window the step may not leave
    soc_max: float
    capacity_as: float  # capacity, A s
    eta_c: float  # coulombic efficiency of charging
    dt_s: float  # the step


@njit(cache=True, inline="always")
def power_limits(voc: float, r_dis: float, r_chg: float, soc: float, lim: PackLimits) -> tuple[float, float]:
    """(max discharge, max charge) terminal power in W, both >= 0, of the pack at open-circuit voltage ``voc`` with
    resistances ``r_dis``/``r_chg`` at ``soc``.

    Limits: terminal voltage within [v_min, v_max], |current| <= i_max, matched-load power, and the
    SOC window (the step may not take SOC outside [soc_min, soc_max]).
    """
    v_min, v_max, i_max, dt = lim.v_min_v, lim.v_max_v, lim.i_max_a, lim.dt_s
    soc_min, soc_max, capacity_as, eta_c = lim.soc_min, lim.soc_max, lim.capacity_as, lim.eta_c
    i_dis = min(i_max, (voc - v_min) / r_dis, voc / (2.0 * r_dis), (soc - soc_min) * capacity_as / dt)
    i_dis = max(i_dis, 0.0)
    p_dis = voc * i_dis - r_dis * i_dis * i_dis
    i_chg = min(i_max, (v_max - voc) / r_chg, (soc_max - soc) * capacity_as / (dt * eta_c))
    i_chg = max(i_chg, 0.0)
    p_chg = voc * i_chg + r_chg * i_chg * i_chg
    return max(p_dis, 0.0), max(p_chg, 0.0)
