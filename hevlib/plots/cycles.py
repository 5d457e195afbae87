"""Speed traces of the drive cycles (``reports/plots/cycles.png``)."""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np

from hevlib.cycles import Cycle
from hevlib.plots import plt, save_figure


def plot_speed_traces(cycles: Sequence[Cycle], path: str | os.PathLike) -> None:
    """One panel per cycle: speed (km/h) against time, key-off periods shaded, title with the key figures."""
    fig, axes = plt.subplots(len(cycles), 1, figsize=(9.0, 2.6 * len(cycles)), squeeze=False)
    for ax, cyc in zip(axes[:, 0], cycles, strict=True):
        ax.plot(cyc.time_s, cyc.speed_mps * 3.6, lw=0.8, color="C0")
        off = ~cyc.key_on
        if np.any(off):
            ax.fill_between(
                cyc.time_s,
                0,
                1,
                where=off,
                transform=ax.get_xaxis_transform(),
                color="0.85",
                step="mid",
                label="key off",
            )
            ax.legend(loc="upper right", fontsize=8)
        s = cyc.summary()
        ax.set_title(
            f"{cyc.name.upper()}: {s['distance_km']:.3f} km in {s['duration_s']:.0f} s, "
            f"mean {s['v_mean_kmh']:.1f} km/h, grade {100 * s['grade']:g} %",
            fontsize=10,
        )
        ax.set_ylabel("speed (km/h)")
        ax.set_xlim(cyc.time_s[0], cyc.time_s[-1])
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time (s)")
    save_figure(fig, path)
