"""Conventional driveline (numba): engine, dry clutch, manual 5-speed with final drive folded in, driven by
ADVISOR's conventional control (``PTC_CONV``, ADVISOR 2003 ``lib_controls.mdl`` ``<vc> conv``).

Gearbox losses follow ADVISOR's TX_VW regression (``P_loss = (a r + b) w_out + (c/r + d)|T_out| +
e P_out + f``, clipped at zero as ADVISOR clips its map), in either direction of power flow.

Control, rule by rule (block and line of ``lib_controls.mdl`` unless said otherwise):

* **Gear** (``gearbox control``, L3399): ADVISOR's load-based logic (``tx_speed_dep = 0``, PTC_CONV.m L134).
  The engine speed and load are those the step asks for in the gear held (``gb_spd_in_r``, L4158;
  ``est eng trq``, L4150, plus the accessory torque); load = torque / full-load torque, clipped to 0..1
  (L4657), 1 when the tyres limit (L3742). Upshift when the load is below the upshift curve, downshift when
  above the downshift curve (``<`` L5429, ``>`` L3989), both read with linear extrapolation beyond their ends
  (``sfun_gearbox.m``): no upshift below 1500 rpm, always a downshift below 800 rpm, none above 0.501 x the map's
  top speed. One gear per step, an upshift first (L3921, L3913, L3717); no downshift in the two steps after an
  upshift (``allow downshift?``, L3763). Launch in first gear. ``gb_shift_delay = 0``: shifts take no time.
  ADVISOR estimates the torque from the previous step's gearbox efficiency; here it is exact.
  The speed-based table (``tx_spd_dep_upshift``) is the other logic the file offers (``-S
  baseline.conventional.shift_logic=speed``).
* **Clutch** (``clutch control``, L1565): open when the torque asked of it is not positive (<= 1e-3 N m,
  L1668) and the gearbox input turns below idle (L1749), or whenever no torque is asked if
  ``vc_clutch_bool = 1`` (PTC_CONV.m L51 sets 0: the clutch stays closed while the car slows, so the wheels
  turn the engine); slipping at the launch speed when torque is asked below the launch speed and the clutch
  was not closed the step before (L1797); closed otherwise. Here a closed clutch also slips when the input
  falls below idle (ADVISOR would drag the engine under its idle speed).
* **Engine** (``lib_fuel_converter.mdl`` ``engine torque``, L15180): its torque is what the clutch asks plus
  the accessory torque, within its full-load torque and not below its closed-throttle torque
  (``max(min(T, T_max), T_ct)``); no fuel cut: fuel is read from the map at ``max(T, 0)`` (FC_SI63_emis:
  ``T_ct = 0`` at every speed, so a closed throttle burns the map's zero-torque column). While the clutch is
  open the engine idles carrying the accessories (``vc_idle_bool = 1``), or stops with them off if
  ``vc_idle_bool = 0``.
* **Braking**: the driveline is asked the wheel file's share of a braking request (``braking strategy``,
  L103013); friction brakes take what the driveline does not (L103752), so closed-throttle drag, accessory
  and gearbox losses all brake the car.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from hevlib.sim.powertrain.engine import EngineArrays, drag_torque, max_torque

#: Clutch states.
OPEN, SLIP, CLOSED = 0, 1, 2
#: Torque asked of the clutch at or below which it counts as none, N m (``clutch control``, L1668).
NO_TORQUE_NM = 1e-3


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
    idle_allowed: bool  # vc_idle_bool: idle (else stop) while the clutch is open
    clutch_opens: bool  # vc_clutch_bool: open whenever no torque is asked


class ShiftLogic(NamedTuple):
    """ADVISOR's two shift logics: load-based curves (engine speed -> load) or the speed table."""

    load_based: bool
    up_w: np.ndarray  # upshift curve: engine speed, rad/s ...
    up_load: np.ndarray  # ... and the load below which to upshift
    dn_w: np.ndarray  # downshift curve: engine speed, rad/s ...
    dn_load: np.ndarray  # ... and the load above which to downshift
    upshift_kmh: np.ndarray  # speed table: vehicle speeds of the upshifts, km/h


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
def input_torque(v: float, f: float, ratio: float, d: ConvDesign) -> float:
    """Gearbox input torque that gives wheel force ``f`` (either sign) at speed ``v`` in the gear of ``ratio``."""
    w_out = v / d.r
    w_in = w_out * ratio
    t_out = f * d.r
    if w_in <= 0.0:
        return t_out / ratio
    return (t_out * w_out + gearbox_loss(w_out, t_out, ratio, d)) / w_in


@njit(cache=True, inline="always")
def output_torque(t_in: float, w_out: float, ratio: float, d: ConvDesign) -> float:
    """Gearbox output torque for input torque ``t_in`` (either sign): the inverse of :func:`input_torque`,
    ``t_in w_in = t_out w_out + max(k_0 + k_t |t_out|, 0)``."""
    if w_out <= 0.0:
        return t_in * ratio
    p_in = t_in * w_out * ratio
    k_t = (d.gb_c / ratio + d.gb_d) + d.gb_e * w_out
    k_0 = (d.gb_a * ratio + d.gb_b) * w_out + d.gb_f
    sign = 1.0 if p_in - k_0 >= 0.0 else -1.0  # the output's sign when the loss is not clipped
    den = w_out + sign * k_t
    t_out = (p_in - k_0) / den if den > 0.0 else p_in / w_out
    if k_0 + k_t * abs(t_out) < 0.0:  # the regression clipped at zero: no loss
        t_out = p_in / w_out
    return t_out


@njit(cache=True, inline="always")
def clutch_closed(v: float, ratio: float, d: ConvDesign) -> bool:
    """The clutch is closed (no slip, the engine turns with the wheels) in the gear of ``ratio`` at speed
    ``v`` under full throttle: the engine speed it implies lies between the launch speed and the top speed."""
    return d.w_launch <= v / d.r * ratio <= d.w_e_max


@njit(cache=True, inline="always")
def open_state(d: ConvDesign) -> ConvState:
    """Clutch open: the engine idles carrying the accessories, or stands still (``idle_allowed`` false)."""
    if not d.idle_allowed:
        return ConvState(
            f_del=0.0, engaged=False, w_e=0.0, t_e=0.0, w_in=0.0, t_in=0.0, loss_gb_w=0.0, loss_clutch_w=0.0
        )
    return ConvState(
        f_del=0.0,
        engaged=False,
        w_e=d.w_idle,
        t_e=d.p_acc_w / d.w_idle,
        w_in=0.0,
        t_in=0.0,
        loss_gb_w=0.0,
        loss_clutch_w=0.0,
    )


@njit(cache=True)
def dispatch(v: float, f: float, ratio: float, slip: bool, d: ConvDesign, E: EngineArrays) -> ConvState:
    """Operating point with the clutch closed (or slipping at the launch speed, ``slip``) in the gear of overall
    ratio ``ratio`` at mean speed ``v``, asked for wheel force ``f`` (either sign): the engine gives what the
    clutch asks plus the accessories, within its full-load and closed-throttle torques."""
    w_out = v / d.r
    w_in = w_out * ratio
    if w_in > d.w_e_max:
        return open_state(d)  # gear not usable at this speed
    w_e = d.w_launch if slip else w_in
    t_in = input_torque(v, f, ratio, d)
    t_out = f * d.r
    loss = gearbox_loss(w_out, t_out, ratio, d)
    t_acc = d.p_acc_w / w_e
    t_e = t_in + t_acc
    t_cap = max_torque(w_e, d.s_eng, E)
    t_ct = drag_torque(w_e, d.s_eng, E)
    if t_e > t_cap or t_e < t_ct:
        t_e = t_cap if t_e > t_cap else t_ct
        t_in = max(t_e - t_acc, 0.0) if slip else t_e - t_acc
        t_out = output_torque(t_in, w_out, ratio, d)
        if slip or t_in > 0.0:
            t_out = max(t_out, 0.0)
        loss = t_in * w_in - t_out * w_out
    slip_w = (w_e - w_in) * t_in if slip else 0.0
    return ConvState(
        f_del=t_out / d.r, engaged=True, w_e=w_e, t_e=t_e, w_in=w_in, t_in=t_in, loss_gb_w=loss, loss_clutch_w=slip_w
    )


@njit(cache=True, inline="always")
def curve(w: float, xs: np.ndarray, ys: np.ndarray) -> float:
    """Shift curve at engine speed ``w``: linear between breakpoints and extrapolated linearly beyond the
    first and last segments (ADVISOR's ``sfun_gearbox.m``)."""
    n = xs.shape[0]
    i = 0
    while i < n - 2 and w >= xs[i + 1]:
        i += 1
    return ys[i] + (ys[i + 1] - ys[i]) * (w - xs[i]) / (xs[i + 1] - xs[i])


@njit(cache=True, inline="always")
def engine_load(v: float, f: float, ratio: float, d: ConvDesign, E: EngineArrays) -> float:
    """Load (torque / full-load torque, 0..1) the step asks of the engine in the gear of ``ratio``: the gearbox
    input torque for wheel force ``f`` plus the accessory torque (at idle speed or above)."""
    w = v / d.r * ratio
    t = input_torque(v, f, ratio, d) + d.p_acc_w / max(w, d.w_idle)
    return min(max(t / max_torque(w, d.s_eng, E), 0.0), 1.0)


@njit(cache=True, inline="always")
def next_gear(g: int, w: float, load: float, allow_down: bool, S: ShiftLogic, n_gears: int) -> int:
    """ADVISOR's load-based decision for gear index ``g`` at engine speed ``w`` (in gear ``g``) and ``load``."""
    if load < curve(w, S.up_w, S.up_load):
        return min(g + 1, n_gears - 1)
    if allow_down and load > curve(w, S.dn_w, S.dn_load):
        return max(g - 1, 0)
    return g


@njit(cache=True, inline="always")
def clutch_state(t_in: float, w_in: float, before: int, d: ConvDesign) -> int:
    """:data:`OPEN`, :data:`SLIP` or :data:`CLOSED` for gearbox input torque ``t_in`` asked at input speed ``w_in``,
    the clutch having been ``before`` the step before."""
    if t_in <= NO_TORQUE_NM:
        if d.clutch_opens or w_in < d.w_idle:
            return OPEN
        return CLOSED
    if w_in < d.w_idle or (w_in < d.w_launch and before != CLOSED):
        return SLIP
    return CLOSED


@njit(cache=True)
def scheduled_gear(v_kmh: float, upshift_kmh: np.ndarray) -> int:
    """Speed-based schedule (ADVISOR PTC_CONV ``tx_spd_dep_upshift``): gear index 0.. from the upshift speeds."""
    g = 0
    for s in upshift_kmh:
        if v_kmh >= s:
            g += 1
    return g
