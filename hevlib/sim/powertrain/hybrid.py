"""Power-split (Prius-type) driveline operating point (numba).

Engine on the planet carrier, generator on the sun, motor and final drive on the ring. Given the
vehicle's mean speed over a step, the wheel force requested and the supervisory decisions (engine on,
target engine power), :func:`dispatch` returns a :class:`SplitState` that honours every limit: engine
full load and speed window, generator torque and speed, motor torque, battery power. What the
driveline cannot deliver shows up as ``f_del < f_req`` (traction) or as friction braking (braking).

Torque conventions (steady state; the rotor inertias the vehicle accelerates are in its equivalent
mass, :func:`hevlib.sim.drive.split_equivalent_mass_kg`): carrier torque ``t_e`` splits into ``t_e k/(1+k)``
on the ring (times the gear-set efficiency) and ``t_e/(1+k)`` on the sun, which the generator reacts
with ``t_g = -t_e/(1+k)`` (``k = N_r/N_s``).

An engine that is off but would leave the generator above its speed limit if it stood still (high ring
speed) is *spun*: the gear set turns it at the lowest speed that keeps the sun within its limit, its
fuel cut, and it drags with its closed-throttle torque (``running`` False, ``w_e`` > 0, ``t_e`` <= 0).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from hevlib.sim.powertrain.engine import EngineArrays, drag_torque, line_speed, max_torque
from hevlib.sim.powertrain.machines import MachineArrays, electric_power, torque_for_power, torque_limit
from hevlib.sim.powertrain.planetary import carrier_speed_window, sun_speed


class SplitDesign(NamedTuple):
    """Per-design driveline scalars (scale factors are design power / base map power)."""

    s_eng: float
    s_mot: float
    s_gen: float
    i0: float
    n_r: float
    n_s: float
    r: float  # wheel radius, m
    w_e_min: float  # lowest running engine speed, rad/s
    w_e_max: float
    w_m_max: float
    w_g_max: float
    planetary_efficiency: float  # planetary gear set (carrier -> ring path)
    final_drive_efficiency: float  # final drive
    p_acc_w: float  # electrical accessory load


class SplitState(NamedTuple):
    f_del: float  # wheel force the driveline delivers, N (negative = regenerative braking)
    running: bool  # engine turning under its own power
    w_e: float
    t_e: float
    w_r: float  # ring = motor speed
    t_m: float
    w_g: float
    t_g: float
    p_m_e: float  # motor electrical power, W (+ drawn)
    p_g_e: float  # generator electrical power, W (+ drawn)
    p_acc: float  # accessory power actually served, W
    p_batt: float  # battery terminal power, W (+ discharge)
    t_r: float  # total ring torque, N m
    t_c: float  # carrier torque into the gear set, N m (the engine's: a running carrier's inertia is left out)


class SplitLimits(NamedTuple):
    """What the driveline can do at one vehicle speed (computed once per speed, shared by the
    supervisor and every dispatch at that speed)."""

    w_r: float  # ring (motor) speed, rad/s
    t_m_cap: float  # motor torque limit, N m
    lo: float  # engine speed window (lo > hi: the engine cannot run)
    hi: float
    p_e_max: float  # most engine power at this speed, W


class OnPoint(NamedTuple):
    """A running engine's operating point in the gear set (:func:`_engine_on`), before the battery's limits."""

    w_e: float  # engine (carrier) speed, rad/s
    t_e: float  # engine torque, N m
    w_g: float  # generator (sun) speed, rad/s
    t_g: float  # generator torque, N m
    t_m: float  # motor torque, N m
    t_r_eng: float  # ring torque from the engine through the gear set, N m
    p_m_e: float  # motor electrical power, W (+ drawn)
    p_g_e: float  # generator electrical power, W (+ drawn)
    t_c: float  # carrier torque into the gear set, N m


class Circulation(NamedTuple):
    """A motoring generator's draw cut back to the battery's limit (:func:`_less_circulation`)."""

    t_e: float  # engine torque, N m
    t_g: float  # generator torque, N m
    t_r_eng: float  # ring torque from the engine, N m
    p_g_e: float  # generator electrical power, W (+ drawn)
    p_acc: float  # accessory power served, W


class SplitDriveline(NamedTuple):
    """One design's power-split driveline: its scalars and the engine, motor and generator maps (built once per
    design; what the solvers around :func:`dispatch` read). :func:`dispatch` itself takes the four apart: handed
    this record of arrays, the drive kernels ran 25-30 % slower (measured on UDDS and FTP)."""

    d: SplitDesign
    E: EngineArrays
    M: MachineArrays
    G: MachineArrays


class SplitCommand(NamedTuple):
    """What one step asks of the driveline (:func:`dispatch`)."""

    f_req_n: float  # wheel force
    engine_on: bool  # the controller's engine state
    p_e_target_w: float  # its target engine power
    p_dis_w: float  # battery discharge / charge power limits, W (>= 0)
    p_chg_w: float
    regen_share: float  # share of a braking request the driveline may take (the rest is friction braking)


@njit(cache=True, inline="always")
def at_power(cmd: SplitCommand, p_e_target_w: float) -> SplitCommand:
    """``cmd`` with the target engine power ``p_e_target_w``."""
    return SplitCommand(
        f_req_n=cmd.f_req_n,
        engine_on=cmd.engine_on,
        p_e_target_w=p_e_target_w,
        p_dis_w=cmd.p_dis_w,
        p_chg_w=cmd.p_chg_w,
        regen_share=cmd.regen_share,
    )


@njit(cache=True, inline="always")
def ring_speed(v: float, d: SplitDesign) -> float:
    return v / d.r * d.i0


@njit(cache=True, inline="always")
def ring_torque_for_wheel_force(f: float, d: SplitDesign) -> float:
    t_wh = f * d.r
    return t_wh / (d.i0 * d.final_drive_efficiency) if t_wh >= 0.0 else t_wh * d.final_drive_efficiency / d.i0


@njit(cache=True, inline="always")
def wheel_force_for_ring_torque(t_r: float, d: SplitDesign) -> float:
    return t_r * d.i0 * d.final_drive_efficiency / d.r if t_r >= 0.0 else t_r * d.i0 / (d.final_drive_efficiency * d.r)


@njit(cache=True, inline="always")
def engine_window(w_r: float, d: SplitDesign) -> tuple[float, float]:
    """Engine speeds allowed at ring speed ``w_r``: own limits and generator speed limit (Willis)."""
    lo, hi = carrier_speed_window(w_r, d.n_r, d.n_s, d.w_g_max)
    return max(lo, d.w_e_min), min(hi, d.w_e_max)


@njit(cache=True, inline="always")
def generator_overspeed_if_stopped(w_r: float, d: SplitDesign) -> bool:
    """With the engine stopped the sun turns at -k w_r: above the limit the engine must turn."""
    return d.n_r / d.n_s * w_r > d.w_g_max


@njit(cache=True, inline="always")
def limits(v: float, d: SplitDesign, E: EngineArrays, M: MachineArrays, G: MachineArrays) -> SplitLimits:
    """Ring speed, motor torque limit, engine speed window and the most engine power at speed ``v``
    (the top of the window at full load, or at the torque the generator can react), W."""
    w_r = ring_speed(v, d)
    lo, hi = engine_window(w_r, d)
    p_max = 0.0
    if lo <= hi:
        k = d.n_r / d.n_s
        w_g = sun_speed(hi, w_r, d.n_r, d.n_s)
        p_max = hi * min(max_torque(hi, d.s_eng, E), (1.0 + k) * torque_limit(w_g, d.s_gen, G))
    return SplitLimits(w_r=w_r, t_m_cap=torque_limit(w_r, d.s_mot, M), lo=lo, hi=hi, p_e_max=p_max)


@njit(cache=True)
def _engine_on(p_e: float, lim: SplitLimits, t_r_drive: float, d: SplitDesign, E: EngineArrays, M: MachineArrays, G):
    """Operating point with the engine delivering (up to) ``p_e`` into the gear set on its best-efficiency line,
    within the speed window of ``lim``; the generator reacts the engine's torque (``t_c``: the running carrier
    moves freely within the window, its inertia left out, as in :mod:`hevlib.bound`; the start's spin-up is
    :func:`spin_up`'s)."""
    k = d.n_r / d.n_s
    lo, hi, w_r, t_m_cap = lim.lo, lim.hi, lim.w_r, lim.t_m_cap
    w_e = min(max(line_speed(p_e, d.s_eng, E), lo), hi)
    w_g = sun_speed(w_e, w_r, d.n_r, d.n_s)
    t_g_cap = (1.0 + k) * torque_limit(w_g, d.s_gen, G)
    t_max = max_torque(w_e, d.s_eng, E)
    t_cap = min(t_max, t_g_cap)
    if p_e > t_cap * w_e and w_e < hi:
        # the line's torque is more than the engine (or the generator reacting it) can take here:
        # turn faster to deliver the power with the torque available
        w_e = min(p_e / t_cap, hi)
        w_g = sun_speed(w_e, w_r, d.n_r, d.n_s)
        t_g_cap = (1.0 + k) * torque_limit(w_g, d.s_gen, G)
        t_max = max_torque(w_e, d.s_eng, E)
        t_cap = min(t_max, t_g_cap)
    t_e = min(max(p_e / w_e, 0.0), t_cap)
    t_c = t_e
    t_g = -t_c / (1.0 + k)
    t_r_eng = (
        d.planetary_efficiency * t_c * k / (1.0 + k) if t_c >= 0.0 else t_c * k / (1.0 + k) / d.planetary_efficiency
    )
    t_m = min(max(t_r_drive - t_r_eng, -t_m_cap), t_m_cap)
    p_m_e = electric_power(t_m, w_r, d.s_mot, M)
    p_g_e = electric_power(t_g, w_g, d.s_gen, G)
    return OnPoint(w_e=w_e, t_e=t_e, w_g=w_g, t_g=t_g, t_m=t_m, t_r_eng=t_r_eng, p_m_e=p_m_e, p_g_e=p_g_e, t_c=t_c)


@njit(cache=True)
def _engine_power_for_battery(
    bracket: tuple[float, float, float, float],
    st_b,
    sign: float,
    target: float,
    lim: SplitLimits,
    t_r_drive: float,
    d: SplitDesign,
    E: EngineArrays,
    M: MachineArrays,
    G: MachineArrays,
):
    """Engine power at which the battery power meets a limit: root of ``g(p) = sign (P_batt(p) - target)``
    in ``bracket = (p_a, g_a, p_b, g_b)``: between ``p_a`` (``g_a > 0``, violating) and ``p_b`` (``g_b <= 0``,
    feasible; ``st_b`` its
    :func:`_engine_on` point); returns the operating point of a feasible end (the caller's own ``st_b`` if no
    step improves on it).

    Battery power falls monotonically and almost linearly as engine power rises (the gear set hands
    the extra to the ring and the generator), so a few Illinois regula-falsi steps suffice (1 W).
    """
    p_a, g_a, p_b, g_b = bracket
    side = 0
    for _ in range(12):
        if abs(p_b - p_a) <= 1.0 or -g_b <= 1.0:
            break
        p = p_b - g_b * (p_b - p_a) / (g_b - g_a) if g_b != g_a else 0.5 * (p_a + p_b)
        if not (min(p_a, p_b) < p < max(p_a, p_b)):
            p = 0.5 * (p_a + p_b)
        st = _engine_on(p, lim, t_r_drive, d, E, M, G)
        g = sign * (st.p_m_e + st.p_g_e + d.p_acc_w - target)
        if g > 0.0:
            p_a, g_a = p, g
            if side == -1:
                g_b *= 0.5
            side = -1
        else:
            p_b, g_b, st_b = p, g, st
            if side == 1:
                g_a *= 0.5
            side = 1
    return st_b


@njit(cache=True)
def _less_circulation(t_e: float, w_g: float, p_m_e: float, p_dis: float, d: SplitDesign, G: MachineArrays):
    """Largest engine torque (<= ``t_e``) whose motoring generator keeps the battery within ``p_dis``
    (bisection; the generator's draw grows with engine torque); if even none is too much, the
    accessory load is shed. Returns (t_e, t_g, ring torque from the engine, p_g_e, p_acc)."""
    k = d.n_r / d.n_s
    lo, hi = 0.0, t_e
    for _ in range(24):
        mid = 0.5 * (lo + hi)
        if p_m_e + electric_power(-mid / (1.0 + k), w_g, d.s_gen, G) + d.p_acc_w > p_dis:
            hi = mid
        else:
            lo = mid
    t_g_cap = (1.0 + k) * torque_limit(w_g, d.s_gen, G)
    t_c = min(max(lo, -t_g_cap), t_g_cap)
    p_g_e = electric_power(-t_c / (1.0 + k), w_g, d.s_gen, G)
    p_acc = max(min(d.p_acc_w, p_dis - p_m_e - p_g_e), 0.0)
    t_r_eng = (
        d.planetary_efficiency * t_c * k / (1.0 + k) if t_c >= 0.0 else t_c * k / (1.0 + k) / d.planetary_efficiency
    )
    return Circulation(t_e=lo, t_g=-t_c / (1.0 + k), t_r_eng=t_r_eng, p_g_e=p_g_e, p_acc=p_acc)


@njit(cache=True, inline="always")
def _point(pt: OnPoint):
    """The fields of an :class:`OnPoint` read by name, in the order :func:`dispatch` keeps them as locals."""
    return pt.w_e, pt.t_e, pt.w_g, pt.t_g, pt.t_m, pt.t_r_eng, pt.p_m_e, pt.p_g_e, pt.t_c


@njit(cache=True)
def dispatch(
    lim: SplitLimits, cmd: SplitCommand, d: SplitDesign, E: EngineArrays, M: MachineArrays, G: MachineArrays
) -> SplitState:
    """Operating point at the speed of ``lim`` (:func:`limits`) for the step's command ``cmd`` (wheel force,
    engine state and target power, battery power limits, regenerative share) within every limit; the carrier
    is free to move within the window of ``lim``."""
    f_req, engine_on, p_e_target = cmd.f_req_n, cmd.engine_on, cmd.p_e_target_w
    p_dis, p_chg, regen_frac = cmd.p_dis_w, cmd.p_chg_w, cmd.regen_share
    w_r, t_m_cap, lo, hi = lim.w_r, lim.t_m_cap, lim.lo, lim.hi
    k = d.n_r / d.n_s
    t_r_req = ring_torque_for_wheel_force(f_req, d)
    t_r_drive = t_r_req if t_r_req >= 0.0 else t_r_req * regen_frac
    p_acc = d.p_acc_w
    running = engine_on and lo <= hi

    if running:
        p_e = p_e_target
        w_e, t_e, w_g, t_g, t_m, t_r_eng, p_m_e, p_g_e, t_c = _point(_engine_on(p_e, lim, t_r_drive, d, E, M, G))
        p_batt = p_m_e + p_g_e + p_acc
        if p_batt > p_dis:
            # more engine power first (battery power falls as engine power rises) ...
            p_hi = lim.p_e_max
            if p_hi > p_e:
                st = _engine_on(p_hi, lim, t_r_drive, d, E, M, G)
                h_hi = st.p_m_e + st.p_g_e + p_acc
                if h_hi <= p_dis:
                    bracket = (p_e, p_batt - p_dis, p_hi, h_hi - p_dis)
                    st = _engine_power_for_battery(bracket, st, 1.0, p_dis, lim, t_r_drive, d, E, M, G)
                w_e, t_e, w_g, t_g, t_m, t_r_eng, p_m_e, p_g_e, t_c = _point(st)
                p_batt = p_m_e + p_g_e + p_acc
            if p_batt > p_dis and t_m > 0.0:
                # ... then less motor torque
                t_m = torque_for_power(max(p_dis - p_acc - p_g_e, 0.0), w_r, d.s_mot, t_m, M)
                p_m_e = electric_power(t_m, w_r, d.s_mot, M)
                p_batt = p_m_e + p_g_e + p_acc
            if p_batt > p_dis and p_g_e > 0.0:
                # ... and when the generator motors (power circulation: engine slower than the ring
                # drags the sun backwards) less engine torque, down to none, then accessories shed
                cut = _less_circulation(t_e, w_g, p_m_e, p_dis, d, G)
                t_e, t_g, t_r_eng, p_g_e, p_acc = cut.t_e, cut.t_g, cut.t_r_eng, cut.p_g_e, cut.p_acc
                t_c = -t_g * (1.0 + k)
            if p_m_e + p_g_e + p_acc > p_dis:
                # nothing left to cut but the accessories
                p_acc = max(min(p_acc, p_dis - p_m_e - p_g_e), 0.0)
            p_batt = p_m_e + p_g_e + p_acc
        elif p_batt < -p_chg:
            # less engine power first (battery power rises as engine power falls) ...
            st0 = _engine_on(0.0, lim, t_r_drive, d, E, M, G)
            h0 = st0.p_m_e + st0.p_g_e + p_acc
            if h0 < -p_chg:
                w_e, t_e, w_g, t_g, t_m, t_r_eng, p_m_e, p_g_e, t_c = _point(st0)
            else:
                bracket = (p_e, -(p_batt + p_chg), 0.0, -(h0 + p_chg))
                w_e, t_e, w_g, t_g, t_m, t_r_eng, p_m_e, p_g_e, t_c = _point(
                    _engine_power_for_battery(bracket, st0, -1.0, -p_chg, lim, t_r_drive, d, E, M, G)
                )
            p_batt = p_m_e + p_g_e + p_acc
            if p_batt < -p_chg and t_m < 0.0:
                # ... then less regenerative torque (friction brakes take the rest)
                t_m = torque_for_power(min(-p_chg - p_acc - p_g_e, -1e-9), w_r, d.s_mot, -t_m, M)
                p_m_e = electric_power(t_m, w_r, d.s_mot, M)
                p_batt = p_m_e + p_g_e + p_acc
        t_r = t_r_eng + t_m
    else:
        w_e, t_e, t_g, p_g_e, t_r_eng = 0.0, 0.0, 0.0, 0.0, 0.0
        if generator_overspeed_if_stopped(w_r, d):
            # spun, fuel cut: the lowest carrier speed that keeps the sun at its limit; the engine's drag
            # torque is reacted by the generator on the sun and taken from the ring (through the gear set)
            k = d.n_r / d.n_s
            w_e = (d.n_r * w_r - d.n_s * d.w_g_max) / (d.n_r + d.n_s)
            t_e = max(drag_torque(w_e, d.s_eng, E), -(1.0 + k) * torque_limit(d.w_g_max, d.s_gen, G))
            t_g = -t_e / (1.0 + k)
            t_r_eng = t_e * k / (1.0 + k) / d.planetary_efficiency
        w_g = sun_speed(w_e, w_r, d.n_r, d.n_s)
        if t_g != 0.0:
            p_g_e = electric_power(t_g, w_g, d.s_gen, G)
        t_m = min(max(t_r_drive - t_r_eng, -t_m_cap), t_m_cap)
        p_m_e = electric_power(t_m, w_r, d.s_mot, M)
        p_batt = p_m_e + p_g_e + p_acc
        if p_batt > p_dis:
            if p_dis - p_acc - p_g_e <= 0.0:
                # battery at its limit and no other source: no traction; what the accessories cannot get
                # is booked as unmet (p_acc below the demand), never silently dropped
                t_m = min(t_m, 0.0)
                p_m_e = electric_power(t_m, w_r, d.s_mot, M)
                p_acc = max(min(p_acc, p_dis - p_m_e - p_g_e), 0.0)
            elif t_m > 0.0:
                t_m = torque_for_power(p_dis - p_acc - p_g_e, w_r, d.s_mot, t_m, M)
                p_m_e = electric_power(t_m, w_r, d.s_mot, M)
        elif p_batt < -p_chg:
            if t_m < 0.0:
                t_m = torque_for_power(min(-p_chg - p_acc - p_g_e, -1e-9), w_r, d.s_mot, -t_m, M)
                p_m_e = electric_power(t_m, w_r, d.s_mot, M)
            if p_m_e + p_g_e + p_acc < -p_chg and w_r > 0.0:
                # a spun engine's generator (holding the sun at its speed limit, reacting the engine's drag) still
                # gives more than the pack can take: the motor spends the rest against the friction brakes (a budget
                # 0.5 % above what is needed: the torque found stays within its budget, from below)
                t_m = torque_for_power(1.005 * (-p_chg - p_acc - p_g_e), w_r, d.s_mot, t_m_cap, M)
                p_m_e = electric_power(t_m, w_r, d.s_mot, M)
        p_batt = p_m_e + p_g_e + p_acc
        t_r = t_r_eng + t_m
        t_c = t_e
    return SplitState(
        f_del=wheel_force_for_ring_torque(t_r, d),
        running=running,
        w_e=w_e,
        t_e=t_e,
        w_r=w_r,
        t_m=t_m,
        w_g=w_g,
        t_g=t_g,
        p_m_e=p_m_e,
        p_g_e=p_g_e,
        p_acc=p_acc,
        p_batt=p_batt,
        t_r=t_r,
        t_c=t_c,
    )


# ---------------------------------------------------------------------------------- engine dynamics
class CarrierDynamics(NamedTuple):
    """The carrier's inertia and what moves it (per design; :func:`carrier_dynamics`)."""

    j: float  # carrier inertia with the ring held: engine start-up inertia + generator through Willis, kg m^2
    t_spin: float  # most carrier torque the generator can apply (its low-speed torque limit times 1 + k), N m
    t_crank: float  # the engine's resistance while cranked (compression and friction), N m
    w_fire: float  # speed at which the engine fires (fuel on), rad/s


@njit(cache=True, inline="always")
def carrier_dynamics(
    d: SplitDesign, G: MachineArrays, j_start: float, j_gen: float, t_crank: float, w_fire: float
) -> CarrierDynamics:
    """The carrier of design ``d``: the engine's start-up inertia and crank torque (base engine values, scaled
    with the engine like its torque), the generator's rotor reflected through Willis (``w_g = (1 + k) w_e``
    with the ring held: ``J_g (1 + k)^2``, scaled with the generator), and the generator's low-speed torque."""
    k = d.n_r / d.n_s
    j = d.s_eng * j_start + d.s_gen * j_gen * (1.0 + k) * (1.0 + k)
    t_spin = (1.0 + k) * torque_limit(0.0, d.s_gen, G)
    return CarrierDynamics(j=j, t_spin=t_spin, t_crank=d.s_eng * t_crank, w_fire=w_fire)


#: The spin-up's torque is cut where the generator's draw at firing speed (its largest) would take more than
#: this share over what the pack can spare: the margin left for the draw's rise with the losses.
SPIN_MARGIN = 1.05


class SpinUp(NamedTuple):
    """One step's part of a start's spin-up (:func:`spin_up`): the generator turns the unfuelled engine from the
    carrier's speed towards its firing speed at a constant torque."""

    t_left_s: float  # time to firing speed from the step's carrier speed (0: none needed; inf: cannot start)
    tau_s: float  # the part of the step the spin-up takes, min(step, t_left_s)
    w_end_rad_s: float  # carrier speed at the end of that part
    w_mean_rad_s: float  # its mean over the part
    t_gen_nm: float  # the generator's torque on the sun
    w_gen_rad_s: float  # the sun's speed at the part's mean carrier speed
    e_mech_j: float  # work into the carrier over the part: kinetic energy gained plus the crank work
    e_elec_j: float  # the generator's electrical energy over the part: that work plus its losses at the mean speed


@njit(cache=True, inline="always")
def spin_up(w0: float, w_r: float, p_spare_w: float, cd: CarrierDynamics, d: SplitDesign, G, h: float) -> SpinUp:
    """The part of a step of length ``h`` a start's spin-up takes, from carrier speed ``w0`` at ring speed ``w_r``.

    The generator spins the carrier at its full low-speed torque (``cd.t_spin``), or at the torque whose draw at
    firing speed, the largest of the spin-up, stays within ``p_spare_w`` (what the pack can spare) with
    :data:`SPIN_MARGIN`; at a constant torque ``T`` the carrier accelerates at ``(T - T_crank) / J`` and takes
    ``t = J (w_f - w0) / (T - T_crank)``. The draw is the carrier's work rate ``T w`` plus the generator's losses
    (the sun's reaction on the ring, ``k / (1 + k) T``, is held by the motor from the same pack). A spin-up longer
    than the step runs on over the next steps, each with its own part: the work ``T w_mean tau`` (kinetic energy
    gained plus the crank work), the generator's losses at its own mean speed. ``t_left_s = inf`` where no torque
    within the pack's spare power overcomes the crank torque (the engine cannot start now)."""
    if w0 >= cd.w_fire:
        return SpinUp(
            t_left_s=0.0,
            tau_s=0.0,
            w_end_rad_s=w0,
            w_mean_rad_s=w0,
            t_gen_nm=0.0,
            w_gen_rad_s=0.0,
            e_mech_j=0.0,
            e_elec_j=0.0,
        )
    k = d.n_r / d.n_s
    t_c = cd.t_spin
    w_g_fire = sun_speed(cd.w_fire, w_r, d.n_r, d.n_s)
    for _ in range(3):
        # the draw at firing speed as booked: the carrier's work rate plus the generator's losses (the ring's share
        # of the sun's reaction is the motor's to hold, from the same pack)
        t_g = t_c / (1.0 + k)
        p_fire = t_c * cd.w_fire + electric_power(t_g, w_g_fire, d.s_gen, G) - t_g * w_g_fire
        if p_fire * SPIN_MARGIN <= p_spare_w:
            break
        t_c = t_c * max(p_spare_w, 0.0) / (SPIN_MARGIN * p_fire)
    if t_c <= cd.t_crank:
        return SpinUp(
            t_left_s=np.inf,
            tau_s=0.0,
            w_end_rad_s=w0,
            w_mean_rad_s=w0,
            t_gen_nm=0.0,
            w_gen_rad_s=0.0,
            e_mech_j=0.0,
            e_elec_j=0.0,
        )
    a = (t_c - cd.t_crank) / cd.j
    t_left = (cd.w_fire - w0) / a
    tau = min(h, t_left)
    w1 = cd.w_fire if tau == t_left else w0 + a * tau
    w_mean = 0.5 * (w0 + w1)
    t_g = t_c / (1.0 + k)
    w_g = sun_speed(w_mean, w_r, d.n_r, d.n_s)
    e_mech = t_c * w_mean * tau
    return SpinUp(
        t_left_s=t_left,
        tau_s=tau,
        w_end_rad_s=w1,
        w_mean_rad_s=w_mean,
        t_gen_nm=t_g,
        w_gen_rad_s=w_g,
        e_mech_j=e_mech,
        e_elec_j=e_mech + (electric_power(t_g, w_g, d.s_gen, G) - t_g * w_g) * tau,
    )
