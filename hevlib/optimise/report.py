"""Reports of an optimiser run: hypervolume settings, surrogate error, the report and wall times."""

from __future__ import annotations

import numpy as np
import pandas as pd

from hevlib.design import OBJECTIVES
from hevlib.judging import HvSettings, spread
from hevlib.optimise.algorithms import Front
from hevlib.params import AlgoParams, BayesParams


def surrogate_error(pred: np.ndarray, sim: np.ndarray, span: np.ndarray | None = None) -> dict[str, dict]:
    """Per objective over rows with a finite simulated value: mae, rmse, r2, bias (mean pred - sim) and,
    with ``span``, nrmse = rmse / span (comparable across objectives)."""
    out = {}
    for k, name in enumerate(OBJECTIVES):
        ok = np.isfinite(sim[:, k]) & np.isfinite(pred[:, k])
        p, s = pred[ok, k], sim[ok, k]
        if len(s) == 0:
            out[name] = {"mae": None, "rmse": None, "r2": None, "bias": None}
            continue
        e = p - s
        ss_tot = float(np.sum((s - s.mean()) ** 2))
        rmse = float(np.sqrt(np.mean(e**2)))
        out[name] = {
            "mae": float(np.mean(np.abs(e))),
            "rmse": rmse,
            "r2": 1.0 - float(np.sum(e**2)) / ss_tot if ss_tot > 0 else None,
            "bias": float(np.mean(e)),
        }
        if span is not None:
            out[name]["nrmse"] = rmse / float(span[k])
    return out


def front_report(
    front: Front, table: pd.DataFrame, hv: HvSettings, *, settings: AlgoParams | BayesParams, n_misleading: int = 3
) -> dict:
    """``reports/optimise_<algo>.json``: the figures of the issue's contract plus the settings used.

    Deterministic (a DVC metric: the same inputs give the same bytes); wall times are not in it but in
    :func:`runtimes`."""
    sim_Y = table[[f"sim_{k}" for k in OBJECTIVES]].to_numpy(dtype=float)
    pred_Y = table[[f"pred_{k}" for k in OBJECTIVES]].to_numpy(dtype=float)
    finite = np.all(np.isfinite(sim_Y), axis=1)
    hv_sim, n_counted = hv.of(table)
    pred_table = table.assign(**{f"sim_{k}": table[f"pred_{k}"] for k in OBJECTIVES})
    hv_pred, _ = hv.of(pred_table)  # the same designs as the surrogate saw them
    errors = surrogate_error(pred_Y, sim_Y, hv.norm.span)
    ranked = sorted((k for k in OBJECTIVES if errors[k].get("nrmse") is not None), key=lambda k: -errors[k]["nrmse"])
    n = len(table)
    return {
        "algo": front.algo,
        "surrogate": getattr(settings, "surrogate", None),
        "front_size": n,
        "n_evaluations": front.n_evaluations,
        "n_candidates": front.n_candidates,
        "n_infeasible_dropped": front.n_infeasible,
        "n_sim_failed": int(n - np.count_nonzero(finite)),
        "hypervolume": hv_sim.value,
        "hypervolume_se": hv_sim.se,
        "hypervolume_method": hv_sim.method,
        "hypervolume_points": hv_sim.n_points,
        "hypervolume_designs": n_counted,
        "hypervolume_pred": hv_pred.value,
        "hypervolume_pred_se": hv_pred.se,
        "hypervolume_pred_method": hv_pred.method,
        "share_nondominated_after_resim": float(table["nondominated_sim"].mean()) if n else None,
        "share_feasible": float(table["feasible"].mean()) if n else None,
        "share_cycle_met": float(table["sim_cycle_met"].mean()) if n else None,
        "surrogate_error": errors,
        "surrogate_misleads_most": ranked[:n_misleading],
        "hypervolume_settings": hv.describe(),
        "spread": spread(table, hv.norm),
        "settings": {**settings.model_dump(), **front.settings},
    }


def runtimes(front: Front, resim_runtime_s: float) -> dict:
    """Wall times of one optimise run (s): machine-dependent, so kept out of the metrics report."""
    return {
        "algo": front.algo,
        "runtime_s": front.runtime_s,
        "runtime_resim_s": resim_runtime_s,
        "runtime_total_s": front.runtime_s + resim_runtime_s,
    }
