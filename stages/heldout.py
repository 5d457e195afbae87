"""``hev heldout``: simulate the held-out Latin hypercube the surrogates are judged on (SPEC 7)."""

from __future__ import annotations

from pathlib import Path

import typer

from hevlib import doe
from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, progress_callback, stage
from stages.simulating import sizing_setup

HELDOUT = Path("data/doe/heldout.parquet")


def heldout_record(cfg) -> dict:
    return doe.heldout_record(cfg.design_space.space(), cfg.surrogate.heldout)


def simulate_heldout(cfg):
    """Simulate the held-out Latin hypercube: (table, metadata)."""
    h = cfg.surrogate.heldout
    X = doe.lhs_designs(cfg.design_space.space(), h.n, h.seed)
    sim, cycle = sizing_setup(cfg)
    with progress_callback(f"held-out: {len(X)} designs on {cycle.name}") as cb:
        table = doe.simulate_designs(sim, X, "heldout", cycle, batch_size=cfg.doe.batch_size, progress=cb)
    return table, doe.run_metadata(cycle, cfg, **heldout_record(cfg))


@app.command("heldout")
@stage
def heldout_stage(params: str = PARAMS_OPTION) -> None:
    """Simulate the held-out designs of params.surrogate.heldout; write data/doe/heldout.parquet."""
    cfg = params_from(params)
    table, meta = simulate_heldout(cfg)
    doe.write_doe(HELDOUT, table, meta)
    typer.echo(f"heldout: {table.num_rows} designs -> {HELDOUT}")
