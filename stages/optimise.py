"""``hev optimise SOURCE``: one source of designs on the sizing problem (SPEC 8): a surrogate-assisted
optimiser with infill (``nsga3``, ``moead``, ``moga``), a BoTorch source (``parego``, ``nehvi``) or the
oracle (the simulator in the loop)."""

from __future__ import annotations

import json
from functools import partial
from pathlib import Path

import typer

from hevlib.io import read_table, write_json, write_parquet
from hevlib.plots import save_figure
from hevlib.plots.fronts import front_figure
from stages.cli import app
from stages.common import PARAMS_OPTION, REFERENCE, params_from, progress_callback, stage
from stages.doe import DOE
from stages.simulating import sizing_setup

FRONTS_DIR = Path("data/pareto")
REPORTS_DIR = Path("reports")
ORACLE_REPORT = REPORTS_DIR / "optimise_oracle.json"
LOGS_DIR = Path("logs")  # wall times and other machine-dependent figures (git-ignored, not metrics)


def _oracle_report() -> dict:
    """The oracle's report (every other source is judged against its archive)."""
    if not ORACLE_REPORT.exists():
        raise FileNotFoundError(f"{ORACLE_REPORT}: no such file; run `hev optimise oracle` first")
    return json.loads(ORACLE_REPORT.read_text())


@app.command("optimise")
@stage
def optimise_stage(
    source: str = typer.Argument(..., help="nsga3, moead, moga (surrogate-assisted), parego, nehvi (BoTorch), oracle"),
    params: str = PARAMS_OPTION,
) -> None:
    """Run SOURCE on the sizing cycle; write data/pareto/SOURCE.parquet (every round's front, column
    ``round``), data/pareto/SOURCE_archive.parquet (every simulation, the DOE's included),
    reports/optimise_SOURCE.json and reports/plots/optimise_SOURCE.png."""
    from hevlib.design import DESIGN_VARS, RESPONSES
    from hevlib.doe import training_data
    from hevlib.judging import HvSettings, judged_normalisation
    from hevlib.optimise import oracle, surrogate_assisted
    from hevlib.optimise.archive import ARCHIVE_SCHEMA, SimulationLog
    from hevlib.optimise.problem import sizing_problem

    cfg = params_from(params)
    o = cfg.optimise
    if o is None:
        raise ValueError("params.yaml: optimise: group missing")
    if source != "oracle" and source not in o.algorithms and source not in o.bayes:
        configured = [*o.algorithms, *o.bayes]
        raise ValueError(
            f"params.yaml: optimise.algorithms.{source} / optimise.bayes.{source}: not configured "
            f"(configured: {', '.join(configured) or 'none'}; or use oracle)"
        )
    sim, cycle = sizing_setup(cfg)
    make_problem = partial(sizing_problem, cfg, sim.mass_kg)

    doe_df = read_table(DOE)
    # the one normalisation every source is judged on: screen-passing designs of the judged scale's reference
    # set, which no source produced; it only scores (HvSettings), never steers a search
    hv = HvSettings.from_params(judged_normalisation(read_table(REFERENCE), cfg.screen), o, cfg.screen)
    log = SimulationLog(sim.on_cycle(cycle, cfg.doe.batch_size))  # every simulation the source makes: its archive

    if source == "oracle":
        settings = o.oracle
        with progress_callback(f"oracle ({settings.algorithm}): {settings.n_gen} generations") as cb:
            result = oracle(make_problem, settings, log, hv, progress=cb)
        surrogate = "simulator"
        final = result.population
    elif source in o.bayes:
        from hevlib.optimise import bayes

        settings = o.bayes[source]
        ref = _oracle_report()
        X, R = doe_df[list(DESIGN_VARS)].to_numpy(dtype=float), doe_df[list(RESPONSES)]
        label = f"{source} (BoTorch): {settings.budget} simulations"
        with progress_callback(label) as cb:
            result = bayes(
                source, settings, make_problem, X, R, log, hv, o.oracle.pop_size, cfg.surrogate.bnn.log_targets,
                ref["archive"]["hypervolume"], progress=cb,
            )  # fmt: skip
        surrogate = "gp"
        final = "last"
    else:
        from hevlib.surrogates import fit_surrogate

        settings = o.algorithms[source]
        ref = _oracle_report()
        log.record(doe_df[list(DESIGN_VARS)].to_numpy(dtype=float), doe_df[list(RESPONSES)])  # the DOE counts
        X, Y = training_data(doe_df, what=str(DOE))
        fit = partial(fit_surrogate, settings.surrogate, params=cfg.surrogate, space=cfg.design_space.space())
        label = f"{source}: {o.infill.rounds + 1} rounds"
        with progress_callback(label) as cb:
            result = surrogate_assisted(
                source, settings, o.infill, make_problem, fit, X, Y, log, hv, ref["archive"]["hypervolume"], progress=cb
            )
        surrogate = settings.surrogate
        final = "last"

    last = result.table[result.table["round"] == result.table["round"].max()]
    norm = hv.norm
    fig = front_figure(last, norm, title=f"{source} ({surrogate}): last round's front on {cycle.name}")
    write_parquet(
        FRONTS_DIR / f"{source}.parquet",
        result.table,
        result.schema,
        metadata={"source": source, "surrogate": surrogate, "cycle": cycle.name},
    )
    write_parquet(
        FRONTS_DIR / f"{source}_archive.parquet",
        log.table(final),
        ARCHIVE_SCHEMA,
        metadata={"source": source, "surrogate": surrogate, "cycle": cycle.name},
    )
    write_json(REPORTS_DIR / f"optimise_{source}.json", result.report)
    write_json(LOGS_DIR / f"optimise_{source}.json", result.runtimes)  # wall times: not a metric, not in git
    save_figure(fig, REPORTS_DIR / "plots" / f"optimise_{source}.png")
    r = result.report
    ratio = r.get("hv_ratio_to_oracle")
    typer.echo(
        f"optimise {source}: {r['front_size']} designs, {r['n_simulations']} simulations in "
        f"{result.runtimes['runtime_total_s']:.0f} s; HV {r['hypervolume']:.4g} +- {r['hypervolume_se']:.2g}"
        + f"; archive HV {r['archive']['hypervolume']:.4g}"
        + (f" ({100 * ratio:.0f} % of the oracle's archive)" if ratio is not None else "")
        + f" -> {FRONTS_DIR / (source + '.parquet')}"
    )
