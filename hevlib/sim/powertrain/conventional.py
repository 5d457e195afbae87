"""Conventional driveline (numba): engine, dry clutch, manual 5-speed with final drive folded in.

Gearbox losses follow ADVISOR's TX_VW regression (``P_loss = (a r + b) w_out + (c/r + d)|T_out| +
e P_out + f``, clipped at zero as ADVISOR clips its map). Below the launch speed the clutch slips and
the engine holds the launch speed; while braking, coasting or stopped the clutch is open and the
engine idles carrying the mechanical accessory load.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from hevlib.sim.powertrain.engine import EngineArrays, max_torque


class ConvDesign(NamedTuple):
    s_eng: float
    r: float  # wheel radius, m
    w_idle: float  # rad/s
    w_launch: float  # engine speed held while the clutch slips, rad/s
    w_e_max: float
    p_acc_w: float  # mechanical accessory load on the engine, W
    gb_a: float
    gb_b: float
    gb_c: float
    gb_d: float
    gb_e: float
    gb_f: float


class ConvState(NamedTuple):
    f_del: float  # wheel force, N (>= 0; braking is all friction)
    engaged: bool
    w_e: float
    t_e: float  # engine torque incl. accessory, N m
    w_in: float  # gearbox input speed, rad/s
    t_in: float  # gearbox input torque (clutch torque), N m
    loss_gb_w: float
    loss_clutch_w: float


@njit(cache=True, inline="always")
def gearbox_loss(w_out: float, t_out: float, ratio: float, d: ConvDesign) -> float:
    if w_out <= 0.0:
        return 0.0
    t = abs(t_out)
    p = (d.gb_a * ratio + d.gb_b) * w_out + (d.gb_c / ratio + d.gb_d) * t + d.gb_e * w_out * t + d.gb_f
    return max(p, 0.0)


@njit(cache=True, inline="always")
def clutch_closed(v: float, ratio: float, d: ConvDesign) -> bool:
    """The clutch is closed (no slip, the engine turns with the wheels) in the gear of ``ratio`` at speed
    ``v``: the engine speed it implies lies between the launch speed and the engine's top speed."""
    return d.w_launch <= v / d.r * ratio <= d.w_e_max


@njit(cache=True, inline="always")
def idle_state(d: ConvDesign) -> ConvState:
    return ConvState(0.0, False, d.w_idle, d.p_acc_w / d.w_idle, 0.0, 0.0, 0.0, 0.0)


@njit(cache=True)
def dispatch(v: float, f_req: float, ratio: float, d: ConvDesign, E: EngineArrays) -> ConvState:
    """Operating point in the gear of overall ratio ``ratio`` at mean speed ``v`` for wheel force ``f_req``."""
    if f_req <= 0.0:
        return idle_state(d)
    w_out = v / d.r
    w_in = w_out * ratio
    if w_in > d.w_e_max:
        return idle_state(d)  # gear not usable at this speed
    t_out = f_req * d.r
    loss = gearbox_loss(w_out, t_out, ratio, d)
    t_in = (t_out * w_out + loss) / w_in if w_in > 0.0 else t_out / ratio
    w_e = max(w_in, d.w_launch)  # below the launch speed the clutch slips
    t_acc = d.p_acc_w / w_e
    t_cap = max_torque(w_e, d.s_eng, E) - t_acc
    if t_in > t_cap:
        t_in = max(t_cap, 0.0)
        if w_out > 0.0:
            # invert P_in = t_out w_out + max(k_0 + k_t t_out, 0) for the wheel torque the capped input gives
            k_t = (d.gb_c / ratio + d.gb_d) + d.gb_e * w_out
            k_0 = (d.gb_a * ratio + d.gb_b) * w_out + d.gb_f
            t_out = (t_in * w_in - k_0) / (w_out + k_t)
            if k_0 + k_t * t_out < 0.0:
                t_out = t_in * ratio
            t_out = max(t_out, 0.0)
            loss = t_in * w_in - t_out * w_out
        else:
            t_out = t_in * ratio
            loss = 0.0
    slip = (w_e - w_in) * t_in
    return ConvState(t_out / d.r, True, w_e, t_in + t_acc, w_in, t_in, loss, slip)


@njit(cache=True)
def scheduled_gear(v_kmh: float, upshift_kmh: np.ndarray) -> int:
    """Speed-based schedule (ADVISOR PTC_CONV): gear index 0.. from the upshift speeds."""
    g = 0
    for s in upshift_kmh:
        if v_kmh >= s:
            g += 1
    return g


@njit(cache=True)
def best_gear(v: float, f_req: float, g0: int, ratios: np.ndarray, d: ConvDesign, E: EngineArrays) -> int:
    """Kick-down: the scheduled gear ``g0`` unless a lower gear delivers more of ``f_req``."""
    best, f_best = g0, dispatch(v, f_req, ratios[g0], d, E).f_del
    if f_best >= f_req * (1.0 - 1e-12):
        return g0
    for g in range(g0 - 1, -1, -1):
        f = dispatch(v, f_req, ratios[g], d, E).f_del
        if f > f_best:
            best, f_best = g, f
    return best
