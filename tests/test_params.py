"""The params contract: a bad key, type or value stops a stage with one line naming the key, no output."""

from __future__ import annotations

import copy

import pytest
import yaml
from typer.testing import CliRunner

from hevlib.params import ParamsError, load_params, parse_params
from stages.cli import app


@pytest.fixture(scope="module")
def raw_params(root) -> dict:
    return yaml.safe_load((root / "params.yaml").read_text())


def _with(raw_params: dict, path: str, value) -> dict:
    """A copy of the params with the dotted key ``path`` set to ``value``."""
    data = copy.deepcopy(raw_params)
    *parents, leaf = path.split(".")
    node = data
    for key in parents:
        node = node[key]
    node[leaf] = value
    return data


def test_repository_params_are_valid(params):
    assert params.cycles.sizing == "udds" and params.cycles.validation == "ftp"
    assert params.cycles.cycles["udds"].grade_pct == 20.0 and params.cycles.cycles["ftp"].grade_pct == 0.0
    conv = params.baseline.conventional
    assert conv.p_eng_kw == 70.0 and conv.test_mass_kg == 1195.0
    assert params.baseline.prius.n_bat == 25 and params.baseline.battery == "li_ion"


BAD = [
    ("cycles.step_size", 1.0, "cycles.step_size: unknown key"),
    ("baseline.prius.mass", 1.0, "baseline.prius.mass: unknown key"),
    ("cycles.step_s", "fast", "cycles.step_s: Input should be a valid number"),
    ("baseline.prius.n_bat", 2.5, "baseline.prius.n_bat: Input should be a valid integer"),
    ("cycles.step_s", 0.0, "cycles.step_s: Input should be greater than 0"),
    ("cycles.cycles.udds.grade_pct", 45.0, "cycles.cycles.udds.grade_pct: Input should be less than or equal to 30"),
    ("baseline.conventional.test_mass_kg", -5, "baseline.conventional.test_mass_kg: Input should be greater than 500"),
    ("baseline.battery", "lead_acid", "baseline.battery: 'lead_acid' is not one of batteries (li_ion, nimh)"),
    ("baseline.conventional.body.file", "VEH_EV1.txt", "baseline.conventional.body.file: String should match pattern"),
    ("baseline.conventional.body.drag_coefficient", -0.3, "baseline.conventional.body.drag_coefficient: Input should"),
    ("baseline.conventional.wheel.spokes", 5, "baseline.conventional.wheel.spokes: unknown key"),
    ("cycles.sizing", "wltp", "cycles.sizing: 'wltp' is not one of cycles.cycles"),
    ("baseline.prius.n_s", 80, "baseline.prius.n_s: 80 sun teeth must be fewer than n_r = 78"),
    ("cycles.cycles.udds.file", "udds.txt", "cycles.cycles.udds.file: String should match pattern"),
    ("baseline.conventional.upshift_kmh", [40.0, 24.0, 64.0, 75.0], "baseline.conventional.upshift_kmh: speeds"),
    ("optimise.tsparego.subset", 1, "optimise.tsparego.subset: Input should be greater than or equal to 2"),
    ("optimise.tsparego.tr_init", 0.9, "optimise.tsparego.tr_init: must lie in [tr_min, tr_max] = [0.02, 0.8]"),
    ("optimise.tsparego.trust", 0.5, "optimise.tsparego.trust: unknown key"),
]

#: A coast-down road load (the 2022 Corolla 20-ZE2C/2's, lbf and mph) and a body that takes it.
COAST_DOWN = {"a_lbf": 27.485, "b_lbf_per_mph": -0.10848, "c_lbf_per_mph2": 0.02012}
CD_BODY = {"file": "VEH_EV1.yaml", "cg_height_m": 0.4, "coast_down": COAST_DOWN}
BAD += [
    # both forms of the road load, one way or the other
    (
        "baseline.conventional.body.coast_down",
        COAST_DOWN,
        "baseline.conventional.body.coast_down: give the road load as coast_down or as drag_coefficient and "
        "frontal_area_m2, not both",
    ),
    (
        "baseline.prius.body",
        {**CD_BODY, "file": "VEH_PRIUS_JPN.yaml", "frontal_area_m2": 1.746},
        "baseline.prius.body.coast_down: give the road load as coast_down or as frontal_area_m2, not both",
    ),
    # an incomplete one, an unknown key, a wrong type, out of range, a road load negative at some speed
    (
        "baseline.conventional.body",
        {**CD_BODY, "coast_down": {"a_lbf": 27.5, "b_lbf_per_mph": 0.1}},
        "baseline.conventional.body.coast_down.c_lbf_per_mph2: Field required",
    ),
    (
        "baseline.conventional.body",
        {**CD_BODY, "coast_down": {**COAST_DOWN, "d_lbf": 1.0}},
        "baseline.conventional.body.coast_down.d_lbf: unknown key",
    ),
    (
        "baseline.conventional.body",
        {**CD_BODY, "coast_down": {**COAST_DOWN, "a_lbf": "27"}},
        "baseline.conventional.body.coast_down.a_lbf: Input should be a valid number",
    ),
    (
        "baseline.conventional.body",
        {**CD_BODY, "coast_down": {**COAST_DOWN, "c_lbf_per_mph2": 0.0}},
        "baseline.conventional.body.coast_down.c_lbf_per_mph2: Input should be greater than 0",
    ),
    (
        "baseline.conventional.body",
        {**CD_BODY, "coast_down": {**COAST_DOWN, "b_lbf_per_mph": -2.0}},
        "baseline.conventional.body.coast_down.b_lbf_per_mph: -2 makes A + B v + C v^2 negative at 49.7 mph",
    ),
    (  # neither coefficient form: an empty coast-down (null is no coast-down: the body file's drag then)
        "baseline.conventional.body",
        {**CD_BODY, "coast_down": {}},
        "baseline.conventional.body.coast_down.a_lbf: Field required (and 2 more errors)",
    ),
    # the tyres' rolling resistance beside a coast-down (whose A term is the rolling resistance)
    (
        "baseline.conventional.wheel.rolling_resistance",
        0.009,
        "baseline.conventional.wheel: rolling_resistance must be left out: body.coast_down gives the rolling term",
    ),
]


@pytest.mark.parametrize("key, value, message", BAD)
def test_bad_params_name_the_key_in_one_line(raw_params, key, value, message):
    data = raw_params
    if key.endswith(".rolling_resistance"):  # a coast-down body for the wheel to clash with
        data = _with(raw_params, "baseline.conventional.body", CD_BODY)
    with pytest.raises(ParamsError) as info:
        parse_params(_with(data, key, value), "bad.yaml")
    msg = str(info.value)
    assert msg.startswith(f"bad.yaml: {message}"), msg
    assert "\n" not in msg


def test_a_coast_down_body_validates_and_gives_its_road_load_in_si(raw_params):
    """A body with a coast-down and no drag coefficient or frontal area is valid, for either car; its values are the
    coefficients in SI (lbf = 4.4482216152605 N exactly, mph = 0.44704 m/s exactly)."""
    data = _with(raw_params, "baseline.conventional.body", CD_BODY)
    data = _with(data, "baseline.prius.body", {"file": "VEH_PRIUS_JPN.yaml", "coast_down": COAST_DOWN})
    p = parse_params(data)
    values = p.baseline.conventional.body.values()
    assert values == {
        "cg_height_m": 0.4,
        "road_load_a_n": pytest.approx(27.485 * 4.4482216152605, rel=1e-15),
        "road_load_b_n_per_mps": pytest.approx(-0.10848 * 4.4482216152605 / 0.44704, rel=1e-15),
        "road_load_c_n_per_mps2": pytest.approx(0.02012 * 4.4482216152605 / 0.44704**2, rel=1e-15),
    }
    assert p.baseline.prius.body.values().keys() == {"road_load_a_n", "road_load_b_n_per_mps", "road_load_c_n_per_mps2"}
    # the study's bodies have none: their values are what they were
    assert parse_params(raw_params).baseline.conventional.body.values() == {
        "drag_coefficient": 0.19,
        "frontal_area_m2": 2.038,
        "cg_height_m": 0.4,
    }


def test_bad_cycle_name_and_file_errors(raw_params, tmp_path):
    data = copy.deepcopy(raw_params)
    data["cycles"]["cycles"]["Bad-Name"] = {"file": "CYC_UDDS.csv", "grade_pct": 0.0}
    with pytest.raises(ParamsError, match=r"cycles\.cycles\.Bad-Name: invalid key name"):
        parse_params(data)
    with pytest.raises(ParamsError, match="no such params file"):
        load_params(tmp_path / "missing.yaml")
    (tmp_path / "broken.yaml").write_text("cycles: [unclosed\n")
    with pytest.raises(ParamsError, match="broken.yaml: not valid YAML"):
        load_params(tmp_path / "broken.yaml")
    (tmp_path / "list.yaml").write_text("- 1\n- 2\n")
    with pytest.raises(ParamsError, match="top level must be a mapping"):
        load_params(tmp_path / "list.yaml")


@pytest.mark.parametrize("stage", ["cycles", "components"])
@pytest.mark.parametrize(
    "key, value, expect",
    [
        ("cycles.typo", 1, "cycles.typo: unknown key"),
        ("baseline.conventional.p_eng_kw", "seventy", "baseline.conventional.p_eng_kw: Input should be a valid number"),
        ("cycles.step_s", 60.0, "cycles.step_s: Input should be less than or equal to 10"),
    ],
)
def test_stage_stops_on_bad_params_and_writes_nothing(raw_params, tmp_path, monkeypatch, stage, key, value, expect):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump(_with(raw_params, key, value)))
    result = CliRunner().invoke(app, [stage, "--params", "bad.yaml"])
    assert result.exit_code == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: bad.yaml: {expect}"), lines
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.yaml"]  # no data/, no reports/


def test_stage_stops_on_missing_inputs_and_writes_nothing(raw_params, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(raw_params))
    result = CliRunner().invoke(app, ["cycles"])
    assert result.exit_code == 1
    assert result.stderr.strip() == "error: data/raw/cycles: cycle directory missing (params cycles.raw_dir)"
    result = CliRunner().invoke(app, ["components"])
    assert result.exit_code == 1
    assert result.stderr.strip() == "error: data/raw/components: component directory missing"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["params.yaml"]


def test_hev_lists_the_stages():
    result = CliRunner().invoke(app, ["--help"])
    assert result.exit_code == 0
    assert "cycles" in result.stdout and "components" in result.stdout
