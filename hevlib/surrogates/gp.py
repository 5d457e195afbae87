"""Gaussian-process surrogates: one exact GP per objective, the standard model of expensive many-objective
optimisation (ParEGO, qNParEGO, EHVI all sit on it), with the predictive standard deviation an infill
criterion needs (:mod:`hevlib.optimise.parego`).

Why our own and not GPyTorch/BoTorch or scikit-learn: neither is in the lock file, BoTorch pins torch
versions of its own (we must keep ``torch==2.13.0``), and what the benchmark needs is small -- an exact GP
on at most a few thousand designs in seven variables. The model is the usual one:

- inputs scaled to [0, 1] over the design space (integers relaxed);
- targets: the heavy-tailed objectives as ``log(y + c)`` (:class:`~hevlib.surrogates.transform.LogTargets`,
  the BNN's rule), then standardised;
- kernel: Matern 5/2 with one length scale per input (ARD), an output scale and a Gaussian noise
  variance (at least ``1e-6`` of the standardised variance), constant zero mean;
- hyperparameters: maximum marginal likelihood with mild log-normal priors on the length scales (centred
  on 0.5, the span of the unit box), fitted by L-BFGS on at most ``max_fit_rows`` designs (a seeded
  subset beyond that: the cost is cubic), the eleven GPs in one batched torch graph; the posterior is then
  conditioned on every design.

``predict(X, return_std=True)`` gives the posterior mean of the latent function back-transformed as the
median (as the BNN) and the delta-method standard deviation; :meth:`GaussianProcesses.sample` draws
posterior samples of the eleven objectives (independent per design and objective) in natural units.
"""

from __future__ import annotations

from typing import Self

import numpy as np

from hevlib.design import OBJECTIVES, DesignSpace
from hevlib.surrogates.base import check_designs, check_targets, clip_objectives
from hevlib.surrogates.transform import LogTargets

_SQRT5 = np.sqrt(5.0)
#: Smallest noise variance, in units of the standardised target's variance.
NOISE_FLOOR = 1e-6


def matern52(A: np.ndarray, B: np.ndarray, lengthscale: np.ndarray, outputscale: float) -> np.ndarray:
    """Matern 5/2 kernel matrix (len(A), len(B)) with ARD ``lengthscale`` (d,) and ``outputscale``."""
    a, b = A / lengthscale, B / lengthscale
    d2 = np.maximum(np.sum(a * a, 1)[:, None] + np.sum(b * b, 1)[None, :] - 2.0 * a @ b.T, 0.0)
    r = _SQRT5 * np.sqrt(d2)
    return outputscale * (1.0 + r + r * r / 3.0) * np.exp(-r)


class GaussianProcesses:
    """Eleven independent exact GPs (``OBJECTIVES`` order); scikit-learn style ``fit`` / ``predict``."""

    kind = "gp"

    def __init__(
        self,
        space: DesignSpace,
        log_targets: tuple[str, ...] | list[str] = (),
        max_fit_rows: int = 250,
        max_iter: int = 40,
        seed: int = 0,
    ):
        self.space = space
        self.log_targets = tuple(log_targets)
        self.max_fit_rows = int(max_fit_rows)
        self.max_iter = int(max_iter)
        self.seed = int(seed)

    # ------------------------------------------------------------------------------------ fitting
    def fit(self, X: np.ndarray, Y: np.ndarray) -> Self:
        X = check_designs(self.space, X, what="GP training designs")
        Y = check_targets(Y, X.shape[0], what="GP training objectives")
        if X.shape[0] < 3:
            raise ValueError("GP training designs: need at least 3 designs")
        self.transform_ = LogTargets.fit(self.log_targets, Y, what="GP log_targets")
        Z = self.transform_.forward(Y)
        self.z_mean_ = Z.mean(axis=0)
        self.z_scale_ = np.where(Z.std(axis=0) > 0, Z.std(axis=0), 1.0)
        self.z_max_ = np.where(self.transform_.mask, Z.max(axis=0), np.inf)
        x = self._scaled(X)
        T = (Z - self.z_mean_) / self.z_scale_
        rng = np.random.default_rng(self.seed)
        sub = np.sort(rng.choice(len(x), self.max_fit_rows, replace=False)) if len(x) > self.max_fit_rows else None
        xs, Ts = (x, T) if sub is None else (x[sub], T[sub])
        self.lengthscale_, self.outputscale_, self.noise_ = _fit_hyper(xs, Ts, self.max_iter)
        self.x_train_ = x
        self.alpha_, self.K_inv_ = [], []
        for k in range(T.shape[1]):
            K = matern52(x, x, self.lengthscale_[k], self.outputscale_[k]) + self.noise_[k] * np.eye(len(x))
            L = np.linalg.cholesky(K + 1e-10 * self.outputscale_[k] * np.eye(len(x)))
            L_inv = np.linalg.solve(L, np.eye(len(x)))
            K_inv = L_inv.T @ L_inv
            self.K_inv_.append(K_inv)
            self.alpha_.append(K_inv @ T[:, k])
        return self

    def _scaled(self, X: np.ndarray) -> np.ndarray:
        return (X - self.space.lower) / (self.space.upper - self.space.lower)

    # --------------------------------------------------------------------------------- prediction
    def latent(self, X: np.ndarray, chunk: int = 2048) -> tuple[np.ndarray, np.ndarray]:
        """Posterior mean and standard deviation (n, 11) of the latent function in transformed units."""
        if not hasattr(self, "alpha_"):
            raise ValueError("GP: not fitted")
        x = self._scaled(check_designs(self.space, X, what="GP input"))
        mu, sd = np.empty((len(x), len(OBJECTIVES))), np.empty((len(x), len(OBJECTIVES)))
        for s in range(0, len(x), chunk):
            xc = x[s : s + chunk]
            for k in range(len(OBJECTIVES)):
                Ks = matern52(xc, self.x_train_, self.lengthscale_[k], self.outputscale_[k])
                mu[s : s + chunk, k] = Ks @ self.alpha_[k]
                var = self.outputscale_[k] - np.einsum("ij,ij->i", Ks @ self.K_inv_[k], Ks)
                sd[s : s + chunk, k] = np.sqrt(np.maximum(var, 1e-12 * self.outputscale_[k]))
        return mu * self.z_scale_ + self.z_mean_, sd * self.z_scale_

    def predict(self, X: np.ndarray, return_std: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Objectives (n, 11) in natural units (the median back-transform, clipped to the physical range);
        with ``return_std`` also the delta-method standard deviation."""
        z, s = self.latent(X)
        z = np.minimum(z, self.z_max_)
        mean = clip_objectives(self.transform_.inverse(z))
        return (mean, self.transform_.std(z, s)) if return_std else mean

    def sample(self, X: np.ndarray, n_samples: int, rng: np.random.Generator) -> np.ndarray:
        """(n_samples, n, 11) posterior samples in natural units, clipped to the physical range (each
        design and objective independent: the marginals an expected improvement per design needs)."""
        z, s = self.latent(X)
        draws = z[None] + s[None] * rng.standard_normal((int(n_samples), *z.shape))
        draws = np.minimum(draws, self.z_max_ + 2.0 * np.where(self.transform_.mask, 1.0, np.inf))
        return np.stack([clip_objectives(self.transform_.inverse(d)) for d in draws])


def _fit_hyper(x: np.ndarray, T: np.ndarray, max_iter: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Length scales (m, d), output scales (m,) and noise variances (m,) maximising each column's log
    marginal likelihood plus log-normal priors on the length scales; the m GPs in one batched graph."""
    from hevlib.determinism import torch as pinned_torch

    torch = pinned_torch()  # one thread, ATen's default capability: the same rounding on every CPU
    n, d = x.shape
    m = T.shape[1]
    xt = torch.as_tensor(x, dtype=torch.float64)
    yt = torch.as_tensor(T.T.copy(), dtype=torch.float64)  # (m, n)
    raw_ls = torch.full((m, d), float(np.log(0.5)), dtype=torch.float64, requires_grad=True)
    raw_os = torch.zeros(m, dtype=torch.float64, requires_grad=True)
    raw_noise = torch.full((m,), float(np.log(1e-2)), dtype=torch.float64, requires_grad=True)
    eye = torch.eye(n, dtype=torch.float64)
    opt = torch.optim.LBFGS([raw_ls, raw_os, raw_noise], lr=0.5, max_iter=max_iter, line_search_fn="strong_wolfe")

    def objective():
        opt.zero_grad()
        ls = torch.exp(raw_ls.clamp(-6.0, 4.0))  # (m, d)
        os_ = torch.exp(raw_os.clamp(-8.0, 6.0))
        noise = torch.exp(raw_noise.clamp(-14.0, 2.0)) + NOISE_FLOOR
        a = xt[None] / ls[:, None, :]  # (m, n, d)
        d2 = torch.cdist(a, a).pow(2)
        r = torch.sqrt(d2 + 1e-12) * float(_SQRT5)
        K = os_[:, None, None] * (1.0 + r + r * r / 3.0) * torch.exp(-r) + noise[:, None, None] * eye
        L = torch.linalg.cholesky(K + 1e-8 * eye)
        alpha = torch.cholesky_solve(yt[:, :, None], L)[:, :, 0]
        nll = 0.5 * (yt * alpha).sum(1) + torch.log(torch.diagonal(L, dim1=1, dim2=2)).sum(1)
        prior = 0.5 * ((torch.log(ls) - float(np.log(0.5))) ** 2).sum(1) / 1.5**2
        loss = (nll + prior).sum() / n
        loss.backward()
        return loss

    opt.step(objective)
    ls = np.exp(np.clip(raw_ls.detach().numpy(), -6.0, 4.0))
    os_ = np.exp(np.clip(raw_os.detach().numpy(), -8.0, 6.0))
    noise = np.exp(np.clip(raw_noise.detach().numpy(), -14.0, 2.0)) + NOISE_FLOOR
    return ls, os_, noise


__all__ = ["GaussianProcesses", "matern52", "NOISE_FLOOR"]
