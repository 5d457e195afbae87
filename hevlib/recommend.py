"""A recommendation, not a lottery: which design to build, and why (``screen.pick: recommend``).

The preference is stated once, here, and applied twice:

* **Shortlist** (the pareto stage, on the sizing cycle): of the kept designs, the knee of
  :data:`KNEE_CRITERIA` on the sizing cycle (``fc`` standing in for the charge-balanced fuel, which only the
  validation runs know), the best design of each objective group (:data:`GROUPS`), then farthest-point
  sampling over the eleven normalised objectives from those seeds until ``n_pick`` are chosen. Deterministic.
* **Recommendation** (the validate stage, on the validation runs): among the shortlisted designs that meet
  every validation cycle (and the highway rule when ``screen.min_v_max_kmh`` is set), the knee of the
  charge-balanced fuel on the first validation cycle (FTP) against test mass and 0-100 km/h time, and the
  best of each group on that cycle (fuel: charge-balanced fuel; emissions: the mean of HC, CO and NOx
  normalised over the eligible designs; performance: 0-100 km/h time).

**Knee** (:func:`knee_index`): criteria min-max normalised over the candidates; of the non-dominated ones,
the design farthest below the hyperplane through the extreme designs (each the best in one criterion) --
the point where trading one criterion for another costs most (Das 1999, "On characterizing the 'knee' of
the Pareto curve based on normal-boundary intersection"; Deb & Gupta 2011). Where the extremes do not span
a plane (repeated or collinear), the plane is the equal-weight one, ``sum f_i = const``.

**Near-equivalents** (:func:`knee_shares`, :func:`equivalents`): the model's noise at a design is the spread of
its knee criteria over *twins*, copies whose continuous variables differ from it by at most a small share of their
ranges (below any build tolerance: ``validate.equivalence``), simulated on the headline cycle like the design. The
knee is drawn again and again with every eligible design represented by itself or one of its twins at random; a
design that comes out as the knee in at least ``min_share`` of the draws cannot be told from the recommended one by
the model: the answer is the recommended design *or any of its equivalents*, and what separates them is listed.
**Families** (:func:`same_family`): designs whose every variable lies within :data:`FAMILY_SHARE` of its range of
each other -- the unit ``hev robustness`` counts recommendations in.

**Reasons** (:func:`reasons`): the design-box bounds a design touches (within :data:`BOUND_TOL` of the range),
the screen rules it is close to (margin within :data:`ACTIVE_MARGIN` of the limit), and its margin to each
rule. **Active bounds** (:func:`active_bounds`): bounds at which at least :data:`FLAG_SHARE` of the kept
designs sit -- the optimum probably lies outside the design box there, and the advice is to widen it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from hevlib.design import DESIGN_VARS, OBJECTIVES
from hevlib.indicators import nondominated_mask, normalise, pick_diverse, to_minimisation

#: Objective groups for "best of each group" (sizing-cycle objectives; SPEC 5).
GROUPS: dict[str, tuple[str, ...]] = {
    "fuel": ("fc",),
    "emissions": ("hc", "co", "nox"),
    "performance": ("accel_dev", "speed_dev", "v_max", "f_max"),
}
#: The stated preference: charge-balanced fuel against test mass and 0-100 km/h time, all minimised.
KNEE_CRITERIA: tuple[str, ...] = ("fc_charge_balanced", "m_veh", "t_0_100_s")
#: Their stand-ins on the sizing cycle, where no run is charge-balanced.
SIZING_KNEE_CRITERIA: tuple[str, ...] = ("fc", "m_veh", "t_0_100_s")
#: On the validation runs: the group criteria (minimised).
VALIDATED_GROUPS: dict[str, tuple[str, ...]] = {
    "fuel": ("fc_charge_balanced",),
    "emissions": ("hc", "co", "nox"),
    "performance": ("t_0_100_s",),
}
#: A variable within this share of its range from a bound touches it.
BOUND_TOL = 0.01
#: A bound is flagged when at least this share of the kept designs touch it: ten times the share that
#: designs spread evenly over the range would put within BOUND_TOL of one bound.
FLAG_SHARE = 0.10
#: A screen rule is active when a design's margin (``value / limit - 1``) is within this of 0.
ACTIVE_MARGIN = 0.05
#: Two designs are of one family when every variable is within this share of its range of the other's.
FAMILY_SHARE = 0.05


# ------------------------------------------------------------------------------------------ choice
def knee_index(F: np.ndarray) -> int:
    """Row of ``F`` ((n, k), minimisation form, finite) at the knee (module docstring); ties go to the
    lowest row."""
    F = np.asarray(F, dtype=float)
    if len(F) == 0:
        raise ValueError("knee: no candidates")
    N = normalise(F)
    nd = nondominated_mask(N)
    k = N.shape[1]
    extremes = N[[int(np.argmin(N[:, j] + 1e-12 * N.sum(axis=1))) for j in range(k)]]
    a = None
    if len({tuple(r) for r in extremes}) == k:
        try:
            a = np.linalg.solve(extremes, np.ones(k))
        except np.linalg.LinAlgError:
            a = None
    if a is None or not np.all(np.isfinite(a)) or np.any(a <= 0):
        a = np.ones(k)  # the equal-weight plane (only the ordering of the depths matters)
    depth = (1.0 - N @ a) / np.linalg.norm(a)  # distance below the plane a.f = 1 (positive: towards the ideal)
    depth = np.where(nd, depth, -np.inf)
    return int(np.argmax(depth))


def best_of_group(F_group: np.ndarray) -> int:
    """Row with the lowest mean of the group's min-max normalised criteria (minimisation form)."""
    return int(np.argmin(normalise(F_group).mean(axis=1)))


def minimisation(table: pd.DataFrame, names: Sequence[str], prefix: str = "") -> np.ndarray:
    """(n, len(names)) of ``prefix + name`` columns in minimisation form (:func:`hevlib.indicators.to_minimisation`)."""
    return to_minimisation(table[[f"{prefix}{n}" for n in names]].to_numpy(dtype=float), names)


def shortlist(kept: pd.DataFrame, k: int, prefix: str = "sim_") -> tuple[np.ndarray, dict[str, int]]:
    """Rows of ``kept`` (the kept designs, best rank first) to validate: the sizing knee, the best of each
    group, then farthest-point fill over the normalised objectives; and ``{role: row}`` of the seeds."""
    if len(kept) == 0:
        return np.zeros(0, dtype=np.int64), {}
    knee_by = [c for c in SIZING_KNEE_CRITERIA if f"{prefix}{c}" in kept.columns]  # a front without t_0_100_s:
    roles = {"knee": knee_index(minimisation(kept, knee_by if len(knee_by) > 1 else OBJECTIVES, prefix))}
    for group, names in GROUPS.items():
        roles[f"best_{group}"] = best_of_group(minimisation(kept, names, prefix))
    F = normalise(minimisation(kept, OBJECTIVES, prefix))
    return pick_diverse(F, k, start=list(roles.values())), roles


# ---------------------------------------------------------------------------- equivalents and families
def same_family(X: np.ndarray, x: np.ndarray, lower: np.ndarray, upper: np.ndarray, share: float = FAMILY_SHARE):
    """Rows of ``X`` (n, 7) of ``x``'s family: every variable within ``share`` of its range of ``x``'s."""
    X = np.atleast_2d(np.asarray(X, dtype=float))
    span = np.asarray(upper, dtype=float) - np.asarray(lower, dtype=float)
    return np.all(np.abs(X - np.asarray(x, dtype=float)) <= share * span + 1e-12, axis=1)


def knee_shares(versions: Sequence[np.ndarray], draws: int, rng: np.random.Generator) -> np.ndarray:
    """Share of ``draws`` in which each design is the knee (:func:`knee_index`) when every design is represented
    by one of its ``versions`` (design i: an (m_i, k) array of knee criteria in minimisation form, finite, the
    design itself and its twins) drawn uniformly at random."""
    n = len(versions)
    counts = np.zeros(n, dtype=np.int64)
    sizes = np.array([len(v) for v in versions])
    if n == 0 or np.any(sizes == 0):
        raise ValueError("knee_shares: every design needs at least one version")
    pick = (rng.random((int(draws), n)) * sizes).astype(np.int64)
    for d in range(int(draws)):
        F = np.stack([versions[i][pick[d, i]] for i in range(n)])
        counts[knee_index(F)] += 1
    return counts / float(draws)


def noise_spread(versions: Sequence[np.ndarray]) -> np.ndarray:
    """The model's noise per criterion: the root mean square over designs and twins of a twin's deviation from
    its design (row 0 of each version array), in the criteria's units."""
    dev = [v[1:] - v[0] for v in versions if len(v) > 1]
    if not dev:
        return np.full(versions[0].shape[1] if len(versions) else 0, np.nan)
    D = np.concatenate(dev)
    return np.sqrt(np.mean(D**2, axis=0))


def separation(x_a: Mapping[str, float], x_b: Mapping[str, float], space, share: float = FAMILY_SHARE) -> list[dict]:
    """What separates design ``b`` from ``a``: the variables that differ by more than ``share`` of their range,
    ``[{variable, recommended, this, difference, share_of_range}]`` (largest share first)."""
    out = []
    for v in DESIGN_VARS:
        lo, hi = (float(b) for b in getattr(space, v))
        diff = float(x_b[v]) - float(x_a[v])
        frac = abs(diff) / (hi - lo)
        if frac > share + 1e-12:
            out.append(
                {
                    "variable": v,
                    "recommended": float(x_a[v]),
                    "this": float(x_b[v]),
                    "difference": diff,
                    "share_of_range": frac,
                }
            )
    return sorted(out, key=lambda d: -d["share_of_range"])


# ------------------------------------------------------------------------------------------ reasons
def bounds_touched(x: Mapping[str, float], space) -> list[dict]:
    """The design-box bounds design ``x`` touches: ``[{variable, side, bound, value}]``; ``space`` is
    ``params.design_space``."""
    out = []
    for v in DESIGN_VARS:
        lo, hi = (float(b) for b in getattr(space, v))
        tol = BOUND_TOL * (hi - lo)
        value = float(x[v])
        if value <= lo + tol:
            out.append({"variable": v, "side": "lower", "bound": lo, "value": value})
        elif value >= hi - tol:
            out.append({"variable": v, "side": "upper", "bound": hi, "value": value})
    return out


def active_bounds(kept: pd.DataFrame, space) -> dict:
    """``reports/pareto.json``'s ``active_bounds``: per variable, how many kept designs touch each bound,
    and the flagged bounds (at least :data:`FLAG_SHARE` of them) with the advice to widen."""
    n = len(kept)
    by_var, flagged = {}, []
    for v in DESIGN_VARS:
        lo, hi = (float(b) for b in getattr(space, v))
        tol = BOUND_TOL * (hi - lo)
        x = kept[v].to_numpy(dtype=float) if n else np.zeros(0)
        entry = {}
        for side, bound, at in (("lower", lo, x <= lo + tol), ("upper", hi, x >= hi - tol)):
            share = float(at.mean()) if n else 0.0
            entry[side] = {"bound": bound, "kept_at": int(at.sum()), "share": share}
            if n and share >= FLAG_SHARE:
                flagged.append({"variable": v, "side": side, "bound": bound, "kept_share": share})
        by_var[v] = entry
    advice = (
        "; ".join(
            f"{f['variable']} sits at its {f['side']} bound ({f['bound']:g}) in {100 * f['kept_share']:.0f} % of the "
            f"kept designs: the optimum probably lies beyond it -- widen design_space.{f['variable']}"
            for f in flagged
        )
        or "no bound of the design box holds a large share of the kept designs"
    )
    return {
        "tolerance_share_of_range": BOUND_TOL,
        "flag_share": FLAG_SHARE,
        "n_kept": n,
        "by_variable": by_var,
        "flagged": flagged,
        "advice": advice,
    }


def screen_margins(row: Mapping[str, float], rules) -> dict[str, dict]:
    """Per screen rule with a limit: the design's value, the limit, its margin (``value / limit - 1``,
    ``<= 0`` passes; for a lower limit ``1 - value / limit``) and whether it is active (within
    :data:`ACTIVE_MARGIN` of the limit)."""
    out = {}
    for rule in rules:
        if rule.limit is None or rule.margin is None:
            continue
        cols = {k: np.array([float(row[k])]) for k in rule.reads}
        margin = float(rule.constraint(cols)[0])
        out[rule.name] = {
            "enabled": rule.enabled,
            "value": float(row[rule.reads[0]]),
            "limit": rule.limit,
            "margin": margin,
            "active": bool(np.isfinite(margin) and -ACTIVE_MARGIN <= margin <= 0.0),
        }
    return out


def reasons(row: Mapping[str, float], space, rules) -> dict:
    """Why a design stands where it does: bounds it touches, screen margins and the active rules."""
    margins = screen_margins(row, rules)
    return {
        "bounds_touched": bounds_touched(row, space),
        "screen_margins": margins,
        "active_rules": [name for name, m in margins.items() if m["active"] and m["enabled"]],
    }


# ------------------------------------------------------------------------------------- recommendation
def recommend(designs: pd.DataFrame, eligible: np.ndarray) -> dict:
    """On one validation cycle's design rows (``vehicle`` id and responses): the knee of
    :data:`KNEE_CRITERIA` and the best of each :data:`VALIDATED_GROUPS` among ``eligible`` rows with finite
    criteria (all finite rows when none is eligible). Returns ``{"design", "best": {group: id}, "pool",
    "pool_rule"}``."""
    crit = designs[list(KNEE_CRITERIA)].to_numpy(dtype=float)
    finite = np.all(np.isfinite(crit), axis=1)
    pool = np.asarray(eligible, dtype=bool) & finite
    rule = "eligible"
    if not pool.any():
        pool, rule = finite, "none eligible: every design with finite criteria"
    if not pool.any():
        return {"design": None, "best": {}, "pool": 0, "pool_rule": "no design with finite criteria"}
    idx = np.flatnonzero(pool)
    ids = designs["vehicle"].astype(str).to_numpy()
    best = {}
    for group, names in VALIDATED_GROUPS.items():
        G = designs.loc[idx, list(names)].to_numpy(dtype=float)
        ok = np.all(np.isfinite(G), axis=1)
        best[group] = str(ids[idx[ok][best_of_group(G[ok])]]) if ok.any() else None
    return {"design": str(ids[idx[knee_index(crit[idx])]]), "best": best, "pool": int(pool.sum()), "pool_rule": rule}


__all__ = [
    "ACTIVE_MARGIN",
    "BOUND_TOL",
    "FAMILY_SHARE",
    "FLAG_SHARE",
    "GROUPS",
    "KNEE_CRITERIA",
    "SIZING_KNEE_CRITERIA",
    "VALIDATED_GROUPS",
    "active_bounds",
    "best_of_group",
    "bounds_touched",
    "knee_index",
    "knee_shares",
    "minimisation",
    "noise_spread",
    "reasons",
    "recommend",
    "same_family",
    "screen_margins",
    "separation",
    "shortlist",
]
