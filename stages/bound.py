"""``hev bound``: the controller's gap, the rule base against the least fuel any controller could burn on the same
hardware (dynamic programming over SOC, :mod:`hevlib.bound`), for every pick and the stock Prius."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, progress_callback, stage
from stages.simulating import cycle_named, simulator


@app.command("bound")
@stage
def bound(
    selected: Path = typer.Option(Path("data/pareto/selected.parquet"), "--selected", help="the picks"),
    validation: Path = typer.Option(
        Path("reports/validation.json"), "--validation", help="the validate stage's report (the recommended design)"
    ),
    out_dir: Path = typer.Option(Path("reports"), "--out-dir", help="where bound.json, bound.md and plots/bound go"),
    params: str = PARAMS_OPTION,
) -> None:
    """The controller's gap: each pick's and the stock Prius's fuel under the rule base against the charge-
    sustaining bound, on bound.cycles; the headline saving at the bound; the bound's grid convergence."""
    p = params_from(params)
    recommended = json.loads(validation.read_text())["recommendation"]["design"]["design_id"]

    import pandas as pd

    from hevlib.bound import BoundGrid
    from hevlib.controller_gap import bound_study, gap_markdown
    from hevlib.design import DESIGN_VARS
    from hevlib.io import write_json, write_text
    from hevlib.plots import save_figure
    from hevlib.plots.bound import gap_figure, soc_figure

    picks = pd.read_parquet(selected)
    designs = {row["design_id"]: [float(row[k]) for k in DESIGN_VARS] for _, row in picks.iterrows()}
    if recommended not in designs:
        raise ValueError(f"{validation}: the recommended design {recommended} is not among the picks of {selected}")
    cycles = {name: cycle_named(name) for name in p.bound.cycles}
    grid = BoundGrid.from_params(p.bound)
    with progress_callback("bound") as progress:
        study = bound_study(simulator(p), designs, recommended, cycles, grid, progress, ecms_gain=p.pms.ecms_soc_gain)
    first = p.bound.cycles[0]
    plots = out_dir / "plots" / "bound"
    plots.mkdir(parents=True, exist_ok=True)
    save_figure(gap_figure(study.table, recommended), plots / "gap.png")
    title = f"{recommended} on {first}: SOC under the rule base and at the bound"
    soc_rule, soc_bound = study.recommended_rule_trace["soc"].to_numpy(), study.recommended_bound.trace[:, 0]
    save_figure(soc_figure(cycles[first].time_s, soc_rule, soc_bound, title), plots / "soc.png")
    write_json(out_dir / "bound.json", study.report)
    write_text(out_dir / "bound.md", gap_markdown(study.report))
    c = study.report["by_cycle"][first]
    typer.echo(
        f"bound: {len(designs) + 1} vehicles x {len(cycles)} cycles; on {first} the rule base burns "
        f"{c['recommended_gap_pct']:+.1f} % more than the bound for {recommended} ({c['prius_gap_pct']:+.1f} % for "
        f"the stock Prius), ECMS {c['recommended_ecms_gap_pct']:+.1f} % more, ECMS in the drive step "
        f"{c['recommended_ecms_drive_gap_pct']:+.1f} % more -> wrote {out_dir / 'bound.json'}, "
        f"{out_dir / 'bound.md'}, {plots}"
    )
