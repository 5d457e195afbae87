"""The recommendation: eligibility (every validation cycle met, the highway rule), the design to build (the knee),
the best of each group, each with its reasons and figures, the twins and the near-equivalents within the model's
noise."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
import pyarrow as pa

from hevlib.cycles import Cycle
from hevlib.design import (
    BOOL_RESPONSES,
    DESIGN_VARS,
    INTEGER_MASK,
    RESPONSES,
    design_matrix,
)
from hevlib.io import finite_or_none
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
from hevlib.results import Equivalent, HighwayRule, Noise, Pick, Recommendation
from hevlib.screen import min_v_max, screening_rules
from hevlib.validation.improvement import NO_BATTERY, improvement
from hevlib.validation.runs import RunsCycles, responses_of, split_cycle

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
    return {r: (bool(row[r]) if r in BOOL_RESPONSES else finite_or_none(row[r])) for r in RECOMMENDED_RESPONSES}


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
    res = responses_of(
        sim.run(T, cycle, vehicle="hybrid", batch_size=batch_size, charge_balanced=True), len(T), "twins"
    )
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
        sigma={c: finite_or_none(v) for c, v in zip(KNEE_CRITERIA, sigma, strict=True)},
        sigma_pct_of_mean={
            c: finite_or_none(100 * v / np.mean(np.abs(crit[:, j])))
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
                criteria={c: finite_or_none(crit[i, j]) for j, c in enumerate(KNEE_CRITERIA)},
                vs_recommended={
                    c: {
                        "difference": finite_or_none(crit[i, j] - base[j]),
                        "pct": finite_or_none(100 * (crit[i, j] - base[j]) / abs(base[j])),
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
                        r: finite_or_none(
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
