"""The two reference vehicles (conventional car, stock Prius) simulated on every reference cycle.

``reports/baselines.json`` holds ``{vehicle: {run: {response: value}}}`` where a run is a cycle at the
grade it carries from params (``udds_grade20``), the same cycle flat (``udds_flat``) for graded cycles,
or the cycle's own name for flat ones (``ftp``, ``hwfet``, ``us06``, ``nedc``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
import pandas as pd

from hevlib.cycles import Cycle
from hevlib.design import BOOL_RESPONSES, CHARGE_BALANCE_RESPONSES, RESPONSES
from hevlib.sim.simulator import Simulator, energy_balance

BASELINE_VEHICLES: tuple[str, ...] = ("prius", "conventional")


def baseline_runs(cycles: Mapping[str, Cycle]) -> dict[str, Cycle]:
    """Run name -> cycle: graded cycles twice (as carried and flat), flat cycles once."""
    runs: dict[str, Cycle] = {}
    for name, cyc in cycles.items():
        grade_pct = 100.0 * float(np.mean(cyc.grade))
        if abs(grade_pct) > 1e-12:
            runs[f"{name}_grade{grade_pct:g}"] = cyc
            runs[f"{name}_flat"] = cyc.with_grade(0.0)
        else:
            runs[name] = cyc
    return runs


def simulate_baselines(
    sim: Simulator, cycles: Mapping[str, Cycle], progress: Callable[[int, int], None] | None = None
) -> tuple[dict, pd.DataFrame]:
    """(report dict for baselines.json, energy-balance table with one row per vehicle and run).

    ``progress(n_done, n_total)`` is called after each vehicle-run.
    """
    report: dict[str, dict] = {v: {} for v in BASELINE_VEHICLES}
    balance = []
    runs = baseline_runs(cycles)
    n_total = len(runs) * len(BASELINE_VEHICLES)
    for run, cyc in runs.items():
        for vehicle in BASELINE_VEHICLES:
            raw, resp = sim.drive(sim.vehicle(None, vehicle), cyc, charge_balanced=True)
            resp = resp.iloc[0]
            report[vehicle][run] = {
                k: (bool(resp[k]) if k in BOOL_RESPONSES else float(resp[k]))
                for k in RESPONSES + CHARGE_BALANCE_RESPONSES
            }
            eb = energy_balance(raw).iloc[0]
            balance.append(
                {
                    "vehicle": vehicle,
                    "run": run,
                    **eb.to_dict(),
                    "limit_violations": float(raw.frame()["limit_violations"].iloc[0]),
                }
            )
            if progress is not None:
                progress(len(balance), n_total)
    return report, pd.DataFrame(balance)
