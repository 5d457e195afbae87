"""Time the surrogates at the study's settings on synthetic data (no simulator needed).

    .venv/bin/python benchmarks/bench_surrogates.py [--params params.yaml] [--n-train 327] [--n-predict 100000]

Trains the BNN with ``params.surrogate.bnn`` (Levenberg-Marquardt with MacKay's evidence updates, one
small tanh network per objective, fc/hc/co/nox fitted in log space) on ``--n-train`` Latin-hypercube designs with
smooth nonlinear synthetic targets (positive and heavy-tailed for the log-transformed objectives),
fits the regressions on the same data, then times prediction of ``--n-predict`` designs (mean; BNN also
with the Laplace standard deviation; best of 3). Prints one table with the bars of issue 5: training
under 2 minutes, prediction of 100 000 designs under 1 second.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from hevlib.design import OBJECTIVES
from hevlib.doe import lhs_designs
from hevlib.params import load_params
from hevlib.surrogates.bnn import BayesRegMLP
from hevlib.surrogates.metrics import r2_score
from hevlib.surrogates.regression import LinearRegressions


def synthetic_targets(
    X: np.ndarray, lower: np.ndarray, upper: np.ndarray, positive: tuple[str, ...] = ()
) -> np.ndarray:
    """Eleven smooth nonlinear functions of the scaled designs (an objective-like workload); the objectives
    in ``positive`` are ``20 exp(2 f)``: positive and heavy-tailed, like the per-km figures."""
    u = (X - lower) / (upper - lower)
    Y = np.stack(
        [
            np.tanh(u @ np.sin(np.arange(7) * (k + 1))) + 0.5 * np.sin(3 * u[:, k % 7]) * u[:, (k + 2) % 7]
            for k in range(11)
        ],
        axis=1,
    )
    for name in positive:
        k = OBJECTIVES.index(name)
        Y[:, k] = 20.0 * np.exp(2.0 * Y[:, k])
    return Y


def best_of(fn, repeats: int = 3) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--params", default="params.yaml")
    ap.add_argument("--n-train", type=int, default=327)
    ap.add_argument("--n-predict", type=int, default=100_000)
    args = ap.parse_args()
    params = load_params(args.params)
    space = params.design_space.space()
    p = params.surrogate.bnn
    X = lhs_designs(space, args.n_train, 0)
    Y = synthetic_targets(X, space.lower, space.upper, tuple(p.log_targets))
    Xp = lhs_designs(space, args.n_predict, 1)

    t0 = time.perf_counter()
    bnn = BayesRegMLP.from_params(space, p).fit(X, Y)
    t_train = time.perf_counter() - t0
    t0 = time.perf_counter()
    reg = LinearRegressions(space).fit(X, Y)
    t_reg = time.perf_counter() - t0
    rows = [
        (
            f"BNN train ({args.n_train} designs, {bnn.epochs_} epochs, hidden {p.hidden}, "
            f"log {','.join(p.log_targets) or 'none'})",
            t_train,
            120.0,
        ),
        (f"BNN predict {args.n_predict} (mean)", best_of(lambda: bnn.predict(Xp)), 1.0),
        (f"BNN predict {args.n_predict} (mean + std)", best_of(lambda: bnn.predict(Xp, return_std=True)), None),
        (f"regression fit ({args.n_train} designs)", t_reg, None),
        (f"regression predict {args.n_predict}", best_of(lambda: reg.predict(Xp)), 1.0),
    ]
    width = max(len(r[0]) for r in rows)
    print(f"{'task':<{width}}  {'seconds':>9}  bar")
    for name, sec, bar in rows:
        verdict = "" if bar is None else (f"< {bar:g} s ok" if sec < bar else f"< {bar:g} s FAILED")
        print(f"{name:<{width}}  {sec:9.3f}  {verdict}")
    r2 = r2_score(synthetic_targets(Xp[:2000], space.lower, space.upper, tuple(p.log_targets)), bnn.predict(Xp[:2000]))
    print(
        f"BNN: gamma per network {np.round(np.ravel(bnn.gamma_), 1).tolist()} of {bnn.n_weights_} weights each; "
        f"R^2 on 2000 fresh designs min {r2.min():.4f}, mean {r2.mean():.4f}"
    )


if __name__ == "__main__":
    main()
