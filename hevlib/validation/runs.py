"""Simulating the picks and both baselines on the validation cycles: the validation table (one row per vehicle
and cycle), its schema, the split of one cycle, the best pick, time traces and the cold-start window."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Protocol

import numpy as np
import pandas as pd
import pyarrow as pa

from hevlib.cycles import Cycle
from hevlib.design import (
    BOOL_RESPONSES,
    CHARGE_BALANCE_RESPONSES,
    DESIGN_VARS,
    RESPONSES,
    design_matrix,
    design_vector,
)
from hevlib.validation.improvement import BASELINE_ALGO, BASELINES


class RunsCycles(Protocol):
    def run(
        self,
        X: np.ndarray,
        cycle: Cycle,
        vehicle: str = "hybrid",
        batch_size: int = 1000,
        progress: Callable[[int, int], None] | None = None,
        charge_balanced: bool = False,
    ) -> pd.DataFrame: ...


# ---------------------------------------------------------------------------------- simulation
def load_cycles(names: Sequence[str], known: Sequence[str], cycles_dir: str | Path) -> list[Cycle]:
    """The validation cycles from ``<cycles_dir>/<name>.parquet``; unknown names fail naming the key."""
    for name in names:
        if name not in known:
            raise ValueError(f"params.yaml: validate.cycles: {name!r} is not one of cycles.cycles")
    return [Cycle.from_parquet(Path(cycles_dir) / f"{name}.parquet", name=name) for name in names]


def cycle_notes(cycles: Sequence[Cycle]) -> list[str]:
    """Report lines for validation cycles that carry a road grade (validation is meant on a flat road)."""
    return [
        f"validation cycle {c.name} carries a mean road grade of {100 * float(np.mean(c.grade)):.1f} %"
        for c in cycles
        if np.any(c.grade != 0)
    ]


def prius_design(prius) -> np.ndarray:
    """The stock Prius as a (7,) design vector (``params.baseline.prius``)."""
    return design_vector(prius)


#: The validation table's response columns: every response and the charge-balanced fuel with its runs.
VALIDATION_RESPONSES: tuple[str, ...] = RESPONSES + CHARGE_BALANCE_RESPONSES


def responses_of(df: pd.DataFrame, n: int, what: str) -> pd.DataFrame:
    missing = [c for c in VALIDATION_RESPONSES if c not in df.columns]
    if missing:
        raise ValueError(f"simulator result for {what}: missing response column(s) {', '.join(missing)}")
    if len(df) != n:
        raise ValueError(f"simulator result for {what}: expected {n} row(s), got {len(df)}")
    return df[list(VALIDATION_RESPONSES)].reset_index(drop=True)


def validation_table(
    sim: RunsCycles, selected: pd.DataFrame, cycles: Sequence[Cycle], prius_x: np.ndarray, *, batch_size: int = 1000
) -> pd.DataFrame:
    """Simulate the picks and both baselines on every cycle: one row per vehicle and cycle.

    Columns: ``vehicle`` (the design id, ``conventional`` or ``prius``), ``algo`` (``baseline`` for the
    baselines), ``cycle``, the seven variables (NaN for the conventional car, the stock values for the
    Prius), then every column of :data:`hevlib.design.RESPONSES`.
    """
    X = design_matrix(selected, what="selected designs")
    prius_x = np.asarray(prius_x, dtype=float)
    parts = []
    for cycle in cycles:
        blocks = []
        if len(X):
            res = responses_of(
                sim.run(X, cycle, vehicle="hybrid", batch_size=batch_size, charge_balanced=True),
                len(X),
                f"the picked designs on {cycle.name}",
            )
            ids = pd.DataFrame(
                {
                    "vehicle": selected["design_id"].astype(str).to_numpy(),
                    "algo": selected["algo"].astype(str).to_numpy(),
                }
            )
            blocks.append(pd.concat([ids, pd.DataFrame(X, columns=list(DESIGN_VARS)), res], axis=1))
        for vehicle in BASELINES:
            res = responses_of(
                sim.run(prius_x[None, :], cycle, vehicle=vehicle, charge_balanced=True), 1, f"{vehicle} on {cycle.name}"
            )
            x = prius_x if vehicle == "prius" else np.full(len(DESIGN_VARS), np.nan)
            ids = pd.DataFrame({"vehicle": [vehicle], "algo": [BASELINE_ALGO]})
            blocks.append(pd.concat([ids, pd.DataFrame(x[None, :], columns=list(DESIGN_VARS)), res], axis=1))
        part = pd.concat(blocks, ignore_index=True)
        part.insert(2, "cycle", cycle.name)
        parts.append(part)
    table = pd.concat(parts, ignore_index=True)
    for flag in BOOL_RESPONSES:
        table[flag] = table[flag].astype(bool)
    return table


def validation_schema() -> pa.Schema:
    """Explicit schema of ``reports/validation.parquet``."""
    fields = [
        pa.field("vehicle", pa.string(), nullable=False),
        pa.field("algo", pa.string(), nullable=False),
        pa.field("cycle", pa.string(), nullable=False),
    ]
    fields += [pa.field(v, pa.float64()) for v in DESIGN_VARS]
    fields += [pa.field(r, pa.bool_() if r in BOOL_RESPONSES else pa.float64()) for r in VALIDATION_RESPONSES]
    return pa.schema(fields)


def split_cycle(table: pd.DataFrame, cycle: str) -> tuple[pd.DataFrame, dict[str, pd.Series]]:
    """(picked-design rows, {baseline: row}) of one cycle of the validation table."""
    rows = table[table["cycle"] == cycle]
    designs = rows[rows["algo"] != BASELINE_ALGO].reset_index(drop=True)
    baselines = {}
    for name in BASELINES:
        hit = rows[rows["vehicle"] == name]
        if len(hit) != 1:
            raise ValueError(f"validation table: expected one {name!r} row on cycle {cycle!r}, got {len(hit)}")
        baselines[name] = hit.iloc[0]
    return designs, baselines


def best_design(table: pd.DataFrame, cycle: str) -> str | None:
    """The pick with the lowest SOC-corrected fuel consumption on ``cycle`` among those that met it
    (all picks when none did); None without picks."""
    designs, _ = split_cycle(table, cycle)
    if designs.empty:
        return None
    pool = designs[designs["cycle_met"]] if designs["cycle_met"].any() else designs
    fc = pool["fc_soc_corrected"].to_numpy(dtype=float)
    if not np.isfinite(fc).any():
        return str(pool["vehicle"].iloc[0])
    return str(pool["vehicle"].iloc[int(np.nanargmin(fc))])


def traces(
    sim, selected: pd.DataFrame, design_id: str, cycle: Cycle, prius_x: np.ndarray
) -> dict[str, pd.DataFrame] | None:
    """Time traces of one picked design and both baselines on ``cycle`` (``sim.trace``), keyed by vehicle;
    None when the simulator offers no traces."""
    trace = getattr(sim, "trace", None)
    if trace is None:
        return None
    row = selected[selected["design_id"].astype(str) == design_id]
    if len(row) != 1:
        raise ValueError(f"selected designs: no single design {design_id!r}")
    prius_x = np.asarray(prius_x, dtype=float)[None, :]
    out = {design_id: trace(design_matrix(row), cycle, "hybrid")}
    for vehicle in BASELINES:
        out[vehicle] = trace(prius_x, cycle, vehicle)
    return out


#: FTP bag 1 (the cold-start phase), s: the catalyst plot's window on a cycle with a key-off soak.
FTP_BAG1_S = 505.0


def cold_start_window_s(sim, cycle: Cycle, traces: dict[str, pd.DataFrame] | None) -> float | None:
    """Seconds of ``cycle`` the catalyst warm-up plot shows: FTP's bag 1 (505 s, before its key-off soak)
    or the whole cycle; None when the cycle does not start cold or the traces carry no temperatures."""
    if not traces or "t_cat_c" not in next(iter(traces.values())):
        return None
    if sim.start_state(cycle) != "cold":
        return None
    off = np.flatnonzero(~cycle.key_on[1:])
    return FTP_BAG1_S if len(off) and cycle.time_s[1:][off[0]] > FTP_BAG1_S else float(cycle.duration_s)
