"""Flat-road performance tests (numba): full-power launch, 0-100 km/h time and top speed.

Launch: from standstill with everything the driveline can give (engine at the top of its speed window
when it can run, motor at its torque limit within the battery's discharge limit at the drive's initial SOC,
``sim.soc_init``), front-axle adhesion respected, stepped at ``dt``. ``f_max`` is the highest acceleration reached
(m/s^2), ``t_0_100_s`` the time to 100 km/h (inf if not reached within ``t_max``). Top speed ``v_max``
(km/h): the highest steady speed at which the available force still covers the road load, never
above the speed the component speed limits allow through ``i0`` and the gear set (or gearbox).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, types
from numba.extending import overload

from hevlib.sim.drive import (
    NO_ENVELOPE,
    ON,
    R_MASS,
    R_N_BAT,
    R_SOC0,
    ConvCommand,
    ConventionalRec,
    DriveConfig,
    HybridRec,
    StepRoad,
    chassis,
    conventional_equivalent_mass_kg,
    limited_step_conv,
    limited_step_split,
    pack_limits,
    split_design,
    split_equivalent_mass_kg,
    split_speed_limit,
)
from hevlib.sim.powertrain import conventional as conv
from hevlib.sim.powertrain import hybrid as split
from hevlib.sim.powertrain.borrow import borrowed
from hevlib.sim.powertrain.engine import EngineArrays
from hevlib.sim.powertrain.vehicle import Chassis, adhesion_limit, road_total

V_100 = 100.0 / 3.6
BIG_FORCE = 1e7


class HybridFlat(NamedTuple):
    """One power-split design on the flat-road tests: its chassis, the pack's power limits at the initial SOC,
    its driveline and the top speed its components allow (m/s)."""

    ch: Chassis
    p_dis_w: float
    p_chg_w: float
    dl: split.SplitDriveline
    v_lim_mps: float


class ConventionalFlat(NamedTuple):
    """One conventional car on the flat-road tests: its chassis (clutch open), mass, drive settings, gearbox and
    engine, and its top speed in the highest gear at the engine's speed limit (m/s)."""

    ch: Chassis
    m_kg: float
    c: DriveConfig
    ratios: np.ndarray
    cd: conv.ConvDesign
    E: EngineArrays
    v_lim_mps: float


def _is(ty, cls) -> bool:
    return isinstance(ty, types.BaseNamedTuple) and ty.instance_class is cls


# ---- what differs between the two kinds, chosen by the record's type while numba compiles (no kind flag)
def _flat(veh, i):
    """The flat-road record (:class:`HybridFlat`, :class:`ConventionalFlat`) of design ``i`` of ``veh``."""


def _launch_step(v, dt, f, env):
    """(mean speed over a full-force launch step from ``v``, the force envelope for the next)."""


def _force(v, f):
    """The most force the driveline gives at steady speed ``v`` on a flat road, N."""


@overload(_flat)
def _flat_impl(veh, i):
    if _is(veh, HybridRec):

        def hybrid(veh, i):
            row, c, sc = veh.rows[i], veh.c, veh.sc
            d = split_design(row, c, sc)
            ch = chassis(row[R_MASS], split_equivalent_mass_kg(row, c, sc), c)
            p_dis, p_chg = pack_limits(row[R_SOC0], row[R_N_BAT], sc, veh.B, c.dt)
            dl = split.SplitDriveline(d=d, E=veh.E, M=veh.M, G=veh.G)
            return HybridFlat(ch=ch, p_dis_w=p_dis, p_chg_w=p_chg, dl=dl, v_lim_mps=split_speed_limit(d))

        return hybrid
    if _is(veh, ConventionalRec):

        def conventional(veh, i):
            m, c, cd = veh.rows[i][R_MASS], veh.c, veh.cd
            ch = chassis(m, conventional_equivalent_mass_kg(m, 0.0, False, cd.s_eng, c), c)
            v_lim = cd.w_e_max * cd.r / veh.ratios[-1]
            return ConventionalFlat(ch=ch, m_kg=m, c=c, ratios=veh.ratios, cd=cd, E=veh.E, v_lim_mps=v_lim)

        return conventional
    return None


@njit(cache=True)
def _hybrid_state(v, f: HybridFlat):
    """(command, state): everything the power-split driveline can give at speed ``v`` on a flat road."""
    ch, dl = f.ch, f.dl
    f_cmd = min(BIG_FORCE, adhesion_limit(0.0, 1.0, road_total(v, 0.0, 1.0, ch), ch))
    lim = split.limits(v, dl.d, dl.E, dl.M, dl.G)
    cmd = split.SplitCommand(
        f_req_n=f_cmd, engine_on=ON, p_e_target_w=lim.p_e_max, p_dis_w=f.p_dis_w, p_chg_w=f.p_chg_w, regen_share=1.0
    )
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


@overload(_launch_step)
def _launch_step_impl(v, dt, f, env):
    if _is(f, HybridFlat):

        def hybrid(v, dt, f, env):
            cmd, st = _hybrid_state(v, f)
            flat = StepRoad(sin_g=0.0, cos_g=1.0, dt_s=dt)
            _, _, v_avg, env = limited_step_split(v, v, f.v_lim_mps, cmd, flat, st, env, f.ch, f.dl)
            return v_avg, env

        return hybrid
    if _is(f, ConventionalFlat):

        def conventional(v, dt, f, env):
            # the gear that gains most speed over the step (a gear running out of revs mid-step loses)
            ch, m, c, ratios, cd, E = f.ch, f.m_kg, f.c, f.ratios, f.cd, f.E
            f_cmd = min(BIG_FORCE, adhesion_limit(0.0, 1.0, road_total(v, 0.0, 1.0, ch), ch))
            v_avg = 0.0
            road = StepRoad(sin_g=0.0, cos_g=1.0, dt_s=dt)
            for g in range(ratios.shape[0]):
                engaged = conv.clutch_closed(v, ratios[g], cd)  # the engine is reflected
                st_c = conv.dispatch(v, f_cmd, ratios[g], not engaged, cd, E)
                ch_g = chassis(m, conventional_equivalent_mass_kg(m, ratios[g], engaged, cd.s_eng, c), c)
                cmd = ConvCommand(f_req_n=f_cmd, ratio=ratios[g], slip=not engaged)
                v_avg = max(v_avg, limited_step_conv(v, v, f.v_lim_mps, cmd, road, st_c, ch_g, cd, E)[2])
            return v_avg, env

        return conventional
    return None


@overload(_force)
def _force_impl(v, f):
    if _is(f, HybridFlat):
        return lambda v, f: _hybrid_state(v, f)[1].f_del
    if _is(f, ConventionalFlat):
        return lambda v, f: _conv_gear(v, f.ratios, f.cd, f.ch, f.E)[2].f_del
    return None


@njit(cache=True, inline="always")
def _surplus(v, f):
    """Force left over the flat-road load at steady speed ``v``, N."""
    return _force(v, f) - road_total(v, 0.0, 1.0, f.ch)


@njit(cache=True)
def _launch_and_top(veh, i: int, dt, t_max):
    """Design ``i`` of ``veh`` (:class:`~hevlib.sim.drive.HybridRec` or
    :class:`~hevlib.sim.drive.ConventionalRec`). Returns (f_max, t_0_100_s, v_max_kmh)."""
    veh = borrowed(veh)  # not reference-counted (borrow.py)
    f = _flat(veh, i)
    v_lim = f.v_lim_mps
    # ---- launch: each step the speed the full force buys (as in a force-limited driving step)
    v, t, f_max, t100 = 0.0, 0.0, 0.0, np.inf
    env = NO_ENVELOPE  # full-power force envelope, carried from step to step (see limited_step_split)
    while t < t_max and v < v_lim:
        v_avg, env = _launch_step(v, dt, f, env)
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
    if _surplus(v_lim, f) >= 0.0:
        return f_max, t100, v_lim * 3.6
    hi = v_lim
    lo = hi
    while lo > 0.0:
        lo = max(lo - 5.0, 0.0)
        if _surplus(lo, f) >= 0.0:
            break
        hi = lo
    while hi - lo > 1e-3:
        mid = 0.5 * (lo + hi)
        if _surplus(mid, f) >= 0.0:
            lo = mid
        else:
            hi = mid
    return f_max, t100, lo * 3.6


@njit(cache=True, nogil=True)
def performance_batch(veh, dt: float, t_max: float, out: np.ndarray, start: int, stop: int):
    """Rows ``start .. stop - 1`` of ``out`` (n, 3): f_max (m/s^2), t_0_100_s, v_max (km/h) of those designs of
    ``veh`` (a :class:`~hevlib.sim.drive.HybridRec` or a :class:`~hevlib.sim.drive.ConventionalRec`: one
    compiled kernel each), launched at ``dt`` for at most ``t_max`` seconds. Releases the GIL
    (:func:`hevlib.sim.simulator.in_parallel`)."""
    for i in range(start, stop):
        f_max, t100, v_max = _launch_and_top(veh, i, dt, t_max)
        out[i, 0], out[i, 1], out[i, 2] = f_max, t100, v_max
