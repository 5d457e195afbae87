"""The screen's rules (SPEC 9), declared once and rendered in the three shapes the code needs:

- :meth:`ScreenRule.mask` -- a numpy pass mask over columns (a mapping name -> array, design variables
  and responses by their plain names): the surrogates' held-out followers, a search's own scales,
  ParEGO's screen-passing designs;
- :meth:`ScreenRule.expr` -- a polars expression over a table (design variables plain, responses with
  the ``sim_`` prefix): :func:`apply_screening` (the pareto stage's screening, with its report) and
  :func:`passes_screen` (every judged hypervolume);
- :meth:`ScreenRule.constraint` -- a pymoo inequality column (``<= 0`` feasible, dimensionless) over the
  same kind of mapping: :class:`hevlib.optimise.problem.HevProblem` (with the exact mass and the
  model's speed deviation).

A missing value (NaN or null) never passes. A rule switched off in ``params.screen`` is still evaluated
and reported (how many designs it would remove) but removes nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import polars as pl

from hevlib.design import DESIGN_VARS, gear_set_buildable
from hevlib.tables import Table, columns, lazy, n_rows

Columns = Mapping[str, np.ndarray]
SIM = "sim_"
#: Margin that makes "strictly below" a ``<= 0`` constraint.
STRICT = 1e-9


@dataclass(frozen=True)
class ScreenRule:
    """One rule: ``passes(cols)`` is True where a design passes; ``margin(cols)`` (if the rule can be a
    constraint) is its dimensionless ``<= 0`` form."""

    name: str
    enabled: bool
    description: str
    reads: tuple[str, ...]
    passes: Callable[[Columns], np.ndarray]
    margin: Callable[[Columns], np.ndarray] | None = None
    limit: float | None = None

    def mask(self, cols: Columns) -> np.ndarray:
        """(n,) bool pass mask; NaN fails."""
        with np.errstate(invalid="ignore"):
            return np.asarray(self.passes({k: np.asarray(cols[k], dtype=float) for k in self.reads}), dtype=bool)

    def constraint(self, cols: Columns) -> np.ndarray:
        if self.margin is None:
            raise ValueError(f"screen rule {self.name}: not a constraint (it is kept by repair)")
        return np.asarray(self.margin({k: np.asarray(cols[k], dtype=float) for k in self.reads}), dtype=float)

    def expr_columns(self) -> list[str]:
        """The table columns :meth:`expr` reads (design variables plain, responses ``sim_``-prefixed)."""
        return [k if k in DESIGN_VARS else f"{SIM}{k}" for k in self.reads]

    def expr(self) -> pl.Expr:
        """Polars expression (bool) over a table whose responses carry the ``sim_`` prefix."""
        names = self.expr_columns()
        fields = [pl.col(n).cast(pl.Float64).alias(k) for n, k in zip(names, self.reads, strict=True)]
        return pl.struct(fields).map_batches(
            lambda s: pl.Series(self.mask({k: s.struct.field(k).to_numpy() for k in self.reads})),
            return_dtype=pl.Boolean,
        )

    def check(self, table) -> np.ndarray:
        """(n,) bool pass mask on a table (``sim_`` responses)."""
        return passing(table, self.expr())


def passing(table, expr: pl.Expr) -> np.ndarray:
    """(n,) bool: where the boolean expression holds on ``table`` (null fails); reads only its columns."""
    return lazy(table).select(expr.fill_null(False).alias("ok")).collect().to_series().to_numpy().astype(bool)


def gen_below_motor(enabled: bool = True) -> ScreenRule:
    return ScreenRule(
        "gen_below_motor",
        enabled,
        "p_gen_kw < p_mot_kw",
        ("p_gen_kw", "p_mot_kw"),
        lambda c: c["p_gen_kw"] < c["p_mot_kw"],
        lambda c: c["p_gen_kw"] / c["p_mot_kw"] - 1.0 + STRICT,
    )


def not_stalled() -> ScreenRule:
    return ScreenRule(
        "not_stalled",
        True,
        "not sim_stalled (stood still while the sizing cycle asked to move)",
        ("stalled",),
        lambda c: c["stalled"] == 0.0,
        lambda c: np.where(c["stalled"] != 0.0, 1.0, -1.0),
    )


def _at_most(name: str, response: str, limit: float, description: str) -> ScreenRule:
    """A simulated response at most ``limit`` (NaN fails); as a constraint ``value / limit - 1``."""
    return ScreenRule(
        name,
        True,
        description,
        (response,),
        lambda c: c[response] <= limit,
        lambda c: c[response] / limit - 1.0,
        float(limit),
    )


def _at_least(name: str, response: str, limit: float, description: str, enabled: bool = True) -> ScreenRule:
    """A simulated response at least ``limit`` (NaN fails); as a constraint ``1 - value / limit``."""
    return ScreenRule(
        name,
        enabled,
        description,
        (response,),
        lambda c: c[response] >= limit,
        lambda c: 1.0 - c[response] / limit,
        float(limit),
    )


#: The top speed the highway rule asks for when ``screen.min_v_max_kmh`` is unset (the rule is then
#: evaluated and reported, not applied): US06's peak, 129.2 km/h, rounded up.
HIGHWAY_V_MAX_KMH = 130.0


def min_v_max(limit_kmh: float | None) -> ScreenRule:
    """Highway capability: ``sim_v_max`` at least ``limit_kmh``; off (reported at
    :data:`HIGHWAY_V_MAX_KMH`) when ``limit_kmh`` is None."""
    limit = HIGHWAY_V_MAX_KMH if limit_kmh is None else float(limit_kmh)
    description = f"sim_v_max >= {limit:g} km/h (highway capability)"
    return _at_least("min_v_max", "v_max", limit, description, enabled=limit_kmh is not None)


def speed_dev_max(limit: float) -> ScreenRule:
    description = f"sim_speed_dev <= {limit:g} (share of the cycle off the trace)"
    return _at_most("speed_dev_max", "speed_dev", limit, description)


def mass_max(limit: float) -> ScreenRule:
    return _at_most("mass_max", "m_veh", limit, f"sim_m_veh <= {limit:g} kg")


def _buildable(c: Columns) -> np.ndarray:
    ok = np.isfinite(c["n_r"]) & np.isfinite(c["n_s"])
    out = np.zeros(len(ok), dtype=bool)
    out[ok] = gear_set_buildable(np.round(c["n_r"][ok]).astype(np.int64), np.round(c["n_s"][ok]).astype(np.int64))
    return out


def buildable_gear_set(enabled: bool = True) -> ScreenRule:
    return ScreenRule(
        "buildable_gear_set",
        enabled,
        "planet teeth (n_r-n_s)/2 whole and >= 9, (n_r+n_s) divisible by 4",
        ("n_r", "n_s"),
        _buildable,
    )


def screening_rules(screen) -> list[ScreenRule]:
    """The rules of ``params.screen`` (:class:`hevlib.params.ScreenParams`), in the order they are applied."""
    return [
        gen_below_motor(bool(screen.gen_below_motor)),
        not_stalled(),
        speed_dev_max(screen.speed_dev_max),
        mass_max(screen.mass_max_kg),
        buildable_gear_set(bool(screen.buildable_gear_set)),
        min_v_max(screen.min_v_max_kmh),
    ]


def passes(cols: Columns, screen) -> np.ndarray:
    """(n,) bool: designs (columns by plain name) that pass every enabled rule of ``params.screen``."""
    ok = None
    for rule in screening_rules(screen):
        if rule.enabled:
            m = rule.mask(cols)
            ok = m if ok is None else ok & m
    return ok


def apply_screening(
    table: Table, rules: Sequence[ScreenRule], candidates: np.ndarray | None = None
) -> tuple[np.ndarray, dict[str, np.ndarray], dict]:
    """Evaluate every rule on ``table`` (one pass over the columns the rules read); return (feasible mask,
    {name: pass mask}, report).

    ``candidates`` (default: all rows) are the designs being screened; the report counts, among them,
    how many each rule fails on its own (``fails_alone``) and how many it removed when the enabled
    rules are applied in order (``removed_in_sequence``; 0 for a rule that is switched off).
    """
    present = set(columns(table))
    absent = {r.name for r in rules if not set(r.expr_columns()) <= present}
    for r in rules:
        if r.name in absent and r.enabled:
            missing = sorted(set(r.expr_columns()) - present)
            raise ValueError(f"screen rule {r.name}: the table has no column {', '.join(missing)}")
    evaluated = [r for r in rules if r.name not in absent]  # a rule that is off and cannot be evaluated: skipped
    if evaluated:
        ok_all = lazy(table).select([r.expr().fill_null(False).alias(r.name) for r in evaluated]).collect()
    n = len(ok_all) if evaluated else n_rows(table)
    cand = np.ones(n, dtype=bool) if candidates is None else np.asarray(candidates, dtype=bool)
    masks, report, alive = {}, {}, cand.copy()
    for rule in rules:
        if rule.name in absent:
            report[rule.name] = {
                "enabled": False,
                "rule": rule.description,
                "limit": rule.limit,
                "fails_alone": None,
                "removed_in_sequence": 0,
                "remaining_after": int(alive.sum()),
                "note": f"not evaluated: the table has no column {', '.join(rule.expr_columns())}",
            }
            continue
        ok = ok_all[rule.name].to_numpy().astype(bool)
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


def passes_screen(table: Table, screen) -> np.ndarray:
    """(n,) bool: rows (``sim_`` objectives and the design variables) that pass every enabled rule of
    ``params.screen``."""
    return apply_screening(table, screening_rules(screen))[0]


__all__ = [
    "STRICT",
    "ScreenRule",
    "apply_screening",
    "buildable_gear_set",
    "gen_below_motor",
    "HIGHWAY_V_MAX_KMH",
    "mass_max",
    "min_v_max",
    "not_stalled",
    "passes",
    "passes_screen",
    "passing",
    "screening_rules",
    "speed_dev_max",
]
