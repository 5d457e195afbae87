"""``hev predict``: evaluate a fitted surrogate on a table of designs."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hevlib.design import read_designs
from stages.cli import app
from stages.common import stage

MODELS = Path("models")


@app.command("predict")
@stage
def predict(
    model: Annotated[str, typer.Option("--model", help="bnn or regression")],
    designs: Annotated[Path, typer.Option("--designs", help="CSV/Parquet table with the 7 design columns")],
    out: Annotated[Path, typer.Option("--out", help="output table (.csv or .parquet)")],
    models_dir: Annotated[Path, typer.Option("--models-dir", help="folder with the fitted models")] = MODELS,
) -> None:
    """Write the designs plus the 11 predicted objectives (and <key>_std for the BNN) to --out.

    All in natural units and inside each objective's physical range (no negative fuel, mass, emission or
    deviation; speed_dev at most 1); for the BNN's log-transformed objectives the value is the median
    back-transform and <key>_std the delta-method standard deviation (hevlib/surrogates/transform.py)."""
    from hevlib.surrogates.metrics import load_surrogate, prediction_table, write_prediction_table

    if out.suffix.lower() not in (".csv", ".parquet"):
        raise ValueError(f"{out}: unsupported output format (use .csv or .parquet)")
    surrogate = load_surrogate(model, models_dir)
    X = read_designs(designs, surrogate.space, integers=False)  # the model's own space; its lines named
    table = prediction_table(surrogate, X)
    write_prediction_table(out, table)
    typer.echo(f"predict: {len(table)} designs with {model} -> {out}")
