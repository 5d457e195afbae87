"""Batch Thompson-sampling ParEGO on pathwise Gaussian-process samples: the large-budget source (issue 55).

The pattern of MORBO (Daulton et al., *Multi-objective Bayesian optimization over high-dimensional search spaces*,
UAI 2022), one trust region, on BoTorch's models. Each round:

1. **Hyperparameters** of one GP per objective (BoTorch's ``SingleTaskGP`` on the eleven model-space targets:
   larger is better, the log targets logged; ``Normalize`` inputs, ``Standardize`` outcomes; RBF with BoTorch's
   priors) and of the failure model (a GP on +1 stalled / -1 ran labels with a fixed small noise), fitted by
   ``fit_gpytorch_mll`` on a **subset** of ``subset`` designs (the newest half and a seeded random half of the
   rest), every ``refit_every`` rounds, each fit warm-started from the last.
2. **Conditioning on every design** with those hyperparameters: one Cholesky factor per output (n x n).
3. **Pathwise posterior samples** by Matheron's rule (Wilson et al., *Efficiently sampling functions from
   Gaussian process posteriors*, ICML 2020): a prior path of ``n_features`` random Fourier features plus the
   exact update ``k(x, X) (K + s2 I)^-1 (y - f(X) - e)``. Written out here rather than BoTorch's
   ``draw_matheron_paths``: that one broadcasts the training Cholesky over the samples (35 GB at n = 2 000 and
   ``batch`` = 100, measured in the issue); here the update is one n x batch solve per output, no n x n tensor
   per sample.
4. **Selection**: each of the ``batch`` samples gets its own Dirichlet weights and BoTorch's augmented Chebyshev
   scalarisation (``get_chebyshev_scalarization``, normalised by the designs simulated so far) and picks its best
   design from the candidate pool -- ``pool`` admissible Latin-hypercube designs plus ``local_pool`` around the
   current non-dominated designs within the trust region (its edge a share of each variable's range: doubled
   after a round in which a new design dominates one of the last front, halved after one without, within
   ``tr_min`` and ``tr_max``) -- among the candidates the same sample keeps feasible (its failure path below
   zero, its speed deviation within the screen's rule); a design already simulated or picked is skipped.

Candidates are repaired (integers, the buildable gear set) and checked against the exact rules by the problem
every source uses (:func:`hevlib.optimise.problem._repaired`, ``problem.admissible``): no candidate breaks one.
Every random choice comes from ``seed`` (one numpy generator; torch seeded from it each round) and torch runs on
one thread in float64 (:func:`hevlib.determinism.torch`), so a run reproduces bit for bit.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from hevlib.design import OBJECTIVES, SENSE, DesignSpace
from hevlib.determinism import torch as _torch
from hevlib.doe import lhs_designs
from hevlib.indicators import nondominated_mask, to_minimisation
from hevlib.optimise.bayesopt import _seen
from hevlib.optimise.problem import HevProblem, _repaired

#: Noise variance of the failure labels (+1 / -1; the simulator is deterministic), as the pipeline's failure model.
LABEL_NOISE = 1e-4
#: Rows of the pool evaluated at once (bounds the pool x n cross-covariance held in memory).
CHUNK = 2048


@dataclass(frozen=True)
class TsParegoSettings:
    """A run's budget (simulations, the DOE's included) and the method's knobs (module docstring)."""

    budget: int = 2000
    batch: int = 100
    pool: int = 4000
    local_pool: int = 2000
    subset: int = 300
    refit_every: int = 4
    n_features: int = 1024
    tr_init: float = 0.2
    tr_min: float = 0.02
    tr_max: float = 0.8
    seed: int = 0

    def __post_init__(self):
        for name in ("budget", "batch", "pool", "subset", "refit_every", "n_features"):
            if getattr(self, name) < 1:
                raise ValueError(f"tsparego.{name}: must be at least 1, got {getattr(self, name)}")
        if self.local_pool < 0:
            raise ValueError(f"tsparego.local_pool: must be at least 0, got {self.local_pool}")
        if not 0.0 < self.tr_min <= self.tr_init <= self.tr_max <= 1.0:
            raise ValueError("tsparego: need 0 < tr_min <= tr_init <= tr_max <= 1")


@dataclass
class Hyper:
    """One round's fitted hyperparameters for ``m`` outputs, in BoTorch's units (inputs normalised to the design
    space's box, outcomes standardised by ``y_mean`` / ``y_std`` of the subset they were fitted on)."""

    lengthscale: np.ndarray  # (m, d)
    constant: np.ndarray  # (m,)
    noise: np.ndarray  # (m,)
    y_mean: np.ndarray  # (m,)
    y_std: np.ndarray  # (m,)
    state: dict = field(default_factory=dict)  # the model's raw state, to warm-start the next fit


def fit_hyper(
    space: DesignSpace, X: np.ndarray, T: np.ndarray, warm: Hyper | None = None, noise: float | None = None
) -> Hyper:
    """Hyperparameters of a ``SingleTaskGP`` on designs ``X`` (n, 7) and targets ``T`` (n, m) by
    ``fit_gpytorch_mll``, started from ``warm``'s where given (same ``m``); ``noise`` fixes the noise variance."""
    torch = _torch()
    from botorch.fit import fit_gpytorch_mll
    from botorch.models import SingleTaskGP
    from botorch.models.transforms import Normalize, Standardize
    from gpytorch.mlls import ExactMarginalLogLikelihood

    bounds = torch.as_tensor(np.vstack([space.lower, space.upper]), dtype=torch.float64)
    tx = torch.as_tensor(np.ascontiguousarray(X), dtype=torch.float64)
    ty = torch.as_tensor(np.ascontiguousarray(T), dtype=torch.float64)
    model = SingleTaskGP(
        tx,
        ty,
        train_Yvar=None if noise is None else torch.full_like(ty, noise),
        input_transform=Normalize(d=X.shape[1], bounds=bounds),
        outcome_transform=Standardize(m=T.shape[1]),
    )
    if warm is not None and warm.state:
        own = model.state_dict()
        model.load_state_dict(
            {k: v for k, v in warm.state.items() if k in own and own[k].shape == v.shape}, strict=False
        )
    fit_gpytorch_mll(ExactMarginalLogLikelihood(model.likelihood, model))
    m, d = T.shape[1], X.shape[1]
    with torch.no_grad():
        ls = model.covar_module.lengthscale.reshape(m, d).numpy().copy()
        const = model.mean_module.constant.reshape(m).numpy().copy()
        nz = model.likelihood.noise.reshape(m, -1)[:, 0].numpy().copy()  # standardised (a fixed one is too)
        mu = model.outcome_transform.means.reshape(m).numpy().copy()
        sd = model.outcome_transform.stdvs.reshape(m).numpy().copy()
    state = {k: v.clone() for k, v in model.state_dict().items() if "raw_" in k or "constant" in k}
    return Hyper(ls, const, nz, mu, sd, state)


class Paths:
    """Posterior paths of every output conditioned on all designs (module docstring, steps 2-3): ``q`` samples,
    each a function of the design evaluated by :meth:`at` (natural model-space units)."""

    def __init__(self, space: DesignSpace, X: np.ndarray, T: np.ndarray, hyper: Hyper, q: int, n_features: int, rng):
        torch = _torch()
        self.torch = torch
        self.lo = torch.as_tensor(space.lower, dtype=torch.float64)
        self.span = torch.as_tensor(space.upper - space.lower, dtype=torch.float64)
        self.h = hyper
        m, d = hyper.lengthscale.shape
        self.m, self.q = m, q
        self.X = self._norm(X)
        Y = (torch.as_tensor(T, dtype=torch.float64) - torch.as_tensor(hyper.y_mean)) / torch.as_tensor(hyper.y_std)
        n = self.X.shape[0]
        g = torch.Generator().manual_seed(int(rng.integers(0, 2**63 - 1)))
        self.omega = torch.randn(m, n_features, d, generator=g, dtype=torch.float64)  # RFF frequencies (unit scale)
        self.phase = 2 * np.pi * torch.rand(m, n_features, generator=g, dtype=torch.float64)
        self.w = torch.randn(m, n_features, q, generator=g, dtype=torch.float64)  # prior path weights
        eps = (
            torch.randn(m, n, q, generator=g, dtype=torch.float64) * torch.as_tensor(hyper.noise).sqrt()[:, None, None]
        )
        self.v = torch.empty(m, n, q, dtype=torch.float64)
        for j in range(m):
            K = self._k(j, self.X, self.X)
            K.diagonal().add_(float(hyper.noise[j]))
            L = torch.linalg.cholesky(K)
            resid = (Y[:, j] - float(hyper.constant[j]))[:, None] - self._prior(j, self.X) - eps[j]
            self.v[j] = torch.cholesky_solve(resid, L)

    def _norm(self, X):
        return (self.torch.as_tensor(np.ascontiguousarray(X), dtype=self.torch.float64) - self.lo) / self.span

    def _k(self, j, A, B):
        ls = self.torch.as_tensor(self.h.lengthscale[j])
        return self.torch.exp(-0.5 * self.torch.cdist(A / ls, B / ls).square())

    def _prior(self, j, A):
        """(len(A), q): the prior paths of output ``j`` at normalised designs ``A``."""
        ls = self.torch.as_tensor(self.h.lengthscale[j])
        feats = self.torch.cos((A / ls) @ self.omega[j].T + self.phase[j]) * np.sqrt(2.0 / self.omega.shape[1])
        return feats @ self.w[j]

    def at(self, P: np.ndarray) -> np.ndarray:
        """(q, len(P), m): every sample's outputs at designs ``P`` in the targets' own units."""
        out = np.empty((self.q, len(P), self.m))
        mu, sd = self.h.y_mean, self.h.y_std
        for s in range(0, len(P), CHUNK):
            A = self._norm(P[s : s + CHUNK])
            for j in range(self.m):
                f = self._prior(j, A) + self._k(j, A, self.X) @ self.v[j] + float(self.h.constant[j])
                out[:, s : s + len(A), j] = (f * sd[j] + mu[j]).T.numpy()
        return out


@dataclass
class TsParegoRun:
    """What a run did: the designs simulated (the DOE first), their responses, and each round's bookkeeping."""

    X: np.ndarray
    R: pd.DataFrame
    rounds: list[dict]


def _targets(Y: np.ndarray, log_targets):
    """Natural objectives (n, 11) -> (model space: larger is better, ``log_targets`` logged as the BNN and the GPs
    log them; the transform)."""
    from hevlib.surrogates.transform import LogTargets

    tf = LogTargets.fit(log_targets, Y, what="tsparego log_targets")
    return -SENSE * tf.forward(Y), tf


def _subset(n: int, size: int, rng) -> np.ndarray:
    """Indices of the hyperparameter fit: all of ``n`` up to ``size``, else the newest half and a random half."""
    if n <= size:
        return np.arange(n)
    newest = np.arange(n - size // 2, n)
    rest = rng.choice(n - size // 2, size - size // 2, replace=False)
    return np.sort(np.concatenate([rest, newest]))


def candidate_pool(
    problem: HevProblem, space: DesignSpace, centres: np.ndarray, edge: float, settings: TsParegoSettings, rng
) -> np.ndarray:
    """Admissible candidates: ``pool`` Latin-hypercube designs and ``local_pool`` within ``edge`` (share of each
    range) of the ``centres``, repaired as every source repairs; duplicates dropped."""
    parts = [lhs_designs(space, settings.pool, int(rng.integers(0, 2**31 - 1)))]
    if settings.local_pool and len(centres):
        c = centres[rng.integers(0, len(centres), settings.local_pool)]
        half = edge * (space.upper - space.lower)
        parts.append(np.clip(c + rng.uniform(-1.0, 1.0, c.shape) * half, space.lower, space.upper))
    P = _repaired(problem, np.vstack(parts))
    P = P[problem.admissible(P)]
    return np.unique(P, axis=0)


def tsparego(
    settings: TsParegoSettings,
    problem: HevProblem,
    space: DesignSpace,
    X_doe: np.ndarray,
    R_doe: pd.DataFrame,
    simulate: Callable[[np.ndarray], pd.DataFrame],
    log_targets=(),
    progress: Callable[[int, int], None] | None = None,
) -> TsParegoRun:
    """Rounds of (refit) -> condition -> sample -> pick ``batch`` designs -> simulate, from the DOE until
    ``settings.budget`` simulations (module docstring). ``simulate(X)`` returns the responses (``OBJECTIVES`` and
    ``stalled``)."""
    torch = _torch()
    from botorch.utils.multi_objective.scalarization import get_chebyshev_scalarization

    rng = np.random.default_rng(settings.seed)
    X = np.asarray(X_doe, dtype=float)
    R = R_doe.reset_index(drop=True)
    hyper, hyper_f, edge, rounds = None, None, settings.tr_init, []
    sd_max = problem.speed_dev_max
    j_sd = OBJECTIVES.index("speed_dev")
    while len(X) < settings.budget:
        t0 = time.perf_counter()
        Y, ran = _ran(R)
        T, tf = _targets(Y[ran], log_targets)
        lab = np.where(ran, -1.0, 1.0)[:, None]  # the failure model's labels: +1 stalled
        refit = len(rounds) % settings.refit_every == 0
        if refit:
            sub = _subset(int(ran.sum()), settings.subset, rng)
            hyper = fit_hyper(space, X[ran][sub], T[sub], hyper)
            if (~ran).any():
                sub_f = _subset(len(X), settings.subset, rng)
                hyper_f = fit_hyper(space, X[sub_f], lab[sub_f], hyper_f, noise=LABEL_NOISE)
        t_fit = time.perf_counter() - t0
        q = min(settings.batch, settings.budget - len(X))
        paths = Paths(space, X[ran], T, hyper, q, settings.n_features, rng)
        feas = None
        if hyper_f is not None and (~ran).any():
            feas = Paths(space, X, lab, hyper_f, q, settings.n_features, rng)
        front = nondominated_mask(to_minimisation(Y[ran]))
        P = candidate_pool(problem, space, X[ran][front], edge, settings, rng)
        P = P[~_seen(P, X)]
        t_cond = time.perf_counter() - t0 - t_fit
        F = paths.at(P)  # (q, p, 11)
        ok = np.ones(F.shape[:2], dtype=bool)
        if feas is not None:
            ok &= feas.at(P)[:, :, 0] <= 0.0
        if sd_max is not None:
            # the sample's speed deviation back in natural units: within the screen's rule
            Z = np.zeros((F.shape[0] * F.shape[1], len(OBJECTIVES)))
            Z[:, j_sd] = -SENSE[j_sd] * F[:, :, j_sd].ravel()
            ok &= (tf.inverse(Z)[:, j_sd] <= sd_max).reshape(F.shape[:2])
        t_tensor = torch.as_tensor(T, dtype=torch.float64)
        weights = rng.dirichlet(np.ones(len(OBJECTIVES)), size=q)
        chosen: list[int] = []
        for s in range(q):
            scal = get_chebyshev_scalarization(torch.as_tensor(weights[s]), t_tensor)
            raw = scal(torch.as_tensor(F[s])).numpy()
            raw[chosen] = -np.inf
            # the sample's best among the candidates it keeps feasible, else its best of all (never one picked)
            score = np.where(ok[s], raw, -np.inf)
            best = int(np.argmax(score))
            if not np.isfinite(score[best]):
                best = int(np.argmax(raw))
            if np.isfinite(raw[best]):
                chosen.append(best)
        t_pick = time.perf_counter() - t0 - t_fit - t_cond
        if not chosen:
            break
        X_new = P[chosen]
        R_new = simulate(X_new).reset_index(drop=True)
        X, R = np.vstack([X, X_new]), pd.concat([R, R_new], ignore_index=True)
        success = _improves(Y[ran][front], R_new)
        edge = min(edge * 2.0, settings.tr_max) if success else max(edge / 2.0, settings.tr_min)
        rounds.append(
            {
                "round": len(rounds) + 1,
                "n_simulations": len(X),
                "n_new": len(X_new),
                "refit": refit,
                "pool": len(P),
                "trust_region": edge,
                "fit_s": t_fit,
                "condition_s": t_cond,
                "pick_s": t_pick,
                "runtime_s": time.perf_counter() - t0,
            }
        )
        if progress is not None:
            progress(len(X), settings.budget)
    return TsParegoRun(X, R, rounds)


def _ran(R: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """(objectives (n, 11), which designs ran: not stalled, every objective finite)."""
    Y = R[list(OBJECTIVES)].to_numpy(dtype=float)
    return Y, ~R["stalled"].to_numpy(dtype=bool) & np.all(np.isfinite(Y), axis=1)


def _improves(front: np.ndarray, R_new: pd.DataFrame) -> bool:
    """A round's success for the trust region: a new design that ran dominates a design of the last front (with
    eleven objectives nearly every new design is merely non-dominated, which says nothing of progress): a member
    of the front drops out of the non-dominated set once the new designs join it."""
    Y, ran = _ran(R_new)
    if not ran.any() or not len(front):
        return False
    return not nondominated_mask(to_minimisation(np.vstack([front, Y[ran]])))[: len(front)].all()
