"""``hev car MAKE MODEL``: a params profile for one car of the EPA test car list (issue 52; hevlib/epa.py)."""

from __future__ import annotations

from pathlib import Path

import typer

from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, stage


@app.command("car")
@stage
def car(
    make: str = typer.Argument(..., help="Represented Test Veh Make, e.g. TOYOTA (any case)"),
    model: str = typer.Argument(..., help="Represented Test Veh Model, e.g. COROLLA (the whole name, any case)"),
    config: int | None = typer.Option(None, "--config", help="Test Veh Configuration # (where a model has several)"),
    vehicle_id: str | None = typer.Option(None, "--vehicle-id", help="Test Vehicle ID (where a model has several)"),
    line: int | None = typer.Option(None, "--line", help="the file line of one of its tests (where tests disagree)"),
    out: Path | None = typer.Option(
        None, "--out", help="profile file to write, e.g. profiles/corolla.yaml (else stdout)"
    ),
    table: Path = typer.Option(Path("data/raw/epa/test_car_list_2022.csv"), "--table", help="the EPA test car list"),
    params: str = PARAMS_OPTION,
) -> None:
    """Write a params profile for a car of the EPA test car list: its test mass, coast-down road load, engine
    power and gears (a power-split hybrid: the stock Prius's test mass, road load, tyre and axle ratio)."""
    from hevlib.epa import car_profile, check_profile, find_car, read_test_car_list, render_profile

    p = params_from(params)
    found = find_car(
        read_test_car_list(table), make, model, config=config, vehicle_id=vehicle_id, line=line, source=table
    )
    entries = car_profile(found, p.baseline, table, p.epa)
    check_profile(entries, params)
    text = render_profile(found, entries, out.stem if out is not None else "NAME")
    if out is None:
        typer.echo(text, nl=False)
        return
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    typer.echo(f"{out}: {found.name} ({found.kind}); use it with: dvc exp run $(hev profile {out.stem})")
