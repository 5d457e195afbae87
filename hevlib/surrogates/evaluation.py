"""Fit both surrogates on one split of the DOE and judge them on the test split and a held-out set.

Both models are fitted on the same seeded ``train_fraction`` of the DOE, so ``train``, ``test`` and
``heldout`` mean the same rows for both; ``heldout`` is a fresh Latin hypercube simulated separately
and never used in fitting. ``heldout_followers`` are the held-out designs that follow the sizing cycle
well enough to survive screening (simulated ``speed_dev`` at most ``screen.speed_dev_max``): the
region the optimisers search, since they constrain the predicted ``speed_dev`` to that limit. The
whole held-out set is dominated by the few designs that barely move (per-km figures ten times the
typical ones); the followers show how well the surrogates resolve the designs that matter.

Metrics (:attr:`SurrogateStudy.metrics`) are in natural units and add Spearman's rank correlation.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hevlib.design import OBJECTIVES, DesignSpace
from hevlib.surrogates.metrics import objective_metrics, train_test_split
from hevlib.surrogates.regression import LinearRegressions

SPLITS = ("train", "test", "heldout", "heldout_followers")
MODELS = ("bnn", "regression")
I_SPEED_DEV = OBJECTIVES.index("speed_dev")


@dataclass(frozen=True)
class SurrogateStudy:
    """Fitted models, the data each split holds, their predictions, and the metrics of the contract."""

    models: dict  # "bnn" -> BayesRegMLP, "regression" -> LinearRegressions
    data: dict  # split -> (X, Y)
    predictions: dict  # model -> split -> Y_pred
    train_index: np.ndarray  # DOE rows in the training split
    test_index: np.ndarray
    speed_dev_max: float  # screening limit that defines heldout_followers

    @property
    def n_designs(self) -> dict[str, int]:
        """Designs in every split."""
        return {s: int(len(self.data[s][0])) for s in SPLITS}

    @property
    def metrics(self) -> dict:
        """``{model: {split: {objective: {"r2", "rmse", "mae", "spearman"}}}}`` for ``bnn`` and ``regression``,
        plus ``n_designs`` (per split) and ``heldout_followers_speed_dev_max``."""
        out: dict = {
            m: {s: objective_metrics(self.data[s][1], pred[s]) for s in SPLITS} for m, pred in self.predictions.items()
        }
        out["n_designs"] = self.n_designs
        out["heldout_followers_speed_dev_max"] = float(self.speed_dev_max)
        return out


def followers(Y: np.ndarray, speed_dev_max: float) -> np.ndarray:
    """(n,) bool: designs whose simulated speed deviation (column of ``Y``, (n, 11)) passes screening."""
    return np.asarray(Y, dtype=float)[:, I_SPEED_DEV] <= speed_dev_max


def fit_surrogates(
    X: np.ndarray,
    Y: np.ndarray,
    X_heldout: np.ndarray,
    Y_heldout: np.ndarray,
    params,
    space: DesignSpace,
    speed_dev_max: float,
    progress: Callable[[int, int], None] | None = None,
) -> SurrogateStudy:
    """Split, fit the BNN and the regressions, predict every split. ``params`` is ``SurrogateParams``;
    ``speed_dev_max`` (``screen.speed_dev_max``) picks the held-out followers."""
    from hevlib.surrogates.bnn import BayesRegMLP  # torch only here

    itr, ite = train_test_split(len(X), params.train_fraction, params.split_seed)
    keep = followers(Y_heldout, speed_dev_max)
    data = {
        "train": (X[itr], Y[itr]),
        "test": (X[ite], Y[ite]),
        "heldout": (X_heldout, Y_heldout),
        "heldout_followers": (X_heldout[keep], Y_heldout[keep]),
    }
    models = {
        "bnn": BayesRegMLP.from_params(space, params.bnn).fit(*data["train"], progress=progress),
        "regression": LinearRegressions(space).fit(*data["train"]),
    }
    predictions = {m: {s: _predict(model, data[s][0]) for s in SPLITS} for m, model in models.items()}
    return SurrogateStudy(models, data, predictions, itr, ite, float(speed_dev_max))


def _predict(model, X: np.ndarray) -> np.ndarray:
    return model.predict(X) if len(X) else np.empty((0, len(OBJECTIVES)))


def training_curve_table(history: dict[str, np.ndarray]) -> pd.DataFrame:
    """The BNN training curve as plot data: epoch, e_d, e_w, alpha, beta, gamma."""
    n = len(next(iter(history.values())))
    return pd.DataFrame({"epoch": np.arange(1, n + 1), **{k: np.asarray(v) for k, v in history.items()}})


def metric_table(metrics: dict, split: str = "heldout", metric: str = "r2") -> pd.DataFrame:
    """One metric of every objective (rows) for every model (columns) on one split."""
    return pd.DataFrame({m: {o: v[metric] for o, v in metrics[m][split].items()} for m in MODELS if m in metrics})


def summary_table(metrics: dict) -> pd.DataFrame:
    """Held-out R^2 and Spearman rho, on all held-out designs and on the followers (``fol.``), of both
    models (columns ``<model> <figure>``)."""
    cols = {}
    for split, metric, label in (
        ("heldout", "r2", "R2"),
        ("heldout_followers", "r2", "R2 fol."),
        ("heldout", "spearman", "rho"),
        ("heldout_followers", "spearman", "rho fol."),
    ):
        for m, col in metric_table(metrics, split, metric).items():
            cols[f"{m} {label}"] = col
    return pd.DataFrame(cols)
