"""Batch ParEGO on Gaussian processes: the field's standard for expensive many-objective problems.

Knowles (2006) turns the many-objective problem into a random scalar one per infill point: each point
gets its own weight vector ``w`` on the simplex and the augmented Chebyshev scalarisation
``g_w(f) = max_j w_j f_j + rho * sum_j w_j f_j`` of normalised objectives. BoTorch's qNParEGO (Daulton
et al. 2020; its authors' recommendation beyond three objectives) keeps one model per objective and
scalarises *posterior samples*, so the acquisition is a Monte Carlo expected improvement of ``g_w`` over
the best design found so far. That is what :func:`parego` does, with the eleven
:class:`~hevlib.surrogates.gp.GaussianProcesses`:

- each round the GPs are refitted on every design simulated so far (the DOE included; nothing else),
  and the objectives are normalised by the ideal and nadir of this run's own screen-passing designs
  (a search never sees a normalisation built from data it did not produce);
- a pool of candidates: ``pool_random`` uniform designs plus ``pool_local`` Gaussian moves (5 % of each
  range) around the non-dominated screen-passing designs simulated so far; integers repaired, the gear
  set snapped to a buildable one, and designs that break an exact constraint (test mass,
  ``p_gen < p_mot``) dropped;
- ``n_samples`` joint posterior draws per candidate (common random numbers across candidates);
  for each of ``batch`` Dirichlet weight vectors the candidate with the largest
  ``E[max(g* - g_w(F), 0) * 1{speed_dev <= max}]`` is taken (σ enters through the draws; the indicator
  is the screen's speed-deviation rule, so improvement only counts where the design would pass);
  a candidate is taken once per round;
- the batch is simulated and the loop repeats until ``budget`` simulations (the DOE's included).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hevlib.design import DESIGN_VARS, OBJECTIVES
from hevlib.optimise.infill import own_normalisation
from hevlib.optimise.problem import HevProblem, _repaired
from hevlib.pareto import nondominated_mask, to_minimisation
from hevlib.screen import passes, speed_dev_max

_SPEED_DEV = OBJECTIVES.index("speed_dev")


@dataclass(frozen=True)
class ParegoSettings:
    """Batch size, candidate pool and Monte Carlo settings of :func:`parego`."""

    batch: int = 100
    pool_random: int = 2000
    pool_local: int = 2000
    local_step: float = 0.05
    n_samples: int = 32
    rho: float = 0.05
    seed: int = 0


def screen_mask(X: np.ndarray, responses: pd.DataFrame, screen) -> np.ndarray:
    """(n,) bool: simulated designs (``X`` and their responses) that pass every enabled screen rule."""
    cols = {v: X[:, j] for j, v in enumerate(DESIGN_VARS)}
    cols.update({k: responses[k].to_numpy(dtype=float) for k in ("speed_dev", "m_veh", "stalled")})
    return passes(cols, screen)


def candidate_pool(
    problem: HevProblem, X_best: np.ndarray, settings: ParegoSettings, rng: np.random.Generator
) -> np.ndarray:
    """Uniform designs plus local moves around ``X_best``, repaired, inside the exact constraints."""
    lo, hi = problem.xl, problem.xu
    parts = [lo + rng.random((settings.pool_random, problem.n_var)) * (hi - lo)]
    if len(X_best) and settings.pool_local:
        centre = X_best[rng.integers(0, len(X_best), settings.pool_local)]
        step = settings.local_step * (hi - lo) * rng.standard_normal(centre.shape)
        parts.append(np.clip(centre + step, lo, hi))
    X = _repaired(problem, np.vstack(parts))
    G = problem.constraint(X, np.zeros((len(X), len(OBJECTIVES))))  # speed_dev judged by the draws, not here
    exact = [i for i, name in enumerate(problem.constraint_names) if name in ("mass", "gen_below_motor")]
    keep = np.all(G[:, exact] <= 0.0, axis=1) if exact else np.ones(len(X), dtype=bool)
    return np.unique(X[keep], axis=0)


def choose_batch(
    draws_norm: np.ndarray,
    feasible: np.ndarray,
    best_norm: np.ndarray,
    weights: np.ndarray,
    rho: float,
) -> np.ndarray:
    """Indices into the pool, one per weight vector (distinct): the Monte Carlo expected improvement of
    the augmented Chebyshev scalarisation over the best of ``best_norm`` (normalised objectives of the
    screen-passing designs so far), counted on draws that pass the speed rule (``feasible``, (S, m)).
    ``draws_norm``: (S, m, 11) normalised posterior draws. With no improvement anywhere, the candidate
    with the best expected scalarisation among the most probably feasible is taken."""
    chosen: list[int] = []
    p_feasible = feasible.mean(axis=0)
    for w in weights:
        g = np.max(draws_norm * w, axis=2) + rho * np.sum(draws_norm * w, axis=2)  # (S, m)
        if len(best_norm):
            g_best = float(np.min(np.max(best_norm * w, axis=1) + rho * np.sum(best_norm * w, axis=1)))
            score = np.mean(np.maximum(g_best - g, 0.0) * feasible, axis=0)
        else:
            score = np.zeros(g.shape[1])
        score[chosen] = -np.inf
        if not np.max(score) > 0.0:
            fallback = -g.mean(axis=0) + 1e6 * p_feasible
            fallback[chosen] = -np.inf
            score = fallback
        chosen.append(int(np.argmax(score)))
    return np.array(chosen, dtype=np.int64)


def parego(
    make_problem: Callable[..., HevProblem],
    fit: Callable[[np.ndarray, np.ndarray], object],
    X_doe: np.ndarray,
    responses_doe: pd.DataFrame,
    simulate: Callable[[np.ndarray], pd.DataFrame],
    screen,
    budget: int,
    settings: ParegoSettings = ParegoSettings(),
    progress: Callable[[int, int], None] | None = None,
) -> tuple[np.ndarray, pd.DataFrame]:
    """Run batch ParEGO from the DOE until ``budget`` simulations; returns every simulated design and its
    responses (the DOE first). ``fit(X, Y)`` fits the GPs (``predict``, ``sample``); ``simulate(X)`` runs
    the simulator; ``screen`` is ``params.screen``."""
    rng = np.random.default_rng(settings.seed)
    X = np.asarray(X_doe, dtype=float)
    R = responses_doe.reset_index(drop=True)
    while len(X) < budget:
        q = min(settings.batch, budget - len(X))
        Y = R[list(OBJECTIVES)].to_numpy(dtype=float)
        ok = np.all(np.isfinite(Y), axis=1)
        model = fit(X[ok], Y[ok])
        problem = make_problem(model)
        F_min = to_minimisation(Y)
        passing = screen_mask(X, R, screen) & ok
        norm = own_normalisation(F_min, passing)
        best = norm(F_min[passing])
        nd = nondominated_mask(best)
        pool = candidate_pool(problem, X[np.flatnonzero(passing)[nd]], settings, rng)
        draws = model.sample(pool, settings.n_samples, rng)  # (S, m, 11) natural units
        feasible = (
            speed_dev_max(problem.speed_dev_max).mask({"speed_dev": draws[..., _SPEED_DEV]})
            if problem.speed_dev_max is not None
            else np.ones(draws.shape[:2], dtype=bool)
        )
        weights = rng.dirichlet(np.ones(len(OBJECTIVES)), q)
        pick = choose_batch(norm(to_minimisation(draws)), feasible, best[nd], weights, settings.rho)
        X_new = pool[pick]
        R_new = simulate(X_new).reset_index(drop=True)
        X, R = np.vstack([X, X_new]), pd.concat([R, R_new], ignore_index=True)
        if progress is not None:
            progress(len(X), budget)
    return X, R


__all__ = ["ParegoSettings", "candidate_pool", "choose_batch", "parego", "screen_mask"]
