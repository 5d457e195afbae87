"""Batch Thompson-sampling ParEGO (:mod:`hevlib.optimise.tsparego`, issue 55): the pathwise samples against the
exact posterior of BoTorch's own model, the exact rules on every candidate, the budget, and bit-for-bit runs."""

from __future__ import annotations

import numpy as np
import pytest
from test_infill import _designs
from test_optimise import SPACE, stand_in_mass_kg, stand_in_simulate

from hevlib.design import DESIGN_VARS, INTEGER_MASK, gear_set_buildable
from hevlib.determinism import torch as _torch
from hevlib.optimise.problem import HevProblem, admissible_lhs
from hevlib.optimise.tsparego import Paths, TsParegoSettings, candidate_pool, fit_hyper, tsparego

J_R, J_S = DESIGN_VARS.index("n_r"), DESIGN_VARS.index("n_s")


def _problem() -> HevProblem:
    return HevProblem(
        None, SPACE, stand_in_mass_kg, 1195.0, speed_dev_max=0.4, gen_below_motor=True, buildable_gear_set=True
    )


def _smooth(X: np.ndarray) -> np.ndarray:
    """Two smooth targets of the normalised designs."""
    U = (X - SPACE.lower) / (SPACE.upper - SPACE.lower)
    return np.column_stack([np.sin(3 * U[:, 0]) + U[:, 1] ** 2, np.cos(2 * U[:, 2] + U[:, 3]) - U[:, 4]])


def test_path_samples_match_botorchs_exact_posterior():
    """Matheron samples of the model conditioned on every design: their mean and variance at test designs are the
    exact posterior's (BoTorch's ``SingleTaskGP`` with the same hyperparameters) within Monte Carlo error."""
    torch = _torch()
    from botorch.models import SingleTaskGP
    from botorch.models.transforms import Normalize, Standardize

    X, X_test = _designs(12, 1), _designs(6, 2)
    T = _smooth(X)
    hyper = fit_hyper(SPACE, X, T)
    q = 4000
    S = Paths(SPACE, X, T, hyper, q, 4096, np.random.default_rng(0)).at(X_test)  # (q, 6, 2)
    bounds = torch.as_tensor(np.vstack([SPACE.lower, SPACE.upper]), dtype=torch.float64)
    model = SingleTaskGP(
        torch.as_tensor(X), torch.as_tensor(T), input_transform=Normalize(d=7, bounds=bounds),
        outcome_transform=Standardize(m=2),
    )  # fmt: skip
    model.load_state_dict(hyper.state, strict=False)
    model.eval()
    with torch.no_grad():
        post = model.posterior(torch.as_tensor(X_test))  # the latent function, in the targets' units
        mean, var = post.mean.numpy(), post.variance.numpy()
    se = np.sqrt(var / q)
    assert np.all(np.abs(S.mean(axis=0) - mean) < 5 * se + 1e-3 * np.sqrt(var))
    # the random-Fourier prior's own error is about 1 / sqrt(features) of the prior variance
    prior = hyper.y_std**2
    assert np.all(np.abs(S.var(axis=0) - var) < 0.15 * var + 0.005 * prior)
    # at a design it was conditioned on, a path passes within the noise of the data
    at_data = Paths(SPACE, X, T, hyper, 200, 4096, np.random.default_rng(1)).at(X[:3])
    assert np.all(np.abs(at_data.mean(axis=0) - T[:3]) < 0.05 * T.std(axis=0))


def test_every_candidate_meets_the_exact_rules_and_is_repaired():
    problem = _problem()
    rng = np.random.default_rng(5)
    centres = admissible_lhs(problem, SPACE, 10, 3)
    settings = TsParegoSettings(pool=400, local_pool=400)
    for edge in (0.02, 0.8):
        P = candidate_pool(problem, SPACE, centres, edge, settings, rng)
        assert len(P) > 200
        assert problem.admissible(P).all()
        np.testing.assert_array_equal(P[:, INTEGER_MASK], np.round(P[:, INTEGER_MASK]))
        assert gear_set_buildable(P[:, J_R].astype(int), P[:, J_S].astype(int)).all()
        assert SPACE.check(P) is not None
        assert len(np.unique(P, axis=0)) == len(P)


def _run(seed: int, budget: int = 70):
    problem = _problem()
    X0 = admissible_lhs(problem, SPACE, 30, 1)
    settings = TsParegoSettings(budget=budget, batch=10, pool=300, local_pool=200, subset=40, refit_every=2,
                                n_features=128, seed=seed)  # fmt: skip
    return tsparego(settings, problem, SPACE, X0, stand_in_simulate(X0), stand_in_simulate, log_targets=("fc",))


def test_a_run_spends_its_budget_on_new_admissible_designs_and_reproduces_bit_for_bit():
    a, b, c = _run(3), _run(3), _run(4)
    assert len(a.X) == 70 and len(a.R) == 70
    assert len(np.unique(a.X, axis=0)) == 70  # nothing simulated twice
    assert _problem().admissible(a.X[30:]).all()
    np.testing.assert_array_equal(a.X, b.X)
    assert a.R.equals(b.R)
    assert not np.array_equal(a.X, c.X)
    assert [r["refit"] for r in a.rounds] == [i % 2 == 0 for i in range(len(a.rounds))]
    assert all(0.02 <= r["trust_region"] <= 0.8 for r in a.rounds)


def test_settings_are_checked():
    with pytest.raises(ValueError, match="tsparego.batch"):
        TsParegoSettings(batch=0)
    with pytest.raises(ValueError, match="tr_min"):
        TsParegoSettings(tr_min=0.5, tr_init=0.2)
