"""Simulator throughput and memory: design-cycles per second and peak memory vs batch size, the numba
compile time of a cold cache, and Dask throughput against worker count.

    python benchmarks/bench_simulator.py [--sizes 1 100 1000 10000] [--repeat 3]
        [--dask-workers 1 2] [--dask-designs 4000] [--no-cold-compile] [--out reports/benchmark.json]

Each batch size runs in its own subprocess (so peak RSS is that run's own), on random designs (seeded
Latin hypercube over the design space) on UDDS at the sizing grade (20 %), flat UDDS and FTP (cold start,
key-off soak included). Timed after a warm-up call (numba compilation excluded: the cold-cache compile is
timed in a subprocess with an empty ``NUMBA_CACHE_DIR``). ``drive``: the cycle kernel alone; ``full``:
what ``Simulator.run`` does per design (cycle + flat-road performance tests + responses). Dask: the same
designs on graded UDDS through ``sim.executor: dask`` on a ``LocalCluster`` of 1, 2, ... single-process
workers (start-up and the workers' numba cache load excluded by a first untimed run).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _one(n: int, repeat: int) -> dict:
    """Measure one batch size in this process."""
    import numba

    from hevlib.doe import lhs_designs

    sim, cycles = _setup()
    udds = cycles["udds"]
    X = lhs_designs(sim.params.design_space.space(), max(n, 2), seed=2026)[:n]
    t0 = time.perf_counter()
    sim.run(X[:1], udds)  # compile (or load the numba cache)
    warmup_s = time.perf_counter() - t0
    out = {"n_designs": n, "threads": numba.get_num_threads(), "warmup_s": warmup_s}
    for label, cyc in cases(cycles).items():
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
    return out


#: The simulator benchmarks' cases: UDDS at the sizing grade, flat UDDS, FTP (cold, key-off soak).
CASES = ("udds_grade20", "udds_flat", "ftp")


def cases(cycles: dict) -> dict:
    """The :data:`CASES` by label."""
    udds = cycles["udds"]
    return dict(zip(CASES, (udds, udds.with_grade(0.0), cycles["ftp"]), strict=True))


def _setup(params_path: Path = ROOT / "params.yaml", **sim_update):
    """The simulator on the repository's params (data paths absolute, ``sim`` keys overridden) and cycles."""
    from hevlib.cycles import build_cycles
    from hevlib.params import load_params
    from hevlib.sim.simulator import Simulator
    from hevlib.sizing import study_library

    params = load_params(params_path)
    params = params.model_copy(
        update={
            "cycles": params.cycles.model_copy(update={"raw_dir": str(ROOT / params.cycles.raw_dir)}),
            "baseline": params.baseline.model_copy(
                update={"components_dir": str(ROOT / params.baseline.components_dir)}
            ),
            "sim": params.sim.model_copy(update=sim_update),
        }
    )
    return Simulator(study_library(params.baseline), params), build_cycles(params.cycles)


def _cold_compile() -> dict:
    """Compile every kernel into an empty numba cache, twice (subprocesses: nothing compiled in this one): in
    one process, one kernel after the other (``compile_s``: what a stage that finds no cache pays), and as
    ``hev warmup`` does, each vehicle kind's kernels in a process of its own side by side (``warmup_s``)."""
    code = (
        "import time, sys; sys.path.insert(0, sys.argv[1]); t0 = time.perf_counter();"
        "from hevlib.params import load_params; from hevlib.sim.simulator import warm_up;"
        "from hevlib.warmup import timed_warm_up;"
        "p = load_params(sys.argv[1] + '/params.yaml');"
        "p = p.model_copy(update={'baseline': p.baseline.model_copy("
        "update={'components_dir': sys.argv[1] + '/' + p.baseline.components_dir})});"
        "warm_up(p) if sys.argv[2] == 'serial' else timed_warm_up(p);"
        "print(time.perf_counter() - t0)"
    )
    out = {}
    for how, key in (("serial", "compile_s"), ("side_by_side", "warmup_s")):
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, NUMBA_CACHE_DIR=cache)
            t0 = time.perf_counter()
            res = subprocess.run(
                [sys.executable, "-c", code, str(ROOT), how],
                env=env,
                capture_output=True,
                text=True,
                check=True,
                cwd=ROOT,
            )
            out[key] = float(res.stdout.strip().splitlines()[-1])
            out[key.replace("_s", "_process_s")] = time.perf_counter() - t0
    return out


def _dask(workers: list[int], n: int, batch: int) -> list[dict]:
    """Throughput of ``n`` designs on graded UDDS, ``batch`` designs per task, against worker count."""
    from hevlib.doe import lhs_designs

    rows = []
    for k in workers:
        sim, cycles = _setup(executor="dask", workers=k)
        X = lhs_designs(sim.params.design_space.space(), n, seed=2026)
        with sim:
            t0 = time.perf_counter()
            sim.run(X[: k * batch], cycles["udds"], batch_size=batch)  # cluster start, numba cache load
            start_s = time.perf_counter() - t0
            t0 = time.perf_counter()
            sim.run(X, cycles["udds"], batch_size=batch)
            wall = time.perf_counter() - t0
            threads = sim.executor._threads_per_worker()
        rows.append(
            {
                "workers": k,
                "kernel_threads_per_worker": threads,
                "n_designs": n,
                "batch_size": batch,
                "start_s": start_s,
                "wall_s": wall,
                "full_design_cycles_per_s": n / wall,
            }
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1, 100, 1000, 10000])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=str(ROOT / "reports" / "benchmark.json"))
    ap.add_argument("--dask-workers", type=int, nargs="*", default=[1, 2], help="LocalCluster sizes (none: skip)")
    ap.add_argument("--dask-designs", type=int, default=4000)
    ap.add_argument("--dask-batch", type=int, default=250, help="designs per Dask task")
    ap.add_argument("--no-cold-compile", action="store_true", help="skip the cold-cache compile timing")
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
    cold = None if args.no_cold_compile else _cold_compile()
    dask_rows = _dask(args.dask_workers, args.dask_designs, args.dask_batch) if args.dask_workers else []
    print(f"{'designs':>8} {'full design-cycles/s: UDDS 20 %':>32} {'UDDS flat':>10} {'FTP':>8} {'peak RSS MiB':>13}")
    for r in rows:
        g, f, ftp = r["udds_grade20"], r["udds_flat"], r["ftp"]
        print(
            f"{r['n_designs']:>8} {g['full_design_cycles_per_s']:>32.0f} {f['full_design_cycles_per_s']:>10.0f} "
            f"{ftp['full_design_cycles_per_s']:>8.0f} {r['peak_rss_mib']:>13.0f}"
        )
    single = next((r for r in rows if r["n_designs"] == 1), None)
    if single:
        print(f"one design, full response on UDDS 20 %: {single['udds_grade20']['full_s'] * 1e3:.1f} ms")
    if cold:
        print(
            f"numba compile, cold cache: {cold['compile_s']:.0f} s in one process; "
            f"hev warmup (one process per vehicle kind, side by side) {cold['warmup_s']:.0f} s"
        )
    for r in dask_rows:
        print(
            f"dask LocalCluster, {r['workers']} worker(s) x {r['kernel_threads_per_worker']} kernel thread(s): "
            f"{r['full_design_cycles_per_s']:.0f} design-cycles/s on UDDS 20 % ({r['n_designs']} designs, "
            f"{r['batch_size']} per task; start {r['start_s']:.1f} s)"
        )
    report = {
        "machine": {
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
            "processor": platform.processor() or platform.machine(),
        },
        "cycles": "udds (1370 steps of 1 s) at 20 % grade and flat; ftp (2477 steps, cold start, 600 s soak)",
        "results": rows,
        "numba_cold_compile": cold,
        "dask": dask_rows,
    }
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.exists():  # keep the other benchmarks' entries (bench_study.py writes "study")
        report = {**{k: v for k, v in json.loads(out.read_text()).items() if k not in report}, **report}
    out.write_text(json.dumps(report, indent=2) + "\n")


if __name__ == "__main__":
    main()
