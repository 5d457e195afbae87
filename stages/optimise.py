"""``hev optimise ALGO``: one many-objective optimiser on its surrogate, the front re-simulated (SPEC 8)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import typer

from hevlib.io import read_table, write_json, write_parquet
from hevlib.optimise import ALGORITHMS, HevProblem, HvSettings, doe_normalisation, optimise_and_resimulate
from hevlib.plots import save_figure
from hevlib.plots.fronts import front_figure
from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, progress_callback, sizing_setup, stage
from stages.doe import DOE
from stages.surrogates import HELDOUT

MODELS_DIR = Path("models")
FRONTS_DIR = Path("data/pareto")
REPORTS_DIR = Path("reports")
LOGS_DIR = Path("logs")  # wall times and other machine-dependent figures (git-ignored, not metrics)


@app.command("optimise")
@stage
def optimise_stage(
    algo: str = typer.Argument(..., help=f"one of {', '.join(ALGORITHMS)}"), params: str = PARAMS_OPTION
) -> None:
    """Optimise on the surrogate of params.optimise.algorithms.ALGO, re-simulate the front on the sizing
    cycle; write data/pareto/ALGO.parquet, reports/optimise_ALGO.json and reports/plots/optimise_ALGO.png."""
    from hevlib.surrogates import load_surrogate

    cfg = params_from(params)
    if cfg.optimise is None:
        raise ValueError("params.yaml: optimise: group missing")
    if algo not in cfg.optimise.algorithms:
        raise ValueError(
            f"params.yaml: optimise.algorithms.{algo}: not configured "
            f"(configured: {', '.join(cfg.optimise.algorithms) or 'none'})"
        )
    settings = cfg.optimise.algorithms[algo]
    o = cfg.optimise
    # common normalisation of all three algorithms: the range of every simulated design so far (DOE and
    # the held-out Latin hypercube, which spans the whole design space)
    simulated = pd.concat([read_table(DOE), read_table(HELDOUT)], ignore_index=True)
    hv = HvSettings(doe_normalisation(simulated, what=f"{DOE} + {HELDOUT}"), o.hv_reference, o.hv_samples, o.hv_seed)
    surrogate = load_surrogate(settings.surrogate, models_dir=MODELS_DIR)
    sim, cycle = sizing_setup(cfg)
    space = cfg.design_space.space()
    rules = cfg.screen if o.apply_screen_rules else None
    problem = HevProblem(
        surrogate,
        space,
        sim.mass_kg,
        cfg.baseline.conventional.test_mass_kg,
        speed_dev_max=rules.speed_dev_max if rules else None,
        gen_below_motor=bool(rules and rules.gen_below_motor),
        buildable_gear_set=bool(rules and rules.buildable_gear_set),
    )
    with progress_callback(f"optimise {algo}: {settings.n_gen} generations of {settings.pop_size}") as cb:
        result = optimise_and_resimulate(
            problem,
            algo,
            settings,
            lambda X: sim.run(X, cycle, vehicle="hybrid", batch_size=cfg.doe.batch_size),
            hv,
            progress=cb,
        )
    fig = front_figure(
        result.table, hv.norm, title=f"{algo} on {settings.surrogate}: front re-simulated on {cycle.name}"
    )

    write_parquet(
        FRONTS_DIR / f"{algo}.parquet",
        result.table,
        result.schema,
        metadata={"algo": algo, "surrogate": settings.surrogate, "cycle": cycle.name},
    )
    write_json(REPORTS_DIR / f"optimise_{algo}.json", result.report)
    write_json(LOGS_DIR / f"optimise_{algo}.json", result.runtimes)  # wall times: not a metric, not in git
    save_figure(fig, REPORTS_DIR / "plots" / f"optimise_{algo}.png")
    r, t = result.report, result.runtimes
    typer.echo(
        f"optimise {algo}: {r['front_size']} designs in {t['runtime_s']:.1f} s "
        f"({r['n_evaluations']} evaluations) + {t['runtime_resim_s']:.1f} s re-simulation; "
        f"HV {r['hypervolume']:.4g} +- {r['hypervolume_se']:.2g}, "
        f"{100 * (r['share_nondominated_after_resim'] or 0):.0f} % still non-dominated "
        f"-> {FRONTS_DIR / (algo + '.parquet')}"
    )
