"""Merge the optimisers' fronts, keep the non-dominated designs, screen them, rank, keep and pick.

The steps of SPEC section 9, each a pure function over tables or arrays:

1. :func:`merge_fronts` -- one row per distinct design (the seven variables rounded to
   :data:`DEDUP_DECIMALS` decimals). A design found by several algorithms is kept once; ``algo``
   lists every algorithm that found it (``"nsga3+moead"``, in the order the fronts were given) and
   ``sources`` the rows it came from (``"nsga3-17+moead-4"``, row numbers within each front file).
   Its ``design_id`` is its first source. Predicted columns come from the first source (simulated
   ones are the same for every source: the simulator is deterministic).
2. :func:`hevlib.indicators.nondominated_mask` on the simulated objectives in minimisation form
   (:func:`hevlib.judging.objective_matrix`: ``Y * sense``); designs with a non-finite simulated objective
   are excluded first and counted.
3. Screening (:func:`hevlib.screen.apply_screening`): each rule of :func:`hevlib.screen.screening_rules`
   (declared once there, as a polars expression here, a numpy mask or a pymoo constraint elsewhere) gives
   a pass mask. Every rule is evaluated and reported (how many non-dominated designs it would remove on its own, and how
   many it removed in sequence); a rule switched off in ``params.screen`` removes nothing.
4. Ranking (:func:`hevlib.indicators.ideal_distance`): objectives in minimisation form are min-max normalised over the
   feasible set (a constant objective contributes 0) and each design is ranked by its Euclidean
   distance to the ideal point (the origin of the normalised space); ties keep merge order. The best
   ``n_keep`` are kept -- all of them when fewer are feasible.
5. Picking ``n_pick`` of the kept designs: ``recommend`` (the default: a shortlist for the validate stage's
   recommendation, :func:`hevlib.recommend.shortlist`; each seed's role in ``pick_role``),
   :func:`hevlib.indicators.pick_random` (``np.random.default_rng(seed)`` choice without replacement, as the
   study did) or :func:`hevlib.indicators.pick_diverse` (farthest-point sampling on objectives normalised over
   the kept set, starting from the best-ranked design; deterministic).
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import polars as pl
import pyarrow as pa

from hevlib.design import DESIGN_VARS, OBJECTIVES, RESPONSES
from hevlib.indicators import (
    Normalisation,
    ideal_distance,
    nondominated_mask,
    normalisation_dict,
    normalise,
    pick_diverse,
    pick_random,
    rank_by,
)
from hevlib.judging import JUDGED_SCALE, HvSettings, objective_matrix, spread
from hevlib.recommend import shortlist
from hevlib.results import Judging, ParetoCounts, ParetoSummary, Selection, SourceSummary
from hevlib.screen import SIM, apply_screening, screening_rules
from hevlib.tables import Table, columns, lazy, n_rows

PRED = "pred_"
#: Decimals the design variables are rounded to when looking for identical designs.
DEDUP_DECIMALS = 9
#: Per-front flags the optimisers write; dropped on merging (dominance and feasibility are recomputed).
FRONT_FLAGS: tuple[str, ...] = ("nondominated_sim", "feasible")


# ------------------------------------------------------------------------------------- merging
def merge_fronts(fronts: Mapping[str, Table], objectives: Sequence[str] = OBJECTIVES) -> pl.LazyFrame:
    """Concatenate the fronts (``{algo: table}``, in order) and keep one row per distinct design, lazily.

    Returns the first row of every distinct design with ``design_id``, ``algo``, ``sources`` and
    ``n_sources`` in front, then the seven variables, then every other column (pred_/sim_ columns; a
    column missing from one front is null there). The fronts' own flags (:data:`FRONT_FLAGS`) are
    dropped: dominance and feasibility are recomputed over the merged set.
    """
    parts = []
    for algo, front in fronts.items():
        if "+" in algo or "-" in algo:
            raise ValueError(f"front {algo!r}: algorithm names may not contain '+' or '-'")
        lf = lazy(front)
        have = columns(lf)
        need = list(DESIGN_VARS) + [f"{SIM}{k}" for k in objectives]
        missing = [c for c in need if c not in have]
        if missing:
            raise ValueError(f"front {algo!r}: missing column(s) {', '.join(missing)}")
        lf = lf.drop([c for c in (*FRONT_FLAGS, "algo", "source") if c in have]).with_row_index("__row")
        parts.append(
            lf.select(
                pl.format(f"{algo}-{{}}", pl.col("__row")).alias("source"),
                pl.lit(algo).alias("algo"),
                pl.all().exclude("__row"),
            )
        )
    if not parts:
        raise ValueError("no fronts to merge")
    allrows = pl.concat(parts, how="diagonal_relaxed")
    bad = (
        allrows.filter(~pl.all_horizontal(pl.col(v).cast(pl.Float64).is_finite().fill_null(False) for v in DESIGN_VARS))
        .select("algo", "source")
        .head(1)
        .collect()
    )
    if len(bad):
        raise ValueError(f"front {bad['algo'][0]!r}: non-finite design variable in row {bad['source'][0]}")
    keys = [f"__key_{v}" for v in DESIGN_VARS]
    rest = [c for c in allrows.collect_schema().names() if c not in ("source", "algo", *DESIGN_VARS)]
    # groups in order of first appearance, rows within a group in input order: the first is the first source
    return (
        allrows.with_columns(
            pl.col(v).cast(pl.Float64).round(DEDUP_DECIMALS).alias(k) for v, k in zip(DESIGN_VARS, keys, strict=True)
        )
        .group_by(keys, maintain_order=True)
        .agg(
            pl.col("source").first().alias("design_id"),
            pl.col("algo").unique(maintain_order=True).str.join("+").alias("algo"),
            pl.col("source").str.join("+").alias("sources"),
            pl.len().cast(pl.Int64).alias("n_sources"),
            *[pl.col(c).first() for c in (*DESIGN_VARS, *rest)],
        )
        .select("design_id", "algo", "sources", "n_sources", *DESIGN_VARS, *rest)
    )


def algo_names(algo: str) -> list[str]:
    """The algorithms of a merged ``algo`` entry (``"nsga3+moead"`` -> ``["nsga3", "moead"]``)."""
    return algo.split("+")


# --------------------------------------------------------------------------- the sources compared
JUDGED_OBJECT = "archive"


def source_summary(
    fronts: Mapping[str, Table],
    archives: Mapping[str, Table],
    reports: Mapping[str, dict],
    merged: Table,
    screen,
    optimise,
    norm: Normalisation,
) -> tuple[Judging, dict[str, float]]:
    """``reports/pareto.json``'s judging of every source and the hypervolumes' wall times (s; machine-dependent,
    for the logs). Every source is judged on the same object (``judged_object: archive``): every design it
    simulated (its archive, ``data/pareto/<source>_archive.parquet``: the DOE's included for the
    surrogate-assisted ones) that passes the screen, not thinned, with the one normalisation ``norm``
    (the judged scale's reference set, ``hev judge``: data no source produced) and reference point. Per source:
    that hypervolume (exact or Monte Carlo, :func:`hevlib.indicators.hypervolume`, with its points,
    samples and error), its ratio to the oracle's archive, the hypervolume of the front shown to users
    (the hypervolume-greedy subset of the archive, the same size for every source), simulations used,
    spread and share of the picks. One seed each: the seed spread is the benchmark's
    (``reports/benchmark/summary.json``)."""
    settings = HvSettings.from_params(norm, optimise, screen)
    judged = {a: settings.of(t) for a, t in archives.items()}
    shown = {a: settings.of(t) for a, t in fronts.items()}
    oracle_hv = judged["oracle"][0].value if "oracle" in judged else None
    oracle_front = shown["oracle"][0].value if "oracle" in shown else None
    picked_algos = lazy(merged).filter(pl.col("picked")) if "picked" in columns(merged) else None
    n_by_algo = _count(picked_algos, list(fronts)) if picked_algos is not None else dict.fromkeys(fronts, 0)
    n_picked = max(n_rows(picked_algos) if picked_algos is not None else 0, 1)
    sources = {}
    for a, t in fronts.items():
        n_a = n_by_algo[a]
        h, n_counted = judged[a]
        f, _ = shown[a]
        sources[a] = SourceSummary(
            judged_object=JUDGED_OBJECT,
            hypervolume=h.value,
            hypervolume_se=h.se,
            hypervolume_method=h.method,
            hypervolume_points=h.n_points,
            hypervolume_designs=n_counted,
            hv_ratio_to_oracle=h.value / oracle_hv if oracle_hv else None,
            front_hypervolume=f.value,
            front_hypervolume_se=f.se,
            front_hv_ratio_to_oracle=f.value / oracle_front if oracle_front else None,
            n_simulations=reports[a].get("n_simulations"),
            archive_size=n_rows(archives[a]),
            front_size=n_rows(t),
            picked=n_a,
            picked_share=n_a / n_picked,
            spread=spread(t, norm),
            seed_spread=f"reports/benchmark/summary.json: sources.{a}",
        )
    hv_report = {**settings.describe(), "choice": {a: h.describe() for a, (h, _) in judged.items()}}
    hv_report.pop("normalisation")
    wall = {a: h.wall_s for a, (h, _) in judged.items()}
    return Judging(
        judged_object=JUDGED_OBJECT,
        judged_object_means="every design the source simulated (the DOE's included for the surrogate-assisted "
        "sources) that passes the screen, not thinned; the oracle is the best-known front at its budget, not the truth",
        hv_reference=settings.reference,
        normalisation={**normalisation_dict(norm), "built_from": JUDGED_SCALE},
        hypervolume=hv_report,
        sources=sources,
    ), wall


# ------------------------------------------------------------------------------ rank and pick
#: How each ``screen.pick`` chooses the designs to validate (reported in ``reports/pareto.json``).
PICK_RULES = {
    "recommend": "shortlist for a recommendation (hevlib/recommend.py): the knee of sizing-cycle fc against "
    "m_veh and t_0_100_s, the best design of each objective group (fuel; emissions; performance), then "
    "farthest-point sampling over the normalised objectives; the validate stage recommends one of them",
    "random": "seeded random choice without replacement, as the study did",
    "diverse": "farthest-point sampling over the normalised objectives from the best-ranked design",
}


# -------------------------------------------------------------------------------- the stage
class _Clock:
    """Wall seconds since the previous call, stored under each step's name (nothing when ``into`` is None)."""

    def __init__(self, into: dict[str, float] | None):
        self.into, self.t = into, time.perf_counter()

    def __call__(self, step: str) -> None:
        now = time.perf_counter()
        if self.into is not None:
            self.into[step] = now - self.t
        self.t = now


@dataclass
class ParetoResult:
    """Everything the ``pareto`` stage writes: the merged table, the picked designs (polars), the summary."""

    merged: pl.DataFrame
    selected: pl.DataFrame
    summary: ParetoSummary


def _count(rows: Table, names: Sequence[str]) -> dict[str, int]:
    """Per algorithm, the rows of ``rows`` it found (``algo`` lists every algorithm of a merged design)."""
    algos = pl.col("algo").str.split("+")
    counts = lazy(rows).select([algos.list.contains(a).sum().alias(a) for a in names]).collect()
    return {a: int(counts[a][0] or 0) for a in names}


def select_designs(
    fronts: Mapping[str, Table],
    screen,
    objectives: Sequence[str] = OBJECTIVES,
    *,
    timings: dict[str, float] | None = None,
) -> ParetoResult:
    """Merge, filter, screen, rank, keep and pick (module docstring); ``screen`` is ``params.screen``.

    ``fronts`` may be polars (lazy: a scan of Parquet parts) or pandas tables; the merged table is
    collected once (every column of the distinct designs), the objectives are read from it as one float
    matrix for the non-dominated filter and the ranking. ``timings``, when given, receives the wall
    seconds of each step (``merge``, ``nondominated``, ``screen``, ``rank_pick``, ``summary``)."""
    clock = _Clock(timings)
    names = list(fronts)
    n_in = {a: n_rows(f) for a, f in fronts.items()}
    merged = merge_fronts(fronts, objectives).collect()
    clock("merge")
    F = objective_matrix(merged, objectives, what="merged fronts")
    finite = np.all(np.isfinite(F), axis=1)
    nondom = nondominated_mask(F)
    clock("nondominated")
    feasible, masks, rule_report = apply_screening(merged, screening_rules(screen), candidates=nondom)
    clock("screen")

    distance = np.full(len(merged), np.nan)
    rank = np.full(len(merged), -1, dtype=np.int64)
    idx_feas = np.flatnonzero(feasible)
    distance[idx_feas] = ideal_distance(F[idx_feas])
    rank[idx_feas] = rank_by(distance[idx_feas])
    kept = feasible & (rank >= 1) & (rank <= screen.n_keep)

    idx_kept = np.flatnonzero(kept)
    idx_kept = idx_kept[np.argsort(rank[idx_kept], kind="stable")]  # best first
    roles: dict[str, int] = {}
    if screen.pick == "recommend":
        kept_rows = merged[idx_kept].select([f"{SIM}{k}" for k in RESPONSES if f"{SIM}{k}" in merged.columns])
        local, roles = shortlist(kept_rows.to_pandas(), screen.n_pick)
    elif screen.pick == "random":
        local = pick_random(len(idx_kept), screen.n_pick, screen.seed)
    else:
        local = pick_diverse(normalise(F[idx_kept]), screen.n_pick, start=0)
    picked = np.zeros(len(merged), dtype=bool)
    picked[idx_kept[local]] = True
    role = np.full(len(merged), "", dtype=object)
    for name, i in roles.items():
        j = idx_kept[i]
        role[j] = f"{role[j]}+{name}" if role[j] else name

    merged = merged.with_columns(
        pl.Series("finite", finite),
        pl.Series("nondominated", nondom),
        *[pl.Series(f"pass_{name}", ok) for name, ok in masks.items()],
        pl.Series("feasible", feasible),
        pl.Series("ideal_distance", distance).fill_nan(None),
        pl.Series("rank", rank),
        pl.Series("kept", kept),
        pl.Series("picked", picked),
        pl.Series("pick_role", role.tolist(), dtype=pl.String),
    )

    sel_cols = [
        "design_id",
        "algo",
        "sources",
        "rank",
        "ideal_distance",
        "pick_role",
        *DESIGN_VARS,
        *[f"{SIM}{k}" for k in objectives],
        *[c for c in merged.columns if c.startswith(PRED)],
    ]
    selected = merged.filter(pl.col("picked")).select(sel_cols).sort("rank", maintain_order=True)
    clock("rank_pick")

    notes = []
    if idx_feas.size < screen.n_keep:
        notes.append(f"only {idx_feas.size} feasible designs, fewer than n_keep={screen.n_keep}: all kept")
    if idx_kept.size < screen.n_pick:
        notes.append(f"only {idx_kept.size} kept designs, fewer than n_pick={screen.n_pick}: all picked")
    n_rows_in = int(sum(n_in.values()))
    subsets = {
        "merged": merged,
        "nondominated": merged.filter(pl.col("nondominated")),
        "feasible": merged.filter(pl.col("feasible")),
        "kept": merged.filter(pl.col("kept")),
        "picked": merged.filter(pl.col("picked")),
    }
    counts = {what: _count(rows, names) for what, rows in subsets.items()}
    summary = ParetoSummary(
        counts=ParetoCounts(
            input=n_rows_in,
            duplicates_removed=n_rows_in - len(merged),
            merged=len(merged),
            non_finite=int((~finite).sum()),
            nondominated=int(nondom.sum()),
            feasible=int(feasible.sum()),
            kept=int(kept.sum()),
            picked=int(picked.sum()),
        ),
        screen=rule_report,
        by_algo={a: {"input": n_in[a], **{what: counts[what][a] for what in subsets}} for a in names},
        shared_designs=int((merged["n_sources"] > 1).sum()),
        kept_share={a: c / max(int(kept.sum()), 1) for a, c in counts["kept"].items()},
        picked_share={a: c / max(int(picked.sum()), 1) for a, c in counts["picked"].items()},
        selection=Selection(
            rank_rule="euclidean distance to the ideal point, objectives min-max normalised over the feasible set",
            n_keep=int(screen.n_keep),
            n_pick=int(screen.n_pick),
            pick=screen.pick,
            seed=int(screen.seed) if screen.pick == "random" else None,
            pick_rule=PICK_RULES[screen.pick],
            roles={name: str(merged["design_id"][int(idx_kept[i])]) for name, i in roles.items()},
        ),
        notes=notes,
    )
    clock("summary")
    return ParetoResult(merged=merged, selected=selected, summary=summary)


# ---------------------------------------------------------------------------------- schemas
def table_schema(table: Table) -> pa.Schema:
    """Explicit schema for the merged / selected tables: id strings, int64 for integer columns (counters,
    rank, integer design variables as the fronts store them), bool masks, float64 for the rest."""
    fields = []
    for col, dtype in lazy(table).collect_schema().items():
        if col in ("design_id", "algo", "sources", "pick_role"):
            fields.append(pa.field(col, pa.string(), nullable=False))
        elif dtype == pl.Boolean:
            fields.append(pa.field(col, pa.bool_(), nullable=False))
        elif dtype.is_integer():
            fields.append(pa.field(col, pa.int64(), nullable=False))
        else:
            fields.append(pa.field(col, pa.float64()))
    return pa.schema(fields)


__all__ = [
    "DEDUP_DECIMALS",
    "FRONT_FLAGS",
    "JUDGED_OBJECT",
    "PICK_RULES",
    "PRED",
    "ParetoResult",
    "algo_names",
    "merge_fronts",
    "select_designs",
    "source_summary",
    "table_schema",
]
