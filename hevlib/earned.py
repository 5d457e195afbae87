"""Per-km figures a design did not earn on a cycle: what ``hev simulate`` leaves empty, and why.

A design that stalled, drove less than ``sim.min_distance_share`` of the cycle or missed its trace (``cycle_met``
False: off by more than ``sim.cycle_met_tolerance_kmh`` at some step, or its accessories left unpowered) burnt
and emitted what it did over a drive that is not the cycle's, so its fuel and emissions per km are no figure
of that cycle. The simulator still returns them (the failure ceiling of
:func:`hevlib.sim.simulator.failure_ceilings` for the first two, the run's own figure otherwise), and the DOE,
the optimisers and the screen rank on them unchanged; only the table a person reads leaves them empty
(:func:`mark_unearned`, column :data:`NOT_EARNED` giving the reason) and says so in one line
(:func:`unearned_warning`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from hevlib.design import UNITS

if TYPE_CHECKING:
    from hevlib.params import SimParams

#: Every per-km response (fuel in L/100 km, emissions in g/km; ``e_l`` is a distance in km, not per km):
#: ``fc``, ``hc``, ``co``, ``nox``, ``fc_soc_corrected``, the engine-out emissions and ``fc_charge_balanced``.
PER_KM: tuple[str, ...] = tuple(k for k, unit in UNITS.items() if unit in ("L/100 km", "g/km"))
#: The column that gives why a row's per-km figures are empty ("" where the design drove the cycle).
NOT_EARNED = "not_earned"
STALLED = "stalled"
SHORT = "short of the distance"
MISSED = "missed the trace"
UNPOWERED = "accessories unpowered"
#: Reasons, worst first (the order the warning counts them in and picks its worst design by).
REASONS: tuple[str, ...] = (STALLED, SHORT, MISSED, UNPOWERED)


def not_earned(table: pd.DataFrame, *, distance_m: float, sim: SimParams) -> np.ndarray:
    """Why each row's per-km figures are not the cycle's (:data:`REASONS`), "" where the design drove it.

    ``table`` holds the simulator's responses on a cycle of ``distance_m`` (the reference trace's distance).
    Stalled is the simulator's own flag. Short of the distance is read from ``e_l``: the simulator gives a
    design that drove less than ``sim.min_distance_share`` of the cycle an ``e_l`` of at least the cycle's
    distance, while one that drove that share or more has at most ``1 - share`` of it left, so the midpoint
    tells them apart. Otherwise ``cycle_met`` False is a missed trace where the design was off the trace
    (``speed_dev`` > 0: the share of the cycle off by more than the tolerance), else unpowered accessories.
    """
    n = len(table)
    stalled = table["stalled"].to_numpy(dtype=bool)
    short = table["e_l"].to_numpy(dtype=float) * 1e3 > (1.0 - sim.min_distance_share / 2.0) * distance_m
    unmet = ~table["cycle_met"].to_numpy(dtype=bool)
    off = table["speed_dev"].to_numpy(dtype=float) > 0.0
    out = np.full(n, "", dtype=object)
    for mask, reason in ((unmet, UNPOWERED), (unmet & off, MISSED), (short, SHORT), (stalled, STALLED)):
        out[mask] = reason  # worst last: it wins
    return out


def mark_unearned(table: pd.DataFrame, *, distance_m: float, sim: SimParams) -> pd.DataFrame:
    """A copy of ``table`` with the per-km figures (:data:`PER_KM`) of every row that did not drive the cycle
    (:func:`not_earned`) left empty (NaN) and the reason in a last column :data:`NOT_EARNED`."""
    reasons = not_earned(table, distance_m=distance_m, sim=sim)
    out = table.copy()
    bad = reasons != ""
    cols = [k for k in PER_KM if k in out.columns]
    if bad.any() and cols:
        out.loc[bad, cols] = np.nan
    out[NOT_EARNED] = reasons
    return out


def unearned_warning(marked: pd.DataFrame, *, cycle: str, sim: SimParams, vehicle: str = "hybrid") -> str | None:
    """One line saying how many rows of ``marked`` (:func:`mark_unearned`) did not drive ``cycle``, why, and
    which did worst (worst reason, then largest mean speed error); None where every row drove it."""
    reasons = marked[NOT_EARNED].to_numpy(dtype=object)
    bad = np.flatnonzero(reasons != "")
    if len(bad) == 0:
        return None
    what = {
        STALLED: f"stalled (stood still over {sim.stall_time_s:g} s)",
        SHORT: f"drove less than {100 * sim.min_distance_share:g} % of it",
        MISSED: f"missed the trace by more than {sim.cycle_met_tolerance_kmh:g} km/h",
        UNPOWERED: "left the accessories unpowered",
    }
    counts = {r: int(np.sum(reasons[bad] == r)) for r in REASONS}
    err = marked["speed_err_mean_kmh"].to_numpy(dtype=float)
    dev = marked["speed_dev"].to_numpy(dtype=float)
    worst = min(bad, key=lambda i: (REASONS.index(reasons[i]), -err[i], i))
    how = f"off the trace {100 * dev[worst]:.0f} % of the time, mean speed error {err[worst]:.1f} km/h"
    if vehicle != "hybrid":
        return (
            f"simulate: warning: the {vehicle} did not drive {cycle} ({what[reasons[worst]]}; {how}): its per-km "
            f"figures are left empty (column {NOT_EARNED})"
        )
    mixed = sum(1 for n in counts.values() if n) > 1
    why = ", ".join(f"{n} {what[r]}" for r, n in counts.items() if n) if mixed else what[reasons[worst]]
    row = f"row {worst} ({reasons[worst]})" if mixed else f"row {worst}"
    return (
        f"simulate: warning: {len(bad)} of {len(marked)} design(s) did not drive {cycle} ({why}); worst: {row}, "
        f"{how}: their per-km figures are left empty (column {NOT_EARNED})"
    )


__all__ = ["NOT_EARNED", "PER_KM", "REASONS", "mark_unearned", "not_earned", "unearned_warning"]
