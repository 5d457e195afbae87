"""Surrogate figures: parity plots of all eleven objectives and the BNN's LM / evidence training curve.

Parity plots are readable despite the few designs that barely move on the sizing cycle: those that
fail the screening rule (simulated ``speed_dev`` above ``screen.speed_dev_max``) are drawn as faint
triangles, and the heavy-tailed objectives (the BNN's ``log_targets``) get symmetric-log axes (linear
within a decade of zero, so the zero-fuel designs that never move still show).

Functions return the figure; write it with :func:`hevlib.plots.save_figure`.
"""

from __future__ import annotations

import numpy as np

from hevlib.design import OBJECTIVE_UNITS, OBJECTIVES
from hevlib.plots import plt
from hevlib.surrogates.evaluation import followers
from hevlib.surrogates.metrics import r2_score, spearman

#: Point styles per data split, drawn in this order (held-out on top).
_STYLE = {
    "train": dict(color="0.6", marker=".", s=10, alpha=0.6),
    "test": dict(color="tab:blue", marker="x", s=14, alpha=0.8),
    "heldout": dict(facecolors="none", edgecolors="tab:red", marker="o", s=14, alpha=0.8),
}


def parity_figure(
    sets: dict[str, tuple[np.ndarray, np.ndarray]],
    title: str,
    *,
    log_objectives: tuple[str, ...] = (),
    speed_dev_max: float | None = None,
) -> plt.Figure:
    """Predicted against simulated value for every objective (one panel each, 3 x 4 grid).

    ``sets`` maps a split name (``train``, ``test``, ``heldout``) to ``(Y_true, Y_pred)``, (n, 11) in
    ``OBJECTIVES`` order. Each panel gives the R^2 and Spearman rho of the held-out set (or of the last
    set given) and, with ``speed_dev_max``, the R^2 of its designs that follow the cycle; designs
    that do not are faint triangles. ``log_objectives`` get symmetric-log axes.
    """
    fig, axes = plt.subplots(3, 4, figsize=(13, 9.5))
    ref = "heldout" if "heldout" in sets else list(sets)[-1]
    follows = {
        name: (np.ones(len(yt), bool) if speed_dev_max is None else followers(yt, speed_dev_max))
        for name, (yt, _) in sets.items()
    }
    for k, (obj, ax) in enumerate(zip(OBJECTIVES, axes.flat, strict=False)):
        lo, hi = np.inf, -np.inf
        for name, (yt, yp) in sets.items():
            ok, style = follows[name], _STYLE.get(name, {})
            ax.scatter(yt[ok, k], yp[ok, k], label=name, **style)
            if not ok.all():
                faint = {**style, "marker": "^", "alpha": 0.3}
                ax.scatter(yt[~ok, k], yp[~ok, k], label=f"{name}, speed_dev > {speed_dev_max:g}", **faint)
            lo, hi = min(lo, yt[:, k].min(), yp[:, k].min()), max(hi, yt[:, k].max(), yp[:, k].max())
        if obj in log_objectives:
            _symlog(ax, np.concatenate([yt[:, k] for yt, _ in sets.values()]))
            pad = 0.0  # a linear pad would reach below zero, a decade on symlog axes
        else:
            pad = 0.05 * (hi - lo) if hi > lo else 1.0
        ax.plot([lo - pad, hi + pad], [lo - pad, hi + pad], color="k", lw=0.8)
        yt, yp = sets[ref]
        text = f"R$^2_{{{ref}}}$={r2_score(yt, yp)[k]:.3f} $\\rho$={spearman(yt[:, k], yp[:, k])[0]:.3f}"
        ok = follows[ref]
        if speed_dev_max is not None and ok.sum() > 1:
            text += f"\nR$^2$ followers ({int(ok.sum())})={r2_score(yt[ok], yp[ok])[k]:.3f}"
        ax.set_title(f"{obj} [{OBJECTIVE_UNITS[obj]}]", fontsize=9)
        ax.text(0.03, 0.97, text, transform=ax.transAxes, fontsize=7, va="top")
        ax.set_xlabel("simulated", fontsize=8)
        ax.set_ylabel("predicted", fontsize=8)
        ax.tick_params(labelsize=7)
    legend_ax = axes.flat[len(OBJECTIVES)]
    legend_ax.axis("off")
    entries = {}
    for ax in axes.flat[: len(OBJECTIVES)]:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            entries.setdefault(lab, h)
    legend_ax.legend(list(entries.values()), list(entries), loc="center", title=title, fontsize=8)
    fig.suptitle(title)
    return fig


def _symlog(ax, values: np.ndarray) -> None:
    """Symmetric-log axes, linear below the decade of the smallest positive simulated value."""
    positive = values[values > 0]
    linthresh = 10.0 ** np.floor(np.log10(positive.min())) if positive.size else 1.0
    ax.set_xscale("symlog", linthresh=linthresh)
    ax.set_yscale("symlog", linthresh=linthresh)


def training_curve_figure(model) -> plt.Figure:
    """The BNN's Levenberg-Marquardt / evidence training curve, one line per network: gamma (with the
    network's weights and the residuals as limits), E_D per residual, alpha, beta and the LM damping mu
    against epoch (log scale except gamma)."""
    h = model.history_
    names = model.network_names_
    panels = (
        ("gamma", r"$\gamma$ (effective parameters)", False),
        ("e_d", "E$_D$ / N (mean sq. std. residual)", True),
        ("alpha", r"$\alpha$ (weight prior precision)", True),
        ("beta", r"$\beta$ (noise precision / 2)", True),
        ("mu", r"$\mu$ (LM damping)", True),
    )
    epoch = np.arange(h["gamma"].shape[1])
    fig, axes = plt.subplots(1, len(panels), figsize=(18, 3.8))
    colors = plt.get_cmap("tab20")(np.linspace(0, 1, max(len(names), 2)))
    for (key, title, log), ax in zip(panels, axes, strict=True):
        first = 1 if key == "alpha" else 0  # the start value of alpha is ~0 (trainbr's first step is plain LM)
        for i, name in enumerate(names):
            y = h[key][i] / (model.n_residuals_ if key == "e_d" else 1.0)
            ax.plot(epoch[first:], y[first:], lw=1.0, color=colors[i], label=name)
        if log:
            ax.set_yscale("log")
        else:
            n_w, n_res = model.n_weights_, model.n_residuals_
            ax.axhline(n_w, color="k", ls="--", lw=0.8, label=f"N$_w$ = {n_w}")
            if n_res <= 2 * n_w:
                ax.axhline(n_res, color="k", ls=":", lw=0.8, label=f"N = {n_res}")
            ax.set_ylim(0, 1.1 * min(n_res, 2 * n_w) if n_res <= 2 * n_w else 1.1 * n_w)
            title = f"{title}, N = {n_res}"
        ax.set_xlabel("epoch")
        ax.set_title(title, fontsize=9)
        ax.tick_params(labelsize=7)
    axes[0].legend(fontsize=6, ncol=2)
    fig.suptitle(
        f"BNN training: Levenberg-Marquardt with MacKay evidence updates ({len(names)} network(s) "
        f"7-{model.hidden_}-{model.n_out_})"
    )
    return fig


def surrogate_figures(study) -> dict[str, plt.Figure]:
    """The ``surrogates`` stage's figures of a :class:`~hevlib.surrogates.evaluation.SurrogateStudy`, by
    file name: ``parity_<model>.png`` (train points of the split model, held-out points of the saved model)
    and ``bnn_training.png`` (the saved BNN). Both parity plots use symmetric-log axes for the BNN's
    log-transformed objectives."""
    bnn = study.models["bnn"]
    figures = {
        f"parity_{m}.png": parity_figure(
            {s: (study.data[s][1], pred[s]) for s in ("train", "heldout")},
            title=f"{m}: predicted vs simulated",
            log_objectives=bnn.log_targets,
            speed_dev_max=study.speed_dev_max,
        )
        for m, pred in study.predictions.items()
    }
    figures["bnn_training.png"] = training_curve_figure(bnn)
    return figures
