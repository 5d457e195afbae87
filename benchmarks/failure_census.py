"""Failure census of the simulator on the sizing cycle, and its responses against the study's regressions.

    .venv/bin/python benchmarks/failure_census.py [--n 10000] [--seed 0]

Needs the ``cycles`` and ``components`` stages' outputs (``dvc repro components cycles``). Part 1
simulates ``--n`` Latin-hypercube designs on the sizing cycle and reports NaNs, designs that never move
and whether each is flagged ``stalled``, designs with unmet accessory energy, and how ``e_l`` relates to
``speed_dev`` (a constant ratio would make them one objective). Part 2 simulates the study's L27 designs
and compares every objective with the study's regression equations (``data/raw/paper``) at the same
points: medians, ranges, their ratio and the correlation across the 27 designs.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd

from hevlib.cycles import Cycle
from hevlib.design import DESIGN_VARS, OBJECTIVES
from hevlib.doe import l27_designs, lhs_designs
from hevlib.params import load_params
from hevlib.sim.simulator import Simulator


def census(sim: Simulator, cycle: Cycle, n: int, seed: int) -> dict:
    X = lhs_designs(sim.space, n, seed)
    t0 = time.perf_counter()
    res = sim.run_raw(X, cycle)
    r = sim.responses(res, cycle)
    wall = time.perf_counter() - t0
    o = res.frame()
    never_moved = o["dist_m"].to_numpy() < 1.0
    moving = r["speed_dev"].to_numpy() > 0
    ratio = r["e_l"].to_numpy()[moving] / r["speed_dev"].to_numpy()[moving]
    return {
        "n_designs": n,
        "wall_s": round(wall, 2),
        "n_nan": int(r.isna().sum().sum()),
        "n_never_moved": int(never_moved.sum()),
        "n_never_moved_flagged_stalled": int(r.loc[never_moved, "stalled"].sum()),
        "n_stalled": int(r["stalled"].sum()),
        "n_accessory_unmet": int((r["accessory_unmet_kwh"] > 1e-9).sum()),
        "n_cycle_met": int(r["cycle_met"].sum()),
        "e_l_over_speed_dev": {
            "min": float(ratio.min()),
            "max": float(ratio.max()),
            "cv": float(ratio.std() / ratio.mean()),
        },
        "corr_e_l_speed_dev": float(np.corrcoef(r["e_l"], r["speed_dev"])[0, 1]),
    }


def study_comparison(sim: Simulator, cycle: Cycle, l27_file: str, equations: str) -> pd.DataFrame:
    X = l27_designs(l27_file)
    r = sim.run(X, cycle)
    eq = pd.read_csv(equations).set_index("response")
    rows = []
    for k in OBJECTIVES:
        c = eq.loc[k]
        study = c["intercept"] + X @ c[list(DESIGN_VARS)].to_numpy(float)
        ours = r[k].to_numpy(float)
        rows.append(
            {
                "response": k,
                "study_median": np.median(study),
                "ours_median": np.median(ours),
                "study_range": f"{study.min():.3g}..{study.max():.3g}",
                "ours_range": f"{ours.min():.3g}..{ours.max():.3g}",
                "ratio_of_medians": np.median(ours) / np.median(study),
                "corr": np.corrcoef(study, ours)[0, 1],
            }
        )
    return pd.DataFrame(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--params", default="params.yaml")
    ap.add_argument("--n", type=int, default=10_000)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    p = load_params(a.params)
    sim = Simulator.from_params(p)
    cycle = Cycle.from_parquet(f"data/cycles/{p.cycles.sizing}.parquet")
    sim.run(np.array([[43.0, 31.0, 15.0, 3.93, 25, 78, 30]]), cycle)  # compile outside the timing
    print(f"census of {a.n} Latin-hypercube designs on {cycle.name} (grade {100 * cycle.grade[0]:g} %):")
    for k, v in census(sim, cycle, a.n, a.seed).items():
        print(f"  {k}: {v}")
    print("\nL27 designs: our objectives against the study's regression equations at the same points")
    print(
        study_comparison(sim, cycle, p.doe.l27_file, "data/raw/paper/regression_equations.csv")
        .round(3)
        .to_string(index=False)
    )


if __name__ == "__main__":
    main()
