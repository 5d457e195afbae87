"""Component library: loading and normalising the ADVISOR data, the best-efficiency line, persistence."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import yaml

from hevlib.components import (
    RPM,
    ComponentLibrary,
    best_efficiency_line,
    load_engine,
    load_library,
    read_baseline_table,
    read_paper_row,
)
from hevlib.params import load_params, parse_params
from hevlib.sizing import library_files, scale_engine, study_library


def _raw(raw, name: str) -> dict:
    return yaml.safe_load((raw / "components" / name).read_text())


def test_engine_figures_match_the_source(lib, raw):
    hyb, conv = lib.engine_hybrid, lib.engine_conventional
    assert hyb.name == "FC_PRIUS_JPN" and conv.name == "FC_SI63_emis"
    assert hyb.peak_power_kw == pytest.approx(42.7136, abs=1e-3)
    assert conv.peak_power_kw == pytest.approx(62.6690, abs=1e-3)
    # minimum BSFC over grid points at or below full load (ADVISOR_README: 219.4 and 247.5 g/kWh)
    assert hyb.min_bsfc_g_per_kwh() == pytest.approx(
        _raw(raw, "FC_PRIUS_JPN.yaml")["derived_checks"]["min_bsfc_g_per_kwh_at_or_below_full_load"], rel=1e-9
    )
    assert conv.min_bsfc_g_per_kwh() == pytest.approx(247.5326, abs=1e-3)
    assert hyb.max_efficiency() == pytest.approx(0.3852, abs=1e-4)


@pytest.mark.parametrize("field", ["engine_hybrid", "engine_conventional"])
def test_engine_maps_cover_zero_to_full_load_and_keep_source_values(lib, field, raw):
    eng = getattr(lib, field)
    raw = _raw(raw, f"{eng.name}.yaml")
    assert eng.torque_nm[0] == 0.0 and eng.torque_nm[-1] >= eng.max_torque_nm.max() - 1e-9
    src_t = np.array(raw["torque_axis_nm"])
    cols = np.searchsorted(eng.torque_nm, src_t)
    np.testing.assert_array_equal(eng.torque_nm[cols], src_t)
    at_or_below = src_t[None, :] <= eng.max_torque_nm[:, None] * (1 + 1e-9)
    for key in ("fuel", "hc", "co", "nox"):
        kept = getattr(eng, f"{key}_g_s")[:, cols]
        np.testing.assert_array_equal(kept[at_or_below], np.array(raw[f"{key}_map_g_per_s"])[at_or_below])
    # added columns continue each row linearly (Willans line), never negative
    fuel = eng.fuel_g_s
    assert np.all(fuel >= 0) and np.all(fuel[:, 0] > 0)


@pytest.mark.parametrize("name", ["FC_PRIUS_JPN", "FC_SI63_emis"])
def test_engine_maps_are_never_read_above_full_load(raw, tmp_path, name):
    """Poison every source value above its row's full-load torque: the loaded maps, the kernels' uniform
    tables and every lookup at or below full load stay exactly as they were, so nothing above the curve
    is read; and the continuation above full load never beats the row's best efficiency at or below it."""
    from hevlib.sim.vehicles import engine_arrays

    src = _raw(raw, f"{name}.yaml")
    t_src = np.array(src["torque_axis_nm"])
    above = t_src[None, :] > np.array(src["max_torque_nm"])[:, None] * (1 + 1e-9)
    assert above.any()  # both files have values above full load
    poisoned = dict(src)
    for key in ("fuel", "hc", "co", "nox"):
        m = np.array(src[f"{key}_map_g_per_s"], dtype=float)
        m[above] = 1e3 * (1.0 + m[above])
        poisoned[f"{key}_map_g_per_s"] = m.tolist()
    (tmp_path / f"{name}.yaml").write_text(yaml.safe_dump(poisoned))
    clean, dirty = load_engine(raw / "components" / f"{name}.yaml"), load_engine(tmp_path / f"{name}.yaml")
    for key in ("fuel", "hc", "co", "nox"):
        np.testing.assert_array_equal(getattr(clean, f"{key}_g_s"), getattr(dirty, f"{key}_g_s"))
    for a, b in zip(engine_arrays(clean), engine_arrays(dirty), strict=True):
        np.testing.assert_array_equal(a, b)
    # efficiency at the full-load curve (between grid speeds too) never exceeds the best below it
    w = np.linspace(clean.speed_rad_s[0], clean.speed_rad_s[-1], 400)
    t_fl = clean.max_torque_at(w)
    eta_fl = w * t_fl / (clean.rate_g_s("fuel", w, t_fl) * clean.lhv_j_per_g)
    assert eta_fl.max() <= 0.40  # the source's best at or below full load is 0.385 (Prius), 0.341 (63 kW)


def test_prius_zero_torque_fuel_is_the_willans_intercept(lib):
    eng = lib.engine_hybrid
    t1, t2 = eng.torque_nm[1:3]
    f1, f2 = eng.fuel_g_s[:, 1], eng.fuel_g_s[:, 2]
    np.testing.assert_allclose(eng.fuel_g_s[:, 0], f1 - (f2 - f1) * t1 / (t2 - t1))
    assert eng.fuel_g_s[0, 0] == pytest.approx(0.1034, abs=1e-4)  # 1000 rpm, 0 N*m


def test_machine_maps_replace_source_fills(lib, raw):
    mot, gen = lib.motor, lib.generator
    assert mot.speed_rad_s[0] == 0 and mot.torque_nm[0] == 0
    np.testing.assert_array_equal(mot.efficiency[0], mot.efficiency[1])  # 0 rpm row = 500 rpm row
    np.testing.assert_array_equal(mot.efficiency[:, 0], mot.efficiency[:, 1])  # 0 N*m column = 5 N*m
    raw = np.array(_raw(raw, "MC_PRIUS_JPN.yaml")["efficiency_map"])
    np.testing.assert_array_equal(mot.efficiency[1:, 1:], raw[1:, 12:])  # measured part unchanged
    assert mot.efficiency.max() == pytest.approx(0.912) and gen.efficiency.max() == pytest.approx(0.8645)
    assert mot.max_torque_nm[0] == 305.0 and gen.max_torque_nm.max() == 55.0
    assert mot.peak_power_kw == pytest.approx(31.52, abs=0.01)  # torque curve linear between points
    assert gen.peak_power_kw == pytest.approx(15.42, abs=0.01)
    w = np.linspace(0, mot.max_speed_rad_s, 2001)
    assert np.max(w * mot.max_torque_at(w)) / 1e3 == pytest.approx(mot.peak_power_kw, rel=1e-4)


def test_battery_and_bodies(lib):
    b = lib.battery
    assert b.name == "ESS_LI7_temp" and b.temperature_c == 41.0 and b.capacity_ah == pytest.approx(7.405)
    assert b.energy_wh() == pytest.approx(b.capacity_ah * b.mean_ocv_v())
    body, wheel = lib.body_conventional, lib.wheel_conventional
    assert (body.drag_coefficient, body.frontal_area_m2, body.cg_height_m, wheel.radius_m) == (0.19, 2.038, 0.4, 0.282)
    assert (lib.body_prius.drag_coefficient, lib.body_prius.frontal_area_m2, lib.wheel_prius.radius_m) == (
        0.30,
        1.746,
        0.287,
    )
    assert lib.power_split.n_r == 78 and lib.power_split.n_s == 30 and lib.power_split.i0 == 3.93
    np.testing.assert_allclose(lib.gearbox.ratios, [13.195, 7.3486, 4.9126, 3.4916, 2.5984])
    assert lib.conventional_idle_rad_s == pytest.approx(800 * RPM)
    assert lib.conventional_launch_rad_s == pytest.approx(1200 * RPM)  # PTC_CONV value for 800 rpm idle


def test_nimh_battery_is_selectable(raw, params):
    baseline = params.baseline.model_copy(update={"battery": "nimh"})
    nimh = load_library(raw / "components", library_files(baseline)).battery
    assert nimh.name == "ESS_NIMH6" and nimh.temperature_c == 25.0 and nimh.capacity_ah == 6.0
    data = params.model_dump(mode="json")
    data["baseline"]["battery"] = "lead"
    lead = r"^params.yaml: baseline.battery: 'lead' is not one of batteries \(li_ion, nimh\)$"
    with pytest.raises(ValueError, match=lead):
        parse_params(data)


def test_the_study_cars_values_are_table_1s(params, raw):
    """params.yaml's body and wheel values of both cars are the study's Table 1 (its provenance), the rest
    of each part is its ADVISOR file's."""
    t1 = read_baseline_table(raw / "paper" / "table1_baseline_vehicles.csv")
    for car in ("conventional", "prius"):
        given = getattr(params.baseline, car)
        values = {**given.body.values(), "wheel_radius_m": given.wheel.radius_m}
        assert values == {k: t1[car][k] for k in values}, car
        assert given.test_mass_kg == t1[car]["test_mass_kg"] and given.p_eng_kw == t1[car]["p_eng_kw"]


def test_another_car_is_params_alone(raw, params):
    """Another car's body and wheels from params: the values replace the files', the rest stays the file's."""
    conv = params.baseline.conventional
    other = conv.model_copy(
        update={
            "body": conv.body.model_copy(update={"drag_coefficient": 0.30, "frontal_area_m2": 2.3}),
            "wheel": conv.wheel.model_copy(update={"radius_m": 0.33, "rolling_resistance": 0.0095}),
        }
    )
    lib = study_library(params.baseline.model_copy(update={"conventional": other}))
    ref = study_library(params.baseline)
    assert (lib.body_conventional.drag_coefficient, lib.body_conventional.frontal_area_m2) == (0.30, 2.3)
    assert (lib.wheel_conventional.radius_m, lib.wheel_conventional.rolling_resistance) == (0.33, 0.0095)
    assert lib.body_conventional.cg_height_m == ref.body_conventional.cg_height_m == 0.4
    share = lib.wheel_conventional.brake_driveline_share
    assert share.tolist() == ref.wheel_conventional.brake_driveline_share.tolist()
    assert lib.body_prius == ref.body_prius


def test_no_component_file_is_named_in_the_code(root):
    """Which file is which part is params.yaml's: no component file name in hevlib/ or stages/ code."""
    names = {p.name for p in (root / "data" / "raw" / "components").glob("*.yaml")}
    for folder in ("hevlib", "stages"):
        for path in (root / folder).rglob("*.py"):
            text = path.read_text()
            named = sorted(n for n in names if f'"{n}"' in text or f"'{n}'" in text)
            assert not named, f"{path.relative_to(root)} names {named}"


def test_best_efficiency_line_minimises_fuel(lib):
    eng = lib.engine_hybrid
    p, w, t = best_efficiency_line(eng)
    assert p[0] == 0 and p[-1] == pytest.approx(eng.peak_power_kw * 1e3, rel=1e-3)
    assert np.all(np.diff(p) > 0) and np.all(np.diff(w) >= 0)
    np.testing.assert_allclose(w * t, p)
    assert np.all(t <= eng.max_torque_at(w) * (1 + 1e-9))
    assert np.all((w >= eng.min_speed_rad_s) & (w <= eng.max_speed_rad_s))
    # brute force: no feasible speed burns less fuel for the same power (within the search grid's resolution)
    ws = np.linspace(eng.min_speed_rad_s, eng.max_speed_rad_s, 2001)
    for k in range(5, len(p), 7):
        ts = p[k] / ws
        ok = ts <= eng.max_torque_at(ws)
        best = eng.rate_g_s("fuel", ws[ok], ts[ok]).min()
        assert eng.rate_g_s("fuel", w[k], t[k]) <= best * 1.003
    # the line is better than ADVISOR's own 5-point Prius line at every one of its points
    ps = lib.power_split
    for p_op, w_op in zip(ps.operating_line_power_w, ps.operating_line_speed_rad_s, strict=True):
        w_best = np.interp(p_op, p, w)
        assert eng.rate_g_s("fuel", w_best, p_op / w_best) <= eng.rate_g_s("fuel", w_op, p_op / w_op) + 1e-9


def test_best_efficiency_line_of_a_scaled_engine_scales(lib):
    p, w, t = best_efficiency_line(lib.engine_hybrid)
    p2, w2, t2 = best_efficiency_line(scale_engine(lib.engine_hybrid, 2 * lib.engine_hybrid.peak_power_kw))
    np.testing.assert_allclose(p2, 2 * p)
    np.testing.assert_allclose(w2, w)
    np.testing.assert_allclose(t2, 2 * t)
    _, _, t_res = best_efficiency_line(lib.engine_hybrid, load_limit=0.9)
    assert np.all(t_res <= 0.9 * lib.engine_hybrid.max_torque_at(w.max()) + 1e-9)


def _assert_same(a, b, where=""):
    if dataclasses.is_dataclass(a):
        assert type(a) is type(b), where
        for f in dataclasses.fields(a):
            _assert_same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b, err_msg=where)
        assert a.dtype == b.dtype and not b.flags.writeable, where
    else:
        assert a == b and type(a) is type(b), where


def test_save_load_round_trip_is_exact_and_deterministic(lib, tmp_path):
    lib.save(tmp_path / "a")
    (tmp_path / "a" / "old_component.npz").write_bytes(b"stale")
    lib.save(tmp_path / "a")
    lib.save(tmp_path / "b")
    names = sorted(p.name for p in (tmp_path / "a").iterdir())
    assert "old_component.npz" not in names and "library.json" in names
    for name in names:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name
    back = ComponentLibrary.load(tmp_path / "a")
    _assert_same(lib, back)
    assert back.meta == lib.meta


def test_load_errors_name_the_file(lib, tmp_path):
    with pytest.raises(FileNotFoundError, match="library.json: missing; run `hev components`"):
        ComponentLibrary.load(tmp_path)
    lib.save(tmp_path)
    (tmp_path / "motor.npz").unlink()
    with pytest.raises(FileNotFoundError, match="motor.npz: missing component map"):
        ComponentLibrary.load(tmp_path)


def test_raw_component_errors_name_the_file(tmp_path, raw, root):
    with pytest.raises(FileNotFoundError, match="FC_NONE.yaml: no such component file"):
        load_engine(tmp_path / "FC_NONE.yaml")
    bad = tmp_path / "FC_BAD.yaml"
    source = _raw(raw, "FC_PRIUS_JPN.yaml")
    bad.write_text(yaml.safe_dump({k: v for k, v in source.items() if k != "fuel_map_g_per_s"}))
    with pytest.raises(ValueError, match="FC_BAD.yaml: missing key 'fuel_map_g_per_s'"):
        load_engine(bad)
    with pytest.raises(FileNotFoundError, match="component directory missing"):
        load_library(tmp_path / "nowhere", library_files(load_params(root / "params.yaml").baseline))


def test_study_tables(tmp_path, raw):
    t1 = read_baseline_table(raw / "paper" / "table1_baseline_vehicles.csv")
    conv, prius = t1["conventional"], t1["prius"]
    assert conv == {
        "test_mass_kg": 1195.0,
        "p_eng_kw": 70.0,
        "drag_coefficient": 0.19,
        "frontal_area_m2": 2.038,
        "cg_height_m": 0.4,
        "wheel_radius_m": 0.282,
        "gear_ratios": [13.195, 7.3486, 4.9126, 3.4916, 2.5984],
    }
    assert (prius["test_mass_kg"], prius["p_mot_kw"], prius["p_gen_kw"], prius["final_drive_ratio"]) == (
        1404.0,
        31.0,
        15.0,
        3.93,
    )
    row = read_paper_row(raw / "paper" / "l27_assignment.csv", "exp", 1)
    assert row == {
        "exp": 1,
        "p_eng_kw": 50,
        "n_bat": 40,
        "p_mot_kw": 50,
        "p_gen_kw": 25,
        "n_r": 78,
        "n_s": 30,
        "i0": 3.93,
    }
    bad = tmp_path / "t1.csv"
    bad.write_text("parameter,unit,conventional\nvehicle_mass,kg,1195\n")
    with pytest.raises(ValueError, match="t1.csv: missing column 'prius'"):
        read_baseline_table(bad)
    with pytest.raises(ValueError, match="l27_assignment.csv: no row with exp = 99"):
        read_paper_row(raw / "paper" / "l27_assignment.csv", "exp", 99)


def test_a_bad_vehicle_file_stops_check_in_one_line(tmp_path, root, monkeypatch):
    """A body file without its drag coefficient: `hev check` (the pipeline's first stage) names file and key."""
    import shutil

    from typer.testing import CliRunner

    from stages.cli import app

    components = tmp_path / "components"
    shutil.copytree(root / "data" / "raw" / "components", components)
    body = yaml.safe_load((components / "VEH_EV1.yaml").read_text())
    del body["drag_coefficient"]
    (components / "VEH_MYCAR.yaml").write_text(yaml.safe_dump(body))
    data = yaml.safe_load((root / "params.yaml").read_text())
    data["baseline"]["components_dir"] = str(components)
    data["baseline"]["conventional"]["body"] = {"file": "VEH_MYCAR.yaml", "frontal_area_m2": 2.3}
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(data))
    monkeypatch.chdir(root)  # the cycles and DOE inputs of the repository; check fails before writing
    result = CliRunner().invoke(app, ["check", "--params", str(tmp_path / "params.yaml")])
    assert result.exit_code == 1
    assert result.stderr.strip() == f"error: {components / 'VEH_MYCAR.yaml'}: missing key 'drag_coefficient'"
