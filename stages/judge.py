"""``hev judge``: simulate the judged scale's reference set -- a large Latin hypercube of admissible designs
that no search produces or sees; its screen-passing designs normalise every hypervolume and IGD+ figure."""

from __future__ import annotations

import typer

from hevlib import doe
from stages.cli import app
from stages.common import PARAMS_OPTION, REFERENCE, params_from, progress_callback, stage
from stages.simulating import sizing_setup


@app.command("judge")
@stage
def judge_stage(params: str = PARAMS_OPTION) -> None:
    """Simulate params.optimise.judge.n admissible Latin-hypercube designs; write data/judge/reference.parquet."""
    from hevlib.judging import simulated_as_front
    from hevlib.optimise.problem import RulesOnly, admissible_lhs, sizing_problem
    from hevlib.screen import passes_screen

    cfg = params_from(params)
    j = cfg.optimise.judge
    sim, cycle = sizing_setup(cfg)
    problem = sizing_problem(cfg, sim.mass_kg, RulesOnly())  # the exact rules and gear-set repair every source uses
    X = admissible_lhs(problem, cfg.design_space.space(), j.n, j.seed)
    with progress_callback(f"judge: {len(X)} designs on {cycle.name}") as cb:
        table = doe.simulate_designs(sim, X, "judge", cycle, batch_size=cfg.doe.batch_size, progress=cb)
    front = simulated_as_front(table.to_pandas())
    n_pass = int(passes_screen(front, cfg.screen).sum())
    if n_pass < 2:
        raise ValueError(f"optimise.judge.n: {n_pass} of {j.n} designs pass the screen; the judged scale needs more")
    doe.write_doe(REFERENCE, table, doe.run_metadata(cycle, cfg, method="admissible lhs", n=j.n, seed=j.seed))
    typer.echo(f"judge: {table.num_rows} designs ({n_pass} pass the screen: the judged scale) -> {REFERENCE}")
