"""Fit both surrogates, judge them on the test split and a held-out set, and keep the models to save.

Which rows each model sees (nothing here ever fits on a held-out design):

* ``split_models``: fitted on the seeded ``train_fraction`` of the DOE only; the ``train`` and ``test``
  metrics are theirs (the test rows are unseen by them).
* ``models`` (saved to ``models/`` for the optimisers): refitted on every DOE design, train and test (the
  study fitted its regressions on all 27 L27 runs; an orthogonal array loses its orthogonality when
  rows are left out). The ``heldout`` and ``heldout_followers`` metrics are theirs: the models the
  optimisers use, judged on designs neither ever saw.

``heldout`` is a fresh Latin hypercube over the whole design space, simulated separately.
``heldout_followers`` are the held-out designs that follow the sizing cycle well enough to survive
screening (simulated ``speed_dev`` at most ``screen.speed_dev_max``): the region the optimisers search,
since they constrain the predicted ``speed_dev`` to that limit. The whole held-out set is dominated by the
few designs that barely move (per-km figures ten times the typical ones); the followers show how well
the surrogates resolve the designs that matter.

Metrics (:attr:`SurrogateStudy.metrics`) are in natural units and add Spearman's rank correlation, and for
the BNN ``coverage_2sigma``: the share of points within the predicted mean +- 2 predictive std (about
0.95 when the std is calibrated).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from hevlib.design import OBJECTIVES, DesignSpace
from hevlib.screen import speed_dev_max as speed_dev_rule
from hevlib.surrogates.fitting import fit_surrogate
from hevlib.surrogates.metrics import objective_metrics, train_test_split

SPLITS = ("train", "test", "heldout", "heldout_followers")
#: Splits judged with the models fitted on the training split; the others with the saved models.
SPLIT_MODEL_SPLITS = ("train", "test")
MODELS = ("bnn", "regression")
I_SPEED_DEV = OBJECTIVES.index("speed_dev")


@dataclass(frozen=True)
class SurrogateStudy:
    """Fitted models, the data each split holds, their predictions, and the metrics of the contract."""

    models: dict  # "bnn" -> BayesRegMLP, "regression" -> LinearRegressions: fitted on every DOE design (saved)
    split_models: dict  # the same kinds fitted on the training split only (judged on train and test)
    data: dict  # split -> (X, Y)
    predictions: dict  # model -> split -> Y_pred
    stds: dict  # model -> split -> predictive std (models that report one: the BNN)
    train_index: np.ndarray  # DOE rows in the training split
    test_index: np.ndarray
    speed_dev_max: float  # screening limit that defines heldout_followers

    @property
    def n_designs(self) -> dict[str, int]:
        """Designs in every split."""
        return {s: int(len(self.data[s][0])) for s in SPLITS}

    def model_for(self, kind: str, split: str):
        """The model whose predictions of ``split`` are judged (split model for train/test, else saved)."""
        return self.split_models[kind] if split in SPLIT_MODEL_SPLITS else self.models[kind]

    @property
    def metrics(self) -> dict:
        """``{model: {split: {objective: {"r2", "rmse", "mae", "spearman"[, "coverage_2sigma"]}}}}`` for
        ``bnn`` and ``regression``, plus ``n_designs`` (per split), ``n_fit`` (designs the split models and
        the saved models were fitted on), ``heldout_followers_speed_dev_max`` and ``bnn_evidence`` (per
        network of the saved and of the split BNN: gamma, n_weights, hidden, alpha, beta, log evidence,
        epochs)."""
        out: dict = {
            m: {s: objective_metrics(self.data[s][1], pred[s], self.stds.get(m, {}).get(s)) for s in SPLITS}
            for m, pred in self.predictions.items()
        }
        out["n_designs"] = self.n_designs
        out["n_fit"] = {"split_models": int(len(self.train_index)), "saved_models": int(self._n_doe)}
        out["heldout_followers_speed_dev_max"] = float(self.speed_dev_max)
        if "bnn" in self.models:
            out["bnn_evidence"] = {
                "saved": _numeric_evidence(self.models["bnn"]),
                "split": _numeric_evidence(self.split_models["bnn"]),
            }
        return out

    @property
    def _n_doe(self) -> int:
        return len(self.train_index) + len(self.test_index)


def _numeric_evidence(bnn) -> dict:
    return {
        name: {k: v for k, v in rec.items() if not isinstance(v, str)} | {"hidden": int(bnn.hidden_)}
        for name, rec in bnn.evidence_summary().items()
    }


def followers(Y: np.ndarray, speed_dev_max: float) -> np.ndarray:
    """(n,) bool: designs whose simulated speed deviation (column of ``Y``, (n, 11)) passes screening."""
    return speed_dev_rule(speed_dev_max).mask({"speed_dev": np.asarray(Y, dtype=float)[:, I_SPEED_DEV]})


def fit_surrogates(
    X: np.ndarray,
    Y: np.ndarray,
    X_heldout: np.ndarray,
    Y_heldout: np.ndarray,
    params,
    space: DesignSpace,
    speed_dev_max: float,
) -> SurrogateStudy:
    """Split; fit the BNN and the regressions on the training split (judged on train and test) and again
    on every DOE design (the saved models, judged on the held-out set); predict every split. ``params`` is
    ``SurrogateParams``; ``speed_dev_max`` (``screen.speed_dev_max``) picks the held-out followers.
    Models are built by :func:`hevlib.surrogates.fitting.fit_surrogate` only."""
    itr, ite = train_test_split(len(X), params.train_fraction, params.split_seed)
    keep = followers(Y_heldout, speed_dev_max)
    data = {
        "train": (X[itr], Y[itr]),
        "test": (X[ite], Y[ite]),
        "heldout": (X_heldout, Y_heldout),
        "heldout_followers": (X_heldout[keep], Y_heldout[keep]),
    }
    split_models = {kind: fit_surrogate(kind, *data["train"], params, space) for kind in MODELS}
    models = {kind: fit_surrogate(kind, X, Y, params, space) for kind in MODELS}
    study = SurrogateStudy(models, split_models, data, {}, {}, itr, ite, float(speed_dev_max))
    for kind in MODELS:
        study.predictions[kind], std = {}, {}
        for s in SPLITS:
            mean, sd = _predict(study.model_for(kind, s), data[s][0])
            study.predictions[kind][s] = mean
            if sd is not None:
                std[s] = sd
        if std:
            study.stds[kind] = std
    return study


def _predict(model, X: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Mean and, for a model that reports one (``kind == "bnn"``), the predictive std; empty splits allowed."""
    has_std = getattr(model, "kind", None) == "bnn"
    if not len(X):
        empty = np.empty((0, len(OBJECTIVES)))
        return empty, (empty if has_std else None)
    return model.predict(X, return_std=True) if has_std else (model.predict(X), None)


def training_curve_table(model) -> pd.DataFrame:
    """The BNN's training curve (Levenberg-Marquardt epochs, 0 = the start) as plot data: ``epoch``,
    ``gamma`` (summed over the networks: the effective parameters of the whole surrogate), ``e_d``, ``e_w``
    (summed), then per network ``<key>_<network>`` for gamma, e_d, e_w, alpha, beta and mu. A network that
    stopped keeps its last values."""
    h = model.history_
    names = model.network_names_
    n = h["gamma"].shape[1]
    cols: dict[str, np.ndarray] = {"epoch": np.arange(n)}
    for key in ("gamma", "e_d", "e_w"):
        cols[key] = h[key].sum(axis=0)
    for key in ("gamma", "e_d", "e_w", "alpha", "beta", "mu"):
        for i, name in enumerate(names):
            cols[f"{key}_{name}"] = h[key][i]
    return pd.DataFrame(cols)


def metric_table(metrics: dict, split: str = "heldout", metric: str = "r2") -> pd.DataFrame:
    """One metric of every objective (rows) for every model (columns) on one split (models without it,
    such as the regressions for ``coverage_2sigma``, are left out)."""
    return pd.DataFrame(
        {
            m: {o: v[metric] for o, v in metrics[m][split].items()}
            for m in MODELS
            if m in metrics and metric in next(iter(metrics[m][split].values()))
        }
    )


def summary_table(metrics: dict) -> pd.DataFrame:
    """Held-out R^2 and Spearman rho, on all held-out designs and on the followers (``fol.``), of both
    models (columns ``<model> <figure>``), and the BNN's held-out ``coverage_2sigma`` (``cov2s``)."""
    cols = {}
    for split, metric, label in (
        ("heldout", "r2", "R2"),
        ("heldout_followers", "r2", "R2 fol."),
        ("heldout", "spearman", "rho"),
        ("heldout_followers", "spearman", "rho fol."),
        ("heldout", "coverage_2sigma", "cov2s"),
    ):
        for m, col in metric_table(metrics, split, metric).items():
            cols[f"{m} {label}"] = col
    return pd.DataFrame(cols)
