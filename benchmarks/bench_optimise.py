"""Time each optimiser at the full study budget in params.yaml on stand-in surrogates of realistic cost.

    .venv/bin/python benchmarks/bench_optimise.py [--params params.yaml] [--algos nsga3,moead,moga]

Stand-ins (no trained model needed): for ``bnn`` a torch MLP 7-20-11 with random weights, input and
output standardisation and the design-space check of every call (the BNN's predict path); for
``regression`` one linear model per objective with the study's kind of terms (numpy). The mass is the
simulator's analytic mass model when ``hevlib.sim.simulator`` exists, else a linear stand-in. Prints one
line per algorithm (optimiser wall time, evaluations, front size) and the total against the 10-minute
bar of issue 6 (re-simulation excluded: it depends on the simulator).
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from hevlib.design import INTEGER_MASK, OBJECTIVES, DesignSpace
from hevlib.optimise import HevProblem, optimise
from hevlib.params import load_params

#: Objective scales (natural units) the stand-ins' outputs are mapped to: mean and spread.
_LOC = np.array([1150.0, 6.0, 10.0, 0.2, 1.5, 0.3, 0.2, 3.0, 0.02, 150.0, 3.5])
_SCALE = np.array([40.0, 1.5, 8.0, 0.05, 0.5, 0.1, 0.3, 2.0, 0.05, 20.0, 0.8])


class MlpStandIn:
    """A 7-20-11 tanh MLP with random (seeded) weights: the BNN's cost per call, not its answers."""

    def __init__(self, space: DesignSpace, seed: int = 0):
        torch.manual_seed(seed)
        self.space = space
        self.net = torch.nn.Sequential(torch.nn.Linear(7, 20), torch.nn.Tanh(), torch.nn.Linear(20, 11)).double()
        self.mid, self.half = (space.lower + space.upper) / 2, (space.upper - space.lower) / 2

    def predict(self, X):
        X = self.space.check(X, what="surrogate input", integers=False)
        with torch.no_grad():
            z = self.net(torch.from_numpy((X - self.mid) / self.half)).numpy()
        return _LOC + _SCALE * z

    def predict_std(self, X):
        return 0.05 * np.abs(self.predict(X))


class LinearStandIn:
    """One linear model per objective (intercept, 7 linear terms, 7 squares): the regressions' cost."""

    def __init__(self, space: DesignSpace, seed: int = 0):
        self.space = space
        self.B = np.random.default_rng(seed).normal(size=(15, 11)) * 0.3
        self.mid, self.half = (space.lower + space.upper) / 2, (space.upper - space.lower) / 2

    def predict(self, X):
        X = self.space.check(X, what="surrogate input", integers=False)
        z = (X - self.mid) / self.half
        return _LOC + _SCALE * (np.hstack([np.ones((len(z), 1)), z, z**2]) @ self.B)


def _mass_function(params):
    try:
        from hevlib.sim.simulator import Simulator
    except ImportError:
        coef = np.array([1.6, 0.9, 0.9, 0.0, 1.5, 0.0, 0.0])
        return (lambda X: 1040.0 + np.asarray(X) @ coef), "linear stand-in"
    return Simulator.from_params(params, components_dir="data/components").mass_kg, "Simulator.mass_kg"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--params", default="params.yaml")
    ap.add_argument("--algos", default="nsga3,moead,moga")
    args = ap.parse_args()
    params = load_params(args.params)
    space = params.design_space.space()
    mass_kg, mass_name = _mass_function(params)
    m_max = params.baseline.conventional.test_mass_kg
    print(f"torch threads {torch.get_num_threads()}, mass: {mass_name}, objectives {len(OBJECTIVES)}")
    total = 0.0
    for algo in args.algos.split(","):
        s = params.optimise.algorithms[algo]
        surrogate = MlpStandIn(space) if s.surrogate == "bnn" else LinearStandIn(space)
        front = optimise(HevProblem(surrogate, space, mass_kg, m_max), algo, s)
        total += front.runtime_s
        whole = bool(np.all(front.X[:, INTEGER_MASK] == np.round(front.X[:, INTEGER_MASK])))
        print(
            f"{algo:6s} surrogate={s.surrogate:10s} pop={s.pop_size} n_gen={s.n_gen} "
            f"runtime_s={front.runtime_s:7.1f} n_evaluations={front.n_evaluations:9d} "
            f"front={len(front):4d} infeasible_dropped={front.n_infeasible} integers_whole={whole}"
        )
    print(f"total optimiser time {total:.1f} s (bar: 600 s for the three stages incl. re-simulation)")


if __name__ == "__main__":
    main()
