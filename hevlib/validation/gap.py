"""The controller's gap in the answer (issue 56): ``hev bound``'s table of every shortlisted design's and both reference
cars' fuel under each controller (``data/bound/gap.parquet``, :data:`hevlib.controller_gap.GAP_COLUMNS`) read into
``validation.json``'s ``controller_gap`` with the recommended design's saving under each controller. Only the
table's columns are read here: the bound's physics stays in :mod:`hevlib.controller_gap`."""

from __future__ import annotations

from collections.abc import Sequence

import pandas as pd

from hevlib.io import finite_or_none

#: The reference cars of the gap table (every other vehicle is a pick).
REFERENCE_CARS = ("prius", "conventional")
#: The controllers of the answer's gap: name -> (the gap table's column of their hot-map, SOC-corrected fuel, label).
CONTROLLERS: dict[str, tuple[str, str]] = {
    "rule": ("rule_fc_hot", "the rule base (Table 2; the conventional car's shift logic)"),
    "ecms_drive": ("ecms_drive_fc_hot", "ECMS in the drive step (pms.strategy: ecms)"),
    "ecms": ("ecms_fc", "ECMS on the bound's model and candidates"),
    "bound": ("bound_fc", "the bound: dynamic programming over SOC (the conventional car: the best gear each step)"),
}


def check_covers(table: pd.DataFrame, designs: Sequence[str]) -> None:
    """Stop unless ``hev bound``'s table has a row for every design of ``designs`` (a table of another shortlist is
    an error, not a gap)."""
    missing = sorted(set(designs) - set(table["vehicle"]))
    if missing:
        raise ValueError(f"the controller's gap table has no row for {', '.join(missing)} (another shortlist?)")


def recommended_gap(table: pd.DataFrame, designs: Sequence[str], recommended: str | None) -> dict:
    """The controller's gap in the answer (``validation.json``'s ``controller_gap``): from ``hev bound``'s table
    (``data/bound/gap.parquet``), per cycle, the fuel of each of ``designs`` (the shortlist) and both reference cars
    under every controller of :data:`CONTROLLERS` (hot map, SOC-corrected, L/100 km), how much more each burns than
    the bound, and the ``recommended`` design's saving against the conventional car under each controller (the
    conventional car under its shift logic; ``bound_both``: both at their bounds). Every design of ``designs`` must
    be in the table (a table of another shortlist is an error, not a gap)."""
    check_covers(table, designs)
    by_cycle = {}
    for cname, rows in table.groupby("cycle", sort=False):
        rows = rows.set_index("vehicle")
        vehicles = {}
        for v in [*designs, *REFERENCE_CARS]:
            if v not in rows.index:
                continue
            r = rows.loc[v]
            fc = {name: finite_or_none(r[col]) for name, (col, _) in CONTROLLERS.items()}
            gap = {
                name: (100.0 * (fc[name] / fc["bound"] - 1.0) if fc[name] is not None and fc["bound"] else None)
                for name in CONTROLLERS
                if name != "bound"
            }
            vehicles[v] = {"fc_l_100km": fc, "over_bound_pct": gap, "note": str(r["note"])}
        entry = {"vehicles": vehicles, "saving_pct": None}
        if recommended is not None and recommended in vehicles and "conventional" in vehicles:
            rec, conv = vehicles[recommended]["fc_l_100km"], vehicles["conventional"]["fc_l_100km"]

            def saving(hybrid: float | None, base: float | None) -> float | None:
                return 100.0 * (1.0 - hybrid / base) if hybrid is not None and base else None

            entry["saving_pct"] = {name: saving(rec[name], conv["rule"]) for name in CONTROLLERS} | {
                "bound_both": saving(rec["bound"], conv["bound"])
            }
        by_cycle[cname] = entry
    return {
        "yardstick": "fuel SOC-corrected on the engine's hot map (the cold start's surplus out), L/100 km",
        "controllers": {name: label for name, (_, label) in CONTROLLERS.items()},
        "recommended": recommended,
        "by_cycle": by_cycle,
    }
