"""Front figures: predicted against simulated objectives, and the objective distributions of a front."""

from __future__ import annotations

import numpy as np
import pandas as pd

from hevlib.design import OBJECTIVE_UNITS, OBJECTIVES
from hevlib.indicators import Normalisation, to_minimisation
from hevlib.plots import plt


def front_figure(table: pd.DataFrame, norm: Normalisation, *, title: str = "") -> plt.Figure:
    """Eleven parity panels (predicted vs simulated, +-1 std bars when the table has them, designs
    still non-dominated after re-simulation in colour) and one panel of the objective distributions
    (predicted and simulated, minimisation form, normalised by ``norm``: 0 = best, 1 = worst of the DOE).

    ``table`` is a ``data/pareto/<algo>.parquet`` table (``pred_<obj>``, ``sim_<obj>``, ``nondominated_sim``).
    """
    fig, axes = plt.subplots(3, 4, figsize=(16, 11))
    nd = table["nondominated_sim"].to_numpy(dtype=bool)
    for k, name in enumerate(OBJECTIVES):
        ax = axes.flat[k]
        p, s = table[f"pred_{name}"].to_numpy(float), table[f"sim_{name}"].to_numpy(float)
        std_col = f"pred_{name}_std"
        if std_col in table:
            ax.errorbar(s, p, yerr=table[std_col].to_numpy(float), fmt="none", ecolor="0.7", lw=0.6, zorder=1)
        ax.scatter(s[~nd], p[~nd], s=10, c="0.55", label="dominated after re-sim", zorder=2)
        ax.scatter(s[nd], p[nd], s=10, c="tab:blue", label="non-dominated after re-sim", zorder=3)
        finite = np.concatenate([p[np.isfinite(p)], s[np.isfinite(s)]])
        if finite.size:
            lo, hi = float(finite.min()), float(finite.max())
            ax.plot([lo, hi], [lo, hi], "k--", lw=0.8)
        ax.set_title(f"{name} [{OBJECTIVE_UNITS[name]}]", fontsize=10)
        ax.set_xlabel("simulated", fontsize=8)
        ax.set_ylabel("predicted", fontsize=8)
        ax.tick_params(labelsize=7)
    axes.flat[0].legend(fontsize=7, loc="best")

    ax = axes.flat[11]
    pred = norm(to_minimisation(table[[f"pred_{k}" for k in OBJECTIVES]].to_numpy(float)))
    sim = norm(to_minimisation(table[[f"sim_{k}" for k in OBJECTIVES]].to_numpy(float)))
    pos = np.arange(len(OBJECTIVES))
    for data, offset, colour, label in ((pred, -0.2, "tab:orange", "predicted"), (sim, 0.2, "tab:blue", "simulated")):
        cols = [c[np.isfinite(c)] for c in data.T]
        if all(len(c) for c in cols):
            bp = ax.boxplot(cols, positions=pos + offset, widths=0.35, patch_artist=True, showfliers=False)
            for box in bp["boxes"]:
                box.set_facecolor(colour)
            ax.plot([], [], color=colour, lw=6, label=label)
    ax.set_xticks(pos, OBJECTIVES, rotation=60, fontsize=7)
    ax.set_ylabel("normalised (0 best, 1 worst of DOE)", fontsize=8)
    ax.set_title("objective distributions", fontsize=10)
    ax.legend(fontsize=7)
    if title:
        fig.suptitle(title)
    return fig


__all__ = ["front_figure"]
