"""Params profiles (`hev profile NAME`): dotted-key overrides checked against params.yaml before any stage
runs, a leading + adding a key (a new cycle, its start state), and `-S` words DVC splits right."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from hevlib.params import ParamsError, parse_params
from hevlib.profiles import apply_overrides, load_profile, set_args

REPO = Path(__file__).resolve().parents[1]
BASE = yaml.safe_load((REPO / "params.yaml").read_text())


def test_an_override_must_land_on_a_key_unless_it_adds_one():
    with pytest.raises(ParamsError, match=r"^profile: screen.n_kep: no such params key \(\+ adds one\)$"):
        apply_overrides(BASE, {"screen.n_kep": 3})
    with pytest.raises(ParamsError, match=r"^profile: scren: no such params key$"):
        apply_overrides(BASE, {"scren.n_keep": 3})
    with pytest.raises(ParamsError, match=r"^profile: \+screen.n_keep: already exists \(drop the \+\)$"):
        apply_overrides(BASE, {"+screen.n_keep": 3})
    out = apply_overrides(BASE, {"+cycles.cycles.wltc": {"file": "CYC_WLTC3B.csv"}, "+sim.start.wltc": "hot"})
    assert out["cycles"]["cycles"]["wltc"] == {"file": "CYC_WLTC3B.csv"} and out["sim"]["start"]["wltc"] == "hot"
    assert "wltc" not in BASE["cycles"]["cycles"]  # a copy: params.yaml's mapping is untouched
    assert parse_params(out).cycles.cycles["wltc"].grade_pct is None


@pytest.mark.parametrize("name", ["fast", "sedan"])
def test_the_shipped_profiles_validate_and_give_one_word_per_value(name):
    overrides = load_profile(name, REPO / "params.yaml", REPO / "profiles")
    args = set_args(overrides)
    assert args[::2] == ["-S"] * len(overrides)
    assert [a.split("=", 1)[0] for a in args[1::2]] == list(overrides)
    assert not any(ch.isspace() for a in args for ch in a)


def test_a_long_mapping_stays_one_word_in_its_order():
    args = set_args(
        {"+cycles.cycles.wltc": {"file": "CYC_WLTC3B.csv", "grade_pct": 1.5, **{f"k{i}": i for i in range(30)}}}
    )
    assert args[1].startswith("+cycles.cycles.wltc={file:CYC_WLTC3B.csv,grade_pct:1.5,k0:0,k1:1,")
