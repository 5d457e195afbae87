"""The three many-objective optimisers (NSGA-III, MOEA/D, the weighted-sum GA), each
``(problem, settings: AlgoParams, progress, initial) -> Front``, seeded from the settings; :func:`optimise`
dispatches by name and :func:`run` is the only caller of :func:`pymoo.optimize.minimize`. They take any
pymoo ``Problem`` (tests run them on DTLZ2 and ZDT1). ``initial`` (designs) resumes a search from an
earlier population (the infill loop) instead of a random start.

A :class:`Front` is always feasible, non-dominated (in its model's objectives) and deduplicated; designs
the algorithm returned that violate a constraint are dropped and counted.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from pymoo.algorithms.base.genetic import GeneticAlgorithm
from pymoo.algorithms.moo.nsga3 import NSGA3
from pymoo.core.problem import Problem
from pymoo.core.survival import Survival
from pymoo.operators.crossover.sbx import SBX
from pymoo.operators.mutation.pm import PM
from pymoo.operators.sampling.rnd import FloatRandomSampling
from pymoo.operators.selection.tournament import TournamentSelection
from pymoo.optimize import minimize
from pymoo.util.ref_dirs.energy import RieszEnergyReferenceDirectionFactory
from pymoo.util.reference_direction import UniformReferenceDirectionFactory

from hevlib.indicators import Normalisation, nondominated_mask
from hevlib.optimise.moead import MOEADBounded
from hevlib.optimise.problem import NOT_EVALUATED, HevProblem, _evaluate_base, _integer_repair, _Reformulated, _repaired
from hevlib.params import AlgoParams

#: Distribution indices of simulated binary crossover and polynomial mutation (Deb's usual values).
SBX_ETA = 15.0
PM_ETA = 20.0
ALGORITHMS = ("nsga3", "moead", "moga")


# --------------------------------------------------------------------------------- building blocks
def reference_directions(
    n_obj: int, *, partitions: list[int] | None = None, n_points: int | None = None, seed: int = 0
) -> np.ndarray:
    """Directions on the unit simplex: layered Das-Dennis (``partitions``) or Riesz s-energy (``n_points``).

    ``partitions=[p1, p2, ...]``: layer ``i`` is the Das-Dennis lattice with ``p_i`` partitions shrunk
    towards the centroid by ``0.5**i`` (Deb & Jain 2014's two-layer scheme for [2, 1]; 11 objectives:
    C(12, 2) = 66 boundary + 11 inner = 77 directions). Deterministic.
    ``n_points``: exactly that many directions spread by minimising the Riesz s-energy (pymoo
    "energy"), seeded; costs seconds for a few hundred points in 11 dimensions.
    """
    if (partitions is None) == (n_points is None):
        raise ValueError("reference_directions: give exactly one of partitions or n_points")
    if n_points is not None:
        if n_points < 1:
            raise ValueError("reference_directions: n_points must be positive")
        if n_points == 1 or n_obj == 1:
            return np.full((n_points, n_obj), 1.0 / n_obj)
        if n_points < n_obj:
            raise ValueError(
                f"reference_directions: {n_points} energy directions cannot cover {n_obj} "
                f"objectives (use 1 or at least {n_obj})"
            )
        return _riesz_directions(int(n_obj), int(n_points), int(seed)).copy()
    if not partitions or any(p < 1 for p in partitions):
        raise ValueError(f"ref_dirs_partitions: need at least one layer of >= 1 partitions, got {partitions}")
    layers = [
        UniformReferenceDirectionFactory(n_obj, n_partitions=int(p), scaling=0.5**i).do()
        for i, p in enumerate(partitions)
    ]
    return np.unique(np.vstack(layers).round(12), axis=0)


@functools.lru_cache(maxsize=16)
def _riesz_directions(n_obj: int, n_points: int, seed: int) -> np.ndarray:
    """Riesz s-energy directions, cached: deterministic for given arguments and costly to recompute."""
    ref = RieszEnergyReferenceDirectionFactory(n_obj, n_points).do(seed=seed)
    ref.setflags(write=False)
    return ref


def estimate_normalisation(problem: Problem, n_samples: int, seed) -> Normalisation:
    """Ideal and nadir (minimisation form) of ``n_samples`` uniform designs (integers rounded) through the
    problem's model: the range normalisation MOEA/D's decomposition and the MOGA's weighted sums need
    so that kilograms and SOC fractions weigh alike. Infeasible samples count too (they bound the range),
    but not those that break an exact rule: they are never evaluated (``NOT_EVALUATED``)."""
    rng = np.random.default_rng(seed)
    X = problem.xl + rng.random((int(n_samples), problem.n_var)) * (problem.xu - problem.xl)
    F, _ = _evaluate_base(problem, _repaired(problem, X))
    evaluated = np.all(F < NOT_EVALUATED, axis=1)
    return Normalisation.from_points(F[evaluated] if np.any(evaluated) else F)


def _settings_normalisation(problem: Problem, settings: AlgoParams) -> Normalisation:
    """:func:`estimate_normalisation` on ``settings.norm_samples`` designs, seeded from (but independent
    of) the algorithm's own seed."""
    return estimate_normalisation(problem, settings.norm_samples, np.random.SeedSequence(settings.seed).spawn(1)[0])


def _operators(problem: Problem, settings: AlgoParams, initial: np.ndarray | None = None) -> dict:
    """Study operators: SBX with crossover probability ``crossover_prob`` per mating, polynomial mutation
    of every offspring with probability ``mutation_prob`` per variable; the integer repair. The first
    population is uniform random, or ``initial`` (designs, e.g. the last population of an earlier round)."""
    return dict(
        sampling=FloatRandomSampling() if initial is None else np.asarray(initial, dtype=float),
        crossover=SBX(prob=settings.crossover_prob, eta=SBX_ETA),
        mutation=PM(prob=1.0, prob_var=settings.mutation_prob, eta=PM_ETA),
        repair=_integer_repair(problem),
    )


def run(problem: Problem, algorithm, n_gen: int, seed: int, progress: Callable[[int, int], None] | None = None):
    """The one call of :func:`pymoo.optimize.minimize`: ``n_gen`` generations, seeded, quiet;
    ``progress(generation, n_gen)`` after each generation (a progress bar at a terminal)."""
    extra = {} if progress is None else {"callback": lambda algorithm: progress(int(algorithm.n_gen), int(n_gen))}
    return minimize(problem, algorithm, ("n_gen", int(n_gen)), seed=int(seed), verbose=False, **extra)


@dataclass(frozen=True)
class Front:
    """A final front: feasible, non-dominated in its predicted objectives, deduplicated, sorted by X.

    ``X`` (n, n_var) with integer columns whole; ``F`` (n, n_obj) predicted objectives in natural units
    (for a generic pymoo problem: its own F); ``std`` the surrogate's standard deviation or None.
    ``n_evaluations`` counts every design the algorithm's model evaluated (normalisation samples
    included); ``runtime_s`` is the optimiser's wall time; ``n_candidates`` the distinct designs the
    algorithm returned, of which ``n_infeasible`` violated the constraint and were dropped.
    """

    algo: str
    X: np.ndarray
    F: np.ndarray
    std: np.ndarray | None
    n_evaluations: int
    runtime_s: float
    n_candidates: int
    n_infeasible: int
    settings: dict = field(default_factory=dict)
    population: np.ndarray | None = None  # the algorithm's final population (to resume the search from)

    def __len__(self) -> int:
        return len(self.X)


def _front(
    problem: Problem,
    X: np.ndarray,
    *,
    algo: str,
    n_evaluations: int,
    t0: float,
    settings: dict,
    population: np.ndarray | None = None,
) -> Front:
    X = np.unique(_repaired(problem, np.atleast_2d(X)), axis=0)
    F, G = _evaluate_base(problem, X)
    feasible = np.all(G <= 0.0, axis=1)
    X, F = X[feasible], F[feasible]
    keep = nondominated_mask(F)
    X, F = X[keep], F[keep]
    std = None
    if isinstance(problem, HevProblem) and len(X):
        F, std = problem.predict(X)
    return Front(
        algo=algo,
        X=X,
        F=F,
        std=std,
        n_evaluations=int(n_evaluations),
        runtime_s=time.perf_counter() - t0,
        n_candidates=len(feasible),
        n_infeasible=int(np.count_nonzero(~feasible)),
        settings=settings,
        population=None if population is None else np.asarray(population, dtype=float),
    )


def _by_violation_then_random(pop, P, random_state=None, **kwargs) -> np.ndarray:
    """NSGA-III's binary tournament (pymoo's ``comp_by_cv_then_random``: the smaller constraint violation
    wins, a tie or two feasible parents is a coin toss) with every coin drawn from the algorithm's seeded
    ``random_state``. pymoo 0.6.2's own version breaks a tie between two infeasible parents of equal
    violation with ``compare(..., return_random_if_equal=True)`` without passing it, i.e. with a fresh
    OS-seeded generator, so the search did not reproduce from process to process (measured on the
    pipeline's NSGA-III stage: four different fronts in six runs of the same inputs)."""
    cv = pop.get("CV")[:, 0]
    S = np.empty(P.shape[0], dtype=int)
    for i in range(P.shape[0]):
        a, b = P[i, 0], P[i, 1]
        if (cv[a] > 0.0 or cv[b] > 0.0) and cv[a] != cv[b]:
            S[i] = a if cv[a] < cv[b] else b
        else:
            S[i] = random_state.choice([a, b])
    return S[:, None]


# ------------------------------------------------------------------------------------- algorithms
def nsga3(problem: Problem, settings: AlgoParams, progress=None, initial: np.ndarray | None = None) -> Front:
    """NSGA-III with two-layer Das-Dennis reference directions (``settings.ref_dirs_partitions``).

    Why Das-Dennis layers and not Riesz energy: with 11 objectives one Das-Dennis layer places no
    direction inside the simplex until 11 partitions (C(21, 10) = 352 716 directions); two layers
    ([2, 1]: 66 directions on the boundary, 11 pulling towards the centre; Deb & Jain's scheme for 8-15
    objectives) give 77 directions deterministically and at no cost, and NSGA-III only uses them to keep
    niches. Riesz energy (used by :func:`moead`, which needs exactly one direction per individual) is
    stochastic and costs seconds. The population is ``max(pop_size, n_directions)`` (pymoo wants at
    least one individual per direction). The front is taken from the whole final population (pymoo's
    ``Result.X`` keeps only the survivor closest to each direction).
    """
    t0 = time.perf_counter()
    ref = reference_directions(problem.n_obj, partitions=list(settings.ref_dirs_partitions))
    pop_size = max(settings.pop_size, len(ref))
    algorithm = NSGA3(
        ref,
        pop_size=pop_size,
        eliminate_duplicates=True,
        selection=TournamentSelection(func_comp=_by_violation_then_random),
        **_operators(problem, settings, initial),
    )
    res = run(problem, algorithm, settings.n_gen, settings.seed, progress)
    return _front(
        problem,
        res.pop.get("X"),
        population=res.pop.get("X"),
        algo="nsga3",
        n_evaluations=res.algorithm.evaluator.n_eval,
        t0=t0,
        settings={"pop_size": pop_size, "n_ref_dirs": len(ref), "ref_dirs": "das-dennis layers"},
    )


def moead(problem: Problem, settings: AlgoParams, progress=None, initial: np.ndarray | None = None) -> Front:
    """MOEA/D with bounded replacement (:class:`hevlib.optimise.moead.MOEADBounded`, a pymoo ``Algorithm``
    run by :func:`run` like the others): one subproblem per individual on
    ``pop_size`` Riesz s-energy directions (seeded, so the directions cover the simplex's interior),
    neighbourhoods of ``n_neighbors``, mating and replacement there with probability ``delta``, at most
    ``n_replace`` slots per offspring, Tchebycheff (or PBI) on objectives normalised online, constraints
    by constraint domination. The study's SBX / polynomial mutation and the integer repair. Infeasible
    designs of the final population are dropped from the front and counted (``n_infeasible``)."""
    if settings.n_neighbors > settings.pop_size:
        raise ValueError(
            f"optimise.algorithms.moead.n_neighbors: {settings.n_neighbors} exceeds pop_size {settings.pop_size}"
        )
    t0 = time.perf_counter()
    ref = reference_directions(problem.n_obj, n_points=settings.pop_size, seed=settings.seed)
    algorithm = MOEADBounded(
        ref,
        n_neighbors=settings.n_neighbors,
        delta=settings.delta,
        n_replace=settings.n_replace,
        decomposition=settings.decomposition,
        seed=settings.seed,
        crossover_prob=settings.crossover_prob,
        mutation_prob=settings.mutation_prob,
        sbx_eta=SBX_ETA,
        pm_eta=PM_ETA,
        repair=lambda Z: _repaired(problem, Z),
        initial=initial,
    )
    # pymoo counts the initial population as generation 1: n_gen generations are n_gen + 1 of its iterations
    step = None if progress is None else (lambda done, total: progress(done - 1, total - 1) if done > 1 else None)
    res = run(problem, algorithm, settings.n_gen + 1, settings.seed, step)
    X, n_eval = res.pop.get("X"), res.algorithm.evaluator.n_eval
    return _front(
        problem,
        X,
        population=X,
        algo="moead",
        n_evaluations=n_eval,
        t0=t0,
        settings={"pop_size": len(ref), "n_ref_dirs": len(ref), "ref_dirs": "riesz energy"},
    )


def weighted_sum_ranks(F: np.ndarray, cv: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Rank (n, k) of each design under each weighted sum: feasible before infeasible, then by
    ``F @ w`` (feasible) or constraint violation (infeasible); 0 is the best design for that weight."""
    S = np.asarray(F, dtype=float) @ np.asarray(weights, dtype=float).T
    R = np.empty(S.shape, dtype=np.int64)
    for k in range(S.shape[1]):
        order = np.lexsort((S[:, k], cv))
        R[order, k] = np.arange(len(order))
    return R


def _round_robin_score(R: np.ndarray) -> np.ndarray:
    """Order in which a round-robin over the weights (each weight taking its best design not yet taken)
    reaches each design: ``min_k (R[i, k] * n_weights + k)``; lower is better."""
    return np.min(R * R.shape[1] + np.arange(R.shape[1])[None, :], axis=1)


class _WeightedSumSurvival(Survival):
    """Survivors by round-robin over the weight vectors: weight 1's best, weight 2's best, ..., then each
    weight's second best, ... (designs already taken are skipped). Elitist for every weight: each
    weight's best design always survives while ``n_survive >= n_weights``."""

    def __init__(self, weights: np.ndarray):
        super().__init__(filter_infeasible=False)
        self.weights = weights

    def _do(self, problem, pop, *args, n_survive=None, **kwargs):
        R = weighted_sum_ranks(pop.get("F"), pop.get("CV")[:, 0], self.weights)
        order = np.argsort(_round_robin_score(R), kind="stable")[:n_survive]
        survivors = pop[order]
        survivors.set("score", np.arange(len(order)))
        return survivors


def _by_score(pop, P, **kwargs):
    """Binary tournament on the survival order (lower wins)."""
    score = pop.get("score")
    return np.where(score[P[:, 0]] <= score[P[:, 1]], P[:, 0], P[:, 1])


def moga(problem: Problem, settings: AlgoParams, progress=None, initial: np.ndarray | None = None) -> Front:
    """Weighted-sum GA over ``n_weights`` weight vectors in one population -> a front.

    - Objectives normalised by :func:`estimate_normalisation` (``norm_samples`` seeded designs through
      the same surrogate), so a weight means the same share of every objective's range.
    - Weights: ``n_weights`` Riesz s-energy directions on the simplex (seeded; they include the
      single-objective corners).
    - One GA population of ``pop_size`` runs ``n_gen`` generations (SBX, polynomial mutation, integer
      repair as for the others). Every design is evaluated once per generation and scored under every
      weighted sum ``w . F_norm`` (mass constraint first: feasible designs before infeasible ones,
      those by violation). Survival takes designs round-robin over the weights (each weight its best
      not yet taken), so each weighted sum keeps about ``pop_size / n_weights`` designs and its best
      one always; parents come from binary tournaments on that order. This is ``n_weights``
      single-objective GAs sharing one population and its evaluations (in the spirit of Hughes'
      multiple-single-objective Pareto sampling), so the budget is the study's ``pop_size x n_gen``
      evaluations, the same as NSGA-III and MOEA/D (independent runs would cost ``n_weights`` times
      that; measured: ~6 min at the full budget on this machine, against ~10 s).
    - The front: the final population's feasible, non-dominated, distinct designs -- each weighted
      sum's best few (``pop_size / n_weights`` of them), not only its single best, so that the GA hands
      a front of some size to re-simulation (the single bests alone are at most ``n_weights`` supported
      points: 13 designs on the sizing problem).
    """
    if settings.n_weights > settings.pop_size:
        raise ValueError(
            f"optimise.algorithms.moga.n_weights: {settings.n_weights} exceeds pop_size {settings.pop_size}"
        )
    t0 = time.perf_counter()
    norm = _settings_normalisation(problem, settings)
    weights = reference_directions(problem.n_obj, n_points=settings.n_weights, seed=settings.seed)
    algorithm = GeneticAlgorithm(
        pop_size=settings.pop_size,
        selection=TournamentSelection(func_comp=_by_score),
        survival=_WeightedSumSurvival(weights),
        eliminate_duplicates=True,
        advance_after_initial_infill=True,
        **_operators(problem, settings, initial),
    )
    res = run(_Reformulated(problem, norm), algorithm, settings.n_gen, settings.seed, progress)
    pop = res.pop
    return _front(
        problem,
        pop.get("X"),
        population=pop.get("X"),
        algo="moga",
        n_evaluations=res.algorithm.evaluator.n_eval + settings.norm_samples,
        t0=t0,
        settings={
            "pop_size": settings.pop_size,
            "n_weights": len(weights),
            "weights": "riesz energy",
            "normalisation": norm.to_dict(),
        },
    )


_WRAPPERS: dict[str, Callable[..., Front]] = {"nsga3": nsga3, "moead": moead, "moga": moga}


def optimise(
    problem: Problem,
    algo: str,
    settings: AlgoParams,
    progress: Callable[[int, int], None] | None = None,
    initial: np.ndarray | None = None,
) -> Front:
    """Run algorithm ``algo`` (one of :data:`ALGORITHMS`) on ``problem`` with ``settings``;
    ``progress(generation, n_gen)`` after each generation; ``initial``: start population (else random)."""
    if algo not in _WRAPPERS:
        raise ValueError(f"optimise: unknown algorithm {algo!r} (use one of {', '.join(ALGORITHMS)})")
    return _WRAPPERS[algo](problem, settings, progress, initial)
