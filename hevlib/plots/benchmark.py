"""The benchmark's anytime plot: judged hypervolume against simulations, median and IQR over runs."""

from __future__ import annotations

import numpy as np

from hevlib.benchmark.runs import KIND
from hevlib.plots import plt

_STYLE = {
    "saea": {"ls": "-", "marker": "o"},
    "direct": {"ls": "--", "marker": "s"},
    "oracle": {"ls": ":", "marker": "^"},
}


def anytime_figure(scores, table: dict, ceiling: str) -> plt.Figure:
    """Median (line) and quartiles (band) of each source's archive hypervolume at each budget; the
    oracle's whole-run archive as a horizontal ceiling with its quartiles."""
    fig, ax = plt.subplots(figsize=(9.0, 5.5))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (source, per) in enumerate(sorted(table.items())):
        pts = sorted((int(k), v) for k, v in per.items() if k != "end")
        if not pts:
            continue
        x = np.array([p[0] for p in pts])
        med = np.array([p[1]["median"] for p in pts])
        lo, hi = np.array([p[1]["q1"] for p in pts]), np.array([p[1]["q3"] for p in pts])
        c = colours[i % len(colours)]
        style = _STYLE[KIND[source]]
        n = per[next(k for k in per if k != "end")]["n"]
        ax.plot(x, med, color=c, label=f"{source} ({KIND[source]}, {n} runs)", **style)
        ax.fill_between(x, lo, hi, color=c, alpha=0.15)
        if source == ceiling and "end" in per:
            e = per["end"]
            ax.axhline(e["median"], color=c, lw=1.0, ls=":")
            ax.axhspan(e["q1"], e["q3"], color=c, alpha=0.08)
            ax.annotate(
                f"{ceiling}, every simulation ({e['n_simulations']['median']:.0f}): {e['median']:.3g}",
                (x.min(), e["median"]),
                textcoords="offset points",
                xytext=(2, 4),
                fontsize=8,
                color=c,
            )
    ax.set_xscale("log")
    ax.set_xlabel("simulations (DOE included)")
    ax.set_ylabel("hypervolume of the screened archive (common normalisation)")
    ax.set_title("Equal-budget benchmark: median and interquartile range over runs")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    return fig


__all__ = ["anytime_figure"]
