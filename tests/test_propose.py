"""`hev propose` (hevlib/proposal.py): a starting profile for another car, its gear ratios and design space scaled
from params.yaml's car; docs/your-car.md."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from hevlib.params import parse_params
from hevlib.profiles import apply_overrides, load_profile
from hevlib.proposal import Reference, check_proposal, propose
from stages.cli import app

REPO = Path(__file__).resolve().parents[1]
RAW = yaml.safe_load((REPO / "params.yaml").read_text())
REF = Reference.from_params(RAW)


def _space(mass_kg, power_kw, radius=None) -> dict:
    return {
        k.removeprefix("design_space."): v
        for k, v in propose(REF, mass_kg, power_kw, radius).overrides().items()
        if k.startswith("design_space.")
    }


def test_the_study_cars_own_figures_give_back_its_design_space_and_ratios():
    car = RAW["baseline"]["conventional"]
    overrides = propose(REF, car["test_mass_kg"], car["p_eng_kw"], car["wheel"]["radius_m"]).overrides()
    for name, bounds in RAW["design_space"].items():
        assert overrides[f"design_space.{name}"] == pytest.approx(bounds), name
    assert overrides["baseline.conventional.gear_ratios"] == pytest.approx(car["gear_ratios"])
    assert overrides["screen.mass_max_kg"] == car["test_mass_kg"]


def test_a_heavier_more_powerful_car_gets_a_larger_kit_and_larger_wheels_longer_ratios():
    base, suv = _space(1195, 70), _space(1650, 110, 0.34)
    for name in ("p_eng_kw", "p_mot_kw", "p_gen_kw", "n_bat"):
        assert suv[name][0] > base[name][0] and suv[name][1] > base[name][1], name
    assert suv["p_eng_kw"] == pytest.approx([25 * 1650 / 1195, 110.0], abs=0.05)  # lower: mass, upper: power
    assert suv["i0"][1] == pytest.approx(4.5 * 0.34 / 0.282, abs=0.005) and suv["n_r"] == base["n_r"]
    ratios = propose(REF, 1650, 110, 0.34).overrides()["baseline.conventional.gear_ratios"]
    assert ratios[0] == pytest.approx(13.195 * 0.34 / 0.282, abs=1e-3)
    # the same mass, more power: the same lower bounds, higher upper ones; a lighter car: lower lower bounds
    sporty, light = _space(1195, 100), _space(900, 50)
    assert sporty["p_eng_kw"][0] == base["p_eng_kw"][0] and sporty["p_eng_kw"][1] > base["p_eng_kw"][1]
    assert light["p_eng_kw"][0] < base["p_eng_kw"][0] and light["p_eng_kw"][1] < base["p_eng_kw"][1]


def test_the_proposal_validates_with_the_params():
    proposal = propose(REF, 1650, 110, 0.34, drag_coefficient=0.33, frontal_area_m2=2.6)
    check_proposal(proposal, RAW)
    p = parse_params(apply_overrides(RAW, proposal.overrides()))
    assert p.baseline.conventional.body.drag_coefficient == 0.33 and p.baseline.conventional.wheel.radius_m == 0.34
    assert p.doe.method == "lhs" and p.design_space.n_bat[1] == 95


def test_hev_propose_writes_a_profile_hev_profile_takes(project):
    runner = CliRunner()
    out = runner.invoke(app, ["propose", "--mass-kg", "1650", "--power-kw", "110", "--out", "profiles/suv.yaml"])
    assert out.exit_code == 0, out.output
    text = (project / "profiles" / "suv.yaml").read_text()
    assert text.startswith("# A starting point, not an answer: a 1650 kg, 110 kW car")
    assert "dvc exp run $(hev profile suv)" in text and "lower x 1.381 (mass), upper x 1.571 (power)" in text
    shown = runner.invoke(app, ["profile", "suv"])
    assert shown.exit_code == 0, shown.output
    assert "design_space.p_eng_kw=[34.5,110.0]" in shown.output.split()
    overrides = load_profile("suv", "params.yaml", "profiles")
    assert "baseline.conventional.wheel.radius_m" not in overrides  # no radius given: params.yaml's wheels


@pytest.mark.parametrize(
    "args, message",
    [
        (["--mass-kg", "-1650", "--power-kw", "110"], "--mass-kg: -1650 kg: must be a positive number"),
        (["--mass-kg", "1650", "--power-kw", "0"], "--power-kw: 0 kW: must be a positive number"),
        (["--mass-kg", "5000", "--power-kw", "110"], "test_mass_kg: Input should be less than or equal to 4000"),
    ],
)
def test_hev_propose_refuses_a_bad_argument_in_one_line_and_writes_nothing(project, args, message):
    out = CliRunner().invoke(app, ["propose", *args, "--out", "profiles/x.yaml"])
    assert out.exit_code == 1
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and message in lines[0], lines
    assert not (project / "profiles").exists()
