"""One answer on every machine: the fast profile of the whole pipeline (simulation, surrogates, every optimiser,
pareto, validate) and the benchmark's run paths (ParEGO's GP on torch, an SAEA on the BNN) give byte-identical
outputs under two emulated x86-64 CPU kinds.

Each kind is an environment that makes the numeric libraries take the code paths (and thread counts) they would
pick on another CPU: numpy's SIMD dispatch, OpenBLAS's kernel, torch's ATen capability and MKL's code path,
glibc's libm variant (FMA or not), numba's target CPU, and the thread counts of numba, OpenBLAS and OpenMP.
``hev`` pins what changes the rounding (``hevlib.determinism``), so the two runs must agree byte for byte; before
that pin they did not (the surrogates' weights, every front, the shortlist and the recommended design moved).

The seed-spread study (``hev robustness``, two replicates) runs too: its replicate 0 must give the default
pipeline's answer byte for byte. The two kinds run side by side (each pipeline keeps about one core busy on
average: its stages run one at a time and most of them on one thread), about 15 minutes on 2 cores; CI runs it
as its own step (``pytest -m cpukinds``, ``.ci/run``).
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
import yaml
from conftest import CPU_KINDS, copy_repo, unpinned_environ

from hevlib.profiles import apply_overrides, load_profile

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
pytestmark = [pytest.mark.slow, pytest.mark.cpukinds, pytest.mark.timeout(3600)]

#: The benchmark's runs at a small budget: ParEGO (BoTorch on torch, scipy's SLSQP) and NSGA-III on the BNN,
#: one seed each. (The fast pipeline runs both BoTorch sources too.)
BENCHMARK = {
    "benchmark.seeds": 1,
    "benchmark.oracle_seeds": 1,
    "benchmark.budget": 87,
    "benchmark.direct_budget": 87,
    "benchmark.budgets": [50, 87],
    "optimise.bayes.parego.batch": 10,
    "optimise.bayes.parego.raw_samples": 16,
    "optimise.bayes.parego.num_restarts": 1,
    "optimise.bayes.parego.mc_samples": 8,
}
BENCHMARK_SOURCES = ("parego", "nsga3")
#: The seed-spread study at its smallest: replicate 0 (the params' seeds) and one more.
ROBUSTNESS = {"robustness.seeds": 2}
#: Everything the runs write that a user keeps (logs/, the replicates' included, holds wall times: left out).
OUTPUTS = ("data", "models", "reports")


#: Parquet metadata that records how long a run took (a benchmark run's ``hev.wall_s``): a measurement, not a
#: result, so the digest of such a file is its bytes rewritten without it (every other byte still compared).
TIMING_METADATA = (b"hev.wall_s",)


def _digest(path: Path) -> str:
    if path.suffix == ".parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        meta = pq.read_schema(path).metadata or {}
        if any(k in meta for k in TIMING_METADATA):
            table = pq.read_table(path)
            table = table.replace_schema_metadata({k: v for k, v in meta.items() if k not in TIMING_METADATA})
            sink = pa.BufferOutputStream()
            with pa.ipc.new_stream(sink, table.schema) as writer:
                writer.write_table(table)
            return "timing-free " + hashlib.sha256(sink.getvalue().to_pybytes()).hexdigest()
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _digests(base: Path) -> dict[str, str]:
    out = {}
    for top in OUTPUTS:
        for f in sorted((base / top).rglob("*")):
            rel = f.relative_to(base)
            if f.is_file() and rel.parts[:2] != ("data", "raw") and "logs" not in rel.parts:
                out[str(rel)] = _digest(f)
    return out


def _run_kind(dest: Path, kind: dict[str, str]) -> dict[str, str]:
    copy_repo(REPO, dest)
    params = yaml.safe_load((dest / "params.yaml").read_text())
    overrides = {**load_profile("fast", dest / "params.yaml", dest / "profiles"), **BENCHMARK, **ROBUSTNESS}
    (dest / "params.yaml").write_text(yaml.safe_dump(apply_overrides(params, overrides), sort_keys=False))
    env = {**unpinned_environ(), **kind}
    env.update({"PATH": f"{BIN}{os.pathsep}{env.get('PATH', '')}", "PYTHONPATH": str(dest), "DVC_NO_ANALYTICS": "1"})

    def run(*cmd: str) -> None:
        out = subprocess.run(cmd, cwd=dest, env=env, capture_output=True, text=True, timeout=1800)
        assert out.returncode == 0, f"{' '.join(cmd)}:\n{out.stdout[-3000:]}\n{out.stderr[-3000:]}"

    run("git", "init", "-q")
    run("dvc", "repro")
    for source in BENCHMARK_SOURCES:
        run("hev", "benchmark-run", source)
    run("dvc", "repro", "benchmarks/robustness/dvc.yaml")
    return _digests(dest)


def test_two_cpu_kinds_give_the_same_bytes(tmp_path):
    # side by side: each kind's commands are subprocesses of their own, in a copy of their own
    with ThreadPoolExecutor(len(CPU_KINDS)) as pool:
        runs = {name: pool.submit(_run_kind, tmp_path / name, kind) for name, kind in CPU_KINDS.items()}
        digests = {name: run.result() for name, run in runs.items()}
    # the seed-spread study's replicate 0 reruns the default pipeline's chain with its seeds: the same answer
    host = tmp_path / next(iter(CPU_KINDS))
    rep0 = json.loads((host / "data/robustness/runs/rep_0/reports/validation.json").read_text())
    main = json.loads((host / "reports/validation.json").read_text())
    assert rep0["recommendation"] == main["recommendation"]
    assert (host / "data/robustness/runs/rep_0/reports/answer.json").read_bytes() == (
        host / "reports/answer.json"
    ).read_bytes()
    a, b = digests.values()
    assert any(k.startswith("data/benchmark/runs/parego/") for k in a) and "reports/validation.json" in a
    assert "reports/robustness/summary.json" in a and "data/robustness/runs/rep_1/reports/validation.json" in a
    differ = sorted(k for k in a.keys() | b.keys() if a.get(k) != b.get(k))
    assert not differ, f"{len(differ)} of {len(a)} outputs differ between {' and '.join(CPU_KINDS)}: " + ", ".join(
        differ
    )
