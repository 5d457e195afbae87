"""Bayesian optimisation on BoTorch: the surrogate-assisted sources ``parego`` and ``nehvi``.

Both start from the DOE and add ``batch`` designs per round until ``budget`` simulations (the DOE's
included), each round on models refitted to every design simulated so far (:mod:`hevlib.surrogates.gp`):

- ``parego``: BoTorch's ``qLogNParEGO`` (Knowles 2006 with Daulton et al.'s noisy, log-smoothed expected
  improvement of an augmented Chebyshev scalarisation of posterior samples) on all eleven objectives; a
  batch is chosen greedily, each next design with its own Dirichlet weight vector and the designs chosen
  before it as pending points (BoTorch's ``optimize_acqf_list`` scheme; qNParEGO's authors' recommendation
  beyond three objectives). The scalarisation normalises by the run's own data (BoTorch's rule), never by
  the judged normalisation.
- ``nehvi``: ``qLogNoisyExpectedHypervolumeImprovement`` on a reduced objective set
  (:func:`reduced_objectives`: chosen from the DOE alone), reference point from the run's own feasible
  designs (each objective's worst minus a tenth of its range, BoTorch's usual heuristic); judged on all
  eleven like every source.

What a design must satisfy enters in three ways, the same for every source (:meth:`HevProblem.admissible`):

- the **exact, cheap rules** -- test mass at most the limit and ``p_gen < p_mot`` -- are linear in the
  design (the mass model is affine; :func:`linear_rules` checks it on every run) and are passed to the
  acquisition optimiser as linear inequality constraints: no candidate that breaks them is proposed, and
  any that would is dropped before simulation and counted (``n_rejected``);
- the **gear-set rule**: the planetary set is one ordinal discrete variable, the index into the buildable
  sets sorted by ratio ``n_r / n_s`` (:class:`MixedSpace`), so every candidate is buildable; ``n_bat`` is
  a discrete variable too. Both are searched by BoTorch's mixed-space optimiser
  ``optimize_acqf_mixed_alternating`` (discrete local search alternating with gradient steps on the continuous
  variables: SLSQP, because the exact rules are linear constraints);
- **failures and the screen's speed rule** weight the acquisition by their posterior probability: the
  speed deviation is one of the modelled objectives (an outcome constraint of the MC acquisition); a
  stall is modelled by :class:`~hevlib.surrogates.gp.FeasibilityGP` (fitted once a design has stalled),
  whose probability that the design runs multiplies the acquisition (Gardner et al. 2014). Stalled
  designs are never fitted as objective values.

Every random choice comes from ``seed`` (numpy and torch generators seeded per round); torch runs on one
thread in float64 (:func:`hevlib.determinism.torch`), so a run reproduces bit for bit on every CPU kind.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hevlib.design import DESIGN_VARS, INTEGER_MASK, OBJECTIVES, DesignSpace
from hevlib.determinism import botorch_logei
from hevlib.determinism import torch as _torch  # torch itself is imported on the first call
from hevlib.optimise.problem import HevProblem

ACQUISITIONS = ("parego", "nehvi")
#: Margin (kg of test mass, kW of generator power) the linear rules keep from the exact limits.
RULE_MARGIN = 1e-3
#: Alternating discrete/continuous steps of each restart of BoTorch's mixed optimiser (its default: 64).
ALTERNATING_STEPS = 4
_SPEED_DEV = "speed_dev"


@dataclass(frozen=True)
class BayesSettings:
    """One Bayesian-optimisation source (``optimise.bayes.<name>`` in params.yaml)."""

    acquisition: str  # parego | nehvi
    budget: int  # simulations, the DOE's included
    batch: int = 10
    num_restarts: int = 2
    raw_samples: int = 64
    mc_samples: int = 32
    n_objectives: int = 5  # nehvi: size of the reduced objective set
    seed: int = 0

    def __post_init__(self):
        if self.acquisition not in ACQUISITIONS:
            raise ValueError(f"acquisition: unknown {self.acquisition!r} (use {' or '.join(ACQUISITIONS)})")


# ------------------------------------------------------------------------------------ the objective set
def reduced_objectives(Y: np.ndarray, k: int) -> tuple[str, ...]:
    """``k`` of the eleven objectives that stand for the others, from designs ``Y`` (n, 11) alone.

    Objectives are clustered by rank correlation (average-linkage agglomeration on ``1 - |Spearman|``,
    cut at ``k`` clusters); each cluster is represented by its member with the highest mean ``|Spearman|``
    to the rest of its cluster (ties: ``OBJECTIVES`` order). Objectives that move together
    (``accel_dev``/``e_l``/``speed_dev``, ``hc``/``co``) then cost one model output, not three."""
    from scipy.cluster.hierarchy import fcluster, linkage
    from scipy.spatial.distance import squareform
    from scipy.stats import spearmanr

    Y = np.asarray(Y, dtype=float)
    if not 1 <= k <= len(OBJECTIVES):
        raise ValueError(f"n_objectives: must be 1..{len(OBJECTIVES)}, got {k}")
    if k == len(OBJECTIVES):
        return OBJECTIVES
    rho = np.abs(np.nan_to_num(spearmanr(Y).statistic, nan=0.0))
    np.fill_diagonal(rho, 1.0)
    dist = squareform(np.clip(1.0 - rho, 0.0, None), checks=False)
    labels = fcluster(linkage(dist, method="average"), t=k, criterion="maxclust")
    chosen = []
    for c in np.unique(labels):
        members = np.flatnonzero(labels == c)
        score = rho[np.ix_(members, members)].mean(axis=1)
        chosen.append(int(members[np.argmax(score)]))
    return tuple(OBJECTIVES[j] for j in sorted(chosen))


# ---------------------------------------------------------------------------------------- the space
@dataclass(frozen=True)
class MixedSpace:
    """The search encoding: ``(p_eng_kw, p_mot_kw, p_gen_kw, i0, n_bat, gear)`` with ``gear`` the index
    into ``gear_sets`` ((k, 2) (n_r, n_s) pairs sorted by ratio, then ring size): a design's first five
    variables as they are, the planetary set as one ordinal discrete variable."""

    space: DesignSpace
    gear_sets: np.ndarray

    @classmethod
    def of(cls, problem: HevProblem, space: DesignSpace) -> MixedSpace:
        sets = problem.gear_sets
        if sets is None:  # every integer pair inside the bounds with n_s < n_r
            j_r, j_s = DESIGN_VARS.index("n_r"), DESIGN_VARS.index("n_s")
            r, s = np.meshgrid(
                np.arange(np.ceil(space.lower[j_r]), np.floor(space.upper[j_r]) + 1),
                np.arange(np.ceil(space.lower[j_s]), np.floor(space.upper[j_s]) + 1),
                indexing="ij",
            )
            sets = np.column_stack([r.ravel(), s.ravel()])
            sets = sets[sets[:, 1] < sets[:, 0]]
        sets = np.asarray(sets, dtype=float)
        order = np.lexsort((sets[:, 0], sets[:, 0] / sets[:, 1]))
        return cls(space, sets[order])

    @property
    def bounds(self) -> np.ndarray:
        """(2, 6) bounds of the encoding."""
        lo, hi = self.space.lower[:5].copy(), self.space.upper[:5].copy()
        lo[INTEGER_MASK[:5]], hi[INTEGER_MASK[:5]] = np.ceil(lo[INTEGER_MASK[:5]]), np.floor(hi[INTEGER_MASK[:5]])
        return np.vstack([np.append(lo, 0.0), np.append(hi, len(self.gear_sets) - 1.0)])

    @property
    def discrete_dims(self) -> dict[int, list[float]]:
        j = DESIGN_VARS.index("n_bat")
        lo, hi = self.bounds[:, j]
        return {j: [float(v) for v in np.arange(lo, hi + 1)], 5: [float(v) for v in range(len(self.gear_sets))]}

    def decode(self, Z):
        """Encoded designs (..., 6) (a torch tensor) -> designs (..., 7) in ``DESIGN_VARS`` order."""
        torch = _torch()
        table = torch.as_tensor(self.gear_sets, dtype=Z.dtype)
        idx = Z[..., 5].round().clamp(0, len(self.gear_sets) - 1).long()
        return torch.cat([Z[..., :5], table[idx]], dim=-1)

    def encode(self, X: np.ndarray) -> np.ndarray:
        """Designs (n, 7) with buildable gear sets -> the encoding (n, 6)."""
        X = np.asarray(X, dtype=float)
        hit = np.all(X[:, None, 5:7] == self.gear_sets[None], axis=2)
        if not np.all(hit.any(axis=1)):
            raise ValueError("design with a gear set outside the search's gear sets")
        return np.column_stack([X[:, :5], np.argmax(hit, axis=1).astype(float)])


def linear_rules(problem: HevProblem, space: DesignSpace) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """The exact rules as BoTorch linear inequality constraints ``sum(coef * z[idx]) >= rhs`` on the
    encoding: the test mass (affine in the powers and ``n_bat``: coefficients read off ``problem.mass_kg``
    and checked on random designs; ValueError if the mass model is not affine) and, when the problem has
    the rule, ``p_gen_kw < p_mot_kw``; both with ``RULE_MARGIN`` (kg, kW) to spare, so that the optimiser's
    feasibility tolerance never proposes a design the exact check then rejects."""
    rng = np.random.default_rng(0)
    X = space.lower + rng.random((64, space.n)) * (space.upper - space.lower)
    X[:, INTEGER_MASK] = np.round(X[:, INTEGER_MASK])
    base = space.lower[None].copy()
    m0 = float(problem.mass_kg(base)[0])
    coef = np.zeros(space.n)
    for j in range(space.n):
        x = base.copy()
        x[0, j] = space.upper[j]
        coef[j] = (float(problem.mass_kg(x)[0]) - m0) / (space.upper[j] - space.lower[j])
    affine = m0 + (X - space.lower) @ coef
    if not np.allclose(affine, problem.mass_kg(X), rtol=0.0, atol=1e-6):
        raise ValueError("mass_kg: the mass model is not affine in the design; it cannot be a linear constraint")
    idx = np.flatnonzero((coef != 0.0) & (np.arange(space.n) < 5))
    if np.any((coef != 0.0) & (np.arange(space.n) >= 5)):
        raise ValueError("mass_kg: the test mass depends on the gear set")
    rhs = m0 - float(coef @ space.lower) - (problem.m_veh_max_kg - RULE_MARGIN)  # -coef.x >= m0 - coef.lo - m_max
    rules = [(idx, -coef[idx], rhs)]
    if "gen_below_motor" in problem.constraint_names:
        j_m, j_g = DESIGN_VARS.index("p_mot_kw"), DESIGN_VARS.index("p_gen_kw")
        rules.append((np.array([j_m, j_g]), np.array([1.0, -1.0]), RULE_MARGIN))
    return rules


# ------------------------------------------------------------------------------------------ models
@dataclass
class RoundModels:
    """The models of one round: the objectives' GPs and the failure model (None before any failure)."""

    objectives: object  # GaussianProcesses
    failure: object | None  # FeasibilityGP


def fit_models(X: np.ndarray, R: pd.DataFrame, space: DesignSpace, names: tuple[str, ...], log_targets) -> RoundModels:
    """GPs of ``names`` on the designs that ran (not stalled, finite objectives); the failure model on
    every design once one has stalled."""
    from hevlib.surrogates.gp import FeasibilityGP, GaussianProcesses

    Y = R[list(OBJECTIVES)].to_numpy(dtype=float)
    stalled = R["stalled"].to_numpy(dtype=bool)
    ran = ~stalled & np.all(np.isfinite(Y), axis=1)
    logged = [k for k in log_targets if k in names]
    gp = GaussianProcesses(space, logged, names).fit(X[ran], Y[ran])
    failed = ~ran
    feas = FeasibilityGP(space).fit(X, failed) if failed.any() else None
    return RoundModels(gp, feas)


# --------------------------------------------------------------------------------------- the search
def _constraints(models: RoundModels, speed_dev_max: float | None) -> list[Callable]:
    """Outcome constraints on the model's joint output (<= 0 feasible)."""
    gp = models.objectives
    cons = []
    if speed_dev_max is not None and _SPEED_DEV in gp.objectives:
        k = gp.objectives.index(_SPEED_DEV)
        thr = gp.model_threshold(_SPEED_DEV, speed_dev_max)
        cons.append(lambda Z, k=k, thr=thr: thr - Z[..., k])  # model units: larger is better
    return cons


def _on_designs(acq, mixed: MixedSpace, failure=None):
    """``acq`` (a log-acquisition of designs) as a function of the search encoding, plus the log of the
    failure model's probability that every design of the batch runs: the constraint-weighted acquisition
    of Gardner et al. (2014), with the failure model outside the objectives' joint posterior (a second
    model in BoTorch's MC constraint would make every evaluation draw from a list of GPs: 30x slower)."""
    from botorch.acquisition import AcquisitionFunction

    torch = _torch()

    class Encoded(AcquisitionFunction):
        def __init__(self):
            super().__init__(model=acq.model)
            self.inner = acq

        def forward(self, Z):
            X = mixed.decode(Z)
            value = self.inner(X)
            if failure is not None:
                post = failure.posterior(X)  # (b, q, 1): > 0 means the design fails
                z = -post.mean[..., 0] / post.variance[..., 0].clamp_min(1e-12).sqrt()
                value = value + torch.special.log_ndtr(z).sum(dim=-1)
            return value

    return Encoded()


def propose(
    models: RoundModels,
    settings: BayesSettings,
    mixed: MixedSpace,
    rules,
    X_seen: np.ndarray,
    Y_ran: np.ndarray,
    objective_names: tuple[str, ...],
    speed_dev_max: float | None,
    q: int,
    rng: np.random.Generator,
) -> np.ndarray:
    """``q`` designs (q, 7) maximising the round's acquisition on ``objective_names``, chosen one at a time
    (pending points). ``X_seen``: every design simulated so far (the acquisition's baseline); ``Y_ran``:
    the natural objectives (n, 11) of those that ran (NEHVI's reference point)."""
    torch = _torch()
    qLogNoisyExpectedHypervolumeImprovement = botorch_logei().qLogNoisyExpectedHypervolumeImprovement
    from botorch.acquisition.multi_objective.objective import IdentityMCMultiOutputObjective
    from botorch.acquisition.multi_objective.parego import qLogNParEGO
    from botorch.optim.optimize_mixed import optimize_acqf_mixed_alternating
    from botorch.sampling import SobolQMCNormalSampler

    gp = models.objectives
    outcomes = [gp.objectives.index(k) for k in objective_names]
    model = gp.model
    objective = IdentityMCMultiOutputObjective(outcomes=outcomes)
    constraints = _constraints(models, speed_dev_max) or None
    baseline = torch.as_tensor(X_seen, dtype=torch.float64)
    bounds = torch.as_tensor(mixed.bounds, dtype=torch.float64)
    ineq = [
        (torch.as_tensor(i, dtype=torch.long), torch.as_tensor(c, dtype=torch.float64), float(r)) for i, c, r in rules
    ]
    ref_point = None
    if settings.acquisition == "nehvi":
        T = gp.to_model_space(Y_ran)[:, outcomes]
        lo, hi = T.min(axis=0), T.max(axis=0)
        ref_point = torch.as_tensor(lo - 0.1 * np.maximum(hi - lo, 1e-9), dtype=torch.float64)
    chosen: list[np.ndarray] = []
    for _ in range(q):
        seed = int(rng.integers(0, 2**31 - 1))
        sampler = SobolQMCNormalSampler(sample_shape=torch.Size([settings.mc_samples]), seed=seed)
        pending = torch.as_tensor(np.array(chosen), dtype=torch.float64) if chosen else None
        torch.manual_seed(seed)  # baseline pruning and the optimiser's starting points draw from torch's generator
        if settings.acquisition == "parego":
            w = torch.as_tensor(rng.dirichlet(np.ones(len(outcomes))), dtype=torch.float64)
            acq = qLogNParEGO(
                model, baseline, scalarization_weights=w, sampler=sampler, objective=objective,
                constraints=constraints, X_pending=pending, prune_baseline=True,
            )  # fmt: skip
        else:
            acq = qLogNoisyExpectedHypervolumeImprovement(
                model, ref_point, baseline, sampler=sampler, objective=objective,
                constraints=constraints, X_pending=pending, prune_baseline=True,
            )  # fmt: skip
        failure = None if models.failure is None else models.failure.model
        z, _ = optimize_acqf_mixed_alternating(
            _on_designs(acq, mixed, failure), bounds, discrete_dims=mixed.discrete_dims, q=1,
            raw_samples=settings.raw_samples, num_restarts=settings.num_restarts, inequality_constraints=ineq,
            options={"max_discrete_values": 10_000, "maxiter_alternating": ALTERNATING_STEPS},
        )  # fmt: skip
        chosen.append(mixed.decode(z.detach())[0].numpy().copy())
    return np.array(chosen)


@dataclass
class BayesRun:
    """What a run did: designs simulated (DOE first), their responses, and per-round bookkeeping."""

    X: np.ndarray
    R: pd.DataFrame
    objectives: tuple[str, ...]
    n_rejected: int
    rounds: list[dict]


def bayes_search(
    settings: BayesSettings,
    problem: HevProblem,
    space: DesignSpace,
    X_doe: np.ndarray,
    R_doe: pd.DataFrame,
    simulate: Callable[[np.ndarray], pd.DataFrame],
    log_targets=(),
    progress: Callable[[int, int], None] | None = None,
) -> BayesRun:
    """Rounds of fit -> propose ``batch`` designs -> simulate, from the DOE until ``settings.budget``
    simulations. ``problem`` gives the exact rules, the gear sets and the speed rule (its model is not
    used); ``simulate(X)`` runs the simulator (a :class:`~hevlib.optimise.archive.SimulationLog` records
    it)."""
    rng = np.random.default_rng(settings.seed)
    mixed = MixedSpace.of(problem, space)
    rules = linear_rules(problem, space)
    X = np.asarray(X_doe, dtype=float)
    R = R_doe.reset_index(drop=True)
    if settings.acquisition == "parego":
        chosen = OBJECTIVES
    else:
        chosen = reduced_objectives(R[list(OBJECTIVES)].to_numpy(dtype=float), settings.n_objectives)
    names = _with_speed(chosen) if problem.speed_dev_max is not None else chosen
    n_rejected, rounds = 0, []
    torch = _torch()
    with torch.random.fork_rng(devices=[]):  # seeded here; the caller's torch generator is left as it was
        while len(X) < settings.budget:
            n_before = len(X)
            X, R, n_bad, entry = _round(
                settings, problem, space, mixed, rules, names, chosen, X, R, simulate, log_targets, rng
            )
            n_rejected += n_bad
            if len(X) == n_before:  # nothing new: the acquisition has converged on designs already simulated
                break
            rounds.append({"round": len(rounds) + 1, **entry})
            if progress is not None:
                progress(len(X), settings.budget)
    return BayesRun(X, R, chosen, n_rejected, rounds)


def _round(settings, problem, space, mixed, rules, names, chosen, X, R, simulate, log_targets, rng):
    """One round: fit, propose, drop what breaks an exact rule or was simulated before, simulate the rest.
    Returns the grown ``X``, ``R``, the count of proposals that broke an exact rule, and the round's entry."""
    t0 = time.perf_counter()
    _torch().manual_seed(int(rng.integers(0, 2**31 - 1)))  # the GP fit's restarts, if any, draw from it
    q = min(settings.batch, settings.budget - len(X))
    models = fit_models(X, R, space, names, log_targets)
    t_fit = time.perf_counter() - t0
    Y = R[list(OBJECTIVES)].to_numpy(dtype=float)
    ran = ~R["stalled"].to_numpy(dtype=bool) & np.all(np.isfinite(Y), axis=1)
    X_new = propose(models, settings, mixed, rules, X, Y[ran], chosen, problem.speed_dev_max, q, rng)
    admissible = problem.admissible(X_new)
    X_new = X_new[admissible & ~_seen(X_new, X)]
    if len(X_new):
        R_new = simulate(X_new).reset_index(drop=True)
        X, R = np.vstack([X, X_new]), pd.concat([R, R_new], ignore_index=True)
    entry = {"n_simulations": len(X), "n_new": len(X_new), "fit_s": t_fit, "runtime_s": time.perf_counter() - t0}
    return X, R, int(np.count_nonzero(~admissible)), entry


def _with_speed(names: tuple[str, ...]) -> tuple[str, ...]:
    """The reduced set plus ``speed_dev`` (the screen's speed rule is a constraint on it), in order."""
    return tuple(k for k in OBJECTIVES if k in names or k == _SPEED_DEV)


def _seen(X_new: np.ndarray, X: np.ndarray) -> np.ndarray:
    """(q,) bool: rows of ``X_new`` already in ``X`` (or earlier in ``X_new``)."""
    seen = {row.tobytes() for row in np.ascontiguousarray(X)}
    out = np.zeros(len(X_new), dtype=bool)
    for i, row in enumerate(np.ascontiguousarray(X_new)):
        key = row.tobytes()
        out[i] = key in seen
        seen.add(key)
    return out


__all__ = [
    "ACQUISITIONS",
    "BayesRun",
    "BayesSettings",
    "MixedSpace",
    "RoundModels",
    "bayes_search",
    "fit_models",
    "linear_rules",
    "propose",
    "reduced_objectives",
]
