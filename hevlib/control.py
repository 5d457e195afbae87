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

from numba import njit


@njit(cache=True, inline="always")
def above(x: float, value: float, width: float) -> float:
    """Membership of 'x above the threshold' (trapezoid edge; crisp when width == 0)."""
    if width <= 0.0:
        return 1.0 if x > value else 0.0
    f = (x - (value - 0.5 * width)) / width
    return 0.0 if f < 0.0 else (1.0 if f > 1.0 else f)


@njit(cache=True)
def rule_strengths(soc: float, grade: float, speed_kmh: float, torque_frac: float, th) -> tuple:
    """Firing strengths (r1..r7) of the rule base.

    ``th`` = (soc_low v, w, soc_high v, w, grade_low v, w, grade_high v, w, speed_high v, w,
    torque_low v, w, torque_high v, w) as a float array.
    """
    soc_gt_low = above(soc, th[0], th[1])
    soc_gt_high = above(soc, th[2], th[3])
    g_gt_low = above(grade, th[4], th[5])
    g_gt_high = above(grade, th[6], th[7])
    v_gt_high = above(speed_kmh, th[8], th[9])
    t_gt_low = above(torque_frac, th[10], th[11])
    t_gt_high = above(torque_frac, th[12], th[13])
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
def decide(soc: float, grade: float, speed_kmh: float, torque_frac: float, th, on_threshold: float,
           currently_on: bool) -> tuple:
    """(engine wanted ON, charge degree in [0, 1], boost degree in [0, 1]) from the fuzzy rules."""
    r1, r2, r3, r4, r5, r6, r7 = rule_strengths(soc, grade, speed_kmh, torque_frac, th)
    on = max(r1, r2, r5, r6, r7)
    off = max(r3, r4)
    if on + off < 1e-12:
        want = currently_on
    else:
        want = on / (on + off) > on_threshold
    return want, max(r1, r6), r5
