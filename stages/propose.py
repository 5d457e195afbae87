"""``hev propose``: a starting profile for another car, its gear ratios and design space scaled from params.yaml's
car (hevlib/proposal.py)."""

from __future__ import annotations

from pathlib import Path

import typer

from stages.cli import app
from stages.common import PARAMS_OPTION, stage


@app.command("propose")
@stage
def propose(
    mass_kg: float = typer.Option(..., "--mass-kg", help="the car's test mass (kg)"),
    power_kw: float = typer.Option(..., "--power-kw", help="its rated engine power (kW)"),
    wheel_radius_m: float | None = typer.Option(
        None, "--wheel-radius-m", help="its wheels' rolling radius (m; else params.yaml's)"
    ),
    drag_coefficient: float | None = typer.Option(None, "--drag-coefficient", help="its Cd (else params.yaml's)"),
    frontal_area_m2: float | None = typer.Option(
        None, "--frontal-area-m2", help="its frontal area (m2; else params.yaml's)"
    ),
    out: Path | None = typer.Option(None, "--out", help="profile file to write, e.g. profiles/suv.yaml (else stdout)"),
    params: str = PARAMS_OPTION,
) -> None:
    """Write a starting params profile for a car of this test mass and engine power: gear ratios and a design
    space scaled from params.yaml's car (lower bounds with mass, upper with power, ratios with the wheel radius)."""
    from hevlib.proposal import Reference, check_proposal, read_params, render
    from hevlib.proposal import propose as make

    raw = read_params(params)
    proposal = make(Reference.from_params(raw), mass_kg, power_kw, wheel_radius_m, drag_coefficient, frontal_area_m2)
    check_proposal(proposal, raw, params)
    text = render(proposal, out.stem if out is not None else "NAME", mass_kg, power_kw, wheel_radius_m)
    if out is None:
        typer.echo(text, nl=False)
        return
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    typer.echo(
        f"{out}: a starting point for a {mass_kg:g} kg, {power_kw:g} kW car; use it with: "
        f"dvc exp run $(hev profile {out.stem})"
    )
