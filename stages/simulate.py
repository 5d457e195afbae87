"""``hev simulate``: check designs by hand, or re-simulate them, on any cycle."""

from __future__ import annotations

from pathlib import Path

import typer

from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, stage
from stages.simulating import cycle_named, simulator

#: Designs ``--trace`` records at most (a trace is one row per step and design).
MAX_TRACED = 50
#: The kinds of vehicle ``--vehicle`` takes (hevlib.sim.vehicles.VEHICLES, named here so that a bad value fails
#: before the simulator loads; a test holds the two equal).
VEHICLES = ("hybrid", "prius", "conventional")


@app.command("simulate")
@stage
def simulate(
    designs: Path = typer.Option(None, "--designs", help="CSV or Parquet with the seven design-variable columns"),
    cycle: str = typer.Option(
        ..., "--cycle", help="a cycle of params.yaml's cycles.cycles (udds, ftp, hwfet, us06, nedc by default)"
    ),
    grade: float = typer.Option(None, "--grade", help="road grade in percent; overrides the cycle's own grade"),
    vehicle: str = typer.Option("hybrid", "--vehicle", help="hybrid, conventional or prius"),
    out: Path = typer.Option(..., "--out", help="output table (.csv or .parquet)"),
    trace: Path = typer.Option(
        None,
        "--trace",
        help="also write per-step traces (speed, SOC, engine on/off, coolant and catalyst temperature, "
        f"engine-out and tailpipe rates; at most {MAX_TRACED} designs) to this table (.csv or .parquet)",
    ),
    params: str = PARAMS_OPTION,
) -> None:
    """Simulate designs (or a baseline) and write the inputs plus every response, one row per design; a design
    that did not drive the cycle gets no per-km figure (column not_earned says why) and a warning on stderr."""
    p = params_from(params)  # every input is checked before the simulator (numba) is loaded
    if vehicle not in VEHICLES:
        raise ValueError(f"--vehicle: {vehicle!r} is not one of {', '.join(VEHICLES)}")
    if cycle not in p.cycles.cycles:
        raise ValueError(f"--cycle: {cycle!r} is not one of {', '.join(p.cycles.cycles)}")
    if grade is not None and not -30.0 <= grade <= 30.0:
        raise ValueError(f"--grade: {grade:g} % is outside [-30, 30] %")
    for path in (out, trace):
        if path is not None and path.suffix.lower() not in (".csv", ".parquet"):
            raise ValueError(f"{path}: write a .csv or .parquet table")
    X = None
    if vehicle == "hybrid":
        if designs is None:
            raise ValueError("--designs: a design table is required for --vehicle hybrid")
        from hevlib.design import read_designs

        X = read_designs(designs, p.design_space.space())
        if trace is not None and len(X) > MAX_TRACED:
            raise ValueError(f"--trace: {len(X)} designs; traces are for at most {MAX_TRACED}")
    elif designs is not None:
        raise ValueError(f"--designs: only for --vehicle hybrid ({vehicle} is a fixed car; drop --designs)")
    cyc = cycle_named(cycle)
    if grade is not None:
        cyc = cyc.with_grade(grade / 100.0)

    import numpy as np
    import pandas as pd

    from hevlib.earned import mark_unearned, unearned_warning
    from hevlib.io import write_table
    from hevlib.sim.simulator import with_inputs

    sim = simulator(p)
    if vehicle == "hybrid":
        table = with_inputs(X, sim.run(X, cyc, "hybrid", batch_size=p.doe.batch_size))
    else:
        X = np.array([list(sim.design_of(vehicle).values())])
        table = with_inputs(X, sim.run(None, cyc, vehicle))
    table.insert(0, "vehicle", vehicle)
    table["cycle"] = cycle
    table["grade"] = float(np.mean(cyc.grade))
    traces = None
    if trace is not None:
        traces = sim.trace(X if vehicle == "hybrid" else None, cyc, vehicle)
        traces.insert(0, "vehicle", vehicle)
    # a design that did not drive the cycle keeps no per-km figure here (the simulator's own responses, which
    # the pipeline ranks on, are unchanged): empty, with the reason in column not_earned, and one warning line
    table = mark_unearned(pd.DataFrame(table), distance_m=cyc.distance_m, sim=p.sim)
    write_table(out, table)
    if traces is not None:
        write_table(trace, traces)
    wrote = f"{out}" + (f" and {trace}" if traces is not None else "")
    typer.echo(f"simulate: {len(table)} {'design' if vehicle == 'hybrid' else vehicle}(s) on {cycle} -> wrote {wrote}")
    warning = unearned_warning(table, cycle=cycle, sim=p.sim, vehicle=vehicle)
    if warning is not None:
        typer.echo(warning, err=True)
