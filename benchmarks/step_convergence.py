"""Time-step convergence of the simulator on a fixed set of vehicles and cycles (issue 52's bar).

The fixed set: the conventional car, the stock Prius, the 27 L27 designs and the recommended design
(``reports/validation.json``), on FTP, HWFET, US06 and the sizing cycle, each at a 1 s step (the default) and at
0.25 s and 0.1 s, with the params' thermal start. For every vehicle, cycle and step it reports raw and
charge-balanced fuel (SAE J1711 1 %), tailpipe HC, CO and NOx, the speed deviation, the engine starts and
whether the cycle was met, and the largest move of each against the 1 s step; ``--out`` writes the table.

``--audit`` adds where a move comes from: per cycle and step, the median over the vehicles of the charge-balanced
run's energy terms that depend on the engine's dynamics (:data:`AUDIT`: the carrier's inertia work while running,
the starts' energy, the battery's and the generator's losses, the engine's time on, the force-limited steps),
each against the vehicle's own at the first step.

    python benchmarks/step_convergence.py [--steps 1 0.25 0.1] [--cycles ftp hwfet us06 udds] [--out FILE] [--audit]
        [--strategy fuzzy|ecms]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

# isort: off
import hevlib  # noqa: F401  (before numpy: pins its CPU-dependent code paths)
import numpy as np
import pandas as pd
# isort: on

from hevlib.cycles import Cycle, build_cycles, resample
from hevlib.design import DESIGN_VARS
from hevlib.doe import l27_designs
from hevlib.params import load_params
from hevlib.sim.powertrain.layout import OUT_NAMES
from hevlib.sim.simulator import Simulator, charge_balance, responses, simulate
from hevlib.sizing import study_library

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ("fc", "fc_charge_balanced", "hc", "co", "nox")
#: Energy terms of the charge-balanced run (``OUT_NAMES``, J or counts) that ``--audit`` follows across steps.
AUDIT = ("e_fuel_j", "e_engine_start_j", "e_loss_batt_j", "e_loss_gen_j", "n_limited")


def resampled(cycle: Cycle, dt_s: float) -> Cycle:
    """``cycle`` at a step of ``dt_s``: speed and grade linear between its points, the key state held from the
    point before (the FTP's key-off soak stays where it is)."""
    t, speed_mps = resample(cycle.time_s, cycle.speed_mps, dt_s)
    key_on = cycle.key_on[np.searchsorted(cycle.time_s, t + 1e-9) - 1]
    return Cycle(cycle.name, t, speed_mps, np.interp(t, cycle.time_s, cycle.grade), key_on)


def fixed_set(root: Path = ROOT) -> dict[str, np.ndarray | None]:
    """Vehicle label -> designs (None for a baseline): both reference cars, the L27 designs and the recommended
    design of ``reports/validation.json``."""
    rec = json.loads((root / "reports/validation.json").read_text())["recommendation"]["design"]
    x_rec = np.array([[rec["design"][k] for k in DESIGN_VARS]])
    l27 = l27_designs(root / "data/raw/paper/l27_assignment.csv")
    return {"conventional": None, "prius": None, "l27": l27, rec["design_id"]: x_rec}


def run_one(sim: Simulator, label: str, X: np.ndarray | None, cycle: Cycle) -> pd.DataFrame:
    kind = "hybrid" if X is not None else label
    vehicle = sim.vehicle(X, kind)
    first = simulate(vehicle, cycle)
    r = responses(first, cycle, vehicle.library)
    last, cb = charge_balance(vehicle, cycle, first, tolerance=0.01, max_runs=10)
    n = len(r)
    names = [label] if n == 1 else [f"{label}-{i + 1}" for i in range(n)]
    out = np.asarray(last.out)
    dt = float(cycle.time_s[1] - cycle.time_s[0])
    audit = {k: out[:, OUT_NAMES.index(k)] for k in AUDIT}
    audit["engine_on_s"] = out[:, OUT_NAMES.index("eng_on_steps")] * dt
    return pd.DataFrame(
        {
            **audit,
            "vehicle": names,
            "fc": r["fc"].to_numpy(),
            "fc_charge_balanced": cb["fc_charge_balanced"].to_numpy(),
            "hc": r["hc"].to_numpy(),
            "co": r["co"].to_numpy(),
            "nox": r["nox"].to_numpy(),
            "speed_dev": r["speed_dev"].to_numpy(),
            "n_engine_starts": r["n_engine_starts"].to_numpy(),
            "cycle_met": r["cycle_met"].to_numpy(),
        }
    )


def table(steps: list[float], cycle_names: list[str], root: Path = ROOT, strategy: str | None = None) -> pd.DataFrame:
    params = load_params(root / "params.yaml")
    if strategy is not None:  # the hybrids' supervisory controller (pms.strategy), the rest of the params as they are
        params = params.model_copy(update={"pms": params.pms.model_copy(update={"strategy": strategy})})
    sim = Simulator(study_library(params.baseline), params)
    base = build_cycles(params.cycles)
    frames = []
    for name in cycle_names:
        for dt in steps:
            cyc = resampled(base[name], dt)
            for label, X in fixed_set(root).items():
                f = run_one(sim, label, X, cyc)
                f.insert(0, "step_s", dt)
                f.insert(0, "cycle", name)
                frames.append(f)
    return pd.concat(frames, ignore_index=True)


def moves(t: pd.DataFrame, ref_step: float) -> pd.DataFrame:
    """Per cycle and step: the largest relative move of each figure against ``ref_step``, the largest speed
    deviation move, the largest change in engine starts and how many vehicles change cycle_met."""
    ref = t[t.step_s == ref_step].set_index(["cycle", "vehicle"])
    rows = []
    for (cyc, dt), g in t[t.step_s != ref_step].groupby(["cycle", "step_s"]):
        g = g.set_index(["cycle", "vehicle"])
        r = ref.loc[g.index]
        row = {"cycle": cyc, "step_s": dt}
        for k in FIGURES:
            rel = (g[k] - r[k]) / r[k]
            row[f"{k}_max_pct"] = 100 * np.nanmax(np.abs(rel.to_numpy()))
            row[f"{k}_worst"] = rel.abs().idxmax()[1] if rel.notna().any() else ""
        row["speed_dev_max"] = float(np.max(np.abs(g.speed_dev - r.speed_dev)))
        row["starts_max"] = float(np.max(np.abs(g.n_engine_starts - r.n_engine_starts)))
        row["cycle_met_flips"] = int((g.cycle_met != r.cycle_met).sum())
        row["cb_nan"] = int(g.fc_charge_balanced.isna().sum())
        rows.append(row)
    return pd.DataFrame(rows)


def audit(t: pd.DataFrame, ref_step: float) -> pd.DataFrame:
    """Per cycle and step: the median over the vehicles (those that meet the cycle at both steps) of each
    :data:`AUDIT` term and the engine's time on, as the move against the vehicle's own at ``ref_step`` (energies
    in MJ, times in s, counts as they are) and the median charge-balanced fuel move in %."""
    keys = [*AUDIT, "engine_on_s"]
    ref = t[t.step_s == ref_step].set_index(["cycle", "vehicle"])
    rows = []
    for (cyc, dt), g in t[t.step_s != ref_step].groupby(["cycle", "step_s"]):
        g = g.set_index(["cycle", "vehicle"])
        r = ref.loc[g.index]
        both = (g.cycle_met & r.cycle_met).to_numpy()
        row = {"cycle": cyc, "step_s": dt, "vehicles": int(both.sum())}
        row["fc_cb_pct"] = float(np.nanmedian(100 * (g.fc_charge_balanced / r.fc_charge_balanced - 1)[both]))
        for k in keys:
            scale = 1e-6 if k.endswith("_j") else 1.0
            row[k.removesuffix("_j") + ("_mj" if k.endswith("_j") else "")] = (
                float(np.median(((g[k] - r[k]) * scale)[both])) if both.any() else np.nan
            )
        rows.append(row)
    return pd.DataFrame(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=float, nargs="+", default=[1.0, 0.25, 0.1])
    ap.add_argument("--cycles", nargs="+", default=["ftp", "hwfet", "us06", "udds"])
    ap.add_argument("--out", type=Path)
    ap.add_argument("--audit", action="store_true", help="where the moves come from (module docstring)")
    ap.add_argument("--strategy", choices=["fuzzy", "ecms"], default=None, help="pms.strategy (default: params.yaml's)")
    a = ap.parse_args()
    t0 = time.perf_counter()
    t = table(a.steps, a.cycles, strategy=a.strategy)
    if a.out:
        t.to_csv(a.out, index=False)
    pd.set_option("display.width", 250, "display.max_columns", 40)
    print(moves(t, a.steps[0]).round(3).to_string(index=False))
    if a.audit:
        print(audit(t, a.steps[0]).round(3).to_string(index=False))
    print(f"wall {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
