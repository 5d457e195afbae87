"""The charge-sustaining fuel bound (hevlib.bound, ``hev bound``): below the rule base on the same hardware,
charge-sustaining, never better than the engine's best efficiency allows, costlier with engine starts than
without, converged in its grid; the step's candidates reduced to their fuel-battery front; ECMS on the same
candidates between the bound and the rule base, holding charge by its SOC feedback; the stage end to end."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import yaml
from typer.testing import CliRunner

from hevlib.bound import (
    TRACE_COLUMNS,
    BoundGrid,
    Ecms,
    Infeasible,
    _admitted,
    _forward,
    _front,
    controls,
    ecms_fuel,
    fuel_bound,
    gear_bound,
)
from hevlib.controller_gap import controller_gap
from hevlib.design import DESIGN_VARS
from hevlib.params import ParamsError, load_params
from hevlib.sim.ecms import equivalence_factor
from hevlib.sim.powertrain import layout as L
from hevlib.sim.simulator import charge_balance, responses, simulate

#: A coarse grid: the tests' bounds in seconds (the params' finer grid moves them by < 0.3 %).
COARSE = BoundGrid(soc_step=0.001, n_speed=12, n_torque=12)


@pytest.fixture(scope="module")
def prius_hwfet(sim, cycles):
    """The stock Prius on HWFET: the rule base's charge-balanced run and the bound from the SOC it starts from."""
    cyc = cycles["hwfet"]
    car = sim.vehicle(None, "prius")
    first = simulate(car, cyc)
    last, cb = charge_balance(car, cyc, first, tolerance=0.01, max_runs=10)
    soc0 = float(cb["soc_init_charge_balanced"].iloc[0])
    return car, cyc, last, soc0, fuel_bound(car, cyc, COARSE, soc0)


def test_the_front_keeps_exactly_the_candidates_no_other_beats_in_fuel_and_battery_power():
    rng = np.random.default_rng(3)
    fuel, p = rng.uniform(0, 1, 200), rng.uniform(-1, 1, 200)
    kept = set(_front(fuel, p, 200).tolist())
    brute = {i for i in range(200) if not np.any((fuel <= fuel[i]) & (p <= p[i]) & ((fuel < fuel[i]) | (p < p[i])))}
    assert kept == brute
    assert np.all(np.diff(p[_front(fuel, p, 200)]) > 0)  # in order of rising battery power, falling fuel


def test_charging_beyond_the_pack_is_shed_to_the_friction_brakes_only_within_the_regeneration():
    assert _admitted(-5e3, 0.0, 20e3, 10e3) == -5e3  # within the limits: itself
    assert _admitted(-15e3, 8e3, 20e3, 10e3) == -10e3  # 5 kW too much, 8 kW of regeneration to shed: the limit
    assert np.isnan(_admitted(-15e3, 4e3, 20e3, 10e3))  # 5 kW too much, only 4 kW to shed: not admissible
    assert np.isnan(_admitted(25e3, 1e9, 20e3, 10e3))  # discharging beyond the pack: never


def test_the_bound_is_below_the_rule_base_and_holds_charge(prius_hwfet, sim):
    car, cyc, last, soc0, b = prius_hwfet
    rule = responses(last, cyc, car.library).iloc[0]
    assert b.soc_init == soc0 and soc0 - 1e-3 <= b.soc_end <= soc0 + 0.01  # charge-sustaining, no hoarding
    assert b.responses["n_engine_starts"] >= 1
    # the rule base's balanced run, SOC-corrected (HWFET starts hot: no cold surplus), burns more
    assert rule["fc_soc_corrected"] > 1.05 * b.responses["fc_soc_corrected"]
    assert b.responses["fc_soc_corrected"] == pytest.approx(b.responses["fc"], rel=0.01)
    # the bound drives the whole trace
    assert b.out[L.O_DIST_M] == pytest.approx(cyc.distance_m, rel=1e-9)


def test_the_bound_never_beats_the_engine_at_its_best_efficiency(prius_hwfet, lib):
    car, cyc, last, soc0, b = prius_hwfet
    # the road takes this much at the wheels (the rule base meets the same trace) and the accessories theirs; the
    # battery ends no emptier: all of it came from fuel, at best at the engine's peak efficiency
    needed = last.out[0, L.O_E_ROAD] + last.out[0, L.O_E_ACC]
    assert b.out[L.O_E_FUEL] * lib.engine_hybrid.max_efficiency() > needed
    assert b.out[L.O_E_FUEL] == pytest.approx(b.out[L.O_FUEL_G] * lib.engine_hybrid.lhv_j_per_g)


def test_engine_starts_cost_the_bound_fuel(prius_hwfet, lib, params):
    from hevlib.sim.simulator import Simulator

    car, cyc, _, soc0, b = prius_hwfet
    free = params.model_copy(update={"pms": params.pms.model_copy(update={"engine_dynamics": False})})
    b_free = fuel_bound(Simulator(lib, free).vehicle(None, "prius"), cyc, COARSE, soc0)
    assert b_free.responses["fc_soc_corrected"] < b.responses["fc_soc_corrected"]
    assert b_free.responses["n_engine_starts"] >= b.responses["n_engine_starts"]


def test_the_bound_converges_in_its_soc_grid(prius_hwfet):
    car, cyc, _, soc0, b = prius_hwfet
    half = fuel_bound(car, cyc, COARSE._replace(soc_step=COARSE.soc_step / 2), soc0)
    assert half.responses["fc_soc_corrected"] == pytest.approx(b.responses["fc_soc_corrected"], rel=0.005)


def test_ecms_holds_charge_between_the_bound_and_the_rule_base(prius_hwfet):
    car, cyc, last, soc0, b = prius_hwfet
    rule = responses(last, cyc, car.library).iloc[0]
    e = ecms_fuel(car, cyc, COARSE, 20.0, soc0, tolerance=0.01, max_runs=10)
    assert e.balanced and abs(e.run.out[L.O_E_BATT]) <= 0.01 * e.run.out[L.O_E_FUEL]  # SAE J1711's 1 %
    fc = e.run.responses["fc_soc_corrected"]
    # a causal controller on the bound's candidates: never below the bound, well below the rule base on HWFET
    assert b.responses["fc_soc_corrected"] <= fc < 0.97 * rule["fc_soc_corrected"]
    assert fc < 1.05 * b.responses["fc_soc_corrected"]
    assert e.run.out[L.O_DIST_M] == pytest.approx(cyc.distance_m, rel=1e-9)
    assert e.settings.s0 == pytest.approx(_s0(car)) and e.settings.soc_target == 0.6  # PTC_PRIUS_JPN


def _s0(car) -> float:
    return equivalence_factor(car.kernel.E, car.kernel.c.lhv_j_per_g)


def test_the_equivalence_factor_is_the_reciprocal_of_the_engines_best_efficiency(sim, lib):
    car = sim.vehicle(None, "prius")
    assert _s0(car) == pytest.approx(1 / lib.engine_hybrid.max_efficiency(), rel=0.02)
    assert car.kernel.pc.ecms_s0 == _s0(car)  # what the drive step's ECMS and the bound's are handed


def _ecms_end_soc(car, cyc, ctl, soc0: float, s0: float, gain: float) -> float:
    sc = car.kernel.sc
    step = (sc.soc_max - sc.soc_min) / round((sc.soc_max - sc.soc_min) / COARSE.soc_step)
    record = np.zeros((cyc.n_steps, len(TRACE_COLUMNS)))
    ecms = Ecms(s0=s0, gain=gain, soc_target=0.6)
    o = _forward(car.kernel, 0, ctl, soc0, np.zeros((1, 2, 1)), sc.soc_min, step, ecms, np.zeros(L.N_O), record)
    assert np.isfinite(o[L.O_SOC_END])
    return float(o[L.O_SOC_END])


def test_ecms_charges_more_when_battery_energy_is_dearer_and_its_feedback_pulls_to_the_target(prius_hwfet):
    car, cyc, _, _, _ = prius_hwfet
    ctl = controls(car, cyc, COARSE)
    s0 = _s0(car)
    # a dearer battery (a higher factor at the target) leaves the pack fuller
    assert _ecms_end_soc(car, cyc, ctl, 0.6, 1.2 * s0, 20.0) > _ecms_end_soc(car, cyc, ctl, 0.6, 0.8 * s0, 20.0) + 0.01
    # feedback: below the target it charges, above it discharges
    assert _ecms_end_soc(car, cyc, ctl, 0.5, s0, 40.0) > 0.5
    assert _ecms_end_soc(car, cyc, ctl, 0.72, s0, 40.0) < 0.72


def test_a_bound_is_for_one_power_split_car(sim, cycles):
    with pytest.raises(ValueError, match="one power-split vehicle"):
        fuel_bound(sim.vehicle(None, "conventional"), cycles["hwfet"], COARSE)
    with pytest.raises(ValueError, match="the conventional car expected"):
        gear_bound(sim.vehicle(None, "prius"), cycles["hwfet"])


def test_the_best_gear_on_every_step_burns_a_little_less_than_the_shift_logic(sim, cycles):
    from hevlib.controller_gap import cold_share

    car, ftp = sim.vehicle(None, "conventional"), cycles["ftp"]
    run = simulate(car, ftp)
    shift_logic_hot = responses(run, ftp, car.library)["fc"].iloc[0] * (1.0 - cold_share(run.out[0]))
    bound = gear_bound(car, ftp)
    # the same engine, gearbox and trace: only the gear differs, so a few per cent at most, never more fuel
    assert 0.9 * shift_logic_hot < bound["fc"] < shift_logic_hot
    assert bound["fc_soc_corrected"] == bound["fc"]  # no battery


def test_a_trace_no_control_can_drive_is_said(sim, cycles):
    # the stock Prius does not meet US06 under the rule base: the bound, which follows the trace exactly, has no
    # admissible control on some step, and the gap table says so instead of a figure
    with pytest.raises(Infeasible, match="no admissible control on step"):
        fuel_bound(sim.vehicle(None, "prius"), cycles["us06"], COARSE)
    gap = controller_gap({"prius": sim.vehicle(None, "prius")}, {"us06": cycles["us06"]}, COARSE, ecms_gain=20.0)
    table = gap.table
    assert np.isnan(table["bound_fc"].iloc[0]) and "does not meet the trace" in table["note"].iloc[0]
    # its SOC traces all the same: the rule base's and ECMS's where they ran, none for the bound
    assert len(gap.soc) == cycles["us06"].n_steps and gap.soc["soc_bound"].isna().all()
    assert gap.soc["soc_rule"].notna().all()


@pytest.mark.parametrize(
    ("group", "change", "message"),
    [
        ("bound", {"soc_step": 0.0}, "bound.soc_step"),
        ("bound", {"n_speed": 1}, "bound.n_speed"),
        ("bound", {"cycles": ["wltp"]}, "bound.cycles: 'wltp' is not one of cycles.cycles"),
        ("bound", {"grid": 3}, "bound.grid: unknown key"),
        ("bound", {"ecms_soc_gain": 20.0}, "bound.ecms_soc_gain: unknown key"),  # moved to pms (both ECMS read it)
        ("pms", {"strategy": "dp"}, "pms.strategy"),
        ("pms", {"ecms_soc_gain": -1.0}, "pms.ecms_soc_gain"),
        ("pms", {"ecms_n_torque": 1}, "pms.ecms_n_torque"),
        ("pms", {"ecms_n_speed": 0}, "pms.ecms_n_speed"),
    ],
)
def test_bad_controller_settings_stop_with_one_line_naming_the_key(tmp_path, root, group, change, message):
    raw = yaml.safe_load((root / "params.yaml").read_text())
    raw[group].update(change)
    path = tmp_path / "params.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    with pytest.raises(ParamsError, match=message.replace(".", r"\.")):
        load_params(path)


def test_validate_reads_the_table_where_bound_writes_it():
    import stages.bound
    import stages.validate

    assert (stages.validate.GAP, stages.validate.SOC) == (stages.bound.GAP, stages.bound.SOC)


def test_hev_bound_writes_the_gap_of_each_pick_and_both_cars(stage_dir, root):
    from hevlib.validation import recommended_gap
    from stages.cli import app, register_all

    register_all()
    rec = json.loads((root / "reports/validation.json").read_text())["recommendation"]["design"]
    picks = pd.DataFrame([{"design_id": rec["design_id"], **rec["design"]}])
    (stage_dir / "data/pareto").mkdir(parents=True)
    picks[["design_id", *DESIGN_VARS]].to_parquet(stage_dir / "data/pareto/selected.parquet")
    raw = yaml.safe_load((stage_dir / "params.yaml").read_text())
    raw["bound"] = {"soc_step": 0.001, "n_speed": 12, "n_torque": 12, "cycles": ["hwfet", "us06"]}
    (stage_dir / "params.yaml").write_text(yaml.safe_dump(raw, sort_keys=False))
    out = CliRunner().invoke(app, ["bound"])
    assert out.exit_code == 0, out.output
    report = json.loads((stage_dir / "reports/bound.json").read_text())
    rows = {(r["vehicle"], r["cycle"]): r for r in report["rows"]}
    assert set(rows) == {(v, c) for v in ("conventional", "prius", rec["design_id"]) for c in ("hwfet", "us06")}
    table = pd.read_parquet(stage_dir / "data/bound/gap.parquet")  # the table validate reads: the report's rows
    assert table.set_index(["vehicle", "cycle"])["rule_fc_hot"].to_dict() == pytest.approx(
        {k: r["rule_fc_hot"] for k, r in rows.items()}, rel=1e-11
    )
    conventional = rows[("conventional", "hwfet")]  # its shift logic against its best gear on every step
    assert 0.0 <= conventional["gap_pct"] < 5.0 and conventional["rule_cold_pct"] == 0.0
    hw = rows[(rec["design_id"], "hwfet")]
    assert hw["bound_fc"] < hw["rule_fc_hot"] and hw["gap_pct"] == pytest.approx(
        100 * (hw["rule_fc_hot"] / hw["bound_fc"] - 1)
    )
    assert rows[("prius", "us06")]["bound_fc"] is None  # no bound where the rule base leaves the trace
    c = report["by_cycle"]["hwfet"]
    assert c["gap_pct"]["median"] == pytest.approx(hw["gap_pct"]) and c["picks_with_bound"] == 1
    assert hw["bound_fc"] <= hw["ecms_fc"] < hw["rule_fc_hot"] and hw["ecms_gap_pct"] == pytest.approx(
        100 * (hw["ecms_fc"] / hw["bound_fc"] - 1)
    )
    assert c["ecms_gap_pct"]["median"] == pytest.approx(hw["ecms_gap_pct"]) and report["settings"]["ecms_soc_gain"] > 0
    # ECMS in the drive step: between the bound and the rule base on the highway
    assert hw["bound_fc"] <= hw["ecms_drive_fc_hot"] < hw["rule_fc_hot"] and hw["ecms_drive_gap_pct"] == pytest.approx(
        100 * (hw["ecms_drive_fc_hot"] / hw["bound_fc"] - 1)
    )
    assert c["ecms_drive_gap_pct"]["max"] == pytest.approx(hw["ecms_drive_gap_pct"])
    assert c["ecms_drive_over_rule_pct"]["median"] < 0 and c["picks_meeting_under_ecms_drive"] == 1
    # the grid convergence on the first cycle: every power-split vehicle with a bound, the finer candidates on two
    cv = report["convergence"]
    assert cv["cycle"] == "hwfet" and {e["vehicle"] for e in cv["rows"]} == {"prius", rec["design_id"]}
    assert cv["soc_step_halved_pct_max_abs"] < 0.5 and all(e["candidates_doubled_pct"] is not None for e in cv["rows"])
    # the headline saving under each controller (validate's, from this table)
    gap = recommended_gap(table, [rec["design_id"]], rec["design_id"])
    sv = gap["by_cycle"]["hwfet"]["saving_pct"]
    assert sv["rule"] == pytest.approx(100 * (1 - hw["rule_fc_hot"] / conventional["rule_fc_hot"]))
    assert sv["bound_both"] == pytest.approx(100 * (1 - hw["bound_fc"] / conventional["bound_fc"]))
    assert sv["rule"] < sv["ecms"] <= sv["bound"] and sv["rule"] < sv["ecms_drive"] <= sv["bound"]
    assert gap["by_cycle"]["us06"]["vehicles"]["prius"]["fc_l_100km"]["bound"] is None
    with pytest.raises(ValueError, match="no row for oracle-999"):
        recommended_gap(table, ["oracle-999"], None)
    # SOC under each controller on the first cycle, each from its own start
    soc = pd.read_parquet(stage_dir / "data/bound/soc.parquet")
    one = soc[soc["vehicle"] == rec["design_id"]]
    n_steps = len(pd.read_parquet(stage_dir / "data/cycles/hwfet.parquet"))
    assert set(soc["vehicle"]) == {"prius", rec["design_id"]} and len(one) == n_steps
    assert abs(one["soc_rule"].iloc[0] - hw["soc_init"]) < 0.01  # both from the rule base's balanced start
    assert abs(one["soc_bound"].iloc[0] - hw["soc_init"]) < 0.01 and one["soc_bound"].iloc[-1] >= hw["soc_init"] - 2e-3
    assert one["soc_ecms_drive"].notna().all() and soc.loc[soc["vehicle"] == "prius", "soc_bound"].notna().all()
    assert (stage_dir / "reports/bound.md").read_text().startswith("# The controller's gap")
    assert (stage_dir / "reports/plots/bound/gap.png").stat().st_size > 0
