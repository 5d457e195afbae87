"""``hev benchmark-run SOURCE``: the runs of the equal-budget, many-seed benchmark of every source (its own
pipeline, ``benchmarks/surrogate/dvc.yaml``; not part of the default ``dvc repro``; scored by
``hev benchmark-report``, :mod:`stages.benchmark_report`).

Each run is written as soon as it ends (``data/benchmark/runs/<source>/run_<k>.parquet``) and a run
already on disk with the same settings, simulator and run code is not run again, so an interrupted benchmark
resumes where it stopped (``--fresh`` runs everything again)."""

from __future__ import annotations

import hashlib
import json
import time
from functools import partial
from pathlib import Path

import pyarrow.parquet as pq
import typer

from hevlib.codedeps import closure_hash
from hevlib.design import DESIGN_VARS, RESPONSES
from hevlib.doe import simulation_fingerprint
from hevlib.io import read_table, write_parquet
from hevlib.params import BENCHMARK_SOURCES
from stages.cli import app
from stages.common import BENCHMARK_RUNS_DIR, PARAMS_OPTION, params_from, progress_callback, stage
from stages.doe import DOE
from stages.simulating import sizing_setup

ROOT = Path(__file__).resolve().parents[1]
#: The code a stored run executes besides the simulator (whose source is in the simulation fingerprint): the
#: benchmark's run drivers with everything they import (optimisers, surrogates, and through them the sizing problem
#: shared with ``hev optimise``). An edit there runs every seed again; a report or plot edit does not.
RUN_CODE_MODULES: tuple[str, ...] = ("hevlib.benchmark.runs",)


def _settings_fingerprint(cfg, source: str, root: Path = ROOT) -> str:
    """What a stored run depends on: the simulator, the code that runs it (``RUN_CODE_MODULES``), the study's
    optimiser and surrogate settings, the screen, and this source's benchmark settings."""
    blob = json.dumps(
        {
            "sim": simulation_fingerprint(cfg),
            "code": closure_hash(root, RUN_CODE_MODULES),
            **cfg.model_dump(mode="json", include={"design_space", "surrogate", "optimise", "screen", "doe"}),
            "benchmark": cfg.benchmark.model_dump(mode="json", exclude={"sources", "seeds", "oracle_seeds"}),
            "source": source,
        },
        sort_keys=True,
    )
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def run_path(source: str, run: int, runs_dir: Path = BENCHMARK_RUNS_DIR) -> Path:
    return Path(runs_dir) / source / f"run_{run}.parquet"


@app.command("benchmark-run")
@stage
def benchmark_run_stage(
    source: str = typer.Argument(
        ..., help="nsga3, moead, moga, parego, nehvi, tsparego, nsga3_direct, moead_direct, lhs or oracle"
    ),
    params: str = PARAMS_OPTION,
    fresh: bool = typer.Option(False, "--fresh", help="run every seed again, even those already on disk"),
    runs_dir: Path = typer.Option(BENCHMARK_RUNS_DIR, "--runs-dir", help="where the runs are written"),
) -> None:
    """Run SOURCE's benchmark seeds; write data/benchmark/runs/SOURCE/run_<k>.parquet (every simulation)."""
    from hevlib.benchmark.runs import RUN_SCHEMA, RunContext, n_runs, run_seed, run_source  # optimisers: pymoo
    from hevlib.optimise.problem import sizing_problem

    cfg = params_from(params)
    if source not in BENCHMARK_SOURCES:
        raise ValueError(f"benchmark-run: unknown source {source!r} (use one of {', '.join(BENCHMARK_SOURCES)})")
    if cfg.optimise is None:
        raise ValueError("params.yaml: optimise: group missing (the benchmark runs the study's optimisers)")
    fingerprint = _settings_fingerprint(cfg, source)
    todo = []
    for k in range(n_runs(cfg, source)):
        path = run_path(source, k, runs_dir)
        if not fresh and path.exists():
            meta = pq.read_schema(path).metadata or {}
            if meta.get(b"hev.benchmark_fingerprint", b"").decode() == fingerprint:
                continue
        todo.append(k)
    if not todo:
        typer.echo(f"benchmark-run {source}: all {n_runs(cfg, source)} runs on disk are current")
        return
    sim, cycle = sizing_setup(cfg)
    doe = read_table(DOE)
    X_doe = doe[list(DESIGN_VARS)].to_numpy(dtype=float)
    R_doe = doe[list(RESPONSES)]
    simulate = sim.on_cycle(cycle, cfg.doe.batch_size)

    for k in todo:
        t0 = time.perf_counter()
        with progress_callback(f"benchmark {source}: run {k + 1}/{n_runs(cfg, source)}") as cb:
            ctx = RunContext(cfg, simulate, partial(sizing_problem, cfg, sim.mass_kg), X_doe, R_doe, cb)
            table = run_source(ctx, source, k)
        wall = time.perf_counter() - t0
        out = run_path(source, k, runs_dir)
        write_parquet(
            out,
            table,
            RUN_SCHEMA,
            metadata={
                "hev.benchmark_fingerprint": fingerprint,
                "hev.source": source,
                "hev.run": k,
                "hev.seed": run_seed(cfg.benchmark.seed, source, k),
                "hev.wall_s": f"{wall:.1f}",
                "hev.cycle": cycle.name,
            },
        )
        typer.echo(f"benchmark-run {source}: run {k} ({table.num_rows} simulations) in {wall:.0f} s -> {out}")
