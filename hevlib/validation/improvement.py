"""Validate the picked designs against the conventional car and the stock Prius (the study's Table 8).

:func:`validation_table` simulates every picked design and both baselines on each validation cycle
(one row per vehicle and cycle). :func:`improvement_table` turns one cycle of it into mean
improvements, '+' = better:

* minimised responses (mass, fuel, emissions): ``100 * (base - design) / |base|`` (%);
* maximised responses (``v_max``, ``f_max``, ``eta_drivetrain``): ``100 * (design - base) / |base|`` (%);
* ``diff_soc`` (SOC at start - SOC at end, minimised like the objective): ``100 * (base - design)``,
  an absolute difference in **SOC percentage points**, because a baseline's SOC difference can be
  near zero or negative and a percentage of it means nothing. Against the conventional car (no
  traction battery) it is not applicable and reported as null;
* a percentage whose base is zero or not finite is null, never a division by zero.

The mean over an algorithm's picks is the mean of the per-design improvements (the same as the
improvement of the mean design, the base being fixed); a design found by several algorithms counts
for each of them; ``"all"`` is every pick once. Engine downsizing is ``100 * (p_conv - mean p_eng_kw)
/ p_conv`` with ``p_conv`` the conventional car's engine power (70 kW).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from hevlib.design import (
    MAXIMISED_OBJECTIVES,
)
from hevlib.pareto import algo_names

#: Responses of the improvement table, in its row order.
IMPROVEMENT_RESPONSES: tuple[str, ...] = (
    "m_veh",
    "fc_charge_balanced",
    "fc",
    "fc_soc_corrected",
    "diff_soc",
    "hc",
    "co",
    "nox",
    "v_max",
    "f_max",
    "eta_drivetrain",
)
#: Responses where more is better: the maximised objectives (hevlib.design) and the drivetrain efficiency.
MAXIMISED = frozenset({*MAXIMISED_OBJECTIVES, "eta_drivetrain"})
#: Responses whose improvement is an absolute difference (SOC percentage points), not a percentage.
SOC_POINTS = frozenset({"diff_soc"})
BASELINES: tuple[str, ...] = ("conventional", "prius")
#: Baselines without a traction battery: SOC comparisons against them are not applicable.
NO_BATTERY = frozenset({"conventional"})
BASELINE_ALGO = "baseline"
ALL = "all"
_EPS = 1e-12


# ---------------------------------------------------------------------------------- improvement
def improvement(response: str, design, base: float, *, base_has_battery: bool = True) -> np.ndarray:
    """Per-design improvement over ``base`` for one response ('+' = better; module docstring for units)."""
    design = np.asarray(design, dtype=float)
    base = float(base)
    if response in SOC_POINTS:
        if not base_has_battery or not np.isfinite(base):
            return np.full(design.shape, np.nan)
        return 100.0 * (base - design)
    if not np.isfinite(base) or abs(base) < _EPS:
        return np.full(design.shape, np.nan)
    gain = design - base if response in MAXIMISED else base - design
    return 100.0 * gain / abs(base)


def mean_or_none(values: np.ndarray) -> float | None:
    values = values[np.isfinite(values)]
    return float(values.mean()) if values.size else None


def group_rows(vehicles: pd.DataFrame, algos: Sequence[str]) -> dict[str, np.ndarray]:
    """Masks of the design rows of each algorithm (a shared design counts for each) and of ``all``."""
    lists = [algo_names(a) for a in vehicles["algo"]]
    groups = {a: np.array([a in names for names in lists], dtype=bool) for a in algos}
    groups[ALL] = np.ones(len(vehicles), dtype=bool)
    return groups


def improvement_table(
    designs: pd.DataFrame,
    baselines: dict[str, pd.Series],
    algos: Sequence[str],
    responses: Sequence[str] = IMPROVEMENT_RESPONSES,
) -> dict:
    """``{algo|"all": {"vs_<baseline>": {response: mean improvement or None}}}`` for one cycle."""
    out = {}
    for group, mask in group_rows(designs, algos).items():
        out[group] = {}
        for name, base in baselines.items():
            has_batt = name not in NO_BATTERY
            out[group][f"vs_{name}"] = {
                r: mean_or_none(
                    improvement(r, designs.loc[mask, r].to_numpy(dtype=float), base[r], base_has_battery=has_batt)
                )
                for r in responses
            }
    return out


def engine_downsizing(designs: pd.DataFrame, algos: Sequence[str], p_conv_kw: float) -> dict[str, float | None]:
    """Mean engine power of each group's picks vs the conventional engine, in % ('+' = smaller)."""
    out = {}
    for group, mask in group_rows(designs, algos).items():
        p = designs.loc[mask, "p_eng_kw"].to_numpy(dtype=float)
        out[group] = float(100.0 * (p_conv_kw - p.mean()) / p_conv_kw) if p.size else None
    return out
