"""``hev components``: load and normalise the component maps, check the mass model, plot the maps."""

from __future__ import annotations

from pathlib import Path

import typer

from hevlib.io import write_json
from hevlib.plots.maps import write_map_plots
from hevlib.sizing import study_library, study_report
from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, stage

OUT_DIR = Path("data/components")
REPORT = Path("reports/components.json")
PLOT_DIR = Path("reports/plots")


@app.command("components")
@stage
def components(params: str = PARAMS_OPTION) -> None:
    """Write data/components/ (normalised maps), reports/components.json and reports/plots/maps_*.png."""
    baseline = params_from(params).baseline
    lib = study_library(baseline)
    report = study_report(lib, baseline)
    lib.save(OUT_DIR)
    write_json(REPORT, report)
    write_map_plots(lib, PLOT_DIR)
    typer.echo(f"components: normalised maps -> wrote {OUT_DIR}, {REPORT}, {PLOT_DIR}/maps_*.png")
