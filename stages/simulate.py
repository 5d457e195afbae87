"""``hev simulate``: check designs by hand, or re-simulate them, on any cycle."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import typer

from hevlib.design import read_designs
from hevlib.io import write_table
from hevlib.sim.simulator import VEHICLES, with_inputs
from stages.cli import app
from stages.common import PARAMS_OPTION, cycle_named, params_from, simulator, stage

#: Designs ``--trace`` records at most (a trace is one row per step and design).
MAX_TRACED = 50


@app.command("simulate")
@stage
def simulate(
    designs: Path = typer.Option(None, "--designs", help="CSV or Parquet with the seven design-variable columns"),
    cycle: str = typer.Option(..., "--cycle", help="cycle name (data/cycles/<name>.parquet)"),
    grade: float = typer.Option(None, "--grade", help="road grade in percent; overrides the cycle's own grade"),
    vehicle: str = typer.Option("hybrid", "--vehicle", help="hybrid | conventional | prius"),
    out: Path = typer.Option(..., "--out", help="output table (.csv or .parquet)"),
    trace: Path = typer.Option(
        None,
        "--trace",
        help="also write per-step traces (speed, SOC, engine on/off, coolant and catalyst temperature, "
        f"engine-out and tailpipe rates; at most {MAX_TRACED} designs) to this table (.csv or .parquet)",
    ),
    params: str = PARAMS_OPTION,
) -> None:
    """Simulate designs (or a baseline) and write the inputs plus every response, one row per design."""
    p = params_from(params)
    if vehicle not in VEHICLES:
        raise ValueError(f"--vehicle: {vehicle!r} is not one of {', '.join(VEHICLES)}")
    if cycle not in p.cycles.cycles:
        raise ValueError(f"--cycle: {cycle!r} is not one of {', '.join(p.cycles.cycles)}")
    cyc = cycle_named(cycle)
    if grade is not None:
        if not -30.0 <= grade <= 30.0:
            raise ValueError(f"--grade: {grade:g} % is outside [-30, 30] %")
        cyc = cyc.with_grade(grade / 100.0)
    sim = simulator(p)
    if vehicle == "hybrid":
        if designs is None:
            raise ValueError("--designs: a design table is required for --vehicle hybrid")
        X = read_designs(designs)
        if trace is not None and len(X) > MAX_TRACED:
            raise ValueError(f"--trace: {len(X)} designs; traces are for at most {MAX_TRACED}")
        table = with_inputs(X, sim.run(X, cyc, "hybrid", batch_size=p.doe.batch_size))
    else:
        if designs is not None:
            raise ValueError(f"--designs: only for --vehicle hybrid ({vehicle} is a fixed car; drop --designs)")
        X = np.array([list(sim.design_of(vehicle).values())])
        table = with_inputs(X, sim.run(None, cyc, vehicle))
    table.insert(0, "vehicle", vehicle)
    table["cycle"] = cycle
    table["grade"] = float(np.mean(cyc.grade))
    traces = None
    if trace is not None:
        traces = sim.trace(X if vehicle == "hybrid" else None, cyc, vehicle)
        traces.insert(0, "vehicle", vehicle)
    write_table(out, pd.DataFrame(table))
    if traces is not None:
        write_table(trace, traces)
