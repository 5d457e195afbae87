"""``hev engine-map``: an engine file of another technology, an ADVISOR map re-levelled to a published curve."""

from __future__ import annotations

from pathlib import Path

import typer

from stages.cli import app
from stages.common import stage


@app.command("engine-map")
@stage
def engine_map(
    source: Path = typer.Option(
        ..., "--source", help="the engine file whose map gives the shape, e.g. data/raw/components/FC_SI63_emis.yaml"
    ),
    curve: str = typer.Option(
        ...,
        "--curve",
        help="the published efficiency curve (hevlib/engine_curves.py CURVES: fastsim_si, fastsim_prius_2016)",
    ),
    out: Path = typer.Option(..., "--out", help="engine file to write (beside the source, to be named in params)"),
) -> None:
    """Write an engine file whose best-efficiency line follows a published efficiency-versus-load curve (FASTSim's
    generic curves), the source map giving where on the map that efficiency is reached (hevlib/engine_curves.py)."""
    from hevlib.engine_curves import CURVES, engine_file, render

    if curve not in CURVES:
        raise typer.BadParameter(f"{curve!r} is not one of {', '.join(CURVES)}", param_hint="--curve")
    if not source.is_file():
        raise typer.BadParameter(f"{source}: no such file", param_hint="--source")
    from hevlib.io import write_text

    write_text(out, render(engine_file(source, curve)))
    typer.echo(f"engine-map: {source.name} re-levelled to {curve} -> {out}")
