"""``hev engine-map`` and ``hev wheel-regen``: parts of a car of today, each an ADVISOR file with one published
curve written into it (an engine's efficiency against load; a power split's regenerative share of braking)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import typer

from stages.cli import app
from stages.common import stage


def _write_derived(source: Path, curve: str, curves: Mapping, derive: Callable, render: Callable, out: Path) -> None:
    """Check the curve's name and the source file (one line each), then write ``render(derive(source, curve))``."""
    if curve not in curves:
        raise typer.BadParameter(f"{curve!r} is not one of {', '.join(curves)}", param_hint="--curve")
    if not source.is_file():
        raise typer.BadParameter(f"{source}: no such file", param_hint="--source")
    from hevlib.io import write_text

    write_text(out, render(derive(source, curve)))


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

    _write_derived(source, curve, CURVES, engine_file, render, out)
    typer.echo(f"engine-map: {source.name} re-levelled to {curve} -> {out}")


@app.command("wheel-regen")
@stage
def wheel_regen(
    source: Path = typer.Option(
        ..., "--source", help="the wheel file whose other values stay, e.g. data/raw/components/WH_PRIUS_JPN.yaml"
    ),
    curve: str = typer.Option(
        ..., "--curve", help="the published regeneration curve (hevlib/regen_curves.py CURVES: fastsim_prius_2016)"
    ),
    out: Path = typer.Option(..., "--out", help="wheel file to write (beside the source, to be named in params)"),
) -> None:
    """Write a wheel file whose driveline share of braking is a published regeneration curve (FASTSim's), the
    motor, battery and tyre limits capping it in the drive step (hevlib/regen_curves.py)."""
    from hevlib.engine_curves import render
    from hevlib.regen_curves import CURVES, wheel_file

    _write_derived(source, curve, CURVES, wheel_file, render, out)
    typer.echo(f"wheel-regen: {source.name} braking blended by {curve} -> {out}")
