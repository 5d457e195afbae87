"""A car from its certification data (issue 52): the EPA test car list read with its dtypes, one car found by make,
model, test vehicle and configuration (or refused in one line), its powertrain told from the row's columns, and its
profile -- test mass, coast-down road load, engine power, wheel radius and gears, each checked by hand here --
through ``hev car`` and ``hev profile``; and the coast-down road load in the kernels: the force it gives and the
energy balance it keeps."""

from __future__ import annotations

import copy
import hashlib
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from typer.testing import CliRunner

from hevlib import epa
from hevlib.params import N_PER_LBF, ParamsError, parse_params
from hevlib.profiles import apply_overrides, load_profile
from stages.cli import app

REPO = Path(__file__).resolve().parents[1]
TABLE = REPO / "data" / "raw" / "epa" / "test_car_list_2022.csv"
K = 0.44704 * 60.0 / (2.0 * math.pi)  # rpm per mph per (overall ratio / m)
BASELINE = parse_params(yaml.safe_load((REPO / "params.yaml").read_text())).baseline


@pytest.fixture(scope="module")
def table() -> pd.DataFrame:
    return epa.read_test_car_list(TABLE)


def _car(table, make, model, **which) -> epa.Car:
    return epa.find_car(table, make, model, source=TABLE, **which)


# ------------------------------------------------------------------------------------------- the list
def test_the_list_is_the_shared_copy_byte_for_byte_with_its_provenance():
    assert hashlib.sha256(TABLE.read_bytes()).hexdigest() == epa.TEST_CAR_LIST_SHA256
    readme = (TABLE.parent / "README.md").read_text()
    assert "## PROVENANCE" in readme and epa.TEST_CAR_LIST_SHA256 in readme
    assert "never the shared folder at run time" in readme


def test_the_list_is_read_with_explicit_dtypes_and_its_file_lines(table):
    assert len(table) == 4397 and list(table.columns) == ["line", *epa.COLUMNS]
    assert table[epa.CONFIG].dtype == np.int64 and table[epa.GEARS].dtype == np.int64
    for col in (epa.ETW, epa.HP, epa.AXLE, epa.NV, epa.COEF_A, epa.COEF_B, epa.COEF_C, epa.DISPLACEMENT):
        assert table[col].dtype == np.float64, col
    first = table.iloc[0]  # the byte-order mark is not part of the first column's name
    assert (first["line"], first[epa.MAKE], first[epa.MODEL]) == (2, "Aston Martin", "DB11 V8")
    assert table["line"].iloc[-1] == 4398


def test_a_missing_file_or_column_stops_in_one_line(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"missing.csv: no such file"):
        epa.read_test_car_list(tmp_path / "missing.csv")
    bad = tmp_path / "bad.csv"
    bad.write_text("Represented Test Veh Make,Represented Test Veh Model\nTOYOTA,COROLLA\n")
    with pytest.raises(ValueError, match=r"^.*bad.csv: ") as info:
        epa.read_test_car_list(bad)
    assert "\n" not in str(info.value)


# --------------------------------------------------------------------------------- finding one car
def test_a_car_by_make_model_vehicle_and_configuration(table):
    car = _car(table, "toyota", "corolla", vehicle_id="20-ze2c", config=2)  # any case
    assert (car.make, car.model, car.vehicle_id, car.config) == ("TOYOTA", "COROLLA", "20-ZE2C", 2)
    assert car.kind == epa.CONVENTIONAL
    assert car.lines == (3712,)  # its FTP test (the HWY test on line 3713 agrees)
    assert epa.coast_down(car) == {"a_lbf": 27.485, "b_lbf_per_mph": -0.10848, "c_lbf_per_mph2": 0.02012}


def test_a_missing_car_names_what_the_list_has(table):
    with pytest.raises(epa.CarNotFound, match=r"no make 'TOYOTTA' in the list"):
        _car(table, "TOYOTTA", "COROLLA")
    with pytest.raises(epa.CarNotFound) as info:
        _car(table, "TOYOTA", "COROLA")
    assert "no model 'COROLA' of TOYOTA (its models: 4RUNNER 2WD, " in str(info.value)
    with pytest.raises(epa.CarNotFound) as info:
        _car(table, "TOYOTA", "COROLLA", config=7)
    assert str(info.value) == (
        f"{TABLE}: no TOYOTA COROLLA with configuration 7 (test vehicle/configuration: 20-ME1M/0, 20-ME2C/2, "
        "20-ZE1M/0, 20-ZE2C/1, 20-ZE2C/2)"
    )


def test_an_ambiguous_car_lists_its_candidates_shortened(table):
    with pytest.raises(epa.AmbiguousCar) as info:
        _car(table, "TOYOTA", "COROLLA")
    assert str(info.value) == (
        f"{TABLE}: 5 cars are TOYOTA COROLLA (give --vehicle-id and --config): 20-ME1M/0 (3375 lb, M6), "
        "20-ME2C/2 (3375 lb, CVT1), 20-ZE1M/0 (3125 lb, M6), 20-ZE2C/1 (3250 lb, CVT1), 20-ZE2C/2 (3250 lb, CVT1)"
    )
    with pytest.raises(epa.AmbiguousCar, match=r"and \d+ more$"):  # more than 8 candidates: shortened
        _car(table, "CHEVROLET", "CAMARO")
    # one configuration whose FTP tests disagree: --line picks one of them
    with pytest.raises(epa.AmbiguousCar, match=r"FTP tests of Land Rover Defender 3ELTT039/0 disagree .*--line"):
        _car(table, "Land Rover", "Defender", vehicle_id="3ELTT039", config=0)
    line = int(table.loc[(table[epa.VEHICLE_ID] == "3ELTT039") & (table[epa.CATEGORY] == "FTP"), "line"].iloc[0])
    car = _car(table, "Land Rover", "Defender", line=line)
    assert car.lines == (line,)


# ----------------------------------------------------------------------------------- powertrains
@pytest.mark.parametrize(
    "make, model, which, kind",
    [
        ("TOYOTA", "COROLLA", {"vehicle_id": "20-ZE2C", "config": 2}, "conventional"),
        ("TOYOTA", "COROLLA CROSS", {}, "conventional"),  # a Toyota CVT without the hybrid's H
        ("TOYOTA", "COROLLA HYBRID", {}, "power-split hybrid"),
        ("TOYOTA", "SIENNA", {"config": 0}, "power-split hybrid"),  # hybrid-only: no HYBRID in the name
        ("LEXUS", "UX 250h", {"config": 0}, "power-split hybrid"),
        ("Ford", "Escape FHEV", {"vehicle_id": "LUA00090"}, "power-split hybrid"),
        ("Ford", "Maverick", {"vehicle_id": "NFE1-2.5-J-332"}, "power-split hybrid"),  # the hybrid, unnamed
        ("Ford", "Maverick", {"vehicle_id": "NRA00026"}, "conventional"),  # the 2.0 L, 8-speed one
        ("TOYOTA", "TUNDRA 2WD", {"vehicle_id": "22-VK5H", "config": 0}, "hybrid that is not a power split"),
        ("HONDA", "ACCORD HYBRID", {"vehicle_id": "DJC21C", "config": 1}, "hybrid that is not a power split"),
        ("Ford", "Explorer FHEV", {"vehicle_id": "MGA00010"}, "hybrid that is not a power split"),
        ("TOYOTA", "PRIUS PRIME", {"vehicle_id": "17-ZW2H", "config": 0}, "plug-in hybrid"),  # no CD test itself
        ("Jeep", "Gladiator 4X4", {"vehicle_id": "L1JTJ2432"}, "diesel"),
    ],
)
def test_the_powertrain_is_told_from_the_row(table, make, model, which, kind):
    assert _car(table, make, model, **which).kind == kind


def test_an_electric_car_is_refused_in_one_line(table):
    with pytest.raises(epa.UnsupportedCar) as info:
        _car(table, "Tesla", "Model 3 RWD")
    assert str(info.value) == f"{TABLE}: Tesla Model 3 RWD: an electric car with no road test (FTP, HWY, US06, SC03)"


def test_every_power_split_hybrid_of_the_list_is_a_toyota_lexus_or_ford_e_cvt(table):
    found = set()
    for mk, md, vid, cfg in table[[epa.MAKE, epa.MODEL, epa.VEHICLE_ID, epa.CONFIG]].drop_duplicates().values:
        try:
            car = _car(table, mk, md, vehicle_id=vid, config=int(cfg))
        except ValueError:
            continue
        if car.kind == epa.POWER_SPLIT:
            found.add(car.model.upper())
            assert car.make.upper() in ("TOYOTA", "LEXUS", "FORD") and car.value(epa.TRANS_CODE) in ("CVT", "SCV")
    assert {
        "PRIUS",
        "COROLLA HYBRID",
        "CAMRY HYBRID LE",
        "RAV4 HYBRID AWD",
        "SIENNA",
        "VENZA AWD",
        "ES 300h".upper(),
    } <= found
    assert {"ESCAPE FHEV", "MAVERICK", "MAVERICK FHEV FWD"} <= found
    assert not {m for m in found if "PRIME" in m or "+" in m}  # the plug-ins are not


# ------------------------------------------------------------------------- conversions, by hand
def test_the_corolla_cvt_converts_as_computed_by_hand(table):
    car = _car(table, "TOYOTA", "COROLLA", vehicle_id="20-ZE2C", config=2)
    # ETW 3250 lb x 0.45359237 = 1474.175 kg; 139 hp x 0.745699872 = 103.652 kW
    assert epa.test_mass_kg(car) == 1474.2 and epa.engine_kw(car) == 103.7
    d = epa.driveline(car)
    # a CVT: no overdrive ratio to derive the radius from, so a car's typical 205/55 R16 (203.2 + 112.75 mm)
    assert (d.box, d.radius_derived, d.radius_m) == ("cvt", False, 0.316)
    # N/V 26.4 rpm/mph x 0.316 m / 4.268918 = 1.95421; 8 steps of a 7.0 spread: 13.6795 (x 7) ... 1.9542
    assert K == pytest.approx(4.268918, abs=1e-6)
    assert d.top_overall == pytest.approx(26.4 * 0.316 / 4.268918, rel=1e-6) == pytest.approx(1.95421, abs=1e-5)
    assert d.ratios[0] == pytest.approx(7.0 * d.top_overall, rel=1e-12)
    entries = {key: value for _, key, value in epa.car_profile(car, BASELINE, "list.csv")}
    assert entries["baseline.conventional.gear_ratios"] == [
        13.6795,
        10.3596,
        7.8454,
        5.9414,
        4.4994,
        3.4075,
        2.5805,
        1.9542,
    ]
    assert entries["baseline.conventional.wheel"] == {
        "file": "WH_SMCAR.yaml",
        "radius_m": 0.316,
        "inertia_kg_m2": 4.098,
    }
    # 2750 rpm in the first step: 287.98 rad/s x 0.316 m / 13.6795 x 3.6 = 23.9 km/h
    assert entries["baseline.conventional.upshift_kmh"][0] == 23.9


def test_an_eight_speed_automatic_derives_its_radius_from_n_v_and_axle_ratio(table):
    car = _car(table, "TOYOTA", "CAMRY")  # 18-GV1A/2: V6, 8-speed automatic, axle 2.56, N/V 22.6
    d = epa.driveline(car)
    # r = 4.268918 x 0.667 (the 8HP's top) x 2.56 / 22.6 = 0.32253 m: a tyre's radius, kept (to the mm)
    assert d.radius_from_box_m == pytest.approx(4.268918 * 0.667 * 2.56 / 22.6, rel=1e-6)
    assert (d.box, d.radius_derived, d.radius_m) == ("automatic", True, 0.323)
    # top overall = N/V x r / K = 22.6 x 0.323 / 4.268918 = 1.70999; the 8HP's ratios x 1.70999 / 0.667 (~ the axle)
    assert d.top_overall == pytest.approx(1.70999, abs=1e-5)
    assert d.ratios == pytest.approx([i * d.top_overall / 0.667 for i in epa.AUTOMATIC_RATIOS[8]], rel=1e-12)
    assert d.ratios[0] == pytest.approx(4.714 * 2.5637, rel=1e-4)  # first gear x "axle" 2.56
    assert epa.test_mass_kg(car) == 1757.7 and epa.engine_kw(car) == 224.5  # 3875 lb; 301 hp


def test_a_manual_whose_box_gives_no_tyre_radius_keeps_n_v(table):
    car = _car(table, "TOYOTA", "COROLLA", vehicle_id="20-ZE1M")  # 6-speed manual, axle 4.21, N/V 36.5
    d = epa.driveline(car)
    # the T-56's 0.50 top gear: 4.268918 x 0.50 x 4.21 / 36.5 = 0.246 m, below a tyre's: a car's 0.316 m instead
    assert d.radius_from_box_m == pytest.approx(0.24620, abs=1e-5)
    assert (d.box, d.radius_derived, d.radius_m) == ("manual", False, 0.316)
    assert d.top_overall == pytest.approx(36.5 * 0.316 / 4.268918, rel=1e-6)  # 2.70186: N/V holds in top gear
    assert d.ratios[0] / d.ratios[-1] == pytest.approx(2.66 / 0.50, rel=1e-12)  # the T-56's spread


def test_the_three_thousand_pound_elantra(table):
    car = _car(table, "HYUNDAI", "Elantra", vehicle_id="CN7U10MC175F")
    # 3000 lb x 0.45359237 kg/lb = 1360.777 kg; 147 hp x 0.745699872 = 109.618 kW
    assert (epa.test_mass_kg(car), epa.engine_kw(car)) == (1360.8, 109.6)


def test_a_hybrid_row_gives_the_stock_prius_its_test_mass_road_load_and_gearing(table):
    car = _car(table, "TOYOTA", "COROLLA HYBRID")
    entries = {key: value for _, key, value in epa.car_profile(car, BASELINE, "list.csv")}
    assert entries == {
        "baseline.prius.body": {
            "file": "VEH_PRIUS_JPN.yaml",
            "coast_down": {"a_lbf": 15.891, "b_lbf_per_mph": 0.36102, "c_lbf_per_mph2": 0.012344},
        },
        "baseline.prius.test_mass_kg": 1530.9,  # 3375 lb
        # a car's typical tyre (205/55 R16), the 181 lb wheel set at its radius: 82.086 kg x 0.316^2 / 2
        "baseline.prius.wheel": {"file": "WH_PRIUS_JPN.yaml", "radius_m": 0.316, "inertia_kg_m2": 4.098},
        "baseline.prius.i0": 2.83,  # the row's Axle Ratio: ring to wheels (not the 2001 Prius's 3.93)
    }
    assert car.lines == (3737,)  # the FTP test, not the cold-CO one (line 3734) with its cold road load


def test_a_hybrid_truck_takes_a_truck_tyre_and_its_own_axle_ratio(table):
    car = _car(table, "TOYOTA", "SIENNA", config=0)
    entries = {key: value for _, key, value in epa.car_profile(car, BASELINE, "list.csv")}
    # 235/65 R17; 82.086 kg x 0.369^2 / 2 = 5.588 kg m^2; the row's Axle Ratio 3.64
    assert entries["baseline.prius.wheel"] == {"file": "WH_PRIUS_JPN.yaml", "radius_m": 0.369, "inertia_kg_m2": 5.588}
    assert entries["baseline.prius.i0"] == 3.64
    # the ring turns slower per road speed than on the 2001 Prius (3.93 on 0.287 m): less power circulation
    assert entries["baseline.prius.i0"] / 0.369 < BASELINE.prius.i0 / BASELINE.prius.wheel.radius_m


@pytest.mark.parametrize(
    "make, model, which, message",
    [
        ("TOYOTA", "PRIUS PRIME", {"vehicle_id": "17-ZW2H", "config": 0}, "a plug-in hybrid: only conventional"),
        ("Ford", "Bronco", {"vehicle_id": "MLA60101"}, "no typical ratio set for a 7-speed manual box"),
    ],
)
def test_what_does_not_convert_says_why_in_one_line(table, make, model, which, message):
    with pytest.raises(epa.UnsupportedCar, match=message) as info:
        epa.car_profile(_car(table, make, model, **which), BASELINE)
    assert "\n" not in str(info.value)


# -------------------------------------------------------------------------------- hev car, hev profile
def test_hev_car_writes_a_profile_hev_profile_takes(project):
    runner = CliRunner()
    out = runner.invoke(
        app,
        ["car", "TOYOTA", "COROLLA", "--vehicle-id", "20-ZE2C", "--config", "2", "--out", "profiles/corolla.yaml"]
        + ["--table", str(TABLE)],
    )
    assert out.exit_code == 0, out.output
    text = (project / "profiles" / "corolla.yaml").read_text()
    assert text.startswith("# TOYOTA COROLLA, test vehicle 20-ZE2C, configuration 2: a conventional car")
    assert "dvc exp run $(hev profile corolla)" in text and "Equivalent Test Weight 3250 lb" in text
    shown = runner.invoke(app, ["profile", "corolla"])
    assert shown.exit_code == 0, shown.output
    args = shown.output.split()
    assert args[1] == (
        "baseline.conventional.body={file:VEH_EV1.yaml,coast_down:{a_lbf:27.485,b_lbf_per_mph:-0.10848,"
        "c_lbf_per_mph2:0.02012}}"
    )
    assert "baseline.conventional.test_mass_kg=1474.2" in args and "baseline.conventional.p_eng_kw=103.7" in args
    overrides = load_profile("corolla", "params.yaml", "profiles")
    p = parse_params(apply_overrides(yaml.safe_load(Path("params.yaml").read_text()), overrides))
    conv = p.baseline.conventional
    assert conv.body.coast_down is not None and conv.body.drag_coefficient is None
    assert len(conv.gear_ratios) == 8 and len(conv.upshift_kmh) == 7 and conv.wheel.radius_m == 0.316


def test_hev_car_prints_to_stdout_without_out(project):
    out = CliRunner().invoke(app, ["car", "TOYOTA", "COROLLA HYBRID", "--table", str(TABLE)])
    assert out.exit_code == 0, out.output
    assert "baseline.prius.test_mass_kg: 1530.9" in out.stdout and not (project / "profiles").exists()


@pytest.mark.parametrize(
    "args, message",
    [
        (["TOYOTA", "COROLLA"], "5 cars are TOYOTA COROLLA (give --vehicle-id and --config): 20-ME1M/0 (3375 lb, M6)"),
        (["TOYOTA", "COROLA"], "no model 'COROLA' of TOYOTA (its models: "),
        (["TOYOTA", "PRIUS PRIME", "--vehicle-id", "17-ZW2H", "--config", "0"], "a plug-in hybrid: only"),
        (["Aston Martin", "DB11 V8"], "baseline.conventional.p_eng_kw: Input should be less than or equal to 300"),
    ],
)
def test_hev_car_refuses_in_one_line_and_writes_nothing(project, args, message):
    out = CliRunner().invoke(app, ["car", *args, "--out", "profiles/x.yaml", "--table", str(TABLE)])
    assert out.exit_code == 1
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and message in lines[0], lines
    assert not (project / "profiles").exists()


# ----------------------------------------------------------------------- the coast-down in the kernels
def test_the_road_force_of_a_coast_down_is_a_plus_b_v_plus_c_v2_on_the_flat(lib):
    """(i) F(v) = A + B v + C v^2, the coefficients in SI, at the car's test mass: the kernels' road force."""
    import dataclasses

    from hevlib.sim.powertrain.vehicle import Chassis, mean_speed_for_force, road_force, road_total
    from hevlib.sim.vehicles import road_load

    a, b, c = 27.485 * N_PER_LBF, -0.10848 * N_PER_LBF / 0.44704, 0.02012 * N_PER_LBF / 0.44704**2
    body = dataclasses.replace(
        lib.body_conventional, road_load_a_n=a, road_load_b_n_per_mps=b, road_load_c_n_per_mps2=c
    )
    m = 1474.2
    rl = road_load(body, lib.wheel_conventional, m)
    assert (rl.axle0_nm, rl.axle_per_kg_nm, rl.k_lin) == (0.0, 0.0, b)  # no axle drag: the coast-down has it
    g = body.gravity_m_s2
    ch = Chassis(
        m=m,
        m_eff=m + 40.0,
        cda=rl.cda,
        crr=rl.crr,
        r=0.316,
        axle_drag_nm=0.0,
        h_over_l=0.16,
        f_front=0.6,
        adhesion_coefficient=0.9,
        rho=body.air_density_kg_m3,
        g=g,
        k_lin=rl.k_lin,
    )
    for v_mph in (5.0, 20.0, 50.0, 80.0):
        v = v_mph * 0.44704
        aero, roll, grade, axle = road_force(v, 0.0, 1.0, ch)
        assert grade == 0.0 and axle == 0.0
        assert aero == pytest.approx(c * v * v, rel=1e-14)  # C v^2
        assert roll == pytest.approx(a + b * v, rel=1e-14)  # A + B v
        lbf = (27.485 - 0.10848 * v_mph + 0.02012 * v_mph**2) * N_PER_LBF  # the list's own units
        assert road_total(v, 0.0, 1.0, ch) == pytest.approx(lbf, rel=1e-13)
    assert road_force(0.0, 0.0, 1.0, ch) == (0.0, 0.0, 0.0, 0.0)  # standing: no road load
    # the speed a force buys solves the step's balance with the linear term in it
    for f in (-500.0, 300.0, 2500.0):
        u = mean_speed_for_force(20.0, f, 0.0, 1.0, 1.0, ch)
        assert f - road_total(u, 0.0, 1.0, ch) == pytest.approx(2 * ch.m_eff * (u - 20.0), rel=1e-9, abs=1e-9)
    # without a linear term the forces are bit for bit those of the formula without it
    flat = ch._replace(k_lin=0.0)
    assert road_force(12.3, 0.0, 1.0, flat)[1] == flat.m * flat.g * 1.0 * flat.crr


def _coast_down_params(params, b_lbf_per_mph: float):
    """The repository's params with the 2022 Corolla (20-ZE2C/2) as the conventional car, its coast-down's B set."""
    table = epa.read_test_car_list(TABLE)
    car = _car(table, "TOYOTA", "COROLLA", vehicle_id="20-ZE2C", config=2)
    overrides = copy.deepcopy(epa.profile_overrides(epa.car_profile(car, params.baseline)))
    overrides["baseline.conventional.body"]["coast_down"]["b_lbf_per_mph"] = b_lbf_per_mph
    data = apply_overrides(yaml.safe_load((REPO / "params.yaml").read_text()), overrides)
    data["cycles"]["raw_dir"] = params.cycles.raw_dir
    data["baseline"]["components_dir"] = params.baseline.components_dir
    return parse_params(data)


@pytest.mark.parametrize("b_lbf_per_mph", [0.0, -0.10848])
def test_a_coast_down_car_and_its_conversion_book_the_road_load_and_balance(params, cycles, b_lbf_per_mph):
    """(ii) the converted Corolla and a hybrid on its chassis drive the FTP; the road energy is the coast-down's
    (A at the car's test mass, scaled with the conversion's mass; B v; C v^2) at each step's mean speed, booked in
    ``e_road_j``, and the energy balance closes."""
    from hevlib.sim.powertrain.layout import TRACE_NAMES
    from hevlib.sim.simulator import Simulator, energy_balance, simulate
    from hevlib.sizing import study_library

    p = _coast_down_params(params, b_lbf_per_mph)
    sim = Simulator(study_library(p.baseline), p)
    a = 27.485 * N_PER_LBF
    b = b_lbf_per_mph * N_PER_LBF / 0.44704
    c = 0.02012 * N_PER_LBF / 0.44704**2
    cycle = cycles["ftp"]
    for vehicle in (sim.vehicle(None, "conventional"), sim.vehicle(np.array([[60.0, 50.0, 25.0, 4.0, 40, 80, 30]]))):
        res = simulate(vehicle, cycle, record=True, performance=False)
        assert energy_balance(res)["residual_share"].abs().iloc[0] < 1e-9
        tr = pd.DataFrame(res.traces[0], columns=list(TRACE_NAMES))
        v = tr["v_mps"].to_numpy()
        v = np.r_[0.5 * v[0], 0.5 * (v[1:] + v[:-1])]  # each step's mean speed
        moving = v > 0.0
        scale = res.mass_kg[0] / p.baseline.conventional.test_mass_kg  # A belongs to the car's test mass
        expected = ((a * scale + b * v + c * v * v) * v)[moving].sum() * cycle.dt_s
        row = res.frame().iloc[0]
        assert row["e_road_j"] == pytest.approx(expected, rel=1e-9), vehicle.kind


def test_params_refuse_a_bad_coast_down_in_one_line(params):
    """(iii) the params contract for the coast-down block (more cases in tests/test_params.py)."""
    data = yaml.safe_load((REPO / "params.yaml").read_text())
    data["baseline"]["conventional"]["body"]["coast_down"] = {
        "a_lbf": 27.5,
        "b_lbf_per_mph": 0.1,
        "c_lbf_per_mph2": 0.02,
    }
    with pytest.raises(ParamsError) as info:
        parse_params(data)
    assert str(info.value) == (
        "params.yaml: baseline.conventional.body.coast_down: give the road load as coast_down or as drag_coefficient "
        "and frontal_area_m2, not both"
    )


def test_a_coast_down_body_survives_the_component_library_round_trip(params, tmp_path):
    """The components stage writes a coast-down body's coefficients (SI) into library.json and the simulating
    stages read them back exactly; a body without one writes no such key (the study's bytes unchanged)."""
    import json

    from hevlib.components import ComponentLibrary
    from hevlib.sizing import study_library

    lib = study_library(_coast_down_params(params, -0.10848).baseline)
    lib.save(tmp_path / "cd")
    back = ComponentLibrary.load(tmp_path / "cd")
    assert back.body_conventional == lib.body_conventional
    assert back.body_conventional.coast_down == (
        27.485 * N_PER_LBF,
        -0.10848 * N_PER_LBF / 0.44704,
        0.02012 * N_PER_LBF / 0.44704**2,
    )
    study = study_library(params.baseline)
    study.save(tmp_path / "study")
    index = json.loads((tmp_path / "study" / "library.json").read_text())
    assert "road_load_a_n" not in index["body_conventional"]["scalars"]
    assert ComponentLibrary.load(tmp_path / "study").body_conventional.coast_down is None
