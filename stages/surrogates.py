"""``hev surrogates``: fit and judge the BNN and the regressions (SPEC 7)."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from hevlib import doe
from hevlib.design import OBJECTIVES, design_matrix
from hevlib.io import write_json, write_text
from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, stage
from stages.doe import DOE
from stages.heldout import HELDOUT, heldout_record, simulate_heldout

MODELS_DIR = Path("models")
METRICS = Path("reports/surrogate_metrics.json")
SIGNS_JSON = Path("reports/regression_signs.json")
SIGNS_MD = Path("reports/regression_signs.md")
TRAINING_CSV = Path("reports/bnn_training.csv")
PLOTS_DIR = Path("reports/plots")
STUDY_COEFFICIENTS = Path("data/raw/paper/regression_equations.csv")


def _load_heldout(cfg):
    """The held-out set: reused from HELDOUT when it matches params, else simulated (and written later)."""
    if HELDOUT.exists():
        df, meta = doe.read_doe(HELDOUT)
        if doe.is_current(meta, cfg, **heldout_record(cfg)):
            return df, None
        typer.echo(f"surrogates: {HELDOUT} was simulated with other params; simulating it again")
    table, meta = simulate_heldout(cfg)
    return table.to_pandas(), (table, meta)


def _xy(df, what: str):
    keep = doe.finite_objectives(df)
    if not keep.all():
        typer.echo(f"surrogates: {what}: dropping {int((~keep).sum())} designs with non-finite objectives")
    df = df[keep]
    return design_matrix(df, what=what), df[list(OBJECTIVES)].to_numpy(dtype=float)


@app.command("surrogates")
@stage
def surrogates_stage(params: str = PARAMS_OPTION) -> None:
    """Fit the BNN and the regressions on the DOE; judge them; write models/, metrics and plots.

    Split metrics (train, test) come from models fitted on the training split only; the saved models are
    refitted on every DOE design and judged on the held-out designs, which nothing is ever fitted on.
    Reads params surrogate (all of it) and screen.speed_dev_max (which held-out designs count as
    followers of the cycle in the metrics)."""
    from hevlib.plots import save_figure
    from hevlib.plots.surrogates import surrogate_figures
    from hevlib.surrogates.evaluation import fit_surrogates, summary_table, training_curve_table
    from hevlib.surrogates.regression import (
        compare_signs,
        read_study_coefficients,
        sign_summary,
        signs_markdown,
    )

    cfg = params_from(params)
    doe_df, _ = doe.read_doe(DOE)
    X, Y = _xy(doe_df, str(DOE))
    study_coef = read_study_coefficients(STUDY_COEFFICIENTS)
    heldout_df, new_heldout = _load_heldout(cfg)
    Xh, Yh = _xy(heldout_df, str(HELDOUT))

    study = fit_surrogates(X, Y, Xh, Yh, cfg.surrogate, cfg.design_space.space(), cfg.screen.speed_dev_max)
    bnn, reg = study.models["bnn"], study.models["regression"]
    metrics = study.metrics
    signs = compare_signs(reg, study_coef)
    figures = surrogate_figures(study)

    if new_heldout is not None:
        doe.write_doe(HELDOUT, *new_heldout)
    bnn.save(MODELS_DIR / "bnn.pt")
    reg.save(MODELS_DIR / "regression.json")
    write_json(METRICS, metrics)
    write_json(SIGNS_JSON, {"summary": sign_summary(signs), "coefficients": signs.to_dict(orient="records")})
    write_text(SIGNS_MD, signs_markdown(signs))
    write_text(TRAINING_CSV, training_curve_table(bnn).to_csv(index=False, float_format="%.6g"))
    for name, fig in figures.items():
        save_figure(fig, PLOTS_DIR / name)

    n = study.n_designs
    offsets = dict(zip(OBJECTIVES, bnn.target_transform_.offset, strict=True))
    logged = ", ".join(o + (f" (+{offsets[o]:.3g})" if offsets[o] else "") for o in bnn.log_targets) or "none"
    evidence = ", ".join(
        f"{name} {rec['gamma']:.1f} ({rec['epochs']} ep, {rec['stop']})" for name, rec in bnn.evidence_summary().items()
    )
    typer.echo(
        f"surrogates: {n['train']} train / {n['test']} test / {n['heldout']} held-out designs "
        f"({n['heldout_followers']} follow the cycle: speed_dev <= {cfg.screen.speed_dev_max:g}); "
        f"saved models fitted on all {len(X)} DOE designs; BNN log targets: {logged}"
    )
    typer.echo(
        f"BNN {len(bnn.network_names_)} network(s) 7-{bnn.hidden_}-{bnn.n_out_} ({bnn.n_weights_} weights each, "
        f"{bnn.n_residuals_} residuals); gamma per network: {evidence}"
    )
    typer.echo(
        "held-out R^2, Spearman rho (all held-out designs and the followers, fol.) and BNN 2-sigma coverage:\n"
        + summary_table(metrics).to_string(float_format=lambda v: f"{v:.3f}")
    )
    worse = _worse_than_constant(metrics)
    if worse:
        typer.echo(
            "surrogates: worse than a constant on the held-out designs (R^2 < 0): "
            + "; ".join(f"{name} on {', '.join(objs)}" for name, objs in worse.items())
            + " -- `hev validate` flags the sources that optimise on them (summary.md: Trust of each source)"
        )


def _worse_than_constant(metrics: dict) -> dict[str, list[str]]:
    """``{model: [objective, ...]}`` where the model's held-out R² is below 0 (hevlib.validation.trust's rule)."""
    out = {}
    for name in ("bnn", "regression"):
        r2 = {o: metrics.get(name, {}).get("heldout", {}).get(o, {}).get("r2") for o in OBJECTIVES}
        objs = [o for o, v in r2.items() if isinstance(v, float | int) and math.isfinite(v) and v < 0]
        if objs:
            out[name] = objs
    return out
