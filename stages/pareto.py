"""``hev pareto``: merge the optimisers' fronts, keep the non-dominated, screen, rank, keep and pick."""

from __future__ import annotations

import json
from pathlib import Path

import polars as pl

from hevlib.io import read_table, write_json, write_parquet, write_text
from hevlib.judging import judged_normalisation
from hevlib.pareto import select_designs, source_summary, table_schema
from hevlib.plots import save_figure
from hevlib.plots.pareto import distributions_figure, infill_figure, tradeoff_data, tradeoffs_figure
from hevlib.recommend import active_bounds
from hevlib.results import to_json
from hevlib.tables import scan
from stages.cli import app
from stages.common import PARAMS_OPTION, REFERENCE, params_from, stage

FRONTS_DIR = Path("data/pareto")
MERGED = FRONTS_DIR / "merged.parquet"
SELECTED = FRONTS_DIR / "selected.parquet"
METRICS = Path("reports/pareto.json")
PLOTS_DIR = Path("reports/plots/pareto")
REPORTS_DIR = Path("reports")
PLOT_DATA_DIR = Path("reports/pareto_tradeoffs")
LOGS_DIR = Path("logs")  # machine-dependent figures (git-ignored, not metrics)


@app.command("pareto")
@stage
def pareto(params_path: str = PARAMS_OPTION) -> None:
    """Merge data/pareto/<algo>.parquet, screen (params.screen), keep and pick; write the Pareto outputs."""
    params = params_from(params_path)
    if params.optimise is None or not params.optimise.sources:
        raise ValueError("params.yaml: optimise.sources: needed to know which fronts to merge")
    o = params.optimise
    algos = list(o.sources)
    tables = {a: scan(FRONTS_DIR / f"{a}.parquet") for a in algos}
    reports = {a: json.loads((REPORTS_DIR / f"optimise_{a}.json").read_text()) for a in algos}
    # a source's front is its last round's rows (earlier rounds are the infill history)
    fronts = {a: t.filter(pl.col("round") == pl.col("round").max()).drop("round").collect() for a, t in tables.items()}
    archives = {a: scan(FRONTS_DIR / f"{a}_archive.parquet").collect() for a in algos}
    norm = judged_normalisation(read_table(REFERENCE), params.screen)
    result = select_designs(fronts, params.screen)
    judging, hv_wall_s = source_summary(fronts, archives, reports, result.merged, params.screen, o, norm)
    kept = result.merged.filter(pl.col("kept")).to_pandas()  # matplotlib's edge
    summary = result.summary.judged(judging, active_bounds(kept, params.design_space))
    figures = {
        "tradeoffs.png": tradeoffs_figure(kept, algos),
        "distributions.png": distributions_figure(kept, algos),
        "infill.png": infill_figure({a: r["rounds"] for a, r in reports.items() if a != "oracle"}),
    }
    plot_data = {a: tradeoff_data(kept, a).to_csv(index=False) for a in algos}

    write_parquet(MERGED, result.merged, table_schema(result.merged))
    write_parquet(SELECTED, result.selected, table_schema(result.selected))
    write_json(METRICS, to_json(summary))
    write_json(LOGS_DIR / "pareto.json", {"hypervolume_wall_s": hv_wall_s})  # wall times: not a metric
    for name, fig in figures.items():
        save_figure(fig, PLOTS_DIR / name)
    for a, text in plot_data.items():
        write_text(PLOT_DATA_DIR / f"{a}.csv", text)
    c = summary.counts
    print(
        f"pareto: {c.merged} designs, {c.nondominated} non-dominated, {c.feasible} feasible, "
        f"{c.kept} kept, {c.picked} picked ({params.screen.pick}) -> wrote {MERGED}, {SELECTED}, {METRICS}"
    )
    for flag in summary.active_bounds["flagged"]:
        print(
            f"pareto: {flag['variable']} at its {flag['side']} bound {flag['bound']:g} in "
            f"{100 * flag['kept_share']:.0f} % of the kept designs: widen design_space.{flag['variable']}"
        )
