"""Braking of a power split of today (hevlib/regen_curves.py, ``hev wheel-regen``): FASTSim's regeneration curve
written into a wheel file. The curve must be FASTSim's formula, the file what the command writes, the rest of the
wheel the source's, and a Prius braking through it must recover more and burn less with the balance closed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from hevlib import epa
from hevlib.components.files import load_wheel
from hevlib.engine_curves import render
from hevlib.params import parse_params
from hevlib.regen_curves import CURVES, SPEED_MPH, RegenCurve, tabulation_error, wheel_file
from stages.cli import app

RAW = Path("data/raw/components")
SOURCE, DERIVED = "WH_PRIUS_JPN.yaml", "WH_PRIUS_JPN_FASTSIM_PRIUS_2016_REGEN.yaml"
CURVE = CURVES["fastsim_prius_2016"]


def test_the_committed_file_is_what_the_command_writes(tmp_path):
    out = tmp_path / DERIVED
    res = CliRunner().invoke(
        app, ["wheel-regen", "--source", str(RAW / SOURCE), "--curve", CURVE.name, "--out", str(out)]
    )
    assert res.exit_code == 0, res.output
    assert out.read_text() == (RAW / DERIVED).read_text() == render(wheel_file(RAW / SOURCE, CURVE.name))


def test_the_curve_is_fastsims():
    # fastsim/simdrive.py: max_regen / (1 + regen_a exp(-regen_b (mph + 1))), 0.98, 500, 0.99
    assert CURVE.share(10.0) == pytest.approx(0.98 / (1.0 + 500.0 * np.exp(-0.99 * 11.0)), rel=1e-12)
    assert CURVE.share(10.0) == pytest.approx(0.97095, abs=1e-5)
    assert CURVE.share(5.0) == pytest.approx(0.42314, abs=1e-5)  # fading at walking pace
    assert CURVE.share(0.0) == 0.0 and CURVE.share(-1.0) == 0.0  # nothing at a standstill
    mph = np.linspace(0.01, 20.0, 500)
    assert np.all(np.diff(CURVE.share(mph)) > 0.0) and CURVE.share(80.0) == pytest.approx(0.98, abs=1e-12)
    assert tabulation_error(CURVE) < 0.006


def test_the_wheel_brakes_by_the_curve_and_keeps_the_rest_of_the_source():
    src, new = load_wheel(RAW / SOURCE), load_wheel(RAW / DERIVED)
    for mph in (3.0, 7.25, 10.0, 15.5, 45.0, 70.0):
        v = mph * 0.44704
        read = np.interp(v, new.brake_speed_mps, new.brake_driveline_share)
        assert read == pytest.approx(float(CURVE.share(mph)), abs=0.006), mph
        if mph >= 10.0:  # ADVISOR's 1998 Prius: half from 10 mph up
            assert np.interp(v, src.brake_speed_mps, src.brake_driveline_share) == pytest.approx(0.5)
            assert read > 0.95
    same = ("radius_m", "rolling_resistance", "inertia_kg_m2", "axle_drag_nm_at_0kg", "axle_drag_nm_per_kg")
    assert all(getattr(new, k) == getattr(src, k) for k in same)
    table = yaml.safe_load((RAW / DERIVED).read_text())["braking"]
    total = np.asarray(table["driveline_fraction"]) + np.asarray(table["front_friction_fraction"])
    assert np.all(total <= 1.0 + 1e-9) and table["vehicle_speed_mph"] == list(SPEED_MPH)


def test_a_prius_braking_by_the_curve_recovers_more_and_burns_less(params, cycles):
    """The stock Prius on FTP (its SOC window held by the rule base): the friction brakes take less, the battery
    more, the balance closes to round-off, and it burns less fuel than on ADVISOR's half share."""
    from hevlib.sim.simulator import Simulator, energy_balance, simulate
    from hevlib.sizing import study_library

    out = {}
    for name in (SOURCE, DERIVED):
        wheel = params.baseline.prius.wheel.model_copy(update={"file": name})
        prius = params.baseline.prius.model_copy(update={"wheel": wheel})
        p = params.model_copy(update={"baseline": params.baseline.model_copy(update={"prius": prius})})
        sim = Simulator(study_library(p.baseline), p)
        res = simulate(sim.vehicle(None, "prius"), cycles["ftp"], record=False, performance=False)
        balance = energy_balance(res).iloc[0]
        assert abs(balance["residual_share"]) < 1e-9, name
        out[name] = (res.frame().iloc[0], balance)
    (old, _), (new, _) = out[SOURCE], out[DERIVED]
    assert new["e_brake_j"] < 0.6 * old["e_brake_j"]
    assert new["e_fuel_j"] - new["e_batt_j"] < old["e_fuel_j"] - old["e_batt_j"]


def test_a_2022_hybrid_gets_todays_braking_and_the_study_keeps_advisors():
    params = parse_params(yaml.safe_load(Path("params.yaml").read_text()))
    assert params.epa.wheel_power_split == DERIVED and params.baseline.prius.wheel.file == SOURCE
    car = epa.find_car(epa.read_test_car_list(), "TOYOTA", "COROLLA HYBRID")
    today = epa.profile_overrides(epa.car_profile(car, params.baseline, parts=params.epa))
    assert today["baseline.prius.wheel"]["file"] == DERIVED
    study = epa.profile_overrides(epa.car_profile(car, params.baseline))
    assert study["baseline.prius.wheel"]["file"] == SOURCE


def test_a_bad_curve_stops_in_one_line(tmp_path):
    res = CliRunner().invoke(
        app, ["wheel-regen", "--source", str(RAW / SOURCE), "--curve", "ev", "--out", str(tmp_path / "x.yaml")]
    )
    assert res.exit_code != 0 and "fastsim_prius_2016" in res.output and not (tmp_path / "x.yaml").exists()
    with pytest.raises(ValueError, match="max_regen"):
        RegenCurve("x", 1.2, 500.0, 0.99, "s")
