"""Forward-facing drive-cycle kernels (numba), one design at a time, GIL released (threads run chunks).

Each step the driver asks for the force that takes the vehicle from its achieved speed ``v0`` to the
cycle's next speed; the supervisory controller decides the engine state; the driveline delivers what
its limits (and front-axle adhesion) allow; the achieved speed follows from the force actually
delivered. A force-limited step is solved as a fixed point (speed -> available force -> speed), so
weak designs fall behind the trace instead of breaking physics. Results accumulate per design in the
``O_*`` columns of :mod:`hevlib.sim.powertrain.layout`; full traces only for designs asked to record.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from hevlib.cycles import KernelCycle
from hevlib.lookup import cell, interp1_np
from hevlib.scaling import in_series
from hevlib.sim import ecms as ecms_
from hevlib.sim.control import Observed, PmsConfig, Thresholds, supervise
from hevlib.sim.powertrain import conventional as conv
from hevlib.sim.powertrain import hybrid as split
from hevlib.sim.powertrain import layout as L  # O_*, T_* column indices (compile-time constants)
from hevlib.sim.powertrain import thermal as th_
from hevlib.sim.powertrain.battery import PackLimits, charge_drawn, power_limits
from hevlib.sim.powertrain.borrow import borrowed
from hevlib.sim.powertrain.engine import EngineArrays, max_torque, rates
from hevlib.sim.powertrain.machines import MachineArrays, torque_limit
from hevlib.sim.powertrain.vehicle import Chassis, adhesion_limit, mean_speed_for_force, road_force

LIMIT_TOL = 1e-9  # relative tolerance of the limit checks
#: SOC above the controller's window counted as a violation: a spun engine's generator reacting its drag can give a
#: few watts more than a full pack takes where the motor cannot spend them (measured: 3.5 W, 3e-7 of SOC)
SOC_TOL = 1e-6
#: Flags handed to the kernels that are compiled on their own (not inlined) as typed booleans: numba types a
#: literal ``True``/``False`` argument as a constant and compiles a second copy of the callee, and of all
#: that it inlines, for it (measured: 10 s of a 60 s cold compile). A numpy bool global is not a literal.
ON, OFF = np.True_, np.False_


class BatteryArrays(NamedTuple):
    """One module's Rint tables on a uniform SOC grid ``dsoc i`` from 0 (the pack multiplies voltages
    and resistances by n_bat)."""

    dsoc: float
    ocv_v: np.ndarray
    r_dis_ohm: np.ndarray
    r_chg_ohm: np.ndarray


class DriveConfig(NamedTuple):
    """Scalars every design of a batch shares, for either car: chassis, road, brakes, fuel, the step."""

    dt: float
    adhesion_coefficient: float
    rho: float
    g: float
    cda: float
    crr: float
    r: float
    axle0_nm: float
    axle_per_kg_nm: float
    h_over_l: float
    f_front: float
    brake_v_mps: np.ndarray  # braking split of the wheel file: speed axis ...
    brake_share: np.ndarray  # ... and the share of braking the driveline may take (regeneration)
    lhv_j_per_g: float
    j_wheel: float  # all wheels, tyres and axles, kg m^2
    j_eng: float  # base-map rotor inertia (scaled with each design's power), kg m^2
    cycle_met_tolerance_mps: float  # speed error above which a step counts as off the trace (speed_dev)
    k_lin: float  # linear road-load term (a coast-down's B), N per m/s (hevlib.sim.vehicles.road_load); 0 else


class SplitConfig(NamedTuple):
    """Scalars of the power split alone, shared by every design of a batch: gear set, machines, pack,
    controller window, electrical accessories, engine start (the conventional car has none of them)."""

    soc_min: float
    soc_max: float
    planetary_efficiency: float
    final_drive_efficiency: float
    pack_current_max_a: float
    p_acc_w: float  # electrical accessory load, W
    w_e_min: float
    w_e_max: float
    w_m_max: float
    w_g_max: float
    cap_as: float  # module capacity, A s
    eta_c: float
    v_min_mod: float
    v_max_mod: float
    j_mot: float  # base-map rotor inertias (scaled with each design's power), kg m^2
    j_gen: float
    engine_dynamics: bool  # starts spin the carrier up over their duration (start-up inertia, crank work)
    j_start: float  # the engine's start-up effective inertia (base engine), kg m^2
    t_crank: float  # its crank torque (base engine), N m
    w_fire: float  # firing speed: fuel flows from here up, rad/s


class HybridRec(NamedTuple):
    """A batch of power-split hybrids as :func:`drive_hybrid` and the performance tests read them
    (:meth:`hevlib.sim.vehicles.Vehicle.from_design`): what those kernels read, nothing else."""

    rows: np.ndarray  # (n, N_R) per-design rows, R_* columns
    c: DriveConfig
    sc: SplitConfig
    th: Thresholds  # of the fuzzy rule base (hevlib.sim.control.thresholds)
    pc: PmsConfig
    E: EngineArrays
    M: MachineArrays
    G: MachineArrays
    B: BatteryArrays
    X: th_.ThermalConfig


class ConventionalRec(NamedTuple):
    """A batch of conventional cars as :func:`drive_conventional` and the performance tests read them: no
    battery, machines or controller (the rows' R_S_MOT .. R_N_S columns are unread)."""

    rows: np.ndarray  # (n, N_R) per-design rows: R_MASS, R_SOC0 (the engine's scale is cd.s_eng)
    c: DriveConfig
    E: EngineArrays
    ratios: np.ndarray  # gearbox: overall ratio of each gear ...
    shift: conv.ShiftLogic  # ... and its shift logic
    cd: conv.ConvDesign
    X: th_.ThermalConfig


class StepRoad(NamedTuple):
    """The road under one step: the grade's sine and cosine, and the step's length."""

    sin_g: float
    cos_g: float
    dt_s: float


class StepPart(NamedTuple):
    """The stretch of drive step ``t`` an engine and exhaust update covers: the whole step, or one of the two parts
    of a step in which a start's spin-up ends (:func:`_hybrid_one`)."""

    t: int  # the step
    h_s: float  # the part's length, s
    t_end_s: float  # the cycle time at its end, s


class EngineOp(NamedTuple):
    """The engine's operating point over one step."""

    running: bool  # fuelled
    w_e_rad_s: float
    t_e_nm: float


class ConvCommand(NamedTuple):
    """What one step asks of the conventional car's driveline in a fixed gear and clutch state."""

    f_req_n: float
    ratio: float  # overall ratio of the gear in use
    slip: bool  # clutch slipping


@njit(cache=True, inline="always")
def _key_off(dt: float) -> th_.ThermalStep:
    """What a key-off step (nothing runs) of length ``dt`` hands the thermal nodes."""
    return th_.ThermalStep(
        key_on=OFF, fuel_g_s=0.0, q_waste_w=0.0, w_e_rad_s=0.0, hc_g_s=0.0, co_g_s=0.0, nox_g_s=0.0, v_mps=0.0, dt_s=dt
    )


#: Achieved speed below which the car counts as standing still, m/s (and the trace as asking it to move
#: when the cycle's speed is above it).
STILL_MPS = 0.01


# per-design row of the design matrix the kernels read (R_SOC0: the drive's initial SOC)
R_S_ENG, R_S_MOT, R_S_GEN, R_I0, R_N_BAT, R_N_R, R_N_S, R_MASS, R_SOC0 = range(9)
N_R = 9


@njit(cache=True, inline="always")
def chassis(m: float, m_eff: float, c: DriveConfig) -> Chassis:
    return Chassis(
        m=m,
        m_eff=m_eff,
        cda=c.cda,
        crr=c.crr,
        r=c.r,
        axle_drag_nm=c.axle0_nm + c.axle_per_kg_nm * m,
        h_over_l=c.h_over_l,
        f_front=c.f_front,
        adhesion_coefficient=c.adhesion_coefficient,
        rho=c.rho,
        g=c.g,
        k_lin=c.k_lin,
    )


@njit(cache=True, inline="always")
def split_equivalent_mass_kg(row: np.ndarray, c: DriveConfig, sc: SplitConfig) -> float:
    """Test mass plus the rotating inertias the power-split car accelerates with the vehicle.

    Wheels ``J_wh / r^2``; motor on the ring ``J_m (i0 / r)^2``; generator on the sun, which at a held
    engine speed (and with the engine stopped) turns at ``-k`` times the ring (Willis), ``J_g (k i0 / r)^2``.
    The engine's speed is set by the controller, not by the vehicle's, so its inertia does not reflect: a start's
    spin-up of the carrier (engine and generator through Willis) is the engine dynamics' (``e_engine_start_j``;
    a running carrier's own speed changes are left out, as is the cross term of the generator's two motions).
    Machine inertias scale with the machine's power, like their masses.
    """
    k = row[R_N_R] / row[R_N_S]
    g2 = (row[R_I0] / c.r) ** 2
    return row[R_MASS] + c.j_wheel / (c.r * c.r) + (row[R_S_MOT] * sc.j_mot + k * k * row[R_S_GEN] * sc.j_gen) * g2


@njit(cache=True, inline="always")
def conventional_equivalent_mass_kg(m: float, ratio: float, engaged: bool, s_eng: float, c: DriveConfig) -> float:
    """Test mass plus wheels plus, with the clutch closed, the engine reflected through the overall
    ratio of the gear in use, ``J_e (ratio / r)^2`` (gearbox inertia: none in the data)."""
    m_eff = m + c.j_wheel / (c.r * c.r)
    if engaged:
        m_eff += s_eng * c.j_eng * (ratio / c.r) ** 2
    return m_eff


@njit(cache=True, inline="always")
def driveline_brake_share(v: float, c: DriveConfig) -> float:
    """Share of a braking request the driveline may take at speed ``v`` (the wheel file's table)."""
    return interp1_np(v, c.brake_v_mps, c.brake_share)


@njit(cache=True, inline="always")
def split_design(row: np.ndarray, c: DriveConfig, sc: SplitConfig) -> split.SplitDesign:
    return split.SplitDesign(
        s_eng=row[R_S_ENG],
        s_mot=row[R_S_MOT],
        s_gen=row[R_S_GEN],
        i0=row[R_I0],
        n_r=row[R_N_R],
        n_s=row[R_N_S],
        r=c.r,
        w_e_min=sc.w_e_min,
        w_e_max=sc.w_e_max,
        w_m_max=sc.w_m_max,
        w_g_max=sc.w_g_max,
        planetary_efficiency=sc.planetary_efficiency,
        final_drive_efficiency=sc.final_drive_efficiency,
        p_acc_w=sc.p_acc_w,
    )


@njit(cache=True, inline="always")
def split_speed_limit(d: split.SplitDesign) -> float:
    """Top vehicle speed the component speed limits allow (motor on the ring; engine and generator
    through Willis), m/s."""
    w_r_max = min(d.w_m_max, ((d.n_r + d.n_s) * d.w_e_max + d.n_s * d.w_g_max) / d.n_r)
    return w_r_max * d.r / d.i0


@njit(cache=True, inline="always")
def pack_state(soc: float, n_bat: float, B: BatteryArrays) -> tuple[float, float, float]:
    """(OCV, discharge resistance, charge resistance) of the series pack at ``soc``."""
    i, f = cell(soc, 0.0, B.dsoc, B.ocv_v.shape[0])
    ocv = B.ocv_v[i] + f * (B.ocv_v[i + 1] - B.ocv_v[i])
    r_d = B.r_dis_ohm[i] + f * (B.r_dis_ohm[i + 1] - B.r_dis_ohm[i])
    r_c = B.r_chg_ohm[i] + f * (B.r_chg_ohm[i + 1] - B.r_chg_ohm[i])
    return in_series(ocv, n_bat), in_series(r_d, n_bat), in_series(r_c, n_bat)


@njit(cache=True, inline="always")
def pack_power_limits(
    ocv: float, r_d: float, r_c: float, soc: float, soc_min: float, n_bat: float, sc: SplitConfig, dt: float
):
    """(max discharge, max charge) terminal power of the pack in state (``ocv``, ``r_d``, ``r_c``) at ``soc`` over a
    step ``dt``, W, discharging down to ``soc_min`` (the controller's window, ``sc.soc_min``; 0 for what the pack
    itself can give)."""
    lim = PackLimits(
        v_min_v=in_series(sc.v_min_mod, n_bat),
        v_max_v=in_series(sc.v_max_mod, n_bat),
        i_max_a=sc.pack_current_max_a,
        soc_min=soc_min,
        soc_max=sc.soc_max,
        capacity_as=sc.cap_as,
        eta_c=sc.eta_c,
        dt_s=dt,
    )
    return power_limits(ocv, r_d, r_c, soc, lim)


@njit(cache=True, inline="always")
def pack_limits(soc: float, n_bat: float, sc: SplitConfig, B: BatteryArrays, dt: float) -> tuple[float, float]:
    ocv, r_d, r_c = pack_state(soc, n_bat, B)
    return pack_power_limits(ocv, r_d, r_c, soc, sc.soc_min, n_bat, sc, dt)


@njit(cache=True, inline="always")
def _clean(x: float) -> float:
    """A shortfall or error, with round-off (below 1e-9 m/s or m/s^2) counted as none."""
    return x if x > 1e-9 else 0.0


@njit(cache=True, inline="always")
def _book_engine(o, fuel, hc, co, nox, p_shaft, lhv_j_per_g, dt):
    """Fuel, emissions and the engine's energy terms of one step."""
    o[L.O_FUEL_G] += fuel * dt
    o[L.O_HC_G] += hc * dt
    o[L.O_CO_G] += co * dt
    o[L.O_NOX_G] += nox * dt
    o[L.O_E_FUEL] += fuel * lhv_j_per_g * dt
    o[L.O_E_ENG_SHAFT] += p_shaft * dt
    o[L.O_E_LOSS_ENG] += (fuel * lhv_j_per_g - p_shaft) * dt


@njit(cache=True, inline="always")
def _exhaust(o, nodes: th_.ThermalNodes, s: th_.ThermalStep, t_end_s, t, tr, record):
    """Thermal nodes and tailpipe emissions of step ``t``, or of its part ending at ``t_end_s`` (and their trace
    channels)."""
    temp, k, X = nodes.temp_c, nodes.k, nodes.cfg
    tp_hc, tp_co, tp_nox = th_.thermal_step(temp, k, X, s, o)
    th_.check_light_off(temp, X, t_end_s, o)
    if record:
        tr[t + 1, L.T_T_COOLANT] = temp[th_.N_BLOCK]
        tr[t + 1, L.T_T_CAT] = temp[th_.N_MON]
        tr[t + 1, L.T_HC_EO] = s.hc_g_s
        tr[t + 1, L.T_CO_EO] = s.co_g_s
        tr[t + 1, L.T_NOX_EO] = s.nox_g_s
        tr[t + 1, L.T_HC_TP] = tp_hc
        tr[t + 1, L.T_CO_TP] = tp_co
        tr[t + 1, L.T_NOX_TP] = tp_nox


@njit(cache=True, inline="always")
def _engine_step(o, nodes: th_.ThermalNodes, op: EngineOp, s_eng, E, c, v_avg, part: StepPart, tr, record):
    """One key-on step of the engine at ``op``, or the part of it ``part`` says: fuel and engine-out rates from the
    hot maps times the cold-engine factors of the block temperature (none while it does not run), its energy
    terms, then the thermal nodes and the tailpipe (:func:`_exhaust`). Returns the fuel rate, g/s."""
    running, w_e, t_e = op.running, op.w_e_rad_s, op.t_e_nm
    temp, X = nodes.temp_c, nodes.cfg
    fuel = hot = hc = co = nox = 0.0
    if running:
        hot, hc, co, nox = rates(w_e, max(t_e, 0.0), s_eng, E)
        c_f, c_hc, c_co, c_nox = th_.cold_factors(temp[th_.N_BLOCK], X)
        fuel, hc, co, nox = hot * c_f, hc * c_hc, co * c_co, nox * c_nox
    p_shaft = t_e * w_e
    h = part.h_s
    _book_engine(o, fuel, hc, co, nox, p_shaft, c.lhv_j_per_g, h)
    if running:
        o[L.O_E_SHAFT_FUELLED] += p_shaft * h
        o[L.O_E_FUEL_COLD] += (fuel - hot) * c.lhv_j_per_g * h
    # ADVISOR's 'fc temp' takes the waste heat and the exhaust flow from the hot map's fuel: a cold engine's
    # surplus fuel leaves unburnt (the extra HC and CO of the cold factors) and heats nothing
    q_waste = hot * c.lhv_j_per_g - p_shaft
    step = th_.ThermalStep(
        key_on=ON,
        fuel_g_s=hot,
        q_waste_w=q_waste,
        w_e_rad_s=w_e,
        hc_g_s=hc,
        co_g_s=co,
        nox_g_s=nox,
        v_mps=v_avg,
        dt_s=h,
    )
    _exhaust(o, nodes, step, part.t_end_s, part.t, tr, record)
    return fuel


@njit(cache=True, inline="always")
def _book_wheel(o, f_del, v_disp, f_brake, v0, v_avg, limited, road: StepRoad, ch):
    """Work at the wheels (driveline, friction brakes) against road loads, grade and inertia; for a
    force-limited step also the residual of its speed fixed point."""
    sn, cs, dt = road.sin_g, road.cos_g, road.dt_s
    fa, fr, fg, fx = road_force(v_avg, sn, cs, ch)
    w_wheel = f_del * v_disp * dt
    if w_wheel >= 0.0:
        o[L.O_E_TRACTION] += w_wheel
    else:
        o[L.O_E_REGEN] -= w_wheel
    o[L.O_E_BRAKE] -= f_brake * v_avg * dt
    o[L.O_E_ROAD] += (fa + fr + fx) * v_avg * dt
    o[L.O_E_GRADE] += fg * v_avg * dt
    if limited:
        # driveline work at v_disp against the motion it bought
        a = 2.0 * (v_avg - v0) / dt
        o[L.O_E_MISMATCH] += w_wheel - (ch.m_eff * a + fa + fr + fg + fx) * v_avg * dt


@njit(cache=True, inline="always")
def _book_following(o, v_ref_now, v_ref_next, v0, v_next, v_avg, dt, cycle_met_tolerance_mps):
    """Cycle-following statistics of one step: acceleration shortfall, speed error and time off the
    trace, distances, and the spell the car has stood still while the cycle asked it to move."""
    a_req = (v_ref_next - v_ref_now) / dt  # what the cycle asks for this step
    if a_req > 0.0:
        o[L.O_ACC_REQ] += a_req
        o[L.O_ACC_SHORT] += _clean(a_req - (v_next - v0) / dt)
        o[L.O_ACC_REQ_MAX] = max(o[L.O_ACC_REQ_MAX], a_req)
    o[L.O_ACC_ABS_ERR] += _clean(abs(a_req - (v_next - v0) / dt))
    err = _clean(abs(v_ref_next - v_next))
    o[L.O_SPEED_ERR_SUM] += err
    o[L.O_MAX_SPEED_ERR] = max(o[L.O_MAX_SPEED_ERR], err)
    if err > cycle_met_tolerance_mps:
        o[L.O_OFF_TRACE_S] += dt
    if v_next < STILL_MPS and v_ref_next > STILL_MPS:
        o[L.O_STUCK_NOW_S] += dt
        o[L.O_STUCK_MAX_S] = max(o[L.O_STUCK_MAX_S], o[L.O_STUCK_NOW_S])
    else:
        o[L.O_STUCK_NOW_S] = 0.0
    o[L.O_DIST_M] += v_avg * dt
    o[L.O_DIST_REF_M] += 0.5 * (v_ref_now + v_ref_next) * dt
    o[L.O_N_STEPS] += 1.0
    return a_req


@njit(cache=True, inline="always")
def _falls_short(f_del: float, f_req: float) -> bool:
    """A traction step whose delivered force falls short of the request (a force-limited step)."""
    return f_req > 0.0 and f_del < f_req - 1e-6 * max(1.0, f_req)


@njit(cache=True, inline="always")
def _over(x: float, cap: float) -> bool:
    return x > cap * (1.0 + LIMIT_TOL) + 1e-12


SPEED_TOL = 1e-6  # m/s, convergence of a force-limited step's speed
NO_ENVELOPE = (-1.0, 0.0, 0.0)  # (speed, force, slope) of the full-power envelope: none known yet


@njit(cache=True, inline="always")
def _secant_step(v_a: float, h_a: float, v_b: float, h_b: float, v_max: float) -> float:
    """Next guess for the root of h(v) = v_bought(v) - v from two iterates (fixed point if degenerate)."""
    den = h_b - h_a
    v = v_b - h_b * (v_b - v_a) / den if abs(den) > 1e-15 else v_b + h_b
    return min(max(v, 0.0), v_max)


@njit(cache=True, inline="always")
def _newton_from(v0, v_e, f_e, slope, sn, cs, dt, v_max, ch: Chassis) -> float:
    """Newton step for the root of h(v) = v_bought(F(v)) - v from ``v_e``, where the driveline gives the force
    ``f_e`` and ``F`` has the slope ``slope`` (N s/m) against speed. ``v_bought`` (:func:`mean_speed_for_force`,
    this step's start speed and grade) rises with the force at ``1 / (2 m_eff / dt + rho CdA u)`` (0 on its
    branch where the step ends at v0 / 2)."""
    u = mean_speed_for_force(v0, f_e, sn, cs, dt, ch)
    du_df = 1.0 / (2.0 * ch.m_eff / dt + ch.k_lin + ch.rho * ch.cda * u) if u > 0.0 and 2.0 * u - v0 > 0.0 else 0.0
    dh = min(du_df * slope - 1.0, -0.1)  # h falls with v (the force falls, or barely rises, with speed)
    return min(max(v_e - (u - v_e) / dh, 0.0), v_max)


@njit(cache=True)
def limited_step_split(
    v0,
    v_req,
    v_cap,
    cmd: split.SplitCommand,
    road: StepRoad,
    st,
    env,
    ch,
    dl: split.SplitDriveline,
):
    """Solve a force-limited step of the power-split car (the drive loop's, and each step of the performance
    tests' full-power launch): the mean speed ``v`` (<= ``v_cap``) at which
    the force the driveline gives at ``v`` (``st``: its state at ``v_req``; ``cmd``'s at full engine power) buys
    exactly ``v``.

    ``env = (v, F, dF/dv)``: a point of the full-power force envelope against speed and its slope, from the
    previous force-limited step (``v < 0``: none). Consecutive limited steps have nearly the same envelope and
    nearby solutions, so the first guess is the Newton step from that point (else the fixed-point step from
    ``v_req``), the second a Newton step with the slope, then secant steps, until the speed bought is within
    ``SPEED_TOL``.
    Returns (state, v_disp, v_avg, the envelope point and slope for the next solve)."""
    sn, cs, dt = road.sin_g, road.cos_g, road.dt_s
    d, E, M, G = dl.d, dl.E, dl.M, dl.G
    v_e, f_e, slope = env
    u = mean_speed_for_force(v0, st.f_del, sn, cs, dt, ch)
    v_a, f_a, h_a = v_req, st.f_del, u - v_req
    if v_e >= 0.0:
        v_b = _newton_from(v0, v_e, f_e, slope, sn, cs, dt, v_cap, ch)
    else:
        v_b = min(max(v_req + h_a, 0.0), v_cap)
    f_b = f_a
    for it in range(12):
        lim = split.limits(v_b, d, E, M, G)
        st = split.dispatch(lim, split.at_power(cmd, lim.p_e_max), d, E, M, G)
        f_b = st.f_del
        u = mean_speed_for_force(v0, f_b, sn, cs, dt, ch)
        h_b = u - v_b
        if abs(h_b) <= SPEED_TOL:
            break
        if it == 0 and v_e >= 0.0:
            v_next = _newton_from(v0, v_b, f_b, slope, sn, cs, dt, v_cap, ch)
        else:
            v_next = _secant_step(v_a, h_a, v_b, h_b, v_cap)
        v_a, h_a, f_a, v_b = v_b, h_b, f_b, v_next
    if abs(h_b) > SPEED_TOL:
        # the secant steps did not settle (a kink of the envelope, e.g. where the
        # generator's limit takes over): bisect, h(0) >= 0 >= h(v_cap)
        v_lo, v_hi = 0.0, v_cap
        for _ in range(64):
            v_b = 0.5 * (v_lo + v_hi)
            lim = split.limits(v_b, d, E, M, G)
            st = split.dispatch(lim, split.at_power(cmd, lim.p_e_max), d, E, M, G)
            f_b = st.f_del
            u = mean_speed_for_force(v0, f_b, sn, cs, dt, ch)
            h_b = u - v_b
            if abs(h_b) <= SPEED_TOL or v_hi - v_lo <= 1e-12:
                break
            if h_b > 0.0:
                v_lo = v_b
            else:
                v_hi = v_b
        return st, v_b, u, NO_ENVELOPE
    if 1e-9 < abs(v_b - v_a) < 0.5:  # a local secant of the envelope (not the chord from a distant v_req)
        slope = (f_b - f_a) / (v_b - v_a)
    return st, v_b, u, (v_b, f_b, slope)


@njit(cache=True)
def limited_step_conv(v0, v_req, v_cap, cmd: ConvCommand, road: StepRoad, st, ch, d, E):
    """As :func:`limited_step_split` for the conventional car in a fixed gear and clutch state (fixed-point start)."""
    f_cmd, ratio, slip = cmd.f_req_n, cmd.ratio, cmd.slip
    sn, cs, dt = road.sin_g, road.cos_g, road.dt_s
    v_a = v_req
    h_a = mean_speed_for_force(v0, st.f_del, sn, cs, dt, ch) - v_a
    v_b = min(max(v_a + h_a, 0.0), v_cap)
    for _ in range(12):
        st = conv.dispatch(v_b, f_cmd, ratio, slip, d, E)
        h_b = mean_speed_for_force(v0, st.f_del, sn, cs, dt, ch) - v_b
        if abs(h_b) <= SPEED_TOL:
            break
        v_a, h_a, v_b = v_b, h_b, _secant_step(v_a, h_a, v_b, h_b, v_cap)
    return st, v_b, mean_speed_for_force(v0, st.f_del, sn, cs, dt, ch)


@njit(cache=True, inline="always")
def _off(f_req: float, p_dis: float, p_chg: float, regen: float) -> split.SplitCommand:
    """The command of a spin-up part: the wheels on the motor alone within (``p_dis``, ``p_chg``)."""
    return split.SplitCommand(
        f_req_n=f_req, engine_on=OFF, p_e_target_w=0.0, p_dis_w=p_dis, p_chg_w=p_chg, regen_share=regen
    )


@njit(cache=True, inline="always")
def _spin_window(p_dis: float, p_left: float, p_acc: float) -> float:
    """The discharge window of the wheels and accessories while a spin-up draws on the pack: the controller's
    window ``p_dis`` within what the pack itself has left beside the spin-up, ``p_left``; the accessories keep
    theirs from the pack's own reserve (the spin-up's torque leaves them room: ``split.spin_up``)."""
    return max(min(p_dis, p_left), min(p_acc, p_left), 0.0)


@njit(cache=True, inline="always")
def _idle(lim: split.SplitLimits) -> split.SplitState:
    """Nothing turns but the ring: the state of a part that does not happen."""
    return split.SplitState(
        f_del=0.0,
        running=OFF,
        w_e=0.0,
        t_e=0.0,
        w_r=lim.w_r,
        t_m=0.0,
        w_g=0.0,
        t_g=0.0,
        p_m_e=0.0,
        p_g_e=0.0,
        p_acc=0.0,
        p_batt=0.0,
        t_r=0.0,
        t_c=0.0,
    )


@njit(cache=True, inline="always")
def _split_violations(st: split.SplitState, d: split.SplitDesign, E, M, G) -> float:
    """How many component limits the power-split state ``st`` exceeds (engine, generator, motor)."""
    bad = 0.0
    if st.running:
        if _over(st.w_e, d.w_e_max) or st.w_e < d.w_e_min * (1.0 - LIMIT_TOL):
            bad += 1.0
        if _over(st.t_e, max_torque(st.w_e, d.s_eng, E)):
            bad += 1.0
    if _over(abs(st.w_g), d.w_g_max) or _over(abs(st.t_g), torque_limit(st.w_g, d.s_gen, G)):
        bad += 1.0
    if _over(st.w_r, d.w_m_max) or _over(abs(st.t_m), torque_limit(st.w_r, d.s_mot, M)):
        bad += 1.0
    return bad


@njit(cache=True, inline="always")
def _book_split_part(o, st: split.SplitState, h: float, v_disp: float, d: split.SplitDesign):
    """The machines', gear set's, final drive's and accessories' energy terms of a power-split part of ``h``
    seconds at ``st``."""
    k = d.n_r / d.n_s
    o[L.O_E_LOSS_MOT] += (st.p_m_e - st.t_m * st.w_r) * h
    o[L.O_E_LOSS_GEN] += (st.p_g_e - st.t_g * st.w_g) * h
    o[L.O_E_GEN_MECH_IN] += max(-st.t_g * st.w_g, 0.0) * h
    o[L.O_E_GEN_ELEC_OUT] += max(-st.p_g_e, 0.0) * h
    # gear-set loss: the engine's ideal ring share minus what reaches (or leaves) the ring
    o[L.O_E_LOSS_PG] += (st.t_c * k / (1.0 + k) - (st.t_r - st.t_m)) * st.w_r * h
    o[L.O_E_LOSS_FD] += (st.t_r * st.w_r - st.f_del * v_disp) * h
    o[L.O_E_ACC] += st.p_acc * h
    o[L.O_E_ACC_UNMET] += (d.p_acc_w - st.p_acc) * h


@njit(cache=True)
def _hybrid_one(veh: HybridRec, i: int, cyc: KernelCycle, t_init, o, tr, record: bool, scratch):
    # everything below reads the caller's arrays through views that are not reference-counted (borrow.py)
    veh, cyc, t_init, o, tr, scratch = borrowed((veh, cyc, t_init, o, tr, scratch))
    row, c, sc, th, pc = veh.rows[i], veh.c, veh.sc, veh.th, veh.pc
    E, M, G, B, X = veh.E, veh.M, veh.G, veh.B, veh.X
    v_ref, grade, sin_g, cos_g, key_on = cyc.v_ref, cyc.grade, cyc.sin_g, cyc.cos_g, cyc.key_on
    d = split_design(row, c, sc)
    ch = chassis(row[R_MASS], split_equivalent_mass_kg(row, c, sc), c)
    n_bat = row[R_N_BAT]
    cap = sc.cap_as
    dt = c.dt
    v_lim = split_speed_limit(d)
    soc, v = row[R_SOC0], 0.0
    eng_on, t_state = OFF, 1e9
    cdyn = split.carrier_dynamics(d, G, sc.j_start, sc.j_gen, sc.t_crank, sc.w_fire)
    w_c, was_running = 0.0, False  # carrier speed at the end of the last step; the engine fired then
    env = NO_ENVELOPE  # the last force-limited step's point on the full-power force envelope (limited_step_split)
    soc_lo, soc_hi = soc, soc
    n = v_ref.shape[0]
    k_th, temp = th_.start(d.s_eng * X.p_base_kw, X, t_init, dt, o, scratch)
    nodes = th_.ThermalNodes(temp_c=temp, k=k_th, cfg=X)
    dl = split.SplitDriveline(d=d, E=E, M=M, G=G)
    for t in range(n - 1):
        v0 = v
        gr, sn, cs = grade[t], sin_g[t], cos_g[t]
        road = StepRoad(sin_g=sn, cos_g=cs, dt_s=dt)
        v_ref_next = v_ref[t + 1]
        v_tgt = min(v_ref_next, v_lim)
        ocv, r_d, r_c = pack_state(soc, n_bat, B)
        p_dis, p_chg = pack_power_limits(ocv, r_d, r_c, soc, sc.soc_min, n_bat, sc, dt)
        stationary = v0 <= 1e-9 and v_tgt <= 1e-9
        if stationary and not key_on[t]:
            # prescribed key-off (e.g. the FTP soak): nothing runs, no accessory load
            eng_on = OFF
            w_c, was_running = 0.0, False
            _book_following(o, v_ref[t], v_ref_next, 0.0, 0.0, 0.0, dt, c.cycle_met_tolerance_mps)
            _exhaust(o, nodes, _key_off(dt), (t + 1) * dt, t, tr, record)
            t_state += dt
            if record:
                tr[t + 1, L.T_SOC] = soc
                tr[t + 1, L.T_GRADE] = gr
            continue
        v_req = 0.0 if stationary else 0.5 * (v0 + v_tgt)
        f_aero, f_roll, f_grade, f_axle = road_force(v_req, sn, cs, ch)
        f_road = f_aero + f_roll + f_grade + f_axle
        f_req = 0.0 if stationary else ch.m_eff * (v_tgt - v0) / dt + f_road
        f_adh = adhesion_limit(sn, cs, f_road, ch)
        f_cmd = min(f_req, f_adh) if f_req >= 0.0 else max(f_req, -f_adh)
        regen = driveline_brake_share(v_req, c)
        lim = split.limits(v_req, d, E, M, G)
        t_r_req = split.ring_torque_for_wheel_force(f_cmd, d)
        seen = Observed(
            engine_on=eng_on,
            t_in_state_s=t_state,
            soc=soc,
            grade=gr,
            v_kmh=v0 * 3.6,
            t_r_req_nm=t_r_req,
            p_dis_w=p_dis,
            t_coolant_c=temp[th_.N_BLOCK],
        )
        lim_on = lim  # the window a running engine's dispatch works in (ECMS pins it to the speed it chose)
        if pc.ecms:
            p_start_w = 0.0  # a start's energy over the shortest run that follows it (hevlib/sim/ecms.py)
            if sc.engine_dynamics and not was_running:
                su0 = split.spin_up(w_c, lim.w_r, np.inf, cdyn, d, G, np.inf)
                p_start_w = np.inf if su0.t_left_s == np.inf else su0.e_elec_j / max(dt, pc.engine_min_on_s)
            pack_now = ecms_.EcmsStep(
                f_cmd_n=f_cmd, f_req_n=f_req, regen_share=regen, p_dis_w=p_dis, p_chg_w=p_chg, soc=soc, ocv_v=ocv,
                r_d_ohm=r_d, r_c_ohm=r_c, eta_c=sc.eta_c, dt_s=dt, running=was_running, p_start_w=p_start_w,
            )  # fmt: skip
            pick = ecms_.choose(lim, pack_now, seen, c.lhv_j_per_g, pc, d, E, M, G)
            want, p_target = pick.engine_on, pick.p_e_target_w
            if want and pick.w_pin_rad_s > 0.0:
                lim_on = ecms_.pinned(lim, pick.w_pin_rad_s, d, E, G)
        else:
            want, p_target = supervise(seen, lim, th, pc, sc.soc_min, d, E, M)
        # ---- a start: the generator spins the carrier up to firing speed (engine dynamics), from what the pack
        # itself can spare (its voltage and current, not the controller's SOC window), the start first
        su = split.spin_up(w_c, lim.w_r, 0.0, cdyn, d, G, 0.0)  # none
        p_own = 0.0
        if sc.engine_dynamics and want and not was_running:
            p_own = pack_power_limits(ocv, r_d, r_c, soc, 0.0, n_bat, sc, dt)[0]
            su = split.spin_up(w_c, lim.w_r, p_own - d.p_acc_w, cdyn, d, G, dt)
            lo, hi = split.engine_window(split.ring_speed(min(v0, v_req), d), d)
            if lo > hi or su.t_left_s == np.inf:
                # the engine could not run at the speed the step starts from (a generator that would overspeed), or
                # no torque the pack can spare overcomes its crank torque
                want, p_target = False, 0.0
                su = split.spin_up(w_c, lim.w_r, 0.0, cdyn, d, G, 0.0)
        spin = want and su.tau_s > 0.0
        if want != eng_on:
            eng_on = want
            t_state = 0.0
        # ---- a spin-up that ends within the step splits it: the spin-up's part (engine unfuelled, the wheels on the
        # pack's window less the spin-up's draw), then the engine runs for the rest with the whole window and makes
        # up what the first part fell short of; else (a spin-up through the step, or a rest that cannot make up the
        # force) one part, the spin-up's energy booked over the step
        tau = 0.0  # the spin-up part of a split step, s
        st_a, p_dis_a = _idle(lim), 0.0
        if spin and su.tau_s < dt:
            p_dis_a = _spin_window(p_dis, p_own - su.e_elec_j / su.tau_s, d.p_acc_w)
            st_a = split.dispatch(lim, _off(f_cmd, p_dis_a, p_chg, regen), d, E, M, G)
            # a traction shortfall is made up; braking is not (the friction brakes take what the driveline does not)
            f_b = (f_cmd * dt - st_a.f_del * su.tau_s) / (dt - su.tau_s) if f_cmd > 0.0 else f_cmd
            cmd_b = split.SplitCommand(
                f_req_n=f_b, engine_on=ON, p_e_target_w=p_target, p_dis_w=p_dis, p_chg_w=p_chg, regen_share=regen
            )
            st = split.dispatch(lim_on, cmd_b, d, E, M, G)
            if not stationary and _falls_short(st.f_del, f_b) and p_target < lim.p_e_max:
                st = split.dispatch(lim, split.at_power(cmd_b, lim.p_e_max), d, E, M, G)
            if stationary or not _falls_short(st.f_del, f_b):
                tau = su.tau_s
        through = spin and su.tau_s >= dt  # the spin-up runs on past the step: the engine does not run yet
        e_start = su.e_mech_j if spin else 0.0
        p_start = su.e_elec_j / dt if spin else 0.0  # the start's electrical power over the step
        limited = False
        v_disp, v_avg, f_brake = v_req, v_req, 0.0
        if tau > 0.0:
            f_mean = (st_a.f_del * tau + st.f_del * (dt - tau)) / dt
            f_brake = 0.0 if stationary else f_req - f_mean
            v_avg = 0.0 if stationary else v_req
        else:
            # a spin-up through the step, or a start merged into its step: the wheels get the controller's window
            # less what the spin-up draws from the pack's own (the engine unfuelled through the step, or running)
            cmd = split.SplitCommand(
                f_req_n=f_cmd,
                engine_on=eng_on and not through,
                p_e_target_w=p_target,
                p_dis_w=_spin_window(p_dis, p_own - p_start, d.p_acc_w) if spin else p_dis,
                p_chg_w=p_chg,
                regen_share=regen,
            )
            st = split.dispatch(lim_on if cmd.engine_on else lim, cmd, d, E, M, G)
            limited = not stationary and _falls_short(st.f_del, f_req)
            if stationary:
                v_avg = 0.0
            elif limited:
                # the driver floors it: engine at full power, then the speed this force buys (fixed point)
                if cmd.engine_on and p_target < lim.p_e_max:
                    st = split.dispatch(lim, split.at_power(cmd, lim.p_e_max), d, E, M, G)
                    limited = _falls_short(st.f_del, f_req)
                if limited:
                    st, v_disp, v_avg, env = limited_step_split(v0, v_req, v_req, cmd, road, st, env, ch, dl)
                else:
                    f_brake = f_req - st.f_del
            else:
                f_brake = f_req - st.f_del
            f_mean = st.f_del
        if limited:
            o[L.O_N_LIMITED] += 1.0
        v_next = max(2.0 * v_avg - v0, 0.0)
        if st.running and not was_running:
            o[L.O_N_STARTS] += 1.0
        # ---- battery: each part's current
        h_b = dt - tau
        p_a = st_a.p_batt + su.e_elec_j / tau if tau > 0.0 else 0.0
        p_b = st.p_batt + (p_start if tau == 0.0 else 0.0)
        q = charge_drawn(p_a, ocv, r_d, r_c, tau, sc.eta_c) + charge_drawn(p_b, ocv, r_d, r_c, h_b, sc.eta_c)
        soc -= q / cap
        p_chem = ocv * q / dt
        p_batt = (p_a * tau + p_b * h_b) / dt
        # ---- engine, its heat and the exhaust; energy accounting (J)
        if st.running:
            o[L.O_ENG_ON_STEPS] += 1.0
        elif st.w_e > 0.0:
            o[L.O_ENG_SPUN_STEPS] += 1.0  # spun by the gear set with its fuel cut
        t_now = t * dt
        if tau > 0.0:
            # the engine unfuelled: the spin-up's work is e_start's; what the dispatch has the carrier do besides (a
            # carrier the gear set spins, its drag reacted by the generator) is booked as in any step
            spun = EngineOp(running=OFF, w_e_rad_s=st_a.w_e, t_e_nm=st_a.t_e)
            _engine_step(o, nodes, spun, d.s_eng, E, c, v_avg, StepPart(t=t, h_s=tau, t_end_s=t_now + tau), tr, False)
            _book_split_part(o, st_a, tau, v_disp, d)
        op = EngineOp(running=st.running, w_e_rad_s=st.w_e, t_e_nm=st.t_e)
        fuel = _engine_step(
            o, nodes, op, d.s_eng, E, c, v_avg, StepPart(t=t, h_s=h_b, t_end_s=(t + 1) * dt), tr, record
        )
        fuel *= h_b / dt  # the step's mean rate
        _book_split_part(o, st, h_b, v_disp, d)
        o[L.O_E_BATT] += p_chem * dt
        o[L.O_E_LOSS_BATT] += (p_chem - p_batt) * dt
        o[L.O_E_LOSS_GEN] += p_start * dt - e_start
        o[L.O_E_ENGINE_START] += e_start
        _book_wheel(o, f_mean, v_disp, f_brake, v0, v_avg, limited, road, ch)
        a_req = _book_following(o, v_ref[t], v_ref_next, v0, v_next, v_avg, dt, c.cycle_met_tolerance_mps)
        soc_lo, soc_hi = min(soc_lo, soc), max(soc_hi, soc)
        # ---- limits
        bad = _split_violations(st, d, E, M, G)
        if tau > 0.0:
            bad += _split_violations(st_a, d, E, M, G)
        # the controller's SOC window: the drive draws no more than the window allows at the step's start (a
        # spin-up may draw on the pack's own reserve below it, the start first), and charges no further than its top
        p_win = _spin_window(p_dis, p_own - p_start, d.p_acc_w) if spin and tau == 0.0 else p_dis
        if _over(st.p_batt, p_win) or (tau > 0.0 and _over(st_a.p_batt, p_dis_a)) or soc > sc.soc_max + SOC_TOL:
            bad += 1.0
        o[L.O_LIMIT_VIOLATIONS] += bad
        if record:
            tr[t + 1, L.T_V_REF] = v_ref_next
            tr[t + 1, L.T_V] = v_next
            tr[t + 1, L.T_SOC] = soc
            tr[t + 1, L.T_W_E] = st.w_e
            tr[t + 1, L.T_T_E] = st.t_e
            tr[t + 1, L.T_W_M] = st.w_r
            tr[t + 1, L.T_T_M] = st.t_m
            tr[t + 1, L.T_W_G] = st.w_g
            tr[t + 1, L.T_T_G] = st.t_g
            tr[t + 1, L.T_P_BATT] = p_batt
            tr[t + 1, L.T_P_ENGINE_START] = p_start
            tr[t + 1, L.T_FUEL] = fuel
            tr[t + 1, L.T_ENG_ON] = 1.0 if st.running else 0.0
            tr[t + 1, L.T_F_PT] = f_mean
            tr[t + 1, L.T_F_BRK] = f_brake
            tr[t + 1, L.T_GEAR] = 0.0
            tr[t + 1, L.T_A_REQ] = a_req
            tr[t + 1, L.T_A_ACH] = (v_next - v0) / dt
            tr[t + 1, L.T_P_MOT_E] = st.p_m_e
            tr[t + 1, L.T_P_GEN_E] = st.p_g_e
            tr[t + 1, L.T_T_E_MAX] = max_torque(st.w_e, d.s_eng, E) if st.running else 0.0
            tr[t + 1, L.T_T_M_MAX] = torque_limit(st.w_r, d.s_mot, M)
            tr[t + 1, L.T_T_G_MAX] = torque_limit(st.w_g, d.s_gen, G)
            tr[t + 1, L.T_GRADE] = gr
            tr[t + 1, L.T_P_ACC_UNMET] = d.p_acc_w - st.p_acc
            tr[t + 1, L.T_M_EFF] = ch.m_eff
            # the spin-up part of a split step (its length; 0 else), the rest of the step in the channels above
            tr[t + 1, L.T_SPIN_PART_S] = tau
            tr[t + 1, L.T_SPIN_W_ENG] = st_a.w_e
            tr[t + 1, L.T_SPIN_T_ENG] = st_a.t_e
            tr[t + 1, L.T_SPIN_T_MOT] = st_a.t_m
            tr[t + 1, L.T_SPIN_P_MOT_E] = st_a.p_m_e
            tr[t + 1, L.T_SPIN_W_GEN] = st_a.w_g
            tr[t + 1, L.T_SPIN_T_GEN] = st_a.t_g
            tr[t + 1, L.T_SPIN_P_GEN_E] = st_a.p_g_e
            tr[t + 1, L.T_SPIN_F_PT] = st_a.f_del
        v = v_next
        t_state += dt
        # the carrier: where a spin-up left it while the engine does not run yet, else where the step left it
        w_c, was_running = (su.w_end_rad_s, False) if spin and not st.running else (st.w_e, st.running)
    o[L.O_SOC_END] = soc
    o[L.O_SOC_MIN_SEEN] = soc_lo
    o[L.O_SOC_MAX_SEEN] = soc_hi
    o[L.O_E_KIN_END] = 0.5 * ch.m_eff * v * v
    th_.finish(temp, k_th, (n - 1) * dt, o)
    if record:
        tr[0, L.T_V_REF] = v_ref[0]
        tr[0, L.T_SOC] = row[R_SOC0]
        tr[0, L.T_GRADE] = grade[0]
        tr[0, L.T_T_COOLANT] = t_init[th_.N_BLOCK]
        tr[0, L.T_T_CAT] = t_init[th_.N_MON]


@njit(cache=True, nogil=True)
def drive_hybrid(veh: HybridRec, cyc: KernelCycle, t_init, out, traces, rec_index, start: int, stop: int):
    """Drive designs ``start .. stop - 1`` of ``veh`` (its rows) over ``cyc`` from the thermal start ``t_init``;
    fill their rows of ``out`` (``O_*`` columns) and, where ``rec_index`` is >= 0, that trace of ``traces``.
    Releases the GIL: :func:`hevlib.sim.simulator.in_parallel` runs chunks of a batch on threads."""
    scratch = np.empty(th_.N_SCRATCH)  # the thermal model's working row, design after design
    for i in range(start, stop):
        j = rec_index[i]
        _hybrid_one(veh, i, cyc, t_init, out[i], traces[max(j, 0)], j >= 0, scratch)


@njit(cache=True)
def _conventional_one(veh: ConventionalRec, i: int, cyc: KernelCycle, t_init, o, tr, record: bool, scratch):
    # the caller's arrays through views that are not reference-counted (borrow.py)
    veh, cyc, t_init, o, tr, scratch = borrowed((veh, cyc, t_init, o, tr, scratch))
    row, c, ratios, S, d, E, X = veh.rows[i], veh.c, veh.ratios, veh.shift, veh.cd, veh.E, veh.X
    v_ref, grade, sin_g, cos_g, key_on = cyc.v_ref, cyc.grade, cyc.sin_g, cyc.cos_g, cyc.key_on
    m = row[R_MASS]
    n_gears = ratios.shape[0]
    m_free = conventional_equivalent_mass_kg(m, 0.0, False, d.s_eng, c)  # clutch open
    m_prev = m_free
    dt = c.dt
    v_lim = d.w_e_max * d.r / ratios[-1]
    v = 0.0
    n = v_ref.shape[0]
    gear, g_1, g_2 = 0, 0, 0  # the gear held and those of the two steps before it (ADVISOR's downshift guard)
    clutch = conv.OPEN
    k_th, temp = th_.start(d.s_eng * X.p_base_kw, X, t_init, dt, o, scratch)
    nodes = th_.ThermalNodes(temp_c=temp, k=k_th, cfg=X)
    for t in range(n - 1):
        v0 = v
        gr, sn, cs = grade[t], sin_g[t], cos_g[t]
        road = StepRoad(sin_g=sn, cos_g=cs, dt_s=dt)
        v_ref_next = v_ref[t + 1]
        v_tgt = min(v_ref_next, v_lim)
        stationary = v0 <= 1e-9 and v_tgt <= 1e-9
        if stationary and not key_on[t]:
            _book_following(o, v_ref[t], v_ref_next, 0.0, 0.0, 0.0, dt, c.cycle_met_tolerance_mps)
            _exhaust(o, nodes, _key_off(dt), (t + 1) * dt, t, tr, record)
            if record:
                tr[t + 1, L.T_GRADE] = gr
            continue
        v_req = 0.0 if stationary else 0.5 * (v0 + v_tgt)
        ch = chassis(m, m_free, c)
        f_aero, f_roll, f_grade, f_axle = road_force(v_req, sn, cs, ch)
        f_road = f_aero + f_roll + f_grade + f_axle
        # what the step asks of the driveline, the engine's own inertia aside (ADVISOR adds it in the engine)
        f_ask = 0.0 if stationary else m_free * (v_tgt - v0) / dt + f_road
        f_grip = adhesion_limit(sn, cs, f_road, ch)
        # ---- gear: ADVISOR's load-based logic in the gear held, or the speed table
        if S.load_based:
            load = 1.0 if f_ask > f_grip else conv.engine_load(v_req, f_ask, ratios[gear], d, E)
            w_held = v_req / d.r * ratios[gear]
            new = conv.next_gear(gear, w_held, load, not (gear > g_1 or gear > g_2), S, n_gears)
        else:
            new = min(conv.scheduled_gear(v0 * 3.6, S.upshift_kmh), n_gears - 1)
        g_2, g_1, gear = g_1, gear, new
        ratio = ratios[gear]
        # ---- clutch, on the torque asked of it at the gearbox input
        clutch = conv.clutch_state(conv.input_torque(v_req, f_ask, ratio, d), v_req / d.r * ratio, clutch, d)
        m_eff = conventional_equivalent_mass_kg(m, ratio, clutch == conv.CLOSED, d.s_eng, c)
        ch = chassis(m, m_eff, c)
        f_req = 0.0 if stationary else m_eff * (v_tgt - v0) / dt + f_road
        if m_eff != m_prev:
            # clutch closing or opening, or a shift: the engine's share of the kinetic energy jumps; the
            # clutch slip that syncs it dissipates (or, rev-matching a downshift, supplies) the difference
            o[L.O_E_LOSS_CLUTCH] += 0.5 * (m_prev - m_eff) * v0 * v0
            m_prev = m_eff
        f_cmd = min(f_req, f_grip)
        slip = clutch == conv.SLIP
        if clutch == conv.OPEN:
            st = conv.open_state(d)
        else:
            # traction as asked; of a braking request the driveline is asked the wheel file's share
            f_dl = f_cmd if f_req > 0.0 else driveline_brake_share(v_req, c) * f_req
            st = conv.dispatch(v_req, f_dl, ratio, slip, d, E)
        v_disp = v_req
        f_brake = 0.0
        limited = not stationary and _falls_short(st.f_del, f_req)
        if stationary:
            v_avg = 0.0
        elif limited:
            o[L.O_N_LIMITED] += 1.0
            if clutch == conv.OPEN:
                v_avg = mean_speed_for_force(v0, 0.0, sn, cs, dt, ch)  # coasting with the clutch open
                v_disp = v_avg
            else:
                cmd = ConvCommand(f_req_n=f_cmd, ratio=ratio, slip=slip)
                st, v_disp, v_avg = limited_step_conv(v0, v_req, v_req, cmd, road, st, ch, d, E)
        else:
            v_avg = v_req
            f_brake = f_req - st.f_del
        v_next = max(2.0 * v_avg - v0, 0.0)
        running = clutch != conv.OPEN or d.idle_allowed
        op = EngineOp(running=running, w_e_rad_s=st.w_e, t_e_nm=st.t_e)
        fuel = _engine_step(o, nodes, op, d.s_eng, E, c, v_avg, StepPart(t=t, h_s=dt, t_end_s=(t + 1) * dt), tr, record)
        if running:
            o[L.O_E_ACC] += d.p_acc_w * dt
            o[L.O_ENG_ON_STEPS] += 1.0
        else:
            o[L.O_E_ACC_UNMET] += d.p_acc_w * dt  # ADVISOR switches the accessories off with the engine
        o[L.O_E_LOSS_GB] += st.loss_gb_w * dt
        o[L.O_E_LOSS_CLUTCH] += st.loss_clutch_w * dt
        _book_wheel(o, st.f_del, v_disp, f_brake, v0, v_avg, limited, road, ch)
        a_req = _book_following(o, v_ref[t], v_ref_next, v0, v_next, v_avg, dt, c.cycle_met_tolerance_mps)
        if _over(st.w_e, d.w_e_max) or _over(st.t_e, max_torque(st.w_e, d.s_eng, E)):
            o[L.O_LIMIT_VIOLATIONS] += 1.0
        if record:
            tr[t + 1, L.T_V_REF] = v_ref_next
            tr[t + 1, L.T_V] = v_next
            tr[t + 1, L.T_W_E] = st.w_e
            tr[t + 1, L.T_T_E] = st.t_e
            tr[t + 1, L.T_FUEL] = fuel
            tr[t + 1, L.T_ENG_ON] = 1.0 if running else 0.0
            tr[t + 1, L.T_F_PT] = st.f_del
            tr[t + 1, L.T_F_BRK] = f_brake
            tr[t + 1, L.T_GEAR] = gear + 1.0 if clutch != conv.OPEN else 0.0
            tr[t + 1, L.T_A_REQ] = a_req
            tr[t + 1, L.T_A_ACH] = (v_next - v0) / dt
            tr[t + 1, L.T_T_E_MAX] = max_torque(st.w_e, d.s_eng, E)
            tr[t + 1, L.T_GRADE] = gr
            tr[t + 1, L.T_M_EFF] = ch.m_eff
        v = v_next
    o[L.O_SOC_END] = row[R_SOC0]
    o[L.O_SOC_MIN_SEEN] = row[R_SOC0]
    o[L.O_SOC_MAX_SEEN] = row[R_SOC0]
    o[L.O_E_KIN_END] = 0.5 * m_prev * v * v
    th_.finish(temp, k_th, (n - 1) * dt, o)
    if record:
        tr[0, L.T_V_REF] = v_ref[0]
        tr[0, L.T_GRADE] = grade[0]
        tr[0, L.T_T_COOLANT] = t_init[th_.N_BLOCK]
        tr[0, L.T_T_CAT] = t_init[th_.N_MON]


@njit(cache=True, nogil=True)
def drive_conventional(veh: ConventionalRec, cyc: KernelCycle, t_init, out, traces, rec_index, start: int, stop: int):
    """As :func:`drive_hybrid` for the conventional car."""
    scratch = np.empty(th_.N_SCRATCH)  # the thermal model's working row, design after design
    for i in range(start, stop):
        j = rec_index[i]
        _conventional_one(veh, i, cyc, t_init, out[i], traces[max(j, 0)], j >= 0, scratch)
