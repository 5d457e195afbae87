"""Component map figures (``reports/plots/maps_*.png``): engine BSFC with its best-efficiency line,
engine-out emissions, motor and generator efficiency."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from hevlib.components import RPM, ComponentLibrary, EngineMap, MachineMap, best_efficiency_line
from hevlib.lookup import interp_map
from hevlib.plots import plt, save_figure

_N = 160  # grid points per axis of the contour plots


def _engine_grid(engine: EngineMap) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fine (speed, torque) grid over the map and the mask of points above full load."""
    w = np.linspace(engine.speed_rad_s[0], engine.speed_rad_s[-1], _N)
    t = np.linspace(0.0, float(np.max(engine.max_torque_nm)), _N)
    ww, tt = np.meshgrid(w, t, indexing="ij")
    return ww, tt, tt > engine.max_torque_at(ww) + 1e-9


def _full_load(ax, speed_rad_s: np.ndarray, max_torque_nm: np.ndarray, label: str = "full load") -> None:
    ax.plot(speed_rad_s / RPM, max_torque_nm, "k-", lw=1.8, label=label)


def plot_engine_map(
    engine: EngineMap, path: str | os.PathLike, *, operating_line: tuple[np.ndarray, np.ndarray] | None = None
) -> None:
    """BSFC contours (g/kWh, at or below full load), full-load curve and the best-efficiency line.

    ``operating_line`` = (power_w, speed_rad_s) of a reference line (ADVISOR's Prius line) to compare.
    """
    ww, tt, above = _engine_grid(engine)
    fuel = engine.rate_g_s("fuel", ww, tt)
    with np.errstate(divide="ignore", invalid="ignore"):
        bsfc = np.where(above | (tt <= 0), np.nan, fuel / (ww * tt / 1e3) * 3600.0)
    p_w, w_line, t_line = best_efficiency_line(engine)
    b_min = engine.min_bsfc_g_per_kwh()
    fig, ax = plt.subplots(figsize=(8.0, 5.5))
    steps = np.array([1.0, 1.02, 1.05, 1.1, 1.2, 1.35, 1.5, 1.75, 2.0, 2.5, 3.0])
    levels = np.unique(np.round(b_min * steps))
    cs = ax.contour(ww / RPM, tt, bsfc, levels=levels, cmap="viridis_r", linewidths=1.0)
    ax.clabel(cs, fmt="%.0f", fontsize=7)
    _full_load(ax, engine.speed_rad_s, engine.max_torque_nm)
    ax.plot(w_line / RPM, t_line, "r-", lw=2.0, label="best-efficiency line (min fuel per power)")
    if operating_line is not None:
        p_op, w_op = operating_line
        ax.plot(w_op / RPM, p_op / w_op, "bs--", ms=5, lw=1.0, label="ADVISOR Prius operating line")
    for p_kw in (5, 10, 20, 30, 40, 60):
        if p_kw * 1e3 < np.max(p_w):
            w = np.linspace(engine.speed_rad_s[0], engine.speed_rad_s[-1], 100)
            ax.plot(w / RPM, p_kw * 1e3 / w, ":", color="0.5", lw=0.8)
            ax.annotate(f"{p_kw} kW", (w[-1] / RPM, p_kw * 1e3 / w[-1]), fontsize=7, color="0.4")
    ax.set_ylim(0, float(np.max(engine.max_torque_nm)) * 1.08)
    ax.set_xlabel("engine speed (rpm)")
    ax.set_ylabel("torque (N m)")
    ax.set_title(
        f"{engine.name}: BSFC (g/kWh), {engine.peak_power_kw:.1f} kW, "
        f"min {b_min:.1f} g/kWh = {100 * engine.max_efficiency():.1f} % efficiency",
        fontsize=10,
    )
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(alpha=0.3)
    save_figure(fig, path)


def plot_emission_maps(engine: EngineMap, path: str | os.PathLike) -> None:
    """Engine-out CO, HC and NOx rates (g/s) at or below full load."""
    ww, tt, above = _engine_grid(engine)
    fig, axes = plt.subplots(1, 3, figsize=(14.0, 4.4))
    for ax, key in zip(axes, ("co", "hc", "nox"), strict=True):
        z = np.where(above, np.nan, engine.rate_g_s(key, ww, tt))
        cf = ax.contourf(ww / RPM, tt, z, levels=14, cmap="magma_r")
        fig.colorbar(cf, ax=ax, label=f"{key.upper()} (g/s)")
        _full_load(ax, engine.speed_rad_s, engine.max_torque_nm)
        ax.set_title(f"{engine.name}: engine-out {key.upper()}", fontsize=10)
        ax.set_xlabel("engine speed (rpm)")
        ax.set_ylim(0, float(np.max(engine.max_torque_nm)) * 1.05)
    axes[0].set_ylabel("torque (N m)")
    save_figure(fig, path)


def plot_machine_map(machine: MachineMap, path: str | os.PathLike, *, role: str) -> None:
    """Efficiency contours (motor + inverter) within the torque limit, one quadrant (the map is mirrored)."""
    w = np.linspace(0.0, machine.max_speed_rad_s, _N)
    t = np.linspace(0.0, float(np.max(machine.max_torque_nm)), _N)
    ww, tt = np.meshgrid(w, t, indexing="ij")
    eff = interp_map(machine.speed_rad_s, machine.torque_nm, machine.efficiency, ww, tt)
    eff = np.where(tt > machine.max_torque_at(ww) + 1e-9, np.nan, eff)
    fig, ax = plt.subplots(figsize=(8.0, 5.5))
    cf = ax.contourf(ww / RPM, tt, eff, levels=np.arange(0.5, 0.951, 0.025), cmap="viridis", extend="min")
    fig.colorbar(cf, ax=ax, label="efficiency (machine + inverter)")
    _full_load(ax, machine.speed_rad_s, machine.max_torque_nm, label="torque limit")
    ax.set_xlabel(f"{role} speed (rpm)")
    ax.set_ylabel("|torque| (N m)")
    ax.set_title(
        f"{machine.name} ({role}): {machine.peak_power_kw:.1f} kW peak, max efficiency {machine.efficiency.max():.3f}",
        fontsize=10,
    )
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(alpha=0.3)
    save_figure(fig, path)


def write_map_plots(lib: ComponentLibrary, out_dir: str | os.PathLike) -> list[Path]:
    """The four map figures of the components stage: ``maps_{engine,emissions,motor,generator}.png``."""
    out = Path(out_dir)
    paths = [out / f"maps_{k}.png" for k in ("engine", "emissions", "motor", "generator")]
    ps = lib.power_split
    plot_engine_map(
        lib.engine_hybrid, paths[0], operating_line=(ps.operating_line_power_w, ps.operating_line_speed_rad_s)
    )
    plot_emission_maps(lib.engine_hybrid, paths[1])
    plot_machine_map(lib.motor, paths[2], role="motor")
    plot_machine_map(lib.generator, paths[3], role="generator")
    return paths
