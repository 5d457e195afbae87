"""DOE designs (L27, Latin hypercube), the DOE table schema, metadata and summary."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from hevlib import MODEL_VERSION, doe
from hevlib.cycles import Cycle
from hevlib.design import DESIGN_VARS, INTEGER_MASK, OBJECTIVES, RESPONSES, DesignSpace
from hevlib.params import DesignSpaceParams, load_params

REPO = Path(__file__).resolve().parents[1]
L27 = REPO / "data" / "raw" / "paper" / "l27_assignment.csv"
LEVELS = REPO / "data" / "raw" / "paper" / "table4_doe_levels.csv"
SPACE = DesignSpaceParams().space()


# ---------------------------------------------------------------------------------------------- L27
def test_l27_loads_27_runs_at_the_study_levels():
    X = doe.l27_designs(L27)
    assert X.shape == (27, 7)
    levels = pd.read_csv(LEVELS).set_index("factor")
    for j, v in enumerate(DESIGN_VARS):
        want = sorted(levels.loc[v, ["level1", "level2", "level3"]].astype(float))
        assert sorted(set(X[:, j])) == want, v
        assert all(np.sum(X[:, j] == lv) == 9 for lv in want), v  # orthogonal array: 9 runs per level
    assert X[0].tolist() == [50, 50, 25, 3.93, 40, 78, 30]  # run 1, DESIGN_VARS order
    SPACE.check(X)  # all runs inside the default design space, integers integer


def test_l27_names_the_missing_column(tmp_path):
    bad = tmp_path / "l27.csv"
    pd.read_csv(L27).drop(columns=["n_s"]).to_csv(bad, index=False)
    with pytest.raises(ValueError, match=r"l27.csv: missing design-variable column\(s\) n_s"):
        doe.l27_designs(bad)
    with pytest.raises(FileNotFoundError, match="nope.csv"):
        doe.l27_designs(tmp_path / "nope.csv")


# ---------------------------------------------------------------------------------------------- LHS
def test_lhs_is_seeded_within_bounds_and_integer():
    a, b, c = doe.lhs_designs(SPACE, 60, 7), doe.lhs_designs(SPACE, 60, 7), doe.lhs_designs(SPACE, 60, 8)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    SPACE.check(a)  # inside, integers whole, n_s < n_r
    assert np.all(a >= SPACE.lower) and np.all(a <= SPACE.upper)
    np.testing.assert_array_equal(a[:, INTEGER_MASK], np.round(a[:, INTEGER_MASK]))


def test_lhs_is_stratified():
    n = 50
    X = doe.lhs_designs(SPACE, n, 3)
    for j in np.flatnonzero(~INTEGER_MASK):  # one design in each of the n equal strata
        u = (X[:, j] - SPACE.lower[j]) / (SPACE.upper[j] - SPACE.lower[j])
        np.testing.assert_array_equal(np.sort(np.floor(u * n)), np.arange(n))
    for j in np.flatnonzero(INTEGER_MASK):  # every whole number about equally often
        lo, hi = SPACE.lower[j], SPACE.upper[j]
        k = int(hi - lo + 1)
        counts = np.bincount((X[:, j] - lo).astype(int), minlength=k)
        assert counts.size == k
        assert np.all(np.abs(counts - n / k) <= 2), DESIGN_VARS[j]


def test_lhs_repairs_impossible_gear_sets():
    bounds = {v: (lo, hi) for v, lo, hi in zip(DESIGN_VARS, SPACE.lower, SPACE.upper, strict=True)}
    bounds.update({"n_r": (20, 40), "n_s": (18, 40)})
    space = DesignSpace.from_bounds(bounds)
    X = doe.lhs_designs(space, 200, 0)
    space.check(X)  # raises on n_s >= n_r or out of bounds
    bounds["n_s"] = (40, 50)
    with pytest.raises(ValueError, match="no gear set fits"):
        doe.lhs_designs(DesignSpace.from_bounds(bounds), 5, 0)


def test_doe_designs_methods_and_sources():
    X, src = doe.doe_designs("both", 10, 1, SPACE, L27)
    assert X.shape == (37, 7) and list(src[:27]) == ["l27"] * 27 and list(src[27:]) == ["lhs"] * 10
    np.testing.assert_array_equal(X[27:], doe.lhs_designs(SPACE, 10, 1))
    assert doe.doe_designs("l27", 10, 1, SPACE, L27)[0].shape == (27, 7)
    assert set(doe.doe_designs("lhs", 10, 1, SPACE, L27)[1]) == {"lhs"}
    small = DesignSpace(SPACE.lower, np.where(np.array(DESIGN_VARS) == "p_eng_kw", 45.0, SPACE.upper))
    with pytest.raises(ValueError, match=r"p_eng_kw=50 in row 1 is outside the design space"):
        doe.doe_designs("l27", 10, 1, small, L27)


# ------------------------------------------------------------------------------------- DOE table
class FakeSimulator:
    """Stands in for hevlib.sim.simulator.Simulator: smooth responses, batch-wise progress."""

    calls = 0

    @classmethod
    def from_params(cls, params, components_dir="data/components"):
        return cls()

    def close(self):  # a stage closes the simulators it made (their executor)
        pass

    def run(self, X, cycle, vehicle="hybrid", batch_size=1000, progress=None):
        assert vehicle == "hybrid"
        type(self).calls += 1
        X = np.asarray(X, dtype=float)
        out = []
        for start in range(0, len(X), batch_size):
            out.append(fake_responses(X[start : start + batch_size]))
            if progress is not None:
                progress(min(start + batch_size, len(X)), len(X))
        return pd.concat(out, ignore_index=True)


def fake_responses(X: np.ndarray) -> pd.DataFrame:
    """Smooth, mildly nonlinear responses of the designs (units as the real ones, magnitudes plausible)."""
    u = (X - SPACE.lower) / (SPACE.upper - SPACE.lower)
    cols = {
        "m_veh": 880 + 2.8 * X[:, 0] + 1.9 * X[:, 1] + 2.2 * X[:, 2] + 1.15 * X[:, 4],
        "fc": 4 + 3 * u[:, 0] - 1.5 * u[:, 3] + np.sin(2 * u[:, 4]),
        "accel_dev": 20 * np.exp(-2 * u[:, 0] - u[:, 1]),
        "hc": 0.2 + 0.1 * u[:, 0] ** 2,
        "co": 0.8 + 0.3 * u[:, 3] * u[:, 0],
        "nox": 0.1 + 0.05 * u[:, 2],
        "e_l": np.maximum(0.0, 1.0 - 3 * u[:, 0] - 2 * u[:, 1]),
        "speed_dev": 0.25 * np.exp(-3 * u[:, 0]) + 0.04 * u[:, 5],
        "diff_soc": 0.05 * np.tanh(u[:, 4] - u[:, 6]),
        "v_max": 120 + 60 * np.tanh(u[:, 0] + u[:, 1] - u[:, 3]),
        "f_max": 2 + 2 * u[:, 1] + u[:, 3],
    }
    cols["fc_soc_corrected"] = cols["fc"] + 0.1
    cols["eta_drivetrain"] = 0.3 + 0.1 * u[:, 1]
    cols["t_0_100_s"] = 8 + 6 * (1 - u[:, 0])
    cols["stalled"] = u[:, 0] + u[:, 1] < 0.02
    cols["cycle_met"] = (cols["e_l"] <= 0.0) & ~cols["stalled"]
    cols["speed_err_mean_kmh"] = 10.0 * cols["speed_dev"]
    cols["accessory_unmet_kwh"] = np.where(cols["stalled"], 0.05, 0.0)
    for p in ("hc", "co", "nox"):
        cols[f"{p}_engine_out"] = 3.0 * cols[p]
    cols["t_cat_light_off_s"] = 60.0 + 100.0 * u[:, 0]
    cols["n_engine_starts"] = np.round(10 + 30 * u[:, 2])
    cols["e_engine_start_j"] = 4000.0 * cols["n_engine_starts"]
    cols["eta_engine_mean"] = 0.3 + 0.05 * u[:, 0]
    cols["accel_dev_mean_abs"] = 0.2 * cols["accel_dev"]
    return pd.DataFrame(cols)[list(RESPONSES)]


def sizing_cycle() -> Cycle:
    t = np.arange(0.0, 60.0)
    return Cycle("udds", t, np.clip(np.sin(t / 10) * 10, 0, None), np.full(t.size, 0.2))


def test_simulate_designs_builds_the_schema_and_reports_progress():
    X, src = doe.doe_designs("both", 13, 2, SPACE, L27)
    seen = []
    table = doe.simulate_designs(
        FakeSimulator(), X, src, sizing_cycle(), batch_size=16, progress=lambda d, t: seen.append((d, t))
    )
    assert seen == [(16, 40), (32, 40), (40, 40)]
    assert table.schema.equals(doe.DOE_SCHEMA, check_metadata=True)
    assert table.column_names == list(DESIGN_VARS) + list(RESPONSES) + ["source"]
    assert table.schema.field("n_r").type == "int64" and table.schema.field("cycle_met").type == "bool"
    assert table.schema.field("fc").metadata[b"unit"] == b"L/100 km"
    df = table.to_pandas()
    np.testing.assert_array_equal(df[list(DESIGN_VARS)].to_numpy(dtype=float), X)
    np.testing.assert_allclose(df["m_veh"], fake_responses(X)["m_veh"])


def test_doe_table_names_a_missing_response():
    X = doe.l27_designs(L27)
    with pytest.raises(ValueError, match=r"simulator output: missing response column\(s\) t_0_100_s"):
        doe.doe_table(X, fake_responses(X).drop(columns=["t_0_100_s"]), "l27")
    with pytest.raises(ValueError, match="unknown source label"):
        doe.doe_table(X, fake_responses(X), "random")


def test_doe_parquet_round_trip_with_metadata_and_summary(tmp_path):
    params = load_params(REPO / "params.yaml")
    X, src = doe.doe_designs("both", 30, 4, SPACE, L27)
    cycle = sizing_cycle()
    table = doe.simulate_designs(FakeSimulator(), X, src, cycle)
    meta = doe.run_metadata(cycle, params, **doe.doe_record(params.doe))
    doe.write_doe(tmp_path / "doe.parquet", table, meta)
    df, meta_back = doe.read_doe(tmp_path / "doe.parquet")
    assert meta_back["hev.cycle"] == "udds" and meta_back["hev.grade_pct"] == "20"
    assert meta_back["hev.model_version"] == MODEL_VERSION
    assert doe.is_current(meta_back, params, **doe.doe_record(params.doe))
    other = params.model_copy(update={"sim": params.sim.model_copy(update={"stall_time_s": 20.0})})
    assert not doe.is_current(meta_back, other, **doe.doe_record(params.doe))
    assert pq.read_schema(tmp_path / "doe.parquet").field("p_eng_kw").metadata[b"unit"] == b"kW"

    summary = doe.doe_summary(df, meta_back)
    missed = ~fake_responses(X)["cycle_met"].to_numpy()
    assert summary["n_designs"] == 57 and summary["by_source"] == {"l27": 27, "lhs": 30}
    assert summary["n_cycle_not_met"] == missed.sum() > 0
    assert [d["row"] for d in summary["cycle_not_met"]] == np.flatnonzero(missed).tolist()
    assert summary["ranges"]["p_eng_kw"]["min"] >= 25 and summary["ranges"]["n_r"]["max"] <= 90
    assert set(summary["ranges"]) >= set(DESIGN_VARS) | set(OBJECTIVES)
    json.dumps(summary)  # plain JSON types only

    pd.DataFrame({"p_eng_kw": [1.0]}).to_parquet(tmp_path / "bad.parquet")
    with pytest.raises(ValueError, match=r"bad.parquet: missing column\(s\) p_mot_kw"):
        doe.read_doe(tmp_path / "bad.parquet")
