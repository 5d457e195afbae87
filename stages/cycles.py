"""``hev cycles``: load, check and resample the drive cycles, attach their road grades."""

from __future__ import annotations

from pathlib import Path

import typer

from hevlib.cycles import build_cycles, write_cycles
from hevlib.plots.cycles import plot_speed_traces
from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, stage

OUT_DIR = Path("data/cycles")
REPORT = Path("reports/cycles.json")
PLOT = Path("reports/plots/cycles.png")


@app.command("cycles")
@stage
def cycles(params: str = PARAMS_OPTION) -> None:
    """Write data/cycles/<name>.parquet, reports/cycles.json and the sizing/validation speed traces."""
    cfg = params_from(params).cycles
    built = build_cycles(cfg)
    write_cycles(built, OUT_DIR, REPORT)
    plot_speed_traces([built[cfg.sizing], built[cfg.validation]], PLOT)
    typer.echo(f"cycles: {', '.join(built)} -> wrote {OUT_DIR}/<name>.parquet, {REPORT}, {PLOT}")
