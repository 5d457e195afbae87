"""The fleet validation (``benchmarks/fleet``): predicted against measured fuel economy of EPA's tests."""

from __future__ import annotations

import numpy as np
import pandas as pd

from hevlib.plots import plt

MARKERS = {"conventional": "o", "power_split": "^"}
CATEGORY_COLOURS = {"FTP": "tab:blue", "HWY": "tab:orange", "US06": "tab:green"}


def predicted_vs_measured_figure(results: pd.DataFrame, peers: dict[str, str]) -> plt.Figure:
    """One panel per predictor (``peers``: column of predicted mpg -> title): every test's predicted against its
    measured unadjusted mpg, by test category (colour) and powertrain (marker), with the 1:1 line and +-10 %."""
    fig, axes = plt.subplots(1, len(peers), figsize=(6.0 * len(peers), 5.6), squeeze=False)
    top = float(np.nanmax(results[["measured_mpg", *peers]].to_numpy(dtype=float))) * 1.05
    for ax, (col, title) in zip(axes[0], peers.items(), strict=True):
        for (kind, cat), g in results.groupby(["powertrain", "category"]):
            ok = np.isfinite(g[col])
            ax.scatter(
                g.loc[ok, "measured_mpg"],
                g.loc[ok, col],
                s=14 if kind == "conventional" else 34,
                marker=MARKERS.get(kind, "s"),
                color=CATEGORY_COLOURS.get(cat, "grey"),
                alpha=0.55 if kind == "conventional" else 0.9,
                edgecolors="black" if kind != "conventional" else "none",
                linewidths=0.5,
                label=f"{cat}, {kind.replace('_', '-')} ({int(ok.sum())})",
            )
        x = np.array([0.0, top])
        ax.plot(x, x, color="black", lw=1.0)
        ax.fill_between(x, 0.9 * x, 1.1 * x, color="grey", alpha=0.15, lw=0, label="within 10 %")
        ax.set(xlim=(0, top), ylim=(0, top), xlabel="measured, unadjusted [mpg]", ylabel="predicted [mpg]", title=title)
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left")
    return fig
