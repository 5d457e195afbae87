"""What the pins of ``hevlib.determinism`` cost: the project's numeric workloads timed pinned (``hev``'s
environment: numpy's baseline kernels, OpenBLAS Nehalem on one thread, torch's default capability, MKL
COMPATIBLE, glibc's libm without FMA) against native (``HEV_NATIVE_CPU=1``: each library's fastest path for this
CPU), each in a fresh process, the two interleaved, best of ``--rounds``.

    .venv/bin/python benchmarks/bench_determinism.py [--rounds 3]   # -> reports/benchmark.json: "determinism"

Workloads (the study's settings, synthetic data where a fit needs no simulator):

* ``bnn_fit``: the BNN (11 per-objective 7-8-1 networks, 2 restarts each, trainbr) on 427 designs, the size of
  the last infill round's training set;
* ``bnn_predict``: 500 predictions with the Laplace standard deviation of 200 designs, an SAEA's search;
* ``gp_fit``: ParEGO's eleven GPs on 250 designs (torch, L-BFGS);
* ``simulate``: 2 000 designs on the graded UDDS (the numba kernels; glibc's ``exp`` and ``pow``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
WORKLOADS = ("bnn_fit", "bnn_predict", "gp_fit", "simulate")


def _data(n: int, seed: int = 0):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_surrogates import synthetic_targets

    from hevlib.doe import lhs_designs
    from hevlib.params import load_params

    p = load_params(ROOT / "params.yaml")
    space = p.design_space.space()
    X = lhs_designs(space, n, seed)
    return p, space, X, synthetic_targets(X, space.lower, space.upper, tuple(p.surrogate.bnn.log_targets))


def worker(name: str) -> float:
    """Seconds the workload ``name`` takes in this process (set-up excluded)."""
    if name in ("bnn_fit", "bnn_predict"):
        from hevlib.surrogates.bnn import BayesRegMLP

        p, space, X, Y = _data(427)
        model = BayesRegMLP.from_params(space, p.surrogate.bnn)
        t0 = time.perf_counter()
        model.fit(X, Y)
        if name == "bnn_fit":
            return time.perf_counter() - t0
        t0 = time.perf_counter()
        for k in range(500):
            model.predict(X[(k % 2) * 200 : (k % 2) * 200 + 200], return_std=True)
        return time.perf_counter() - t0
    if name == "gp_fit":
        from hevlib.surrogates.gp import GaussianProcesses

        p, space, X, Y = _data(250)
        t0 = time.perf_counter()
        GaussianProcesses(space, p.surrogate.bnn.log_targets, 250, seed=0).fit(X, Y)
        return time.perf_counter() - t0
    if name == "simulate":
        from hevlib.cycles import build_cycles
        from hevlib.doe import lhs_designs
        from hevlib.params import load_params
        from hevlib.sim.simulator import Simulator
        from hevlib.sizing import study_library

        p = load_params(ROOT / "params.yaml")
        p = p.model_copy(
            update={
                "cycles": p.cycles.model_copy(update={"raw_dir": str(ROOT / p.cycles.raw_dir)}),
                "baseline": p.baseline.model_copy(update={"components_dir": str(ROOT / p.baseline.components_dir)}),
            }
        )
        sim = Simulator(study_library(p.baseline), p)
        cycle = build_cycles(p.cycles)[p.cycles.sizing]
        X = lhs_designs(sim.space, 2000, 1)
        sim.run(X[:50], cycle)  # kernels loaded from the cache
        t0 = time.perf_counter()
        sim.run(X, cycle, batch_size=2000)
        return time.perf_counter() - t0
    raise ValueError(f"unknown workload {name!r}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--worker", choices=WORKLOADS)
    args = ap.parse_args()
    if args.worker:
        if not os.environ.get("HEV_NATIVE_CPU"):
            from hevlib.determinism import ensure_pinned

            ensure_pinned(sys.argv)
        print(json.dumps({"s": worker(args.worker)}))
        return
    from hevlib import determinism

    clean = {k: v for k, v in os.environ.items() if k not in determinism.PINNED and k != "HEV_PINNED_EXEC"}
    envs = {"pinned": determinism.pinned_environ(clean), "native": {**clean, determinism.OFF_SWITCH: "1"}}
    times: dict[str, dict[str, list[float]]] = {w: {k: [] for k in envs} for w in WORKLOADS}
    for r in range(args.rounds):
        for w in WORKLOADS:
            for kind, env in envs.items():
                out = subprocess.run(
                    [sys.executable, __file__, "--worker", w], env=env, capture_output=True, text=True, check=True
                )
                times[w][kind].append(json.loads(out.stdout.strip().splitlines()[-1])["s"])
                print(f"round {r + 1}: {w:12s} {kind:6s} {times[w][kind][-1]:7.2f} s", flush=True)
    result = {
        "what": __doc__.split("\n\n")[0].replace("\n", " "),
        "rounds": args.rounds,
        "best_s": {w: {k: min(v) for k, v in t.items()} for w, t in times.items()},
        "all_s": times,
        "pinned_over_native": {w: min(t["pinned"]) / min(t["native"]) for w, t in times.items()},
    }
    path = ROOT / "reports" / "benchmark.json"
    report = json.loads(path.read_text()) if path.exists() else {}
    report["determinism"] = result
    from hevlib.io import write_json

    write_json(path, report)
    for w in WORKLOADS:
        b = result["best_s"][w]
        print(
            f"{w:12s} pinned {b['pinned']:7.2f} s  native {b['native']:7.2f} s  x{result['pinned_over_native'][w]:.2f}"
        )


if __name__ == "__main__":
    main()
