"""``reports/validation.json`` (:func:`summarise`), ``reports/headline.json`` (:func:`headline`) and
``reports/answer.json`` (:func:`answer`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import pandas as pd

from hevlib.results import SEED_SPREAD_NOT_MEASURED, Counts, Recommendation, Trust, ValidationSummary
from hevlib.validation.improvement import (
    ALL,
    IMPROVEMENT_RESPONSES,
    SOC_POINTS,
    engine_downsizing,
    group_rows,
    improvement_table,
    mean_or_none,
)
from hevlib.validation.recommendation import failed_cycles
from hevlib.validation.runs import best_design, split_cycle

#: ``seed_spread_status`` of a seed-spread study made with this run's settings and code, and of one that was not.
SEED_SPREAD_CURRENT = "made with these settings and code"
SEED_SPREAD_OTHER = (
    "made with other settings or code, so not shown: `dvc repro benchmarks/robustness/dvc.yaml` makes it for this run"
)
#: What ``validation.json`` keeps of a current study (``reports/robustness/summary.json``).
SEED_SPREAD_KEYS = (
    "fingerprint",
    "replicates",
    "seeds_per_source",
    "family_share_of_range",
    "default_answer_share",
    "default_family_share",
    "recommended_by_source",
    "spread",
    "variable_range",
)


def seed_spread(robustness: Mapping | None) -> tuple[dict | None, str]:
    """``(seed_spread, seed_spread_status)`` of ``validation.json``: the study's figures only where it was made
    with this run's settings and code (``robustness["current"]``), else None and how to make them."""
    if not robustness:
        return None, SEED_SPREAD_NOT_MEASURED
    if not robustness.get("current"):
        return None, SEED_SPREAD_OTHER
    return {k: robustness[k] for k in SEED_SPREAD_KEYS if k in robustness}, SEED_SPREAD_CURRENT


def summarise(
    table: pd.DataFrame,
    algos: Sequence[str],
    cycles: Sequence[str],
    p_conv_kw: float,
    recommendation: Recommendation | None = None,
    trust: Trust | None = None,
    robustness: Mapping | None = None,
    controller_gap: Mapping | None = None,
) -> ValidationSummary:
    """``reports/validation.json``: headline (first cycle) improvement table, counts, engine downsizing,
    baseline and mean-pick responses, the same improvement table for every other cycle, and the
    ``recommendation`` (:func:`recommendation`) when given; the ``trust`` of each source
    (:func:`~hevlib.validation.trust.source_trust`) and the seed spread (:func:`seed_spread` of the
    ``robustness`` study, with its ``current`` flag); the ``controller_gap``
    (:func:`hevlib.validation.gap.recommended_gap`) where given."""
    headline = cycles[0]
    designs, baselines = split_cycle(table, headline)
    groups = group_rows(designs, algos)

    def _abs(df: pd.DataFrame) -> dict:
        return {r: mean_or_none(df[r].to_numpy(dtype=float)) for r in IMPROVEMENT_RESPONSES}

    by_cycle, met, balanced = {}, {}, {}
    for cycle in cycles:
        d, b = split_cycle(table, cycle)
        met[cycle] = {"picked": int(d["cycle_met"].sum()), **{k: bool(v["cycle_met"]) for k, v in b.items()}}
        balanced[cycle] = {
            "picked": int(d["charge_balanced"].sum()),
            **{k: bool(v["charge_balanced"]) for k, v in b.items()},
        }
        if cycle != headline:
            by_cycle[cycle] = {"improvement": improvement_table(d, b, algos)}
    return ValidationSummary(
        cycle=headline,
        improvement=improvement_table(designs, baselines, algos),
        units={r: ("SOC percentage points" if r in SOC_POINTS else "%") for r in IMPROVEMENT_RESPONSES},
        counts=Counts(
            picked=int(len(designs)),
            by_algo={g: int(m.sum()) for g, m in groups.items() if g != ALL},
            cycle_met=met,
            charge_balanced=balanced,
            failed_cycles=failed_cycles(table, cycles),
        ),
        engine_downsizing_pct=engine_downsizing(designs, algos, p_conv_kw),
        mean_p_eng_kw={g: mean_or_none(designs.loc[m, "p_eng_kw"].to_numpy(dtype=float)) for g, m in groups.items()},
        p_eng_conventional_kw=float(p_conv_kw),
        absolute={
            "mean_of_picks": {g: _abs(designs[m]) for g, m in groups.items()},
            **{name: {r: float(b[r]) for r in IMPROVEMENT_RESPONSES} for name, b in baselines.items()},
        },
        by_cycle=by_cycle,
        best_design=best_design(table, headline),
        recommendation=recommendation,
        trust=trust,
        **dict(zip(("seed_spread", "seed_spread_status"), seed_spread(robustness), strict=True)),
        controller_gap=dict(controller_gap) if controller_gap is not None else None,
    )


def headline(summary: ValidationSummary) -> dict:
    """``reports/headline.json``: the answer in six figures (its keys are a contract; ``reports/answer.json``,
    :func:`answer`, holds the same figures under short keys as the declared DVC metric).

    Mean of the picked designs on the first validation cycle (FTP): fuel saved against the conventional
    car and against the stock Prius (the study's protocol, from SOC 0.7: ``fc``), mass saved against the
    conventional car (percent, positive = better), mean engine power, number of picks; and the fuel saved
    against the conventional car on charge-balanced runs (``fc_charge_balanced``, SAE J1711: the battery's net
    energy within 1 % of the fuel's), the figure to quote; and the recommended design (``screen.pick:
    recommend``) with its own charge-balanced saving. The full tables stay in ``reports/validation.json``.
    """
    imp = summary.improvement[ALL]
    return {
        "fc_saving_charge_balanced_pct": imp["vs_conventional"]["fc_charge_balanced"],
        "fc_saving_pct": imp["vs_conventional"]["fc"],
        "fc_saving_vs_prius_pct": imp["vs_prius"]["fc"],
        "mass_saving_pct": imp["vs_conventional"]["m_veh"],
        "p_eng_kw": summary.mean_p_eng_kw[ALL],
        "n_picks": summary.counts.picked,
        **_recommended_headline(summary),
    }


def _recommended_headline(summary: ValidationSummary) -> dict:
    """The recommended design's id and its charge-balanced fuel saving against the conventional car on the
    headline cycle (null without a recommendation)."""
    rec = summary.recommendation.design if summary.recommendation is not None else None
    if rec is None:
        return {"recommended_design": None, "recommended_fc_saving_charge_balanced_pct": None}
    vs = rec.by_cycle[summary.cycle]["vs_conventional"]
    return {
        "recommended_design": rec.design_id,
        "recommended_fc_saving_charge_balanced_pct": vs["fc_charge_balanced"],
    }


#: ``reports/answer.json``'s short keys for the headline's figures, in the headline's order.
ANSWER_KEYS: dict[str, str] = {
    "fc_saving_charge_balanced_pct": "fc_cb_pct",
    "fc_saving_pct": "fc_pct",
    "fc_saving_vs_prius_pct": "fc_vs_prius_pct",
    "mass_saving_pct": "mass_pct",
    "p_eng_kw": "p_eng_kw",
    "n_picks": "n_picks",
    "recommended_fc_saving_charge_balanced_pct": "rec_fc_cb_pct",
}


def answer(head: dict) -> dict:
    """``reports/answer.json``, the pipeline's declared DVC metric: :func:`headline`'s figures under the short
    keys of :data:`ANSWER_KEYS`, so that ``dvc metrics show`` and ``dvc exp show`` fit one 120-column line
    (the long names of ``headline.json`` do not); the recommended design's id, a string, stays in the headline."""
    return {ANSWER_KEYS[k]: v for k, v in head.items() if k in ANSWER_KEYS}
