"""Many-objective sizing on a surrogate (SPEC section 8): problem, algorithms, fronts, re-simulation.

- :class:`HevProblem` -- the seven design variables, the eleven objectives in minimisation form (maximised
  objectives are negated by :func:`hevlib.pareto.to_minimisation`, the one place that does it) and one inequality
  constraint, the exact test mass at most ``m_veh_max_kg`` (``G = m_veh / m_veh_max - 1 <= 0``), from
  an analytic mass function, never a surrogate, so every reported design honours it exactly.
- :class:`IntegerRepair` -- the one repair that keeps ``n_bat``, ``n_r``, ``n_s`` integer; pymoo
  applies it to every sampled and every mated (crossed and mutated) design, so the optimiser and the
  surrogate only ever see whole numbers there.
- :func:`nsga3`, :func:`moead`, :func:`moga` -- one wrapper per algorithm, each
  ``(problem, settings: AlgoParams) -> Front``, seeded from the settings; :func:`optimise` dispatches
  by name; :func:`run` is the only caller of :func:`pymoo.optimize.minimize`. The wrappers take any
  pymoo ``Problem`` (tests run them on DTLZ2 and ZDT1).
- :func:`optimise_and_resimulate` -- the stage's work: optimise, re-simulate every design of the front
  with the true model, tabulate predicted against simulated objectives (:func:`front_table`) and
  report (:func:`front_report`: size, runtimes, hypervolume on the common normalisation, share still
  non-dominated, surrogate error per objective).

A :class:`Front` is always feasible, non-dominated (in its predicted objectives) and deduplicated;
designs the algorithm returned that violate the mass constraint are dropped and counted.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import sys
import time
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
import pyarrow as pa
from pymoo.algorithms.base.genetic import GeneticAlgorithm
from pymoo.algorithms.moo.moead import ParallelMOEAD
from pymoo.algorithms.moo.nsga3 import NSGA3
from pymoo.core.problem import Problem
from pymoo.core.repair import Repair
from pymoo.core.survival import Survival
from pymoo.decomposition.pbi import PBI
from pymoo.decomposition.tchebicheff import Tchebicheff
from pymoo.operators.crossover.sbx import SBX
from pymoo.operators.mutation.pm import PM
from pymoo.operators.sampling.rnd import FloatRandomSampling
from pymoo.operators.selection.tournament import TournamentSelection
from pymoo.optimize import minimize
from pymoo.util.ref_dirs.energy import RieszEnergyReferenceDirectionFactory
from pymoo.util.reference_direction import UniformReferenceDirectionFactory

from hevlib.design import (
    BOOL_RESPONSES,
    DESIGN_VARS,
    INTEGER_MASK,
    OBJECTIVES,
    RESPONSES,
    DesignSpace,
    buildable_gear_sets,
    nearest_gear_set,
)
from hevlib.indicators import Normalisation, hypervolume_mc
from hevlib.params import AlgoParams
from hevlib.pareto import nondominated_mask, to_minimisation

#: Distribution indices of simulated binary crossover and polynomial mutation (Deb's usual values).
SBX_ETA = 15.0
PM_ETA = 20.0
ALGORITHMS = ("nsga3", "moead", "moga")


# --------------------------------------------------------------------------------------- problem
class HevProblem(Problem):
    """Size the hybrid on a surrogate: 7 variables, 11 minimised objectives, the mass constraint and,
    optionally, the screening rules as constraints.

    ``surrogate`` is any :class:`hevlib.surrogates.base.Surrogate` (``predict(X) -> (n, 11)`` in natural
    units; ``predict_std`` is used when present); ``mass_kg`` maps ``X`` (n, 7) to the exact test mass
    (n,) (``Simulator.mass_kg``). The whole population is evaluated in one call of each.

    Constraints, all ``G <= 0`` feasible and dimensionless (so one penalty weight fits all):

    - always: exact test mass at most ``m_veh_max_kg`` (``m / m_max - 1``);
    - ``speed_dev_max``: the surrogate's predicted speed deviation (share of the sizing cycle off the
      trace) at most that (``pred / max - 1``), so fronts are not spent on designs that cannot follow
      the sizing cycle (a stalled design misses the trace for most of it);
    - ``stalled``: a callable ``X -> (n,) bool`` that says which designs stall (the simulator, where it
      is in the loop); a stalled design is infeasible (``+1``, else ``-1``) whatever its objectives;
    - ``gen_below_motor``: generator peak power below the motor's (``p_gen / p_mot - 1 < 0``, exact).

    ``buildable_gear_set`` makes the repair snap (n_r, n_s) to the nearest buildable planetary set.
    """

    def __init__(
        self,
        surrogate,
        space: DesignSpace,
        mass_kg: Callable[[np.ndarray], np.ndarray],
        m_veh_max_kg: float,
        *,
        speed_dev_max: float | None = None,
        gen_below_motor: bool = False,
        buildable_gear_set: bool = False,
        stalled: Callable[[np.ndarray], np.ndarray] | None = None,
    ):
        if not m_veh_max_kg > 0:
            raise ValueError(f"m_veh_max_kg: must be positive, got {m_veh_max_kg}")
        j_r, j_s = DESIGN_VARS.index("n_r"), DESIGN_VARS.index("n_s")
        if space.upper[j_s] >= space.lower[j_r]:
            raise ValueError(
                "design_space.n_s: upper bound must lie below n_r's lower bound, or the optimisers "
                "would propose gear sets with n_s >= n_r"
            )
        if speed_dev_max is not None and not speed_dev_max > 0:
            raise ValueError(f"speed_dev_max: must be positive, got {speed_dev_max}")
        self.constraint_names = (
            ["mass"]
            + (["speed_dev"] if speed_dev_max is not None else [])
            + (["gen_below_motor"] if gen_below_motor else [])
            + (["stalled"] if stalled is not None else [])
        )
        super().__init__(
            n_var=space.n,
            n_obj=len(OBJECTIVES),
            n_ieq_constr=len(self.constraint_names),
            xl=space.lower,
            xu=space.upper,
        )
        self.surrogate = surrogate
        self.mass_kg = mass_kg
        self.m_veh_max_kg = float(m_veh_max_kg)
        self.speed_dev_max = speed_dev_max
        self.stalled = stalled
        self.integer_mask = INTEGER_MASK.copy()
        self.gear_sets = buildable_gear_sets(space) if buildable_gear_set else None
        if self.gear_sets is not None and len(self.gear_sets) == 0:
            raise ValueError("design_space: no buildable gear set (n_r, n_s) lies inside the bounds")

    def predict(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Predicted objectives (n, 11) in natural units and their standard deviation (None if unavailable)."""
        X = np.asarray(X, dtype=float)
        Y = self._checked(self.surrogate.predict(X), len(X), "predict")
        return Y, self._std(X)

    def _std(self, X: np.ndarray) -> np.ndarray | None:
        """``predict_std(X)``, or ``predict(X, return_std=True)[1]``, or None when the surrogate has neither."""
        if hasattr(self.surrogate, "predict_std"):
            return self._checked(self.surrogate.predict_std(X), len(X), "predict_std")
        if "return_std" in inspect.signature(self.surrogate.predict).parameters:
            return self._checked(self.surrogate.predict(X, return_std=True)[1], len(X), "predict_std")
        return None

    def constraint(self, X: np.ndarray, Y: np.ndarray | None = None) -> np.ndarray:
        """(n, n_ieq_constr) constraint values in ``constraint_names`` order; <= 0 is feasible. ``Y``: the
        predicted objectives of ``X`` when already known (the speed-deviation constraint reads them)."""
        X = np.asarray(X, dtype=float)
        m = np.asarray(self.mass_kg(X), dtype=float).reshape(-1)
        if m.shape != (len(X),) or not np.all(np.isfinite(m)):
            raise ValueError(f"mass_kg: expected {len(X)} finite masses, got shape {m.shape}")
        cols = [m / self.m_veh_max_kg - 1.0]
        if self.speed_dev_max is not None:
            if Y is None:
                Y = self._checked(self.surrogate.predict(X), len(X), "predict")
            cols.append(Y[:, OBJECTIVES.index("speed_dev")] / self.speed_dev_max - 1.0)
        if "gen_below_motor" in self.constraint_names:
            cols.append(X[:, DESIGN_VARS.index("p_gen_kw")] / X[:, DESIGN_VARS.index("p_mot_kw")] - 1.0 + 1e-9)
        if self.stalled is not None:
            st = np.asarray(self.stalled(X), dtype=bool).reshape(-1)
            if st.shape != (len(X),):
                raise ValueError(f"stalled: expected {len(X)} flags, got shape {st.shape}")
            cols.append(np.where(st, 1.0, -1.0))
        return np.column_stack(cols)

    def _evaluate(self, x, out, *args, **kwargs):
        Y = self._checked(self.surrogate.predict(x), len(x), "predict")
        out["F"] = to_minimisation(Y)
        out["G"] = self.constraint(x, Y)

    @staticmethod
    def _checked(Y, n: int, what: str) -> np.ndarray:
        Y = np.asarray(Y, dtype=float)
        if Y.shape != (n, len(OBJECTIVES)):
            raise ValueError(f"surrogate.{what}: expected shape ({n}, {len(OBJECTIVES)}), got {Y.shape}")
        if not np.all(np.isfinite(Y)):
            k = int(np.argmax(~np.all(np.isfinite(Y), axis=0)))
            raise ValueError(f"surrogate.{what}: {OBJECTIVES[k]} is not finite for some design")
        return Y


class IntegerRepair(Repair):
    """Round the integer columns (``mask``) to whole numbers within the bounds; other columns untouched.
    With ``gear_sets`` ((k, 2) buildable (n_r, n_s) pairs), snap the planetary set to the nearest one."""

    def __init__(self, mask, gear_sets: np.ndarray | None = None):
        super().__init__()
        self.mask = np.asarray(mask, dtype=bool)
        self.gear_sets = gear_sets

    def _do(self, problem, X, **kwargs):
        X = np.array(X, dtype=float)
        lo, hi = np.ceil(problem.xl[self.mask]), np.floor(problem.xu[self.mask])
        X[:, self.mask] = np.clip(np.round(X[:, self.mask]), lo, hi)
        if self.gear_sets is not None and len(X):
            j_r, j_s = DESIGN_VARS.index("n_r"), DESIGN_VARS.index("n_s")
            X[:, j_r], X[:, j_s] = nearest_gear_set(X[:, j_r], X[:, j_s], self.gear_sets)
        return X


def _integer_repair(problem: Problem) -> IntegerRepair | None:
    mask = getattr(problem, "integer_mask", None)
    if mask is None or not np.any(mask):
        return None
    return IntegerRepair(mask, getattr(problem, "gear_sets", None))


def _repaired(problem: Problem, X: np.ndarray) -> np.ndarray:
    repair = _integer_repair(problem)
    X = np.asarray(X, dtype=float)
    return repair._do(problem, X) if repair is not None else X


def _evaluate_base(problem: Problem, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(F, G)`` of ``problem`` at ``X``; ``G`` is (n, 0) for an unconstrained problem."""
    if problem.n_ieq_constr == 0:
        return np.asarray(problem.evaluate(X, return_values_of=["F"]), dtype=float), np.zeros((len(X), 0))
    F, G = problem.evaluate(X, return_values_of=["F", "G"])
    return np.asarray(F, dtype=float), np.asarray(G, dtype=float).reshape(len(X), -1)


class _Reformulated(Problem):
    """A view of ``base`` for an algorithm that needs it: objectives normalised by ``norm``, then
    optionally collapsed to a weighted sum (``weights``, MOGA) and/or the constraints folded into the
    objectives as ``penalty * sum(max(G, 0))`` (``penalty``, MOEA/D, which takes no constraints).
    Without ``penalty`` the base constraints are passed through unchanged."""

    def __init__(
        self, base: Problem, norm: Normalisation, *, weights: np.ndarray | None = None, penalty: float | None = None
    ):
        super().__init__(
            n_var=base.n_var,
            n_obj=base.n_obj if weights is None else 1,
            n_ieq_constr=base.n_ieq_constr if penalty is None else 0,
            xl=base.xl,
            xu=base.xu,
        )
        self.base, self.norm, self.penalty = base, norm, penalty
        self.weights = None if weights is None else np.asarray(weights, dtype=float)
        self.integer_mask = getattr(base, "integer_mask", None)
        self.gear_sets = getattr(base, "gear_sets", None)

    def _evaluate(self, x, out, *args, **kwargs):
        F, G = _evaluate_base(self.base, x)
        F = self.norm(F)
        if self.weights is not None:
            F = F @ self.weights[:, None]
        if self.penalty is not None:
            F = F + self.penalty * np.maximum(G, 0.0).sum(axis=1, keepdims=True)
        elif self.n_ieq_constr:
            out["G"] = G
        out["F"] = F


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
    so that kilograms and SOC fractions weigh alike. Infeasible samples count too (they bound the range)."""
    rng = np.random.default_rng(seed)
    X = problem.xl + rng.random((int(n_samples), problem.n_var)) * (problem.xu - problem.xl)
    F, _ = _evaluate_base(problem, _repaired(problem, X))
    return Normalisation.from_points(F)


def _settings_normalisation(problem: Problem, settings: AlgoParams) -> Normalisation:
    """:func:`estimate_normalisation` on ``settings.norm_samples`` designs, seeded from (but independent
    of) the algorithm's own seed."""
    return estimate_normalisation(problem, settings.norm_samples, np.random.SeedSequence(settings.seed).spawn(1)[0])


def _operators(problem: Problem, settings: AlgoParams) -> dict:
    """Study operators: SBX with crossover probability ``crossover_prob`` per mating, polynomial mutation
    of every offspring with probability ``mutation_prob`` per variable; the integer repair."""
    return dict(
        sampling=FloatRandomSampling(),
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

    def __len__(self) -> int:
        return len(self.X)


def _front(problem: Problem, X: np.ndarray, *, algo: str, n_evaluations: int, t0: float, settings: dict) -> Front:
    X = np.unique(_repaired(problem, np.atleast_2d(X)), axis=0)
    F, G = _evaluate_base(problem, X)
    feasible = np.all(G <= 0.0, axis=1)
    X, F = X[feasible], F[feasible]
    keep = nondominated_mask(F)
    X, F = X[keep], F[keep]
    std = None
    if isinstance(problem, HevProblem):
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
    )


# ------------------------------------------------------------------------------------- algorithms
def nsga3(problem: Problem, settings: AlgoParams, progress=None) -> Front:
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
    algorithm = NSGA3(ref, pop_size=pop_size, eliminate_duplicates=True, **_operators(problem, settings))
    res = run(problem, algorithm, settings.n_gen, settings.seed, progress)
    return _front(
        problem,
        res.pop.get("X"),
        algo="nsga3",
        n_evaluations=res.algorithm.evaluator.n_eval,
        t0=t0,
        settings={"pop_size": pop_size, "n_ref_dirs": len(ref), "ref_dirs": "das-dennis layers"},
    )


def moead(problem: Problem, settings: AlgoParams, progress=None) -> Front:
    """MOEA/D (pymoo's batched ``ParallelMOEAD``) on normalised objectives with a mass penalty.

    - One subproblem per individual: ``pop_size`` Riesz s-energy directions (seeded), so the
      population is exactly ``pop_size`` and the directions cover the simplex's interior.
    - Each generation makes one offspring per subproblem from its ``n_neighbors`` nearest neighbours,
      evaluates all of them in one surrogate call, then replaces neighbours as the loop-wise MOEA/D does.
    - Decomposition ``pbi`` (theta 5) or ``tchebicheff`` on objectives normalised by
      :func:`estimate_normalisation` (``norm_samples`` seeded designs): the decomposition compares
      objectives on one scale.
    - Constraint: pymoo's MOEA/D takes none, so it is a penalty, ``penalty * max(0, m/m_max - 1)`` added
      to every normalised objective (1 % over the mass limit costs 10 normalised units at the default
      1000, more than any objective's range), not a repair: a repair would need to know how each
      variable moves the mass and would change offspring behind the algorithm's back. Infeasible
      designs of the final population are dropped from the front and counted (``n_infeasible``).
    """
    if settings.n_neighbors > settings.pop_size:
        raise ValueError(
            f"optimise.algorithms.moead.n_neighbors: {settings.n_neighbors} exceeds pop_size {settings.pop_size}"
        )
    t0 = time.perf_counter()
    norm = _settings_normalisation(problem, settings)
    ref = reference_directions(problem.n_obj, n_points=settings.pop_size, seed=settings.seed)
    decomposition = PBI() if settings.decomposition == "pbi" else Tchebicheff()
    algorithm = ParallelMOEAD(
        ref, n_neighbors=settings.n_neighbors, decomposition=decomposition, **_operators(problem, settings)
    )
    res = run(
        _Reformulated(problem, norm, penalty=settings.penalty), algorithm, settings.n_gen, settings.seed, progress
    )
    return _front(
        problem,
        res.pop.get("X"),
        algo="moead",
        n_evaluations=res.algorithm.evaluator.n_eval + settings.norm_samples,
        t0=t0,
        settings={
            "pop_size": len(ref),
            "n_ref_dirs": len(ref),
            "ref_dirs": "riesz energy",
            "normalisation": norm.to_dict(),
        },
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


def moga(problem: Problem, settings: AlgoParams, progress=None) -> Front:
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
    - The front: the best design of every weighted sum in the final population, then feasible,
      non-dominated and distinct (weighted sums find supported points only: at most ``n_weights``).
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
        **_operators(problem, settings),
    )
    res = run(_Reformulated(problem, norm), algorithm, settings.n_gen, settings.seed, progress)
    pop = res.pop
    R = weighted_sum_ranks(pop.get("F"), pop.get("CV")[:, 0], weights)
    best = pop.get("X")[np.argmin(R, axis=0)]
    return _front(
        problem,
        best,
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


@contextmanager
def _torch_single_thread():
    """Run torch on one thread while optimising, if torch is loaded: the optimisers call the surrogate on
    a few hundred rows at a time, where thread hand-offs cost far more than the work (a 7-20-11 MLP on
    200 rows: 0.07 ms on one thread, 7.5 ms on two on this shared 2-core machine)."""
    torch = sys.modules.get("torch")
    if torch is None:
        yield
        return
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def optimise(
    problem: Problem, algo: str, settings: AlgoParams, progress: Callable[[int, int], None] | None = None
) -> Front:
    """Run algorithm ``algo`` (one of :data:`ALGORITHMS`) on ``problem`` with ``settings``;
    ``progress(generation, n_gen)`` after each generation."""
    if algo not in _WRAPPERS:
        raise ValueError(f"optimise: unknown algorithm {algo!r} (use one of {', '.join(ALGORITHMS)})")
    with _torch_single_thread():
        return _WRAPPERS[algo](problem, settings, progress)


# ------------------------------------------------------------------------- re-simulation, report
@dataclass(frozen=True)
class HvSettings:
    """Common hypervolume settings of the three algorithms: normalisation, reference point, MC samples."""

    norm: Normalisation
    reference: float = 1.1
    n_samples: int = 200_000
    seed: int = 7


def doe_normalisation(doe: pd.DataFrame, *, what: str = "data/doe/doe.parquet") -> Normalisation:
    """The common normalisation: ideal and nadir of simulated objectives (the DOE and the held-out set)
    in minimisation form."""
    missing = [k for k in OBJECTIVES if k not in doe.columns]
    if missing:
        raise ValueError(f"{what}: missing objective column(s) {', '.join(missing)}")
    return Normalisation.from_points(to_minimisation(doe[list(OBJECTIVES)].to_numpy(dtype=float)))


def resimulate(X: np.ndarray, simulate: Callable[[np.ndarray], pd.DataFrame]) -> pd.DataFrame:
    """Simulate designs ``X`` with the true model; ``simulate`` returns one row per design with RESPONSES."""
    sim = simulate(np.asarray(X, dtype=float))
    if len(sim) != len(X):
        raise ValueError(f"simulator: returned {len(sim)} rows for {len(X)} designs")
    missing = [c for c in RESPONSES if c not in sim.columns]
    if missing:
        raise ValueError(f"simulator: missing response column(s) {', '.join(missing)}")
    return sim.reset_index(drop=True)


def front_schema(with_std: bool) -> pa.Schema:
    """``data/pareto/<algo>.parquet``: design, pred_/pred_*_std/sim_ objectives, exact mass, flags."""
    fields = [
        pa.field(v, pa.int64() if m else pa.float64(), nullable=False)
        for v, m in zip(DESIGN_VARS, INTEGER_MASK, strict=True)
    ]
    fields += [pa.field(f"pred_{k}", pa.float64()) for k in OBJECTIVES]
    if with_std:
        fields += [pa.field(f"pred_{k}_std", pa.float64()) for k in OBJECTIVES]
    fields += [pa.field(f"sim_{k}", pa.bool_() if k in BOOL_RESPONSES else pa.float64()) for k in RESPONSES]
    fields += [
        pa.field("m_veh_exact_kg", pa.float64()),
        pa.field("feasible", pa.bool_()),
        pa.field("nondominated_sim", pa.bool_()),
    ]
    return pa.schema(fields)


def front_table(front: Front, sim: pd.DataFrame, problem: HevProblem) -> pd.DataFrame:
    """One row per front design: variables, predicted (and std), simulated, exact mass, flags.

    ``feasible``: every constraint of ``problem`` met as the optimiser saw it (exact mass, exact power
    ratio, predicted speed deviation; true for every row of a :class:`Front`);
    ``nondominated_sim``: not dominated within this front by the simulated objectives (minimisation
    form); a design with a non-finite simulated objective is never non-dominated.
    """
    cols: dict[str, np.ndarray] = {}
    for j, v in enumerate(DESIGN_VARS):
        cols[v] = np.round(front.X[:, j]).astype(np.int64) if INTEGER_MASK[j] else front.X[:, j]
    for k, name in enumerate(OBJECTIVES):
        cols[f"pred_{name}"] = front.F[:, k]
    if front.std is not None:
        for k, name in enumerate(OBJECTIVES):
            cols[f"pred_{name}_std"] = front.std[:, k]
    for name in RESPONSES:
        cols[f"sim_{name}"] = sim[name].to_numpy(dtype=bool if name in BOOL_RESPONSES else float)
    G = problem.constraint(front.X, front.F) if len(front) else np.zeros((0, problem.n_ieq_constr))
    cols["m_veh_exact_kg"] = (G[:, 0] + 1.0) * problem.m_veh_max_kg
    cols["feasible"] = np.all(G <= 0.0, axis=1)
    Fs = to_minimisation(sim[list(OBJECTIVES)].to_numpy(dtype=float)) if len(front) else np.zeros((0, 11))
    finite = np.all(np.isfinite(Fs), axis=1)
    nd = np.zeros(len(front), dtype=bool)
    nd[finite] = nondominated_mask(Fs[finite])
    cols["nondominated_sim"] = nd
    return pd.DataFrame(cols)


def surrogate_error(pred: np.ndarray, sim: np.ndarray, span: np.ndarray | None = None) -> dict[str, dict]:
    """Per objective over rows with a finite simulated value: mae, rmse, r2, bias (mean pred - sim) and,
    with ``span``, nrmse = rmse / span (comparable across objectives)."""
    out = {}
    for k, name in enumerate(OBJECTIVES):
        ok = np.isfinite(sim[:, k]) & np.isfinite(pred[:, k])
        p, s = pred[ok, k], sim[ok, k]
        if len(s) == 0:
            out[name] = {"mae": None, "rmse": None, "r2": None, "bias": None}
            continue
        e = p - s
        ss_tot = float(np.sum((s - s.mean()) ** 2))
        rmse = float(np.sqrt(np.mean(e**2)))
        out[name] = {
            "mae": float(np.mean(np.abs(e))),
            "rmse": rmse,
            "r2": 1.0 - float(np.sum(e**2)) / ss_tot if ss_tot > 0 else None,
            "bias": float(np.mean(e)),
        }
        if span is not None:
            out[name]["nrmse"] = rmse / float(span[k])
    return out


def front_report(
    front: Front, table: pd.DataFrame, hv: HvSettings, *, settings: AlgoParams, n_misleading: int = 3
) -> dict:
    """``reports/optimise_<algo>.json``: the figures of the issue's contract plus the settings used.

    Deterministic (a DVC metric: the same inputs give the same bytes); wall times are not in it but in
    :func:`runtimes`."""
    sim_Y = table[[f"sim_{k}" for k in OBJECTIVES]].to_numpy(dtype=float)
    pred_Y = table[[f"pred_{k}" for k in OBJECTIVES]].to_numpy(dtype=float)
    finite = np.all(np.isfinite(sim_Y), axis=1)
    hv_est, hv_se = hypervolume_mc(
        hv.norm(to_minimisation(sim_Y[finite])), hv.reference, n_samples=hv.n_samples, seed=hv.seed
    )
    hv_pred, hv_pred_se = hypervolume_mc(
        hv.norm(to_minimisation(pred_Y)), hv.reference, n_samples=hv.n_samples, seed=hv.seed
    )
    errors = surrogate_error(pred_Y, sim_Y, hv.norm.span)
    ranked = sorted((k for k in OBJECTIVES if errors[k].get("nrmse") is not None), key=lambda k: -errors[k]["nrmse"])
    n = len(table)
    return {
        "algo": front.algo,
        "surrogate": settings.surrogate,
        "front_size": n,
        "n_evaluations": front.n_evaluations,
        "n_candidates": front.n_candidates,
        "n_infeasible_dropped": front.n_infeasible,
        "n_sim_failed": int(n - np.count_nonzero(finite)),
        "hypervolume": hv_est,
        "hypervolume_se": hv_se,
        "hypervolume_pred": hv_pred,
        "hypervolume_pred_se": hv_pred_se,
        "share_nondominated_after_resim": float(table["nondominated_sim"].mean()) if n else None,
        "share_feasible": float(table["feasible"].mean()) if n else None,
        "share_cycle_met": float(table["sim_cycle_met"].mean()) if n else None,
        "surrogate_error": errors,
        "surrogate_misleads_most": ranked[:n_misleading],
        "hypervolume_settings": {
            "space": "simulated objectives, minimisation form, (F - ideal) / (nadir - ideal)",
            "normalisation": "ideal/nadir of the simulated DOE and held-out designs (shared by all algorithms)",
            "reference": hv.reference,
            "n_samples": hv.n_samples,
            "seed": hv.seed,
            **hv.norm.to_dict(),
        },
        "settings": {**settings.model_dump(), **front.settings},
    }


def runtimes(front: Front, resim_runtime_s: float) -> dict:
    """Wall times of one optimise run (s): machine-dependent, so kept out of the metrics report."""
    return {
        "algo": front.algo,
        "runtime_s": front.runtime_s,
        "runtime_resim_s": resim_runtime_s,
        "runtime_total_s": front.runtime_s + resim_runtime_s,
    }


@dataclass(frozen=True)
class StudyResult:
    front: Front
    table: pd.DataFrame
    report: dict
    runtimes: dict = field(default_factory=dict)

    @property
    def schema(self) -> pa.Schema:
        return front_schema(self.front.std is not None)


def optimise_and_resimulate(
    problem: HevProblem,
    algo: str,
    settings: AlgoParams,
    simulate: Callable[[np.ndarray], pd.DataFrame],
    hv: HvSettings,
    progress: Callable[[int, int], None] | None = None,
) -> StudyResult:
    """The optimise stage's work: front on the surrogate, every design re-simulated, table and report."""
    front = optimise(problem, algo, settings, progress)
    t0 = time.perf_counter()
    sim = resimulate(front.X, simulate) if len(front) else pd.DataFrame({c: [] for c in RESPONSES})
    resim_s = time.perf_counter() - t0
    front, sim, n_stalled = drop_stalled(front, sim)
    table = front_table(front, sim, problem)
    report = front_report(front, table, hv, settings=settings)
    report["n_stalled_dropped"] = n_stalled
    return StudyResult(front, table, report, runtimes(front, resim_s))


def drop_stalled(front: Front, sim: pd.DataFrame) -> tuple[Front, pd.DataFrame, int]:
    """The front without the designs the true model finds stalled (infeasible whatever the surrogate
    predicted), the re-simulated rows to match, and how many were dropped."""
    if not len(front):
        return front, sim, 0
    keep = ~sim["stalled"].to_numpy(dtype=bool)
    if keep.all():
        return front, sim, 0
    std = front.std[keep] if front.std is not None else None
    kept = dataclasses.replace(front, X=front.X[keep], F=front.F[keep], std=std)
    return kept, sim[keep].reset_index(drop=True), int(np.count_nonzero(~keep))


__all__ = [
    "ALGORITHMS",
    "Front",
    "HevProblem",
    "HvSettings",
    "IntegerRepair",
    "StudyResult",
    "doe_normalisation",
    "drop_stalled",
    "estimate_normalisation",
    "front_report",
    "front_schema",
    "front_table",
    "moead",
    "moga",
    "nsga3",
    "optimise",
    "optimise_and_resimulate",
    "reference_directions",
    "resimulate",
    "run",
    "runtimes",
    "surrogate_error",
    "to_minimisation",
    "weighted_sum_ranks",
]
