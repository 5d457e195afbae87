"""Merge the optimisers' fronts, keep the non-dominated designs, screen them, rank, keep and pick.

The steps of SPEC section 9, each a pure function over tables or arrays:

1. :func:`merge_fronts` -- one row per distinct design (the seven variables rounded to
   :data:`DEDUP_DECIMALS` decimals). A design found by several algorithms is kept once; ``algo``
   lists every algorithm that found it (``"nsga3+moead"``, in the order the fronts were given) and
   ``sources`` the rows it came from (``"nsga3-17+moead-4"``, row numbers within each front file).
   Its ``design_id`` is its first source. Predicted columns come from the first source (simulated
   ones are the same for every source: the simulator is deterministic).
2. :func:`nondominated_mask` on the simulated objectives in minimisation form (``Y * sense``);
   designs with a non-finite simulated objective are excluded first and counted.
3. Screening: each rule of :func:`screening_rules` is a named function returning a pass mask. Every
   rule is evaluated and reported (how many non-dominated designs it would remove on its own, and how
   many it removed in sequence); a rule switched off in ``params.screen`` removes nothing.
4. Ranking (:func:`ideal_distance`): objectives in minimisation form are min-max normalised over the
   feasible set (a constant objective contributes 0) and each design is ranked by its Euclidean
   distance to the ideal point (the origin of the normalised space); ties keep merge order. The best
   ``n_keep`` are kept -- all of them when fewer are feasible.
5. Picking ``n_pick`` of the kept designs: :func:`pick_random` (``np.random.default_rng(seed)``
   choice without replacement, as the study did) or :func:`pick_diverse` (farthest-point sampling on
   objectives normalised over the kept set, starting from the best-ranked design; deterministic).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
import pyarrow as pa

from hevlib.design import DESIGN_VARS, OBJECTIVES, RESPONSES, SENSE, gear_set_buildable
from hevlib.indicators import Normalisation, hypervolume_mc

SIM, PRED = "sim_", "pred_"
#: Decimals the design variables are rounded to when looking for identical designs.
DEDUP_DECIMALS = 9
#: Per-front flags the optimisers write; dropped on merging (dominance and feasibility are recomputed).
FRONT_FLAGS: tuple[str, ...] = ("nondominated_sim", "feasible")
_SENSE_OF = dict(zip(OBJECTIVES, SENSE, strict=True))


# ----------------------------------------------------------------------------------- dominance
def nondominated_mask(F: np.ndarray) -> np.ndarray:
    """Boolean mask of the rows of ``F`` (n, m; all minimised) that no other row dominates.

    Duplicated rows do not dominate each other, so all copies of a non-dominated point are kept.
    """
    F = np.asarray(F, dtype=float)
    n = F.shape[0]
    keep = np.ones(n, dtype=bool)
    for start in range(0, n, 512):  # blocks keep memory at O(512 * n * m)
        block = F[start : start + 512]
        le = np.all(F[None, :, :] <= block[:, None, :], axis=2)
        lt = np.any(F[None, :, :] < block[:, None, :], axis=2)
        keep[start : start + 512] = ~np.any(le & lt, axis=1)
    return keep


def sense_of(objectives: Sequence[str]) -> np.ndarray:
    """+1 (minimised) / -1 (maximised) per objective name; names outside OBJECTIVES are minimised."""
    return np.array([_SENSE_OF.get(k, 1.0) for k in objectives])


def to_minimisation(Y: np.ndarray, objectives: Sequence[str] = OBJECTIVES) -> np.ndarray:
    """Objectives (..., m) in natural units -> minimisation form (v_max, f_max negated); its own inverse.
    The one place maximised objectives change sign."""
    return np.asarray(Y, dtype=float) * sense_of(objectives)


def objective_matrix(
    table: pd.DataFrame, objectives: Sequence[str] = OBJECTIVES, *, prefix: str = SIM, what: str = "designs"
) -> np.ndarray:
    """The (n, m) matrix of ``<prefix><objective>`` columns in minimisation form (maximised ones negated)."""
    cols = [f"{prefix}{k}" for k in objectives]
    missing = [c for c in cols if c not in table.columns]
    if missing:
        raise ValueError(f"{what}: missing objective column(s) {', '.join(missing)}")
    return to_minimisation(table[cols].to_numpy(dtype=float), objectives)


# ------------------------------------------------------------------------------------- merging
def merge_fronts(fronts: Mapping[str, pd.DataFrame], objectives: Sequence[str] = OBJECTIVES) -> pd.DataFrame:
    """Concatenate the fronts (``{algo: table}``, in order) and keep one row per distinct design.

    Returns the first row of every distinct design with ``design_id``, ``algo``, ``sources`` and
    ``n_sources`` in front, then the seven variables, then every other column (pred_/sim_ columns; a
    column missing from one front is NaN there). The fronts' own flags (:data:`FRONT_FLAGS`) are
    dropped: dominance and feasibility are recomputed over the merged set.
    """
    parts = []
    for algo, front in fronts.items():
        if "+" in algo or "-" in algo:
            raise ValueError(f"front {algo!r}: algorithm names may not contain '+' or '-'")
        need = list(DESIGN_VARS) + [f"{SIM}{k}" for k in objectives]
        missing = [c for c in need if c not in front.columns]
        if missing:
            raise ValueError(f"front {algo!r}: missing column(s) {', '.join(missing)}")
        part = front.drop(columns=[c for c in (*FRONT_FLAGS, "algo") if c in front.columns])
        part = part.reset_index(drop=True)
        part.insert(0, "algo", algo)
        part.insert(0, "source", [f"{algo}-{i}" for i in range(len(part))])
        parts.append(part)
    if not parts:
        raise ValueError("no fronts to merge")
    allrows = pd.concat(parts, ignore_index=True)
    X = allrows[list(DESIGN_VARS)].to_numpy(dtype=float)
    if not np.all(np.isfinite(X)):
        row = allrows.iloc[int(np.argmax(~np.all(np.isfinite(X), axis=1)))]
        raise ValueError(f"front {row['algo']!r}: non-finite design variable in row {row['source']}")
    key = pd.DataFrame(np.round(X, DEDUP_DECIMALS), columns=list(DESIGN_VARS))
    # groups are numbered by first appearance, so every per-group series below is in merge order
    group = key.groupby(list(DESIGN_VARS), sort=False).ngroup().to_numpy()
    by = allrows.groupby(group, sort=True)
    merged = allrows.loc[~pd.Series(group).duplicated().to_numpy()].reset_index(drop=True)
    merged.insert(0, "design_id", merged.pop("source"))
    merged["algo"] = by["algo"].agg(lambda s: "+".join(dict.fromkeys(s))).to_numpy()
    merged.insert(2, "sources", by["source"].agg("+".join).to_numpy())
    merged.insert(3, "n_sources", by.size().to_numpy().astype(np.int64))
    rest = [c for c in merged.columns if c not in ("design_id", "algo", "sources", "n_sources", *DESIGN_VARS)]
    return merged[["design_id", "algo", "sources", "n_sources", *DESIGN_VARS, *rest]]


def algo_names(algo: str) -> list[str]:
    """The algorithms of a merged ``algo`` entry (``"nsga3+moead"`` -> ``["nsga3", "moead"]``)."""
    return algo.split("+")


# ------------------------------------------------------------------------------------ screening
def rule_gen_below_motor(table: pd.DataFrame) -> np.ndarray:
    """Generator peak power strictly below motor peak power (``p_gen_kw < p_mot_kw``)."""
    return table["p_gen_kw"].to_numpy(dtype=float) < table["p_mot_kw"].to_numpy(dtype=float)


def rule_speed_dev(table: pd.DataFrame, max_share: float) -> np.ndarray:
    """Simulated share of the sizing cycle off the trace within ``max_share`` (NaN fails)."""
    return table[f"{SIM}speed_dev"].to_numpy(dtype=float) <= max_share


def rule_not_stalled(table: pd.DataFrame) -> np.ndarray:
    """The re-simulated design did not stall on the sizing cycle (a failed design never passes)."""
    return ~table[f"{SIM}stalled"].to_numpy(dtype=bool)


def rule_mass(table: pd.DataFrame, max_kg: float) -> np.ndarray:
    """Simulated test mass within ``max_kg`` (NaN fails)."""
    return table[f"{SIM}m_veh"].to_numpy(dtype=float) <= max_kg


def rule_buildable_gear_set(table: pd.DataFrame) -> np.ndarray:
    """The planetary set can be built (:func:`hevlib.design.gear_set_buildable`)."""
    n_r = np.round(table["n_r"].to_numpy(dtype=float)).astype(np.int64)
    n_s = np.round(table["n_s"].to_numpy(dtype=float)).astype(np.int64)
    return gear_set_buildable(n_r, n_s)


@dataclass(frozen=True)
class ScreenRule:
    """One screening rule: ``check(table)`` is True where a design passes."""

    name: str
    enabled: bool
    description: str
    check: Callable[[pd.DataFrame], np.ndarray]
    limit: float | None = None


def screening_rules(screen) -> list[ScreenRule]:
    """The rules of ``params.screen`` (:class:`hevlib.params.ScreenParams`), in the order they are applied."""
    return [
        ScreenRule("gen_below_motor", bool(screen.gen_below_motor), "p_gen_kw < p_mot_kw", rule_gen_below_motor),
        ScreenRule(
            "not_stalled", True, "not sim_stalled (stood still while the sizing cycle asked to move)", rule_not_stalled
        ),
        ScreenRule(
            "speed_dev_max",
            True,
            f"sim_speed_dev <= {screen.speed_dev_max:g} (share of the cycle off the trace)",
            lambda t: rule_speed_dev(t, screen.speed_dev_max),
            float(screen.speed_dev_max),
        ),
        ScreenRule(
            "mass_max",
            True,
            f"sim_m_veh <= {screen.mass_max_kg:g} kg",
            lambda t: rule_mass(t, screen.mass_max_kg),
            float(screen.mass_max_kg),
        ),
        ScreenRule(
            "buildable_gear_set",
            bool(screen.buildable_gear_set),
            "planet teeth (n_r-n_s)/2 whole and >= 9, (n_r+n_s) divisible by 4",
            rule_buildable_gear_set,
        ),
    ]


def apply_screening(
    table: pd.DataFrame, rules: Sequence[ScreenRule], candidates: np.ndarray | None = None
) -> tuple[np.ndarray, dict[str, np.ndarray], dict]:
    """Evaluate every rule on ``table``; return (feasible mask, {name: pass mask}, report).

    ``candidates`` (default: all rows) are the designs being screened; the report counts, among them,
    how many each rule fails on its own (``fails_alone``) and how many it removed when the enabled
    rules are applied in order (``removed_in_sequence``; 0 for a rule that is switched off).
    """
    n = len(table)
    cand = np.ones(n, dtype=bool) if candidates is None else np.asarray(candidates, dtype=bool)
    masks, report, alive = {}, {}, cand.copy()
    for rule in rules:
        ok = np.asarray(rule.check(table), dtype=bool)
        masks[rule.name] = ok
        removed = int(np.sum(alive & ~ok)) if rule.enabled else 0
        if rule.enabled:
            alive &= ok
        report[rule.name] = {
            "enabled": rule.enabled,
            "rule": rule.description,
            "limit": rule.limit,
            "fails_alone": int(np.sum(cand & ~ok)),
            "removed_in_sequence": removed,
            "remaining_after": int(alive.sum()),
        }
    return alive, masks, report


def passes_screen(table: pd.DataFrame, screen) -> np.ndarray:
    """(n,) bool: rows (``sim_`` objectives and the design variables) that pass every enabled rule of
    ``params.screen``."""
    return apply_screening(table, screening_rules(screen))[0]


def simulated_as_front(table: pd.DataFrame) -> pd.DataFrame:
    """A table of simulated designs (DOE, held-out: unprefixed responses) with the ``sim_`` names a front uses."""
    return table.rename(columns={k: f"{SIM}{k}" for k in RESPONSES if k in table.columns})


def screened_normalisation(tables: Sequence[pd.DataFrame], screen) -> Normalisation:
    """The hypervolume's normalisation: ideal and nadir (minimisation form) of the simulated designs of
    ``tables`` (``sim_`` columns) that pass the screen, so every objective spans the range of designs a
    user could pick (not of designs that barely move, which would squeeze fuel and emissions into a
    sliver near 0). Raises if no design passes."""
    F = []
    for t in tables:
        ok = passes_screen(t, screen) & np.all(np.isfinite(objective_matrix(t, OBJECTIVES, what="table")), axis=1)
        F.append(objective_matrix(t[ok], OBJECTIVES, what="table"))
    F = np.vstack(F) if F else np.zeros((0, len(OBJECTIVES)))
    if len(F) == 0:
        raise ValueError("hypervolume normalisation: no simulated design passes the screen")
    return Normalisation.from_points(F)


def screened_hypervolume(
    table: pd.DataFrame, screen, norm: Normalisation, reference: float, n_samples: int, seed: int
) -> tuple[float, float, int]:
    """(hypervolume, its standard error, designs counted) of the screen-passing rows of a front (``sim_``
    objectives; every row with finite objectives when ``screen`` is None) on ``norm``: the one
    hypervolume every report uses."""
    if len(table) == 0:
        return 0.0, 0.0, 0
    F = objective_matrix(table, OBJECTIVES, what="front")
    ok = np.all(np.isfinite(F), axis=1)
    if screen is not None:
        ok &= passes_screen(table, screen)
    hv, se = hypervolume_mc(norm(F[ok]), reference, n_samples=n_samples, seed=seed) if ok.any() else (0.0, 0.0)
    return hv, se, int(ok.sum())


def spread(table: pd.DataFrame, norm: Normalisation) -> dict[str, float]:
    """Per objective, the range of a front's simulated values in normalised units (0 = collapsed)."""
    F = norm(objective_matrix(table, OBJECTIVES, what="front")) if len(table) else np.zeros((0, len(OBJECTIVES)))
    F = F[np.all(np.isfinite(F), axis=1)]
    return {k: (float(np.ptp(F[:, j])) if len(F) else 0.0) for j, k in enumerate(OBJECTIVES)}


def normalisation_dict(norm: Normalisation) -> dict:
    """``{ideal: {objective: value}, nadir: {...}}`` in each objective's own units (natural sense: for
    ``v_max``, ``f_max`` the ideal is the largest)."""
    ideal, nadir = to_minimisation(norm.ideal), to_minimisation(norm.nadir)
    return {
        "ideal": {k: float(v) for k, v in zip(OBJECTIVES, ideal, strict=True)},
        "nadir": {k: float(v) for k, v in zip(OBJECTIVES, nadir, strict=True)},
    }


def normalisation_from_dict(data: dict) -> Normalisation:
    """The inverse of :func:`normalisation_dict`."""
    ideal = to_minimisation(np.array([data["ideal"][k] for k in OBJECTIVES], dtype=float))
    nadir = to_minimisation(np.array([data["nadir"][k] for k in OBJECTIVES], dtype=float))
    return Normalisation(ideal, nadir)


def source_summary(
    fronts: Mapping[str, pd.DataFrame], reports: Mapping[str, dict], merged: pd.DataFrame, screen, optimise
) -> dict:
    """``reports/pareto.json`` additions: the hypervolume normalisation (ideal and nadir of the
    screen-passing designs of every source's final front: fixed for this run), its reference point and,
    per source, its hypervolume, ratio to the oracle's, simulations used, spread and share of the picks."""
    norm = screened_normalisation(list(fronts.values()), screen)
    ref, n, seed = optimise.hv_reference, optimise.hv_samples, optimise.hv_seed
    hv = {a: screened_hypervolume(t, screen, norm, ref, n, seed) for a, t in fronts.items()}
    oracle_hv = hv["oracle"][0] if "oracle" in hv else None
    picked = merged.loc[merged["picked"], "algo"] if "picked" in merged else pd.Series(dtype=str)
    n_picked = max(len(picked), 1)
    sources = {}
    for a, t in fronts.items():
        n_a = int(sum(a in algo_names(g) for g in picked))
        sources[a] = {
            "hypervolume": hv[a][0],
            "hypervolume_se": hv[a][1],
            "hypervolume_designs": hv[a][2],
            "hv_ratio_to_oracle": hv[a][0] / oracle_hv if oracle_hv else None,
            "n_simulations": reports[a].get("n_simulations"),
            "front_size": int(len(t)),
            "picked": n_a,
            "picked_share": n_a / n_picked,
            "spread": spread(t, norm),
        }
    return {"hv_reference": ref, "normalisation": normalisation_dict(norm), "sources": sources}


# ------------------------------------------------------------------------------ rank and pick
def normalise(F: np.ndarray, ref: np.ndarray | None = None) -> np.ndarray:
    """Min-max normalise the columns of ``F`` over the rows of ``ref`` (default ``F``); constant -> 0."""
    F = np.asarray(F, dtype=float)
    ref = F if ref is None else np.asarray(ref, dtype=float)
    if len(ref) == 0:
        return np.zeros_like(F)
    lo, hi = ref.min(axis=0), ref.max(axis=0)
    span = hi - lo
    safe = np.where(span > 0, span, 1.0)
    return np.where(span > 0, (F - lo) / safe, 0.0)


def ideal_distance(F: np.ndarray) -> np.ndarray:
    """Euclidean distance of each row of ``F`` (minimisation form) to the ideal point, after normalising."""
    return np.linalg.norm(normalise(F), axis=1)


def rank_by(distance: np.ndarray) -> np.ndarray:
    """1-based ranks, smallest distance first; ties keep the input order."""
    order = np.argsort(distance, kind="stable")
    rank = np.empty(len(distance), dtype=np.int64)
    rank[order] = np.arange(1, len(distance) + 1)
    return rank


def pick_random(n: int, k: int, seed: int) -> np.ndarray:
    """``min(k, n)`` distinct indices of ``range(n)``, drawn with ``np.random.default_rng(seed)``, sorted."""
    rng = np.random.default_rng(seed)
    return np.sort(rng.choice(n, size=min(k, n), replace=False))


def pick_diverse(F_norm: np.ndarray, k: int, start: int = 0) -> np.ndarray:
    """Farthest-point sampling: from ``start``, repeatedly add the row farthest from those picked.

    Deterministic (ties go to the lowest index); returns ``min(k, n)`` indices in the order picked.
    """
    F_norm = np.asarray(F_norm, dtype=float)
    n = len(F_norm)
    k = min(k, n)
    if k == 0:
        return np.zeros(0, dtype=np.int64)
    picked = [int(start)]
    dmin = np.linalg.norm(F_norm - F_norm[start], axis=1)
    for _ in range(k - 1):
        dmin[picked] = -np.inf
        nxt = int(np.argmax(dmin))
        picked.append(nxt)
        dmin = np.minimum(dmin, np.linalg.norm(F_norm - F_norm[nxt], axis=1))
    return np.array(picked, dtype=np.int64)


# -------------------------------------------------------------------------------- the stage
@dataclass
class ParetoResult:
    """Everything the ``pareto`` stage writes: the merged table, the picked designs, the summary."""

    merged: pd.DataFrame
    selected: pd.DataFrame
    summary: dict = field(default_factory=dict)


def _share(algos: pd.Series, names: Sequence[str]) -> dict[str, float]:
    n = len(algos)
    return {a: (float(sum(a in algo_names(s) for s in algos)) / n if n else 0.0) for a in names}


def _count(algos: pd.Series, names: Sequence[str]) -> dict[str, int]:
    return {a: int(sum(a in algo_names(s) for s in algos)) for a in names}


def select_designs(fronts: Mapping[str, pd.DataFrame], screen, objectives: Sequence[str] = OBJECTIVES) -> ParetoResult:
    """Merge, filter, screen, rank, keep and pick (module docstring); ``screen`` is ``params.screen``."""
    names = list(fronts)
    n_in = {a: len(f) for a, f in fronts.items()}
    merged = merge_fronts(fronts, objectives)
    F = objective_matrix(merged, objectives, what="merged fronts")
    finite = np.all(np.isfinite(F), axis=1)
    nondom = np.zeros(len(merged), dtype=bool)
    nondom[finite] = nondominated_mask(F[finite])
    feasible, masks, rule_report = apply_screening(merged, screening_rules(screen), candidates=nondom)

    distance = np.full(len(merged), np.nan)
    rank = np.full(len(merged), -1, dtype=np.int64)
    idx_feas = np.flatnonzero(feasible)
    distance[idx_feas] = ideal_distance(F[idx_feas])
    rank[idx_feas] = rank_by(distance[idx_feas])
    kept = feasible & (rank >= 1) & (rank <= screen.n_keep)

    idx_kept = np.flatnonzero(kept)
    idx_kept = idx_kept[np.argsort(rank[idx_kept], kind="stable")]  # best first
    if screen.pick == "random":
        local = pick_random(len(idx_kept), screen.n_pick, screen.seed)
    else:
        local = pick_diverse(normalise(F[idx_kept]), screen.n_pick, start=0)
    picked = np.zeros(len(merged), dtype=bool)
    picked[idx_kept[local]] = True

    merged = merged.copy()
    merged["finite"] = finite
    merged["nondominated"] = nondom
    for name, ok in masks.items():
        merged[f"pass_{name}"] = ok
    merged["feasible"] = feasible
    merged["ideal_distance"] = distance
    merged["rank"] = rank
    merged["kept"] = kept
    merged["picked"] = picked

    sel_cols = [
        "design_id",
        "algo",
        "sources",
        "rank",
        "ideal_distance",
        *DESIGN_VARS,
        *[f"{SIM}{k}" for k in objectives],
        *[c for c in merged.columns if c.startswith(PRED)],
    ]
    selected = merged.loc[picked, sel_cols].sort_values("rank", kind="stable").reset_index(drop=True)

    notes = []
    if idx_feas.size < screen.n_keep:
        notes.append(f"only {idx_feas.size} feasible designs, fewer than n_keep={screen.n_keep}: all kept")
    if idx_kept.size < screen.n_pick:
        notes.append(f"only {idx_kept.size} kept designs, fewer than n_pick={screen.n_pick}: all picked")
    n_rows = int(sum(n_in.values()))
    summary = {
        "counts": {
            "input": n_rows,
            "duplicates_removed": n_rows - len(merged),
            "merged": len(merged),
            "non_finite": int((~finite).sum()),
            "nondominated": int(nondom.sum()),
            "feasible": int(feasible.sum()),
            "kept": int(kept.sum()),
            "picked": int(picked.sum()),
        },
        "screen": rule_report,
        "by_algo": {
            a: {
                "input": n_in[a],
                "merged": _count(merged["algo"], names)[a],
                "nondominated": _count(merged.loc[nondom, "algo"], names)[a],
                "feasible": _count(merged.loc[feasible, "algo"], names)[a],
                "kept": _count(merged.loc[kept, "algo"], names)[a],
                "picked": _count(merged.loc[picked, "algo"], names)[a],
            }
            for a in names
        },
        "shared_designs": int((merged["n_sources"] > 1).sum()),
        "kept_share": _share(merged.loc[kept, "algo"], names),
        "picked_share": _share(merged.loc[picked, "algo"], names),
        "selection": {
            "rank_rule": "euclidean distance to the ideal point, objectives min-max normalised over the feasible set",
            "n_keep": int(screen.n_keep),
            "n_pick": int(screen.n_pick),
            "pick": screen.pick,
            "seed": int(screen.seed) if screen.pick == "random" else None,
        },
        "notes": notes,
    }
    return ParetoResult(merged=merged, selected=selected, summary=summary)


# ---------------------------------------------------------------------------------- schemas
def table_schema(table: pd.DataFrame) -> pa.Schema:
    """Explicit schema for the merged / selected tables: id strings, int64 for integer columns (counters,
    rank, integer design variables as the fronts store them), bool masks, float64 for the rest."""
    fields = []
    for col in table.columns:
        dtype = table[col].dtype
        if col in ("design_id", "algo", "sources"):
            fields.append(pa.field(col, pa.string(), nullable=False))
        elif pd.api.types.is_bool_dtype(dtype):
            fields.append(pa.field(col, pa.bool_(), nullable=False))
        elif pd.api.types.is_integer_dtype(dtype):
            fields.append(pa.field(col, pa.int64(), nullable=False))
        else:
            fields.append(pa.field(col, pa.float64()))
    return pa.schema(fields)


__all__ = [
    "nondominated_mask",
    "sense_of",
    "objective_matrix",
    "merge_fronts",
    "algo_names",
    "rule_gen_below_motor",
    "rule_not_stalled",
    "rule_speed_dev",
    "rule_mass",
    "rule_buildable_gear_set",
    "ScreenRule",
    "screening_rules",
    "apply_screening",
    "normalise",
    "ideal_distance",
    "rank_by",
    "pick_random",
    "pick_diverse",
    "ParetoResult",
    "select_designs",
    "table_schema",
    "SIM",
    "PRED",
    "FRONT_FLAGS",
]
