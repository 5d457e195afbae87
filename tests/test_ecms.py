"""ECMS in the drive step (``pms.strategy: ecms``, hevlib/sim/ecms.py): it holds charge within J1711's 1 %, meets
the traces the rule base meets, closes the energy balance, burns less than the rule base and never less than the
bound; its equivalence factor and SOC feedback act in the right sense; it keeps the warm-up rule; the rule base
is untouched by its settings (a bad setting: tests/test_bound.py)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from hevlib.bound import BoundGrid, fuel_bound
from hevlib.sim.powertrain import layout as L
from hevlib.sim.simulator import TRACE_NAMES, charge_balance, energy_balance, responses, simulate

COARSE = BoundGrid(soc_step=0.001, n_speed=12, n_torque=12)


def _balanced(car, cyc):
    first = simulate(car, cyc)
    last, cb = charge_balance(car, cyc, first, tolerance=0.01, max_runs=10)
    return last, cb.iloc[0], responses(last, cyc, car.library).iloc[0]


@pytest.fixture(scope="module")
def prius(sim):
    car = sim.vehicle(None, "prius")
    return car.with_strategy("fuzzy"), car.with_strategy("ecms")


@pytest.mark.parametrize("name", ["hwfet", "ftp"])
def test_ecms_holds_charge_meets_the_trace_and_burns_less_than_the_rule_base(prius, cycles, name):
    rule, ecms = prius
    cyc = cycles[name]
    _, cb_rule, r_rule = _balanced(rule, cyc)
    last, cb, r = _balanced(ecms, cyc)
    assert bool(cb["charge_balanced"]) and abs(last.out[0, L.O_E_BATT]) <= 0.01 * last.out[0, L.O_E_FUEL]
    assert bool(r["cycle_met"]) and r["speed_dev"] == 0.0 and r["accessory_unmet_kwh"] == 0.0
    eb = energy_balance(last)
    assert eb["residual_share"].abs().iloc[0] < 1e-9 and eb["thermal_residual_share"].abs().iloc[0] < 1e-6
    # the same hardware and trace: ECMS saves some per cent (5-10 % measured), fewer starts than the rule base
    assert cb["fc_charge_balanced"] < 0.97 * cb_rule["fc_charge_balanced"]
    assert r["n_engine_starts"] < r_rule["n_engine_starts"]


def test_ecms_in_the_drive_step_never_beats_the_bound(prius, cycles):
    _, ecms = prius
    cyc = cycles["hwfet"]  # a hot start: the bound's hot map is the run's
    last, cb, r = _balanced(ecms, cyc)
    b = fuel_bound(ecms, cyc, COARSE, float(cb["soc_init_charge_balanced"]))
    assert b.responses["fc_soc_corrected"] <= r["fc_soc_corrected"] < 1.06 * b.responses["fc_soc_corrected"]


def _end_soc(car, cyc, soc0: float, **pms) -> float:
    kernel = car.kernel._replace(pc=car.kernel.pc._replace(**pms))
    out = simulate(type(car)(car.kind, car.design, kernel, car.library).with_soc_init(soc0), cyc).out[0]
    assert out[L.O_N_STEPS] == cyc.n_steps - 1  # every step driven
    return float(out[L.O_SOC_END])


def test_dearer_battery_energy_leaves_the_pack_fuller_and_the_feedback_pulls_to_the_target(prius, cycles):
    _, ecms = prius
    cyc, s0 = cycles["hwfet"], ecms.kernel.pc.ecms_s0
    assert ecms.kernel.pc.soc_target == 0.6 and 2.0 < s0 < 3.5  # 1 / the Prius map's best efficiency
    # a higher factor at the target (battery energy dearer) charges more, a lower one spends the pack
    assert _end_soc(ecms, cyc, 0.6, ecms_s0=1.3 * s0) > _end_soc(ecms, cyc, 0.6, ecms_s0=0.7 * s0) + 0.01
    # the feedback: from below the target it charges, from above it discharges (a flipped sign does the reverse)
    assert _end_soc(ecms, cyc, 0.5, ecms_soc_gain=40.0) > 0.52
    assert _end_soc(ecms, cyc, 0.74, ecms_soc_gain=40.0) < 0.72


def test_ecms_keeps_a_cold_engine_running_until_it_is_warm(prius, cycles):
    _, ecms = prius
    cyc = cycles["ftp"]  # cold start
    run = simulate(ecms, cyc, record=True, performance=False)
    tr = pd.DataFrame(run.traces[0], columns=list(TRACE_NAMES))
    warmup_c = ecms.kernel.pc.t_warmup_c
    cold = tr.index[(tr["t_coolant_c"] < warmup_c - 1.0) & (tr.index > 20)]
    assert len(cold) > 10
    # every step of the cold phase after the first start: the engine runs (or spins up to run)
    first_on = int(tr.index[tr["eng_on"] > 0][0])
    cold = cold[cold > first_on + 1]
    running = (tr.loc[cold, "eng_on"] > 0) | (tr.loc[cold, "spin_part_s"] > 0)
    assert running.mean() > 0.98


def test_the_rule_base_is_untouched_by_the_ecms_settings(prius, cycles):
    rule, _ = prius
    cyc = cycles["ftp"]
    a = simulate(rule, cyc).out
    kernel = rule.kernel._replace(pc=rule.kernel.pc._replace(ecms_s0=9.0, ecms_soc_gain=0.0, ecms_n_speed=2))
    b = simulate(type(rule)(rule.kind, rule.design, kernel, rule.library), cyc).out
    assert np.array_equal(a, b)


def test_a_conventional_car_has_no_supervisory_strategy(sim):
    with pytest.raises(ValueError, match="fuzzy or ecms"):
        sim.vehicle(None, "conventional").with_strategy("ecms")
    with pytest.raises(ValueError, match="fuzzy or ecms"):
        sim.vehicle(None, "prius").with_strategy("dp")
