"""``hev check-metrics``: fail when a guarded metric moved beyond its tolerance (CI's regression gate)."""

from __future__ import annotations

from pathlib import Path

import typer

from hevlib.regression_check import compare, load_tolerances, table
from stages.cli import app
from stages.common import stage


@app.command("check-metrics")
@stage
def check_metrics(
    baseline: Path = typer.Option(Path("ci/fast_baseline"), "--baseline", help="folder of baseline metrics JSON"),
    current: Path = typer.Option(Path("reports"), "--current", help="folder of the fresh run's metrics JSON"),
    tolerances: Path = typer.Option(Path("ci/metrics_tolerances.yaml"), "--tolerances", help="tolerance file"),
    show_all: bool = typer.Option(False, "--all", help="show every metric, not only guarded or changed ones"),
) -> None:
    """Compare every metric of BASELINE/*.json with CURRENT/*.json; exit 1 on a regression."""
    rows = compare(baseline, current, load_tolerances(tolerances))
    typer.echo(table(rows, all_rows=show_all))
    bad = [r for r in rows if not r.ok]
    guarded = sum(r.rule is not None for r in rows)
    if bad:
        typer.echo(f"check-metrics: {len(bad)} of {guarded} guarded metrics regressed", err=True)
        raise typer.Exit(code=1)
    typer.echo(f"check-metrics: all {guarded} guarded metrics within tolerance")
