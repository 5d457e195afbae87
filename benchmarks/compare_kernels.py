"""Drive-kernel throughput of this checkout against another (e.g. a worktree of the last release), interleaved.

    git worktree add /tmp/base <commit>
    python benchmarks/compare_kernels.py /tmp/base [--designs 1000] [--rounds 3] [--repeat 3]

Each round runs, for every case (UDDS at the sizing grade, flat UDDS, FTP with its key-off soak), one fresh
process per checkout, alternating, so that both see the same machine state. A process loads its own
checkout's ``hevlib`` (``PYTHONPATH``; its numba cache is keyed on its kernel sources), compiles on a first
call, then times ``Simulator.run_raw(..., performance=False)`` (the cycle kernel alone) on the same seeded
Latin-hypercube designs with one numba thread, ``--repeat`` times, keeping the least CPU time. Reported:
design-cycles per CPU second of each (median over rounds), the ratio's median and range, and whether both
checkouts give the same output bits (a SHA-256 of the accumulator array).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

from bench_simulator import CASES  # this folder (the script's own) is on sys.path

ROOT = Path(__file__).resolve().parents[1]


def _one(case: str, n: int, repeat: int) -> dict:
    """Time the drive kernel of the ``hevlib`` on ``sys.path`` on one case (run in a child process)."""
    import time  # noqa: I001  (hevlib first: it pins the numeric libraries before numpy loads)

    import hevlib  # noqa: F401
    import numba

    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_simulator import _setup, cases  # noqa: E402

    from hevlib.doe import lhs_designs

    numba.set_num_threads(1)
    sim, cycles = _setup(Path.cwd() / "params.yaml")
    cycle = cases(cycles)[case]
    X = lhs_designs(sim.params.design_space.space(), n, seed=2026)
    sim.run_raw(X[:2], cycle, performance=False)  # compile or load the cache
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.process_time()
        out = sim.run_raw(X, cycle, performance=False).out
        best = min(best, time.process_time() - t0)
    return {"design_cycles_per_cpu_s": n / best, "sha256": hashlib.sha256(out.tobytes()).hexdigest()}


def _measure(root: Path, case: str, n: int, repeat: int) -> dict:
    env = {**os.environ, "PYTHONPATH": str(root)}
    env.pop("NUMBA_CACHE_DIR", None)  # each checkout's own cache (hevlib keys it on its kernel sources)
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", case, "--designs", str(n), "--repeat", str(repeat)]
    done = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("other", nargs="?", type=Path, help="the other checkout (a worktree)")
    ap.add_argument("--designs", type=int, default=1000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=CASES)
    ap.add_argument("--out", type=Path, help="write the rounds and the summary as JSON")
    ap.add_argument("--child", choices=CASES, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(_one(args.child, args.designs, args.repeat)))
        return
    if args.other is None:
        ap.error("the other checkout is required")
    rounds = {case: [] for case in args.cases}
    for r in range(args.rounds):
        for case in args.cases:
            base = _measure(args.other.resolve(), case, args.designs, args.repeat)
            this = _measure(ROOT, case, args.designs, args.repeat)
            rounds[case].append({"round": r, "other": base, "this": this})
    summary = {}
    for case, runs in rounds.items():
        ratios = [x["this"]["design_cycles_per_cpu_s"] / x["other"]["design_cycles_per_cpu_s"] for x in runs]
        summary[case] = {
            "other_design_cycles_per_cpu_s": statistics.median(x["other"]["design_cycles_per_cpu_s"] for x in runs),
            "this_design_cycles_per_cpu_s": statistics.median(x["this"]["design_cycles_per_cpu_s"] for x in runs),
            "speedup_median": statistics.median(ratios),
            "speedup_min": min(ratios),
            "speedup_max": max(ratios),
            "same_bits": all(x["this"]["sha256"] == x["other"]["sha256"] for x in runs),
        }
        s = summary[case]
        print(
            f"{case:13s} other {s['other_design_cycles_per_cpu_s']:7.0f}  this {s['this_design_cycles_per_cpu_s']:7.0f}"
            f"  design-cycles/CPU-s  speedup {s['speedup_median']:.3f} ({s['speedup_min']:.3f}-{s['speedup_max']:.3f})"
            f"  same bits: {s['same_bits']}"
        )
    if args.out:
        meta = {"designs": args.designs, "rounds": args.rounds, "repeat": args.repeat, "other": str(args.other)}
        args.out.write_text(json.dumps({"settings": meta, "summary": summary, "rounds": rounds}, indent=2) + "\n")


if __name__ == "__main__":
    main()
