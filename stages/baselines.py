"""``hev baselines``: the stock Prius and the conventional car on every reference cycle."""

from __future__ import annotations

from pathlib import Path

import typer

from hevlib.baselines import simulate_baselines
from hevlib.io import write_json, write_table
from hevlib.plots.traces import plot_hybrid_trace
from hevlib.sizing import scale_engine
from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, progress_callback, stage
from stages.simulating import cycle_named, simulator

REPORT = Path("reports/baselines.json")
BALANCE = Path("reports/baselines_energy.csv")
TRACE_CSV = Path("reports/baselines_prius_trace.csv")
TRACE_PLOT = Path("reports/plots/baselines_prius_trace.png")


@app.command("baselines")
@stage
def baselines(params: str = PARAMS_OPTION) -> None:
    """Simulate both reference vehicles; write reports/baselines.json, the energy balance and Prius traces."""
    p = params_from(params)
    sim = simulator(p)
    cycles = {name: cycle_named(name) for name in p.cycles.cycles}
    with progress_callback(f"baselines: 2 vehicles on {len(cycles)} cycles") as cb:
        report, balance = simulate_baselines(sim, cycles, progress=cb)
    validation = cycles[p.cycles.validation]
    trace = sim.trace(None, validation, "prius")
    write_json(REPORT, report)
    write_table(BALANCE, balance)
    write_table(TRACE_CSV, trace.drop(columns="design"), float_format="%.6g")
    plot_hybrid_trace(
        trace,
        scale_engine(sim.lib.engine_hybrid, p.baseline.prius.p_eng_kw),
        TRACE_PLOT,
        title=f"stock Prius on {validation.name.upper()}",
    )
    typer.echo(f"baselines: {len(balance)} vehicle-runs on {', '.join(cycles)} -> {REPORT}")
