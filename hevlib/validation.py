"""Validate the picked designs against the conventional car and the stock Prius (the study's Table 8).

:func:`validation_table` simulates every picked design and both baselines on each validation cycle
(one row per vehicle and cycle). :func:`improvement_table` turns one cycle of it into mean
improvements, '+' = better:

* minimised responses (mass, fuel, emissions): ``100 * (base - design) / |base|`` (%);
* maximised responses (``v_max``, ``f_max``, ``eta_drivetrain``): ``100 * (design - base) / |base|`` (%);
* ``diff_soc`` (SOC at start - SOC at end, minimised like the objective): ``100 * (base - design)``,
  an absolute difference in **SOC percentage points**, because a baseline's SOC difference can be
  near zero or negative and a percentage of it means nothing. Against the conventional car (no
  traction battery) it is not applicable and reported as null;
* a percentage whose base is zero or not finite is null, never a division by zero.

The mean over an algorithm's picks is the mean of the per-design improvements (the same as the
improvement of the mean design, the base being fixed); a design found by several algorithms counts
for each of them; ``"all"`` is every pick once. Engine downsizing is ``100 * (p_conv - mean p_eng_kw)
/ p_conv`` with ``p_conv`` the conventional car's engine power (70 kW).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Protocol

import numpy as np
import pandas as pd
import pyarrow as pa

from hevlib.cycles import Cycle
from hevlib.design import (
    BOOL_RESPONSES,
    CHARGE_BALANCE_RESPONSES,
    DESIGN_VARS,
    INTEGER_MASK,
    MAXIMISED_OBJECTIVES,
    RESPONSES,
    design_matrix,
    design_vector,
)
from hevlib.pareto import algo_names
from hevlib.recommend import (
    KNEE_CRITERIA,
    VALIDATED_GROUPS,
    knee_shares,
    minimisation,
    noise_spread,
    reasons,
    recommend,
    separation,
)
from hevlib.results import Counts, Equivalent, HighwayRule, Noise, Pick, Recommendation, ValidationSummary
from hevlib.screen import min_v_max, screening_rules

#: Responses of the improvement table, in its row order.
IMPROVEMENT_RESPONSES: tuple[str, ...] = (
    "m_veh",
    "fc_charge_balanced",
    "fc",
    "fc_soc_corrected",
    "diff_soc",
    "hc",
    "co",
    "nox",
    "v_max",
    "f_max",
    "eta_drivetrain",
)
#: Responses where more is better: the maximised objectives (hevlib.design) and the drivetrain efficiency.
MAXIMISED = frozenset({*MAXIMISED_OBJECTIVES, "eta_drivetrain"})
#: Responses whose improvement is an absolute difference (SOC percentage points), not a percentage.
SOC_POINTS = frozenset({"diff_soc"})
BASELINES: tuple[str, ...] = ("conventional", "prius")
#: Baselines without a traction battery: SOC comparisons against them are not applicable.
NO_BATTERY = frozenset({"conventional"})
BASELINE_ALGO = "baseline"
ALL = "all"
_EPS = 1e-12


class RunsCycles(Protocol):
    def run(
        self,
        X: np.ndarray,
        cycle: Cycle,
        vehicle: str = "hybrid",
        batch_size: int = 1000,
        progress: Callable[[int, int], None] | None = None,
        charge_balanced: bool = False,
    ) -> pd.DataFrame: ...


# ---------------------------------------------------------------------------------- improvement
def improvement(response: str, design, base: float, *, base_has_battery: bool = True) -> np.ndarray:
    """Per-design improvement over ``base`` for one response ('+' = better; module docstring for units)."""
    design = np.asarray(design, dtype=float)
    base = float(base)
    if response in SOC_POINTS:
        if not base_has_battery or not np.isfinite(base):
            return np.full(design.shape, np.nan)
        return 100.0 * (base - design)
    if not np.isfinite(base) or abs(base) < _EPS:
        return np.full(design.shape, np.nan)
    gain = design - base if response in MAXIMISED else base - design
    return 100.0 * gain / abs(base)


def _mean(values: np.ndarray) -> float | None:
    values = values[np.isfinite(values)]
    return float(values.mean()) if values.size else None


def group_rows(vehicles: pd.DataFrame, algos: Sequence[str]) -> dict[str, np.ndarray]:
    """Masks of the design rows of each algorithm (a shared design counts for each) and of ``all``."""
    lists = [algo_names(a) for a in vehicles["algo"]]
    groups = {a: np.array([a in names for names in lists], dtype=bool) for a in algos}
    groups[ALL] = np.ones(len(vehicles), dtype=bool)
    return groups


def improvement_table(
    designs: pd.DataFrame,
    baselines: dict[str, pd.Series],
    algos: Sequence[str],
    responses: Sequence[str] = IMPROVEMENT_RESPONSES,
) -> dict:
    """``{algo|"all": {"vs_<baseline>": {response: mean improvement or None}}}`` for one cycle."""
    out = {}
    for group, mask in group_rows(designs, algos).items():
        out[group] = {}
        for name, base in baselines.items():
            has_batt = name not in NO_BATTERY
            out[group][f"vs_{name}"] = {
                r: _mean(improvement(r, designs.loc[mask, r].to_numpy(dtype=float), base[r], base_has_battery=has_batt))
                for r in responses
            }
    return out


def engine_downsizing(designs: pd.DataFrame, algos: Sequence[str], p_conv_kw: float) -> dict[str, float | None]:
    """Mean engine power of each group's picks vs the conventional engine, in % ('+' = smaller)."""
    out = {}
    for group, mask in group_rows(designs, algos).items():
        p = designs.loc[mask, "p_eng_kw"].to_numpy(dtype=float)
        out[group] = float(100.0 * (p_conv_kw - p.mean()) / p_conv_kw) if p.size else None
    return out


# ---------------------------------------------------------------------------------- simulation
def load_cycles(names: Sequence[str], known: Sequence[str], cycles_dir: str | Path) -> list[Cycle]:
    """The validation cycles from ``<cycles_dir>/<name>.parquet``; unknown names fail naming the key."""
    for name in names:
        if name not in known:
            raise ValueError(f"params.yaml: validate.cycles: {name!r} is not one of cycles.cycles")
    return [Cycle.from_parquet(Path(cycles_dir) / f"{name}.parquet", name=name) for name in names]


def cycle_notes(cycles: Sequence[Cycle]) -> list[str]:
    """Report lines for validation cycles that carry a road grade (validation is meant on a flat road)."""
    return [
        f"validation cycle {c.name} carries a mean road grade of {100 * float(np.mean(c.grade)):.1f} %"
        for c in cycles
        if np.any(c.grade != 0)
    ]


def prius_design(prius) -> np.ndarray:
    """The stock Prius as a (7,) design vector (``params.baseline.prius``)."""
    return design_vector(prius)


#: The validation table's response columns: every response and the charge-balanced fuel with its runs.
VALIDATION_RESPONSES: tuple[str, ...] = RESPONSES + CHARGE_BALANCE_RESPONSES


def _responses(df: pd.DataFrame, n: int, what: str) -> pd.DataFrame:
    missing = [c for c in VALIDATION_RESPONSES if c not in df.columns]
    if missing:
        raise ValueError(f"simulator result for {what}: missing response column(s) {', '.join(missing)}")
    if len(df) != n:
        raise ValueError(f"simulator result for {what}: expected {n} row(s), got {len(df)}")
    return df[list(VALIDATION_RESPONSES)].reset_index(drop=True)


def validation_table(
    sim: RunsCycles, selected: pd.DataFrame, cycles: Sequence[Cycle], prius_x: np.ndarray, *, batch_size: int = 1000
) -> pd.DataFrame:
    """Simulate the picks and both baselines on every cycle: one row per vehicle and cycle.

    Columns: ``vehicle`` (the design id, ``conventional`` or ``prius``), ``algo`` (``baseline`` for the
    baselines), ``cycle``, the seven variables (NaN for the conventional car, the stock values for the
    Prius), then every column of :data:`hevlib.design.RESPONSES`.
    """
    X = design_matrix(selected, what="selected designs")
    prius_x = np.asarray(prius_x, dtype=float)
    parts = []
    for cycle in cycles:
        blocks = []
        if len(X):
            res = _responses(
                sim.run(X, cycle, vehicle="hybrid", batch_size=batch_size, charge_balanced=True),
                len(X),
                f"the picked designs on {cycle.name}",
            )
            ids = pd.DataFrame(
                {
                    "vehicle": selected["design_id"].astype(str).to_numpy(),
                    "algo": selected["algo"].astype(str).to_numpy(),
                }
            )
            blocks.append(pd.concat([ids, pd.DataFrame(X, columns=list(DESIGN_VARS)), res], axis=1))
        for vehicle in BASELINES:
            res = _responses(
                sim.run(prius_x[None, :], cycle, vehicle=vehicle, charge_balanced=True), 1, f"{vehicle} on {cycle.name}"
            )
            x = prius_x if vehicle == "prius" else np.full(len(DESIGN_VARS), np.nan)
            ids = pd.DataFrame({"vehicle": [vehicle], "algo": [BASELINE_ALGO]})
            blocks.append(pd.concat([ids, pd.DataFrame(x[None, :], columns=list(DESIGN_VARS)), res], axis=1))
        part = pd.concat(blocks, ignore_index=True)
        part.insert(2, "cycle", cycle.name)
        parts.append(part)
    table = pd.concat(parts, ignore_index=True)
    for flag in BOOL_RESPONSES:
        table[flag] = table[flag].astype(bool)
    return table


def validation_schema() -> pa.Schema:
    """Explicit schema of ``reports/validation.parquet``."""
    fields = [
        pa.field("vehicle", pa.string(), nullable=False),
        pa.field("algo", pa.string(), nullable=False),
        pa.field("cycle", pa.string(), nullable=False),
    ]
    fields += [pa.field(v, pa.float64()) for v in DESIGN_VARS]
    fields += [pa.field(r, pa.bool_() if r in BOOL_RESPONSES else pa.float64()) for r in VALIDATION_RESPONSES]
    return pa.schema(fields)


def split_cycle(table: pd.DataFrame, cycle: str) -> tuple[pd.DataFrame, dict[str, pd.Series]]:
    """(picked-design rows, {baseline: row}) of one cycle of the validation table."""
    rows = table[table["cycle"] == cycle]
    designs = rows[rows["algo"] != BASELINE_ALGO].reset_index(drop=True)
    baselines = {}
    for name in BASELINES:
        hit = rows[rows["vehicle"] == name]
        if len(hit) != 1:
            raise ValueError(f"validation table: expected one {name!r} row on cycle {cycle!r}, got {len(hit)}")
        baselines[name] = hit.iloc[0]
    return designs, baselines


def best_design(table: pd.DataFrame, cycle: str) -> str | None:
    """The pick with the lowest SOC-corrected fuel consumption on ``cycle`` among those that met it
    (all picks when none did); None without picks."""
    designs, _ = split_cycle(table, cycle)
    if designs.empty:
        return None
    pool = designs[designs["cycle_met"]] if designs["cycle_met"].any() else designs
    fc = pool["fc_soc_corrected"].to_numpy(dtype=float)
    if not np.isfinite(fc).any():
        return str(pool["vehicle"].iloc[0])
    return str(pool["vehicle"].iloc[int(np.nanargmin(fc))])


def traces(
    sim, selected: pd.DataFrame, design_id: str, cycle: Cycle, prius_x: np.ndarray
) -> dict[str, pd.DataFrame] | None:
    """Time traces of one picked design and both baselines on ``cycle`` (``sim.trace``), keyed by vehicle;
    None when the simulator offers no traces."""
    trace = getattr(sim, "trace", None)
    if trace is None:
        return None
    row = selected[selected["design_id"].astype(str) == design_id]
    if len(row) != 1:
        raise ValueError(f"selected designs: no single design {design_id!r}")
    prius_x = np.asarray(prius_x, dtype=float)[None, :]
    out = {design_id: trace(design_matrix(row), cycle, "hybrid")}
    for vehicle in BASELINES:
        out[vehicle] = trace(prius_x, cycle, vehicle)
    return out


#: FTP bag 1 (the cold-start phase), s: the catalyst plot's window on a cycle with a key-off soak.
FTP_BAG1_S = 505.0


def cold_start_window_s(sim, cycle: Cycle, traces: dict[str, pd.DataFrame] | None) -> float | None:
    """Seconds of ``cycle`` the catalyst warm-up plot shows: FTP's bag 1 (505 s, before its key-off soak)
    or the whole cycle; None when the cycle does not start cold or the traces carry no temperatures."""
    if not traces or "t_cat_c" not in next(iter(traces.values())):
        return None
    if sim.start_state(cycle) != "cold":
        return None
    off = np.flatnonzero(~cycle.key_on[1:])
    return FTP_BAG1_S if len(off) and cycle.time_s[1:][off[0]] > FTP_BAG1_S else float(cycle.duration_s)


def summarise(
    table: pd.DataFrame,
    algos: Sequence[str],
    cycles: Sequence[str],
    p_conv_kw: float,
    recommendation: Recommendation | None = None,
) -> ValidationSummary:
    """``reports/validation.json``: headline (first cycle) improvement table, counts, engine downsizing,
    baseline and mean-pick responses, the same improvement table for every other cycle, and the
    ``recommendation`` (:func:`recommendation`) when given."""
    headline = cycles[0]
    designs, baselines = split_cycle(table, headline)
    groups = group_rows(designs, algos)

    def _abs(df: pd.DataFrame) -> dict:
        return {r: _mean(df[r].to_numpy(dtype=float)) for r in IMPROVEMENT_RESPONSES}

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
        mean_p_eng_kw={g: _mean(designs.loc[m, "p_eng_kw"].to_numpy(dtype=float)) for g, m in groups.items()},
        p_eng_conventional_kw=float(p_conv_kw),
        absolute={
            "mean_of_picks": {g: _abs(designs[m]) for g, m in groups.items()},
            **{name: {r: float(b[r]) for r in IMPROVEMENT_RESPONSES} for name, b in baselines.items()},
        },
        by_cycle=by_cycle,
        best_design=best_design(table, headline),
        recommendation=recommendation,
    )


# ------------------------------------------------------------------------------------- recommendation
#: Responses of the "Build this" tables, in their row order (units in hevlib.design.UNITS).
RECOMMENDED_RESPONSES: tuple[str, ...] = (
    "fc_charge_balanced",
    "fc",
    "hc",
    "co",
    "nox",
    "m_veh",
    "t_0_100_s",
    "v_max",
    "f_max",
    "n_engine_starts",
    "t_cat_light_off_s",
    "cycle_met",
)


def failed_cycles(table: pd.DataFrame, cycles: Sequence[str]) -> dict[str, list[str]]:
    """Per picked design (and baseline), the validation cycles it did not meet (off the trace or stalled);
    vehicles that met every cycle are left out."""
    out: dict[str, list[str]] = {}
    for cycle in cycles:
        rows = table[(table["cycle"] == cycle) & ~table["cycle_met"].astype(bool)]
        for v in rows["vehicle"].astype(str):
            out.setdefault(v, []).append(cycle)
    return out


def _plain(selected_row: pd.Series) -> dict[str, float]:
    """A selected design's variables and sizing-cycle objectives under their plain names."""
    out = {v: float(selected_row[v]) for v in DESIGN_VARS}
    out.update({k[len("sim_") :]: float(selected_row[k]) for k in selected_row.index if k.startswith("sim_")})
    return out


def _figures(row: pd.Series) -> dict:
    return {r: (bool(row[r]) if r in BOOL_RESPONSES else _finite(row[r])) for r in RECOMMENDED_RESPONSES}


def _finite(v) -> float | None:
    v = float(v)
    return v if np.isfinite(v) else None


def eligibility(
    table: pd.DataFrame, cycles: Sequence[str], screen
) -> tuple[pd.DataFrame, np.ndarray, list, object, np.ndarray]:
    """The picks on the headline cycle (``cycles[0]``), which of them may be recommended (they meet every
    validation cycle, and reach the highway speed when that rule is on), the failed cycles by design, the
    highway rule and which picks reach its speed."""
    designs, _ = split_cycle(table, cycles[0])
    fails = failed_cycles(table, cycles)
    ids = designs["vehicle"].astype(str)
    highway = min_v_max(screen.min_v_max_kmh)
    meets_all = ~ids.isin(list(fails)).to_numpy()
    fast_enough = highway.mask({"v_max": designs["v_max"].to_numpy(dtype=float)})
    eligible = meets_all & (fast_enough if highway.enabled else True)
    return designs, np.asarray(eligible, dtype=bool), fails, highway, fast_enough


def eligible_ids(table: pd.DataFrame, cycles: Sequence[str], screen) -> list[str]:
    """Ids of the picks the recommendation chooses among (:func:`eligibility`)."""
    designs, eligible, *_ = eligibility(table, cycles, screen)
    return designs["vehicle"].astype(str)[eligible].tolist()


#: Columns of the twins table (``reports/validation_twins.parquet``).
TWIN_COLUMNS: tuple[str, ...] = ("vehicle", "twin", *DESIGN_VARS)


def simulate_twins(
    sim: RunsCycles,
    selected: pd.DataFrame,
    ids: Sequence[str],
    cycle: Cycle,
    space,
    settings,
    *,
    batch_size: int = 1000,
) -> pd.DataFrame:
    """The model's noise at each design of ``ids``: ``settings.twins`` copies whose continuous variables are moved
    uniformly within ``+- settings.share`` of their ranges (clipped to the box; the integers kept), simulated on
    ``cycle`` (charge-balanced, as the validation runs). One row per twin: ``vehicle``, ``twin`` (1..), the seven
    variables and every response. Seeded by ``settings.seed``; the designs in the order of ``ids``."""
    by_id = selected.set_index(selected["design_id"].astype(str))
    X = design_matrix(by_id.loc[list(ids)].reset_index(drop=True), what="twinned designs") if len(ids) else None
    k = int(settings.twins)
    if X is None:
        return pd.DataFrame(columns=[*TWIN_COLUMNS, *RESPONSES])
    rng = np.random.default_rng(int(settings.seed))
    T = np.repeat(X, k, axis=0)
    span = space.upper - space.lower
    moved = rng.uniform(-1.0, 1.0, size=T.shape) * float(settings.share) * span
    T = np.clip(T + np.where(INTEGER_MASK, 0.0, moved), space.lower, space.upper)
    res = _responses(sim.run(T, cycle, vehicle="hybrid", batch_size=batch_size, charge_balanced=True), len(T), "twins")
    ids_col = pd.DataFrame(
        {"vehicle": np.repeat(np.asarray(ids, dtype=str), k), "twin": np.tile(np.arange(1, k + 1), len(X))}
    )
    return pd.concat([ids_col, pd.DataFrame(T, columns=list(DESIGN_VARS)), res], axis=1)


def twins_schema() -> pa.Schema:
    """Explicit schema of ``reports/validation_twins.parquet``."""
    fields = [pa.field("vehicle", pa.string()), pa.field("twin", pa.int64())]
    fields += [pa.field(v, pa.float64()) for v in DESIGN_VARS]
    fields += [pa.field(r, pa.bool_() if r in BOOL_RESPONSES else pa.float64()) for r in RESPONSES]
    return pa.schema(fields)


def _equivalents(designs: pd.DataFrame, pool: np.ndarray, chosen: str, twins: pd.DataFrame, by_id, space, settings):
    """``recommendation.noise`` and ``recommendation.equivalents`` (hevlib/recommend.py) for the designs of the
    ``pool`` rows of ``designs`` (headline cycle), each with its rows of ``twins``."""
    idx = np.flatnonzero(pool)
    ids = designs["vehicle"].astype(str).to_numpy()[idx]
    own = minimisation(designs.iloc[idx].reset_index(drop=True), KNEE_CRITERIA)
    versions = []
    for i, name in enumerate(ids):
        t = minimisation(twins[twins["vehicle"].astype(str) == name].reset_index(drop=True), KNEE_CRITERIA)
        versions.append(np.vstack([own[i], t[np.all(np.isfinite(t), axis=1)]]))
    rng = np.random.default_rng(int(settings.seed))
    shares = knee_shares(versions, settings.draws, rng)
    sigma = noise_spread(versions)
    crit = designs.iloc[idx][list(KNEE_CRITERIA)].to_numpy(dtype=float)
    noise = Noise(
        method=(
            f"each eligible design and {settings.twins} twins whose continuous variables differ by at most "
            f"{100 * settings.share:g} % of their ranges, simulated on the headline cycle; the knee drawn "
            f"{settings.draws} times with each design as itself or one of its twins at random; an equivalent is the "
            f"knee in at least {100 * settings.min_share:g} % of the draws"
        ),
        twins=int(settings.twins),
        share_of_range=float(settings.share),
        draws=int(settings.draws),
        min_share=float(settings.min_share),
        seed=int(settings.seed),
        sigma={c: _finite(v) for c, v in zip(KNEE_CRITERIA, sigma, strict=True)},
        sigma_pct_of_mean={
            c: _finite(100 * v / np.mean(np.abs(crit[:, j])))
            for j, (c, v) in enumerate(zip(KNEE_CRITERIA, sigma, strict=True))
        },
        knee_share={str(n): float(v) for n, v in zip(ids, shares, strict=True)},
    )
    row = {str(n): i for i, n in enumerate(ids)}
    base = crit[row[chosen]]
    out = []
    order = sorted(
        (i for i, n in enumerate(ids) if n != chosen and shares[i] >= settings.min_share),
        key=lambda i: (-shares[i], ids[i]),
    )
    for i in order:
        name = str(ids[i])
        x = by_id[name]
        separated_by = separation(_plain(by_id[chosen]), _plain(x), space)  # beyond a family's share of a range
        out.append(
            Equivalent(
                design_id=name,
                algo=str(x["algo"]),
                knee_share=float(shares[i]),
                design={v: float(x[v]) for v in DESIGN_VARS},
                criteria={c: _finite(crit[i, j]) for j, c in enumerate(KNEE_CRITERIA)},
                vs_recommended={
                    c: {
                        "difference": _finite(crit[i, j] - base[j]),
                        "pct": _finite(100 * (crit[i, j] - base[j]) / abs(base[j])),
                    }
                    for j, c in enumerate(KNEE_CRITERIA)
                },
                separated_by=separated_by,
                same_family=not separated_by,
            )
        )
    return noise, out


def recommendation(
    table: pd.DataFrame,
    selected: pd.DataFrame,
    cycles: Sequence[str],
    screen,
    space,
    twins: pd.DataFrame | None = None,
    equivalence=None,
) -> Recommendation:
    """``reports/validation.json``'s ``recommendation``: the design to build (the knee of the charge-balanced
    fuel on the first cycle against test mass and 0-100 km/h time, among the picks that meet every
    validation cycle and the highway rule when it is on; :func:`hevlib.recommend.recommend`), the best pick
    of each objective group, each with its reasons (bounds touched, screen margins) and its figures against
    both baselines on every validation cycle; with ``twins`` (:func:`simulate_twins` of the eligible picks) and
    the ``equivalence`` settings also the model's noise and the recommendation's near-equivalents."""
    head = cycles[0]
    designs, eligible, fails, highway, fast_enough = eligibility(table, cycles, screen)
    ids = designs["vehicle"].astype(str)
    choice = recommend(designs, eligible)
    rules = screening_rules(screen)
    by_id = {str(r["design_id"]): r for _, r in selected.iterrows()}

    def explain(design_id: str | None) -> Pick | None:
        if design_id is None:
            return None
        x = by_id[design_id]
        by_cycle = {}
        for cycle in cycles:
            d, b = split_cycle(table, cycle)
            row = d[d["vehicle"].astype(str) == design_id].iloc[0]
            by_cycle[cycle] = {
                "design": _figures(row),
                **{name: _figures(base) for name, base in b.items()},
                **{
                    f"vs_{name}": {
                        r: _finite(
                            improvement(r, np.array([row[r]]), base[r], base_has_battery=name not in NO_BATTERY)[0]
                        )
                        for r in RECOMMENDED_RESPONSES
                        if r not in BOOL_RESPONSES
                    }
                    for name, base in b.items()
                },
            }
        return Pick(
            design_id=design_id,
            algo=str(x["algo"]),
            rank=int(x["rank"]) if "rank" in x else None,
            design={v: float(x[v]) for v in DESIGN_VARS},
            **reasons(_plain(x), space, rules),
            fails=fails.get(design_id, []),
            by_cycle=by_cycle,
        )

    noise, equivalents = _near_equivalents(designs, eligible, choice, twins, by_id, space, equivalence)
    return Recommendation(
        cycle=head,
        preference=(
            f"knee of {', '.join(KNEE_CRITERIA)} on {head} (all minimised; hevlib/recommend.py), among the picks that "
            "meet every validation cycle" + (f" and reach {highway.limit:g} km/h" if highway.enabled else "")
        ),
        criteria=list(KNEE_CRITERIA),
        groups={g: list(n) for g, n in VALIDATED_GROUPS.items()},
        eligible=choice["pool"],
        pool_rule=choice["pool_rule"],
        highway_rule=HighwayRule(
            enabled=highway.enabled,
            min_v_max_kmh=highway.limit,
            picks_below=[str(i) for i, ok in zip(ids, fast_enough, strict=True) if not ok],
        ),
        design=explain(choice["design"]),
        best={g: explain(i) for g, i in choice["best"].items()},
        noise=noise,
        equivalents=equivalents,
    )


def _near_equivalents(designs, eligible, choice, twins, by_id, space, settings) -> tuple[Noise | None, list]:
    """``noise`` and ``equivalents`` of the recommendation (none without twins or a recommended design)."""
    if twins is None or settings is None or choice["design"] is None or choice["pool_rule"] != "eligible":
        return None, []
    crit = designs[list(KNEE_CRITERIA)].to_numpy(dtype=float)
    pool = np.asarray(eligible, dtype=bool) & np.all(np.isfinite(crit), axis=1)
    return _equivalents(designs, pool, choice["design"], twins, by_id, space, settings)


#: Tailpipe gases of the bag table with their trace columns.
GAS_TAILPIPE: tuple[tuple[str, str], ...] = (
    ("hc", "hc_tailpipe_g_s"),
    ("co", "co_tailpipe_g_s"),
    ("nox", "nox_tailpipe_g_s"),
)


def bag_figures(trace: pd.DataFrame, density_g_per_l: float, bags: Sequence[tuple[float, float]]) -> list:
    """Fuel (L/100 km), tailpipe HC/CO/NOx (g/km) and SOC change of one vehicle's trace over each bag
    ``(start_s, end_s]`` (seconds since the cycle's start)."""
    t = trace["time_s"].to_numpy(dtype=float)
    dt = np.diff(t, prepend=t[0])
    soc = trace["soc"].to_numpy(dtype=float)
    metres = trace["v_mps"].to_numpy(dtype=float) * dt
    grams = {k: trace[c].to_numpy(dtype=float) * dt for k, c in (("fuel", "fuel_g_s"), *GAS_TAILPIPE)}
    out = []
    for k, (a, b) in enumerate(bags, start=1):
        steps = np.flatnonzero((t > a) & (t <= b))
        km = float(np.sum(metres[steps])) / 1000.0
        fuel_l = float(np.sum(grams["fuel"][steps])) / density_g_per_l
        row = {
            "bag": k,
            "start_s": a,
            "end_s": b,
            "distance_km": km,
            "fc": 100.0 * fuel_l / km if km > 0 else None,
            "delta_soc": float(soc[steps[-1]] - soc[max(steps[0] - 1, 0)]) if steps.size else 0.0,
        }
        for gas, _ in GAS_TAILPIPE:
            row[gas] = float(np.sum(grams[gas][steps])) / km if km > 0 else None
        out.append(row)
    return out


#: FTP's three bags in seconds of our FTP file: bag 1 (cold transient, 0-505 s), bag 2 (stabilised,
#: 505-1372 s), then the 10-minute key-off soak and bag 3 (hot transient, the first 505 s again).
FTP_BAGS_S: tuple[tuple[float, float], ...] = ((0.0, 505.0), (505.0, 1372.0), (1972.0, 2477.0))


def ftp_bags(sim, table: pd.DataFrame, selected: pd.DataFrame, design_id: str, ftp: Cycle, prius_x) -> dict:
    """Bag-by-bag FTP figures (:func:`bag_figures`) of one picked design and both baselines, each hybrid traced
    from the SOC its charge-balanced run started at (the conventional car has no battery: its own start)."""
    rows = table[table["cycle"] == ftp.name].set_index("vehicle")
    density = sim.library.lib.engine_hybrid.fuel_density_g_per_l  # as every fc figure (hevlib.sim.simulator)
    x = design_matrix(selected[selected["design_id"].astype(str) == design_id])
    out = {}
    for name, X, kind in ((design_id, x, "hybrid"), ("prius", np.asarray(prius_x, dtype=float)[None, :], "prius")):
        soc = float(rows.loc[name, "soc_init_charge_balanced"])
        out[name] = bag_figures(sim.trace(X, ftp, kind, soc_init=soc), density, FTP_BAGS_S)
    out["conventional"] = bag_figures(sim.trace(None, ftp, "conventional"), density, FTP_BAGS_S)
    return out


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


__all__ = [
    "FTP_BAGS_S",
    "RECOMMENDED_RESPONSES",
    "bag_figures",
    "failed_cycles",
    "ftp_bags",
    "recommendation",
    "ANSWER_KEYS",
    "answer",
    "IMPROVEMENT_RESPONSES",
    "MAXIMISED",
    "SOC_POINTS",
    "BASELINES",
    "NO_BATTERY",
    "BASELINE_ALGO",
    "ALL",
    "improvement",
    "group_rows",
    "improvement_table",
    "engine_downsizing",
    "load_cycles",
    "cycle_notes",
    "prius_design",
    "validation_table",
    "validation_schema",
    "split_cycle",
    "best_design",
    "summarise",
    "headline",
    "traces",
]
