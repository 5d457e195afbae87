"""``hev baselines``: the stock Prius and the conventional car on every reference cycle."""

from __future__ import annotations

from pathlib import Path

from hevlib.baselines import simulate_baselines
from hevlib.cycles import Cycle
from hevlib.io import write_json, write_table
from hevlib.plots.traces import plot_hybrid_trace
from hevlib.scaling import scale_engine
from hevlib.simulate import Simulator
from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, stage

CYCLES_DIR = Path("data/cycles")
REPORT = Path("reports/baselines.json")
BALANCE = Path("reports/baselines_energy.csv")
TRACE_CSV = Path("reports/baselines_prius_trace.csv")
TRACE_PLOT = Path("reports/plots/baselines_prius_trace.png")


@app.command("baselines")
@stage
def baselines(params: str = PARAMS_OPTION) -> None:
    """Simulate both reference vehicles; write reports/baselines.json, the energy balance and Prius traces."""
    p = params_from(params)
    sim = Simulator.from_params(p)
    cycles = {name: Cycle.from_parquet(CYCLES_DIR / f"{name}.parquet", name) for name in p.cycles.cycles}
    report, balance = simulate_baselines(sim, cycles)
    validation = cycles[p.cycles.validation]
    trace = sim.trace(None, validation, "prius")
    write_json(REPORT, report)
    write_table(BALANCE, balance)
    write_table(TRACE_CSV, trace.drop(columns="design"))
    plot_hybrid_trace(trace, scale_engine(sim.lib.engine_hybrid, p.baseline.prius.p_eng_kw), TRACE_PLOT,
                      title=f"stock Prius on {validation.name.upper()}")
