"""Issue 14: the oracle (simulator in the loop), surrogate-assisted search with infill rounds, candidate
selection and the one hypervolume (simulated objectives of screen-passing designs). Stand-in models from
tests/test_optimise.py; small budgets."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest
from test_optimise import SMALL, SPACE, AnalyticSurrogate, stand_in_mass_kg, stand_in_simulate

from hevlib.design import DESIGN_VARS, INTEGER_MASK, OBJECTIVES
from hevlib.indicators import (
    Normalisation,
    nondominated_mask,
    normalisation_dict,
    normalisation_from_dict,
    to_minimisation,
)
from hevlib.judging import HvSettings, screened_hypervolume, screened_normalisation, simulated_as_front
from hevlib.optimise import (
    HevProblem,
    SimulatorModel,
    optimise,
    optimise_and_resimulate,
    oracle,
    select_candidates,
    surrogate_assisted,
)
from hevlib.params import AlgoParams, InfillParams, OracleParams, ScreenParams
from hevlib.screen import passes_screen

SCREEN = ScreenParams(speed_dev_max=1.0, mass_max_kg=1195.0, gen_below_motor=False, buildable_gear_set=False)


def _designs(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    X = SPACE.lower + rng.random((n, 7)) * (SPACE.upper - SPACE.lower)
    X[:, INTEGER_MASK] = np.round(X[:, INTEGER_MASK])
    return X


def _hv(screen=SCREEN) -> HvSettings:
    table = simulated_as_front(stand_in_simulate(_designs(400, 0)).assign(p_gen_kw=10.0, p_mot_kw=40.0))
    return HvSettings(Normalisation.from_points(to_minimisation(table[[f"sim_{k}" for k in OBJECTIVES]].to_numpy())),
                      reference=1.1, n_samples=20_000, seed=7, screen=screen)  # fmt: skip


def _make_problem(model, stalled=None) -> HevProblem:
    return HevProblem(model, SPACE, stand_in_mass_kg, 1195.0, stalled=stalled)


class CountingFit:
    """``fit(X, Y)`` that records every training set it was given and returns a fitted stand-in."""

    def __init__(self):
        self.seen: list[np.ndarray] = []

    def __call__(self, X, Y):
        assert X.shape[0] == Y.shape[0] and Y.shape[1] == len(OBJECTIVES)
        self.seen.append(np.array(X))
        return AnalyticSurrogate()


# --------------------------------------------------------------------------------- hypervolume
def test_the_report_hypervolume_is_of_simulated_not_predicted_objectives():
    """Computing it from the surrogate's predictions must fail this test: the stand-in's error is large."""
    hv = _hv()
    res = optimise_and_resimulate(_make_problem(AnalyticSurrogate()), "nsga3", SMALL["nsga3"], stand_in_simulate, hv)
    sim_hv, n = hv.of(res.table)
    pred = res.table.assign(**{f"sim_{k}": res.table[f"pred_{k}"] for k in OBJECTIVES})
    pred_hv, _ = hv.of(pred)
    assert res.report["hypervolume"] == sim_hv.value and res.report["hypervolume_designs"] == n > 0
    assert res.report["hypervolume_method"] == sim_hv.method
    assert abs(pred_hv.value - sim_hv.value) > 5 * max(sim_hv.se, 1e-3 * sim_hv.value)
    assert res.report["hypervolume_pred"] == pred_hv.value


def test_only_screen_passing_designs_count_and_the_normalisation_comes_from_them():
    hv = _hv()
    res = optimise_and_resimulate(_make_problem(AnalyticSurrogate()), "nsga3", SMALL["nsga3"], stand_in_simulate, hv)
    strict = SCREEN.model_copy(update={"speed_dev_max": 1e-9})
    empty, n = screened_hypervolume(res.table, strict, hv.norm, 1.1, 1000, 0, 100)
    assert (empty.value, empty.se, empty.method, n) == (0.0, 0.0, "empty", 0)
    table = res.table.copy()
    table.loc[table.index[0], "sim_speed_dev"] = 5.0  # fails the screen: must not widen the range
    norm = screened_normalisation([table], SCREEN)
    ok = passes_screen(table, SCREEN)
    assert not ok[0] and 3 < ok.sum() < len(table)  # some designs fail the screen
    kept = table[ok]
    np.testing.assert_allclose(norm.nadir, to_minimisation(kept[[f"sim_{k}" for k in OBJECTIVES]].to_numpy()).max(0))
    back = normalisation_from_dict(normalisation_dict(norm))
    np.testing.assert_allclose(back.ideal, norm.ideal)
    np.testing.assert_allclose(back.nadir, norm.nadir)
    d = normalisation_dict(norm)
    assert d["ideal"]["v_max"] == kept["sim_v_max"].max() and d["ideal"]["fc"] == kept["sim_fc"].min()
    with pytest.raises(ValueError, match="no simulated design passes the screen"):
        screened_normalisation([table], strict)


# ----------------------------------------------------------------------------------- candidates
def test_candidates_are_diverse_and_the_uncertain_come_first():
    front = optimise(_make_problem(AnalyticSurrogate()), "nsga3", SMALL["nsga3"])
    span = np.ones(len(OBJECTIVES))
    assert len(front) > 10
    np.testing.assert_array_equal(select_candidates(front, len(front) + 5, "diverse", span), np.arange(len(front)))
    pick = select_candidates(front, 8, "diverse", span)
    assert len(pick) == len(set(pick)) == 8
    # farthest-point: the 8 chosen are more spread than the 8 nearest the first choice
    F = to_minimisation(front.F)
    d_pick = np.linalg.norm(F[pick][:, None] - F[pick][None], axis=2).sum()
    near = np.argsort(np.linalg.norm(F - F[pick[0]], axis=1))[:8]
    assert d_pick > np.linalg.norm(F[near][:, None] - F[near][None], axis=2).sum()
    std = np.full_like(front.F, 1e-3)
    std[3] = 10.0  # one design the surrogate knows nothing about
    unsure = dataclasses.replace(front, std=std)
    assert 3 in select_candidates(unsure, 2, "uncertainty", span)
    with pytest.raises(ValueError, match="criterion"):
        select_candidates(front, 2, "best", span)


# ----------------------------------------------------------------------------------- the loop
def test_infill_rounds_refit_on_the_doe_plus_simulated_candidates_only():
    X_doe = _designs(30, 1)
    Y_doe = stand_in_simulate(X_doe)[list(OBJECTIVES)].to_numpy()
    held_out = _designs(50, 2)
    fit = CountingFit()
    infill = InfillParams(rounds=2, designs_per_round=12, n_gen=5, criterion="uncertainty")
    res = surrogate_assisted(
        "nsga3", SMALL["nsga3"], infill, _make_problem, fit, X_doe, Y_doe, stand_in_simulate, _hv(), hv_oracle=0.5
    )
    r = res.report
    assert [e["round"] for e in r["rounds"]] == [0, 1, 2]
    sims = [e["n_simulations"] for e in r["rounds"]]
    assert 30 < sims[0] <= 30 + 12 and sims == sorted(sims) and r["n_simulations"] == sims[-1]
    assert all(b - a <= 12 for a, b in zip(sims, sims[1:], strict=False))  # designs_per_round
    assert all(e["hv_ratio_to_oracle"] == pytest.approx(e["hypervolume"] / 0.5) for e in r["rounds"])
    assert r["hv_ratio_to_oracle"] == pytest.approx(r["hypervolume"] / 0.5) and r["n_doe"] == 30
    # training data: the DOE, then the DOE plus every simulated candidate, growing round by round
    assert len(fit.seen) == 3 and len(fit.seen[0]) == 30
    np.testing.assert_array_equal(fit.seen[0], X_doe)
    for before, after in zip(fit.seen, fit.seen[1:], strict=False):
        assert len(after) > len(before)
        np.testing.assert_array_equal(after[: len(before)], before)
    simulated = res.table[[c for c in res.table.columns if c in DESIGN_VARS]].to_numpy(dtype=float)
    assert len(fit.seen[-1]) == r["rounds"][1]["n_simulations"]  # DOE + every candidate of rounds 0, 1
    seen = {tuple(x) for X in fit.seen for x in X}
    assert not seen & {tuple(x) for x in held_out}  # never the held-out set
    assert {tuple(x) for x in simulated[res.table["round"] < 2]} <= seen
    # every round's front is kept; a round's front is the non-dominated set of all candidates so far
    assert set(res.table["round"]) == {0, 1, 2} and res.schema.names[0] == "round"
    last = res.table[res.table["round"] == 2]
    F_last = to_minimisation(last[[f"sim_{k}" for k in OBJECTIVES]].to_numpy())
    assert nondominated_mask(F_last).all() and last["nondominated_sim"].all()
    for r in (0, 1):  # nothing simulated earlier dominates the final front
        earlier = to_minimisation(res.table.loc[res.table["round"] == r, [f"sim_{k}" for k in OBJECTIVES]].to_numpy())
        both = np.vstack([F_last, earlier])
        assert nondominated_mask(both)[: len(F_last)].all()
    hv = [e["hypervolume"] for e in r_rounds(res)]
    assert hv[-1] >= hv[0]  # the archive keeps what earlier rounds found
    assert (res.table.groupby("round").size() <= SMALL["nsga3"].pop_size * 2).all()  # thinned to the population
    assert passes_screen(res.table, SCREEN).all()  # a front holds only usable designs


def r_rounds(res):
    return res.report["rounds"]


def test_round_zero_alone_is_the_one_shot_protocol():
    X_doe = _designs(20, 3)
    Y_doe = stand_in_simulate(X_doe)[list(OBJECTIVES)].to_numpy()
    infill = InfillParams(rounds=0, designs_per_round=10_000)
    res = surrogate_assisted(
        "moga", SMALL["moga"], infill, _make_problem, CountingFit(), X_doe, Y_doe, stand_in_simulate, _hv()
    )
    one = optimise_and_resimulate(_make_problem(AnalyticSurrogate()), "moga", SMALL["moga"], stand_in_simulate, _hv())
    usable = passes_screen(one.table, SCREEN)
    F = to_minimisation(one.table.loc[usable, [f"sim_{k}" for k in OBJECTIVES]].to_numpy())
    front = one.table[usable][nondominated_mask(F)].reset_index(drop=True)  # the archive of one round
    front["nondominated_sim"] = True
    pd.testing.assert_frame_equal(res.table.drop(columns="round"), front)
    assert res.report["n_simulations"] == 20 + len(one.table) and res.report["hv_ratio_to_oracle"] is None


# ------------------------------------------------------------------------------------ oracle
def test_the_simulator_model_simulates_each_population_once():
    calls = []

    def simulate(X):
        calls.append(len(X))
        return stand_in_simulate(X)

    model = SimulatorModel(simulate)
    X = _designs(7, 4)
    np.testing.assert_array_equal(model.predict(X), stand_in_simulate(X)[list(OBJECTIVES)].to_numpy())
    assert not model.stalled(X).any() and calls == [7] and model.n_simulations == 7
    model.predict(X[:3])
    assert calls == [7, 3] and model.n_simulations == 10


def test_the_oracle_optimises_the_simulator_itself():
    settings = OracleParams(**SMALL["nsga3"].model_dump())
    hv = _hv()
    res = oracle(_make_problem, settings, stand_in_simulate, hv)
    t = res.table
    for k in OBJECTIVES:  # no surrogate error: what it optimised is what was simulated
        np.testing.assert_array_equal(t[f"pred_{k}"].to_numpy(), t[f"sim_{k}"].to_numpy())
    r = res.report
    assert r["algo"] == "oracle" and r["n_simulations"] >= settings.pop_size * settings.n_gen
    assert r["rounds"][0]["hv_ratio_to_oracle"] == 1.0 and (t["round"] == 0).all()
    assert np.all(stand_in_mass_kg(res.front.X) <= 1195.0)


def test_oracle_and_infill_params_are_validated():
    from hevlib.params import OptimiseParams

    algos = {"nsga3": AlgoParams()}
    assert OptimiseParams(algorithms=algos, sources=["nsga3", "oracle"]).oracle.algorithm == "nsga3"
    with pytest.raises(ValueError, match="moga is not in optimise.algorithms"):
        OptimiseParams(algorithms=algos, sources=["moga"])
    with pytest.raises(ValueError):
        InfillParams(criterion="best")


# ------------------------------------------------------------------------------------ judging
def test_every_round_is_judged_on_simulated_objectives_of_the_archive():
    """The path behind ``reports/optimise_<algo>.json``: the front's and the archive's hypervolumes are of
    what the simulator said (recomputed here from the designs alone), never of the predictions."""
    from hevlib.optimise.archive import SimulationLog

    X_doe = _designs(30, 1)
    R_doe = stand_in_simulate(X_doe)
    log = SimulationLog(stand_in_simulate)
    log.record(X_doe, R_doe)
    hv = _hv()
    infill = InfillParams(rounds=1, designs_per_round=12, n_gen=5, criterion="diverse")
    res = surrogate_assisted(
        "nsga3",
        SMALL["nsga3"],
        infill,
        _make_problem,
        CountingFit(),
        X_doe,
        R_doe[list(OBJECTIVES)].to_numpy(),
        log,
        hv,
    )
    last = res.table[res.table["round"] == 1]
    truth = simulated_as_front(stand_in_simulate(last[list(DESIGN_VARS)].to_numpy())).assign(
        **{v: last[v].to_numpy() for v in DESIGN_VARS}
    )
    assert res.report["hypervolume"] == hv.of(truth)[0].value > 0
    everything = log.table("all").to_pandas()
    X_all = everything[list(DESIGN_VARS)].to_numpy()
    truth_all = simulated_as_front(stand_in_simulate(X_all)).assign(
        **{v: X_all[:, j] for j, v in enumerate(DESIGN_VARS)}
    )
    assert res.report["archive"]["hypervolume"] == hv.of(truth_all)[0].value
    assert res.report["rounds"][-1]["archive_hypervolume"] == res.report["archive"]["hypervolume"]
    assert res.report["archive"]["n_simulations"] == res.report["n_simulations"] == len(log)
    pred = last.assign(**{f"sim_{k}": last[f"pred_{k}"] for k in OBJECTIVES})
    assert abs(hv.of(pred)[0].value - res.report["hypervolume"]) > 1e-3 * res.report["hypervolume"]


def test_the_archive_front_is_non_dominated_by_simulation_not_by_prediction():
    from hevlib.optimise.infill import archive_front

    X = _designs(2, 9)
    sim = stand_in_simulate(X)
    table = simulated_as_front(sim).assign(**{v: X[:, j] for j, v in enumerate(DESIGN_VARS)})
    for k in OBJECTIVES:  # design 0 is better in every simulated objective; the predictions say the opposite
        good, bad = (1.0, 2.0) if k not in ("v_max", "f_max") else (2.0, 1.0)
        table[f"sim_{k}"] = [good, bad]
        table[f"pred_{k}"] = [bad, good]
    front = archive_front([table], None, _hv(screen=None))
    assert len(front) == 1 and front["p_eng_kw"].item() == X[0, 0]
