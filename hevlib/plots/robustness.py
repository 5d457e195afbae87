"""The answer's seed spread (``hev robustness report``): each replicate's recommended design over the seven
variables (normalised to the design box) and its headline figures."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from hevlib.design import DESIGN_VARS
from hevlib.plots import plt


def seed_spread_figure(summary: Mapping, lower: np.ndarray, upper: np.ndarray) -> plt.Figure:
    """Left: the recommended design of every replicate as a line over the normalised variables (replicate 0, the
    params' own seeds, in black; the default answer's family and equivalents solid, the others dashed). Right:
    each replicate's charge-balanced fuel saving of the recommended design and of the mean pick."""
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12.0, 4.8), gridspec_kw={"width_ratios": [1.6, 1.0]})
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    span = np.asarray(upper, dtype=float) - np.asarray(lower, dtype=float)
    pos = np.arange(len(DESIGN_VARS))
    for d in summary["recommended"]:
        x = (np.array([d["design"][v] for v in DESIGN_VARS]) - lower) / span
        k = d["replicate"]
        colour = "black" if k == 0 else colours[k % len(colours)]
        ax.plot(
            pos,
            x,
            color=colour,
            lw=2.4 if k == 0 else 1.4,
            ls="-" if d["default_answer"] else "--",
            marker="o",
            label=f"rep {k}: {d['design_id']} ({d['default_answer_as'] or 'another answer'})",
        )
    ax.set_xticks(pos, DESIGN_VARS, rotation=20)
    ax.set_ylim(-0.05, 1.05)
    ax.set_ylabel("share of the design box")
    ax.set_title("recommended design per replicate (solid: the default answer, to the family)")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    reps = [r["replicate"] for r in summary["runs"]]
    for key, marker, label in (("rec_fc_cb_pct", "*", "recommended design"), ("fc_cb_pct", "o", "mean of the picks")):
        vals = [r["answer"].get(key) for r in summary["runs"]]
        bx.plot(reps, [np.nan if v is None else v for v in vals], marker=marker, ms=10, ls="none", label=label)
        s = summary["spread"][key]
        if s.get("n"):
            bx.axhline(s["mean"], lw=0.8, ls=":", color="grey")
    bx.set_xlabel("replicate (0: the params' seeds)")
    bx.set_ylabel("charge-balanced fuel saving vs conventional [%]")
    bx.set_xticks(reps)
    bx.legend(fontsize=8)
    bx.set_title(f"headline over {summary['replicates']} seeds per source")
    return fig


__all__ = ["seed_spread_figure"]
