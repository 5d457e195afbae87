"""``hev benchmark-report``: score every run of the benchmark (``hev benchmark-run``, :mod:`stages.benchmark`)
on one judged object and normalisation. It simulates nothing, so its code deps leave the simulator out."""

from __future__ import annotations

from pathlib import Path

import typer

from stages.cli import app
from stages.common import BENCHMARK_RUNS_DIR, PARAMS_OPTION, REFERENCE, params_from, progress_callback, stage

REPORT_DIR = Path("reports/benchmark")


@app.command("benchmark-report")
@stage
def benchmark_report_stage(
    params: str = PARAMS_OPTION,
    runs_dir: Path = typer.Option(BENCHMARK_RUNS_DIR, "--runs-dir", help="where the runs are"),
    out_dir: Path = typer.Option(REPORT_DIR, "--out", help="where the report goes"),
) -> None:
    """Score every run on one judged object and normalisation; write reports/benchmark/summary.json,
    curves.csv, runs.csv and anytime.png."""
    from hevlib.benchmark.report import benchmark_report

    cfg = params_from(params)
    with progress_callback("benchmark: scoring runs") as cb:
        out = benchmark_report(cfg, runs_dir, REFERENCE, out_dir, progress=cb)
    typer.echo(out)
