"""The trust of each source in the answer: the held-out quality of the model it searched on (issue 53).

A surrogate-assisted source searches a model's predictions and hands on a front that is simulated afterwards:
its picks' figures are the simulator's and hold, but whether its front lies near the best designs depends on the
model it followed. The surrogates stage judges the BNN and the regressions on held-out designs neither ever saw
(``reports/surrogate_metrics.json``; the models fitted on every DOE design, the ones round 0 of every optimiser
searches; infill rounds refit them on more designs, which nothing judges on held-out designs). A model whose
held-out R² on an objective is below 0 predicts it worse than the constant mean of the held-out designs; a source
that optimises that objective on it is **flagged**. The oracle searches the simulator itself; the BoTorch sources
fit Gaussian processes of their own, whose held-out quality nothing measures -- said so, not invented.

Which source searched what comes from its own report (``reports/optimise_<source>.json``: ``surrogate``, and
``objectives_modelled`` for the BoTorch sources; every other source optimises all eleven objectives).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from hevlib.design import OBJECTIVES
from hevlib.results import SourceTrust, Trust

#: The split of ``reports/surrogate_metrics.json`` the rule reads: every held-out design.
SPLIT = "heldout"
#: ... and the one shown beside it: the held-out designs that follow the sizing cycle.
FOLLOWERS = "heldout_followers"
#: The rule: a model is worse than a constant on an objective where its held-out R² is below this.
R2_BELOW = 0.0
SURROGATES = ("bnn", "regression")
ALGORITHMS = {
    "nsga3": "NSGA-III",
    "moead": "MOEA/D",
    "moga": "the weighted-sum GA",
    "parego": "BoTorch's qLogNParEGO",
    "nehvi": "BoTorch's qLogNEHVI",
}
MODELS = {
    "bnn": "the BNN",
    "regression": "the regressions",
    "gp": "its own Gaussian processes",
    "simulator": "the simulator",
    "unknown": "an unknown model",
}


def _r2(value) -> float | None:
    return float(value) if isinstance(value, int | float) and math.isfinite(value) else None


def _table(metrics: Mapping | None, split: str) -> dict[str, dict[str, float | None]]:
    """``{surrogate: {objective: R²}}`` of one split (None where not finite)."""
    if not metrics:
        return {}
    return {
        s: {o: _r2(metrics[s][split].get(o, {}).get("r2")) for o in OBJECTIVES}
        for s in SURROGATES
        if isinstance(metrics.get(s), Mapping) and split in metrics[s]
    }


def _source(name: str, report: Mapping | None, r2: Mapping[str, Mapping], metrics_path: str) -> SourceTrust:
    if report is None:
        model, objectives = "unknown", list(OBJECTIVES)
    elif name == "oracle" or not report.get("surrogate"):
        model, objectives = "simulator", list(OBJECTIVES)
    else:
        model = str(report["surrogate"])
        objectives = list(report.get("objectives_modelled") or OBJECTIVES)
    if name == "oracle":
        algorithm = ALGORITHMS.get(str((report or {}).get("algorithm") or "nsga3"), "NSGA-III")
        searched_on = f"{algorithm} on the simulator, the oracle"
    else:
        searched_on = f"{ALGORITHMS.get(name, name)} on {MODELS.get(model, model)}"
    heldout, worse = None, []
    if model == "simulator":
        note = "searches the simulator itself: no model between its search and the figures"
    elif model == "unknown":
        note = f"no reports/optimise_{name}.json: what it searched on is not known"
    elif model == "gp":
        note = (
            "held-out quality not measured: BoTorch refits its Gaussian processes on the designs it simulated, "
            "every round, and nothing judges them on held-out designs"
        )
    elif model not in r2:
        note = f"held-out quality not measured: {metrics_path} holds no held-out metrics of {MODELS.get(model, model)}"
    else:
        heldout = {o: r2[model].get(o) for o in objectives}
        worse = [o for o, v in heldout.items() if v is not None and v < R2_BELOW]
        known = {o: v for o, v in heldout.items() if v is not None}
        if worse:
            note = (
                f"worse than a constant (held-out R² below {R2_BELOW:g}) on {len(worse)} of the {len(objectives)} "
                "objectives it optimises: " + ", ".join(f"{o} {heldout[o]:.3g}" for o in worse)
            )
        elif known:
            low = min(known, key=known.get)
            shown = ([f"fc {known['fc']:.2f}"] if "fc" in known else []) + [f"lowest: {low} {known[low]:.2f}"]
            note = f"held-out R² at least {R2_BELOW:g} on every objective it optimises ({'; '.join(shown)})"
        else:
            note = f"held-out quality not measured: no finite held-out R² of {MODELS.get(model, model)}"
    return SourceTrust(
        source=name,
        searched_on=searched_on,
        model=model,
        objectives=objectives,
        heldout_r2=heldout,
        worse_than_constant=worse,
        flagged=bool(worse),
        note=note,
    )


def source_trust(
    metrics: Mapping | None,
    reports: Mapping[str, Mapping | None],
    sources: Sequence[str],
    metrics_path: str = "reports/surrogate_metrics.json",
) -> Trust:
    """The :class:`~hevlib.results.Trust` of the merged ``sources`` (the pareto stage's order): ``metrics`` is
    the surrogates stage's ``reports/surrogate_metrics.json`` (None: not on disk), ``reports`` each source's
    ``reports/optimise_<source>.json`` (None where missing)."""
    r2 = _table(metrics, SPLIT)
    per = {s: _source(s, reports.get(s), r2, metrics_path) for s in sources}
    n = (metrics or {}).get("n_designs", {})
    return Trust(
        metrics=metrics_path if metrics else f"{metrics_path} (not on disk)",
        split=SPLIT,
        rule=(
            f"a source is flagged where the model it searched on has a held-out R² below {R2_BELOW:g} (worse than "
            "predicting the held-out designs' mean) on an objective it optimises; not measured is not flagged"
        ),
        n_heldout={k: int(n[k]) for k in (SPLIT, FOLLOWERS) if isinstance(n.get(k), int | float)},
        r2=r2,
        r2_followers=_table(metrics, FOLLOWERS),
        sources=per,
        flagged=[s for s, t in per.items() if t.flagged],
    )


def found_by(algo: str, trust: Trust | None) -> tuple[str, bool]:
    """What found a design whose ``algo`` is ``a`` or ``a+b`` (found by several): the words and whether it is
    flagged (only when every source that found it is flagged: one sound source vouches for the design)."""
    names = [a for a in str(algo).split("+") if a]
    if trust is None or not names or any(a not in trust.sources for a in names):
        return str(algo), False
    parts = [trust.sources[a] for a in names]
    return " and ".join(p.searched_on for p in parts), all(p.flagged for p in parts)


__all__ = ["ALGORITHMS", "FOLLOWERS", "MODELS", "R2_BELOW", "SPLIT", "found_by", "source_trust"]
