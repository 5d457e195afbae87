"""Drive cycles: validation of raw traces, resampling, grades, key-off, Parquet round trip, distances."""

from __future__ import annotations

import numpy as np
import pyarrow.parquet as pq
import pytest
import yaml

from hevlib.cycles import (
    CYCLE_SCHEMA,
    Cycle,
    CycleError,
    load_cycle,
    read_raw_cycle,
    read_raw_trace,
    resample,
    write_cycles,
)


def _csv(tmp_path, text: str, name: str = "CYC_BAD.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    "text, match",
    [
        ("time_s,speed_kmh\n0,0\n2,10\n1,20\n3,0\n", r"time is not strictly increasing at line 4 \(t=1 s\)"),
        ("time_s,speed_kmh\n0,0\n1,10\n1,20\n2,0\n", r"time is not strictly increasing at line 4"),
        ("time_s,speed_kmh\n0,0\n1,-5\n2,0\n", r"negative speed at line 3 \(t=1 s\)"),
        ("time_s,speed_kmh\n0,0\n1,\n2,0\n", r"speed_kmh is missing, NaN or infinite at line 3"),
        ("time_s,speed_kmh\n0,0\n1,nan\n2,0\n", r"speed_kmh is missing, NaN or infinite at line 3"),
        ("time_s,speed_kmh,speed_mph\n0,0,0\n1,1,1\n", r"2 speed columns \(speed_kmh, speed_mph\); give one"),
        ("time_s,speed_kmh,grade_deg\n0,0,0\n1,1,0\n", r"unknown unit in 'grade_deg'"),
        ("time_s,speed_kmh,grade_pct\n0,0,0\n1,1,x\n", r"grade_pct at line 3 is 'x': not a number within \+-30"),
        ("time_s,speed_kmh,grade\n0,0,0\n1,1,0.5\n", r"grade at line 3 is '0.5': not a number within \+-0.3"),
        ("time_s,speed_kmh\n0,0\n,1\n2,0\n", r"time_s is missing, NaN or infinite at line 3"),
        ("time_s\n0\n1\n", r"missing speed column, expected one of speed_kmh, speed_mps, speed_mph"),
        ("t,speed_kmh\n0,0\n1,1\n", r"missing column 'time_s'"),
        ("time_s,speed_fps\n0,0\n1,1\n", r"unknown unit in 'speed_fps'"),
        ("time_s,speed_kmh\n0,0\n", r"needs at least two points"),
        ("", r"not a readable CSV"),
    ],
)
def test_malformed_cycle_gives_one_line_error_naming_file(tmp_path, text, match):
    path = _csv(tmp_path, text)
    with pytest.raises(CycleError, match=match) as info:
        load_cycle(path, name="bad")
    msg = str(info.value)
    assert msg.startswith(str(path)) and "\n" not in msg


def test_missing_cycle_file_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="CYC_NONE.csv: cycle file missing"):
        load_cycle(tmp_path / "CYC_NONE.csv", name="none")


def test_units_are_converted_to_mps(tmp_path):
    for col, factor in (("speed_kmh", 1 / 3.6), ("speed_mph", 0.44704), ("speed_mps", 1.0)):
        path = _csv(tmp_path, f"time_s,{col}\n0,0\n1,10\n2,20\n", name=f"c_{col}.csv")
        _, v = read_raw_cycle(path)
        np.testing.assert_allclose(v, np.array([0, 10, 20]) * factor)


def test_resampling_a_non_uniform_trace(tmp_path):
    path = _csv(tmp_path, "time_s,speed_mps\n10,0\n10.5,1\n12,4\n13.5,1\n", name="c.csv")
    cyc = load_cycle(path, name="c", step_s=1.0, grade=0.05)
    np.testing.assert_allclose(cyc.time_s, [0, 1, 2, 3])  # starts at 0, stops before 13.5 s
    np.testing.assert_allclose(cyc.speed_mps, [0, 2.0, 4.0, 2.0])  # linear between raw points
    np.testing.assert_allclose(cyc.grade, 0.05)
    fine = load_cycle(path, name="c", step_s=0.5)  # every raw point on the grid
    assert fine.n_steps == 8 and fine.dt_s == 0.5
    raw_t, raw_v = read_raw_cycle(path)
    assert fine.distance_m == pytest.approx(np.trapezoid(raw_v, raw_t), rel=1e-12)


def test_resample_rejects_bad_step():
    t, v = np.array([0.0, 1.0, 2.0]), np.array([0.0, 1.0, 0.0])
    with pytest.raises(CycleError, match="step_s"):
        resample(t, v, 0.0)
    with pytest.raises(CycleError, match="fewer than two points"):
        resample(t, v, 5.0)


def test_cycle_object_checks_its_invariants():
    t = np.arange(4.0)
    with pytest.raises(CycleError, match="lengths differ"):
        Cycle("x", t, np.zeros(4), np.zeros(3))
    with pytest.raises(CycleError, match="not uniform"):
        Cycle("x", np.array([0, 1, 3, 4.0]), np.zeros(4), np.zeros(4))
    with pytest.raises(CycleError, match="grade must be finite"):
        Cycle("x", t, np.zeros(4), np.full(4, 2.0))
    with pytest.raises(CycleError, match="negative speed at index 2"):
        Cycle("x", t, np.array([0, 1, -1, 0.0]), np.zeros(4))
    cyc = Cycle("x", t, np.array([0, 1, 2, 0.0]), np.zeros(4))
    with pytest.raises(ValueError):
        cyc.speed_mps[0] = 5.0  # immutable arrays


def test_cycle_figures_match_the_source_metadata(cycles, params, root):
    meta = yaml.safe_load((root / "data/raw/cycles/cycles.yaml").read_text())["cycles"]
    by_file = {m["file"]: m for m in meta.values()}
    assert set(cycles) == {"udds", "ftp", "hwfet", "us06", "nedc"}
    for name, cyc in cycles.items():
        m = by_file[params.cycles.cycles[name].file]
        assert cyc.dt_s == 1.0 and cyc.n_steps == m["points"]
        assert cyc.duration_s == m["duration_s"]
        assert cyc.distance_m / 1e3 == pytest.approx(m["distance_km_trapezoidal"], rel=1e-9)
        assert cyc.speed_mps.max() * 3.6 == pytest.approx(m["max_speed_km_per_h"], rel=1e-9)
    udds, ftp = cycles["udds"].summary(), cycles["ftp"].summary()
    assert (udds["duration_s"], round(udds["distance_km"], 3)) == (1369.0, 11.990)
    assert (ftp["duration_s"], round(ftp["distance_km"], 3)) == (2477.0, 17.769)
    assert udds["v_mean_kmh"] == pytest.approx(11.990238656 / 1369 * 3600, rel=1e-6)


def test_grades_come_from_params(cycles):
    np.testing.assert_array_equal(cycles["udds"].grade, 0.2)  # sizing cycle: 20 % grade
    for name in ("ftp", "hwfet", "us06", "nedc"):
        np.testing.assert_array_equal(cycles[name].grade, 0.0)


def test_ftp_soak_is_key_off(cycles):
    ftp = cycles["ftp"]
    off = ftp.time_s[~ftp.key_on]
    assert off[0] == 0.0 and off[1] == 1373.0 and off[-1] == 1972.0 and len(off) == 601
    assert np.all(ftp.speed_mps[~ftp.key_on] == 0.0)  # never moving with the key off
    assert cycles["udds"].key_on.all()
    # FTP = UDDS, soak, first 505 s of UDDS again
    np.testing.assert_array_equal(ftp.speed_mps[:1370], cycles["udds"].speed_mps)
    np.testing.assert_array_equal(ftp.speed_mps[1973:], cycles["udds"].speed_mps[1:506])


def test_with_grade_keeps_trace_and_key(cycles):
    ftp = cycles["ftp"]
    graded = ftp.with_grade(0.1)
    np.testing.assert_array_equal(graded.speed_mps, ftp.speed_mps)
    np.testing.assert_array_equal(graded.key_on, ftp.key_on)
    np.testing.assert_array_equal(graded.grade, 0.1)


def test_parquet_round_trip_with_explicit_schema(cycles, tmp_path):
    write_cycles(cycles, tmp_path / "cycles", tmp_path / "cycles.json")
    (tmp_path / "cycles" / "stale.parquet").write_bytes(b"")
    write_cycles({"ftp": cycles["ftp"]}, tmp_path / "cycles", tmp_path / "cycles.json")
    assert sorted(p.name for p in (tmp_path / "cycles").iterdir()) == ["ftp.parquet"]  # stale files removed
    path = tmp_path / "cycles" / "ftp.parquet"
    assert pq.read_schema(path).remove_metadata().equals(CYCLE_SCHEMA)
    back = Cycle.from_parquet(path)
    for key in ("time_s", "speed_mps", "grade", "key_on"):
        np.testing.assert_array_equal(getattr(back, key), getattr(cycles["ftp"], key))
    assert back.name == "ftp"


def test_from_parquet_errors_name_the_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="run `hev cycles`"):
        Cycle.from_parquet(tmp_path / "none.parquet")
    bad = tmp_path / "bad.parquet"
    bad.write_text("not parquet")
    with pytest.raises(CycleError, match="bad.parquet: not a readable Parquet file"):
        Cycle.from_parquet(bad)


def test_a_grade_column_is_resampled_with_the_speed(tmp_path):
    """A user's cycle may carry its own grade (percent or rise/run), resampled like the speed; a constant grade
    given as well is refused (which one would the user mean?)."""
    path = _csv(tmp_path, "time_s,speed_kmh,grade_pct\n0,0,0\n2,36,4\n4,36,-2\n", name="CYC_HILL.csv")
    trace = read_raw_trace(path)
    np.testing.assert_allclose(trace.grade, [0.0, 0.04, -0.02])
    cyc = load_cycle(path, name="hill", step_s=1.0)
    np.testing.assert_allclose(cyc.grade, [0.0, 0.02, 0.04, 0.01, -0.02])
    np.testing.assert_allclose(cyc.speed_mps, [0, 5, 10, 10, 10])
    with pytest.raises(CycleError, match=r"CYC_HILL.csv: has a grade column and a constant grade is given too"):
        load_cycle(path, name="hill", grade=0.0)
    flat = _csv(tmp_path, "time_s,speed_mps\n0,0\n1,1\n", name="CYC_FLAT.csv")
    assert read_raw_trace(flat).grade is None
    np.testing.assert_allclose(load_cycle(flat, name="flat").grade, 0.0)  # no column, no constant: flat


def test_wltc_class_3b_matches_gtr_15(root):
    """WLTC class 3b (UN GTR 15 Annex 1, from FASTSim's resources): 1 800 s, 23.266 km, 131.3 km/h, and the
    four phases' distances as GTR 15 tabulates them."""
    raw = root / "data" / "raw" / "cycles"
    meta = yaml.safe_load((raw / "cycles.yaml").read_text())["cycles"]["CYC_WLTC3B"]
    cyc = load_cycle(raw / "CYC_WLTC3B.csv", name="wltc", expected_points=meta["points"])
    assert cyc.duration_s == 1800.0 and cyc.n_steps == 1801
    assert cyc.distance_m == pytest.approx(23_266.0, abs=1.0)
    assert cyc.speed_mps.max() * 3.6 == pytest.approx(131.3, abs=1e-9)
    kmh = cyc.speed_mps * 3.6
    ends = {"low": (0, 589), "medium": (589, 1022), "high": (1022, 1477), "extra_high": (1477, 1800)}
    for phase, (a, b) in ends.items():
        assert kmh[a] == 0.0 and kmh[b] == 0.0, phase  # every phase starts and ends at rest
        km = float(np.sum(cyc.speed_mps[a:b])) / 1000.0
        assert km == pytest.approx(meta["phase_distances_km"][phase], abs=5e-4), phase


@pytest.mark.parametrize(
    "text, column",
    [
        ("time_s,speed_kmh,driver_mood\n0,0,calm\n1,10,calm\n", "'driver_mood'"),  # a stray column
        ("time_s,speed_kmh,grad_pct\n0,0,0\n1,10,2\n", "'grad_pct'"),  # a misspelt grade column
        ("time_s,speed_kmh,\n0,0,\n1,10,\n", "3 (no name)"),  # a trailing comma in the header
    ],
)
def test_an_unknown_raw_cycle_column_is_refused_in_one_line(tmp_path, text, column):
    """Inputs are read strictly: a column that is neither time_s, a speed nor a grade column stops the read
    with one line naming the file, the column and the columns a raw cycle takes (it is not silently ignored)."""
    path = _csv(tmp_path, text)
    with pytest.raises(CycleError) as info:
        read_raw_trace(path)
    msg = str(info.value)
    assert msg == (
        f"{path}: unknown column {column}; a raw cycle takes "
        "time_s, one speed column (speed_kmh, speed_mps, speed_mph) and at most one grade column (grade_pct, grade)"
    )
    # a grade column misspelt by its unit (grade_pcnt) keeps its own one-line message
    path = _csv(tmp_path, "time_s,speed_kmh,grade_pcnt\n0,0,0\n1,10,2\n", name="CYC_PCNT.csv")
    with pytest.raises(CycleError, match=r"CYC_PCNT.csv: unknown unit in 'grade_pcnt', expected at most one of"):
        read_raw_trace(path)


def test_every_shipped_raw_cycle_has_only_known_columns(root):
    """The strict reader accepts every raw cycle the repository ships (time_s and speed_kmh today)."""
    for path in sorted((root / "data" / "raw" / "cycles").glob("*.csv")):
        assert read_raw_trace(path).speed_mps.size > 1, path


def test_hev_check_stops_on_an_unknown_cycle_column_in_one_line(tmp_path, root, monkeypatch):
    """`hev check` (the pipeline's first stage) on a raw cycle directory whose US06 file carries a stray
    column: exit 1, one line naming the file and the column."""
    import shutil

    from typer.testing import CliRunner

    from stages.cli import app

    raw = tmp_path / "cycles"
    shutil.copytree(root / "data" / "raw" / "cycles", raw)
    us06 = raw / "CYC_US06.csv"
    lines = us06.read_text().splitlines()
    us06.write_text("\n".join([lines[0] + ",driver_mood", *(ln + ",calm" for ln in lines[1:])]) + "\n")
    data = yaml.safe_load((root / "params.yaml").read_text())
    data["cycles"]["raw_dir"] = str(raw)
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(data))
    monkeypatch.chdir(root)  # the component and DOE inputs of the repository; check fails before writing
    result = CliRunner().invoke(app, ["check", "--params", str(tmp_path / "params.yaml")])
    assert result.exit_code == 1
    assert result.stderr.strip() == (
        f"error: {us06}: unknown column 'driver_mood'; a raw cycle takes time_s, one speed column "
        "(speed_kmh, speed_mps, speed_mph) and at most one grade column (grade_pct, grade)"
    )
