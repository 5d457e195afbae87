"""Drive-cycle trace figures: speed following, battery SOC, and engine operating points on the map."""

from __future__ import annotations

import os

import numpy as np
import pandas as pd

from hevlib.components import RPM, EngineMap, best_efficiency_line
from hevlib.plots import plt, save_figure


def plot_hybrid_trace(trace: pd.DataFrame, engine: EngineMap, path: str | os.PathLike, *, title: str) -> None:
    """Three panels: reference vs achieved speed, SOC, and engine operating points over BSFC contours.

    ``trace``: one design's :meth:`hevlib.sim.simulator.Simulator.trace` frame; ``engine``: the design's
    engine map already scaled to its power (so the contours are the ones it runs on).
    """
    fig = plt.figure(figsize=(12.0, 8.0))
    ax_v = fig.add_subplot(2, 2, (1, 2))
    ax_s = fig.add_subplot(2, 2, 3)
    ax_e = fig.add_subplot(2, 2, 4)
    t = trace["time_s"].to_numpy()
    ax_v.plot(t, trace["v_ref_mps"] * 3.6, color="0.6", lw=1.0, label="cycle")
    ax_v.plot(t, trace["v_mps"] * 3.6, color="C0", lw=0.9, label="achieved")
    on = trace["eng_on"].to_numpy() > 0.5
    ax_v.fill_between(
        t,
        0,
        np.where(on, trace["v_ref_mps"].max() * 3.6 * 1.05, 0),
        color="C3",
        alpha=0.08,
        step="mid",
        label="engine on",
    )
    ax_v.set_xlabel("time (s)")
    ax_v.set_ylabel("speed (km/h)")
    ax_v.legend(loc="upper right", fontsize=8)
    ax_v.set_title(title, fontsize=10)
    ax_s.plot(t, trace["soc"], color="C2")
    ax_s.set_xlabel("time (s)")
    ax_s.set_ylabel("battery SOC (-)")
    ax_s.grid(alpha=0.3)
    # engine operating points over BSFC
    w = np.linspace(engine.speed_rad_s[0], engine.speed_rad_s[-1], 120)
    tq = np.linspace(0.0, float(np.max(engine.max_torque_nm)), 120)
    ww, tt = np.meshgrid(w, tq, indexing="ij")
    with np.errstate(divide="ignore", invalid="ignore"):
        bsfc = engine.rate_g_s("fuel", ww, tt) / (ww * tt / 1e3) * 3600.0
    bsfc[(tt > engine.max_torque_at(ww)) | (tt <= 0)] = np.nan
    b_min = engine.min_bsfc_g_per_kwh()
    cs = ax_e.contour(
        ww / RPM,
        tt,
        bsfc,
        levels=np.round(b_min * np.array([1.02, 1.05, 1.1, 1.2, 1.35, 1.5, 2.0])),
        cmap="viridis_r",
        linewidths=0.8,
    )
    ax_e.clabel(cs, fmt="%.0f", fontsize=7)
    ax_e.plot(engine.speed_rad_s / RPM, engine.max_torque_nm, "k-", lw=1.5, label="full load")
    _, w_line, t_line = best_efficiency_line(engine)
    ax_e.plot(w_line / RPM, t_line, "r--", lw=1.2, label="best-efficiency line")
    ax_e.plot(
        trace.loc[on, "w_eng_rad_s"] / RPM,
        trace.loc[on, "t_eng_nm"],
        ".",
        ms=3,
        color="C0",
        alpha=0.5,
        label="operating points",
    )
    ax_e.set_xlabel("engine speed (rpm)")
    ax_e.set_ylabel("engine torque (N m)")
    ax_e.legend(loc="lower right", fontsize=7)
    save_figure(fig, path)
