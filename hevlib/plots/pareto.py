"""Figures and plot data of the kept designs: objective trade-offs by algorithm, distributions."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from hevlib.design import OBJECTIVE_UNITS, OBJECTIVES
from hevlib.pareto import algo_names
from hevlib.plots import plt
from hevlib.screen import SIM

#: Objective pairs (x, y) of the trade-off figure, as in the study.
TRADEOFF_PAIRS: tuple[tuple[str, str], ...] = (
    ("diff_soc", "fc"),
    ("co", "hc"),
    ("nox", "co"),
    ("f_max", "v_max"),
    ("speed_dev", "m_veh"),
    ("accel_dev", "e_l"),
)
SHARED = "shared"


def _label(key: str) -> str:
    unit = OBJECTIVE_UNITS.get(key, "")
    return f"{key} [{unit}]" if unit and unit != "-" else key


def _colour_groups(kept: pd.DataFrame, algos: Sequence[str]) -> dict[str, np.ndarray]:
    """Masks per algorithm for designs only it found, plus one for designs several algorithms found."""
    names = [algo_names(a) for a in kept["algo"]]
    groups = {a: np.array([n == [a] for n in names], dtype=bool) for a in algos}
    shared = np.array([len(n) > 1 for n in names], dtype=bool)
    if shared.any():
        groups[SHARED] = shared
    return groups


def tradeoffs_figure(
    kept: pd.DataFrame, algos: Sequence[str], pairs: Sequence[tuple[str, str]] = TRADEOFF_PAIRS
) -> plt.Figure:
    """Scatter of simulated objectives in pairs for the kept designs, coloured by algorithm;
    picked designs (``picked`` column) are ringed."""
    ncol = 3
    nrow = int(np.ceil(len(pairs) / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.6 * nrow), squeeze=False)
    groups = _colour_groups(kept, algos)
    picked = kept["picked"].to_numpy(dtype=bool) if "picked" in kept else np.zeros(len(kept), dtype=bool)
    for ax, (x, y) in zip(axes.flat, pairs, strict=False):
        for name, mask in groups.items():
            ax.scatter(kept.loc[mask, f"{SIM}{x}"], kept.loc[mask, f"{SIM}{y}"], s=18, alpha=0.75, label=name)
        if picked.any():
            ax.scatter(
                kept.loc[picked, f"{SIM}{x}"],
                kept.loc[picked, f"{SIM}{y}"],
                s=60,
                facecolors="none",
                edgecolors="k",
                linewidths=0.9,
                label="picked",
            )
        ax.set_xlabel(_label(x))
        ax.set_ylabel(_label(y))
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(pairs) :]:
        ax.set_visible(False)
    if len(kept):
        axes.flat[0].legend(fontsize=7, loc="best")
    fig.suptitle(f"Kept designs ({len(kept)}): simulated objectives on the sizing cycle")
    return fig


def distributions_figure(
    kept: pd.DataFrame, algos: Sequence[str], objectives: Sequence[str] = OBJECTIVES
) -> plt.Figure:
    """One histogram per objective of the kept designs, stacked by algorithm (shared designs apart)."""
    ncol = 4
    nrow = int(np.ceil(len(objectives) / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.4 * ncol, 2.7 * nrow), squeeze=False)
    groups = _colour_groups(kept, algos)
    for ax, key in zip(axes.flat, objectives, strict=False):
        data = [kept.loc[m, f"{SIM}{key}"].to_numpy(dtype=float) for m in groups.values()]
        allv = np.concatenate(data) if data else np.zeros(0)
        allv = allv[np.isfinite(allv)]
        if allv.size:
            lo, hi = float(allv.min()), float(allv.max())
            bins = np.linspace(lo, hi if hi > lo else lo + 1e-9, 16)
            ax.hist([d[np.isfinite(d)] for d in data], bins=bins, stacked=True, label=list(groups))
        ax.set_xlabel(_label(key))
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(objectives) :]:
        ax.set_visible(False)
    axes.flat[0].set_ylabel("designs")
    if len(kept):
        axes.flat[0].legend(fontsize=7)
    fig.suptitle("Kept designs: distribution of each simulated objective")
    return fig


def tradeoff_data(kept: pd.DataFrame, algo: str, objectives: Sequence[str] = OBJECTIVES) -> pd.DataFrame:
    """Plot data for ``dvc plots``: the kept designs ``algo`` found (alone or with others), one column
    per objective (plain names, sizing-cycle units) plus ``design_id`` and ``picked``."""
    mask = np.array([algo in algo_names(a) for a in kept["algo"]], dtype=bool)
    rows = kept.loc[mask]
    out = pd.DataFrame(
        {
            "design_id": rows["design_id"].astype(str).to_numpy(),
            "picked": rows["picked"].astype(int).to_numpy() if "picked" in rows else 0,
        }
    )
    for key in objectives:
        out[key] = rows[f"{SIM}{key}"].to_numpy(dtype=float)
    return out


__all__ = ["TRADEOFF_PAIRS", "tradeoffs_figure", "distributions_figure", "tradeoff_data"]


def infill_figure(rounds: dict[str, list[dict]]) -> plt.Figure:
    """Archive hypervolume ratio to the oracle's archive against simulations used, one line per
    surrogate-assisted source (one marker per round), the oracle as the line at 1."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for name, entries in rounds.items():
        pts = [
            (e["n_simulations"], e["hv_ratio_to_oracle"]) for e in entries if e.get("hv_ratio_to_oracle") is not None
        ]
        if pts:
            x, y = zip(*pts, strict=True)
            ax.plot(x, y, marker="o", label=name)
    ax.axhline(1.0, color="k", linestyle="--", label="oracle (simulator in the loop)")
    ax.set_xscale("log")
    ax.set_xlabel("simulations used (DOE included)")
    ax.set_ylabel("archive hypervolume / oracle's archive")
    ax.set_title("Surrogate-assisted search with infill against the oracle")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
