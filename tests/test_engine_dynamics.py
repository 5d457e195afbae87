"""Simulator v4: the power-split engine's starts and carrier dynamics, ADVISOR's coolant warm-up rule and
charge-balanced fuel (SAE J1711, FASTSim's ``soc_bal_iters``)."""

from __future__ import annotations

import numpy as np
import pytest

from hevlib.sim.drive import split_design
from hevlib.sim.powertrain import hybrid as split
from hevlib.sim.powertrain.hybrid import CarrierDynamics, start_cost
from hevlib.sim.simulator import Simulator, charge_balance, energy_balance, simulate

PRIUS = [43.0, 31.0, 15.0, 3.93, 25, 78, 30]
#: a large engine on a small generator and a low ring/sun ratio: the slowest carrier of the design box that can
#: still crank its engine (and the one below it that cannot)
SLOW = [70.0, 40.0, 15.0, 3.5, 30, 50, 40]
CANNOT_CRANK = [70.0, 40.0, 5.0, 3.5, 30, 50, 40]


def _dynamics(sim: Simulator, x) -> CarrierDynamics:
    veh = sim.vehicle(np.array([x], float))
    k = veh.kernel
    return split.carrier_dynamics(
        split_design(k.rows[0], k.c, k.sc), k.G, k.sc.j_start, k.sc.j_gen, k.sc.t_crank, k.sc.w_fire, k.c.dt
    )


def _starts(trace) -> np.ndarray:
    """Carrier speed just before each start (the step before the engine runs again)."""
    on = trace["eng_on"].to_numpy() > 0.5
    w = trace["w_eng_rad_s"].to_numpy()
    idx = np.flatnonzero(on[1:] & ~on[:-1]) + 1
    return w[idx - 1]


def test_a_start_costs_the_spin_up_of_the_reflected_inertia_plus_the_crank_work():
    cd = CarrierDynamics(j=0.47, t_spin=198.0, t_crank=40.0, w_fire=125.66370614359172, dw_max=421.0)
    e, t = start_cost(0.0, cd)
    t_ref = 0.47 * cd.w_fire / (198.0 - 40.0)  # constant net torque from rest
    assert t == pytest.approx(t_ref, rel=1e-12)
    assert e == pytest.approx(0.5 * 0.47 * cd.w_fire**2 + 40.0 * 0.5 * cd.w_fire * t_ref, rel=1e-12)
    # from a spun carrier only the rest of the way; nothing above firing speed; inf when it cannot be cranked
    e2, t2 = start_cost(60.0, cd)
    t2_ref = 0.47 * (cd.w_fire - 60.0) / 158.0
    assert e2 == pytest.approx(
        0.5 * 0.47 * (cd.w_fire**2 - 60.0**2) + 40.0 * 0.5 * (60.0 + cd.w_fire) * t2_ref, rel=1e-12
    )
    assert start_cost(130.0, cd) == (0.0, 0.0)
    assert start_cost(0.0, cd._replace(t_spin=39.0)) == (np.inf, np.inf)


def test_the_carrier_reflects_engine_and_generator_through_willis(sim, lib):
    cd = _dynamics(sim, PRIUS)
    k = 78 / 30
    s_eng, s_gen = 43.0 / lib.engine_hybrid.peak_power_kw, 15.0 / lib.generator.peak_power_kw
    ps = lib.power_split
    assert cd.j == pytest.approx(
        s_eng * ps.engine_startup_inertia_kg_m2 + s_gen * lib.generator.inertia_kg_m2 * (1 + k) ** 2
    )
    assert cd.t_spin == pytest.approx((1 + k) * s_gen * lib.generator.max_torque_nm[0])
    assert cd.t_crank == pytest.approx(s_eng * ps.engine_crank_torque_nm)
    assert cd.w_fire == pytest.approx(1200 * np.pi / 30)
    assert cd.dw_max == pytest.approx(cd.t_spin / cd.j)


@pytest.mark.parametrize("x", [PRIUS, SLOW], ids=["prius-design", "slow-carrier"])
def test_every_start_on_ftp_is_booked_exactly(sim, cycles, x):
    cyc = cycles["ftp"]
    res = sim.run_raw(np.array([x], float), cyc, record=True, performance=False)
    tr = sim.trace(np.array([x], float), cyc)
    cd = _dynamics(sim, x)
    w0 = _starts(tr)
    assert len(w0) == res.frame()["n_starts"].iloc[0] > 5
    expected = sum(start_cost(float(w), cd)[0] for w in w0)
    assert res.frame()["e_engine_start_j"].iloc[0] == pytest.approx(expected, rel=1e-9)
    assert energy_balance(res)["residual_share"].iloc[0] < 1e-9


@pytest.mark.parametrize("x", [PRIUS, SLOW], ids=["prius-design", "slow-carrier"])
def test_the_engine_speed_never_moves_faster_than_the_generator_can_turn_the_carrier(sim, cycles, x):
    cd = _dynamics(sim, x)
    for name in ("ftp", "udds"):
        tr = sim.trace(np.array([x], float), cycles[name])
        on = tr["eng_on"].to_numpy() > 0.5
        w = tr["w_eng_rad_s"].to_numpy()
        both = on[1:] & on[:-1]
        dw = np.abs(np.diff(w))[both]
        assert dw.max() <= cd.dw_max * (1 + 1e-9), (name, dw.max(), cd.dw_max)
        # after a start: from firing speed
        first = np.flatnonzero(on[1:] & ~on[:-1]) + 1
        w_from = np.maximum(w[first - 1], cd.w_fire)
        assert (np.abs(w[first] - w_from) <= cd.dw_max * (1 + 1e-9) + 1e-9).all()


def test_the_rate_window_cuts_the_engine_speeds_and_retakes_the_most_power(sim):
    veh = sim.vehicle(np.array([SLOW], float))
    kv = veh.kernel
    d = split_design(kv.rows[0], kv.c, kv.sc)
    lim = split.limits(10.0, d, kv.E, kv.M, kv.G)
    cut = split.within_rate(lim, lim.lo + 20.0, 10.0, 0.5, d, kv.E, kv.G)
    assert (cut.lo, cut.hi) == pytest.approx((lim.lo + 10.0, lim.lo + 30.0))
    assert cut.p_e_max < lim.p_e_max and (cut.w_ref, cut.j_dt) == (lim.lo + 20.0, 0.5)
    far = split.within_rate(lim, lim.hi + 100.0, 10.0, 0.5, d, kv.E, kv.G)  # out of reach: the gear set wins
    assert (far.lo, far.hi, far.p_e_max) == (lim.lo, lim.hi, lim.p_e_max)
    assert split.within_rate(lim, lim.lo, np.inf, 0.0, d, kv.E, kv.G)._replace(w_ref=0.0) == lim


def test_a_generator_that_cannot_crank_the_engine_leaves_it_off(sim, cycles):
    cd = _dynamics(sim, CANNOT_CRANK)
    assert cd.t_spin <= cd.t_crank
    out = sim.run_raw(np.array([CANNOT_CRANK], float), cycles["ftp"], performance=False).frame().iloc[0]
    assert out["n_starts"] == 0 and out["fuel_g"] == 0 and out["e_engine_start_j"] == 0


def _with_pms(params, **kw):
    return params.model_copy(update={"pms": params.pms.model_copy(update=kw)})


def test_the_coolant_warm_up_keeps_a_cold_engine_on_until_75_c_and_no_longer(lib, params, cycles):
    cyc = cycles["ftp"]
    t_warm = lib.power_split.coolant_warmup_temperature_c
    assert t_warm == 75.0
    on_runs = {}
    for rule in (True, False):
        sim = Simulator(lib, _with_pms(params, coolant_warmup=rule))
        tr = sim.trace(None, cyc, "prius")
        cool = tr["t_coolant_c"].to_numpy()
        on = tr["eng_on"].to_numpy() > 0.5
        moving = cyc.key_on[:-1]  # the step from t to t + 1 is driven (not the soak)
        cold = (cool[:-1] < t_warm) & moving
        on_runs[rule] = (on[1:][cold], on[1:][~(cool[:-1] < t_warm) & moving])
    cold_on, warm_on = on_runs[True]
    assert cold_on.size > 100 and cold_on.all()  # every cold driven step has the engine on
    assert not warm_on.all()  # once warm it stops again (the rule base decides)
    assert not on_runs[False][0].all()  # without the rule the cold engine goes off


@pytest.mark.parametrize("cycle", ["ftp", "udds", "hwfet"])
def test_the_prius_charge_balances_within_one_percent(sim, cycles, params, cycle):
    cyc = cycles[cycle]
    veh = sim.vehicle(None, "prius")
    first = simulate(veh, cyc)
    last, cb = charge_balance(
        veh, cyc, first, tolerance=params.sim.charge_balance_tolerance, max_runs=params.sim.charge_balance_max_runs
    )
    row = cb.iloc[0]
    assert bool(row["charge_balanced"]) and abs(row["charge_balance_residual"]) <= 0.01
    e = last.frame().iloc[0]
    assert abs(e["e_batt_j"]) <= 0.01 * e["e_fuel_j"]
    # the last run started where the previous one ended: the SOC it starts from is what the loop reports
    assert last.soc_init[0] != params.sim.soc_init or row["charge_balance_runs"] == 1
    assert np.isfinite(row["fc_charge_balanced"])


def test_a_design_that_cannot_balance_is_reported_not_hidden(sim, cycles, params):
    X = np.array([PRIUS, CANNOT_CRANK], float)
    out = sim.run(X, cycles["ftp"], charge_balanced=True)
    assert out["charge_balanced"].tolist() == [True, False]
    assert np.isnan(out["fc_charge_balanced"].iloc[1]) and np.isinf(out["charge_balance_residual"].iloc[1])
    assert out["charge_balance_runs"].iloc[1] == params.sim.charge_balance_max_runs


def test_the_conventional_car_balances_on_its_first_run(sim, cycles):
    out = sim.run(None, cycles["ftp"], "conventional", charge_balanced=True).iloc[0]
    assert bool(out["charge_balanced"]) and out["charge_balance_runs"] == 1
    assert out["fc_charge_balanced"] == out["fc"]


def test_switching_both_rules_off_gives_the_plain_rule_base(lib, params, cycles):
    """The study's rule base stays one ``-S`` away: no start costs, no warm-up rule."""
    sim = Simulator(lib, _with_pms(params, coolant_warmup=False, engine_dynamics=False, full_power_above_kw=None))
    o = sim.run_raw(None, cycles["ftp"], "prius", performance=False).frame().iloc[0]
    assert o["e_engine_start_j"] == 0 and o["e_engine_inertia_j"] == 0 and o["n_starts"] > 0


def test_the_study_scale_acceleration_deviation_is_what_the_trace_shows(sim, cycles):
    """``accel_dev_mean_abs`` (beside the objective ``accel_dev``): 100 mean |a_req - a_ach| / max a_req."""
    X = np.array([PRIUS, SLOW], float)
    r = sim.run(X, cycles["udds"])
    tr = sim.trace(X, cycles["udds"])
    for i in range(2):
        d = tr[tr["design"] == i].iloc[1:]
        a_req, a_ach = d["a_req_mps2"].to_numpy(), d["a_ach_mps2"].to_numpy()
        expected = 100 * np.abs(a_req - a_ach).mean() / a_req.max()
        assert r["accel_dev_mean_abs"].iloc[i] == pytest.approx(expected, rel=1e-9, abs=1e-9)


def test_from_25_kw_of_road_power_a_running_engine_gives_full_power(lib, params, cycles):
    """ADVISOR's 'max engine if pwr req>limit': the engine goes to the top of its window at full torque."""
    shares = {}
    for rule in (25.0, None):
        sim = Simulator(lib, _with_pms(params, full_power_above_kw=rule))
        tr = sim.trace(None, cycles["us06"], "prius")
        v_mean = 0.5 * (tr["v_mps"] + tr["v_mps"].shift(1).fillna(0.0))
        p_road = (tr["f_pt_n"] + tr["f_brake_n"]) * v_mean
        hard = (tr["eng_on"] > 0.5) & (p_road >= 27e3)  # above 25 kW at the ring
        full = tr["t_eng_nm"] >= 0.999 * tr["t_eng_max_nm"]
        assert hard.sum() > 20
        shares[rule] = float(full[hard].mean())
    assert shares[25.0] == 1.0 > shares[None]  # without the rule the rule base leaves some of them below
