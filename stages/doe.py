"""``hev doe``: simulate the design of experiments on the sizing cycle (SPEC 6)."""

from __future__ import annotations

from pathlib import Path

import typer

from hevlib import doe
from hevlib.io import write_json
from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, progress_callback, stage
from stages.simulating import sizing_setup

DOE = Path("data/doe/doe.parquet")
REPORT = Path("reports/doe.json")


@app.command("doe")
@stage
def doe_stage(params: str = PARAMS_OPTION) -> None:
    """Simulate the DOE of params.doe; write data/doe/doe.parquet and reports/doe.json."""
    cfg = params_from(params)
    p = cfg.doe
    X, source = doe.doe_designs(p.method, p.n_lhs, p.seed, cfg.design_space.space(), p.l27_file)
    sim, cycle = sizing_setup(cfg)
    meta = doe.run_metadata(cycle, cfg, **doe.doe_record(p))
    with progress_callback(f"doe: {len(X)} designs on {cycle.name}") as cb:  # written chunk by chunk
        doe.write_doe(DOE, doe.simulated_chunks(sim, X, source, cycle, batch_size=p.batch_size, progress=cb), meta)
    summary = doe.doe_summary(doe.read_doe(DOE)[0], meta)
    write_json(REPORT, summary)
    typer.echo(
        f"doe: {summary['n_designs']} designs {summary['by_source']} on {cycle.name}, "
        f"{summary['n_cycle_not_met']} missed the cycle -> {DOE}"
    )
