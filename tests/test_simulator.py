"""The vehicle simulator: energy balance, kinematics, limits, driving, baselines, bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hevlib.cycles import build_cycles
from hevlib.design import DESIGN_VARS, OBJECTIVES, RESPONSES
from hevlib.doe import lhs_designs
from hevlib.sim.drive import R_MASS, SPEED_TOL, split_equivalent_mass_kg
from hevlib.sim.powertrain.battery import PackLimits, current_for_power, power_limits
from hevlib.sim.powertrain.layout import OUT_NAMES
from hevlib.sim.powertrain.planetary import carrier_speed, carrier_speed_window, split_torque, sun_speed
from hevlib.sim.powertrain.vehicle import Chassis, adhesion_limit, mean_speed_for_force, road_total
from hevlib.sim.simulator import Simulator, energy_balance, simulate
from hevlib.sim.vehicles import Vehicle

PRIUS = [43.0, 31.0, 15.0, 3.93, 25, 78, 30]


@pytest.fixture(scope="module")
def designs(params) -> np.ndarray:
    """40 random designs over the whole design space (seeded), plus the corners that stress limits."""
    space = params.design_space.space()
    X = lhs_designs(space, 40, seed=11)
    corners = np.array(
        [
            [25, 20, 5, 2.0, 10, 90, 18],
            [70, 60, 30, 4.5, 60, 50, 40],
            [25, 60, 5, 4.5, 10, 90, 40],
            [70, 20, 30, 2.0, 60, 50, 18],
        ],
        dtype=float,
    )
    return np.vstack([X, corners])


@pytest.fixture(scope="module")
def runs(sim, cycles, designs) -> dict:
    """Raw kernel output of the random designs on the sizing cycle (UDDS 20 %) and on FTP."""
    return {name: sim.run_raw(designs, cycles[name]) for name in ("udds", "ftp")}


# --------------------------------------------------------------------------------- energy balance
@pytest.mark.parametrize("cycle", ["udds", "ftp"])
def test_energy_balance_closes_for_every_design(runs, cycle):
    eb = energy_balance(runs[cycle])
    # fuel + net battery = every loss + accessories + brakes + road + grade + kinetic energy, to 0.5 % of fuel
    assert (eb["residual_share"] < 0.005).all(), eb["residual_share"].max()
    # ... and the only term that is not an identity (force-limited steps' fixed point) is negligible
    assert (eb["mismatch_share"] < 1e-3).all(), eb["mismatch_share"].max()
    # every loss term is a loss
    for key in (
        "e_loss_eng_j",
        "e_loss_mot_j",
        "e_loss_gen_j",
        "e_loss_pg_j",
        "e_loss_fd_j",
        "e_loss_batt_j",
        "e_brake_j",
        "e_road_j",
    ):
        assert (eb[key] >= -1e-6).all(), key


def test_energy_balance_sees_a_broken_term(runs):
    """The check can fail: dropping one sink (the road load) leaves a residual far above the bar."""
    o = runs["udds"].frame()
    sinks = o[
        [
            k
            for k in (
                "e_loss_eng_j",
                "e_loss_mot_j",
                "e_loss_gen_j",
                "e_loss_pg_j",
                "e_loss_fd_j",
                "e_loss_batt_j",
                "e_acc_j",
                "e_brake_j",
                "e_grade_j",
                "e_kin_end_j",
            )
        ]
    ].sum(axis=1)
    share = (o["e_fuel_j"] + o["e_batt_j"] - sinks).abs() / (o["e_fuel_j"] + o["e_batt_j"].abs())
    moved = o["dist_m"] > 0.2 * o["dist_ref_m"]
    assert moved.sum() >= 10 and (share[moved] > 0.005).all()


def test_conventional_and_prius_balance_on_every_cycle(sim, cycles):
    for cyc in cycles.values():
        for vehicle in ("prius", "conventional"):
            eb = energy_balance(sim.run_raw(None, cyc, vehicle)).iloc[0]
            assert eb["residual_share"] < 1e-9, (vehicle, cyc.name)


# ------------------------------------------------------------------------------ kinematics, limits
def test_planetary_kinematics_and_torque_split():
    n_r, n_s = 78.0, 30.0
    w_c, w_r = 250.0, 300.0
    w_s = sun_speed(w_c, w_r, n_r, n_s)
    assert w_r * n_r + w_s * n_s == pytest.approx(w_c * (n_r + n_s))  # Willis
    assert carrier_speed(w_r, w_s, n_r, n_s) == pytest.approx(w_c)
    lo, hi = carrier_speed_window(w_r, n_r, n_s, 500.0)
    assert sun_speed(lo, w_r, n_r, n_s) == pytest.approx(-500.0)
    assert sun_speed(hi, w_r, n_r, n_s) == pytest.approx(500.0)
    t_ring, t_sun = split_torque(100.0, n_r, n_s)
    assert t_ring + t_sun == pytest.approx(100.0)
    assert t_ring / t_sun == pytest.approx(n_r / n_s)
    # power is conserved through the lossless set
    assert 100.0 * w_c == pytest.approx(t_ring * w_r + t_sun * w_s)


def test_no_limit_is_ever_exceeded(runs):
    for name, raw in runs.items():
        o = raw.frame()
        assert (o["limit_violations"] == 0).all(), name
        # the drive keeps to the controller's SOC window (0.45-0.75; limit_violations counts a drive that draws
        # more than the window allows); only a start's spin-up may draw on the pack's own reserve below it
        # (simulator v6), the accessories beside it. Measured worst: a 63.5 kW engine on a 5 kW generator, whose
        # 6 s spin-ups (about 30 kJ each) its generator-bound engine cannot charge back, 8.6 % of SOC below the
        # window on FTP (docs/model.md; whether to refuse such a start is open)
        assert (o["soc_min_seen"] >= 0.45 - 0.10).all() and (o["soc_max_seen"] <= 0.75 + 1e-6).all(), name


def test_traces_obey_willis_torque_split_and_limits(sim, cycles, designs, lib, params):
    X = designs[[0, 7, 40, 42]]
    tr = sim.trace(X, cycles["udds"])
    ps = lib.power_split
    for i, x in enumerate(X):
        d = tr[tr["design"] == i]
        n_r, n_s = x[5], x[6]
        on = d["eng_on"] > 0.5
        # Willis on every step (engine stopped: the sun turns at -k w_ring)
        lhs = d["w_mot_rad_s"] * n_r + d["w_gen_rad_s"] * n_s
        assert np.allclose(lhs, d["w_eng_rad_s"] * (n_r + n_s), atol=1e-6)
        # the generator reacts the engine's torque in the ratio of the teeth (a running carrier's inertia left out)
        assert np.allclose(d.loc[on, "t_gen_nm"], -d.loc[on, "t_eng_nm"] * n_s / (n_r + n_s), atol=1e-9)
        assert (d.loc[on, "w_eng_rad_s"] <= ps.engine_max_speed_rad_s * (1 + 1e-9)).all()
        assert (d.loc[on, "w_eng_rad_s"] >= ps.engine_min_on_speed_rad_s * (1 - 1e-9)).all()
        assert (d["w_gen_rad_s"].abs() <= ps.generator_max_speed_rad_s * (1 + 1e-9)).all()
        assert (d["w_mot_rad_s"] <= ps.motor_max_speed_rad_s * (1 + 1e-9)).all()
        assert (d.loc[on, "t_eng_nm"] <= d.loc[on, "t_eng_max_nm"] * (1 + 1e-9)).all()
        assert (d["t_mot_nm"].abs() <= d["t_mot_max_nm"] * (1 + 1e-9)).all()
        assert (d["t_gen_nm"].abs() <= d["t_gen_max_nm"] * (1 + 1e-9)).all()
        assert d["soc"].between(params.sim.soc_min - 1e-9, params.sim.soc_max + 1e-9).all()
        # the same limits recomputed independently from the component maps (not the kernels' tables)
        s_e = x[0] / lib.engine_hybrid.peak_power_kw
        s_m, s_g = x[1] / lib.motor.peak_power_kw, x[2] / lib.generator.peak_power_kw
        t_e_cap = lib.engine_hybrid.max_torque_at(d.loc[on, "w_eng_rad_s"].to_numpy()) * s_e
        assert (d.loc[on, "t_eng_nm"].to_numpy() <= t_e_cap * (1 + 1e-6)).all()
        assert (
            d["t_mot_nm"].abs().to_numpy()
            <= lib.motor.max_torque_at(d["w_mot_rad_s"].abs().to_numpy()) * s_m * (1 + 1e-6)
        ).all()
        assert (
            d["t_gen_nm"].abs().to_numpy()
            <= lib.generator.max_torque_at(d["w_gen_rad_s"].abs().to_numpy()) * s_g * (1 + 1e-6)
        ).all()
        # motor speed is set by the vehicle: ring = wheel speed x i0 (at the step's mean speed)
        v_mean = 0.5 * (d["v_mps"].to_numpy()[1:] + d["v_mps"].to_numpy()[:-1])
        moving = v_mean > 0
        w_ring = d["w_mot_rad_s"].to_numpy()[1:]
        # (force-limited steps converge their speed to SPEED_TOL)
        tol = 2 * SPEED_TOL / lib.wheel_conventional.radius_m * x[3]
        assert np.allclose(w_ring[moving], v_mean[moving] / lib.wheel_conventional.radius_m * x[3], atol=tol)


def _conv_trace(sim, cycle):
    tr = sim.trace(None, cycle, "conventional")
    v = tr["v_mps"].to_numpy()
    return tr, 0.5 * (v + np.r_[0.0, v[:-1]])  # each row's step mean speed (rows 1..: step t -> row t + 1)


def _at_rest(tr) -> np.ndarray:
    """Rows of a trace whose whole step the car stood still and the cycle asked it to."""
    v = tr["v_mps"].to_numpy()
    return (v == 0) & (np.r_[0.0, v[:-1]] == 0) & (tr["v_ref_mps"] == 0).to_numpy()


def test_conventional_gear_kinematics_and_idle(sim, cycles, lib, params):
    tr, v_mean = _conv_trace(sim, cycles["ftp"])
    ratios = np.array(params.baseline.conventional.gear_ratios)
    w_launch, w_idle = lib.conventional_launch_rad_s, lib.conventional_idle_rad_s
    engaged = (tr["gear"] > 0).to_numpy()
    w_in = v_mean[engaged] / lib.wheel_conventional.radius_m * ratios[tr.loc[engaged, "gear"].astype(int) - 1]
    w_e = tr.loc[engaged, "w_eng_rad_s"].to_numpy()
    slipping = np.isclose(w_e, w_launch, rtol=0, atol=1e-9) & (w_in < w_launch - 1e-9)
    assert slipping.sum() > 20  # launches
    assert np.allclose(w_e[~slipping], w_in[~slipping], rtol=1e-9)  # clutch closed: rigid
    # ADVISOR's clutch: a closed clutch stays closed below the launch speed (down to idle)
    closed_below_launch = ~slipping & (w_in < w_launch)
    assert closed_below_launch.sum() > 10 and (w_in[closed_below_launch] >= w_idle * (1 - 1e-9)).all()
    # standstill with the key on: idle fuel; key off (the FTP soak): none
    key_on = np.r_[False, cycles["ftp"].key_on[:-1]]  # row t + 1 holds step t
    stopped = _at_rest(tr)
    idle, soak = stopped & key_on, stopped & ~key_on
    assert idle.sum() > 300 and (tr.loc[idle, "fuel_g_s"] > 0.05).all()
    assert np.allclose(tr.loc[idle, "w_eng_rad_s"], w_idle) and (tr.loc[idle, "gear"] == 0).all()
    assert soak.sum() > 500 and (tr.loc[soak, "fuel_g_s"] == 0).all()


def test_conventional_shift_decision_by_hand(sim):
    """ADVISOR's load-based decision (PTC_CONV curves: upshift below load 0.3 at 1500 rpm rising to 1 at
    0.98 x 5500 rpm; downshift above 0.6 at 800 rpm rising to 0.9 at 2750 rpm, 1 at 2755.5 rpm; both
    extrapolated beyond their ends) at hand-computed points."""
    from hevlib.sim.powertrain import conventional as conv

    S = sim.library.shift
    rpm = np.pi / 30
    up = lambda w: 0.3 + 0.7 * (w - 1500) / (0.98 * 5500 - 1500)  # noqa: E731
    dn = lambda w: 0.6 + 0.3 * (w - 800) / (2750 - 800)  # noqa: E731
    assert conv.curve(1600 * rpm, S.up_w, S.up_load) == pytest.approx(up(1600), rel=1e-9)
    assert conv.curve(2000 * rpm, S.dn_w, S.dn_load) == pytest.approx(dn(2000), rel=1e-9)
    # 1600 rpm in 2nd: upshift at load 0.31 (< 0.318), hold at 0.33; 2000 rpm: downshift above 0.785
    assert conv.next_gear(1, 1600 * rpm, 0.31, True, S, 5) == 2
    assert conv.next_gear(1, 1600 * rpm, 0.33, True, S, 5) == 1
    assert conv.next_gear(1, 2000 * rpm, 0.80, True, S, 5) == 0
    assert conv.next_gear(1, 2000 * rpm, 0.80, False, S, 5) == 1  # two steps after an upshift: no downshift
    # below 1500 rpm never up (even unloaded), below 800 rpm always down, above 2755.5 rpm never down
    assert conv.next_gear(2, 1499 * rpm, 0.0, True, S, 5) == 2
    assert conv.next_gear(2, 799 * rpm, 1.0, True, S, 5) == 1
    assert conv.next_gear(2, 3000 * rpm, 1.0, True, S, 5) == 2
    assert conv.next_gear(4, 5400 * rpm, 1.0, True, S, 5) == 4  # top gear saturates
    assert conv.next_gear(0, 0.0, 0.0, True, S, 5) == 0


def test_conventional_shifts_follow_advisors_load_logic(sim, cycles, lib, params):
    """On FTP (the car keeps up, so each step's speed is the one the decision used): one gear per step; an
    upshift only from 1500 rpm in the gear held, a downshift only under 800 rpm or under load below 0.501 x
    the top speed, none in the two steps after an upshift; the engine far from the speed-table's gears."""
    tr, v_mean = _conv_trace(sim, cycles["ftp"])
    ratios = np.array(params.baseline.conventional.gear_ratios)
    rpm = np.pi / 30
    g = tr["gear"].to_numpy()
    moving = (v_mean > 0.5)[1:] & (g[1:] > 0) & (g[:-1] > 0)
    dg = np.diff(g)[moving]
    assert set(np.unique(dg)) <= {-1, 0, 1} and (dg == 1).sum() > 30 and (dg == -1).sum() > 10
    w_held = (v_mean[1:] / lib.wheel_conventional.radius_m * ratios[np.maximum(g[:-1], 1).astype(int) - 1])[moving]
    assert (w_held[dg == 1] >= 1500 * rpm * (1 - 1e-9)).all()
    assert (w_held[dg == -1] <= 0.501 * lib.engine_conventional.max_speed_rad_s * (1 + 1e-9)).all()
    ups = np.flatnonzero(np.diff(g) == 1)
    checked = 0
    for k in ups:
        if (g[k + 1 : k + 4] > 0).all():  # the clutch stays in (an open clutch shows gear 0)
            assert (np.diff(g[k + 1 : k + 4]) >= 0).all()
            checked += 1
    assert checked > 30
    # the load logic keeps the engine low: most moving steps under 2000 rpm, and it differs from the table
    w_e = tr["w_eng_rad_s"].to_numpy()[1:][moving]
    assert np.median(w_e) < 1500 * rpm
    sched = 1 + np.searchsorted(params.baseline.conventional.upshift_kmh, v_mean[1:][moving] * 3.6, side="right")
    assert np.mean(sched == g[1:][moving]) < 0.8


def test_conventional_speed_table_is_one_setting_away(lib, params, cycles):
    """``baseline.conventional.shift_logic: speed``: the gear is the PTC_CONV table's at the step's start speed."""
    p = params.model_copy(
        update={
            "baseline": params.baseline.model_copy(
                update={"conventional": params.baseline.conventional.model_copy(update={"shift_logic": "speed"})}
            )
        }
    )
    tr, _ = _conv_trace(Simulator(lib, p), cycles["ftp"])
    engaged = tr["gear"] > 0
    v_kmh = np.r_[0.0, tr["v_mps"].to_numpy()[:-1]] * 3.6
    sched = 1 + np.searchsorted(params.baseline.conventional.upshift_kmh, v_kmh[engaged], side="right")
    assert np.mean(sched == tr.loc[engaged, "gear"].to_numpy()) == 1.0


def test_conventional_deceleration_follows_ptc_conv(sim, lib, params, cycles):
    """PTC_CONV as shipped: the clutch stays closed while the car slows (the wheels turn the engine, which reads
    its map at the closed-throttle torque: FC_SI63_emis has no fuel cut and T_ct = 0) until the engine would
    fall below idle. With the file's other settings (clutch open without torque, no idling) the clutch opens on
    every deceleration and the engine, stopped, burns nothing."""
    import dataclasses

    tr, v_mean = _conv_trace(sim, cycles["ftp"])
    slowing = (tr["v_mps"].diff() < -0.05) & (tr["f_brake_n"] < -1.0)
    closed = slowing & (tr["gear"] > 0)
    assert closed.sum() > 100
    # the engine gives some torque when the driveline's share of the braking is small (accessories, gearbox),
    # mostly none: closed throttle, fuel = the map's zero-torque column (x the engine's scale, once hot)
    t_e = tr.loc[closed, "t_eng_nm"]
    assert (t_e >= 0).all() and (t_e == 0).mean() > 0.6
    # where it gives some, the driveline brakes exactly with the wheel file's share of the request
    some = closed & (tr["t_eng_nm"] > 0)
    wh = lib.wheel_conventional
    share = np.interp(v_mean[some.to_numpy()], wh.brake_speed_mps, wh.brake_driveline_share)
    f_req = tr.loc[some, "f_pt_n"] + tr.loc[some, "f_brake_n"]
    np.testing.assert_allclose(tr.loc[some, "f_pt_n"], share * f_req, rtol=1e-9, atol=1e-6)
    s_eng = params.baseline.conventional.p_eng_kw / lib.engine_conventional.peak_power_kw
    hot = closed & (tr["t_coolant_c"] >= 95.9) & (tr["t_eng_nm"] == 0)
    eng = lib.engine_conventional
    zero_col = np.interp(tr.loc[hot, "w_eng_rad_s"], eng.speed_rad_s, eng.fuel_g_s[:, 0])
    assert hot.sum() > 50 and np.allclose(tr.loc[hot, "fuel_g_s"], s_eng * zero_col, rtol=1e-9)
    # the driveline brakes: friction takes less than the whole request
    assert (tr.loc[closed, "f_pt_n"] < 0).all()

    ctl = dataclasses.replace(lib.conventional_control, idle_allowed=False, clutch_opens_without_torque=True)
    other = Simulator(dataclasses.replace(lib, conventional_control=ctl), params)
    tr2, _ = _conv_trace(other, cycles["ftp"])
    res = other.run_raw(None, cycles["ftp"], "conventional")
    assert energy_balance(res)["residual_share"].iloc[0] < 1e-9  # the accessories are off, not lost
    assert res.frame()["e_acc_unmet_j"].iloc[0] > 0
    slowing2 = (tr2["v_mps"].diff() < -0.05) & (tr2["f_brake_n"] < -100.0)  # braking, not easing off
    assert slowing2.sum() > 100
    assert (tr2.loc[slowing2, "gear"] == 0).all() and (tr2.loc[slowing2, "fuel_g_s"] == 0).all()
    assert (tr2.loc[slowing2, "eng_on"] == 0).all()
    stopped = _at_rest(tr2)
    assert stopped.sum() > 300 and (tr2.loc[stopped, "fuel_g_s"] == 0).all()


def test_battery_rint_model_round_trip_and_limits():
    voc, r_d, r_c = 270.0, 0.45, 0.43
    for p in (-20e3, -1e3, 0.0, 5e3, 30e3):
        i = current_for_power(p, voc, r_d, r_c)
        r = r_d if i >= 0 else r_c
        assert voc * i - r * i * i == pytest.approx(p, abs=1e-6)
    lim = PackLimits(
        v_min_v=150.0,
        v_max_v=292.5,
        i_max_a=200.0,
        soc_min=0.4,
        soc_max=0.8,
        capacity_as=7.4 * 3600,
        eta_c=0.99,
        dt_s=1.0,
    )
    p_dis, p_chg = power_limits(voc, r_d, r_c, 0.6, lim)
    i_dis = current_for_power(p_dis, voc, r_d, r_c)
    i_chg = current_for_power(-p_chg, voc, r_d, r_c)
    assert i_dis <= 200.0 + 1e-9 and voc - r_d * i_dis >= 150.0 - 1e-9
    assert -i_chg <= 200.0 + 1e-9 and voc - r_c * i_chg <= 292.5 + 1e-9
    # at the bottom of the SOC window nothing more may be drawn
    assert power_limits(voc, r_d, r_c, 0.4, lim)[0] == 0.0


def test_adhesion_and_force_speed_solution():
    ch = Chassis(
        m=1200.0,
        m_eff=1260.0,
        cda=0.387,
        crr=0.009,
        r=0.282,
        axle_drag_nm=6.4,
        h_over_l=0.16,
        f_front=0.55,
        adhesion_coefficient=0.9,
        rho=1.2,
        g=9.81,
        k_lin=0.0,
    )
    f = adhesion_limit(0.0, 1.0, 0.0, ch)
    a = f / ch.m_eff
    # at that force the front load (with the load transfer of that acceleration) is exactly mu times it
    n_front = ch.m * ch.g * ch.f_front - ch.m * a * ch.h_over_l
    assert f == pytest.approx(ch.adhesion_coefficient * n_front, rel=1e-12)
    v = mean_speed_for_force(10.0, 2000.0, 0.0, 1.0, 1.0, ch)
    assert 2000.0 - road_total(v, 0.0, 1.0, ch) == pytest.approx(2 * ch.m_eff * (v - 10.0), rel=1e-9)
    # too little force on a 20 % grade from standstill: the car stays put, it does not roll back
    s, c = np.sin(np.arctan(0.2)), np.cos(np.arctan(0.2))
    assert mean_speed_for_force(0.0, 1000.0, s, c, 1.0, ch) == 0.0


def test_force_limited_step_converges_from_the_envelope_and_without_it(sim):
    """A force-limited step's speed is the fixed point v = v_bought(F(v)) to SPEED_TOL, whether the solve starts
    from the previous step's point on the full-power envelope or from the fixed-point step (no envelope), and
    a stale envelope (far away, wrong slope) costs iterations, not the answer."""
    from hevlib.sim.drive import (
        N_R,
        NO_ENVELOPE,
        ON,
        R_N_BAT,
        StepRoad,
        chassis,
        limited_step_split,
        pack_limits,
        split_design,
    )
    from hevlib.sim.powertrain import hybrid as split

    veh = sim.vehicle(pd.DataFrame([dict(zip(DESIGN_VARS, [25, 20, 5, 4.5, 10, 78, 30], strict=True))])).kernel
    row = veh.rows[0]
    assert row.shape == (N_R,)
    c, sc, E, M, G = veh.c, veh.sc, veh.E, veh.M, veh.G
    d = split_design(row, c, sc)
    dl = split.SplitDriveline(d=d, E=E, M=M, G=G)
    ch = chassis(row[R_MASS], split_equivalent_mass_kg(row, c, sc), c)
    p_dis, p_chg = pack_limits(0.6, row[R_N_BAT], sc, veh.B, c.dt)
    sn, cs = np.sin(np.arctan(0.2)), np.cos(np.arctan(0.2))
    f_cmd = 1e5  # far beyond what the driveline gives: every step is force-limited

    def solve(v0, v_req, env):
        lim = split.limits(v_req, d, E, M, G)
        cmd = split.SplitCommand(
            f_req_n=f_cmd, engine_on=ON, p_e_target_w=lim.p_e_max, p_dis_w=p_dis, p_chg_w=p_chg, regen_share=1.0
        )
        st = split.dispatch(lim, cmd, d, E, M, G)
        road = StepRoad(sin_g=sn, cos_g=cs, dt_s=1.0)
        st, v, u, env = limited_step_split(v0, v_req, v_req, cmd, road, st, env, ch, dl)
        lim = split.limits(v, d, E, M, G)
        assert st == split.dispatch(lim, split.at_power(cmd, lim.p_e_max), d, E, M, G)  # the state at v
        assert abs(u - v) <= SPEED_TOL and u == mean_speed_for_force(v0, st.f_del, sn, cs, 1.0, ch)
        assert st.f_del < f_cmd and v < v_req
        return v, env

    v1, env = solve(4.0, 12.0, NO_ENVELOPE)
    assert env[0] == v1 and env[2] < 0.0  # the envelope: force falls with speed at full power
    for v0 in (4.0, 4.05, 3.9, 6.0):
        v_cold, _ = solve(v0, 12.0, NO_ENVELOPE)
        v_warm, _ = solve(v0, 12.0, env)
        v_stale, _ = solve(v0, 12.0, (15.0, 50.0, 40.0))
        assert abs(v_warm - v_cold) <= 2 * SPEED_TOL and abs(v_stale - v_cold) <= 2 * SPEED_TOL


def test_vehicle_from_named_design_columns_in_any_order(sim, designs):
    frame = pd.DataFrame(designs[:, ::-1], columns=list(DESIGN_VARS)[::-1])
    frame["note"] = "extra columns are ignored"
    named = Vehicle.from_design(sim.library, frame)
    ordered = Vehicle.from_design(sim.library, designs)
    np.testing.assert_array_equal(named.kernel.rows, ordered.kernel.rows)
    np.testing.assert_array_equal(named.mass_kg, sim.mass_kg(designs))
    assert named.n == len(designs) and list(named.design.columns) == list(DESIGN_VARS)
    with pytest.raises(ValueError, match="missing column.*i0"):
        Vehicle.from_design(sim.library, frame.drop(columns="i0"))
    with pytest.raises(ValueError, match="n_bat"):
        Vehicle.from_design(sim.library, frame.assign(n_bat=1000))


def test_cycle_to_kernel_reads_the_trace_and_its_road_angle(cycles):
    cyc = cycles["udds"]
    k = cyc.to_kernel()
    np.testing.assert_array_equal(k.v_ref, cyc.speed_mps)
    np.testing.assert_array_equal(k.key_on, cyc.key_on)
    theta = np.arctan(cyc.grade)
    np.testing.assert_allclose(k.sin_g, np.sin(theta), rtol=0, atol=0)
    np.testing.assert_allclose(k.cos_g, np.cos(theta), rtol=0, atol=0)
    assert all(a.flags.c_contiguous for a in k)


def test_simulate_is_pure_and_independent_of_how_a_batch_is_split(sim, cycles, designs, monkeypatch):
    import numba

    from hevlib.sim import simulator

    veh = Vehicle.from_design(sim.library, designs[:9])
    a = simulate(veh, cycles["ftp"])
    b = simulate(veh, cycles["ftp"])
    monkeypatch.setattr(simulator, "CHUNKS_PER_THREAD", 3)  # other chunk edges on the threads
    c = simulate(veh, cycles["ftp"])
    numba.set_num_threads(1)
    try:
        d = simulate(veh, cycles["ftp"])
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    one = [simulate(Vehicle.from_design(sim.library, designs[[i]]), cycles["ftp"]) for i in (0, 8)]
    for r in (b, c, d):
        np.testing.assert_array_equal(r.out, a.out)
        np.testing.assert_array_equal(r.perf, a.perf)
    np.testing.assert_array_equal(np.vstack([one[0].out, one[1].out]), a.out[[0, 8]])
    assert (
        veh.kernel.rows.flags.writeable
        and (veh.kernel.rows == Vehicle.from_design(sim.library, designs[:9]).kernel.rows).all()
    )


# ------------------------------------------------------------------------------------ driving
def test_weak_designs_fall_behind_on_the_grade_strong_ones_follow_flat(sim, cycles, params):
    weak = np.array([[25, 20, 5, 2.0, 10, 78, 30]], dtype=float)
    strong = np.array([[70, 60, 30, 3.93, 60, 78, 30]], dtype=float)
    graded = sim.run(np.vstack([weak, strong]), cycles["udds"])
    assert graded.loc[0, "e_l"] > 1.0 and not graded.loc[0, "cycle_met"]
    assert graded.loc[0, "speed_dev"] > graded.loc[1, "speed_dev"]
    assert graded.loc[0, "e_l"] > graded.loc[1, "e_l"]
    flat = sim.run(strong, cycles["ftp"])
    assert flat.loc[0, "cycle_met"] and flat.loc[0, "e_l"] < 1e-3 and flat.loc[0, "accel_dev"] < 1e-6
    # the distance driven plus the distance failed is the cycle distance
    assert graded.loc[0, "e_l"] < cycles["udds"].distance_m / 1e3


def test_batch_is_row_independent_and_ordered(sim, cycles, designs):
    full = sim.run(designs[:12], cycles["udds"], batch_size=5)
    single = pd.concat([sim.run(designs[[i]], cycles["udds"]) for i in (0, 6, 11)], ignore_index=True)
    pd.testing.assert_frame_equal(full.iloc[[0, 6, 11]].reset_index(drop=True), single)


def test_responses_are_finite_and_named(sim, cycles, designs):
    r = sim.run(designs, cycles["udds"])
    assert list(r.columns) == list(RESPONSES)
    assert np.isfinite(r[list(OBJECTIVES)].to_numpy()).all()
    assert r["cycle_met"].dtype == bool
    assert (r["fc"] >= 0).all() and (r["e_l"] >= 0).all() and r["accel_dev"].between(0, 100).all()


def test_mass_model_matches_components(sim, lib):
    from hevlib.sizing import hybrid_masses

    X = np.array([PRIUS, [50, 50, 25, 3.93, 40, 78, 30]], dtype=float)
    m = hybrid_masses(lib, sim.chassis_kg, X[:, 0], X[:, 1], X[:, 2], X[:, 4]).test_mass_kg
    assert np.allclose(sim.mass_kg(X), m)
    assert sim.mass_kg(X[[1]])[0] == pytest.approx(1200.4, abs=0.5)  # L27 design 1 (components.json)


# ------------------------------------------------------------------------------- performance
def test_performance_limits(sim, cycles, designs, lib, params):
    r = sim.run(designs, cycles["ftp"])
    r_w = lib.wheel_conventional.radius_m
    ps = lib.power_split
    for x, vmax in zip(designs, r["v_max"], strict=True):
        w_ring_max = min(
            ps.motor_max_speed_rad_s,
            ((x[5] + x[6]) * ps.engine_max_speed_rad_s + x[6] * ps.generator_max_speed_rad_s) / x[5],
        )
        assert vmax <= w_ring_max * r_w / x[3] * 3.6 * (1 + 1e-9)
    body = lib.body_conventional
    a_adh = params.sim.adhesion_coefficient * body.gravity_m_s2 * body.front_weight_fraction
    # tyres, not the driveline, cap it: the adhesion force accelerates the equivalent (rotating) mass
    veh = sim.vehicle(designs).kernel
    m_ratio = np.array([row[R_MASS] / split_equivalent_mass_kg(row, veh.c, veh.sc) for row in veh.rows])
    assert (m_ratio < 1.0).all()
    assert (r["f_max"] <= a_adh * m_ratio + 1e-6).all()
    assert (r["f_max"] > 0).all()
    finite = np.isfinite(r["t_0_100_s"])
    assert (r.loc[finite, "t_0_100_s"] > 100 / 3.6 / r.loc[finite, "f_max"] - 1e-6).all()
    # more motor and engine power never makes the launch slower (same everything else)
    X = np.array([[30, 30, 15, 3.93, 30, 78, 30], [50, 50, 15, 3.93, 30, 78, 30]], dtype=float)
    t = sim.run(X, cycles["ftp"])["t_0_100_s"]
    assert t[1] < t[0]


# -------------------------------------------------------------------------------- baselines
def test_baselines_are_physically_plausible(sim, cycles):
    """FTP figures against published ones (1st-gen Prius: 4.5-5.6 L/100 km city; a 70 kW compact
    car: 7-10 L/100 km; Prius 0-100 km/h about 14 s, top speed 160 km/h)."""
    prius = sim.run(None, cycles["ftp"], "prius").iloc[0]
    conv = sim.run(None, cycles["ftp"], "conventional").iloc[0]
    assert 3.0 < prius["fc_soc_corrected"] < 6.0
    assert 6.5 < conv["fc"] < 10.0
    assert prius["fc"] < conv["fc"]
    assert 11.0 < prius["t_0_100_s"] < 18.0 and 150 < prius["v_max"] < 180
    assert 8.0 < conv["t_0_100_s"] < 13.0
    assert prius["cycle_met"] and conv["cycle_met"]
    assert conv["diff_soc"] == 0.0


# -------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("row", "name"),
    [
        ([80, 40, 20, 3.0, 30, 78, 30], "p_eng_kw"),
        ([40, 40, 20, 3.0, 30.5, 78, 30], "n_bat"),
        ([40, 40, 20, 9.0, 30, 78, 30], "i0"),
        ([40, 40, 20, 3.0, 30, 78, np.nan], "n_s"),
    ],
)
def test_bad_designs_are_rejected_naming_the_variable(sim, cycles, row, name):
    with pytest.raises(ValueError, match=name):
        sim.run(np.array([row], dtype=float), cycles["ftp"])


def test_impossible_gear_set_is_rejected(lib, params):
    p = params.model_copy(update={"design_space": params.design_space.model_copy(update={"n_s": (18, 60)})})
    with pytest.raises(ValueError, match="n_s"):
        Simulator(lib, p).run(np.array([[40, 40, 20, 3.0, 30, 50, 55]], dtype=float), build_cycles(p.cycles)["ftp"])


def test_unknown_vehicle_is_rejected(sim, cycles):
    with pytest.raises(ValueError, match="vehicle"):
        sim.run_raw(np.array([PRIUS], dtype=float), cycles["ftp"], "truck")


def test_out_names_cover_the_layout():
    assert len(OUT_NAMES) == len(set(OUT_NAMES))
    assert len(DESIGN_VARS) == 7


# ------------------------------------------------------------------------------- hev simulate
def test_hev_simulate_writes_inputs_and_every_response(stage_dir):
    from typer.testing import CliRunner

    from stages.cli import app

    pd.DataFrame([PRIUS, [50, 50, 25, 3.93, 40, 78, 30]], columns=list(DESIGN_VARS)).to_csv("d.csv", index=False)
    res = CliRunner().invoke(
        app, ["simulate", "--designs", "d.csv", "--cycle", "udds", "--grade", "0", "--out", "out.parquet"]
    )
    assert res.exit_code == 0, res.output
    out = pd.read_parquet("out.parquet")
    assert len(out) == 2 and set(DESIGN_VARS) <= set(out.columns) and set(RESPONSES) <= set(out.columns)
    assert (out["grade"] == 0).all() and out["cycle_met"].all()
    res = CliRunner().invoke(app, ["simulate", "--vehicle", "conventional", "--cycle", "ftp", "--out", "c.csv"])
    assert res.exit_code == 0, res.output
    conv = pd.read_csv("c.csv")
    assert len(conv) == 1 and conv.loc[0, "vehicle"] == "conventional" and 6.5 < conv.loc[0, "fc"] < 10
    # traces on request: coolant and catalyst temperature, engine on/off, engine-out and tailpipe rates
    res = CliRunner().invoke(
        app, ["simulate", "--designs", "d.csv", "--cycle", "ftp", "--out", "h.csv", "--trace", "h_trace.parquet"]
    )
    assert res.exit_code == 0, res.output
    tr = pd.read_parquet("h_trace.parquet")
    assert len(tr) == 2 * 2478 and set(tr["design"]) == {0, 1}
    for col in ("t_coolant_c", "t_cat_c", "eng_on", "hc_engine_out_g_s", "hc_tailpipe_g_s", "nox_tailpipe_g_s"):
        assert col in tr.columns
    assert tr["t_cat_c"].max() > 300 and (tr["hc_tailpipe_g_s"] <= tr["hc_engine_out_g_s"] + 1e-15).all()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--designs", "bad.csv", "--cycle", "ftp"], "p_eng_kw"),
        (["--designs", "d.csv", "--cycle", "mars"], "--cycle"),
        (["--designs", "d.csv", "--cycle", "ftp", "--vehicle", "truck"], "--vehicle"),
        (["--designs", "missing.csv", "--cycle", "ftp"], "missing.csv"),
        (["--designs", "empty.csv", "--cycle", "ftp"], "empty.csv: empty file (no header, no rows)"),
        (["--designs", "header.csv", "--cycle", "ftp"], "header.csv: no designs (a header but no rows)"),
        (["--designs", "text.csv", "--cycle", "ftp"], "text.csv: i0 is not a number in line 3 (abc)"),
        (["--designs", "d.csv", "--cycle", "ftp", "--vehicle", "prius"], "--designs: only for --vehicle hybrid"),
    ],
)
def test_hev_simulate_rejects_bad_input_with_one_line_and_no_output(stage_dir, args, message):
    from typer.testing import CliRunner

    from stages.cli import app

    pd.DataFrame([PRIUS], columns=list(DESIGN_VARS)).to_csv("d.csv", index=False)
    pd.DataFrame([[90, 40, 20, 3.0, 30, 78, 30]], columns=list(DESIGN_VARS)).to_csv("bad.csv", index=False)
    Path("empty.csv").write_text("")
    Path("header.csv").write_text(",".join(DESIGN_VARS) + "\n")
    Path("text.csv").write_text(",".join(DESIGN_VARS) + "\n43,31,15,3.93,25,78,30\n43,31,15,abc,25,78,30\n")
    res = CliRunner().invoke(app, ["simulate", *args, "--out", "out.csv"])
    assert res.exit_code == 1
    assert message in res.output and res.output.strip().count("\n") == 0
    assert not (stage_dir / "out.csv").exists()
