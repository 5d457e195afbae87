"""The charge-sustaining fuel bound of a power-split design on a cycle (issue 56): the least fuel any supervisory
controller could burn on the same hardware, by deterministic dynamic programming over the battery's state of
charge (Bellman; the scheme of Sundstroem and Guzzella's ``dpm``: a state grid, the cost-to-go interpolated
linearly between its points, a forward pass from the exact initial state); and the conventional car's over its one
choice, the gear (:func:`gear_bound`). :mod:`hevlib.controller_gap` sets both beside the controllers the simulator
runs.

**What is optimised.** Each step of the cycle, the engine's state (off, or fuelled at any speed and torque the
gear set, the generator and the engine's own limits allow) and so the split of the wheel's demand between engine
and battery; the driver is taken to follow the trace exactly (the demand is the cycle's, as the simulator asks it
of a design that meets the trace). Everything else is the simulator's, read through its own functions:
:func:`hevlib.sim.powertrain.hybrid.dispatch` gives the operating point of every candidate (motor torque, the
generator's reaction, electrical powers, accessories, the braking share the driveline may take, the spun engine
of a stopped carrier), the pack's open-circuit voltage, resistances and power limits are
:func:`hevlib.sim.drive.pack_state` and :func:`~hevlib.sim.drive.pack_power_limits`, its charge moves as in the
drive loop (coulombic efficiency on charge), fuel comes from the engine's hot map
(:func:`hevlib.sim.powertrain.engine.rates`), and an engine start costs the battery what the simulator charges
(the generator spinning the carrier from its speed to firing speed against the crank torque at its full torque,
its losses on top: :func:`hevlib.sim.powertrain.hybrid.spin_up`; the simulator's spin-up may take longer where the
pack cannot spare that torque's draw, at more crank work, and it spreads the start over its duration).

**What it leaves out**, each a relaxation (the bound can only be lower for it): the engine's thermal state (the
hot map throughout: a cold start's surplus fuel is not in the bound; :mod:`hevlib.controller_gap` compares it with
the rule base's fuel on the hot map, the simulator's own cold surplus taken out, and reports that surplus), the
tailpipe (no
emission constraint: the bound is fuel only), a start's duration (its energy is booked within its step; the
simulator spreads it over the spin-up), the rule base's minimum on and off times. A running carrier moves freely
within its window in both (its inertia left out).

**End condition.** Charge sustaining: the final SOC at least the initial one (a steep linear penalty below it on
the last step's grid); the forward pass's small surplus is booked like the simulator's (net battery energy, the
J1711 SOC correction of :func:`hevlib.sim.simulator.responses` on the bound's own run).

**ECMS** (:func:`ecms_fuel`): a causal controller on the same candidates, limits, starts and booking, so the two
compare on one yardstick: each step the control of least fuel plus the battery's energy (its charge at the
open-circuit voltage) at the equivalence factor ``s = s0 + gain (soc_target - soc)`` (adaptive ECMS with SOC
feedback, Onori, Serrao and Rizzoni 2016), ``s0`` the reciprocal of the engine's best efficiency on its map
(:func:`hevlib.sim.ecms.equivalence_factor`), the target the control file's; in the dynamic programme's forward pass
(:func:`_forward`) with a cost-to-go linear in SOC in place of the programme's. It knows nothing of the trace ahead:
what it burns above the bound is what foresight is worth (e.g. an engine kept running through a short stop instead
of a costly restart), what the rule base burns above ECMS what its rules leave.

**Controls.** On each step the engine-on candidates are a grid of ``n_speed`` speeds across the engine's window
at that ring speed and ``n_torque`` torques from zero to the most the engine and the generator can take at each
speed; of them only those on the step's fuel-against-battery-power front are kept (a candidate that burns more and
draws more from the battery than another is never optimal, whatever the SOC).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pandas as pd
from numba import njit

from hevlib.cycles import Cycle, KernelCycle
from hevlib.sim.drive import (
    R_MASS,
    R_N_BAT,
    R_SOC0,
    ConventionalRec,
    HybridRec,
    adhesion_limit,
    chassis,
    conventional_equivalent_mass_kg,
    driveline_brake_share,
    pack_power_limits,
    pack_state,
    split_design,
    split_equivalent_mass_kg,
    split_speed_limit,
)
from hevlib.sim.powertrain import conventional as conv
from hevlib.sim.powertrain import hybrid as split
from hevlib.sim.powertrain import layout as L
from hevlib.sim.powertrain.battery import current_for_power
from hevlib.sim.powertrain.engine import max_torque, rates
from hevlib.sim.powertrain.machines import torque_limit
from hevlib.sim.powertrain.planetary import sun_speed
from hevlib.sim.powertrain.vehicle import road_force

INF = np.inf
#: Penalty on a final SOC below the initial one, g of fuel per unit of SOC: some thousand times what the engine
#: burns to put it back, so the forward pass never ends below it by more than the grid's interpolation allows.
SHORTFALL_G_PER_SOC = 1e7
#: A candidate's delivered force may fall short of the request by this much (the simulator's ``_falls_short``).
SHORT_TOL = 1e-6


class Infeasible(ValueError):
    """No control drives the vehicle over step ``step`` of the cycle from the state the forward pass reached."""

    def __init__(self, step: int):
        super().__init__(f"no admissible control on step {step} (t = {step} .. {step + 1} steps)")
        self.step = step


class BoundGrid(NamedTuple):
    """The resolution of the bound: the SOC grid's step and the engine-on candidates per step."""

    soc_step: float
    n_speed: int
    n_torque: int

    @classmethod
    def from_params(cls, bound) -> BoundGrid:
        """The grid of the ``bound`` params group."""
        return cls(soc_step=bound.soc_step, n_speed=bound.n_speed, n_torque=bound.n_torque)


class StepControls(NamedTuple):
    """Every step's admissible controls (``n_steps = len(cycle) - 1``; ``K`` the most engine-on candidates kept
    on any step): the engine off (one per step) and the engine-on candidates on the step's front."""

    key_off: np.ndarray  # (n_steps,) bool: a prescribed key-off step (nothing runs, nothing is spent)
    off_ok: np.ndarray  # (n_steps,) bool: the engine off meets the step's demand
    p_off_w: np.ndarray  # (n_steps,) battery power with the engine off, W (+ discharge)
    shed_off_w: np.ndarray  # (n_steps,) of its charging, what friction braking can take over (braking steps), W
    w_off: np.ndarray  # (n_steps,) the carrier's speed with the engine off (spun above a ring speed), rad/s
    p_start_w: np.ndarray  # (n_steps,) battery power of a start on this step from the last step's carrier, W
    n_on: np.ndarray  # (n_steps,) engine-on candidates kept
    fuel_g_s: np.ndarray  # (n_steps, K) their fuel rate on the hot map, g/s
    p_on_w: np.ndarray  # (n_steps, K) their battery power, W
    shed_on_w: np.ndarray  # (n_steps, K) of their charging, what friction braking can take over, W
    w_e: np.ndarray  # (n_steps, K) engine speed, rad/s
    t_e: np.ndarray  # (n_steps, K) engine torque, N m
    p_gen_mech_w: np.ndarray  # (n_steps, K) the generator's mechanical input (>= 0), W
    p_gen_elec_w: np.ndarray  # (n_steps, K) its electrical output (>= 0), W
    v_mean_mps: np.ndarray  # (n_steps,) the step's mean speed


@njit(cache=True)
def _front(fuel: np.ndarray, p_batt: np.ndarray, n: int) -> np.ndarray:
    """Indices of the first ``n`` candidates that no other beats in both fuel and battery power, in order of
    rising battery power (and so falling fuel)."""
    order = np.argsort(p_batt[:n], kind="mergesort")
    keep = np.empty(n, dtype=np.int64)
    m = 0
    best = INF
    for idx in order:
        if fuel[idx] < best:
            keep[m] = idx
            m += 1
            best = fuel[idx]
    return keep[:m]


@njit(cache=True)
def step_controls(veh: HybridRec, i: int, cyc: KernelCycle, n_speed: int, n_torque: int, k_max: int):
    """The admissible controls of design ``i`` of ``veh`` on every step of ``cyc`` (a :class:`StepControls`), each
    evaluated by the simulator's own dispatch with the battery unconstrained (the pack's
    limits depend on the SOC: the DP checks them per state)."""
    row, c, sc, E, M, G = veh.rows[i], veh.c, veh.sc, veh.E, veh.M, veh.G
    v_ref, sin_g, cos_g, key_on = cyc.v_ref, cyc.sin_g, cyc.cos_g, cyc.key_on
    d = split_design(row, c, sc)
    ch = chassis(row[R_MASS], split_equivalent_mass_kg(row, c, sc), c)
    dt = c.dt
    k = d.n_r / d.n_s
    v_lim = split_speed_limit(d)
    cdyn = split.carrier_dynamics(d, G, sc.j_start, sc.j_gen, sc.t_crank, sc.w_fire)
    n = v_ref.shape[0] - 1
    key_off = np.zeros(n, dtype=np.bool_)
    off_ok = np.zeros(n, dtype=np.bool_)
    p_off = np.zeros(n)
    shed_off = np.zeros(n)
    w_off = np.zeros(n)
    p_start = np.zeros(n)
    n_on = np.zeros(n, dtype=np.int64)
    fuel_k = np.full((n, k_max), INF)
    p_on_k = np.zeros((n, k_max))
    shed_k = np.zeros((n, k_max))
    w_k = np.zeros((n, k_max))
    t_k = np.zeros((n, k_max))
    gm_k = np.zeros((n, k_max))
    ge_k = np.zeros((n, k_max))
    v_mean = np.zeros(n)
    m = n_speed * n_torque
    fuel_c = np.empty(m)
    p_c = np.empty(m)
    shed_c = np.empty(m)
    w_c = np.empty(m)
    t_c = np.empty(m)
    gm_c = np.empty(m)
    ge_c = np.empty(m)
    for t in range(n):
        v0 = v_ref[t]
        v_tgt = min(v_ref[t + 1], v_lim)
        sn, cs = sin_g[t], cos_g[t]
        stationary = v0 <= 1e-9 and v_tgt <= 1e-9
        if stationary and not key_on[t]:
            key_off[t] = True
            continue
        v_req = 0.0 if stationary else 0.5 * (v0 + v_tgt)
        v_mean[t] = v_req
        f_aero, f_roll, f_grade, f_axle = road_force(v_req, sn, cs, ch)
        f_road = f_aero + f_roll + f_grade + f_axle
        f_req = 0.0 if stationary else ch.m_eff * (v_tgt - v0) / dt + f_road
        f_adh = adhesion_limit(sn, cs, f_road, ch)
        f_cmd = min(f_req, f_adh) if f_req >= 0.0 else max(f_req, -f_adh)
        regen = driveline_brake_share(v_req, c)
        lim = split.limits(v_req, d, E, M, G)
        short = f_req - SHORT_TOL * max(1.0, f_req)
        # ---- the engine off (spun with its fuel cut where the ring is too fast for a stopped carrier)
        off = split.SplitCommand(
            f_req_n=f_cmd, engine_on=False, p_e_target_w=0.0, p_dis_w=INF, p_chg_w=INF, regen_share=regen
        )
        st = split.dispatch(lim, off, d, E, M, G)
        off_ok[t] = not (f_req > 0.0 and st.f_del < short)
        p_off[t] = st.p_batt
        # braking: the regenerative share the pack cannot take goes to the friction brakes (the dispatch's rule)
        shed_off[t] = max(-st.p_m_e, 0.0) if f_req < 0.0 else 0.0
        w_off[t] = st.w_e
        # ---- a start on this step, from the carrier's speed at the end of the last (as the drive loop books it)
        if sc.engine_dynamics:
            w0 = w_off[t - 1] if t > 0 else 0.0
            # at the generator's full torque, whole (the least a start costs: a spin-up the pack cannot give full
            # torque costs more crank work, so the bound stays below the simulator)
            su = split.spin_up(w0, lim.w_r, INF, cdyn, d, G, INF)
            p_start[t] = INF if su.t_left_s == INF else su.e_elec_j / dt
        # ---- the engine on: a grid of speeds across its window, torques up to what engine and generator take
        if lim.lo > lim.hi:
            continue
        cnt = 0
        for a in range(n_speed):
            w_e = lim.lo if n_speed == 1 else lim.lo + (lim.hi - lim.lo) * a / (n_speed - 1)
            w_g = sun_speed(w_e, lim.w_r, d.n_r, d.n_s)
            t_cap = min(max_torque(w_e, d.s_eng, E), (1.0 + k) * torque_limit(w_g, d.s_gen, G))
            pinned = split.SplitLimits(w_r=lim.w_r, t_m_cap=lim.t_m_cap, lo=w_e, hi=w_e, p_e_max=w_e * t_cap)
            for b in range(n_torque):
                t_e = t_cap * b / (n_torque - 1) if n_torque > 1 else t_cap
                cmd = split.SplitCommand(
                    f_req_n=f_cmd, engine_on=True, p_e_target_w=t_e * w_e, p_dis_w=INF, p_chg_w=INF, regen_share=regen
                )
                st = split.dispatch(pinned, cmd, d, E, M, G)
                if not st.running or (f_req > 0.0 and st.f_del < short):
                    continue
                fuel_c[cnt] = rates(st.w_e, max(st.t_e, 0.0), d.s_eng, E)[0]
                p_c[cnt] = st.p_batt
                shed_c[cnt] = max(-st.p_m_e, 0.0) if f_req < 0.0 else 0.0
                w_c[cnt] = st.w_e
                t_c[cnt] = st.t_e
                gm_c[cnt] = max(-st.t_g * st.w_g, 0.0)
                ge_c[cnt] = max(-st.p_g_e, 0.0)
                cnt += 1
        keep = _front(fuel_c, p_c, cnt)
        if keep.shape[0] > k_max:  # thin a front longer than the table: every j-th, both ends kept
            sel = np.unique(np.round(np.linspace(0, keep.shape[0] - 1, k_max)).astype(np.int64))
            keep = keep[sel]
        n_on[t] = keep.shape[0]
        for j in range(keep.shape[0]):
            q = keep[j]
            fuel_k[t, j], p_on_k[t, j], w_k[t, j], t_k[t, j] = fuel_c[q], p_c[q], w_c[q], t_c[q]
            shed_k[t, j] = shed_c[q]
            gm_k[t, j], ge_k[t, j] = gm_c[q], ge_c[q]
    return StepControls(
        key_off=key_off,
        off_ok=off_ok,
        p_off_w=p_off,
        shed_off_w=shed_off,
        w_off=w_off,
        p_start_w=p_start,
        n_on=n_on,
        fuel_g_s=fuel_k,
        p_on_w=p_on_k,
        shed_on_w=shed_k,
        w_e=w_k,
        t_e=t_k,
        p_gen_mech_w=gm_k,
        p_gen_elec_w=ge_k,
        v_mean_mps=v_mean,
    )


@njit(cache=True, inline="always")
def _next_soc(soc: float, p_w: float, ocv: float, r_d: float, r_c: float, eta_c: float, dt: float, cap: float):
    """The SOC after a step at terminal power ``p_w`` (the drive loop's update)."""
    i_a = current_for_power(p_w, ocv, r_d, r_c)
    q = i_a * dt if i_a >= 0.0 else eta_c * i_a * dt
    return soc - q / cap, q


@njit(cache=True, inline="always")
def _cost_to_go(J: np.ndarray, soc: float, soc_lo: float, step: float) -> float:
    """``J`` (on the SOC grid from ``soc_lo`` by ``step``) at ``soc``, linear between grid points; infinite off the
    grid or next to an infeasible point."""
    n = J.shape[0]
    x = (soc - soc_lo) / step
    if x < -1e-9 or x > n - 1 + 1e-9:
        return INF
    x = min(max(x, 0.0), n - 1.0)
    j = min(int(x), n - 2)
    f = x - j
    a, b = J[j], J[j + 1]
    if f <= 0.0:
        return a
    if f >= 1.0:
        return b
    if a == INF or b == INF:
        return INF
    return a + f * (b - a)


@njit(cache=True, inline="always")
def _admitted(p: float, shed: float, p_dis: float, p_chg: float) -> float:
    """The battery power a control of battery power ``p`` ends at within the pack's limits: ``p`` itself; or, if it
    charges faster than the pack takes and friction braking can take over up to ``shed`` of it, the charge limit;
    NaN if neither."""
    lo = -p_chg * (1.0 + 1e-9) - 1e-6
    if p > p_dis * (1.0 + 1e-9) + 1e-6:
        return np.nan
    if p >= lo:
        return p
    return -p_chg if p + shed >= lo else np.nan


@njit(cache=True)
def _best(
    J1: np.ndarray, soc: float, e_prev: int, t: int, ctl: StepControls, pack, soc_lo: float, step: float, dt: float, cap
):
    """(cost, engine on, candidate, next SOC, charge moved) of the best control of step ``t`` from ``soc`` with the
    engine's state ``e_prev`` on the step before; ``J1`` the cost-to-go of step ``t + 1`` (off, on)."""
    key_off, off_ok, p_off, shed_off, p_start = ctl.key_off, ctl.off_ok, ctl.p_off_w, ctl.shed_off_w, ctl.p_start_w
    n_on, fuel, p_on, shed_on = ctl.n_on, ctl.fuel_g_s, ctl.p_on_w, ctl.shed_on_w
    ocv, r_d, r_c, p_dis, p_chg, eta_c = pack
    if key_off[t]:
        return _cost_to_go(J1[0], soc, soc_lo, step), 0, -1, soc, 0.0, 0.0
    best, e_best, j_best, s_best, q_best, p_best = INF, 0, -1, soc, 0.0, 0.0
    p = _admitted(p_off[t], shed_off[t], p_dis, p_chg) if off_ok[t] else np.nan
    if p == p:
        s1, q = _next_soc(soc, p, ocv, r_d, r_c, eta_c, dt, cap)
        best, s_best, q_best, p_best = _cost_to_go(J1[0], s1, soc_lo, step), s1, q, p
    p_extra = p_start[t] if e_prev == 0 else 0.0
    if p_extra < INF:
        for j in range(n_on[t]):
            p = _admitted(p_on[t, j] + p_extra, shed_on[t, j], p_dis, p_chg)
            if p != p:
                continue
            s1, q = _next_soc(soc, p, ocv, r_d, r_c, eta_c, dt, cap)
            cost = fuel[t, j] * dt + _cost_to_go(J1[1], s1, soc_lo, step)
            if cost < best:
                best, e_best, j_best, s_best, q_best, p_best = cost, 1, j, s1, q, p
    return best, e_best, j_best, s_best, q_best, p_best


class Ecms(NamedTuple):
    """An equivalent-consumption minimisation (ECMS) controller's settings (:func:`ecms_fuel`): each step it picks the
    control of least ``fuel + s (battery energy) / LHV``, the equivalence factor ``s = s0 + gain (soc_target - soc)``
    (the adaptive ECMS of Onori, Serrao and Rizzoni, *Hybrid Electric Vehicles: Energy Management Strategies*,
    Springer 2016, ch. 5: SOC feedback that holds charge)."""

    s0: float  # fuel energy per unit of battery (chemical) energy, at the target SOC
    gain: float  # per unit of SOC below the target
    soc_target: float


#: The dynamic programme's forward pass (no ECMS).
NO_ECMS = Ecms(s0=0.0, gain=0.0, soc_target=0.0)


@njit(cache=True)
def _forward(veh: HybridRec, i: int, ctl: StepControls, soc0: float, J, soc_lo, step, ecms: Ecms, o, record):
    """The run from ``soc0`` with the engine off (the drive's start), each step's control the least of
    :func:`_best`'s cost: fuel plus the cost-to-go ``J`` (the dynamic programme), or with ``ecms.s0 > 0`` fuel plus
    the battery energy at the equivalence factor of the step's SOC (ECMS: a cost-to-go linear in SOC, the same
    candidates, limits and booking). Fills ``o`` (an ``O_*`` row) and ``record`` (:data:`TRACE_COLUMNS`); the
    SOC end is NaN where no admissible control drives a step (``O_N_STEPS`` that step)."""
    row, c, sc, B = veh.rows[i], veh.c, veh.sc, veh.B
    n_bat = row[R_N_BAT]
    dt, cap, eta_c = c.dt, sc.cap_as, sc.eta_c
    key_off, fuel, w_e, t_e = ctl.key_off, ctl.fuel_g_s, ctl.w_e, ctl.t_e
    p_gm, p_ge, v_mean = ctl.p_gen_mech_w, ctl.p_gen_elec_w, ctl.v_mean_mps
    n = key_off.shape[0]
    lhv = c.lhv_j_per_g
    use_ecms = ecms.s0 > 0.0
    n_soc = int(round((sc.soc_max - soc_lo) / step)) + 1
    lin = np.empty((2, n_soc))
    soc, e_prev = soc0, 0
    record[0, 0] = soc
    for t in range(n):
        oc, rd, rc = pack_state(soc, n_bat, B)
        pd_, pc_ = pack_power_limits(oc, rd, rc, soc, sc.soc_min, n_bat, sc, dt)
        if use_ecms:
            # fuel (g) a unit of SOC is worth at this step's equivalence factor: its charge at the open-circuit
            # voltage, over the fuel's heating value; the cost-to-go linear in SOC (grid and window as the DP's)
            s_eq = max(ecms.s0 + ecms.gain * (ecms.soc_target - soc), 0.0)
            g_per_soc = s_eq * oc * cap / lhv
            for g in range(n_soc):
                lin[0, g] = lin[1, g] = g_per_soc * (sc.soc_max - (soc_lo + step * g))
            J1 = lin
        else:
            J1 = J[t + 1]
        cost, e, j, s1, q, p_b = _best(J1, soc, e_prev, t, ctl, (oc, rd, rc, pd_, pc_, eta_c), soc_lo, step, dt, cap)
        if cost == INF:
            o[L.O_SOC_END] = np.nan
            o[L.O_N_STEPS] = t  # the step no admissible control drives
            return o
        if e == 1:
            f = fuel[t, j]
            o[L.O_FUEL_G] += f * dt
            o[L.O_E_FUEL] += f * lhv * dt
            o[L.O_E_ENG_SHAFT] += w_e[t, j] * t_e[t, j] * dt
            o[L.O_E_GEN_MECH_IN] += p_gm[t, j] * dt
            o[L.O_E_GEN_ELEC_OUT] += p_ge[t, j] * dt
            o[L.O_ENG_ON_STEPS] += 1.0
            if e_prev == 0:
                o[L.O_N_STARTS] += 1.0
            record[t + 1, 2], record[t + 1, 3], record[t + 1, 5] = w_e[t, j], t_e[t, j], f
        else:
            record[t + 1, 2], record[t + 1, 3], record[t + 1, 5] = 0.0, 0.0, 0.0
        o[L.O_E_BATT] += oc * q
        o[L.O_DIST_M] += v_mean[t] * dt
        soc, e_prev = s1, e
        record[t + 1, 0], record[t + 1, 1], record[t + 1, 4] = soc, e, p_b
    o[L.O_DIST_REF_M] = o[L.O_DIST_M]
    o[L.O_SOC_END] = soc
    o[L.O_N_STEPS] = n
    return o


@njit(cache=True)
def bound_kernel(veh: HybridRec, i: int, ctl: StepControls, soc0: float, soc_step: float, record: np.ndarray):
    """Backward recursion of the cost-to-go on the SOC grid, then the forward pass from ``soc0`` with the engine off
    (the drive's start). Fills and returns an ``O_*`` row of the bound's run (what
    :func:`hevlib.sim.simulator.responses` reads: fuel, distance, energies, starts) and ``record`` (n_steps + 1,
    :data:`TRACE_COLUMNS`): SOC, engine on, engine speed, torque, battery power and fuel rate over each step. The
    row's SOC end is NaN where the forward pass
    found no admissible control (the design cannot drive the cycle on this grid)."""
    row, c, sc, B = veh.rows[i], veh.c, veh.sc, veh.B
    n_bat = row[R_N_BAT]
    dt, cap, eta_c = c.dt, sc.cap_as, sc.eta_c
    n = ctl.key_off.shape[0]
    soc_lo = sc.soc_min
    n_soc = int(round((sc.soc_max - sc.soc_min) / soc_step)) + 1
    step = (sc.soc_max - sc.soc_min) / (n_soc - 1)
    # the pack at every grid point
    ocv = np.empty(n_soc)
    r_d = np.empty(n_soc)
    r_c = np.empty(n_soc)
    p_dis = np.empty(n_soc)
    p_chg = np.empty(n_soc)
    for s in range(n_soc):
        soc = soc_lo + step * s
        ocv[s], r_d[s], r_c[s] = pack_state(soc, n_bat, B)
        p_dis[s], p_chg[s] = pack_power_limits(ocv[s], r_d[s], r_c[s], soc, sc.soc_min, n_bat, sc, dt)
    J = np.empty((n + 1, 2, n_soc))
    for s in range(n_soc):
        short = soc0 - (soc_lo + step * s)
        J[n, 0, s] = J[n, 1, s] = SHORTFALL_G_PER_SOC * short if short > 0.0 else 0.0
    o = np.zeros(L.N_O)
    for t in range(n - 1, -1, -1):
        alive = False
        for s in range(n_soc):
            pack = (ocv[s], r_d[s], r_c[s], p_dis[s], p_chg[s], eta_c)
            soc = soc_lo + step * s
            for e in range(2):
                J[t, e, s] = _best(J[t + 1], soc, e, t, ctl, pack, soc_lo, step, dt, cap)[0]
                alive = alive or J[t, e, s] < INF
        if not alive:
            # no state of the grid drives the cycle on from this step: neither can the forward pass
            o[L.O_SOC_END] = np.nan
            o[L.O_N_STEPS] = t
            return o
    return _forward(veh, i, ctl, soc0, J, soc_lo, step, NO_ECMS, o, record)


@njit(cache=True)
def gear_bound_kernel(veh: ConventionalRec, i: int, cyc: KernelCycle) -> np.ndarray:
    """The conventional car's bound over its one choice, the gear: on each step of ``cyc`` the gear (or the clutch
    open, the engine idling) that meets the step's demand on the least fuel, each evaluated by the drive loop's own
    functions (the equivalent mass of the gear, the clutch slipping below the launch speed or closed above idle
    speed, whichever the drive's clutch could be in, :func:`hevlib.sim.powertrain.conventional.dispatch`, the hot
    map). With no state to carry
    (no battery; shifts cost nothing here) the least sum is the sum of the least. Returns an ``O_*`` row; SOC end
    NaN and ``O_N_STEPS`` the step where no gear drives it."""
    row, c, ratios, d, E = veh.rows[i], veh.c, veh.ratios, veh.cd, veh.E
    v_ref, sin_g, cos_g, key_on = cyc.v_ref, cyc.sin_g, cyc.cos_g, cyc.key_on
    m = row[R_MASS]
    dt = c.dt
    o = np.zeros(L.N_O)
    lhv = c.lhv_j_per_g
    idle = conv.open_state(d)
    idle_fuel = rates(idle.w_e, max(idle.t_e, 0.0), d.s_eng, E)[0] if idle.w_e > 0.0 else 0.0
    n = v_ref.shape[0] - 1
    for t in range(n):
        v0, v1 = v_ref[t], v_ref[t + 1]
        if v0 <= 1e-9 and v1 <= 1e-9:
            if key_on[t]:  # standing with the clutch open: the engine idles (or stands, idle_allowed false)
                o[L.O_FUEL_G] += idle_fuel * dt
                o[L.O_E_FUEL] += idle_fuel * lhv * dt
                o[L.O_E_ENG_SHAFT] += idle.w_e * idle.t_e * dt
            continue
        v_req = 0.5 * (v0 + v1)
        sn, cs = sin_g[t], cos_g[t]
        best, best_shaft = INF, 0.0
        m_free = conventional_equivalent_mass_kg(m, 0.0, False, d.s_eng, c)
        ch = chassis(m, m_free, c)
        f_aero, f_roll, f_grade, f_axle = road_force(v_req, sn, cs, ch)
        f_road = f_aero + f_roll + f_grade + f_axle
        f_grip = adhesion_limit(sn, cs, f_road, ch)
        f_open = m_free * (v1 - v0) / dt + f_road
        if f_open <= 0.0:  # the clutch open, friction brakes (or the road) slow the car: the engine idles
            best, best_shaft = idle_fuel, idle.w_e * idle.t_e
        for g in range(ratios.shape[0]):
            ratio = ratios[g]
            w_in = v_req / d.r * ratio
            if w_in > d.w_e_max:
                continue
            # the clutch slipping at the launch speed (below it) or closed (from idle speed up): either the drive's
            # clutch may be in at this input speed, whichever state it came from
            for slip in (True, False):
                if (slip and w_in >= d.w_launch) or (not slip and w_in < d.w_idle):
                    continue
                m_eff = conventional_equivalent_mass_kg(m, ratio, not slip, d.s_eng, c)
                f_req = m_eff * (v1 - v0) / dt + f_road
                f_dl = min(f_req, f_grip) if f_req > 0.0 else driveline_brake_share(v_req, c) * f_req
                st = conv.dispatch(v_req, f_dl, ratio, slip, d, E)
                if f_req > 0.0 and st.f_del < f_req - SHORT_TOL * max(1.0, f_req):
                    continue
                fuel = rates(st.w_e, max(st.t_e, 0.0), d.s_eng, E)[0]
                if fuel < best:
                    best, best_shaft = fuel, st.w_e * st.t_e
        if best == INF:
            o[L.O_SOC_END] = np.nan
            o[L.O_N_STEPS] = t
            return o
        o[L.O_FUEL_G] += best * dt
        o[L.O_E_FUEL] += best * lhv * dt
        o[L.O_E_ENG_SHAFT] += best_shaft * dt
        o[L.O_DIST_M] += v_req * dt
    o[L.O_DIST_REF_M] = o[L.O_DIST_M]
    o[L.O_SOC_END] = row[R_SOC0]
    o[L.O_N_STEPS] = n
    return o


def gear_bound(vehicle, cycle: Cycle) -> dict:
    """The responses (:func:`hevlib.sim.simulator.responses`) of the conventional car of ``vehicle`` at its gear
    bound on ``cycle`` (:func:`gear_bound_kernel`)."""
    from hevlib.sim.simulator import RunOutput, responses

    if vehicle.kind != "conventional":
        raise ValueError("gear bound: the conventional car expected")
    o = gear_bound_kernel(vehicle.kernel, 0, cycle.to_kernel())
    if not np.isfinite(o[L.O_SOC_END]):
        raise Infeasible(int(o[L.O_N_STEPS]))
    run = RunOutput(o[None, :], np.zeros((1, 3)), np.asarray(vehicle.mass_kg, float), None, o[None, L.O_SOC_END])
    return responses(run, cycle, vehicle.library).drop(columns=["v_max", "f_max", "t_0_100_s"]).iloc[0].to_dict()


#: Columns of a bound's trace (:func:`fuel_bound`), one row per step of the cycle.
TRACE_COLUMNS = ("soc", "eng_on", "w_eng_rad_s", "t_eng_nm", "p_batt_w", "fuel_g_s")


class Bound(NamedTuple):
    """A design's bound on a cycle: its responses (:func:`hevlib.sim.simulator.responses` of the bound's run:
    ``fc``, ``fc_soc_corrected``, ``n_engine_starts`` ...), the SOC it starts from and ends at, its trace and the
    engine-on candidates kept per step (median, most)."""

    responses: dict
    out: np.ndarray  # the bound's run as an ``O_*`` row (fuel, energies, starts, distance)
    soc_init: float
    soc_end: float
    trace: np.ndarray  # (len(cycle), len(TRACE_COLUMNS))
    kept_median: float
    kept_max: int


def controls(vehicle, cycle: Cycle, grid: BoundGrid) -> StepControls:
    """The step controls (:func:`step_controls`) of the one power-split vehicle of ``vehicle`` on ``cycle``, the
    candidate tables cut to the most any step keeps."""
    if vehicle.kind == "conventional" or vehicle.n != 1:
        raise ValueError("bound: one power-split vehicle expected")
    k_max = grid.n_speed * grid.n_torque
    ctl = step_controls(vehicle.kernel, 0, cycle.to_kernel(), grid.n_speed, grid.n_torque, k_max)
    k_used = max(int(ctl.n_on.max()), 1)
    per_candidate = ("fuel_g_s", "p_on_w", "shed_on_w", "w_e", "t_e", "p_gen_mech_w", "p_gen_elec_w")
    return StepControls(
        **{f: getattr(ctl, f)[:, :k_used].copy() if f in per_candidate else getattr(ctl, f) for f in ctl._fields}
    )


def _run(vehicle, cycle: Cycle, ctl: StepControls, o: np.ndarray, record: np.ndarray, soc0: float) -> Bound:
    """A :class:`Bound` of the run ``o`` (an ``O_*`` row) and ``record`` from ``soc0``; :class:`Infeasible` where
    no admissible control drove a step."""
    from hevlib.sim.simulator import RunOutput, responses

    if not np.isfinite(o[L.O_SOC_END]):
        raise Infeasible(int(o[L.O_N_STEPS]))
    # no performance tests: their three responses are dropped
    run = RunOutput(o[None, :], np.zeros((1, 3)), np.asarray(vehicle.mass_kg, float), None, np.array([soc0]))
    r = responses(run, cycle, vehicle.library).drop(columns=["v_max", "f_max", "t_0_100_s"]).iloc[0].to_dict()
    kept = ctl.n_on
    on = kept[kept > 0]
    return Bound(
        responses=r,
        out=o,
        soc_init=soc0,
        soc_end=float(o[L.O_SOC_END]),
        trace=record,
        kept_median=float(np.median(on)) if on.size else 0.0,
        kept_max=int(kept.max()),
    )


def fuel_bound(
    vehicle, cycle: Cycle, grid: BoundGrid, soc_init: float | None = None, *, ctl: StepControls | None = None
) -> Bound:
    """The charge-sustaining fuel bound of the one power-split vehicle of ``vehicle`` (a
    :class:`hevlib.sim.vehicles.Vehicle` of one design, ``hybrid`` or ``prius``) on ``cycle``, from ``soc_init``
    (else the vehicle's own initial SOC); ``ctl``: its :func:`controls` on ``grid`` where already made."""
    ctl = controls(vehicle, cycle, grid) if ctl is None else ctl
    soc0 = float(vehicle.kernel.rows[0, R_SOC0]) if soc_init is None else float(soc_init)
    record = np.zeros((cycle.n_steps, len(TRACE_COLUMNS)))
    o = bound_kernel(vehicle.kernel, 0, ctl, soc0, grid.soc_step, record)
    return _run(vehicle, cycle, ctl, o, record, soc0)


class EcmsRun(NamedTuple):
    """ECMS on a cycle (:func:`ecms_fuel`): its last run (a :class:`Bound` of the same fields: responses, trace
    ...), how many runs the charge balance took, whether it balanced, and the controller's settings."""

    run: Bound
    runs: int
    balanced: bool
    settings: Ecms


def ecms_fuel(
    vehicle,
    cycle: Cycle,
    grid: BoundGrid,
    gain: float,
    soc_init: float | None = None,
    *,
    tolerance: float = 0.01,
    max_runs: int = 10,
    ctl: StepControls | None = None,
) -> EcmsRun:
    """The one power-split vehicle of ``vehicle`` on ``cycle`` under ECMS (:class:`Ecms`: the equivalence factor
    :func:`hevlib.sim.ecms.equivalence_factor` at the control file's target SOC, as the kernel's ``pc.ecms_s0``
    holds it, SOC feedback of ``gain``), on the bound's model and candidates (:func:`step_controls`: the hot map,
    the same limits, starts and booking, so the two compare on one yardstick), charge-balanced as the simulator
    balances (SAE J1711): from ``soc_init`` (else the vehicle's), rerun from the end SOC while the net battery
    energy exceeds ``tolerance`` of the fuel energy, at most ``max_runs`` runs; ``ctl``: the vehicle's
    :func:`controls` on ``grid`` where already made."""
    ctl = controls(vehicle, cycle, grid) if ctl is None else ctl
    pc = vehicle.kernel.pc
    settings = Ecms(s0=float(pc.ecms_s0), gain=float(gain), soc_target=float(pc.soc_target))
    soc0 = float(vehicle.kernel.rows[0, R_SOC0]) if soc_init is None else float(soc_init)
    sc = vehicle.kernel.sc
    step = (sc.soc_max - sc.soc_min) / (int(round((sc.soc_max - sc.soc_min) / grid.soc_step)))
    no_j = np.zeros((1, 2, 1))
    runs, balanced, soc_next = 0, False, soc0
    while not balanced and runs < max_runs:
        soc0 = soc_next
        record = np.zeros((cycle.n_steps, len(TRACE_COLUMNS)))
        o = _forward(vehicle.kernel, 0, ctl, soc0, no_j, sc.soc_min, step, settings, np.zeros(L.N_O), record)
        run = _run(vehicle, cycle, ctl, o, record, soc0)
        runs += 1
        balanced = abs(o[L.O_E_BATT]) <= tolerance * o[L.O_E_FUEL]
        soc_next = run.soc_end
    return EcmsRun(run=run, runs=runs, balanced=bool(balanced), settings=settings)


def bound_trace(bound: Bound, cycle: Cycle) -> pd.DataFrame:
    """The bound's run step by step as the simulator's traces name it (``time_s``, ``v_mps``: the trace's speed at
    the end of each step, and :data:`TRACE_COLUMNS`), for :func:`hevlib.validation.bags.bag_figures`; no tailpipe."""
    frame = pd.DataFrame(bound.trace, columns=list(TRACE_COLUMNS))
    frame.insert(0, "v_mps", cycle.speed_mps)
    frame.insert(0, "time_s", cycle.time_s)
    return frame
