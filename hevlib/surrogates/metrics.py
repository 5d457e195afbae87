"""Judging and using surrogates: the seeded train/test split, per-objective error metrics (R^2, RMSE, MAE
in natural units, Spearman's rank correlation: what an optimiser needs is the order of designs, and for a
model with a predictive std the share of points within 2 sigma), loading a fitted model, and prediction
tables."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from hevlib.design import DESIGN_VARS, OBJECTIVES
from hevlib.io import float_schema, write_parquet, write_text

MODEL_FILES = {"bnn": "bnn.pt", "regression": "regression.json"}


def train_test_split(n: int, train_fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Seeded random split of ``range(n)``: (train indices, test indices), each sorted.

    ``round(train_fraction * n)`` designs train, at least 2, and at least one is left for the test.
    """
    if n < 3:
        raise ValueError(f"train/test split: need at least 3 designs, got {n}")
    n_train = min(max(int(round(train_fraction * n)), 2), n - 1)
    perm = np.random.default_rng(seed).permutation(n)
    return np.sort(perm[:n_train]), np.sort(perm[n_train:])


def r2_score(y_true: np.ndarray, y_pred: np.ndarray) -> np.ndarray:
    """Coefficient of determination per column. A constant column scores 1.0 if predicted exactly and
    0.0 otherwise (scikit-learn's ``force_finite`` convention), so the figure is always finite."""
    y_true, y_pred = np.atleast_2d(y_true.T).T, np.atleast_2d(y_pred.T).T
    ss_res = ((y_true - y_pred) ** 2).sum(axis=0)
    ss_tot = ((y_true - y_true.mean(axis=0)) ** 2).sum(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        r2 = 1.0 - ss_res / ss_tot
    return np.where(ss_tot > 0, r2, np.where(ss_res <= 0, 1.0, 0.0))


def rmse(y_true: np.ndarray, y_pred: np.ndarray) -> np.ndarray:
    return np.sqrt(((y_true - y_pred) ** 2).mean(axis=0))


def mae(y_true: np.ndarray, y_pred: np.ndarray) -> np.ndarray:
    return np.abs(y_true - y_pred).mean(axis=0)


def spearman(y_true: np.ndarray, y_pred: np.ndarray) -> np.ndarray:
    """Spearman's rank correlation per column (average ranks for ties); NaN where either column is
    constant or there are fewer than 2 rows (no order to compare)."""
    y_true, y_pred = np.atleast_2d(y_true.T).T, np.atleast_2d(y_pred.T).T
    if y_true.shape[0] < 2:
        return np.full(y_true.shape[1], np.nan)
    rt, rp = stats.rankdata(y_true, axis=0), stats.rankdata(y_pred, axis=0)
    rt, rp = rt - rt.mean(axis=0), rp - rp.mean(axis=0)
    den = np.sqrt((rt**2).sum(axis=0) * (rp**2).sum(axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, (rt * rp).sum(axis=0) / den, np.nan)


def coverage(y_true: np.ndarray, y_pred: np.ndarray, y_std: np.ndarray, k: float = 2.0) -> np.ndarray:
    """Share of rows per column with ``|y_true - y_pred| <= k * y_std`` (NaN with no rows). For a calibrated
    Gaussian predictive and ``k = 2`` it is about 0.95."""
    y_true, y_pred, y_std = (np.atleast_2d(np.asarray(a, dtype=float).T).T for a in (y_true, y_pred, y_std))
    if y_true.shape[0] == 0:
        return np.full(y_true.shape[1], np.nan)
    return np.mean(np.abs(y_true - y_pred) <= k * y_std, axis=0)


def objective_metrics(
    y_true: np.ndarray, y_pred: np.ndarray, y_std: np.ndarray | None = None
) -> dict[str, dict[str, float]]:
    """``{objective: {"r2", "rmse", "mae", "spearman"}}`` for (n, 11) arrays in ``OBJECTIVES`` order, plus
    ``coverage_2sigma`` (share of rows within ``y_pred +- 2 y_std``) when the predictive std is given.

    With no rows every figure is NaN (written as JSON null)."""
    y_true, y_pred = np.asarray(y_true, dtype=float), np.asarray(y_pred, dtype=float)
    if y_true.shape != y_pred.shape or y_true.ndim != 2 or y_true.shape[1] != len(OBJECTIVES):
        raise ValueError(f"metrics: expected two (n, {len(OBJECTIVES)}) arrays, got {y_true.shape} and {y_pred.shape}")
    if y_std is not None and np.shape(y_std) != y_true.shape:
        raise ValueError(f"metrics: expected the std as a {y_true.shape} array, got {np.shape(y_std)}")
    if len(y_true) == 0:
        nan = float("nan")
        out = {obj: {"r2": nan, "rmse": nan, "mae": nan, "spearman": nan} for obj in OBJECTIVES}
    else:
        r2, e, a = r2_score(y_true, y_pred), rmse(y_true, y_pred), mae(y_true, y_pred)
        rho = spearman(y_true, y_pred)
        out = {
            obj: {"r2": float(r2[k]), "rmse": float(e[k]), "mae": float(a[k]), "spearman": float(rho[k])}
            for k, obj in enumerate(OBJECTIVES)
        }
    if y_std is not None:
        cov = coverage(y_true, y_pred, y_std)
        for k, obj in enumerate(OBJECTIVES):
            out[obj]["coverage_2sigma"] = float(cov[k])
    return out


def load_surrogate(kind: str, models_dir: str | Path = "models"):
    """Load the fitted surrogate ``kind`` (``bnn`` or ``regression``) from ``models_dir``."""
    if kind not in MODEL_FILES:
        raise ValueError(f"surrogate: unknown model {kind!r} (use {' or '.join(MODEL_FILES)})")
    path = Path(models_dir) / MODEL_FILES[kind]
    if kind == "bnn":
        from hevlib.surrogates.bnn import BayesRegMLP  # torch only when needed

        return BayesRegMLP.load(path)
    from hevlib.surrogates.regression import LinearRegressions

    return LinearRegressions.load(path)


def prediction_table(surrogate, X: np.ndarray) -> pd.DataFrame:
    """The designs (``DESIGN_VARS`` columns) and the eleven predicted objectives, plus ``<key>_std`` columns
    (predictive standard deviation, same unit) for a surrogate that reports uncertainty (the BNN)."""
    if getattr(surrogate, "kind", None) == "bnn":
        mean, std = surrogate.predict(X, return_std=True)
    else:
        mean, std = surrogate.predict(X), None
    X = np.asarray(X, dtype=float).reshape(len(mean), len(DESIGN_VARS))
    cols = {v: X[:, j] for j, v in enumerate(DESIGN_VARS)}
    cols.update({o: mean[:, k] for k, o in enumerate(OBJECTIVES)})
    if std is not None:
        cols.update({f"{o}_std": std[:, k] for k, o in enumerate(OBJECTIVES)})
    return pd.DataFrame(cols)


def write_prediction_table(path: str | Path, table: pd.DataFrame) -> None:
    """Write a prediction table as CSV or Parquet (float64 schema), chosen by the file extension."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".parquet":
        write_parquet(path, table, schema=float_schema(list(table.columns)))
    elif suffix == ".csv":
        write_text(path, table.to_csv(index=False))
    else:
        raise ValueError(f"{path}: unsupported output format (use .csv or .parquet)")
