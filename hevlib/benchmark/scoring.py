"""Judging every benchmark run on one object, one normalisation and one set of samples.

- **Judged object** (``archive``): of the first ``n`` simulations of a run, the designs that pass every
  enabled screen rule with finite objectives -- not thinned (hypervolume only grows with it).
- **Normalisation**: ideal and nadir (minimisation form) of the screen-passing designs of the DOE and
  the held-out Latin hypercube: data no compared source produced, fixed before any run is scored and
  never given to a search. The sensitivity check repeats the figures on the ideal and nadir of every
  run's judged designs together.
- **Hypervolume**: up to ``optimise.hv_reference`` (1.1) in every normalised objective, Monte Carlo with
  the same ``benchmark.hv_samples`` uniform samples for every run and budget
  (:class:`hevlib.indicators.CommonSamples`), in the box from the lowest judged point of any run to the
  reference.
- **Also**: the final population's hypervolume, and IGD+ against the best-known front (the non-dominated
  designs of every run's judged archive together), at each budget.
- **Statistics**: at each budget, each surrogate-assisted source against the best direct search (the
  direct source with the highest median there): two-sided Mann-Whitney U over the runs, Holm-corrected
  over the surrogate-assisted sources at that budget, and Vargha-Delaney's A12 (the probability that a
  run of the SAEA beats a run of the direct search; 0.71 is a large effect).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hevlib.benchmark.runs import CEILING, DIRECT, KIND, SAEA
from hevlib.design import OBJECTIVES
from hevlib.indicators import CommonSamples, Normalisation, igd_plus, nondominated_mask
from hevlib.judging import objective_matrix
from hevlib.screen import passes_screen

JUDGED_OBJECT = "archive"


@dataclass(frozen=True)
class Run:
    """One run's judged points: ``index`` (simulation number, 1-based) and ``F`` (natural minimisation
    form) of its screen-passing designs with finite objectives, the final population's mask over them,
    and how many simulations the run made."""

    source: str
    run: int
    index: np.ndarray
    F: np.ndarray
    final: np.ndarray
    n_simulations: int


def judged_run(source: str, run: int, table: pd.DataFrame, screen) -> Run:
    """The judged points of one run's record (``hevlib.benchmark.runs.RUN_SCHEMA``)."""
    F = objective_matrix(table, OBJECTIVES, what=f"benchmark run {source} {run}")
    ok = np.all(np.isfinite(F), axis=1) & passes_screen(table, screen)
    idx = table["sim_index"].to_numpy(dtype=np.int64)
    return Run(source, run, idx[ok], F[ok], table["final_population"].to_numpy(dtype=bool)[ok], len(table))


def prefix(run: Run, budget: int) -> np.ndarray:
    """Mask of the judged points among the run's first ``budget`` simulations."""
    return run.index <= budget


def budgets_of(source: str, budgets: Sequence[int], budget: int, direct_budget: int) -> list[int]:
    """The checkpoints a source is compared at: those within its own budget (the direct searches run to
    ``direct_budget``, the others to ``budget``; the oracle's curve is a ceiling at every checkpoint)."""
    top = direct_budget if source in ("nsga3_direct", "moead_direct") else budget
    if source in CEILING:
        top = max(budgets)
    return [b for b in budgets if b <= top]


def summary_stats(values: Sequence[float]) -> dict:
    v = np.asarray(values, dtype=float)
    q1, med, q3 = np.percentile(v, [25, 50, 75])
    return {"median": float(med), "q1": float(q1), "q3": float(q3), "n": int(len(v))}


def a12(x: Sequence[float], y: Sequence[float]) -> float:
    """Vargha-Delaney A12: P(X > Y) + P(X = Y) / 2 over all pairs."""
    x, y = np.asarray(x, dtype=float)[:, None], np.asarray(y, dtype=float)[None, :]
    return float(np.mean((x > y) + 0.5 * (x == y)))


def holm(p: Sequence[float]) -> np.ndarray:
    """Holm's step-down adjusted p-values (monotone, capped at 1)."""
    p = np.asarray(p, dtype=float)
    order = np.argsort(p, kind="stable")
    adj = np.empty_like(p)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (len(p) - rank) * p[i]))
        adj[i] = running
    return adj


def mann_whitney(x: Sequence[float], y: Sequence[float]) -> float:
    """Two-sided Mann-Whitney U p-value (exact for small samples without ties, as scipy chooses)."""
    from scipy.stats import mannwhitneyu

    return float(mannwhitneyu(np.asarray(x, float), np.asarray(y, float), alternative="two-sided").pvalue)


def sample_box(runs: Sequence[Run], norm: Normalisation, reference: float) -> np.ndarray:
    """The samples' lower corner: the lowest normalised judged point of any run (and at most 0)."""
    lows = [norm(r.F).min(axis=0) for r in runs if len(r.F)]
    lo = np.minimum.reduce(lows) if lows else np.zeros(len(OBJECTIVES))
    lo = np.minimum(lo, 0.0)
    return np.minimum(lo, reference - 1e-9)


def best_known_front(runs: Sequence[Run], norm: Normalisation, reference: float) -> np.ndarray:
    """The non-dominated judged designs of every run together, normalised, below the reference (each
    run's own non-dominated set first: the union's filter then sees far fewer points)."""
    parts = []
    for r in runs:
        F = norm(r.F)
        F = F[np.all(F < reference, axis=1)]
        if len(F):
            parts.append(F[nondominated_mask(F)])
    if not parts:
        return np.zeros((0, len(OBJECTIVES)))
    F = np.vstack(parts)
    return F[nondominated_mask(F)]


@dataclass(frozen=True)
class Scores:
    """Per-run figures in long form (``source, run, budget, hypervolume, hypervolume_se, igd_plus,
    n_judged``) plus each run's final-population hypervolume."""

    per_budget: pd.DataFrame
    final_population: pd.DataFrame


def score_runs(
    runs: Sequence[Run],
    norm: Normalisation,
    samples: CommonSamples,
    budgets: Mapping[str, list[int]],
    reference_front: np.ndarray | None,
    igd_budgets: Sequence[int] = (),
    progress=None,
) -> Scores:
    """Hypervolume (common samples) at every checkpoint of ``budgets[source]`` and at the run's end
    (budget 0 means "every simulation"), IGD+ at ``igd_budgets`` and the end."""
    rows, finals = [], []
    for i, run in enumerate(runs):
        Fn = norm(run.F)
        for b in [*budgets[run.source], 0]:
            mask = prefix(run, b) if b else np.ones(len(Fn), dtype=bool)
            hv, se = samples.of(Fn[mask])
            igd = None
            if reference_front is not None and len(reference_front) and (b == 0 or b in igd_budgets):
                sub = Fn[mask]
                sub = sub[nondominated_mask(sub)] if len(sub) else sub
                igd = igd_plus(sub, reference_front)
            rows.append(
                {
                    "source": run.source,
                    "kind": KIND[run.source],
                    "run": run.run,
                    "budget": b if b else run.n_simulations,
                    "at_end": b == 0,
                    "hypervolume": hv,
                    "hypervolume_se": se,
                    "igd_plus": igd,
                    "n_judged": int(mask.sum()),
                }
            )
        hv, se = samples.of(Fn[run.final])
        finals.append({"source": run.source, "run": run.run, "hypervolume": hv, "hypervolume_se": se})
        if progress is not None:
            progress(i + 1, len(runs))
    return Scores(pd.DataFrame(rows), pd.DataFrame(finals))


def budget_table(scores: Scores) -> dict[str, dict[str, dict]]:
    """``{source: {"<budget>": {median, q1, q3, n}}}`` over runs (checkpoints only, not the run ends)."""
    df = scores.per_budget[~scores.per_budget["at_end"]]
    out: dict[str, dict[str, dict]] = {}
    for (source, budget), g in df.groupby(["source", "budget"], sort=True):
        out.setdefault(source, {})[str(int(budget))] = summary_stats(g["hypervolume"])
    return out


#: The judged indicators and their sense (+1: larger is better).
INDICATORS = {"hypervolume": 1.0, "igd_plus": -1.0}


def comparisons(
    scores: Scores, budgets: Sequence[int], alpha: float, a12_large: float, indicator: str = "hypervolume"
) -> dict[str, dict[str, dict]]:
    """``{"<budget>": {saea: {saea, direct, p_holm, a12, ...}}}``: at each budget, every surrogate-assisted
    source against the best direct search there on ``indicator`` (hypervolume: highest median; IGD+: lowest),
    Mann-Whitney (two-sided), Holm over the SAEAs at that budget, A12 (P[SAEA run better than direct run]);
    ``beats_direct`` when Holm p < ``alpha``, A12 >= ``a12_large`` and the SAEA's median is the better."""
    sense = INDICATORS[indicator]
    df = scores.per_budget[~scores.per_budget["at_end"] & scores.per_budget[indicator].notna()]
    out: dict[str, dict[str, dict]] = {}
    for b in budgets:
        at = df[df["budget"] == b]
        values = {s: sense * g[indicator].to_numpy(dtype=float) for s, g in at.groupby("source")}
        direct = {s: v for s, v in values.items() if s in DIRECT}
        saeas = {s: v for s, v in values.items() if s in SAEA}
        if not direct or not saeas:
            continue
        best = max(direct, key=lambda s: (float(np.median(direct[s])), s))
        names = sorted(saeas)
        p = [mann_whitney(saeas[s], direct[best]) for s in names]
        p_holm = holm(p)
        out[str(b)] = {
            s: {
                "saea": s,
                "direct": best,
                "indicator": indicator,
                "saea_median": float(sense * np.median(saeas[s])),
                "direct_median": float(sense * np.median(direct[best])),
                "p": float(pv),
                "p_holm": float(ph),
                "a12": a12(saeas[s], direct[best]),
                "beats_direct": bool(
                    ph < alpha
                    and a12(saeas[s], direct[best]) >= a12_large
                    and np.median(saeas[s]) > np.median(direct[best])
                ),
            }
            for s, pv, ph in zip(names, p, p_holm, strict=True)
        }
    return out


def both_indicators(scores: Scores, budgets: Sequence[int], alpha: float, a12_large: float) -> dict[str, dict]:
    """:func:`comparisons` on hypervolume with the IGD+ test of the same pair beside it (``igd_plus``);
    ``beats_direct`` only where both indicators say so (the claims a report may make)."""
    hv = comparisons(scores, budgets, alpha, a12_large, "hypervolume")
    igd = comparisons(scores, budgets, alpha, a12_large, "igd_plus")
    for b, per in hv.items():
        for s, t in per.items():
            other = igd.get(b, {}).get(s)
            t["beats_direct_hypervolume"] = t["beats_direct"]
            t["igd_plus"] = other
            t["beats_direct"] = bool(t["beats_direct"] and other is not None and other["beats_direct"])
    return hv


__all__ = [
    "JUDGED_OBJECT",
    "Run",
    "Scores",
    "a12",
    "best_known_front",
    "budget_table",
    "budgets_of",
    "both_indicators",
    "comparisons",
    "holm",
    "judged_run",
    "mann_whitney",
    "prefix",
    "sample_box",
    "score_runs",
    "summary_stats",
]
