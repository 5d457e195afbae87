"""The controller's gap (``hev bound``): the rule base's fuel against the bound, and how each spends the battery."""

from __future__ import annotations

import numpy as np
import pandas as pd

from hevlib.plots import plt


def gap_figure(table: pd.DataFrame) -> plt.Figure:
    """One panel per cycle: each vehicle's fuel under its controller (hot map, SOC-corrected), under ECMS in the drive
    step and on the bound's model, and at its bound, the rule base's gap written beside it ("no bound" where there
    is none)."""
    cycles = list(dict.fromkeys(table["cycle"]))
    n = table["vehicle"].nunique()
    fig, axes = plt.subplots(1, len(cycles), figsize=(5.6 * len(cycles), 0.55 * n + 2.0), squeeze=False)
    bars = (
        ("rule_fc_hot", 0.3, "tab:orange", "its controller: the rule base (Table 2); gears: the shift logic"),
        ("ecms_drive_fc_hot", 0.1, "tab:purple", "ECMS in the drive step (pms.strategy: ecms)"),
        ("ecms_fc", -0.1, "tab:green", "ECMS on the bound's candidates (power-split cars)"),
        ("bound_fc", -0.3, "tab:blue", "its bound: DP over SOC; gears: the best on each step"),
    )
    for ax, cname in zip(axes[0], cycles, strict=True):
        rows = table[table["cycle"] == cname].reset_index(drop=True)
        y = np.arange(len(rows))
        for col, dy, color, label in bars:
            ax.barh(y + dy, rows[col].fillna(0.0), height=0.19, color=color, label=label)
        top = float(np.nanmax(rows["rule_fc_hot"]))
        for i, r in rows.iterrows():
            text = f"{r['gap_pct']:+.1f} %" if np.isfinite(r["gap_pct"]) else "no bound"
            ax.text(top * 1.02, i, text, va="center", fontsize=7)
        ax.set_yticks(y, list(rows["vehicle"]), fontsize=7)
        ax.invert_yaxis()
        ax.set(xlim=(0, top * 1.25), xlabel="fuel, SOC-corrected, hot map [L/100 km]", title=cname)
        ax.grid(axis="x", alpha=0.3)
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=1)
    return fig


#: Each controller's line in :func:`soc_figure` (a :data:`hevlib.controller_gap.SOC_COLUMNS` column: label, colour).
SOC_LINES = {
    "soc_rule": ("rule base", "tab:orange"),
    "soc_ecms_drive": ("ECMS in the drive step", "tab:purple"),
    "soc_bound": ("bound", "tab:blue"),
}


def soc_figure(soc: pd.DataFrame, title: str) -> plt.Figure:
    """The battery's SOC along the cycle under each controller (one vehicle's rows of ``data/bound/soc.parquet``),
    each from the start its fuel figure comes from; a controller without a run there is left out."""
    fig, ax = plt.subplots(figsize=(9.0, 3.4))
    for col, (label, color) in SOC_LINES.items():
        if soc[col].notna().any():
            ax.plot(soc["time_s"], soc[col], color=color, lw=1.0, label=label)
    ax.set(xlabel="time [s]", ylabel="SOC [-]", title=title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig
