"""ECMS in the drive step against the study's rule base (issue 56; docs/controller.md's table).

The set: the 27 L27 designs (``data/doe/doe.parquet``), the picks (``data/pareto/selected.parquet``) and the stock
Prius, on the sizing cycle, FTP, HWFET and US06, each charge-balanced (``sim.charge_balance_*``, SAE J1711) under
``pms.strategy: fuzzy`` and ``ecms`` with the params' other settings (``--set key=value`` overrides ``pms`` keys
of the ECMS run: ``--set ecms_n_speed=24 --set ecms_n_torque=24`` measures the candidates' resolution). Per cycle:
ECMS's charge-balanced fuel against the rule base's (median and range), how many meet the trace under each, the
median engine starts, the stock Prius's and each pick's figures; ``--out`` writes every run.

    python benchmarks/ecms_drive.py [--cycles udds ftp hwfet us06] [--set KEY=VALUE ...] [--out FILE]
"""

from __future__ import annotations

import argparse
import time

# isort: off
import hevlib  # noqa: F401  (before numpy: pins its CPU-dependent code paths)
import numpy as np
import pandas as pd
# isort: on

from hevlib.cycles import build_cycles
from hevlib.design import DESIGN_VARS
from hevlib.params import load_params
from hevlib.sim.simulator import Simulator
from hevlib.sizing import study_library


def runs(params, cycles: dict, X: np.ndarray, names: list[str], pms: dict) -> pd.DataFrame:
    """Every vehicle on every cycle under the ``pms`` overrides, charge-balanced, with the wall time per cycle."""
    raw = params.model_dump(by_alias=True)
    raw["pms"] |= pms
    p = type(params).model_validate(raw, strict=False)
    frames = []
    with Simulator(study_library(p.baseline), p) as sim:
        for name, cycle in cycles.items():
            t0 = time.perf_counter()
            r = sim.run(X, cycle, charge_balanced=True).assign(vehicle=names)
            wall = time.perf_counter() - t0
            prius = sim.run(None, cycle, "prius", charge_balanced=True).assign(vehicle="prius")
            frames.append(pd.concat([r, prius], ignore_index=True).assign(cycle=name, wall_s=wall))
    return pd.concat(frames, ignore_index=True).assign(strategy=pms["strategy"])


def table(both: pd.DataFrame) -> pd.DataFrame:
    """Per cycle: ECMS against the rule base (charge-balanced fuel), traces met and starts under each."""
    rows = []
    for name, g in both.groupby("cycle", sort=False):
        w = g.pivot_table(index="vehicle", columns="strategy", values=["fc_charge_balanced", "n_engine_starts"])
        met = g.groupby("strategy")["cycle_met"].sum()
        rel = 100.0 * (w["fc_charge_balanced"]["ecms"] / w["fc_charge_balanced"]["fuzzy"] - 1.0)
        rows.append(
            {
                "cycle": name,
                "vehicles": int(len(w)),
                "ecms_vs_rule_pct_median": float(rel.median()),
                "ecms_vs_rule_pct_min": float(rel.min()),
                "ecms_vs_rule_pct_max": float(rel.max()),
                "met_rule": int(met.get("fuzzy", 0)),
                "met_ecms": int(met.get("ecms", 0)),
                "starts_rule_median": float(w["n_engine_starts"]["fuzzy"].median()),
                "starts_ecms_median": float(w["n_engine_starts"]["ecms"].median()),
                "prius_rule": float(w["fc_charge_balanced"]["fuzzy"]["prius"]),
                "prius_ecms": float(w["fc_charge_balanced"]["ecms"]["prius"]),
                "wall_rule_s": float(g.loc[g["strategy"] == "fuzzy", "wall_s"].iloc[0]),
                "wall_ecms_s": float(g.loc[g["strategy"] == "ecms", "wall_s"].iloc[0]),
            }
        )
    return pd.DataFrame(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--params", default="params.yaml")
    ap.add_argument("--cycles", nargs="+", default=None, help="default: the sizing cycle, ftp, hwfet, us06")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a pms key of the ECMS run")
    ap.add_argument("--out", default=None, help="parquet file of every run")
    args = ap.parse_args()
    params = load_params(args.params)
    every = build_cycles(params.cycles)
    names = args.cycles or list(dict.fromkeys([params.cycles.sizing, "ftp", "hwfet", "us06"]))
    cycles = {n: every[n] for n in names}
    doe = pd.read_parquet("data/doe/doe.parquet")
    picks = pd.read_parquet("data/pareto/selected.parquet")
    X = np.vstack([doe[list(DESIGN_VARS)].to_numpy(float), picks[list(DESIGN_VARS)].to_numpy(float)])
    labels = [f"L27-{i + 1}" for i in range(len(doe))] + picks["design_id"].tolist()
    overrides = {}
    for item in args.set:
        key, _, value = item.partition("=")
        overrides[key] = float(value) if "." in value else int(value) if value.lstrip("-").isdigit() else value
    both = pd.concat(
        [
            runs(params, cycles, X, labels, {"strategy": "fuzzy"}),
            runs(params, cycles, X, labels, {"strategy": "ecms", **overrides}),
        ],
        ignore_index=True,
    )
    if args.out:
        both.to_parquet(args.out)
    pd.set_option("display.width", 200)
    print(table(both).round(3).to_string(index=False))


if __name__ == "__main__":
    main()
