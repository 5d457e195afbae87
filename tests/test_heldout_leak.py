"""Issue 24 and 38: `hev optimise` with the held-out set and the judged scale on disk never lets either
reach a surrogate.

The stage reads the judged scale's reference set to build the judged normalisation (scoring only). A spy
replaces ``hevlib.surrogates.fit_surrogate``: it records every training set and wraps the fitted model so
that every array any of its methods is given (``predict``, ``predict_std``, or a calibration a future
change might add) is recorded too. No held-out design or held-out objective row may appear anywhere, and
every training row must be one of the source's own simulations (its archive, the DOE included)."""

from __future__ import annotations

import shutil

import numpy as np
import pandas as pd
import pytest
import yaml
from typer.testing import CliRunner

from hevlib.design import DESIGN_VARS, OBJECTIVES
from stages.cli import app

JUDGE = "data/judge/reference.parquet"

TINY = {
    "doe": {"method": "l27"},
    "surrogate": {"heldout": {"n": 12}, "bnn": {"max_epochs": 20, "restarts": 1}},
    "optimise": {
        "hv_samples": 2000,
        "oracle": {"pop_size": 12, "n_gen": 2},
        "judge": {"n": 300},
        "bayes": {"parego": {"budget": 32, "batch": 5, "raw_samples": 16, "num_restarts": 1, "mc_samples": 8}},
        "algorithms": {"nsga3": {"pop_size": 12, "n_gen": 3}},
        "infill": {"rounds": 1, "designs_per_round": 6, "n_gen": 2},
    },
}


def _merge(base: dict, over: dict) -> dict:
    for k, v in over.items():
        base[k] = _merge(base.get(k, {}), v) if isinstance(v, dict) else v
    return base


class _Spy:
    """Records every array handed to a fitted surrogate's methods."""

    def __init__(self, model, seen: list):
        self._model, self._seen = model, seen

    def __getattr__(self, name):
        attr = getattr(self._model, name)
        if not callable(attr):
            return attr

        def call(*args, **kwargs):
            self._seen.extend(
                np.asarray(a, dtype=float) for a in (*args, *kwargs.values()) if isinstance(a, np.ndarray)
            )
            return attr(*args, **kwargs)

        return call


def _rows_in(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """For each row of A, whether it equals some row of B (exactly)."""
    keys = {row.tobytes() for row in np.ascontiguousarray(B, dtype=float)}
    return np.array([row.tobytes() in keys for row in np.ascontiguousarray(A, dtype=float)], dtype=bool)


@pytest.mark.slow
def test_optimise_never_lets_the_held_out_set_reach_a_fit(root, tmp_path, monkeypatch):
    shutil.copytree(root / "data" / "raw", tmp_path / "data" / "raw")
    params = _merge(yaml.safe_load((root / "params.yaml").read_text()), TINY)
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(params, sort_keys=False))
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    for cmd in (["cycles"], ["components"], ["doe"], ["heldout"], ["judge"], ["optimise", "oracle"]):
        result = runner.invoke(app, cmd)
        assert result.exit_code == 0, result.output

    import hevlib.surrogates as surrogates

    fits, calls = [], []
    real = surrogates.fit_surrogate

    def spy(kind, X, Y, params, space):
        fits.append((np.array(X, dtype=float), np.array(Y, dtype=float)))
        return _Spy(real(kind, X, Y, params, space), calls)

    monkeypatch.setattr(surrogates, "fit_surrogate", spy)
    result = runner.invoke(app, ["optimise", "nsga3"])
    assert result.exit_code == 0, result.output
    assert len(fits) == 2  # round 0 and one infill round

    unseen = pd.concat([pd.read_parquet(tmp_path / f) for f in ("data/doe/heldout.parquet", JUDGE)])
    X_h = unseen[list(DESIGN_VARS)].to_numpy(dtype=float)
    Y_h = unseen[list(OBJECTIVES)].to_numpy(dtype=float)
    archive = pd.read_parquet(tmp_path / "data/pareto/nsga3_archive.parquet")
    X_own = archive[list(DESIGN_VARS)].to_numpy(dtype=float)
    Y_own = archive[[f"sim_{k}" for k in OBJECTIVES]].to_numpy(dtype=float)
    for X, Y in fits:
        assert not _rows_in(X, X_h).any() and not _rows_in(Y, Y_h).any()
        assert _rows_in(X, X_own).all() and _rows_in(Y, Y_own).all()  # only its own simulations
    for A in calls:  # nothing of the held-out set reaches the model by any other door either
        if A.ndim == 2 and A.shape[1] == len(DESIGN_VARS):
            assert not _rows_in(A, X_h).any()
        if A.ndim == 2 and A.shape[1] == len(OBJECTIVES):
            assert not _rows_in(A, Y_h).any()
    assert calls  # the spy saw the search's predictions

    # the BoTorch source: every model it fits sees its own simulations only
    import hevlib.optimise.bayesopt as bayesopt

    bo_fits = []
    real_models = bayesopt.fit_models

    def spy_models(X, R, *args):
        bo_fits.append((np.array(X, dtype=float), R[list(OBJECTIVES)].to_numpy(dtype=float)))
        return real_models(X, R, *args)

    monkeypatch.setattr(bayesopt, "fit_models", spy_models)
    result = runner.invoke(app, ["optimise", "parego"])
    assert result.exit_code == 0, result.output
    archive = pd.read_parquet(tmp_path / "data/pareto/parego_archive.parquet")
    assert len(bo_fits) >= 1 and len(archive) == 32
    X_own = archive[list(DESIGN_VARS)].to_numpy(dtype=float)
    for X, Y in bo_fits:
        assert not _rows_in(X, X_h).any() and not _rows_in(Y, Y_h).any()
        assert _rows_in(X, X_own).all()
