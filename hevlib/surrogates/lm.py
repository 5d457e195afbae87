"""Levenberg-Marquardt training with MacKay's evidence re-estimation, as MATLAB's ``trainbr`` does it
(Foresee & Hagan 1997, "Gauss-Newton approximation to Bayesian learning"), for a batch of small tanh
MLPs of one shape trained side by side (plain numpy: no torch, deterministic given the start weights).

Conventions (``trainbr``'s, used everywhere here and in the saved model), per network:

* ``E_D = sum(e**2)`` over its ``N`` residuals (training rows x outputs), ``E_W = sum(w**2)`` over its
  ``n_w`` weights and biases, objective ``F = beta E_D + alpha E_W``;
* ``J = d f / d w`` (``N x n_w``), Gauss-Newton Hessian of ``F``: ``H = 2 beta J^T J + 2 alpha I``;
* LM step ``(beta J^T J + (alpha + mu) I) dw = beta J^T e - alpha w`` with ``e = y - f``; a step that lowers
  ``F`` is taken and ``mu *= mu_dec``, otherwise ``mu *= mu_inc`` and the step is tried again, until
  ``mu > mu_max`` (the network then stops: no step lowers ``F`` any more);
* after each accepted step, at the new weights: ``gamma = n_w - 2 alpha tr(H^-1)
  = sum_i beta l_i / (beta l_i + alpha)`` (``l_i`` the eigenvalues of ``J^T J``), ``alpha = gamma / (2 E_W)``,
  ``beta = (N - gamma) / (2 E_D)``, and ``F`` is re-evaluated with them;
* start as ``trainbr``: ``alpha ~ 0``, ``beta = 1`` (the first step is plain LM), re-estimation from the first
  accepted step on. Optionally (``warmup``) the re-estimation waits until plain LM least squares has
  ``E_D`` stable over a window (or reached its minimum, or after two windows), then starts from
  ``gamma = n_w``, ``alpha = gamma / (2 E_W)``, ``beta = (N - gamma) / (2 E_D)`` at those weights. The
  ``trainbr`` start can let the prior outweigh the data after a poor first step (small ``E_W``,
  ``E_D ~ N``) and collapse the weights to zero (``gamma -> 0``, a constant prediction; seen on 7-1-1
  networks fitted to 27 designs); the warm-up cannot collapse, but from an overfitted least-squares fit it
  settles at a higher ``gamma`` and a lower evidence when the net has many weights (150 noisy rows,
  7-10-1, seeds 0-3: gamma 68-81 against 32-82, test R^2 0.69-0.90 against 0.76-0.93). The BNN uses both kinds of
  start among its restarts and keeps the one with the highest evidence.

At the evidence fixed point ``beta E_D = (N - gamma) / 2`` and ``alpha E_W = gamma / 2``, so ``F`` is always
``N / 2`` after a re-estimation and says nothing about convergence; a network stops instead when
``gamma`` and ``E_D`` have both stayed within a relative ``tol`` over the last ``window`` epochs (or at
``max_epochs``, or at ``mu_max``).

Every trial step is one batched ``n_w x n_w`` solve, ``gamma`` one batched inverse per accepted step
(``J`` is formed once per accepted step and serves both the re-estimation and the next epoch's steps).
The noise precision of ``exp(-F)`` is ``2 beta`` and the Laplace posterior covariance of the weights
``H^-1``; :func:`log_evidence` is ``ln p(D | alpha, beta)`` under the same Gaussian approximation, used to
choose among restarts.
"""

from __future__ import annotations

import ctypes
import functools
import glob
import math
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

#: Floors and ceilings that keep the re-estimated hyperparameters finite and positive.
_TINY = 1e-12
_BETA_MAX = 1e12
_ALPHA_MAX = 1e12
_MU_MIN = 1e-20
#: E_D per residual below which its changes no longer count against convergence (standardised targets:
#: 1e-4 is an rms error of 1 % of the target's spread; a deterministic objective such as the mass is fitted
#: ever more exactly and E_D would otherwise never settle).
_ED_FLOOR = 1e-4
HISTORY_KEYS = ("e_d", "e_w", "alpha", "beta", "gamma", "mu")
STOP_REASONS = ("stable", "max_epochs", "mu_max")


# ----------------------------------------------------------------------------------- BLAS threads
@functools.cache
def _openblas() -> tuple[Callable, Callable] | None:
    """``(get, set)`` of the number of threads of the OpenBLAS bundled with numpy, or None (no such
    library or symbol: then nothing is changed)."""
    root = os.path.dirname(os.path.dirname(np.__file__))
    for path in sorted(glob.glob(os.path.join(root, "numpy.libs", "*openblas*"))):
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for prefix in ("scipy_openblas", "openblas"):
            for suffix in ("64_", ""):
                get = getattr(lib, f"{prefix}_get_num_threads{suffix}", None)
                put = getattr(lib, f"{prefix}_set_num_threads{suffix}", None)
                if get is not None and put is not None:
                    put.argtypes = [ctypes.c_int]
                    return get, put
    return None


@contextmanager
def single_blas_thread() -> Iterator[None]:
    """Run numpy's BLAS on one thread inside the block (restored after). The matrices here are small
    (n_w <= a few hundred): a second BLAS thread gains nothing, and where another library's threads are
    alive (torch's OpenMP pool once a model file is loaded, numba's simulator kernels) OpenBLAS's
    spinning threads made a 300-row fit ~15x slower (35 s instead of 2 s, measured on 2 cores)."""
    blas = _openblas()
    if blas is None:
        yield
        return
    get, put = blas
    before = int(get())
    put(1)
    try:
        yield
    finally:
        put(before)


# ------------------------------------------------------------------------------------ the networks
@dataclass(frozen=True)
class MLPShape:
    """Layer sizes ``(n_in, h_1, ..., n_out)`` of a tanh MLP with a linear output layer.

    A batch of ``M`` networks of this shape is a weight array ``(M, n_w)``: layer by layer, the weight
    matrix (out x in, row-major) then the bias.
    """

    sizes: tuple[int, ...]

    @property
    def layers(self) -> tuple[tuple[int, int], ...]:
        """``(n_out, n_in)`` of every linear layer."""
        return tuple((o, i) for i, o in zip(self.sizes[:-1], self.sizes[1:], strict=True))

    @property
    def n_weights(self) -> int:
        return sum(o * i + o for o, i in self.layers)

    @property
    def n_out(self) -> int:
        return self.sizes[-1]

    def unpack(self, w: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """``[(W (M, out, in), b (M, out)), ...]`` views into ``w`` (M, n_w)."""
        out, pos = [], 0
        for o, i in self.layers:
            W = w[:, pos : pos + o * i].reshape(-1, o, i)
            pos += o * i
            out.append((W, w[:, pos : pos + o]))
            pos += o
        return out

    def forward(self, w: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        """Outputs ``(M, n, n_out)`` of every network at the inputs ``x`` (n, n_in), and the inputs of every
        layer (``x`` itself, then the hidden activations ``(M, n, h)``)."""
        layers = self.unpack(w)
        acts: list[np.ndarray] = [x]
        a = x
        for W, b in layers[:-1]:
            a = np.tanh(a @ W.transpose(0, 2, 1) + b[:, None, :])
            acts.append(a)
        W, b = layers[-1]
        return a @ W.transpose(0, 2, 1) + b[:, None, :], acts

    def jacobian(self, w: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``d f / d w`` for every network, row and output, ``(M, n, n_out, n_w)``, and the outputs.

        Closed-form back-propagation of the identity through the tanh layers (one batched pass)."""
        f, acts = self.forward(w, x)
        layers = self.unpack(w)
        m, n = w.shape[0], x.shape[0]
        k = self.n_out
        delta = np.broadcast_to(np.eye(k), (m, n, k, k))  # d f / d (pre-activation of the layer)
        blocks: list[np.ndarray] = []
        for li in range(len(layers) - 1, -1, -1):
            W, _ = layers[li]
            a = acts[li]
            a4 = a[None, :, None, None, :] if a.ndim == 2 else a[:, :, None, None, :]
            blocks.append(delta)  # bias
            blocks.append((delta[..., None] * a4).reshape(m, n, k, -1))  # weights, row-major
            if li > 0:
                delta = (delta @ W[:, None]) * (1.0 - acts[li] ** 2)[:, :, None, :]
        return np.concatenate(blocks[::-1], axis=3), f


def init_weights(shape: MLPShape, m: int, rng: np.random.Generator) -> np.ndarray:
    """``m`` start weight vectors: Nguyen-Widrow for the first (tanh) layer on inputs in [-1, 1] (MATLAB's
    ``initnw``: the active regions of the hidden units spread over the input box), Glorot-uniform for
    later hidden layers, small uniform output weights and zero output biases."""
    w = np.zeros((m, shape.n_weights))
    views = shape.unpack(w)
    n_layers = len(views)
    for li, ((o, i), (W, b)) in enumerate(zip(shape.layers, views, strict=True)):
        if li == n_layers - 1:
            W[...] = rng.uniform(-1.0, 1.0, size=W.shape) / math.sqrt(i)
        elif li == 0:
            mag = 0.7 * o ** (1.0 / i)
            d = rng.standard_normal(W.shape)
            W[...] = mag * d / np.linalg.norm(d, axis=2, keepdims=True)
            b[...] = rng.uniform(-mag, mag, size=b.shape)
        else:
            bound = math.sqrt(6.0 / (i + o))
            W[...] = rng.uniform(-bound, bound, size=W.shape)
    return w


# ----------------------------------------------------------------------------------- the evidence
def evidence_update(
    jtj_eigvals: np.ndarray, e_d, e_w, alpha, beta, n_residuals: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One MacKay re-estimation: ``(alpha, beta, gamma)`` from the current ones (scalars or arrays (M,)).

    ``jtj_eigvals`` (..., n_w) are the eigenvalues of ``J^T J`` (round-off below zero is clipped);
    ``gamma = sum_i beta l_i / (beta l_i + alpha) = n_w - 2 alpha tr(H^-1)``. See :func:`reestimate`.
    """
    lam = np.clip(np.asarray(jtj_eigvals, dtype=float), 0.0, None)
    alpha = np.maximum(np.asarray(alpha, dtype=float), _TINY)
    beta = np.maximum(np.asarray(beta, dtype=float), _TINY)
    bl = beta[..., None] * lam
    gamma = np.sum(bl / (bl + alpha[..., None]), axis=-1)
    return reestimate(gamma, e_d, e_w, lam.shape[-1], n_residuals)


def reestimate(gamma, e_d, e_w, n_weights: int, n_residuals: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``alpha = gamma / (2 E_W)``, ``beta = (N - gamma) / (2 E_D)`` from the effective number of parameters.

    The result has ``alpha > 0``, ``beta > 0`` and ``0 < gamma <= n_w``, ``gamma < N`` (with ``alpha > 0``
    every term ``beta l / (beta l + alpha)`` is below one; the floors only guard round-off and a perfect fit).
    """
    gamma = np.clip(np.asarray(gamma, dtype=float), _TINY, min(float(n_weights), (1.0 - 1e-9) * n_residuals))
    alpha = np.clip(gamma / (2.0 * np.maximum(e_w, _TINY)), _TINY, _ALPHA_MAX)
    beta = np.clip((n_residuals - gamma) / (2.0 * np.maximum(e_d, _TINY)), _TINY, _BETA_MAX)
    return alpha, beta, gamma


def effective_parameters(jtj: np.ndarray, alpha: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """``gamma = n_w - alpha tr((beta J^T J + alpha I)^-1) = n_w - 2 alpha tr(H^-1)`` for (M, n_w, n_w) ``jtj``."""
    n_w = jtj.shape[-1]
    a = beta[:, None, None] * jtj + alpha[:, None, None] * np.eye(n_w)
    return n_w - alpha * np.trace(np.linalg.inv(a), axis1=1, axis2=2)


def log_evidence(
    jtj_eigvals: np.ndarray, e_d, e_w, alpha, beta, n_residuals: int, hidden: tuple[int, ...] = ()
) -> np.ndarray:
    """``ln p(D | alpha, beta)`` of the Laplace approximation at the weights (``trainbr``'s conventions):

    ``N/2 ln(beta/pi) + n_w/2 ln(alpha/pi) - F + n_w/2 ln(2 pi) - 1/2 ln det H``, ``H = 2 beta J^T J + 2 alpha I``,
    plus MacKay's symmetry term ``sum_l ln(h_l!) + h_l ln 2`` (equivalent hidden-unit permutations and sign
    flips) when ``hidden`` is given. Higher is better; used to choose among restarts."""
    lam = np.clip(np.asarray(jtj_eigvals, dtype=float), 0.0, None)
    n_w = lam.shape[-1]
    alpha, beta = np.asarray(alpha, dtype=float), np.asarray(beta, dtype=float)
    logdet = np.sum(np.log(2.0 * beta[..., None] * lam + 2.0 * alpha[..., None]), axis=-1)
    f = beta * e_d + alpha * e_w
    sym = sum(math.lgamma(h + 1) + h * math.log(2.0) for h in hidden)
    return (
        0.5 * n_residuals * np.log(beta / math.pi)
        + 0.5 * n_w * np.log(alpha / math.pi)
        - f
        + 0.5 * n_w * math.log(2.0 * math.pi)
        - 0.5 * logdet
        + sym
    )


# ---------------------------------------------------------------------------------------- training
@dataclass(frozen=True)
class LMSettings:
    """``trainbr``'s knobs (MATLAB defaults: mu 0.005, mu_dec 0.1, mu_inc 10, mu_max 1e10) and the stop rule."""

    mu: float = 0.005
    mu_dec: float = 0.1
    mu_inc: float = 10.0
    mu_max: float = 1e10
    max_epochs: int = 1000
    window: int = 10
    tol: float = 1e-2
    evidence: bool = True  # False: plain LM least squares (alpha ~ 0 and beta fixed), for comparison
    warmup: bool = False  # least-squares epochs before the first re-estimation (see the module doc)


@dataclass
class LMResult:
    """Trained weights and the evidence state of every network of the batch (arrays over networks)."""

    w: np.ndarray  # (M, n_w)
    alpha: np.ndarray  # (M,)
    beta: np.ndarray
    gamma: np.ndarray
    e_d: np.ndarray
    e_w: np.ndarray
    jtj: np.ndarray  # (M, n_w, n_w): J^T J at the final weights
    epochs: np.ndarray  # (M,) ints
    stop: list[str]  # STOP_REASONS per network
    history: dict[str, np.ndarray]  # HISTORY_KEYS -> (M, epochs + 1): the start, then after every epoch
    n_residuals: int

    def log_evidence(self, hidden: tuple[int, ...] = ()) -> np.ndarray:
        lam = np.linalg.eigvalsh(self.jtj)
        return log_evidence(lam, self.e_d, self.e_w, self.alpha, self.beta, self.n_residuals, hidden=hidden)


def posterior_cov(jtj: np.ndarray, alpha: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """Laplace posterior covariance of the weights, ``H^-1 = (2 beta J^T J + 2 alpha I)^-1``, (M, n_w, n_w)."""
    h = 2.0 * beta[:, None, None] * jtj + 2.0 * alpha[:, None, None] * np.eye(jtj.shape[-1])
    cov = np.linalg.inv(h)
    return 0.5 * (cov + cov.transpose(0, 2, 1))


def train_lm_evidence(
    shape: MLPShape,
    x: np.ndarray,
    y: np.ndarray,
    w0: np.ndarray,
    settings: LMSettings = LMSettings(),
    progress: Callable[[int, int], None] | None = None,
    warmup: np.ndarray | None = None,
) -> LMResult:
    """Train ``M`` networks of ``shape`` from ``w0`` (M, n_w) on inputs ``x`` (n, n_in) and targets ``y``
    (M, n, n_out): one target set per network. All networks step together; each stops on its own.
    ``warmup`` (M,) bool chooses per network whether the re-estimation waits for a least-squares warm-up
    (default: ``settings.warmup`` for all)."""
    s = settings
    w = np.array(w0, dtype=float)
    m, n_w = w.shape
    n_res = int(y.shape[1] * y.shape[2])
    eye = np.eye(n_w)

    def linearise(ws: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``J^T J`` and ``J^T e`` at the weights ``ws``."""
        J, f = shape.jacobian(ws, x)
        J = J.reshape(len(ws), n_res, n_w)
        e = (ys - f).reshape(len(ws), n_res)
        return J.transpose(0, 2, 1) @ J, np.einsum("mrp,mr->mp", J, e)

    f0, _ = shape.forward(w, x)
    e_d, e_w = np.sum((y - f0) ** 2, axis=(1, 2)), np.sum(w**2, axis=1)
    gamma = np.full(m, float(n_w))
    alpha = np.full(m, _TINY)
    beta = np.ones(m)
    mu = np.full(m, float(s.mu))
    jtj, jte = linearise(w, y)
    warm = np.full(m, bool(s.warmup)) if warmup is None else np.array(warmup, dtype=bool).reshape(m)
    warm &= bool(s.evidence)  # in the least-squares warm-up (alpha ~ 0, beta fixed)
    phase_start = np.zeros(m, dtype=int)  # epoch the current phase began
    warmup_max = 2 * s.window

    def start_evidence(js: np.ndarray, epoch: int) -> None:
        """End the warm-up: ``trainbr``'s start (gamma = n_w) at the least-squares weights."""
        js = js[warm[js]]
        if js.size == 0:
            return
        warm[js], phase_start[js], mu[js] = False, epoch, s.mu
        gm = effective_parameters(jtj[js], alpha[js], beta[js])
        alpha[js], beta[js], gamma[js] = reestimate(gm, e_d[js], e_w[js], n_w, n_res)

    hist = {k: [v.copy()] for k, v in zip(HISTORY_KEYS, (e_d, e_w, alpha, beta, gamma, mu), strict=True)}
    active = np.ones(m, dtype=bool)
    stop = ["max_epochs"] * m
    epochs = np.zeros(m, dtype=int)
    for epoch in range(1, s.max_epochs + 1):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        perf = beta[idx] * e_d[idx] + alpha[idx] * e_w[idx]
        rhs = beta[idx, None] * jte[idx] - alpha[idx, None] * w[idx]
        pending = np.ones(idx.size, dtype=bool)
        accepted = np.zeros(idx.size, dtype=bool)
        converged_ls: list[int] = []
        while pending.any():
            p = np.flatnonzero(pending)
            g = idx[p]
            a = beta[g, None, None] * jtj[g] + (alpha[g] + mu[g])[:, None, None] * eye
            w_try = w[g] + np.linalg.solve(a, rhs[p][:, :, None])[:, :, 0]
            f_try, _ = shape.forward(w_try, x)
            ed_try = np.sum((y[g] - f_try) ** 2, axis=(1, 2))
            ew_try = np.sum(w_try**2, axis=1)
            ok = beta[g] * ed_try + alpha[g] * ew_try < perf[p]
            good = g[ok]
            w[good], e_d[good], e_w[good] = w_try[ok], ed_try[ok], ew_try[ok]
            mu[good] = np.maximum(mu[good] * s.mu_dec, _MU_MIN)
            accepted[p[ok]] = True
            pending[p[ok]] = False
            bad = g[~ok]
            mu[bad] *= s.mu_inc
            over = bad[mu[bad] > s.mu_max]
            for j in over:
                if warm[j]:  # the least-squares minimum: go on with the evidence
                    converged_ls.append(int(j))
                else:
                    active[j] = False
                    stop[j] = "mu_max"
            pending[np.isin(idx, over)] = False
        epochs[idx] = epoch
        moved = idx[accepted]
        if moved.size:
            jtj[moved], jte[moved] = linearise(w[moved], y[moved])
            gm = effective_parameters(jtj[moved], alpha[moved], beta[moved])
            upd = moved[~warm[moved]] if s.evidence else moved[:0]
            gamma[moved] = gm
            if upd.size:
                alpha[upd], beta[upd], gamma[upd] = reestimate(gm[~warm[moved]], e_d[upd], e_w[upd], n_w, n_res)
        if converged_ls:
            start_evidence(np.array(converged_ls), epoch)
        for k, v in zip(HISTORY_KEYS, (e_d, e_w, alpha, beta, gamma, mu), strict=True):
            hist[k].append(v.copy())
        for j in moved:
            if epoch - phase_start[j] < s.window:
                continue
            gw = np.array([hh[j] for hh in hist["gamma"][-(s.window + 1) :]])
            dw = np.array([hh[j] for hh in hist["e_d"][-(s.window + 1) :]])
            settled = np.ptp(dw) <= s.tol * max(dw[-1], _ED_FLOOR * n_res)
            if warm[j]:
                if settled or epoch - phase_start[j] >= warmup_max:
                    start_evidence(np.array([j]), epoch)
            elif settled and np.ptp(gw) <= s.tol * max(gw[-1], 1.0):
                active[j] = False
                stop[j] = "stable"
        if progress is not None and (epoch % 10 == 0 or not active.any()):
            progress(epoch, s.max_epochs)
    history = {k: np.stack(v, axis=1) for k, v in hist.items()}  # a stopped network keeps its last state
    return LMResult(w, alpha, beta, gamma, e_d, e_w, jtj, epochs, stop, history, n_res)
