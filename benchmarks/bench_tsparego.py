"""Cost of one batch Thompson-sampling ParEGO run (:mod:`hevlib.optimise.tsparego`) on the sizing cycle, from the
pipeline's DOE, with the simulator in the loop: wall time per round (hyperparameter fit, conditioning and the
candidate pool, the picks, the simulations), the whole run's wall time and peak memory (the process's maximum
resident set), and its judged archive hypervolume (the pipeline's one yardstick: every simulated design that passes
the screen, on the judged scale) at each budget against the oracle's whole archive (``reports/optimise_oracle.json``).

One seed is a cost measurement, not a comparison: the benchmark (benchmarks/surrogate) compares sources over seeds.
Needs `dvc repro` first (data/doe/doe.parquet, data/judge/reference.parquet).

    python benchmarks/bench_tsparego.py [--budget 2000] [--batch 100] [--seed 0] [--out FILE.json]
"""

from __future__ import annotations

import argparse
import json
import resource
import time
from pathlib import Path

import hevlib  # noqa: F401  (before numpy: pins its CPU-dependent code paths)
from hevlib.design import DESIGN_VARS, RESPONSES
from hevlib.io import read_table
from hevlib.judging import HvSettings, judged_normalisation
from hevlib.optimise.archive import SimulationLog
from hevlib.optimise.infill import archive_hypervolume
from hevlib.optimise.problem import RulesOnly, sizing_problem
from hevlib.optimise.tsparego import TsParegoSettings, tsparego
from hevlib.params import load_params
from stages.simulating import sizing_setup

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--budget", type=int, default=2000)
    ap.add_argument("--batch", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--budgets", type=int, nargs="+", default=[250, 500, 1000, 2000])
    ap.add_argument("--out", type=Path)
    a = ap.parse_args()
    cfg = load_params(ROOT / "params.yaml")
    sim, cycle = sizing_setup(cfg)
    problem = sizing_problem(cfg, sim.mass_kg, RulesOnly())
    space = cfg.design_space.space()
    doe = read_table(ROOT / "data/doe/doe.parquet")
    X0, R0 = doe[list(DESIGN_VARS)].to_numpy(dtype=float), doe[list(RESPONSES)]
    hv = HvSettings.from_params(
        judged_normalisation(read_table(ROOT / "data/judge/reference.parquet"), cfg.screen), cfg.optimise, cfg.screen
    )
    t_sim = [0.0]

    def simulate(X):
        t = time.perf_counter()
        out = sim.run(X, cycle, vehicle="hybrid", batch_size=cfg.doe.batch_size)
        t_sim[0] += time.perf_counter() - t
        return out

    log = SimulationLog(simulate)
    log.record(X0, R0)  # the DOE counts
    settings = TsParegoSettings(budget=a.budget, batch=a.batch, seed=a.seed)
    t0 = time.perf_counter()

    def progress(n: int, b: int) -> None:
        print(f"  {n}/{b} simulations, {time.perf_counter() - t0:.0f} s", flush=True)

    run = tsparego(settings, problem, space, X0, R0, log, cfg.surrogate.bnn.log_targets, progress=progress)
    wall = time.perf_counter() - t0
    archive = log.table(None).to_pandas()
    oracle = json.loads((ROOT / "reports/optimise_oracle.json").read_text())["archive"]["hypervolume"]
    at = {}
    for b in a.budgets:
        if b <= len(archive):
            h = archive_hypervolume(archive.iloc[:b], hv)["hypervolume"]
            at[b] = {"hypervolume": h, "ratio_to_oracle_archive": h / oracle}
    out = {
        "settings": settings.__dict__,
        "n_simulations": len(run.X),
        "wall_s": wall,
        "simulation_s": t_sim[0],
        "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "rounds": run.rounds,
        "archive_hypervolume": at,
        "oracle_archive_hypervolume": oracle,
    }
    print(json.dumps({k: v for k, v in out.items() if k != "rounds"}, indent=1))
    if a.out:
        a.out.write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
