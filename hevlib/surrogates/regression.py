"""Linear regression surrogate: one ordinary-least-squares model per objective, the study's form.

``y_k = b0 + sum_j b_j x_j`` with the seven design variables in natural units (``DESIGN_VARS``
order), fitted by OLS. For every objective: coefficients, standard errors
``se = sqrt(s^2 diag((A^T A)^-1))`` with ``s^2 = RSS / (n - p)``, t statistics, two-sided p-values from
Student's t with ``n - p`` degrees of freedom (``scipy.stats.t``), R^2 and adjusted R^2. Saved as JSON.

The saved model (``models/regression.json``) is fitted on every DOE design, as the study fitted all 27 L27
runs (an orthogonal array loses its orthogonality when rows are left out); only the model that is judged
on the test split is fitted on the training rows (:mod:`hevlib.surrogates.evaluation`).

Non-negative objectives: a linear model extrapolates below zero over parts of the box (speed_dev, fc, hc,
accel_dev on the L27 fit). ``predict`` clips every objective to its physical range
(:data:`hevlib.surrogates.base.OBJECTIVE_BOUNDS`: all but ``diff_soc`` non-negative, ``speed_dev`` at most 1,
``accel_dev`` at most 100 %); the stored coefficients are the plain OLS ones, the study's form.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Self

import numpy as np
import pandas as pd
from scipy import stats

from hevlib.design import DESIGN_VARS, OBJECTIVES, DesignSpace
from hevlib.io import write_json
from hevlib.surrogates.base import (
    NotFittedError,
    check_designs,
    check_targets,
    clip_objectives,
    space_from_dict,
    space_to_dict,
)

FORMAT = "hev-regression-1"
TERMS: tuple[str, ...] = ("intercept",) + DESIGN_VARS


def ols(X: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray | float]:
    """OLS of the columns of ``y`` (n, m) on ``[1, X]``: coefficients and inference, arrays (p, m).

    Standard errors, t and p are NaN when there are no residual degrees of freedom (``n <= p``).
    """
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    n = X.shape[0]
    A = np.column_stack([np.ones(n), X])
    p = A.shape[1]
    if np.linalg.matrix_rank(A) < p:
        raise ValueError(
            f"regression: design matrix is rank deficient ({n} designs, {p} terms); "
            "a design variable is constant or collinear in the training set"
        )
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    resid = y - A @ coef
    rss = (resid**2).sum(axis=0)
    tss = ((y - y.mean(axis=0)) ** 2).sum(axis=0)
    df = n - p
    with np.errstate(divide="ignore", invalid="ignore"):
        r2 = np.where(tss > 0, 1.0 - rss / tss, np.where(rss <= 0, 1.0, 0.0))
        r2_adj = 1.0 - (1.0 - r2) * (n - 1) / df if df > 0 else np.full_like(r2, np.nan)
        s2 = rss / df if df > 0 else np.full_like(rss, np.nan)
        xtx_inv = np.linalg.inv(A.T @ A)
        se = np.sqrt(np.outer(np.diag(xtx_inv), s2))
        t = coef / se
        pval = 2.0 * stats.t.sf(np.abs(t), df) if df > 0 else np.full_like(t, np.nan)
    # a perfect fit (se = 0) is infinitely significant unless the coefficient is exactly zero
    pval = np.where((se == 0) & (coef != 0), 0.0, pval)
    return {"coef": coef, "se": se, "t": t, "p": pval, "r2": r2, "r2_adj": r2_adj, "df": df, "rmse_resid": np.sqrt(s2)}


class LinearRegressions:
    """One linear model per objective (``OBJECTIVES`` order), with the inference the study reports."""

    kind = "regression"

    def __init__(self, space: DesignSpace):
        self.space = space

    def fit(self, X: np.ndarray, Y: np.ndarray) -> Self:
        X = check_designs(self.space, X, what="regression training designs")
        Y = check_targets(Y, X.shape[0], what="regression training objectives")
        fit = ols(X, Y)
        self.coef_ = fit["coef"]  # (8, 11): intercept then DESIGN_VARS
        self.se_, self.t_, self.p_ = fit["se"], fit["t"], fit["p"]
        self.r2_, self.r2_adj_ = fit["r2"], fit["r2_adj"]
        self.df_resid_ = int(fit["df"])
        self.n_train_ = int(X.shape[0])
        return self

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Objectives (n, 11) in natural units, clipped to their physical range (module doc)."""
        self._check_fitted()
        X = check_designs(self.space, X)
        return clip_objectives(self.coef_[0] + X @ self.coef_[1:])

    def _check_fitted(self) -> None:
        if not hasattr(self, "coef_"):
            raise NotFittedError("regression surrogate is not fitted: call fit() or LinearRegressions.load()")

    # ----------------------------------------------------------------------------------- tables
    def coefficient_table(self) -> pd.DataFrame:
        """Long table: objective, term, coef, se, t, p (one row per objective and term)."""
        self._check_fitted()
        rows = [
            {
                "objective": obj,
                "term": term,
                "coef": self.coef_[i, k],
                "se": self.se_[i, k],
                "t": self.t_[i, k],
                "p": self.p_[i, k],
            }
            for k, obj in enumerate(OBJECTIVES)
            for i, term in enumerate(TERMS)
        ]
        return pd.DataFrame(rows)

    # ------------------------------------------------------------------------------ persistence
    def to_dict(self) -> dict:
        self._check_fitted()
        models = {}
        for k, obj in enumerate(OBJECTIVES):
            models[obj] = {
                "r2": self.r2_[k],
                "r2_adj": self.r2_adj_[k],
                "terms": {
                    term: {"coef": self.coef_[i, k], "se": self.se_[i, k], "t": self.t_[i, k], "p": self.p_[i, k]}
                    for i, term in enumerate(TERMS)
                },
            }
        return {
            "format": FORMAT,
            "form": "y = intercept + sum_j coef_j * x_j (natural units)",
            "design_vars": list(DESIGN_VARS),
            "space": space_to_dict(self.space),
            "n_train": self.n_train_,
            "df_resid": self.df_resid_,
            "models": models,
        }

    def save(self, path: str | Path) -> None:
        write_json(path, self.to_dict(), digits=None)  # a model: exact coefficients

    @classmethod
    def load(cls, path: str | Path) -> LinearRegressions:
        path = Path(path)
        if not path.exists():
            raise FileNotFoundError(f"{path}: no such regression model; run `hev surrogates` first")
        try:
            data = json.loads(path.read_text())
        except json.JSONDecodeError as err:
            raise ValueError(f"{path}: not valid JSON ({err.msg})") from None
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise ValueError(f"{path}: not a {FORMAT} model file")
        if tuple(data["design_vars"]) != DESIGN_VARS:
            raise ValueError(f"{path}: model was fitted on other design variables")
        missing = [o for o in OBJECTIVES if o not in data["models"]]
        if missing:
            raise ValueError(f"{path}: no model for objective(s) {', '.join(missing)}")
        model = cls(space_from_dict(data["space"]))

        def grid(key: str) -> np.ndarray:
            return np.array([[_num(data["models"][o]["terms"][t][key]) for o in OBJECTIVES] for t in TERMS])

        model.coef_, model.se_, model.t_, model.p_ = grid("coef"), grid("se"), grid("t"), grid("p")
        model.r2_ = np.array([_num(data["models"][o]["r2"]) for o in OBJECTIVES])
        model.r2_adj_ = np.array([_num(data["models"][o]["r2_adj"]) for o in OBJECTIVES])
        model.n_train_, model.df_resid_ = int(data["n_train"]), int(data["df_resid"])
        return model


def _num(v) -> float:
    return float("nan") if v is None else float(v)


# ------------------------------------------------------------------------------------ the study
def read_study_coefficients(path: str | Path = "data/raw/paper/regression_equations.csv") -> pd.DataFrame:
    """The study's regression coefficients: index = objective, columns = ``TERMS`` (+ ``r2_pct``)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: study regression equations missing")
    df = pd.read_csv(path)
    missing = [c for c in ("response",) + TERMS if c not in df.columns]
    if missing:
        raise ValueError(f"{path}: missing column(s) {', '.join(missing)}")
    unknown = sorted(set(df["response"]) - set(OBJECTIVES))
    if unknown:
        raise ValueError(f"{path}: unknown response(s) {', '.join(unknown)}")
    return df.set_index("response")


def compare_signs(model: LinearRegressions, study: pd.DataFrame, alpha: float = 0.05) -> pd.DataFrame:
    """Sign of each of our slope coefficients against the study's (the intercept depends on units, so
    it is left out).

    Columns: objective, term, coef_ours, p_ours, significant (p < ``alpha``), coef_study, sign_ours,
    sign_study (-1, 0, +1), agree (True / False; missing where the study's coefficient is 0 or absent).
    """
    table = model.coefficient_table()
    table = table[table["term"] != "intercept"].reset_index(drop=True)
    rows = []
    for rec in table.itertuples(index=False):
        c_study = float(study.loc[rec.objective, rec.term]) if rec.objective in study.index else float("nan")
        s_ours, s_study = int(np.sign(rec.coef)), (int(np.sign(c_study)) if np.isfinite(c_study) else 0)
        rows.append(
            {
                "objective": rec.objective,
                "term": rec.term,
                "coef_ours": rec.coef,
                "p_ours": rec.p,
                "significant": bool(np.isfinite(rec.p) and rec.p < alpha),
                "coef_study": c_study,
                "sign_ours": s_ours,
                "sign_study": s_study,
                "agree": (s_ours == s_study) if s_study != 0 else None,
            }
        )
    return pd.DataFrame(rows)


def sign_summary(signs: pd.DataFrame) -> dict[str, dict[str, int]]:
    """Per objective: coefficients compared (study non-zero), agreeing, and agreeing among significant."""
    out: dict[str, dict[str, int]] = {}
    for obj in OBJECTIVES:
        s = signs[(signs["objective"] == obj) & signs["agree"].notna()]
        sig = s[s["significant"]]
        out[obj] = {
            "compared": len(s),
            "agree": int(s["agree"].astype(bool).sum()),
            "significant": len(sig),
            "significant_agree": int(sig["agree"].astype(bool).sum()),
        }
    return out


def signs_markdown(signs: pd.DataFrame) -> str:
    """The sign comparison as a Markdown table: objective rows, term columns, ``ours/study`` signs."""
    sym = {-1: "-", 0: "0", 1: "+"}
    lines = ["| objective | " + " | ".join(DESIGN_VARS) + " | agree |", "|---|" + "---|" * (len(DESIGN_VARS) + 1)]
    for obj in OBJECTIVES:
        s = signs[signs["objective"] == obj].set_index("term")
        cells = []
        for term in DESIGN_VARS:
            r = s.loc[term]
            mark = "" if r["agree"] is None else (" ok" if r["agree"] else " **x**")
            star = "*" if r["significant"] else ""
            cells.append(f"{sym[int(r['sign_ours'])]}{star}/{sym[int(r['sign_study'])]}{mark}")
        cmp = s["agree"].dropna()
        lines.append(f"| {obj} | " + " | ".join(cells) + f" | {int(cmp.astype(bool).sum())}/{len(cmp)} |")
    lines.append("")
    lines.append(
        "Cells: our sign (`*` = p < 0.05) / the study's sign; `x` marks a disagreement, "
        "no mark where the study's coefficient is 0."
    )
    return "\n".join(lines) + "\n"
