"""``reports/benchmark/``: every run scored (:mod:`hevlib.benchmark.scoring`), summarised and drawn.

- ``summary.json`` -- the contract: ``judged_object``, ``normalisation`` (ideal, nadir, what it was built
  from), ``hv_reference``, ``sources: {source: {n_seeds, budgets: {"<n>": {median, q1, q3}}}}``,
  ``tests: {"<n>": {<saea>: {saea, direct, p_holm, a12, ...}}}``; plus the final populations, IGD+, the
  sensitivity check on a normalisation over every archive, the bar of issue 24 and plain-words findings;
- ``curves.csv`` -- median and quartiles per source and budget (DVC plots);
- ``runs.csv`` -- every run's figures at every budget;
- ``anytime.png`` -- hypervolume against simulations, median and IQR band per source, the oracle's
  archive as the ceiling.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq

from hevlib.benchmark.runs import CEILING, DIRECT, KIND, SAEA, n_runs
from hevlib.benchmark.scoring import (
    JUDGED_OBJECT,
    Run,
    best_known_front,
    both_indicators,
    budget_table,
    budgets_of,
    comparisons,
    judged_run,
    sample_box,
    score_runs,
    summary_stats,
)
from hevlib.indicators import CommonSamples, Normalisation, normalisation_dict
from hevlib.io import read_table, write_json, write_table
from hevlib.judging import JUDGED_SCALE, judged_normalisation


def load_runs(cfg, runs_dir: Path) -> tuple[list[Run], dict[str, float]]:
    """Every run on disk of the configured sources (judged points) and their wall times (s)."""
    runs, wall = [], {}
    for source in cfg.benchmark.sources:
        for k in range(n_runs(cfg, source)):
            path = Path(runs_dir) / source / f"run_{k}.parquet"
            if not path.exists():
                raise FileNotFoundError(f"{path}: no such run; run `hev benchmark-run {source}` first")
            table = pq.read_table(path)
            meta = table.schema.metadata or {}
            wall[f"{source}/{k}"] = float(meta.get(b"hev.wall_s", b"nan"))
            runs.append(judged_run(source, k, table.to_pandas(), cfg.screen))
    return runs, wall


def _bar(tests: dict, budget_stats: dict, ceiling: str, budget: int, share: float) -> dict:
    """Issue 24's bar at ``budget``: some SAEA beats the best direct search (Holm p < alpha, A12 large,
    higher median) and reaches ``share`` of the oracle archive's median."""
    key = str(budget)
    oracle_median = budget_stats.get(ceiling, {}).get("end", {}).get("median")
    rows = []
    for t in tests.get(key, {}).values():
        ratio = t["saea_median"] / oracle_median if oracle_median else None
        rows.append(
            {
                **{k: t[k] for k in ("saea", "direct", "p_holm", "a12", "beats_direct")},
                "ratio_to_oracle_median": ratio,
                "meets_bar": bool(t["beats_direct"] and ratio is not None and ratio >= share),
            }
        )
    return {
        "budget": budget,
        "oracle_share_required": share,
        "oracle_archive_median": oracle_median,
        "candidates": rows,
        "met": any(r["meets_bar"] for r in rows),
    }


def _findings(tests: dict, bar: dict, table: dict) -> list[str]:
    out = []
    for b, per in tests.items():
        rows = list(per.values())
        winners = [r["saea"] for r in rows if r["beats_direct"]]
        best = rows[0]["direct"] if rows else None
        out.append(
            f"at {b} simulations: "
            + (f"{', '.join(winners)} beat{'s' if len(winners) == 1 else ''} the best direct search ({best})" if winners
               else f"no surrogate-assisted source beats the best direct search ({best})")
        )  # fmt: skip
    out.append(
        f"bar at {bar['budget']} simulations (beat the best direct search and reach "
        f"{bar['oracle_share_required']:.2f} of the oracle archive's median): " + ("met" if bar["met"] else "not met")
    )
    return out


def benchmark_report(cfg, runs_dir: Path, reference_path: Path, out_dir: Path, progress=None) -> str:
    """Score every run and write ``out_dir``; returns a one-line summary."""
    b = cfg.benchmark
    runs, wall = load_runs(cfg, runs_dir)
    reference = float(cfg.optimise.hv_reference)
    norm = judged_normalisation(read_table(reference_path), cfg.screen)
    budgets = {s: budgets_of(s, b.budgets, b.budget, b.direct_budget) for s in cfg.benchmark.sources}
    lo = sample_box(runs, norm, reference)
    samples = CommonSamples.draw(lo, reference, b.hv_samples, b.hv_seed)
    front = best_known_front(runs, norm, reference)
    igd_at = list(b.budgets)
    scores = score_runs(runs, norm, samples, budgets, front, igd_at, progress=progress)

    # sensitivity: the same at 1000 simulations and at the end on a normalisation over every archive
    all_F = np.vstack([r.F for r in runs if len(r.F)])
    norm_all = Normalisation.from_points(all_F)
    lo_all = sample_box(runs, norm_all, reference)
    samples_all = CommonSamples.draw(lo_all, reference, b.hv_samples, b.hv_seed)
    sens_budgets = {s: [x for x in budgets[s] if x == 1000] for s in budgets}
    sens = score_runs(runs, norm_all, samples_all, sens_budgets, None)

    table = budget_table(scores)
    ends = scores.per_budget[scores.per_budget["at_end"]]
    for source, g in ends.groupby("source"):
        table.setdefault(source, {})["end"] = {
            **summary_stats(g["hypervolume"]),
            "n_simulations": summary_stats(g["budget"]),
        }
    tests = both_indicators(scores, b.budgets, b.alpha, b.a12_large)
    sens_tests = comparisons(sens, [1000], b.alpha, b.a12_large)
    bar = _bar(tests, table, CEILING[0], 1000, 0.95)
    sources = {}
    for source in cfg.benchmark.sources:
        fin = scores.final_population[scores.final_population["source"] == source]["hypervolume"]
        igd = scores.per_budget[(scores.per_budget["source"] == source) & scores.per_budget["igd_plus"].notna()]
        sources[source] = {
            "kind": KIND[source],
            "n_seeds": int(n_runs(cfg, source)),
            "budgets": {k: v for k, v in table.get(source, {}).items() if k != "end"},
            "end": table.get(source, {}).get("end"),
            "final_population": summary_stats(fin) if len(fin) else None,
            "igd_plus": {
                ("end" if at_end else str(int(bud))): summary_stats(g["igd_plus"].astype(float))
                for (bud, at_end), g in igd.groupby(["budget", "at_end"])
                if at_end or bud in igd_at
            },
            "sensitivity_all_archives": budget_table(sens).get(source, {}),
        }
    summary = {
        "judged_object": JUDGED_OBJECT,
        "judged_object_means": "of a run's first n simulations, every design that passes the screen with finite "
        "objectives, not thinned (the DOE counts for the surrogate-assisted sources)",
        "normalisation": {
            **normalisation_dict(norm),
            "built_from": JUDGED_SCALE,
        },
        "hv_reference": reference,
        "hypervolume": {
            "method": "Monte Carlo, common samples for every run and budget (hevlib.indicators.CommonSamples)",
            "n_samples": int(b.hv_samples),
            "seed": int(b.hv_seed),
            "box_lower": lo.tolist(),
            "box_volume": samples.volume,
        },
        "best_known_front_size": int(len(front)),
        "groups": {"saea": list(SAEA), "direct": list(DIRECT), "ceiling": list(CEILING)},
        "budgets": list(b.budgets),
        "sources": sources,
        "tests": tests,
        "tests_method": "two-sided Mann-Whitney U over runs, Holm over the surrogate-assisted sources at each budget, "
        "Vargha-Delaney A12 (P[SAEA run better than direct run]); against the direct source with the best median "
        "there, on hypervolume and on IGD+ (beside it, igd_plus); beats_direct only where both say so",
        "sensitivity": {
            "normalisation": "ideal and nadir of every run's judged designs together",
            "tests": sens_tests,
        },
        "bar": bar,
        "findings": _findings(tests, bar, table),
    }
    out_dir = Path(out_dir)
    write_json(out_dir / "summary.json", summary)
    curves = [
        {"source": s, "kind": KIND[s], "budget": int(k), **{q: v[q] for q in ("median", "q1", "q3")}}
        for s, per in table.items()
        for k, v in per.items()
        if k != "end"
    ]
    write_table(out_dir / "curves.csv", pd.DataFrame(curves), float_format="%.6g")
    write_table(out_dir / "runs.csv", scores.per_budget, float_format="%.6g")
    write_table(
        out_dir / "wall_times.csv",
        pd.DataFrame([{"run": k, "wall_s": v} for k, v in wall.items()]),
        float_format="%.1f",
    )
    from hevlib.plots import save_figure
    from hevlib.plots.benchmark import anytime_figure

    save_figure(anytime_figure(scores, table, CEILING[0]), out_dir / "anytime.png")
    return f"benchmark-report: {len(runs)} runs; " + "; ".join(summary["findings"]) + f" -> {out_dir}"


__all__ = ["benchmark_report", "load_runs"]
