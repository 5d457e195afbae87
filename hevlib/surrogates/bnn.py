"""Bayesian-regularised MLP surrogate: MacKay's evidence framework as MATLAB's ``trainbr`` applies it.

Conventions (``trainbr``'s, used consistently here and in the saved model):

* ``E_D = sum(e**2)`` over all ``N = n_train * n_outputs`` standardised training residuals;
* ``E_W = sum(w**2)`` over all ``N_w`` weights and biases;
* objective ``F = beta * E_D + alpha * E_W``;
* Gauss-Newton Hessian of ``F``: ``H = 2 beta J^T J + 2 alpha I`` with ``J = d residuals / d w`` (N x N_w);
* effective number of parameters ``gamma = N_w - 2 alpha tr(H^-1) = sum_i beta l_i / (beta l_i + alpha)``
  (``l_i`` the eigenvalues of ``J^T J``; the eigen form is the same number, computed stably);
* re-estimation ``alpha = gamma / (2 E_W)``, ``beta = (N - gamma) / (2 E_D)``.

``exp(-F)`` is the (unnormalised) posterior, so the noise precision is ``2 beta`` (noise variance
``1 / (2 beta)`` per standardised residual; MacKay's ``1 / beta`` in his ``E_D = sum(e**2) / 2``
convention) and the Laplace posterior covariance of the weights is ``H^-1``. The predictive variance of
output ``k`` at ``x`` is ``g_k^T H^-1 g_k + 1 / (2 beta)`` with ``g_k = d f_k(x) / d w`` (full-network,
Gauss-Newton Laplace approximation), in standardised units, then scaled back per objective.

Optimiser: full-batch Adam starting at the study's learning rate (``lr``), not Levenberg-Marquardt. Adam
uses the study's setting, is insensitive to the scale of ``F`` (which changes by orders of magnitude as
``beta`` grows), and an epoch costs one forward/backward pass instead of LM's Jacobian and
``N_w x N_w`` solve; the Jacobian is only formed every ``evidence_every`` epochs for the re-estimation.
The step size is cosine-annealed to ``LR_FINAL_FRACTION * lr`` by ``max_epochs``: at a constant 0.01
Adam keeps overshooting the sharpening minimum (spikes of E_D once ``beta`` is large), whereas the
evidence formulas assume the weights sit at a minimum of ``F``. Training stops at ``max_epochs`` or when
the standardised training MSE ``E_D / N`` reaches ``error_goal``.
One network predicts all eleven standardised objectives with one shared ``alpha`` and ``beta``.

Targets: the objectives in ``log_targets`` (params ``surrogate.bnn.log_targets``; default the heavy-tailed
fc, hc, co, nox) are log-transformed before standardising (:class:`hevlib.surrogates.transform.LogTargets`);
``y_mean_`` / ``y_scale_`` are the moments of the transformed targets. ``predict`` back-transforms to
natural units (median back-transform) and gives the std in natural units by the delta method. The
evidence framework itself is unchanged: it works on the standardised transformed targets.
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Self

import numpy as np
import torch
from torch import nn

from hevlib.design import DESIGN_VARS, OBJECTIVES, DesignSpace
from hevlib.io import save_with
from hevlib.surrogates.base import (
    NotFittedError,
    check_designs,
    check_targets,
    space_from_dict,
    space_to_dict,
)
from hevlib.surrogates.transform import LogTargets

FORMAT = "hev-bnn-2"
DTYPE = torch.float64
#: Floors and ceilings that keep the re-estimated hyperparameters finite and positive.
_TINY = 1e-12
_BETA_MAX = 1e12
_ALPHA_MAX = 1e12
#: Designs per chunk when forming output Jacobians for the predictive standard deviation.
_STD_CHUNK = 2048
HISTORY_KEYS = ("e_d", "e_w", "alpha", "beta", "gamma")
#: The Adam step size is cosine-annealed from ``lr`` to this fraction of it over ``max_epochs``.
LR_FINAL_FRACTION = 0.01


def evidence_update(
    jtj_eigvals: np.ndarray, e_d: float, e_w: float, alpha: float, beta: float, n_residuals: int
) -> tuple[float, float, float]:
    """One MacKay re-estimation: return ``(alpha, beta, gamma)`` from the current ones.

    ``jtj_eigvals`` are the eigenvalues of ``J^T J`` (length ``N_w``; tiny negative round-off is
    clipped). The result always has ``alpha > 0``, ``beta > 0`` and ``0 < gamma <= N_w``: with
    ``alpha > 0`` every term ``beta l / (beta l + alpha)`` is below one, so ``gamma < rank(J) <= N``;
    the floors only guard round-off and a perfect fit (``E_D = 0``).
    """
    lam = np.clip(np.asarray(jtj_eigvals, dtype=float), 0.0, None)
    n_w = lam.size
    alpha, beta = max(float(alpha), _TINY), max(float(beta), _TINY)
    gamma = float(np.sum(beta * lam / (beta * lam + alpha)))
    gamma = min(max(gamma, _TINY), float(n_w), (1.0 - 1e-9) * n_residuals)
    alpha = min(max(gamma / (2.0 * max(e_w, _TINY)), _TINY), _ALPHA_MAX)
    beta = min(max((n_residuals - gamma) / (2.0 * max(e_d, _TINY)), _TINY), _BETA_MAX)
    return alpha, beta, gamma


def _mlp(n_in: int, hidden: tuple[int, ...], n_out: int) -> nn.Sequential:
    layers: list[nn.Module] = []
    width = n_in
    for h in hidden:
        layers += [nn.Linear(width, h, dtype=DTYPE), nn.Tanh()]
        width = h
    layers.append(nn.Linear(width, n_out, dtype=DTYPE))
    return nn.Sequential(*layers)


def _init_weights(net: nn.Sequential, rng: np.random.Generator) -> None:
    """Glorot-uniform weights, zero biases, drawn from the seeded generator (never torch's global RNG)."""
    with torch.no_grad():
        for layer in net:
            if isinstance(layer, nn.Linear):
                fan_out, fan_in = layer.weight.shape
                bound = math.sqrt(6.0 / (fan_in + fan_out))
                layer.weight.copy_(torch.from_numpy(rng.uniform(-bound, bound, size=(fan_out, fan_in))))
                layer.bias.zero_()


def _output_jacobian(
    net: nn.Sequential, x: torch.Tensor, *, body_only: bool = False
) -> tuple[torch.Tensor, torch.Tensor]:
    """``d f(x_i) / d w`` for every row, (n, n_out, N_w) in ``net.named_parameters()`` order, and the
    input of the output layer (n, h_last).

    Closed-form back-propagation of the identity through the tanh layers (one batched pass; several
    times faster than ``torch.func`` for these small networks). ``body_only`` leaves out the output
    layer's own columns (for output ``k`` they are just ``[a_last, 1]`` in block ``k``).
    """
    linears = [m for m in net if isinstance(m, nn.Linear)]
    with torch.no_grad():
        acts = [x]  # input of every linear layer
        for lin in linears[:-1]:
            acts.append(torch.tanh(lin(acts[-1])))
        n, n_out = x.shape[0], linears[-1].out_features
        delta = torch.eye(n_out, dtype=x.dtype).expand(n, n_out, n_out)  # d f / d (pre-activation)
        blocks: list[torch.Tensor] = []
        for i in range(len(linears) - 1, -1, -1):
            if i < len(linears) - 1 or not body_only:
                blocks.append(delta)  # bias
                blocks.append((delta[:, :, :, None] * acts[i][:, None, None, :]).reshape(n, n_out, -1))
            if i > 0:
                delta = (delta @ linears[i].weight) * (1.0 - acts[i] ** 2)[:, None, :]
        jac = torch.cat(blocks[::-1], dim=2) if blocks else x.new_zeros((n, n_out, 0))
        return jac, acts[-1]


def _sum_sq_weights(net: nn.Module) -> torch.Tensor:
    return sum((p * p).sum() for p in net.parameters())


class BayesRegMLP:
    """Bayesian-regularised tanh MLP predicting all eleven objectives, with predictive uncertainty.

    Hyperparameters are stored unchanged (scikit-learn style); learned state ends in ``_``.
    ``space`` is the design space inputs are checked against (and saved with the model); ``log_targets``
    names the objectives fitted in log space (none by default here; the pipeline's default comes from
    params).
    """

    kind = "bnn"

    def __init__(
        self,
        space: DesignSpace,
        hidden: tuple[int, ...] | list[int] = (20,),
        lr: float = 0.01,
        max_epochs: int = 3500,
        error_goal: float = 1e-10,
        evidence_every: int = 10,
        seed: int = 0,
        log_targets: tuple[str, ...] | list[str] = (),
    ):
        self.space = space
        self.hidden = tuple(int(h) for h in hidden)
        self.lr = lr
        self.max_epochs = max_epochs
        self.error_goal = error_goal
        self.evidence_every = evidence_every
        self.seed = seed
        self.log_targets = tuple(log_targets)

    @classmethod
    def from_params(cls, space: DesignSpace, p) -> BayesRegMLP:
        """From a ``hevlib.params.BnnParams``."""
        return cls(
            space,
            hidden=tuple(p.hidden),
            lr=p.lr,
            max_epochs=p.max_epochs,
            error_goal=p.error_goal,
            evidence_every=p.evidence_every,
            seed=p.seed,
            log_targets=tuple(p.log_targets),
        )

    # ------------------------------------------------------------------------------------ fitting
    def fit(self, X: np.ndarray, Y: np.ndarray, progress=None) -> Self:
        """Train on (n, 7) designs and (n, 11) objectives; ``progress(epoch, max_epochs)`` if given.

        Runs on one torch thread (restored afterwards): the matrices are tiny, so a second thread gains
        little and, on a busy machine, waiting for it can make training many times slower.
        """
        threads = torch.get_num_threads()
        torch.set_num_threads(1)
        try:
            return self._fit(X, Y, progress)
        finally:
            torch.set_num_threads(threads)

    def _fit(self, X: np.ndarray, Y: np.ndarray, progress) -> Self:
        X = check_designs(self.space, X, what="BNN training designs")
        Y = check_targets(Y, X.shape[0], what="BNN training objectives")
        if X.shape[0] < 2:
            raise ValueError("BNN training designs: need at least 2 designs")
        rng = np.random.default_rng(self.seed)
        transform = LogTargets.fit(self.log_targets, Y)
        Z = transform.forward(Y)
        self.x_mean_, self.x_scale_ = _moments(X)
        self.y_mean_, self.y_scale_ = _moments(Z)
        x = torch.from_numpy((X - self.x_mean_) / self.x_scale_)
        y = torch.from_numpy((Z - self.y_mean_) / self.y_scale_)

        net = _mlp(X.shape[1], self.hidden, Y.shape[1])
        _init_weights(net, rng)
        n_res = y.numel()
        n_w = sum(p.numel() for p in net.parameters())
        opt = torch.optim.Adam(net.parameters(), lr=self.lr)
        alpha, beta, gamma = _initial_hyper(net, n_w)
        hist = {k: [] for k in HISTORY_KEYS}
        epoch = 0
        for epoch in range(1, self.max_epochs + 1):
            opt.param_groups[0]["lr"] = _annealed_lr(self.lr, epoch, self.max_epochs)
            opt.zero_grad(set_to_none=True)
            e_d = ((net(x) - y) ** 2).sum()
            e_w = _sum_sq_weights(net)
            (beta * e_d + alpha * e_w).backward()
            opt.step()
            e_d_val, e_w_val = e_d.item(), e_w.item()
            if epoch % self.evidence_every == 0:  # re-estimate at the updated weights
                with torch.no_grad():
                    e_d_now, e_w_now = ((net(x) - y) ** 2).sum().item(), _sum_sq_weights(net).item()
                lam = torch.linalg.eigvalsh(_gram(net, x)).numpy()
                alpha, beta, gamma = evidence_update(lam, e_d_now, e_w_now, alpha, beta, n_res)
            for k, v in zip(HISTORY_KEYS, (e_d_val, e_w_val, alpha, beta, gamma), strict=True):
                hist[k].append(v)
            if progress is not None and (epoch % 100 == 0 or epoch == self.max_epochs):
                progress(epoch, self.max_epochs)
            if e_d_val / n_res <= self.error_goal:
                break

        # Laplace posterior at the final weights, with the alpha, beta the weights were trained under.
        with torch.no_grad():
            e_d_fin = float(((net(x) - y) ** 2).sum())
        jtj = _gram(net, x)
        lam = torch.linalg.eigvalsh(jtj).clamp_min(0.0)
        self.gamma_ = float((beta * lam / (beta * lam + alpha)).sum())
        hess = 2.0 * beta * jtj + 2.0 * alpha * torch.eye(n_w, dtype=DTYPE)
        self.cov_ = torch.cholesky_inverse(torch.linalg.cholesky(hess))  # Laplace posterior covariance H^-1
        self.net_ = net.eval()
        self.target_transform_ = transform
        self.alpha_, self.beta_ = float(alpha), float(beta)
        self.n_weights_, self.n_residuals_, self.epochs_ = int(n_w), int(n_res), int(epoch)
        self.train_mse_std_ = e_d_fin / n_res
        self.history_ = {k: np.asarray(v) for k, v in hist.items()}
        return self

    # --------------------------------------------------------------------------------- prediction
    def predict(self, X: np.ndarray, return_std: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Objectives (n, 11) in natural units; with ``return_std`` also their predictive std (n, 11).

        Log-transformed objectives: the mean is ``exp(mu_z) - c`` (median back-transform) and the std
        ``exp(mu_z) * std_z`` (delta method), see :mod:`hevlib.surrogates.transform`.
        """
        self._check_fitted()
        X = check_designs(self.space, X)
        x = torch.from_numpy((X - self.x_mean_) / self.x_scale_)
        with torch.inference_mode():
            z_mean = self.net_(x).numpy() * self.y_scale_ + self.y_mean_
        mean = self.target_transform_.inverse(z_mean)
        if not return_std:
            return mean
        return mean, self.target_transform_.std(z_mean, self._std(x))

    def _std(self, x: torch.Tensor) -> np.ndarray:
        """Predictive std of the (transformed) targets: ``sqrt(g_k^T H^-1 g_k + 1 / (2 beta))`` per output,
        scaled back from standardised units (natural units for objectives not log-transformed).

        ``g_k`` is dense over the hidden layers (``u_k``) and, in the output layer, non-zero only in row
        ``k`` of its weights and bias (``phi = [a_last, 1]``); the quadratic form is split accordingly
        so 100 000 designs cost seconds, not the ``n * n_out * N_w**2`` of the dense product.
        """
        cov = self.cov_
        n_out = len(self.y_scale_)
        h = self.net_[-1].in_features
        p_h = cov.shape[0] - n_out * (h + 1)
        head = torch.cat(
            [p_h + torch.arange(n_out * h).reshape(n_out, h), (p_h + n_out * h + torch.arange(n_out))[:, None]], dim=1
        )  # (n_out, h + 1)
        s11 = cov[:p_h, :p_h]
        s12 = cov[:p_h][:, head].permute(1, 0, 2)  # (n_out, p_h, h + 1)
        s22 = cov[head[:, :, None], head[:, None, :]]  # (n_out, h + 1, h + 1): diagonal blocks only
        var = np.empty((x.shape[0], n_out))
        for start in range(0, x.shape[0], _STD_CHUNK):
            xc = x[start : start + _STD_CHUNK]
            u, a_last = _output_jacobian(self.net_, xc, body_only=True)  # (m, n_out, p_h), (m, h)
            phi = torch.cat([a_last, a_last.new_ones((a_last.shape[0], 1))], dim=1)  # (m, h + 1)
            quad = ((u @ s11) * u).sum(dim=2)
            cross = ((u.transpose(0, 1) @ s12) * phi[None]).sum(dim=2).T
            last = torch.einsum("mi,kij,mj->mk", phi, s22, phi)
            var[start : start + _STD_CHUNK] = (quad + 2.0 * cross + last).numpy()
        var = np.clip(var, 0.0, None) + 1.0 / (2.0 * self.beta_)
        return np.sqrt(var) * self.y_scale_

    def _check_fitted(self) -> None:
        if not hasattr(self, "net_"):
            raise NotFittedError("BNN surrogate is not fitted: call fit() or BayesRegMLP.load()")

    # -------------------------------------------------------------------------------- persistence
    def save(self, path: str | Path) -> None:
        """Write the model (weights, normaliser, hyperparameters, evidence state, training curve)."""
        self._check_fitted()
        blob = {
            "format": FORMAT,
            "design_vars": list(DESIGN_VARS),
            "objectives": list(OBJECTIVES),
            "space": space_to_dict(self.space),
            "hyper": {
                "hidden": list(self.hidden),
                "lr": float(self.lr),
                "max_epochs": int(self.max_epochs),
                "error_goal": float(self.error_goal),
                "evidence_every": int(self.evidence_every),
                "seed": int(self.seed),
                "log_targets": list(self.log_targets),
            },
            "target_transform": {
                "log_targets": list(self.target_transform_.names),
                "offset": torch.from_numpy(self.target_transform_.offset),
            },
            "state_dict": self.net_.state_dict(),
            "normaliser": {
                k: torch.from_numpy(getattr(self, k + "_")) for k in ("x_mean", "x_scale", "y_mean", "y_scale")
            },
            "evidence": {
                "alpha": self.alpha_,
                "beta": self.beta_,
                "gamma": self.gamma_,
                "n_weights": self.n_weights_,
                "n_residuals": self.n_residuals_,
                "epochs": self.epochs_,
                "train_mse_std": self.train_mse_std_,
            },
            "posterior_cov": self.cov_,
            "history": {k: torch.from_numpy(v) for k, v in self.history_.items()},
        }
        buf = io.BytesIO()  # not torch.save(tmp): the archive would embed the random temp-file name
        torch.save(blob, buf)
        save_with(path, lambda tmp: Path(tmp).write_bytes(buf.getvalue()))

    @classmethod
    def load(cls, path: str | Path) -> BayesRegMLP:
        path = Path(path)
        if not path.exists():
            raise FileNotFoundError(f"{path}: no such BNN model; run `hev surrogates` first")
        try:
            blob = torch.load(path, map_location="cpu", weights_only=True)
        except Exception as err:  # noqa: BLE001 - any unpickling problem is a bad model file
            raise ValueError(f"{path}: not a readable BNN model ({type(err).__name__})") from None
        if not isinstance(blob, dict) or blob.get("format") != FORMAT:
            found = (
                f" (found {blob['format']}; run `hev surrogates` again)"
                if isinstance(blob, dict) and "format" in blob
                else ""
            )
            raise ValueError(f"{path}: not a {FORMAT} model file{found}")
        if tuple(blob["design_vars"]) != DESIGN_VARS or tuple(blob["objectives"]) != OBJECTIVES:
            raise ValueError(f"{path}: model was trained on other design variables or objectives")
        h = blob["hyper"]
        model = cls(space_from_dict(blob["space"]), **h)
        net = _mlp(len(DESIGN_VARS), model.hidden, len(OBJECTIVES))
        net.load_state_dict(blob["state_dict"])
        model.net_ = net.eval()
        tt = blob["target_transform"]
        model.target_transform_ = LogTargets.from_dict(
            {"log_targets": tt["log_targets"], "offset": tt["offset"].numpy()}
        )
        for k, v in blob["normaliser"].items():
            setattr(model, k + "_", v.numpy())
        ev = blob["evidence"]
        model.alpha_, model.beta_, model.gamma_ = ev["alpha"], ev["beta"], ev["gamma"]
        model.n_weights_, model.n_residuals_, model.epochs_ = ev["n_weights"], ev["n_residuals"], ev["epochs"]
        model.train_mse_std_ = ev["train_mse_std"]
        model.cov_ = blob["posterior_cov"]
        model.history_ = {k: v.numpy() for k, v in blob["history"].items()}
        return model


def _annealed_lr(lr: float, epoch: int, max_epochs: int) -> float:
    """Cosine annealing from ``lr`` (first epoch) to ``LR_FINAL_FRACTION * lr`` (last epoch)."""
    frac = (epoch - 1) / max(max_epochs - 1, 1)
    return lr * (LR_FINAL_FRACTION + (1.0 - LR_FINAL_FRACTION) * 0.5 * (1.0 + math.cos(math.pi * frac)))


def _moments(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Column mean and standard deviation (1 where a column is constant, so it standardises to 0)."""
    mean = A.mean(axis=0)
    scale = A.std(axis=0)
    return mean, np.where(scale > 1e-12 * np.maximum(1.0, np.abs(mean)), scale, 1.0)


def _gram(net: nn.Sequential, x: torch.Tensor) -> torch.Tensor:
    """``J^T J`` of the residuals (targets do not depend on the weights: ``J`` is the output Jacobian)."""
    j, _ = _output_jacobian(net, x)
    j = j.reshape(-1, j.shape[2])
    return j.T @ j


def _initial_hyper(net: nn.Module, n_w: int) -> tuple[float, float, float]:
    """Start as ``trainbr`` does with ``beta = 1`` and ``gamma = N_w``, but with the prior that matches the
    initial weights (``alpha = N_w / (2 E_W)``) instead of ``alpha = 0``: the first re-estimation then
    cannot return ``gamma = N`` (and so ``beta = 0``) when there are fewer residuals than weights."""
    with torch.no_grad():
        e_w = float(_sum_sq_weights(net))
    return n_w / (2.0 * max(e_w, _TINY)), 1.0, float(n_w)
