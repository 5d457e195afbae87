"""Flat-road performance tests (numba): full-power launch, 0-100 km/h time and top speed.

Launch: from standstill with everything the driveline can give (engine at the top of its speed window
when it can run, motor at its torque limit within the battery's discharge limit at the initial SOC),
front-axle adhesion respected, stepped at ``dt``. ``f_max`` is the highest acceleration reached
(m/s^2), ``t_0_100_s`` the time to 100 km/h (inf if not reached within ``t_max``). Top speed ``v_max``
(km/h): the highest steady speed at which the available force still covers the road load, never
above the speed the component speed limits allow through ``i0`` and the gear set (or gearbox).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from hevlib.sim.drive import (
    NO_ENVELOPE,
    ON,
    R_MASS,
    R_N_BAT,
    CarrierReach,
    ConvCommand,
    KernelVehicle,
    StepRoad,
    _limited_conv,
    _limited_split,
    chassis,
    conventional_equivalent_mass_kg,
    pack_limits,
    split_design,
    split_equivalent_mass_kg,
    split_speed_limit,
)
from hevlib.sim.powertrain import conventional as conv
from hevlib.sim.powertrain import hybrid as split
from hevlib.sim.powertrain.borrow import borrowed
from hevlib.sim.powertrain.vehicle import adhesion_limit, road_total

V_100 = 100.0 / 3.6
BIG_FORCE = 1e7


@njit(cache=True)
def _hybrid_state(v, p_dis, p_chg, ch, dl: split.SplitDriveline):
    """(command, state): everything the power-split driveline can give at speed ``v`` on a flat road."""
    f_cmd = min(BIG_FORCE, adhesion_limit(0.0, 1.0, road_total(v, 0.0, 1.0, ch), ch))
    lim = split.limits(v, dl.d, dl.E, dl.M, dl.G)
    cmd = split.SplitCommand(f_cmd, ON, lim.p_e_max, p_dis, p_chg, 1.0)
    return cmd, split.dispatch(lim, cmd, dl.d, dl.E, dl.M, dl.G)


@njit(cache=True)
def _conv_gear(v, ratios, d, ch, E):
    """(wheel force command, best gear, its state) of the conventional car at speed ``v``."""
    f_cmd = min(BIG_FORCE, adhesion_limit(0.0, 1.0, road_total(v, 0.0, 1.0, ch), ch))
    g_best, st_best = 0, conv.dispatch(v, f_cmd, ratios[0], not conv.clutch_closed(v, ratios[0], d), d, E)
    for g in range(1, ratios.shape[0]):
        st = conv.dispatch(v, f_cmd, ratios[g], not conv.clutch_closed(v, ratios[g], d), d, E)
        if st.f_del > st_best.f_del:
            g_best, st_best = g, st
    return f_cmd, g_best, st_best


@njit(cache=True)
def _surplus(kind, v, p_dis, p_chg, ratios, cd, ch, dl: split.SplitDriveline):
    """Force left over the flat-road load at steady speed ``v``, N."""
    if kind == 0:
        f = _hybrid_state(v, p_dis, p_chg, ch, dl)[1].f_del
    else:
        f = _conv_gear(v, ratios, cd, ch, dl.E)[2].f_del
    return f - road_total(v, 0.0, 1.0, ch)


@njit(cache=True)
def _launch_and_top(kind, veh: KernelVehicle, i: int, dt, t_max):
    """Design ``i`` of ``veh``; kind 0: power-split hybrid, 1: conventional. Returns (f_max, t_0_100_s,
    v_max_kmh)."""
    row, c, ratios, cd, E, M, G, B = veh.rows[i], veh.c, veh.ratios, veh.cd, veh.E, veh.M, veh.G, veh.B
    row, c, ratios, E, M, G, B = borrowed((row, c, ratios, E, M, G, B))  # not reference-counted (borrow.py)
    d = split_design(row, c)
    dl = split.SplitDriveline(d, E, M, G)
    m = row[R_MASS]
    ch = chassis(
        m,
        split_equivalent_mass_kg(row, c) if kind == 0 else conventional_equivalent_mass_kg(m, 0.0, False, cd.s_eng, c),
        c,
    )
    if kind == 0:
        p_dis, p_chg = pack_limits(c.soc_init, row[R_N_BAT], c, B)
        v_lim = split_speed_limit(d)
    else:
        p_dis, p_chg = 0.0, 0.0
        v_lim = cd.w_e_max * cd.r / ratios[-1]
    # ---- launch: each step the speed the full force buys (as in a force-limited driving step)
    v, t, f_max, t100 = 0.0, 0.0, 0.0, np.inf
    env = NO_ENVELOPE  # full-power force envelope, carried from step to step (see _limited_split)
    while t < t_max and v < v_lim:
        if kind == 0:
            cmd, st = _hybrid_state(v, p_dis, p_chg, ch, dl)
            reach = CarrierReach(0.0, np.inf, 0.0)
            _, _, v_avg, env = _limited_split(v, v, v_lim, cmd, StepRoad(0.0, 1.0, dt), st, env, reach, ch, dl)
        else:
            # the gear that gains most speed over the step (a gear running out of revs mid-step loses)
            f_cmd = min(BIG_FORCE, adhesion_limit(0.0, 1.0, road_total(v, 0.0, 1.0, ch), ch))
            v_avg = 0.0
            for g in range(ratios.shape[0]):
                engaged = conv.clutch_closed(v, ratios[g], cd)  # the engine is reflected
                st_c = conv.dispatch(v, f_cmd, ratios[g], not engaged, cd, E)
                ch_g = chassis(m, conventional_equivalent_mass_kg(m, ratios[g], engaged, cd.s_eng, c), c)
                v_avg = max(
                    v_avg,
                    _limited_conv(
                        v,
                        v,
                        v_lim,
                        ConvCommand(f_cmd, ratios[g], not engaged),
                        StepRoad(0.0, 1.0, dt),
                        st_c,
                        ch_g,
                        cd,
                        E,
                    )[2],
                )
        v_next = min(max(2.0 * v_avg - v, 0.0), v_lim)
        a = (v_next - v) / dt
        f_max = max(f_max, a)
        if v_next >= V_100:
            t100 = t + dt * (V_100 - v) / max(v_next - v, 1e-12)
            break
        if a <= 1e-6:
            break
        v, t = v_next, t + dt
    # ---- top speed: the largest v <= v_lim with force >= road load (coarse scan down, then bisection)
    if _surplus(kind, v_lim, p_dis, p_chg, ratios, cd, ch, dl) >= 0.0:
        return f_max, t100, v_lim * 3.6
    hi = v_lim
    lo = hi
    while lo > 0.0:
        lo = max(lo - 5.0, 0.0)
        if _surplus(kind, lo, p_dis, p_chg, ratios, cd, ch, dl) >= 0.0:
            break
        hi = lo
    while hi - lo > 1e-3:
        mid = 0.5 * (lo + hi)
        if _surplus(kind, mid, p_dis, p_chg, ratios, cd, ch, dl) >= 0.0:
            lo = mid
        else:
            hi = mid
    return f_max, t100, lo * 3.6


@njit(cache=True, nogil=True)
def performance_batch(kind: int, veh: KernelVehicle, dt: float, t_max: float, out: np.ndarray, start: int, stop: int):
    """Rows ``start .. stop - 1`` of ``out`` (n, 3): f_max (m/s^2), t_0_100_s, v_max (km/h) of those designs of
    ``veh`` (kind 0: power-split hybrid, 1: conventional), launched at ``dt`` for at most ``t_max`` seconds.
    Releases the GIL (:func:`hevlib.sim.simulator.in_parallel`)."""
    for i in range(start, stop):
        f_max, t100, v_max = _launch_and_top(kind, veh, i, dt, t_max)
        out[i, 0], out[i, 1], out[i, 2] = f_max, t100, v_max
