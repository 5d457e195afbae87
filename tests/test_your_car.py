"""Another car and another cycle from params alone (issue 40; docs/your-car.md): the sedan profile's car is
the study's conversion recipe applied to a heavier, larger, more powerful car on WLTC, and it behaves as
physics says (the whole pipeline for it from a fresh clone: tests/test_reproducible.py)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from hevlib.cycles import build_cycles
from hevlib.params import parse_params
from hevlib.profiles import apply_overrides, load_profile
from hevlib.sim.simulator import Simulator, energy_balance
from hevlib.sizing import study_library

REPO = Path(__file__).resolve().parents[1]


def _sedan_params():
    base = yaml.safe_load((REPO / "params.yaml").read_text())
    return parse_params(apply_overrides(base, load_profile("sedan", REPO / "params.yaml", REPO / "profiles")))


def _conventional_on(params, cycle):
    sim = Simulator(study_library(params.baseline), params)
    raw, resp = sim.drive(sim.vehicle(None, "conventional"), cycle, charge_balanced=True)
    return resp.iloc[0], energy_balance(raw).iloc[0], sim


def test_the_sedan_burns_more_and_tops_out_lower_than_the_study_car_on_wltc(params):
    """1 500 kg, Cd A 0.69 m2 and 100 kW against 1 195 kg, 0.387 m2 and 70 kW: more fuel on the WLTC (more
    mass to accelerate, more drag, a larger engine at part load) and a lower top speed (drag grows with v^3:
    (100 / 0.69)^(1/3) < (70 / 0.387)^(1/3)); the same energy balance closes."""
    sedan = _sedan_params()
    wltc = build_cycles(sedan.cycles)["wltc"]
    car, car_balance, sim = _conventional_on(sedan, wltc)
    study, _, study_sim = _conventional_on(params, wltc)
    assert sim.lib.body_conventional.drag_coefficient == 0.30 and sim.lib.wheel_conventional.radius_m == 0.317
    assert car["m_veh"] == pytest.approx(1500.0) and study["m_veh"] == pytest.approx(1195.0)
    assert car["speed_dev"] == 0.0 and study["speed_dev"] == 0.0  # both drive the whole trace
    assert car["fc"] > 1.15 * study["fc"], (car["fc"], study["fc"])
    assert car["v_max"] < study["v_max"], (car["v_max"], study["v_max"])
    assert abs(car_balance["residual_share"]) < 1e-9
