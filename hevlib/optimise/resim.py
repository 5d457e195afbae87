"""Re-simulation of a front with the true model, and its table (``data/pareto/<source>.parquet``)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
import pandas as pd
import pyarrow as pa

from hevlib.design import BOOL_RESPONSES, DESIGN_VARS, INTEGER_MASK, OBJECTIVES, RESPONSES
from hevlib.indicators import nondominated_mask, to_minimisation
from hevlib.optimise.algorithms import Front
from hevlib.optimise.problem import HevProblem


def resimulate(X: np.ndarray, simulate: Callable[[np.ndarray], pd.DataFrame]) -> pd.DataFrame:
    """Simulate designs ``X`` with the true model; ``simulate`` returns one row per design with RESPONSES."""
    sim = simulate(np.asarray(X, dtype=float))
    if len(sim) != len(X):
        raise ValueError(f"simulator: returned {len(sim)} rows for {len(X)} designs")
    missing = [c for c in RESPONSES if c not in sim.columns]
    if missing:
        raise ValueError(f"simulator: missing response column(s) {', '.join(missing)}")
    return sim.reset_index(drop=True)


def front_schema(with_std: bool) -> pa.Schema:
    """``data/pareto/<algo>.parquet``: design, pred_/pred_*_std/sim_ objectives, exact mass, flags."""
    fields = [
        pa.field(v, pa.int64() if m else pa.float64(), nullable=False)
        for v, m in zip(DESIGN_VARS, INTEGER_MASK, strict=True)
    ]
    fields += [pa.field(f"pred_{k}", pa.float64()) for k in OBJECTIVES]
    if with_std:
        fields += [pa.field(f"pred_{k}_std", pa.float64()) for k in OBJECTIVES]
    fields += [pa.field(f"sim_{k}", pa.bool_() if k in BOOL_RESPONSES else pa.float64()) for k in RESPONSES]
    fields += [
        pa.field("m_veh_exact_kg", pa.float64()),
        pa.field("feasible", pa.bool_()),
        pa.field("nondominated_sim", pa.bool_()),
    ]
    return pa.schema(fields)


def front_table(front: Front, sim: pd.DataFrame, problem: HevProblem, dominance: bool = True) -> pd.DataFrame:
    """One row per front design: variables, predicted (and std), simulated, exact mass, flags.

    ``feasible``: every constraint of ``problem`` met as the optimiser saw it (exact mass, exact power
    ratio, predicted speed deviation; true for every row of a :class:`Front`);
    ``nondominated_sim``: not dominated within this front by the simulated objectives (minimisation
    form); a design with a non-finite simulated objective is never non-dominated. Left out with
    ``dominance=False``, for a caller that judges dominance itself on a subset (:func:`archive_front` on
    an archive's screen-passing designs).
    """
    cols: dict[str, np.ndarray] = {}
    for j, v in enumerate(DESIGN_VARS):
        cols[v] = np.round(front.X[:, j]).astype(np.int64) if INTEGER_MASK[j] else front.X[:, j]
    for k, name in enumerate(OBJECTIVES):
        cols[f"pred_{name}"] = front.F[:, k]
    if front.std is not None:
        for k, name in enumerate(OBJECTIVES):
            cols[f"pred_{name}_std"] = front.std[:, k]
    for name in RESPONSES:
        cols[f"sim_{name}"] = sim[name].to_numpy(dtype=bool if name in BOOL_RESPONSES else float)
    G = problem.constraint(front.X, front.F) if len(front) else np.zeros((0, problem.n_ieq_constr))
    cols["m_veh_exact_kg"] = (G[:, 0] + 1.0) * problem.m_veh_max_kg
    cols["feasible"] = np.all(G <= 0.0, axis=1)
    if dominance:
        Fs = to_minimisation(sim[list(OBJECTIVES)].to_numpy(dtype=float)) if len(front) else np.zeros((0, 11))
        cols["nondominated_sim"] = nondominated_mask(Fs)
    return pd.DataFrame(cols)


def drop_stalled(front: Front, sim: pd.DataFrame) -> tuple[Front, pd.DataFrame, int]:
    """The front without the designs the true model finds stalled (infeasible whatever the surrogate
    predicted), the re-simulated rows to match, and how many were dropped."""
    if not len(front):
        return front, sim, 0
    keep = ~sim["stalled"].to_numpy(dtype=bool)
    if keep.all():
        return front, sim, 0
    std = front.std[keep] if front.std is not None else None
    kept = dataclasses.replace(front, X=front.X[keep], F=front.F[keep], std=std)
    return kept, sim[keep].reset_index(drop=True), int(np.count_nonzero(~keep))
