"""Gaussian-process surrogates on BoTorch/GPyTorch: the standard model of expensive many-objective search
(ParEGO, NEHVI) with the posterior an acquisition function needs.

:class:`GaussianProcesses` wraps BoTorch's :class:`~botorch.models.SingleTaskGP` behind the project's
scikit-learn style ``fit`` / ``predict`` surrogate interface (:mod:`hevlib.surrogates.base`):

- one independent GP per objective, batched in one multi-output ``SingleTaskGP`` (BoTorch's default
  RBF ARD kernel with Hvarfner et al.'s dimension-scaled log-normal length-scale prior), inputs normalised to the unit
  cube over the design space (``Normalize``; integers relaxed), outcomes standardised (``Standardize``);
- targets in BoTorch's maximisation form: ``-sense * t(y)``, ``t`` the log of the heavy-tailed objectives
  (:class:`~hevlib.surrogates.transform.LogTargets`, the BNN's rule), identity for the others, so that
  "larger is better" for every output (:meth:`GaussianProcesses.to_model_space`);
- hyperparameters by ``fit_gpytorch_mll`` (L-BFGS-B on the exact marginal likelihood, all outputs jointly) on every
  design given: no subset.

:class:`FeasibilityGP` is the failure model: a GP on +1 (the design stalled: fell behind the trace and
did not finish the sizing cycle) / -1 labels of every simulated design, with a small fixed noise
(``LABEL_NOISE``: the simulator is deterministic); the probability that a design runs,
``Phi(-mean / sd)``, weights the acquisition (:mod:`hevlib.optimise.bayesopt`). Failed designs are
therefore never fitted as objective values.

Everything runs in float64 on the one-thread torch of :func:`hevlib.determinism.torch`, so a fit gives
the same bits on every CPU kind (the determinism tests check the sources built on it).
"""

from __future__ import annotations

from typing import Self

import numpy as np

from hevlib.design import OBJECTIVES, SENSE, DesignSpace
from hevlib.determinism import torch as _torch  # torch itself is imported on the first call
from hevlib.surrogates.base import NotFittedError, check_designs, check_targets, clip_objectives
from hevlib.surrogates.transform import LogTargets


def _fitted_gp(space: DesignSpace, X: np.ndarray, T: np.ndarray, noise: float | None = None):
    """A BoTorch ``SingleTaskGP`` on designs ``X`` (n, 7) and targets ``T`` (n, m), hyperparameters fitted;
    the noise variance inferred, or fixed at ``noise`` (in the targets' units) for exact labels."""
    torch = _torch()
    from botorch.fit import fit_gpytorch_mll
    from botorch.models import SingleTaskGP
    from botorch.models.transforms import Normalize, Standardize
    from gpytorch.mlls import ExactMarginalLogLikelihood

    bounds = torch.as_tensor(np.vstack([space.lower, space.upper]), dtype=torch.float64)
    train_x = torch.as_tensor(np.ascontiguousarray(X), dtype=torch.float64)
    train_y = torch.as_tensor(np.ascontiguousarray(T), dtype=torch.float64)
    model = SingleTaskGP(
        train_x,
        train_y,
        train_Yvar=None if noise is None else torch.full_like(train_y, noise),
        input_transform=Normalize(d=X.shape[1], bounds=bounds),
        outcome_transform=Standardize(m=T.shape[1]),
    )
    fit_gpytorch_mll(ExactMarginalLogLikelihood(model.likelihood, model))
    model.eval()
    return model


class GaussianProcesses:
    """Independent GPs for ``objectives`` (default all eleven, ``OBJECTIVES`` order); ``fit`` / ``predict``
    in natural units, ``model`` the fitted BoTorch model for acquisition functions (maximisation form)."""

    kind = "gp"

    def __init__(self, space: DesignSpace, log_targets: tuple[str, ...] | list[str] = (), objectives=OBJECTIVES):
        self.space = space
        self.log_targets = tuple(log_targets)
        self.objectives = tuple(objectives)
        self._cols = [OBJECTIVES.index(k) for k in self.objectives]

    def fit(self, X: np.ndarray, Y: np.ndarray) -> Self:
        """Fit on designs ``X`` (n, 7) and their eleven objectives ``Y`` (n, 11, natural units)."""
        X = check_designs(self.space, X, what="GP training designs")
        Y = check_targets(Y, X.shape[0], what="GP training objectives")
        if X.shape[0] < 3:
            raise ValueError("GP training designs: need at least 3 designs")
        self.transform_ = LogTargets.fit(self.log_targets, Y, what="GP log_targets")
        self.model = _fitted_gp(self.space, X, self.to_model_space(Y))
        return self

    def to_model_space(self, Y: np.ndarray) -> np.ndarray:
        """Natural objectives (n, 11) -> the model's targets (n, len(objectives)): larger is better."""
        Z = self.transform_.forward(np.asarray(Y, dtype=float))
        return (-SENSE * Z)[:, self._cols]

    def model_threshold(self, name: str, value: float) -> float:
        """``value`` of objective ``name`` in the model's units (for an outcome constraint)."""
        y = np.ones((1, len(OBJECTIVES)))
        y[0, OBJECTIVES.index(name)] = value
        return float((-SENSE * self.transform_.forward(y))[0, OBJECTIVES.index(name)])

    def latent(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Posterior mean and standard deviation (n, len(objectives)) in the model's units."""
        if not hasattr(self, "model"):
            raise NotFittedError("GP: not fitted")
        torch = _torch()
        x = torch.as_tensor(check_designs(self.space, X, what="GP input"), dtype=torch.float64)
        with torch.no_grad():
            post = self.model.posterior(x)
            return post.mean.numpy().copy(), post.variance.clamp_min(0.0).sqrt().numpy().copy()

    def predict(self, X: np.ndarray, return_std: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Objectives (n, 11) in natural units (the median back-transform, clipped to the physical range;
        objectives the GPs do not model are NaN); with ``return_std`` also the delta-method deviation."""
        mu, sd = self.latent(X)
        Z, S = np.full((len(mu), len(OBJECTIVES)), np.nan), np.full((len(mu), len(OBJECTIVES)), np.nan)
        Z[:, self._cols] = -SENSE[self._cols] * mu
        S[:, self._cols] = sd
        mean = clip_objectives(self.transform_.inverse(Z))
        return (mean, self.transform_.std(Z, S)) if return_std else mean


#: Noise variance of the failure labels: the simulator is deterministic, a label is exact (a learnt noise
#: smoothed the probability of failure to 1-2 % inside a region where every design had stalled).
LABEL_NOISE = 1e-4


class FeasibilityGP:
    """The failure model: a GP on +1 (failed) / -1 (ran) labels; ``model``'s output <= 0 means feasible."""

    kind = "feasibility"

    def __init__(self, space: DesignSpace):
        self.space = space

    def fit(self, X: np.ndarray, failed: np.ndarray) -> Self:
        X = check_designs(self.space, X, what="feasibility training designs")
        failed = np.asarray(failed, dtype=bool).reshape(-1)
        if failed.shape != (len(X),):
            raise ValueError(f"feasibility labels: expected {len(X)} flags, got shape {failed.shape}")
        self.model = _fitted_gp(self.space, X, np.where(failed, 1.0, -1.0)[:, None], noise=LABEL_NOISE)
        return self

    def probability(self, X: np.ndarray) -> np.ndarray:
        """(n,) posterior probability that each design runs (label < 0)."""
        torch = _torch()
        x = torch.as_tensor(check_designs(self.space, X, what="feasibility input"), dtype=torch.float64)
        with torch.no_grad():
            post = self.model.posterior(x)
            z = -post.mean[:, 0] / post.variance[:, 0].clamp_min(1e-12).sqrt()
            return (0.5 * torch.erfc(-z / np.sqrt(2.0))).numpy().copy()


__all__ = ["FeasibilityGP", "GaussianProcesses"]
