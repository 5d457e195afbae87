"""Figures of the validation: improvement bars against both baselines, time traces on a cycle."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from hevlib.plots import plt

MPS_TO_KMH = 3.6


def improvement_figure(improvement: Mapping[str, Mapping[str, Mapping[str, float | None]]], cycle: str) -> plt.Figure:
    """Grouped bars of mean improvement per response ('+' = better), one panel per baseline.

    ``improvement`` is ``{group: {"vs_<baseline>": {response: value or None}}}`` (missing -> no bar).
    """
    groups = list(improvement)
    comparisons = list(next(iter(improvement.values()))) if groups else []
    fig, axes = plt.subplots(len(comparisons) or 1, 1, figsize=(11, 3.4 * max(len(comparisons), 1)), squeeze=False)
    for ax, comp in zip(axes[:, 0], comparisons, strict=False):
        responses = list(improvement[groups[0]][comp])
        width = 0.8 / len(groups)
        x = np.arange(len(responses))
        for i, g in enumerate(groups):
            vals = np.array(
                [np.nan if improvement[g][comp][r] is None else improvement[g][comp][r] for r in responses], dtype=float
            )
            ax.bar(x + (i - (len(groups) - 1) / 2) * width, np.nan_to_num(vals), width, label=g)
            for xi, v in zip(x, vals, strict=True):
                if not np.isfinite(v):
                    ax.text(
                        xi + (i - (len(groups) - 1) / 2) * width,
                        0,
                        "n/a",
                        ha="center",
                        va="bottom",
                        fontsize=6,
                        rotation=90,
                    )
        ax.axhline(0, color="k", lw=0.7)
        ax.set_xticks(x, responses, rotation=20)
        ax.set_ylabel("improvement [%]  (diff_soc: SOC points)")
        ax.set_title(f"{cycle}: picks {comp.replace('_', ' ')} ('+' = better)")
        ax.grid(axis="y", alpha=0.3)
        ax.legend(fontsize=7, ncol=len(groups))
    return fig


def traces_figure(traces: Mapping[str, pd.DataFrame], cycle: str) -> plt.Figure:
    """Speed (reference and achieved), SOC and cumulative fuel of each vehicle on ``cycle``.

    ``traces`` maps a vehicle label to a DataFrame with ``time_s``, ``v_ref_mps``, ``v_mps`` and
    optionally ``soc`` and ``fuel_g_s``.
    """
    fig, axes = plt.subplots(3, 1, figsize=(11, 8), sharex=True)
    first = next(iter(traces.values()))
    axes[0].plot(first["time_s"], first["v_ref_mps"] * MPS_TO_KMH, color="k", lw=1.4, label="cycle")
    for i, (label, tr) in enumerate(traces.items()):
        t, colour = tr["time_s"].to_numpy(dtype=float), f"C{i}"
        axes[0].plot(t, tr["v_mps"] * MPS_TO_KMH, lw=0.8, color=colour, label=label)
        if "soc" in tr and np.isfinite(tr["soc"].to_numpy(dtype=float)).any() and label != "conventional":
            axes[1].plot(t, tr["soc"], lw=0.9, color=colour, label=label)
        if "fuel_g_s" in tr:
            dt = np.diff(t, prepend=t[0])
            axes[2].plot(t, np.cumsum(tr["fuel_g_s"].to_numpy(dtype=float) * dt), lw=0.9, color=colour, label=label)
    axes[0].set_ylabel("speed [km/h]")
    axes[1].set_ylabel("SOC [-]")
    axes[2].set_ylabel("fuel used [g]")
    axes[2].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left")
    axes[0].set_title(f"{cycle}: best picked design against both baselines")
    return fig


def catalyst_figure(traces: Mapping[str, pd.DataFrame], cycle: str, until_s: float, light_off_c: float) -> plt.Figure:
    """Catalyst (monolith) and coolant temperature, engine on/off and cumulative tailpipe HC of each vehicle
    over the first ``until_s`` seconds of ``cycle`` (FTP: bag 1, the cold start); ``light_off_c``: the
    monolith temperature of 50 % HC conversion, drawn as a line."""
    fig, axes = plt.subplots(3, 1, figsize=(11, 8.5), sharex=True, gridspec_kw={"height_ratios": [3, 1.2, 2]})
    for i, (label, tr) in enumerate(traces.items()):
        win = tr["time_s"].to_numpy(dtype=float) <= until_s
        t, colour = tr["time_s"].to_numpy(dtype=float)[win], f"C{i}"
        axes[0].plot(t, tr["t_cat_c"].to_numpy()[win], lw=1.2, color=colour, label=f"{label}: catalyst")
        axes[0].plot(t, tr["t_coolant_c"].to_numpy()[win], lw=0.8, ls="--", color=colour, label=f"{label}: coolant")
        axes[1].step(t, tr["eng_on"].to_numpy()[win] * 0.8 + i, where="post", lw=0.9, color=colour, label=label)
        dt = np.diff(t, prepend=t[0])
        axes[2].plot(
            t, np.cumsum(tr["hc_tailpipe_g_s"].to_numpy()[win] * dt), lw=1.2, color=colour, label=f"{label}: tailpipe"
        )
        axes[2].plot(
            t,
            np.cumsum(tr["hc_engine_out_g_s"].to_numpy()[win] * dt),
            lw=0.8,
            ls=":",
            color=colour,
            label=f"{label}: engine-out",
        )
    axes[0].axhline(light_off_c, color="k", lw=0.7, ls="-.", label="50 % HC conversion")
    axes[0].set_ylabel("temperature [C]")
    axes[1].set_ylabel("engine on")
    axes[1].set_yticks([])
    axes[2].set_ylabel("HC [g]")
    axes[2].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left", ncol=2)
    axes[0].set_title(f"{cycle}, first {until_s:g} s from a cold start: catalyst warm-up")
    return fig


__all__ = ["catalyst_figure", "improvement_figure", "traces_figure"]
