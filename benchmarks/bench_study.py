"""A million-design study end to end: Latin hypercube, simulation, screen, merge, non-dominated filter, report.

    python benchmarks/bench_study.py [--n 1000000] [--part 25000] [--steps simulate post]
        [--data data/benchmark/study] [--out reports/benchmark.json]

Run after ``dvc repro`` (it reads ``data/components`` and ``data/cycles``). ``simulate`` draws a seeded
Latin hypercube of ``--n`` designs over ``params.design_space`` and simulates it on the sizing cycle with
the executor of ``params.sim`` (``executor: dask`` spreads the parts over a cluster), writing one Parquet
part of ``--part`` designs at a time (DOE schema) under ``--data``; parts already there with the same
designs are kept, so an interrupted run resumes. ``post`` runs what the ``pareto`` stage runs, on the
simulated parts as one source: merge (one row per distinct design), non-dominated filter, screen,
rank, keep, pick, then the hypervolume of the screened front; each step timed, and peak memory
measured per step in its own subprocess (peak RSS of a fresh process, so one step's memory is its own).
Results go to the ``study`` entry of ``--out`` (other entries are kept).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _params():
    from hevlib.params import load_params

    return load_params(ROOT / "params.yaml")


def _designs(params, n: int, seed: int):
    from hevlib.doe import lhs_designs

    return lhs_designs(params.design_space.space(), n, seed)


def simulate(n: int, part: int, seed: int, data: Path) -> dict:
    """Simulate ``n`` LHS designs on the sizing cycle, one Parquet part of ``part`` designs at a time."""
    import numpy as np
    import pyarrow.parquet as pq

    from hevlib.cycles import Cycle
    from hevlib.doe import doe_table, run_metadata, write_doe
    from hevlib.sim.simulator import Simulator

    params = _params()
    t0 = time.perf_counter()
    X = _designs(params, n, seed)
    lhs_s = time.perf_counter() - t0
    cycle = Cycle.from_parquet(ROOT / "data" / "cycles" / f"{params.cycles.sizing}.parquet", params.cycles.sizing)
    data.mkdir(parents=True, exist_ok=True)
    sim_s, done, reused = 0.0, 0, 0
    with Simulator.from_params(params, components_dir=str(ROOT / "data" / "components")) as sim:
        sim.run(X[:2], cycle)  # numba cache load, not timed
        for k, start in enumerate(range(0, n, part)):
            Xk = X[start : start + part]
            path = data / f"part-{k:05d}.parquet"
            design = {"method": "lhs", "n": n, "seed": seed, "part": k, "rows": [start, start + len(Xk)]}
            if path.exists():
                meta = {a.decode(): b.decode() for a, b in (pq.read_schema(path).metadata or {}).items()}
                if meta.get("hev.design") == json.dumps(design, sort_keys=True, default=str):
                    reused += len(Xk)
                    continue
            t1 = time.perf_counter()
            table = doe_table(Xk, sim.run(Xk, cycle, batch_size=params.doe.batch_size), "lhs")
            sim_s += time.perf_counter() - t1
            write_doe(path, table, run_metadata(cycle, params, **design))
            done += len(Xk)
            print(f"  part {k}: {start + len(Xk)}/{n} designs, {done / max(sim_s, 1e-9):.0f} designs/s", flush=True)
    return {
        "n_designs": n,
        "cycle": params.cycles.sizing,
        "executor": params.sim.executor,
        "lhs_s": lhs_s,
        "simulated": done,
        "reused_parts_designs": reused,
        "simulate_s": sim_s,
        "design_cycles_per_s": done / sim_s if sim_s else None,
        "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "n_parts": int(np.ceil(n / part)),
    }


class PeakRss:
    """Wall time and peak resident memory of this process while the block runs (MiB, sampled every 5 ms
    by a thread); ``extra_mib`` is the peak above the RSS at entry (what the step itself needed)."""

    def __enter__(self):
        self.t0 = time.perf_counter()
        self.start_mib = self.peak_mib = _rss_mib()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, daemon=True)
        self._thread.start()
        return self

    def _watch(self):
        while not self._stop.wait(0.005):
            self.peak_mib = max(self.peak_mib, _rss_mib())

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        self.peak_mib = max(self.peak_mib, _rss_mib())
        self.extra_mib = self.peak_mib - self.start_mib
        self.wall_s = time.perf_counter() - self.t0

    def entry(self) -> dict:
        return {"wall_s": self.wall_s, "peak_rss_mib": self.peak_mib, "extra_rss_mib": self.extra_mib}


def _rss_mib() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def post(data: Path, n: int | None, out_dir: Path) -> dict:
    """The pareto stage's steps on the simulated parts (one source, ``lhs``), each timed and its memory
    measured: scan, select (merge, non-dominated filter, screen, rank, keep, pick, summary), hypervolume
    of the screen-passing non-dominated designs, and writing the merged and selected tables."""
    import polars as pl

    from hevlib.io import write_json, write_parquet
    from hevlib.judging import HvSettings, screened_normalisation, simulated_as_front
    from hevlib.pareto import select_designs, table_schema
    from hevlib.results import to_json
    from hevlib.tables import scan

    params = _params()
    steps: dict[str, dict] = {}
    t_all = time.perf_counter()
    with PeakRss() as m:
        lf = scan(data)
        front = simulated_as_front(lf if n is None else lf.head(n))
        n_rows = front.select(pl.len()).collect().item()
    steps["scan"] = m.entry()
    timings: dict[str, float] = {}
    with PeakRss() as m:
        res = select_designs({"lhs": front}, params.screen, timings=timings)
    steps["select"] = {**m.entry(), "steps_s": timings}
    with PeakRss() as m:
        candidates = res.merged.filter(pl.col("nondominated"))
        hv = HvSettings.from_params(screened_normalisation([candidates], params.screen), params.optimise, params.screen)
        value, n_counted = hv.of(candidates)
    steps["hypervolume"] = {**m.entry(), **value.describe(), "designs_counted": n_counted}
    with PeakRss() as m:
        write_parquet(out_dir / "merged.parquet", res.merged, table_schema(res.merged))
        write_parquet(out_dir / "selected.parquet", res.selected, table_schema(res.selected))
        write_json(out_dir / "pareto.json", to_json(res.summary))
    steps["write"] = m.entry()
    c = res.summary.counts
    return {
        "n_designs": n_rows,
        "counts": c,
        "wall_s": time.perf_counter() - t_all,
        "peak_rss_mib": max(v["peak_rss_mib"] for v in steps.values()),
        "steps": steps,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--part", type=int, default=25_000)
    ap.add_argument("--seed", type=int, default=17)
    ap.add_argument("--data", default=str(ROOT / "data" / "benchmark" / "study"))
    ap.add_argument("--steps", nargs="+", default=["simulate", "post"], choices=["simulate", "post"])
    ap.add_argument("--post-rows", type=int, help="post-process only the first rows (scaling runs)")
    ap.add_argument("--out", default=str(ROOT / "reports" / "benchmark.json"))
    args = ap.parse_args()
    data = Path(args.data)
    if "simulate" in args.steps:
        res = simulate(args.n, args.part, args.seed, data)
        print(json.dumps(res, indent=2))
        (data / "simulate.json").write_text(json.dumps(res, indent=2) + "\n")
    if "post" in args.steps:
        res = post(data, args.post_rows, data.parent / "study_out")
        print(json.dumps(res, indent=2))
        if args.post_rows is None:
            out = Path(args.out)
            report = json.loads(out.read_text()) if out.exists() else {}
            sim_json = data / "simulate.json"
            report["study"] = {
                "machine": {"cpus": os.cpu_count()},
                "simulate": json.loads(sim_json.read_text()) if sim_json.exists() else None,
                "post": res,
            }
            out.write_text(json.dumps(report, indent=2) + "\n")


if __name__ == "__main__":
    main()
