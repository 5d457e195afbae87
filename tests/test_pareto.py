"""Merge, non-dominated filtering, screening, ranking and picking on synthetic fronts."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import polars as pl
import pytest
from typer.testing import CliRunner

from hevlib.design import DESIGN_VARS, OBJECTIVES, gear_set_buildable
from hevlib.indicators import ideal_distance, nondominated_mask, normalise, pick_diverse, pick_random, rank_by
from hevlib.judging import objective_matrix
from hevlib.params import ParamsError, ScreenParams, load_params
from hevlib.pareto import merge_fronts, select_designs
from hevlib.screen import (
    apply_screening,
    buildable_gear_set,
    gen_below_motor,
    mass_max,
    not_stalled,
    passing,
    screening_rules,
    speed_dev_max,
)

REPO = Path(__file__).resolve().parents[1]


def rule_gen_below_motor():
    return gen_below_motor().expr()


def rule_speed_dev(limit):
    return speed_dev_max(limit).expr()


def rule_mass(limit):
    return mass_max(limit).expr()


def rule_buildable_gear_set():
    return buildable_gear_set().expr()


def synthetic_front(n: int, seed: int, objectives=OBJECTIVES) -> pd.DataFrame:
    """A front-like table: seven variables in the default space, sim_/pred_ objectives, nondominated_sim."""
    rng = np.random.default_rng(seed)
    n_r = rng.integers(50, 91, n)
    cols = {
        "p_eng_kw": rng.uniform(25, 70, n),
        "p_mot_kw": rng.uniform(20, 60, n),
        "p_gen_kw": rng.uniform(5, 30, n),
        "i0": rng.uniform(2, 4.5, n),
        "n_bat": rng.integers(10, 61, n),
        "n_r": n_r,
        "n_s": np.minimum(rng.integers(18, 41, n), n_r - 2),  # int64, as the fronts store them
    }
    df = pd.DataFrame(cols)
    for k in objectives:
        y = rng.uniform(0, 1, n)
        if k == "m_veh":
            y = rng.uniform(1000, 1300, n)
        elif k == "speed_dev":
            y = rng.uniform(0, 1, n)
        df[f"pred_{k}"] = y + rng.normal(0, 0.01, n)
        df[f"sim_{k}"] = y
    df["sim_stalled"] = rng.uniform(size=n) < 0.05
    df["sim_cycle_met"] = (rng.uniform(size=n) > 0.2) & ~df["sim_stalled"]
    df["feasible"] = True
    df["nondominated_sim"] = True
    return df


def brute_nondominated(F: np.ndarray) -> np.ndarray:
    n = len(F)
    keep = np.ones(n, dtype=bool)
    for i in range(n):
        for j in range(n):
            if i != j and np.all(F[j] <= F[i]) and np.any(F[j] < F[i]):
                keep[i] = False
                break
    return keep


# ------------------------------------------------------------------------------------ dominance
@pytest.mark.parametrize("m", [2, 3, 5])
def test_nondominated_matches_brute_force_with_ties_and_duplicates(m):
    rng = np.random.default_rng(m)
    F = rng.integers(0, 4, size=(150, m)).astype(float)  # few levels: many ties
    F = np.vstack([F, F[:20]])  # exact duplicates
    got = nondominated_mask(F)
    np.testing.assert_array_equal(got, brute_nondominated(F))
    assert 0 < got.sum() < len(F)
    # copies of a non-dominated point are all kept
    assert np.all(got[150:] == got[:20])


def test_nondominated_on_continuous_data_matches_brute_force():
    F = np.random.default_rng(0).normal(size=(300, 3))
    np.testing.assert_array_equal(nondominated_mask(F), brute_nondominated(F))


def test_failed_runs_and_rows_outside_among_neither_compete_nor_survive():
    """A row with a non-finite objective would dominate every other row by its finite part: it is left out, and
    the rest are filtered among themselves; ``among`` does the same for rows a screen refused."""
    F = np.array([[0.0, 0.0], [1.0, 2.0], [2.0, 1.0], [3.0, 3.0], [-1.0, np.nan], [-1.0, -1.0]])
    np.testing.assert_array_equal(nondominated_mask(F[:4]), [True, False, False, False])
    got = nondominated_mask(F[1:5])
    np.testing.assert_array_equal(got, [True, True, False, False])  # the NaN row neither dominates nor survives
    among = np.array([False, True, True, True, True, False])
    np.testing.assert_array_equal(nondominated_mask(F, among=among), [False, True, True, False, False, False])
    assert nondominated_mask(np.zeros((0, 3))).shape == (0,)
    assert not nondominated_mask(np.full((2, 2), np.inf)).any()


def test_objective_matrix_negates_maximised_objectives():
    df = synthetic_front(5, 0)
    F = objective_matrix(df)
    j = OBJECTIVES.index("v_max")
    np.testing.assert_allclose(F[:, j], -df["sim_v_max"])
    np.testing.assert_allclose(F[:, 0], df["sim_m_veh"])
    # a design with a higher top speed and otherwise equal objectives dominates
    two = pd.concat([df.iloc[[0]], df.iloc[[0]]], ignore_index=True)
    two.loc[1, "sim_v_max"] += 10.0
    assert list(nondominated_mask(objective_matrix(two))) == [False, True]


# -------------------------------------------------------------------------------------- merging
def test_merge_keeps_one_row_per_design_and_every_algorithm():
    a, b = synthetic_front(6, 1), synthetic_front(4, 2)
    b.iloc[2, :] = a.iloc[3, :].to_numpy()
    b.loc[2, "p_eng_kw"] = a.loc[3, "p_eng_kw"] + 1e-12  # equal after rounding
    b.loc[2, "pred_fc"] = 99.0  # the other surrogate's prediction
    a2 = pd.concat([a, a.iloc[[0]]], ignore_index=True)  # a duplicate within one front
    merged = merge_fronts({"nsga3": a2, "moead": b}).collect().to_pandas()
    assert len(merged) == 6 + 4 - 1
    assert merged["design_id"].is_unique
    row = merged[merged["design_id"] == "nsga3-3"].iloc[0]
    assert row["algo"] == "nsga3+moead" and row["sources"] == "nsga3-3+moead-2" and row["n_sources"] == 2
    assert row["pred_fc"] == a.loc[3, "pred_fc"]  # first source's prediction
    first = merged[merged["design_id"] == "nsga3-0"].iloc[0]
    assert first["algo"] == "nsga3" and first["sources"] == "nsga3-0+nsga3-6"
    assert list(merged.columns[:4]) == ["design_id", "algo", "sources", "n_sources"]
    assert "nondominated_sim" not in merged
    assert merged["n_bat"].dtype == np.int64


def test_merge_names_a_missing_column():
    bad = synthetic_front(3, 0).drop(columns="sim_nox")
    with pytest.raises(ValueError, match=r"front 'moga': missing column\(s\) sim_nox"):
        merge_fronts({"moga": bad})


# ------------------------------------------------------------------------------------ screening
def screening_table() -> pd.DataFrame:
    """Rows chosen around every rule's boundary (limits: 0.4 of the cycle off the trace, 1195 kg)."""
    return pd.DataFrame(
        {
            "p_gen_kw": [10.0, 20.0, 30.0, 5.0, 15.0, 10.0],
            "p_mot_kw": [20.0, 20.0, 25.0, 60.0, 40.0, 50.0],  # row 1 equal (fails: strict), row 2 above
            "sim_speed_dev": [0.0, 0.4, 0.4001, np.nan, 0.1, 0.39],  # row 1 at the limit passes; 2, 3 fail
            "sim_stalled": [False] * 6,
            "sim_m_veh": [1000.0, 1195.0, 1100.0, 1195.01, np.nan, 1190.0],
            "n_r": [78.0, 79.0, 60.0, 64.0, 78.0, 50.0],  # 79/30 odd, 60/44 planets 8, 78/28 sum%4
            "n_s": [30.0, 30.0, 44.0, 24.0, 28.0, 18.0],
        }
    )


def test_each_rule_flags_exactly_its_violators():
    t = screening_table()
    assert list(~passing(t, rule_gen_below_motor())) == [False, True, True, False, False, False]
    assert list(~passing(t, rule_speed_dev(0.4))) == [False, False, True, True, False, False]
    assert list(~passing(t, rule_mass(1195.0))) == [False, False, False, True, True, False]
    assert list(~passing(t, rule_buildable_gear_set())) == [False, True, True, False, True, False]
    np.testing.assert_array_equal(
        passing(t, rule_buildable_gear_set()), gear_set_buildable(t["n_r"].astype(int), t["n_s"].astype(int))
    )
    # the same masks on a polars table, lazily, and with a missing value as null rather than NaN
    lf = pl.from_pandas(t).lazy().with_columns(pl.col("sim_speed_dev").fill_nan(None))
    np.testing.assert_array_equal(passing(lf, rule_speed_dev(0.4)), passing(t, rule_speed_dev(0.4)))


def test_each_rule_is_one_declaration_in_three_shapes():
    """The polars expression, the numpy mask and the pymoo constraint of a rule agree on every row
    (constraint <= 0 exactly where the design passes; NaN fails everywhere)."""
    t = screening_table()
    cols = {k.removeprefix("sim_"): t[k].to_numpy(dtype=float) for k in t.columns}
    for rule in (gen_below_motor(), speed_dev_max(0.4), mass_max(1195.0), not_stalled(), buildable_gear_set()):
        np.testing.assert_array_equal(passing(t, rule.expr()), rule.mask(cols))
        if rule.margin is not None:
            with np.errstate(invalid="ignore"):
                np.testing.assert_array_equal(rule.constraint(cols) <= 0, rule.mask(cols))
    stalled = {"stalled": np.array([1.0, 0.0, np.nan])}
    assert list(not_stalled().mask(stalled)) == [False, True, False]


@pytest.mark.parametrize("rule", ["gen_below_motor", "not_stalled", "speed_dev_max", "mass_max", "buildable_gear_set"])
def test_each_rule_alone_removes_exactly_the_designs_that_violate_it(rule):
    rng = np.random.default_rng(3)
    t = synthetic_front(400, 3)
    t["sim_speed_dev"] = rng.uniform(0, 0.6, len(t))
    screen = ScreenParams()
    rules = [r for r in screening_rules(screen) if r.name == rule]
    violators = ~rules[0].check(t)
    assert 0 < violators.sum() < len(t)
    feasible, masks, report = apply_screening(t, rules)
    np.testing.assert_array_equal(feasible, ~violators)
    assert report[rule]["removed_in_sequence"] == report[rule]["fails_alone"] == violators.sum()


def test_switched_off_rules_remove_nothing_but_are_reported():
    t = screening_table()
    screen = ScreenParams(gen_below_motor=False, buildable_gear_set=False, speed_dev_max=1.0, mass_max_kg=1e9)
    feasible, masks, report = apply_screening(t, screening_rules(screen))
    assert list(feasible) == [True, True, True, False, False, True]  # only the NaN results fail
    assert report["gen_below_motor"] == {
        **report["gen_below_motor"],
        "enabled": False,
        "fails_alone": 2,
        "removed_in_sequence": 0,
    }
    assert report["buildable_gear_set"]["fails_alone"] == 3
    assert report["speed_dev_max"]["fails_alone"] == 1  # NaN still fails
    assert not masks["gen_below_motor"][1]


def test_screening_in_sequence_counts_only_designs_still_present():
    t = screening_table()
    feasible, _, report = apply_screening(t, screening_rules(ScreenParams()))
    assert list(feasible) == [True, False, False, False, False, True]
    assert [report[r]["removed_in_sequence"] for r in report] == [2, 0, 1, 1, 0, 0]
    assert [report[r]["fails_alone"] for r in report] == [2, 0, 2, 2, 3, None]  # no sim_v_max: not evaluated
    assert report["buildable_gear_set"]["remaining_after"] == 2


def test_the_highway_rule_is_reported_when_off_and_screens_when_on():
    t = screening_table()
    t["sim_v_max"] = [150.0, 120.0, 140.0, 125.0, 160.0, 129.0]
    off = apply_screening(t, screening_rules(ScreenParams()))[2]["min_v_max"]
    assert off["enabled"] is False and off["limit"] == 130.0 and off["fails_alone"] == 3  # US06's peak, reported
    assert off["removed_in_sequence"] == 0
    feasible, masks, report = apply_screening(t, screening_rules(ScreenParams(min_v_max_kmh=128.0)))
    assert list(masks["min_v_max"]) == [True, False, True, False, True, True]
    assert list(feasible) == [True, False, False, False, False, True]  # rows 1 and 3 were out already
    with pytest.raises(ValueError, match="min_v_max: the table has no column sim_v_max"):
        apply_screening(screening_table(), screening_rules(ScreenParams(min_v_max_kmh=128.0)))


def test_a_stalled_design_is_screened_out_whatever_its_objectives():
    t = screening_table()
    t.loc[0, "sim_stalled"] = True  # row 0 passes every other rule
    feasible, masks, report = apply_screening(t, screening_rules(ScreenParams()))
    assert not feasible[0] and not masks["not_stalled"][0]
    assert report["not_stalled"]["fails_alone"] == 1 and report["not_stalled"]["removed_in_sequence"] == 1


# ------------------------------------------------------------------------------- rank and pick
def test_ideal_distance_ranking_on_a_hand_made_case():
    F = np.array([[0.0, 0.0], [1.0, 1.0], [0.5, 0.2], [0.5, 0.2]])
    d = ideal_distance(F)
    np.testing.assert_allclose(d, [0, np.sqrt(2), np.hypot(0.5, 0.2), np.hypot(0.5, 0.2)])
    assert list(rank_by(d)) == [1, 4, 2, 3]  # ties keep input order
    np.testing.assert_array_equal(normalise(np.array([[3.0, 1.0], [5.0, 1.0]])), [[0.0, 0.0], [1.0, 0.0]])


def test_random_pick_is_reproducible_from_its_seed():
    a, b = pick_random(78, 15, seed=2024), pick_random(78, 15, seed=2024)
    np.testing.assert_array_equal(a, b)
    assert len(np.unique(a)) == 15 and a.min() >= 0 and a.max() < 78
    assert not np.array_equal(a, pick_random(78, 15, seed=2025))
    np.testing.assert_array_equal(np.sort(pick_random(5, 15, seed=1)), np.arange(5))  # fewer than asked


def _min_pairwise(F: np.ndarray) -> float:
    d = np.linalg.norm(F[:, None] - F[None], axis=2)
    return float(d[np.triu_indices(len(F), 1)].min())


def test_diverse_pick_takes_extremes_and_spreads_more_than_random():
    line = np.linspace(0, 1, 11)[:, None]
    assert list(pick_diverse(line, 3, start=0)) == [0, 10, 5]
    F = normalise(np.random.default_rng(5).uniform(size=(78, 4)))
    idx = pick_diverse(F, 15)
    assert len(np.unique(idx)) == 15 and idx[0] == 0
    np.testing.assert_array_equal(idx, pick_diverse(F, 15))  # deterministic
    random_min = np.mean([_min_pairwise(F[pick_random(78, 15, seed=s)]) for s in range(30)])
    assert _min_pairwise(F[idx]) > random_min
    assert len(pick_diverse(F[:4], 15)) == 4


# ------------------------------------------------------------------------------------ end to end
def _fronts():
    return {"nsga3": synthetic_front(120, 10), "moead": synthetic_front(90, 11), "moga": synthetic_front(60, 12)}


def test_select_designs_keeps_the_best_ranked_and_picks_among_them():
    screen = ScreenParams(n_keep=20, n_pick=6, speed_dev_max=0.75, mass_max_kg=1250.0, pick="random")
    fronts = _fronts()
    fronts["moead"].iloc[0, :] = fronts["nsga3"].iloc[0, :].to_numpy()  # one shared design
    res = select_designs(fronts, screen)
    m, c = res.merged.to_pandas(), res.summary.counts
    assert c.input == 270 and c.merged == 269 and c.duplicates_removed == 1
    assert c.kept == 20 and c.picked == 6
    assert (
        m["feasible"]
        == (
            m["nondominated"]
            & m["pass_gen_below_motor"]
            & m["pass_not_stalled"]
            & m["pass_speed_dev_max"]
            & m["pass_mass_max"]
            & m["pass_buildable_gear_set"]
        )
    ).all()
    assert set(m.loc[m["kept"], "rank"]) == set(range(1, 21))
    assert (m.loc[~m["feasible"], "rank"] == -1).all()
    assert m.loc[m["picked"], "kept"].all()
    assert list(res.selected["rank"]) == sorted(res.selected["rank"])
    # the kept designs are the feasible ones closest to the ideal point
    feas = m[m["feasible"]]
    worst_kept = feas.loc[feas["kept"], "ideal_distance"].max()
    assert (feas.loc[~feas["kept"], "ideal_distance"] >= worst_kept).all()
    # shares and per-algorithm counts are consistent
    assert sum(b["kept"] for b in res.summary.by_algo.values()) >= 20
    share, by_algo = res.summary.kept_share, res.summary.by_algo
    np.testing.assert_allclose(share["nsga3"], by_algo["nsga3"]["kept"] / 20)
    # same seed -> same picks; another seed -> other picks
    again = select_designs(fronts, screen)
    assert list(again.selected["design_id"]) == list(res.selected["design_id"])
    other = select_designs(fronts, screen.model_copy(update={"seed": 7}))
    assert set(other.selected["design_id"]) != set(res.selected["design_id"])


def test_fewer_designs_than_n_keep_and_n_pick_are_all_kept_and_noted():
    res = select_designs({"nsga3": synthetic_front(30, 4)}, ScreenParams(n_keep=500, n_pick=400, speed_dev_max=1.0))
    c = res.summary.counts
    assert c.kept == c.feasible == c.picked > 0
    assert any("fewer than n_keep" in n for n in res.summary.notes)
    assert any("fewer than n_pick" in n for n in res.summary.notes)


def test_non_finite_objectives_are_dropped_before_dominance():
    front = synthetic_front(20, 6)
    front.loc[3, "sim_fc"] = np.nan
    res = select_designs({"moga": front}, ScreenParams(n_keep=5, n_pick=2, speed_dev_max=1.0))
    merged = res.merged.to_pandas()
    row = merged[merged["design_id"] == "moga-3"].iloc[0]
    assert not row["finite"] and not row["nondominated"] and res.summary.counts.non_finite == 1


def test_any_number_of_objectives():
    objectives = ("a", "b", "c")
    front = synthetic_front(50, 8, objectives=objectives)
    front["sim_speed_dev"], front["sim_m_veh"] = 0.1, 1000.0
    screen = ScreenParams(n_keep=10, n_pick=4, pick="diverse", gen_below_motor=False, buildable_gear_set=False)
    res = select_designs({"nsga3": front}, screen, objectives)
    F = front[["sim_a", "sim_b", "sim_c"]].to_numpy()
    assert res.summary.counts.nondominated == brute_nondominated(F).sum()
    assert res.summary.counts.picked == 4


def test_screen_params_reject_more_picks_than_kept(tmp_path):
    text = (REPO / "params.yaml").read_text().replace("n_pick: 15", "n_pick: 99")
    (tmp_path / "params.yaml").write_text(text)
    with pytest.raises(ParamsError, match=r"params.yaml: screen.n_pick: 99 must not exceed n_keep"):
        load_params(tmp_path / "params.yaml")


# --------------------------------------------------------------------------------------- stage
def test_pareto_stage_writes_its_outputs(tmp_path, monkeypatch):
    from stages.cli import app

    shutil.copy(REPO / "params.yaml", tmp_path / "params.yaml")
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    out = runner.invoke(app, ["pareto"])
    assert out.exit_code == 1 and "data/pareto/nsga3.parquet: no such file" in out.output
    assert not Path("data/pareto/merged.parquet").exists()
    Path("data/pareto").mkdir(parents=True)
    Path("reports").mkdir()
    fronts = {**_fronts(), "parego": synthetic_front(30, 14), "nehvi": synthetic_front(20, 15)}
    fronts["oracle"] = synthetic_front(80, 13)
    for algo, front in fronts.items():
        front["sim_speed_dev"] = front["sim_speed_dev"] / 2
        earlier = synthetic_front(40, 99)  # an earlier infill round: history, never merged
        earlier.insert(0, "round", 0)
        front.insert(0, "round", 1)
        pd.concat([earlier, front], ignore_index=True).to_parquet(f"data/pareto/{algo}.parquet")
        archive = pd.concat([earlier, front], ignore_index=True).drop(columns="round")  # every simulation
        archive.insert(0, "sim_index", np.arange(1, len(archive) + 1))
        archive.assign(final_population=archive["sim_index"] > len(earlier)).to_parquet(
            f"data/pareto/{algo}_archive.parquet"
        )
        rounds = [{"round": r, "n_simulations": 27 + 100 * r, "hv_ratio_to_oracle": 0.5 + 0.1 * r} for r in (0, 1)]
        Path(f"reports/optimise_{algo}.json").write_text(json.dumps({"n_simulations": 127, "rounds": rounds}))
    Path("data/judge").mkdir(parents=True)
    t = synthetic_front(120, 5)  # the judged scale: the judged normalisation's designs
    t.rename(columns={c: c.removeprefix("sim_") for c in t.columns if c.startswith("sim_")}).to_parquet(
        "data/judge/reference.parquet"
    )
    out = runner.invoke(app, ["pareto"])
    assert out.exit_code == 0, out.output
    report = json.loads(Path("reports/pareto.json").read_text())
    assert {s["judged_object"] for s in report["sources"].values()} == {report["judged_object"]} == {"archive"}
    assert report["counts"]["input"] == sum(len(f) for f in fronts.values())  # last rounds only
    assert set(report["sources"]) == {"nsga3", "moead", "moga", "parego", "nehvi", "oracle"}
    assert report["hv_reference"] == 1.1
    assert report["sources"]["oracle"]["hv_ratio_to_oracle"] == 1.0
    assert sum(v["picked"] for v in report["sources"].values()) >= report["counts"]["picked"]
    norm = report["normalisation"]
    assert norm["ideal"]["v_max"] >= norm["nadir"]["v_max"] and norm["ideal"]["fc"] <= norm["nadir"]["fc"]
    assert Path("reports/plots/pareto/infill.png").stat().st_size > 0
    merged = pd.read_parquet("data/pareto/merged.parquet")
    selected = pd.read_parquet("data/pareto/selected.parquet")
    assert {"design_id", "algo", "kept", "rank", "pass_mass_max", *DESIGN_VARS} <= set(merged.columns)
    assert merged["n_r"].dtype == np.int64 and merged["sim_cycle_met"].dtype == bool
    assert len(selected) == min(15, merged["kept"].sum())
    assert {f"sim_{k}" for k in OBJECTIVES} <= set(selected)
    for name in ("reports/pareto.json", "reports/plots/pareto/tradeoffs.png", "reports/pareto_tradeoffs/moga.csv"):
        assert Path(name).stat().st_size > 0
    assert set(pd.read_csv("reports/pareto_tradeoffs/nsga3.csv").columns) >= set(OBJECTIVES)
