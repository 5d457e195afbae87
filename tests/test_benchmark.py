"""Issue 24: the equal-budget benchmark -- its indicators (common-sample hypervolume, greedy hypervolume
subsets, IGD+), statistics (Mann-Whitney, Holm, A12), runs (the BoTorch sources' own tests: test_bayesopt.py) that
record every simulation, and scoring on one judged object. Stand-in models, small budgets."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from test_infill import SCREEN, _designs, _hv, _make_problem
from test_optimise import stand_in_simulate

from hevlib.benchmark.runs import RUN_SCHEMA, RunContext, run_seed, run_source
from hevlib.benchmark.scoring import (
    a12,
    best_known_front,
    both_indicators,
    budget_table,
    comparisons,
    holm,
    judged_run,
    mann_whitney,
    prefix,
    score_runs,
)
from hevlib.design import OBJECTIVES, RESPONSES
from hevlib.indicators import (
    CommonSamples,
    Normalisation,
    hv_greedy_subset,
    hypervolume_exact,
    igd_plus,
    pick_diverse,
    to_minimisation,
)
from hevlib.params import load_params


# ----------------------------------------------------------------------------------- statistics
def test_holm_a12_and_mann_whitney_match_hand_computed_values():
    np.testing.assert_allclose(holm([0.01, 0.04, 0.03]), [0.03, 0.06, 0.06])
    np.testing.assert_allclose(holm([0.5, 0.001]), [0.5, 0.002])
    assert a12([3, 4, 5], [1, 2, 3]) == pytest.approx((9 - 0.5) / 9)
    assert a12([1, 1], [1, 1]) == 0.5
    # perfect separation of 7 against 7: the exact two-sided p is 2 / C(14, 7)
    assert mann_whitney(np.arange(7) + 10.0, np.arange(7.0)) == pytest.approx(2 / 3432)
    assert mann_whitney([1.0, 2, 3], [1.0, 2, 3]) == pytest.approx(1.0)


# ----------------------------------------------------------------------------------- indicators
def test_common_samples_estimate_the_exact_hypervolume_and_share_their_noise():
    rng = np.random.default_rng(0)
    F = rng.random((30, 4))
    F = F / np.linalg.norm(F, axis=1, keepdims=True)
    samples = CommonSamples.draw(F.min(axis=0) - 0.01, 1.1, 200_000, seed=3)
    value, se = samples.of(F)
    exact = hypervolume_exact(F, 1.1)
    assert abs(value - exact) < 4 * se and se < 0.01 * exact
    sub, _ = samples.of(F[:15])
    assert sub <= value  # the same samples: a subset never scores more
    with pytest.raises(ValueError, match="below the samples' box"):
        samples.of(F - 0.5)


def test_greedy_hypervolume_subset_keeps_more_than_farthest_point_or_random():
    rng = np.random.default_rng(1)
    F = rng.random((400, 6))
    F = F / np.linalg.norm(F, axis=1, keepdims=True)
    k = 25
    greedy = hv_greedy_subset(F, k, 1.1, n_samples=50_000, seed=2)
    assert len(greedy) == len(set(greedy)) == k
    subsets = {"greedy": greedy, "fps": pick_diverse(F, k), "random": rng.choice(400, k, replace=False)}
    exact = {name: hypervolume_exact(F[idx], 1.1) for name, idx in subsets.items()}
    assert exact["greedy"] > exact["fps"] and exact["greedy"] > exact["random"]
    np.testing.assert_array_equal(hv_greedy_subset(F[:10], 20, 1.1, n_samples=100, seed=0), np.arange(10))
    outside = np.vstack([F[:5], np.full((3, 6), 2.0)])  # rows beyond the reference come last
    assert set(hv_greedy_subset(outside, 5, 1.1, n_samples=10_000, seed=0)) == set(range(5))


def test_greedy_subset_scans_sorted_samples_and_chooses_as_a_full_scan():
    """The greedy's samples sorted on one objective, each row scanning only those not below it there: every
    row counts the samples it truly dominates, and the greedy chooses what a scan of every sample chooses."""
    from hevlib.indicators import _dominated_samples, _greedy_cover, _sorted_samples

    rng = np.random.default_rng(3)
    F = rng.random((300, 5))
    F = F / np.linalg.norm(F, axis=1, keepdims=True)
    Z = rng.random((5000, 5)) * 1.1

    def cover(Z, first, k=20):
        counts = _dominated_samples(F, Z, first, np.zeros(len(F) + 1, dtype=np.int64), np.empty(0, dtype=np.int64))
        start = np.zeros(len(F) + 1, dtype=np.int64)
        start[1:] = np.cumsum(counts)
        items = np.empty(int(start[-1]), dtype=np.int64)
        _dominated_samples(F, Z, first, start, items)
        return counts, _greedy_cover(start, items, len(Z), k)

    counts, chosen = cover(Z, np.zeros(len(F), dtype=np.int64))
    np.testing.assert_array_equal(counts, (F[:, None, :] <= Z[None, :, :]).all(axis=2).sum(axis=1))
    Z_sorted, first = _sorted_samples(F, Z)
    assert first.min() > 0 and first.mean() > 0.3 * len(Z)  # every row skips samples
    counts_sorted, chosen_sorted = cover(Z_sorted, first)
    np.testing.assert_array_equal(counts_sorted, counts)
    np.testing.assert_array_equal(chosen_sorted, chosen)


def test_igd_plus_counts_only_where_a_front_is_worse():
    R = np.array([[0.0, 1.0], [1.0, 0.0]])
    assert igd_plus(R, R) == 0.0
    assert igd_plus(np.array([[-1.0, -1.0]]), R) == 0.0  # dominates every reference point
    assert igd_plus(np.array([[0.5, 1.0]]), R) == pytest.approx((0.5 + 1.0) / 2)


# ----------------------------------------------------------------------------------- runs
@pytest.fixture(scope="module")
def tiny_cfg():
    cfg = load_params("params.yaml")
    o = cfg.optimise
    small = {
        a: s.model_copy(update={"pop_size": 24, "n_gen": 6, "n_neighbors": 6, "n_weights": 12, "norm_samples": 100})
        for a, s in o.algorithms.items()
    }
    optimise = o.model_copy(
        update={
            "algorithms": small,
            "oracle": o.oracle.model_copy(update={"pop_size": 20, "n_gen": 3}),
            "infill": o.infill.model_copy(update={"designs_per_round": 15, "n_gen": 3}),
            "bayes": {
                "parego": o.bayes["parego"].model_copy(
                    update={"batch": 10, "num_restarts": 1, "raw_samples": 16, "mc_samples": 8}
                )
            },
            "tsparego": o.tsparego.model_copy(
                update={"batch": 10, "pool": 200, "local_pool": 100, "subset": 40, "n_features": 64}
            ),
        }
    )
    bench = cfg.benchmark.model_copy(
        update={
            "budget": 70,
            "direct_budget": 90,
            "seeds": 2,
            "oracle_seeds": 1,
            "nsga3_direct": cfg.benchmark.nsga3_direct.model_copy(update={"pop_size": 20}),
            "moead_direct": cfg.benchmark.moead_direct.model_copy(update={"pop_size": 20, "n_neighbors": 5}),
        }
    )
    return cfg.model_copy(update={"optimise": optimise, "benchmark": bench, "screen": SCREEN})


def _context(cfg) -> RunContext:
    X_doe = _designs(27, 6)
    return RunContext(cfg, stand_in_simulate, _make_problem, X_doe, stand_in_simulate(X_doe))


@pytest.mark.parametrize("source", ["lhs", "nsga3_direct", "moead", "parego", "tsparego", "oracle"])
def test_a_run_records_every_simulation_in_order(tiny_cfg, source):
    if source in ("parego", "tsparego"):  # BoTorch's fits and designs cost seconds: a smaller budget
        budget = {"parego": 33, "tsparego": 45}[source]
        tiny_cfg = tiny_cfg.model_copy(update={"benchmark": tiny_cfg.benchmark.model_copy(update={"budget": budget})})
    ctx = _context(tiny_cfg)
    table = run_source(ctx, source, 0)
    assert table.schema.equals(RUN_SCHEMA)
    df = table.to_pandas()
    np.testing.assert_array_equal(df["sim_index"], np.arange(1, len(df) + 1))
    if source in ("moead", "parego", "tsparego"):  # the DOE counts, first
        np.testing.assert_array_equal(df[["p_eng_kw", "p_mot_kw"]].to_numpy()[:27], ctx.X_doe[:, :2])
    if source in ("lhs", "parego", "tsparego"):
        assert len(df) == tiny_cfg.benchmark.budget
    if source == "moead":
        assert len(df) >= tiny_cfg.benchmark.budget
    X = df[["p_eng_kw", "p_mot_kw", "p_gen_kw", "i0", "n_bat", "n_r", "n_s"]].to_numpy()
    truth = stand_in_simulate(X)
    for k in OBJECTIVES:  # what is recorded is what the simulator said about that design
        np.testing.assert_allclose(df[f"sim_{k}"], truth[k])
    assert df["final_population"].any()
    again = run_source(_context(tiny_cfg), source, 0).to_pandas()
    pd.testing.assert_frame_equal(df, again)  # seeded
    assert run_seed(1, source, 0) != run_seed(1, source, 1)


def test_scoring_judges_every_run_on_the_same_object(tiny_cfg):
    cfg = tiny_cfg
    runs = []
    for source in ("lhs", "nsga3_direct", "moead", "moga"):
        for k in range(2):
            runs.append(judged_run(source, k, run_source(_context(cfg), source, k).to_pandas(), SCREEN))
    norm = _hv().norm
    lo = np.minimum.reduce([norm(r.F).min(axis=0) for r in runs]) - 1e-9
    samples = CommonSamples.draw(np.minimum(lo, 0.0), 1.1, 20_000, seed=1)
    budgets = {r.source: [30, 60] for r in runs}
    scores = score_runs(runs, norm, samples, budgets, best_known_front(runs, norm, 1.1), [30, 60])
    df = scores.per_budget
    for (_s, _k), g in df.groupby(["source", "run"]):
        hv = g.sort_values("budget")["hypervolume"].to_numpy()
        assert np.all(np.diff(hv) >= 0)  # the archive only grows
    r = runs[0]
    at30 = df[(df.source == r.source) & (df.run == r.run) & (df.budget == 30)]
    assert at30["hypervolume"].item() == samples.of(norm(r.F[prefix(r, 30)]))[0]
    table = budget_table(scores)
    assert set(table) == {"lhs", "nsga3_direct", "moead", "moga"} and table["lhs"]["30"]["n"] == 2
    tests = comparisons(scores, [30, 60], 0.05, 0.71)
    medians = {s: table[s]["30"]["median"] for s in ("lhs", "nsga3_direct")}
    assert tests["30"]["moead"]["direct"] == max(medians, key=medians.get)  # the best direct search there
    for per in tests.values():
        assert set(per) == {"moead", "moga"} and all(per[s]["saea"] == s for s in per)
        assert all(t["direct"] in ("lhs", "nsga3_direct") and t["p_holm"] >= t["p"] for t in per.values())
    # IGD+ at every budget, lower is better: the best direct search there is the one with the lowest median
    igd = comparisons(scores, [30, 60], 0.05, 0.71, "igd_plus")
    at = df[(df.budget == 30) & df.source.isin(["lhs", "nsga3_direct"])].groupby("source")["igd_plus"].median()
    assert igd["30"]["moead"]["direct"] == at.idxmin() and igd["30"]["moead"]["indicator"] == "igd_plus"
    both = both_indicators(scores, [30, 60], 1.0, 0.0)  # no bar: only the medians decide
    igd_free = comparisons(scores, [30, 60], 1.0, 0.0, "igd_plus")
    for b, per in both.items():
        for src, t in per.items():
            assert t["igd_plus"] == igd_free[b][src]
            assert t["beats_direct"] == (t["beats_direct_hypervolume"] and igd_free[b][src]["beats_direct"])


def test_the_judged_normalisation_never_reaches_a_search():
    """A search's candidate scales come from its own training data (``search_normalisation``), so a
    judged normalisation built from the judged scale's reference set cannot steer it: two very different judged
    normalisations give the same searched designs."""
    from test_infill import CountingFit
    from test_optimise import SMALL

    from hevlib.optimise import surrogate_assisted
    from hevlib.params import InfillParams

    X_doe = _designs(30, 1)
    Y_doe = stand_in_simulate(X_doe)[list(OBJECTIVES)].to_numpy()
    infill = InfillParams(rounds=1, designs_per_round=10, n_gen=5, criterion="diverse")
    hv = _hv()
    span = hv.norm.span * np.linspace(1.0, 30.0, len(OBJECTIVES))  # a very different weighting
    other = type(hv)(Normalisation(hv.norm.ideal - span, hv.norm.nadir + span), 1.1, 20_000, 7, SCREEN)
    designs = []
    for settings in (hv, other):
        fit = CountingFit()
        surrogate_assisted(
            "nsga3", SMALL["nsga3"], infill, _make_problem, fit, X_doe, Y_doe, stand_in_simulate, settings
        )
        designs.append(np.vstack(fit.seen))
    np.testing.assert_array_equal(designs[0], designs[1])


def test_responses_cover_the_run_schema():
    assert [f.name for f in RUN_SCHEMA][1 + 7 : 1 + 7 + len(RESPONSES)] == [f"sim_{k}" for k in RESPONSES]
    assert to_minimisation(np.ones(len(OBJECTIVES))).shape == (len(OBJECTIVES),)


def test_a_stored_run_is_current_only_while_the_code_it_ran_is_unchanged(tmp_path):
    """The benchmark reuses a run on disk only if its fingerprint matches, and the fingerprint carries the run
    code: an edit to an optimiser or to the sizing problem shared with `hev optimise` runs the seeds again, a plot
    edit does not."""
    import shutil
    from pathlib import Path

    from hevlib.codedeps import closure_hash
    from stages.benchmark import RUN_CODE_MODULES

    repo = Path(__file__).resolve().parents[1]
    root = tmp_path / "repo"
    for package in ("hevlib", "stages"):
        shutil.copytree(repo / package, root / package, ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))

    def fingerprint() -> str:
        return closure_hash(root, RUN_CODE_MODULES)

    def edit(rel: str) -> None:
        path = root / rel
        path.write_text(path.read_text().replace('"""', '"""Edited. ', 1))

    before = fingerprint()
    edit("hevlib/plots/benchmark.py")
    edit("hevlib/benchmark/report.py")
    assert fingerprint() == before  # the report and its figure are not run code
    edit("hevlib/optimise/infill.py")
    after_optimiser = fingerprint()
    assert after_optimiser != before
    edit("hevlib/optimise/problem.py")
    assert fingerprint() != after_optimiser
