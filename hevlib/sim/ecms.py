"""Equivalent-consumption minimisation (ECMS) in the drive step: the supervisory controller of
``pms.strategy: ecms`` (issue 56), beside the study's fuzzy rule base (:func:`hevlib.sim.control.supervise`).

Each step, on the step's demand and the pack's window as the drive loop has them, the engine off and the engine on
at a grid of ``pms.ecms_n_speed`` speeds across its window (at the step's ring speed) by ``pms.ecms_n_torque``
torques from zero to the most the engine and the generator take at that speed are each put through the simulator's
own dispatch (:func:`hevlib.sim.powertrain.hybrid.dispatch`, the carrier pinned to the candidate's speed); of those
that meet the demand within the window, the one of least

``fuel (g) + s x charge drawn x open-circuit voltage / LHV``,   ``s = s0 + gain (SOC_target - SOC)``

is taken (adaptive ECMS with SOC feedback: Onori, Serrao and Rizzoni, *Hybrid Electric Vehicles: Energy Management
Strategies*, Springer 2016, ch. 5). ``s0`` is the reciprocal of the engine map's best efficiency
(:func:`equivalence_factor`: the fuel a joule of battery energy replaces if the engine made it at its best point;
nothing fitted), the target the control file's (``pms.soc_target``), the gain ``pms.ecms_soc_gain``. An engine that
is not running pays its start on top of its candidates (the generator's electrical energy to spin the carrier from
where the last step left it to firing speed at full torque, :func:`hevlib.sim.powertrain.hybrid.spin_up`, as the
bound prices it), spread over the shortest time the engine then runs (``pms.engine_min_on_s``, at least the step):
priced against one step's saving instead, a start looks dearer the shorter the step, and ECMS started less and
burnt 4-9 % more at 0.25 s than at 1 s (median, FTP and HWFET; ``benchmarks/step_convergence.py --strategy
ecms``). Fuel is priced on the hot map (a cold engine burns more, whichever point it runs).

It is the same controller as :func:`hevlib.bound.ecms_fuel` (which runs it on the bound's candidates and model:
hot map, no thermal state, no minimum times) moved into the drive step, where the drive loop then does everything
it does for the rule base: the spin-up spread over its duration, the thermal state, the tailpipe, force-limited
steps. What it keeps of the rule base's authority (:func:`choose`): the physics (an engine that cannot run does
not; where nothing meets the demand a running engine goes to full power, as the driver floors it), the coolant
warm-up rule and the minimum on and off times of ``pms`` (the same settings as the rule base's).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from hevlib.sim.control import Observed
from hevlib.sim.powertrain import hybrid as split
from hevlib.sim.powertrain.battery import charge_drawn
from hevlib.sim.powertrain.engine import EngineArrays, max_torque, rates
from hevlib.sim.powertrain.machines import torque_limit
from hevlib.sim.powertrain.planetary import sun_speed

INF = np.inf
#: a candidate's delivered force may fall short of the request by this much (the drive loop's ``_falls_short``)
SHORT_TOL = 1e-6


class EcmsChoice(NamedTuple):
    """What :func:`choose` hands the drive loop: the engine's state, its target power, and the carrier speed the
    dispatch is pinned to (0: not pinned, the dispatch's own choice within the window)."""

    engine_on: bool
    p_e_target_w: float
    w_pin_rad_s: float


class EcmsStep(NamedTuple):
    """The step as ECMS sees it, beside the driveline's limits: demand, pack and the engine's state."""

    f_cmd_n: float  # wheel force commanded (within adhesion)
    f_req_n: float  # wheel force the driver asks for
    regen_share: float
    p_dis_w: float  # the controller's window
    p_chg_w: float
    soc: float
    ocv_v: float
    r_d_ohm: float
    r_c_ohm: float
    eta_c: float
    dt_s: float
    running: bool  # the engine fired on the last step
    p_start_w: float  # a start's electrical energy over the shortest time the engine then runs (inf: no start)


def equivalence_factor(E: EngineArrays, lhv_j_per_g: float) -> float:
    """ECMS's equivalence factor at the target SOC for an engine of map ``E``: the reciprocal of its best efficiency
    along its best-efficiency line (the fuel energy a unit of battery energy replaces if the engine made it at its
    best point, no electrical loss counted); from its component file, nothing fitted. Scale-free (a scaled engine
    burns in proportion to its power)."""
    best = 0.0
    for p_w, w, t in zip(E.line_p[1:], E.line_w[1:], E.line_t[1:], strict=True):
        fuel = rates(float(w), float(t), 1.0, E)[0]
        if fuel > 0.0:
            best = max(best, float(p_w) / (fuel * lhv_j_per_g))
    if best <= 0.0:
        raise ValueError("ecms: the engine's map has no point of positive efficiency")
    return 1.0 / best


@njit(cache=True, inline="always")
def pinned(lim: split.SplitLimits, w_e: float, d: split.SplitDesign, E, G) -> split.SplitLimits:
    """``lim`` with the engine's window closed to the speed ``w_e`` (its most power there: the engine's or the
    generator's torque limit, as :func:`hevlib.sim.powertrain.hybrid.limits` takes it at the window's top)."""
    k = d.n_r / d.n_s
    w_g = sun_speed(w_e, lim.w_r, d.n_r, d.n_s)
    t_cap = min(max_torque(w_e, d.s_eng, E), (1.0 + k) * torque_limit(w_g, d.s_gen, G))
    return split.SplitLimits(w_r=lim.w_r, t_m_cap=lim.t_m_cap, lo=w_e, hi=w_e, p_e_max=w_e * t_cap)


@njit(cache=True, inline="always")
def _short(f_del: float, f_req: float) -> bool:
    return f_req > 0.0 and f_del < f_req - SHORT_TOL * max(1.0, f_req)


@njit(cache=True)
def costs(
    lim: split.SplitLimits, s: EcmsStep, s_eq: float, lhv: float, n_speed: int, n_torque: int, d, E, M, G
) -> tuple[float, float, float, float]:
    """(cost of the engine off, least cost of the engine on, its power, its speed) of the step ``s`` at the
    equivalence factor ``s_eq``; a cost is inf where no such control meets the demand within the window."""
    g_per_as = s_eq * s.ocv_v / lhv  # fuel (g) a coulomb of the pack's charge is worth at this step
    off = split.SplitCommand(
        f_req_n=s.f_cmd_n, engine_on=False, p_e_target_w=0.0, p_dis_w=s.p_dis_w, p_chg_w=s.p_chg_w,
        regen_share=s.regen_share,
    )  # fmt: skip
    st = split.dispatch(lim, off, d, E, M, G)
    c_off = INF
    if not _short(st.f_del, s.f_req_n):
        c_off = g_per_as * charge_drawn(st.p_batt, s.ocv_v, s.r_d_ohm, s.r_c_ohm, s.dt_s, s.eta_c)
    c_on, p_on, w_on = INF, 0.0, 0.0
    p_extra = 0.0 if s.running else s.p_start_w
    if lim.lo > lim.hi or p_extra == INF:
        return c_off, c_on, p_on, w_on
    for a in range(n_speed):
        w_e = lim.lo if n_speed == 1 else lim.lo + (lim.hi - lim.lo) * a / (n_speed - 1)
        lim_w = pinned(lim, w_e, d, E, G)
        for b in range(n_torque):
            t_e = lim_w.p_e_max / w_e * b / (n_torque - 1) if n_torque > 1 else lim_w.p_e_max / w_e
            cmd = split.SplitCommand(
                f_req_n=s.f_cmd_n, engine_on=True, p_e_target_w=t_e * w_e, p_dis_w=s.p_dis_w, p_chg_w=s.p_chg_w,
                regen_share=s.regen_share,
            )  # fmt: skip
            st = split.dispatch(lim_w, cmd, d, E, M, G)
            if not st.running or _short(st.f_del, s.f_req_n):
                continue
            fuel_g = rates(st.w_e, max(st.t_e, 0.0), d.s_eng, E)[0] * s.dt_s
            q = charge_drawn(st.p_batt + p_extra, s.ocv_v, s.r_d_ohm, s.r_c_ohm, s.dt_s, s.eta_c)
            c = fuel_g + g_per_as * q
            if c < c_on:
                c_on, p_on, w_on = c, st.w_e * st.t_e, st.w_e
    return c_off, c_on, p_on, w_on


@njit(cache=True)
def choose(lim: split.SplitLimits, s: EcmsStep, seen: Observed, lhv: float, pc, d, E, M, G):
    """The engine's state and operating point for the step (an :class:`EcmsChoice`), ``pc`` the
    :class:`hevlib.sim.control.PmsConfig` (its ECMS settings, warm-up temperature and minimum times), ``seen`` what
    the rule base sees at the step's start (the controller's engine state and time in it, the coolant), ``lhv`` the
    fuel's heating value, J/g."""
    engine_on, t_in_state_s, t_coolant_c = seen.engine_on, seen.t_in_state_s, seen.t_coolant_c
    s_eq = max(pc.ecms_s0 + pc.ecms_soc_gain * (pc.soc_target - s.soc), 0.0)
    c_off, c_on, p_on, w_on = costs(lim, s, s_eq, lhv, pc.ecms_n_speed, pc.ecms_n_torque, d, E, M, G)
    # the cheaper; where neither meets the demand, the engine (the driver floors it, below)
    want = c_on < c_off or c_off == INF
    if t_coolant_c < pc.t_warmup_c:
        want = True  # a cold engine stays on (the rule base's warm-up rule, ADVISOR's Prius)
    if engine_on and not want and t_in_state_s < pc.engine_min_on_s and s.f_req_n >= 0.0:
        want = True
    if not engine_on and want and t_in_state_s < pc.engine_min_off_s and c_off < INF:
        want = False
    if lim.lo > lim.hi:
        want = False
    if not want:
        return EcmsChoice(engine_on=False, p_e_target_w=0.0, w_pin_rad_s=0.0)
    if c_on == INF:
        # nothing on the grid meets the demand: the driver floors it (the top of the window at full power)
        return EcmsChoice(engine_on=True, p_e_target_w=lim.p_e_max, w_pin_rad_s=0.0)
    return EcmsChoice(engine_on=True, p_e_target_w=p_on, w_pin_rad_s=w_on)
