"""Power management: the study's rule base (SPEC section 4) as a fuzzy controller.

Each threshold is a trapezoid ``{value, width}``: the degree to which ``x`` is *above* it rises
linearly from 0 at ``value - width/2`` to 1 at ``value + width/2`` (width 0 = crisp threshold).
AND is ``min``, OR is ``max``. The five rules of the study:

| # | SOC | grade | speed | torque demand | engine | motor | generator |
|---|---|---|---|---|---|---|---|
| 1 | < low | > low | > high | < low or > high | ON | generate | ON |
| 2 | > low | < high | > high | between low and high | ON (decoupled, e-CVT) | ON | ON |
| 3 | between | < high | < high | any | OFF | ON | OFF |
| 4 | > high | < low | < high | < low | OFF | ON | ON |
| 5 | > high | > high | > high | > high | ON | ON (boost) | OFF |

The table leaves input regions uncovered (e.g. low SOC at low speed). Two coverage rules close it,
both in the study's spirit: 6 = SOC below low -> engine ON and charge (charge sustaining), and
7 = torque demand above high -> engine ON (assist). When no rule fires the current mode is kept.
Engine ON degree = max(r1, r2, r5, r6, r7), OFF degree = max(r3, r4); the engine is requested ON
when ON / (ON + OFF) exceeds ``engine_on_threshold``. The charge degree max(r1, r6) sets the extra
engine power used to charge; rule 5 (boost) asks for full engine power with no charging.
"""

from __future__ import annotations

from typing import NamedTuple

from numba import njit

from hevlib.sim.powertrain.engine import EngineArrays, line_power_for_torque, max_torque
from hevlib.sim.powertrain.hybrid import SplitDesign, SplitLimits
from hevlib.sim.powertrain.machines import MachineArrays, electric_power


@njit(cache=True, inline="always")
def above(x: float, value: float, width: float) -> float:
    """Membership of 'x above the threshold' (trapezoid edge; crisp when width == 0)."""
    if width <= 0.0:
        return 1.0 if x > value else 0.0
    f = (x - (value - 0.5 * width)) / width
    return 0.0 if f < 0.0 else (1.0 if f > 1.0 else f)


class Thresholds(NamedTuple):
    """The rule base's thresholds, each a value and the width of its trapezoid (the ``pms`` params of the same
    names, :func:`thresholds`)."""

    soc_low: float
    soc_low_width: float
    soc_high: float  # also the SOC above which the engine charges nothing (:func:`supervise`)
    soc_high_width: float
    grade_low: float  # rise over run
    grade_low_width: float
    grade_high: float
    grade_high_width: float
    speed_high_kmh: float
    speed_high_kmh_width: float
    torque_low: float  # share of the ring torque the driveline can give
    torque_low_width: float
    torque_high: float
    torque_high_width: float


@njit(cache=True)
def rule_strengths(soc: float, grade: float, speed_kmh: float, torque_frac: float, th: Thresholds) -> tuple:
    """Firing strengths (r1..r7) of the rule base with the thresholds ``th``."""
    soc_gt_low = above(soc, th.soc_low, th.soc_low_width)
    soc_gt_high = above(soc, th.soc_high, th.soc_high_width)
    g_gt_low = above(grade, th.grade_low, th.grade_low_width)
    g_gt_high = above(grade, th.grade_high, th.grade_high_width)
    v_gt_high = above(speed_kmh, th.speed_high_kmh, th.speed_high_kmh_width)
    t_gt_low = above(torque_frac, th.torque_low, th.torque_low_width)
    t_gt_high = above(torque_frac, th.torque_high, th.torque_high_width)
    soc_lt_low, soc_lt_high = 1.0 - soc_gt_low, 1.0 - soc_gt_high
    g_lt_low, g_lt_high = 1.0 - g_gt_low, 1.0 - g_gt_high
    v_lt_high = 1.0 - v_gt_high
    t_lt_low, t_lt_high = 1.0 - t_gt_low, 1.0 - t_gt_high
    r1 = min(soc_lt_low, g_gt_low, v_gt_high, max(t_lt_low, t_gt_high))
    r2 = min(soc_gt_low, g_lt_high, v_gt_high, min(t_gt_low, t_lt_high))
    r3 = min(min(soc_gt_low, soc_lt_high), g_lt_high, v_lt_high)
    r4 = min(soc_gt_high, g_lt_low, v_lt_high, t_lt_low)
    r5 = min(soc_gt_high, g_gt_high, v_gt_high, t_gt_high)
    r6 = soc_lt_low
    r7 = t_gt_high
    return r1, r2, r3, r4, r5, r6, r7


@njit(cache=True)
def decide(
    soc: float, grade: float, speed_kmh: float, torque_frac: float, th, on_threshold: float, currently_on: bool
) -> tuple:
    """(engine wanted ON, charge degree in [0, 1], boost degree in [0, 1]) from the fuzzy rules."""
    r1, r2, r3, r4, r5, r6, r7 = rule_strengths(soc, grade, speed_kmh, torque_frac, th)
    on = max(r1, r2, r5, r6, r7)
    off = max(r3, r4)
    if on + off < 1e-12:
        want = currently_on
    else:
        want = on / (on + off) > on_threshold
    return want, max(r1, r6), r5


class PmsConfig(NamedTuple):
    """Crisp settings of the supervisory controller (the fuzzy thresholds are :class:`Thresholds`; the SOC window
    is the pack's, ``SplitConfig.soc_min``, handed to :func:`supervise`)."""

    engine_on_threshold: float
    engine_min_on_s: float
    engine_min_off_s: float
    engine_min_power_w: float  # engine power floor while running
    charge_power_fraction: float  # charging power as a share of rated engine power at full charge degree
    soc_target: float
    t_warmup_c: float  # coolant below this: the engine stays on until warm (-inf: rule off)
    full_power_above_w: float  # road power at or above which a running engine is asked for full power (inf: rule off)
    ecms: bool  # the supervisory controller is ECMS (hevlib.sim.ecms), not the rule base (pms.strategy)
    ecms_s0: float  # its equivalence factor at the target SOC (hevlib.sim.ecms.equivalence_factor)
    ecms_soc_gain: float  # its SOC feedback, per unit of SOC below the target
    ecms_n_speed: int  # its engine-on candidates: speeds across the window ...
    ecms_n_torque: int  # ... by torques from zero to the most at each speed


class Observed(NamedTuple):
    """What the supervisory controller sees at the start of a step (:func:`supervise`)."""

    engine_on: bool
    t_in_state_s: float  # time since the engine last changed state
    soc: float
    grade: float  # road grade, rise over run
    v_kmh: float  # vehicle speed
    t_r_req_nm: float  # ring torque the driver asks for
    p_dis_w: float  # battery discharge power limit
    t_coolant_c: float


def thresholds(pms) -> Thresholds:
    """The rule base's :class:`Thresholds` from the ``pms`` params group (each key's ``value`` and ``width``)."""
    keys = [f for f in Thresholds._fields if not f.endswith("_width")]
    named = {key: float(getattr(pms, key).value) for key in keys}
    return Thresholds(**named, **{f"{key}_width": float(getattr(pms, key).width) for key in keys})


@njit(cache=True, inline="always")
def supervise(
    obs: Observed,
    lim: SplitLimits,
    th: Thresholds,
    pc: PmsConfig,
    soc_min: float,
    d: SplitDesign,
    E: EngineArrays,
    M: MachineArrays,
) -> tuple[bool, float]:
    """Engine ON/OFF and target engine power (W) for the next step, from what the controller sees (``obs``) and
    the driveline's limits at this step's speed (``lim``); ``soc_min``: the bottom of the SOC window.

    Order of authority: physics first (the engine cannot run when its speed window is empty; it must run
    whenever it can and the battery alone cannot carry the traction or the accessory load), then the
    fuzzy rule base and the coolant warm-up rule (a cold engine stays on), then the minimum on/off times. The
    engine is fuel-cut while braking once warm; an engine that is off while the ring turns fast enough to
    overspeed a stopped generator is spun by the gear set with its fuel cut
    (:func:`hevlib.sim.powertrain.hybrid.dispatch`), not fired.
    Target power: ring demand plus accessories plus a charging share (fuzzy charge degree or SOC
    below target), floored at ``engine_min_power_w``, capped by what the engine can give; boost, or road power at or
    above ``full_power_above_w`` (ADVISOR's Prius), = full power.
    """
    engine_on, t_in_state_s, soc, grade, v_kmh = obs.engine_on, obs.t_in_state_s, obs.soc, obs.grade, obs.v_kmh
    t_r_req, p_dis, t_coolant_c = obs.t_r_req_nm, obs.p_dis_w, obs.t_coolant_c
    w_r, t_m_cap = lim.w_r, lim.t_m_cap
    can_run = lim.lo <= lim.hi
    k = d.n_r / d.n_s
    t_r_eng_cap = d.planetary_efficiency * k / (1.0 + k) * max_torque(lim.hi, d.s_eng, E) if can_run else 0.0
    torque_frac = t_r_req / max(t_m_cap + t_r_eng_cap, 1e-9)
    want, charge_deg, boost_deg = decide(soc, grade, v_kmh, torque_frac, th, pc.engine_on_threshold, engine_on)
    ev_ok = True
    if t_r_req > 0.0:
        ev_ok = t_r_req <= t_m_cap and electric_power(t_r_req, w_r, d.s_mot, M) + d.p_acc_w <= p_dis
    elif t_r_req == 0.0:
        ev_ok = d.p_acc_w <= p_dis  # standing or coasting: can the battery carry the accessories?
    if not ev_ok:
        want = True
    if t_r_req < 0.0:
        want = False
    if t_coolant_c < pc.t_warmup_c:
        # ADVISOR's Prius (PTC_PRIUS_JPN cs_clt_tmp; its 'need engine on?' block): the engine may go off only
        # with the coolant at the warm-up temperature or above, so a cold engine stays on, braking included
        want = True
    if engine_on and not want and t_in_state_s < pc.engine_min_on_s and t_r_req >= 0.0:
        want = True
    if not engine_on and want and t_in_state_s < pc.engine_min_off_s and ev_ok:
        want = False
    if not can_run:
        want = False
    if not want:
        return False, 0.0
    p_max = lim.p_e_max
    if boost_deg > 0.5 or t_r_req * w_r >= pc.full_power_above_w:
        # boost (rule 5), or ADVISOR's 'max engine if pwr req>limit' (lib_controls.mdl, <vc> prius): from 25 kW
        # of road power the engine runs at the top of its window at full torque
        return True, p_max
    p_rated = d.s_eng * E.line_p[-1]
    soc_deficit = min(max((pc.soc_target - soc) / max(pc.soc_target - soc_min, 1e-9), 0.0), 1.0)
    p_charge = pc.charge_power_fraction * p_rated * max(charge_deg, soc_deficit) if soc < th.soc_high else 0.0
    p = max(t_r_req, 0.0) * w_r / d.planetary_efficiency + d.p_acc_w + p_charge
    if t_r_req > t_m_cap:
        # the motor alone lacks torque: the engine's ring share must cover the rest
        t_e_need = (t_r_req - t_m_cap) * (1.0 + k) / (k * d.planetary_efficiency)
        p = max(p, line_power_for_torque(t_e_need, d.s_eng, E))
    return True, min(max(p, pc.engine_min_power_w), p_max)
