"""Simulator throughput and memory: design-cycles per second and peak memory vs batch size.

    python benchmarks/bench_simulator.py [--sizes 1 100 1000 10000] [--repeat 3] [--out reports/benchmark.json]

Each batch size runs in its own subprocess (so peak RSS is that run's own), on random designs (seeded
Latin hypercube over the design space) on UDDS at the sizing grade (20 %) and flat. Timed after a warm-up
call (numba compilation excluded, it is reported separately). ``drive``: the cycle kernel alone;
``full``: what ``Simulator.run`` does per design (cycle + flat-road performance tests + responses).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _one(n: int, repeat: int) -> dict:
    """Measure one batch size in this process."""
    import numba
    import numpy as np

    from hevlib.cycles import build_cycles
    from hevlib.doe import lhs_designs
    from hevlib.params import load_params
    from hevlib.scaling import study_library
    from hevlib.simulate import Simulator

    params = load_params(ROOT / "params.yaml")
    params = params.model_copy(
        update={
            "cycles": params.cycles.model_copy(update={"raw_dir": str(ROOT / params.cycles.raw_dir)}),
            "baseline": params.baseline.model_copy(
                update={"components_dir": str(ROOT / params.baseline.components_dir)}
            ),
        }
    )
    sim = Simulator(study_library(params.baseline, ROOT / "data" / "raw" / "paper"), params)
    udds = build_cycles(params.cycles)["udds"]
    X = lhs_designs(params.design_space.space(), max(n, 2), seed=2026)[:n]
    t0 = time.perf_counter()
    sim.run(X[:1], udds)  # compile (or load the numba cache)
    warmup_s = time.perf_counter() - t0
    out = {"n_designs": n, "threads": numba.get_num_threads(), "warmup_s": warmup_s}
    for label, cyc in (("udds_grade20", udds), ("udds_flat", udds.with_grade(0.0))):
        drive, full = [], []
        for _ in range(repeat):
            t0 = time.perf_counter()
            sim.run_raw(X, cyc, performance=False)
            drive.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            sim.run(X, cyc, batch_size=n)
            full.append(time.perf_counter() - t0)
        out[label] = {
            "drive_s": min(drive),
            "full_s": min(full),
            "drive_design_cycles_per_s": n / min(drive),
            "full_design_cycles_per_s": n / min(full),
        }
    tracemalloc.start()
    sim.run(X, udds, batch_size=n)
    out["peak_traced_alloc_mib"] = tracemalloc.get_traced_memory()[1] / 2**20
    tracemalloc.stop()
    out["peak_rss_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    out["design_steps"] = int(n * udds.n_steps)
    del np
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1, 100, 1000, 10000])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=str(ROOT / "reports" / "benchmark.json"))
    ap.add_argument("--one", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one is not None:
        print(json.dumps(_one(args.one, args.repeat)))
        return
    rows = []
    for n in args.sizes:
        res = subprocess.run(
            [sys.executable, __file__, "--one", str(n), "--repeat", str(args.repeat)],
            capture_output=True,
            text=True,
            check=True,
            cwd=ROOT,
        )
        rows.append(json.loads(res.stdout.strip().splitlines()[-1]))
    head = (
        f"{'designs':>8} {'UDDS 20%: drive dc/s':>21} {'full dc/s':>10} {'flat: drive dc/s':>17} "
        f"{'full dc/s':>10} {'peak RSS MiB':>13} {'traced MiB':>11}"
    )
    print(head)
    for r in rows:
        g, f = r["udds_grade20"], r["udds_flat"]
        print(
            f"{r['n_designs']:>8} {g['drive_design_cycles_per_s']:>21.0f} {g['full_design_cycles_per_s']:>10.0f} "
            f"{f['drive_design_cycles_per_s']:>17.0f} {f['full_design_cycles_per_s']:>10.0f} "
            f"{r['peak_rss_mib']:>13.0f} {r['peak_traced_alloc_mib']:>11.1f}"
        )
    single = next((r for r in rows if r["n_designs"] == 1), None)
    if single:
        print(f"one design, full response on UDDS 20 %: {single['udds_grade20']['full_s'] * 1e3:.1f} ms")
    report = {
        "machine": {
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
            "processor": platform.processor() or platform.machine(),
        },
        "cycle": "udds (1370 steps of 1 s)",
        "results": rows,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(report, indent=2) + "\n")


if __name__ == "__main__":
    main()
