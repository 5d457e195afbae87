"""Bag-by-bag figures of a trace (the FTP's three bags: cold transient, stabilised, hot transient)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from hevlib.cycles import Cycle
from hevlib.design import (
    design_matrix,
)

#: Tailpipe gases of the bag table with their trace columns.
GAS_TAILPIPE: tuple[tuple[str, str], ...] = (
    ("hc", "hc_tailpipe_g_s"),
    ("co", "co_tailpipe_g_s"),
    ("nox", "nox_tailpipe_g_s"),
)


def bag_figures(trace: pd.DataFrame, density_g_per_l: float, bags: Sequence[tuple[float, float]]) -> list:
    """Fuel (L/100 km), tailpipe HC/CO/NOx (g/km) and SOC change of one vehicle's trace over each bag
    ``(start_s, end_s]`` (seconds since the cycle's start)."""
    t = trace["time_s"].to_numpy(dtype=float)
    dt = np.diff(t, prepend=t[0])
    soc = trace["soc"].to_numpy(dtype=float)
    metres = trace["v_mps"].to_numpy(dtype=float) * dt
    grams = {k: trace[c].to_numpy(dtype=float) * dt for k, c in (("fuel", "fuel_g_s"), *GAS_TAILPIPE)}
    out = []
    for k, (a, b) in enumerate(bags, start=1):
        steps = np.flatnonzero((t > a) & (t <= b))
        km = float(np.sum(metres[steps])) / 1000.0
        fuel_l = float(np.sum(grams["fuel"][steps])) / density_g_per_l
        row = {
            "bag": k,
            "start_s": a,
            "end_s": b,
            "distance_km": km,
            "fc": 100.0 * fuel_l / km if km > 0 else None,
            "delta_soc": float(soc[steps[-1]] - soc[max(steps[0] - 1, 0)]) if steps.size else 0.0,
        }
        for gas, _ in GAS_TAILPIPE:
            row[gas] = float(np.sum(grams[gas][steps])) / km if km > 0 else None
        out.append(row)
    return out


#: FTP's three bags in seconds of our FTP file: bag 1 (cold transient, 0-505 s), bag 2 (stabilised,
#: 505-1372 s), then the 10-minute key-off soak and bag 3 (hot transient, the first 505 s again).
FTP_BAGS_S: tuple[tuple[float, float], ...] = ((0.0, 505.0), (505.0, 1372.0), (1972.0, 2477.0))


def ftp_bags(sim, table: pd.DataFrame, selected: pd.DataFrame, design_id: str, ftp: Cycle, prius_x) -> dict:
    """Bag-by-bag FTP figures (:func:`bag_figures`) of one picked design and both baselines, each hybrid traced
    from the SOC its charge-balanced run started at (the conventional car has no battery: its own start)."""
    rows = table[table["cycle"] == ftp.name].set_index("vehicle")
    density = sim.library.lib.engine_hybrid.fuel_density_g_per_l  # as every fc figure (hevlib.sim.simulator)
    x = design_matrix(selected[selected["design_id"].astype(str) == design_id])
    out = {}
    for name, X, kind in ((design_id, x, "hybrid"), ("prius", np.asarray(prius_x, dtype=float)[None, :], "prius")):
        soc = float(rows.loc[name, "soc_init_charge_balanced"])
        out[name] = bag_figures(sim.trace(X, ftp, kind, soc_init=soc), density, FTP_BAGS_S)
    out["conventional"] = bag_figures(sim.trace(None, ftp, "conventional"), density, FTP_BAGS_S)
    return out
