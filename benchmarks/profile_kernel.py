"""Where the drive kernel spends its time: Linux ``perf`` samples, attributed to the numba-compiled functions.

    python benchmarks/profile_kernel.py [--case ftp] [--designs 3000] [--top 15]

numba's JIT code has no symbols ``perf`` can read, so the profiled process (a child run under ``perf record``)
compiles the kernels into an empty cache (only freshly compiled libraries keep their LLVM modules), drives the
designs, then writes ``/tmp/perf-<pid>.map`` (start, size, name of every compiled function, from the LLVM
module and the code addresses of each kernel's library), the map ``perf report`` reads for JIT code. Printed:
each function's share of the samples that fall in the kernel (compiled code and libm, whose ``pow`` the thermal
model calls), compile time excluded as far as it runs elsewhere (LLVM, Python). Functions numba inlines
(``inline="always"``) count in their caller. Needs ``perf`` (``linux-perf``) and permission to sample.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from bench_simulator import CASES  # this folder (the script's own) is on sys.path

ROOT = Path(__file__).resolve().parents[1]


def _child(case: str, n: int) -> None:
    """Drive ``n`` designs on ``case`` (one thread) and write the perf map of the compiled kernels."""
    import hevlib  # noqa: F401  (pins the numeric libraries before numpy loads)

    sys.path.insert(0, str(ROOT / "benchmarks"))
    import numba
    from bench_simulator import _setup, cases

    from hevlib.doe import lhs_designs
    from hevlib.sim import drive, performance

    numba.set_num_threads(1)
    sim, cycles = _setup()
    cycle = cases(cycles)[case]
    X = lhs_designs(sim.params.design_space.space(), n, seed=2026)
    sim.run_raw(X, cycle, performance=False)
    names = {}
    for dispatcher in (drive.drive_hybrid, drive.drive_conventional, *_dispatchers(performance)):
        for cres in dispatcher.overloads.values():
            lib = cres.library
            for fn in lib._final_module.functions:  # noqa: SLF001  (numba keeps no other list)
                if not fn.is_declaration:
                    address = lib.get_pointer_to_function(fn.name)
                    if address:
                        names[address] = _demangle(fn.name)
    starts = sorted(names)
    with open(f"/tmp/perf-{os.getpid()}.map", "w") as fh:
        for a, b in zip(starts, [*starts[1:], starts[-1] + 0x100000], strict=True):
            fh.write(f"{a:x} {min(b - a, 0x100000):x} {names[a]}\n")


def _dispatchers(module) -> list:
    return [v for v in vars(module).values() if hasattr(v, "overloads") and hasattr(v, "py_func")]


def _demangle(name: str) -> str:
    """``_ZN6hevlib3sim5drive11_hybrid_oneB...`` -> ``hevlib.sim.drive._hybrid_one``."""
    m = re.match(r"_ZN((?:\d+\w+?)+?)B\d", name)
    if not m:
        return name
    parts, s = [], m.group(1)
    while s:
        k = re.match(r"(\d+)", s)
        if not k:
            break
        size = int(k.group(1))
        start = len(k.group(1))
        parts.append(s[start : start + size])
        s = s[start + size :]
    return ".".join(parts)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", choices=CASES, default="ftp")
    ap.add_argument("--designs", type=int, default=3000)
    ap.add_argument("--top", type=int, default=15)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        _child(args.case, args.designs)
        return
    if shutil.which("perf") is None:
        sys.exit("error: perf is not installed (apt install linux-perf)")
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "perf.data"
        env = {**os.environ, "NUMBA_CACHE_DIR": str(Path(tmp) / "numba")}  # compile afresh: modules kept
        cmd = [sys.executable, __file__, "--child", "--case", args.case, "--designs", str(args.designs)]
        subprocess.run(["perf", "record", "-q", "-o", str(data), "--", *cmd], env=env, check=True)
        report = subprocess.run(
            ["perf", "report", "-i", str(data), "--no-children", "--sort", "dso,sym", "--stdio"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
    rows = []
    for line in report.splitlines():
        m = re.match(r"\s*([\d.]+)%\s+(\S+(?: tid \d+)?)\s+\[\.\]\s+(.+)", line)
        if m and ("JIT" in m.group(2) or m.group(2).startswith("libm")):
            rows.append((float(m.group(1)), m.group(3).strip()))
    total = sum(p for p, _ in rows)
    if not total:
        sys.exit("error: no samples in the kernel (is perf allowed to sample? kernel.perf_event_paranoid)")
    print(f"{args.case}, {args.designs} designs: share of the kernel's samples ({total:.1f} % of the process's)")
    for p, name in sorted(rows, reverse=True)[: args.top]:
        print(f"{100 * p / total:6.1f} %  {name}")


if __name__ == "__main__":
    main()
