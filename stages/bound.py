"""``hev bound``: the controller's gap, the rule base and ECMS against the least fuel any controller could burn on
the same hardware (dynamic programming over SOC, :mod:`hevlib.bound`), for every shortlisted design and both
reference cars. It runs before ``hev validate``, which puts the recommended design's gap and the headline saving
under each controller into the answer."""

from __future__ import annotations

from pathlib import Path

import typer

from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, progress_callback, stage
from stages.simulating import cycle_named, simulator

GAP = Path("data/bound/gap.parquet")  # the gap table (hevlib.controller_gap.GAP_COLUMNS), read by `hev validate`
SOC = Path("data/bound/soc.parquet")  # every power-split vehicle's SOC on the first cycle under each controller


@app.command("bound")
@stage
def bound(
    selected: Path = typer.Option(Path("data/pareto/selected.parquet"), "--selected", help="the shortlist"),
    out_dir: Path = typer.Option(Path("reports"), "--out-dir", help="where bound.json, bound.md and plots/bound go"),
    params: str = PARAMS_OPTION,
) -> None:
    """The controller's gap: each shortlisted design's and both reference cars' fuel under the rule base, under
    ECMS and at the charge-sustaining bound, on bound.cycles; the bound's grid convergence."""
    p = params_from(params)

    import pandas as pd

    from hevlib.bound import BoundGrid
    from hevlib.controller_gap import bound_study, gap_markdown, gap_schema, soc_schema
    from hevlib.design import DESIGN_VARS
    from hevlib.io import write_json, write_parquet, write_text
    from hevlib.plots import save_figure
    from hevlib.plots.bound import gap_figure

    picks = pd.read_parquet(selected)
    designs = {row["design_id"]: [float(row[k]) for k in DESIGN_VARS] for _, row in picks.iterrows()}
    cycles = {name: cycle_named(name) for name in p.bound.cycles}
    grid = BoundGrid.from_params(p.bound)
    with progress_callback("bound") as progress:
        study = bound_study(simulator(p), designs, cycles, grid, progress, ecms_gain=p.pms.ecms_soc_gain)
    plots = out_dir / "plots" / "bound"
    plots.mkdir(parents=True, exist_ok=True)
    save_figure(gap_figure(study.table), plots / "gap.png")
    write_parquet(GAP, study.table, gap_schema())
    write_parquet(SOC, study.soc, soc_schema())
    write_json(out_dir / "bound.json", study.report)
    write_text(out_dir / "bound.md", gap_markdown(study.report))
    first = p.bound.cycles[0]
    c, cv = study.report["by_cycle"][first], study.report["convergence"]

    def pct(x):
        return "n/a" if x is None else f"{x:+.1f} %"

    typer.echo(
        f"bound: {len(designs) + 2} vehicles x {len(cycles)} cycles; on {first} the rule base burns "
        f"{pct(c['gap_pct']['median'])} more than the bound over the picks (median; stock Prius "
        f"{pct(c['prius_gap_pct'])}), ECMS in the drive step {pct(c['ecms_drive_gap_pct']['median'])}; halving the "
        f"SOC step moves the bound by at most {cv['soc_step_halved_pct_max_abs']:.2f} % -> wrote {GAP}, {SOC}, "
        f"{out_dir / 'bound.json'}, {out_dir / 'bound.md'}, {plots}"
    )
