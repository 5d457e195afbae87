"""``hev validate``: simulate the picks and both baselines on the validation cycles; write the report."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from hevlib.explorer import explorer_data, write_explorer
from hevlib.io import read_table, write_json, write_parquet, write_text
from hevlib.plots import save_figure
from hevlib.plots.bound import soc_figure
from hevlib.plots.validation import catalyst_figure, improvement_figure, traces_figure
from hevlib.report import build_summary
from hevlib.results import ParetoSummary, from_json, to_json
from hevlib.robustness import settings_fingerprint
from hevlib.validation import (
    answer,
    check_covers,
    cold_start_window_s,
    cycle_notes,
    eligible_ids,
    ftp_bags,
    headline,
    load_cycles,
    prius_design,
    recommendation,
    recommended_gap,
    simulate_twins,
    source_trust,
    summarise,
    traces,
    twins_schema,
    validation_schema,
    validation_table,
)
from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, stage
from stages.simulating import CYCLES_DIR, cycle_named, simulator

SELECTED = Path("data/pareto/selected.parquet")
PARETO_JSON = Path("reports/pareto.json")
TABLE = Path("reports/validation.parquet")
TWINS = Path("reports/validation_twins.parquet")  # the eligible picks' twins: the model's noise (recommendation)
METRICS = Path("reports/validation.json")
HEADLINE = Path("reports/headline.json")
ANSWER = Path("reports/answer.json")  # the declared DVC metric: the headline under short keys
SUMMARY = Path("reports/summary.md")
EXPLORER = Path("reports/explorer.html")
MERGED = Path("data/pareto/merged.parquet")
GAP = Path("data/bound/gap.parquet")  # the controller's gap of the shortlist (`hev bound`, stages/bound.py)
SOC = Path("data/bound/soc.parquet")  # its SOC traces under each controller
PLOTS_DIR = Path("reports/plots/validation")
ROBUSTNESS = Path("reports/robustness/summary.json")  # the seed spread (`hev robustness report`), if measured
SURROGATE_METRICS = Path("reports/surrogate_metrics.json")  # the surrogates' held-out quality (`hev surrogates`)
OPTIMISE_REPORT = "reports/optimise_{}.json"  # what each source searched on (`hev optimise <source>`)


def _robustness(params_path: str) -> dict | None:
    """The committed robustness summary, with ``current``: whether it was made with these settings and code."""
    if not ROBUSTNESS.exists():
        return None
    summary = json.loads(ROBUSTNESS.read_text())
    return {**summary, "current": summary.get("fingerprint") == settings_fingerprint(params_path)[1]}


def _read_json(path: Path) -> dict | None:
    return json.loads(path.read_text()) if path.exists() else None


def _trust(sources: list[str]):
    """Each merged source's trust: its model's held-out quality (:func:`hevlib.validation.source_trust`)."""
    reports = {s: _read_json(Path(OPTIMISE_REPORT.format(s))) for s in sources}
    return source_trust(_read_json(SURROGATE_METRICS), reports, sources, SURROGATE_METRICS.as_posix())


def _gap_inputs(designs: list[str]):
    """``hev bound``'s gap table and SOC traces, read (and checked to cover the shortlist's ``designs``) before any
    simulation."""
    for path in (GAP, SOC):
        if not path.exists():
            raise FileNotFoundError(f"{path}: no such file; run `hev bound` first (or `hev validate --no-gap`)")
    table = read_table(GAP)
    check_covers(table, designs)
    return table, read_table(SOC)


@app.command("validate")
@stage
def validate(
    params_path: str = PARAMS_OPTION,
    gap: bool = typer.Option(
        True,
        "--gap/--no-gap",
        help="put the controller's gap (`hev bound`'s data/bound/gap.parquet for this shortlist) into the answer; "
        "--no-gap: leave it out (the seed-spread replicates, whose shortlists have no bound)",
    ),
) -> None:
    """Simulate the picks and both baselines on params.validate.cycles; write the table, metrics, summary."""
    params = params_from(params_path)
    names = list(params.validation.cycles)
    cycles = load_cycles(names, list(params.cycles.cycles), CYCLES_DIR)
    selected = read_table(SELECTED)
    if not PARETO_JSON.exists():
        raise FileNotFoundError(f"{PARETO_JSON}: no such file; run `hev pareto` first")
    pareto = from_json(ParetoSummary, json.loads(PARETO_JSON.read_text()))
    algos = list(pareto.by_algo)  # the algorithms the pareto stage merged, in its order
    prius_x = prius_design(params.baseline.prius)
    designs = [str(d) for d in selected["design_id"]]
    gap_table, soc = _gap_inputs(designs) if gap else (None, None)

    sim = simulator(params)
    table = validation_table(sim, selected, cycles, prius_x)
    sizing_name = params.cycles.sizing
    sizing_cycle = cycle_named(sizing_name)
    sizing = {v: sim.run(prius_x[None, :], sizing_cycle, v).iloc[0].to_dict() for v in ("prius", "conventional")}
    eq = params.validation.equivalence
    twins = simulate_twins(
        sim, selected, eligible_ids(table, names, params.screen), cycles[0], params.design_space.space(), eq
    )
    rec = recommendation(table, selected, names, params.screen, params.design_space, twins, eq)
    if rec.design is not None and names[0] == "ftp":
        rec = rec.with_ftp_bags(ftp_bags(sim, table, selected, rec.design.design_id, cycles[0], prius_x))
    robustness = _robustness(params_path)
    rec_id = rec.design.design_id if rec.design is not None else None
    controller_gap = recommended_gap(gap_table, designs, rec_id) if gap else None
    summary = summarise(
        table,
        algos,
        names,
        params.baseline.conventional.p_eng_kw,
        rec,
        _trust(algos),
        robustness=robustness,
        controller_gap=controller_gap,
    )

    figures = {
        f"improvement_{c}.png": improvement_figure(
            summary.improvement if c == names[0] else summary.by_cycle[c]["improvement"], c
        )
        for c in names
    }
    notes = cycle_notes(cycles)
    best = rec.design.design_id if rec.design is not None else summary.best_design
    tr = traces(sim, selected, best, cycles[0], prius_x) if best is not None else None
    if tr is not None:
        figures[f"traces_{names[0]}.png"] = traces_figure(tr, names[0])
        window_s = cold_start_window_s(sim, cycles[0], tr)
        if window_s is not None:
            figures[f"catalyst_{names[0]}.png"] = catalyst_figure(tr, names[0], window_s, sim.light_off_temperature_c())
    else:
        notes.append(
            "no time-trace plot: "
            + ("no picked design" if best is None else "the simulator offers no traces (Simulator.trace)")
        )
    if soc is not None and rec_id is not None and (soc["vehicle"] == rec_id).any():
        first = next(iter(controller_gap["by_cycle"]))
        title = f"{rec_id} on {first}: SOC under each controller"
        figures[f"soc_controllers_{first}.png"] = soc_figure(soc[soc["vehicle"] == rec_id], title)
    plots = {
        "Objective trade-offs of the kept designs (sizing cycle)": "plots/pareto/tradeoffs.png",
        "Distributions of the kept designs' objectives (sizing cycle)": "plots/pareto/distributions.png",
    }
    plots.update({f"Improvement on {c}": f"plots/validation/improvement_{c}.png" for c in names})
    if tr is not None:
        caption = f"{names[0]} traces: recommended design {best} against both baselines"
        plots[caption] = f"plots/validation/traces_{names[0]}.png"
        if f"catalyst_{names[0]}.png" in figures:
            caption = f"{names[0]} cold start: catalyst warm-up of recommended design {best} against both baselines"
            plots[caption] = f"plots/validation/catalyst_{names[0]}.png"
    soc_png = [name for name in figures if name.startswith("soc_controllers_")]
    if soc_png:
        plots[f"SOC of recommended design {rec_id} under the rule base, ECMS and the bound"] = (
            f"plots/validation/{soc_png[0]}"
        )
    text = build_summary(pareto, summary, table, selected, plots, notes, robustness)

    write_parquet(TABLE, table, validation_schema())
    write_parquet(TWINS, twins, twins_schema())
    write_json(METRICS, to_json(summary))
    head = headline(summary)
    write_json(HEADLINE, head)
    write_json(ANSWER, answer(head))
    equivalents = [e.design_id for e in rec.equivalents]
    write_explorer(
        EXPLORER,
        explorer_data(
            read_table(MERGED), sizing, best if rec.design else None, sizing_name, equivalents, controller_gap
        ),
    )
    for name, fig in figures.items():
        save_figure(fig, PLOTS_DIR / name)
    write_text(SUMMARY, text)
    flagged = summary.trust.flagged if summary.trust is not None else []
    typer.echo(
        f"validate: {summary.counts.picked} picks on {', '.join(names)}; recommended "
        f"{best if rec.design is not None else 'none'}"
        + (f" (near-equivalents: {', '.join(equivalents)})" if equivalents else "")
        + (f"; flagged sources (surrogate worse than a constant): {', '.join(flagged)}" if flagged else "")
        + f" -> wrote {TABLE}, {METRICS}, {HEADLINE}, {ANSWER}, "
        f"{SUMMARY}, {EXPLORER}"
    )
