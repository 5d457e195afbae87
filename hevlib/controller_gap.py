"""The controller's gap (issue 56, ``hev bound``): each pick's, the stock Prius's and the conventional car's fuel
under their own controller (the study's rule base; the conventional car's shift logic) and under ECMS (a causal
controller that minimises fuel plus the battery's energy at an equivalence factor, :func:`hevlib.bound.ecms_fuel`)
against the bound of :mod:`hevlib.bound` on the same hardware and trace, on one yardstick (SOC-corrected fuel on the
engine's hot map), the headline saving under each, and the bound's grid convergence where it is reported."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple

import numpy as np
import pandas as pd
import pyarrow as pa

from hevlib.bound import Bound, BoundGrid, Infeasible, controls, ecms_fuel, fuel_bound, gear_bound
from hevlib.cycles import Cycle
from hevlib.io import finite_or_none
from hevlib.sim.powertrain import layout as L

#: Columns of :func:`controller_gap`'s table, with their units.
GAP_COLUMNS: dict[str, str] = {
    "vehicle": "the pick's design id, prius or conventional",
    "cycle": "",
    "rule_fc_charge_balanced": "L/100 km: the rule base's (the conventional car's shift logic's) charge-balanced fuel",
    "rule_cold_pct": "% of the rule base's fuel: the cold start's surplus (not in the bound)",
    "rule_fc_hot": "L/100 km: the rule base's balanced run, SOC-corrected, on the hot map (the surplus out)",
    "bound_fc": "L/100 km: the bound, SOC-corrected (its end SOC at least its start)",
    "gap_pct": "%: how much more the rule base burns than the bound (rule_fc_hot / bound_fc - 1)",
    "ecms_fc": "L/100 km: ECMS on the bound's model and candidates, charge-balanced (J1711), SOC-corrected",
    "ecms_gap_pct": "%: how much more ECMS burns than the bound (ecms_fc / bound_fc - 1)",
    "ecms_drive_fc_charge_balanced": "L/100 km: ECMS in the drive step (pms.strategy: ecms, hevlib/sim/ecms.py), "
    "charge-balanced as the rule base",
    "ecms_drive_fc_hot": "L/100 km: that run SOC-corrected on the hot map (its cold start's surplus out)",
    "ecms_drive_gap_pct": "%: how much more ECMS in the drive step burns than the bound "
    "(ecms_drive_fc_hot / bound_fc - 1)",
    "rule_starts": "engine starts of the rule base's balanced run",
    "bound_starts": "engine starts on the bound's run",
    "ecms_starts": "engine starts on ECMS's balanced run",
    "ecms_drive_starts": "engine starts of the drive step's ECMS's balanced run",
    "soc_init": "the SOC both start from: the rule base's charge-balanced start",
    "bound_soc_end": "the bound's final SOC",
    "note": "why there is no bound, where there is none",
}


def _conventional_row(label: str, vehicle, cname: str, cycle: Cycle) -> dict:
    """The conventional car's row of :func:`controller_gap`: its shift logic against its gear bound."""
    from hevlib.sim.simulator import responses, simulate

    run = simulate(vehicle, cycle)
    r = responses(run, cycle, vehicle.library).iloc[0]
    cold = cold_share(run.out[0])
    row = {
        "vehicle": label,
        "cycle": cname,
        "rule_fc_charge_balanced": float(r["fc"]),
        "rule_cold_pct": 100.0 * cold,
        "rule_fc_hot": float(r["fc"] * (1.0 - cold)),
        "bound_fc": np.nan,
        "gap_pct": np.nan,
        "ecms_fc": np.nan,
        "ecms_gap_pct": np.nan,
        "rule_starts": 0.0,
        "bound_starts": 0.0,
        "ecms_starts": np.nan,
        "soc_init": np.nan,
        "bound_soc_end": np.nan,
        "note": "",
    } | dict.fromkeys(_DRIVE_ECMS, np.nan)
    if not bool(r["cycle_met"]):
        row["note"] = "does not meet the trace under its shift logic"
        return row
    try:
        b = gear_bound(vehicle, cycle)
    except Infeasible as err:
        row["note"] = f"gear bound: {err}"
        return row
    row["bound_fc"] = float(b["fc"])
    row["gap_pct"] = 100.0 * (row["rule_fc_hot"] / row["bound_fc"] - 1.0)
    return row


#: The columns of the drive step's ECMS (a power split's rows only).
_DRIVE_ECMS = ("ecms_drive_fc_charge_balanced", "ecms_drive_fc_hot", "ecms_drive_gap_pct", "ecms_drive_starts")


class BalancedRun(NamedTuple):
    """A power-split vehicle's charge-balanced run under one of the simulator's controllers (:func:`balanced_run`)."""

    fc_charge_balanced: float  # L/100 km
    cold_share: float  # of the fuel, the cold start's surplus
    fc_hot: float  # SOC-corrected, the surplus out, L/100 km
    starts: float
    soc_init: float  # the balanced run's start
    met: bool
    balanced: bool


def balanced_run(vehicle, cycle: Cycle) -> BalancedRun:
    """``vehicle`` (one power-split design) on ``cycle`` under its own controller, charge-balanced as every stage
    balances (``sim.charge_balance_*``), with its fuel on the hot map (the cold start's surplus taken out)."""
    from hevlib.sim.simulator import charge_balance, responses, simulate

    sim = vehicle.library.params.sim
    first = simulate(vehicle, cycle)
    last, cb = charge_balance(
        vehicle, cycle, first, tolerance=sim.charge_balance_tolerance, max_runs=sim.charge_balance_max_runs
    )
    r = responses(last, cycle, vehicle.library).iloc[0]
    cold = cold_share(last.out[0])
    return BalancedRun(
        fc_charge_balanced=float(cb["fc_charge_balanced"].iloc[0]),
        cold_share=cold,
        fc_hot=float(r["fc_soc_corrected"] - cold * r["fc"]),
        starts=float(r["n_engine_starts"]),
        soc_init=float(cb["soc_init_charge_balanced"].iloc[0]),
        met=bool(r["cycle_met"]),
        balanced=bool(cb["charge_balanced"].iloc[0]),
    )


def _ecms_figures(vehicle, cycle: Cycle, grid: BoundGrid, gain: float, soc0: float, ctl, bound_fc: float) -> dict:
    """A power-split row's ECMS columns (:func:`hevlib.bound.ecms_fuel` from ``soc0``, balanced as every stage
    balances); a note where ECMS finds no admissible control or does not balance."""
    sim = vehicle.library.params.sim
    try:
        e = ecms_fuel(
            vehicle,
            cycle,
            grid,
            gain,
            soc0,
            tolerance=sim.charge_balance_tolerance,
            max_runs=sim.charge_balance_max_runs,
            ctl=ctl,
        )
    except Infeasible as err:
        return {"note": f"ecms: {err}"}
    if not e.balanced:
        return {"note": f"ecms: no charge balance in {e.runs} runs"}
    fc = float(e.run.responses["fc_soc_corrected"])
    return {
        "ecms_fc": fc,
        "ecms_gap_pct": 100.0 * (fc / bound_fc - 1.0),
        "ecms_starts": float(e.run.responses["n_engine_starts"]),
    }


#: Columns of :class:`GapTable`'s ``soc``: each power-split vehicle's SOC along the first cycle under every controller.
SOC_COLUMNS: dict[str, str] = {
    "vehicle": "the pick's design id or prius",
    "time_s": "s",
    "soc_rule": "the rule base's SOC from its charge-balanced start",
    "soc_ecms_drive": "the drive step's ECMS's SOC from its own charge-balanced start (NaN where it has none)",
    "soc_bound": "the bound's SOC from the rule base's start (NaN where there is no bound)",
}


class GapTable(NamedTuple):
    """:func:`controller_gap`'s result: the gap table (:data:`GAP_COLUMNS`, one row per vehicle and cycle) and the
    SOC traces on the first cycle (:data:`SOC_COLUMNS`, every power-split vehicle)."""

    table: pd.DataFrame
    soc: pd.DataFrame


def _soc_frame(label: str, vehicle, cycle: Cycle, rule: BalancedRun, drive: BalancedRun, bound: Bound | None):
    """One vehicle's :data:`SOC_COLUMNS` on ``cycle``: each controller's SOC from the start its figures come from."""
    from hevlib.sim.simulator import vehicle_trace

    def soc(v, start: float) -> np.ndarray:
        return vehicle_trace(v, cycle, soc_init=start)["soc"].to_numpy(dtype=float)

    nan = np.full(cycle.n_steps, np.nan)
    return pd.DataFrame(
        {
            "vehicle": label,
            "time_s": np.asarray(cycle.time_s, dtype=float),
            "soc_rule": soc(vehicle.with_strategy("fuzzy"), rule.soc_init),
            "soc_ecms_drive": soc(vehicle.with_strategy("ecms"), drive.soc_init)
            if drive.met and drive.balanced
            else nan,
            "soc_bound": bound.trace[:, 0] if bound is not None else nan,
        },
        columns=list(SOC_COLUMNS),
    )


def controller_gap(
    vehicles: Mapping[str, object],
    cycles: Mapping[str, Cycle],
    grid: BoundGrid,
    progress: Callable[[int, int], None] | None = None,
    *,
    ecms_gain: float,
) -> GapTable:
    """For each vehicle (label -> a :class:`hevlib.sim.vehicles.Vehicle` of one design) and cycle: a power-split
    car's rule base, charge-balanced (``sim.charge_balance_*`` as every stage balances), its bound and ECMS (SOC
    feedback ``ecms_gain``, balanced as the rule base) from the SOC that run starts from; the conventional car's
    shift logic and its gear bound (:func:`gear_bound`); side by side on one yardstick (SOC-corrected fuel on the
    hot map), :data:`GAP_COLUMNS`.

    A vehicle that does not meet a cycle's trace under the rule base gets no bound there (the bound follows the
    trace exactly: a controller's fuel on a trace it does not drive is not comparable); nor one whose trace the
    bound finds no admissible control for on its grid (said in ``note``). With the table, every power-split
    vehicle's SOC along the first cycle under each controller (:class:`GapTable`)."""
    rows, socs = [], []
    first = next(iter(cycles), None)
    total, done = len(vehicles) * len(cycles), 0
    for cname, cycle in cycles.items():
        for label, vehicle in vehicles.items():
            if vehicle.kind == "conventional":
                rows.append(_conventional_row(label, vehicle, cname, cycle))
                done += 1
                if progress is not None:
                    progress(done, total)
                continue
            rule = balanced_run(vehicle.with_strategy("fuzzy"), cycle)
            drive = balanced_run(vehicle.with_strategy("ecms"), cycle)
            soc0 = rule.soc_init
            row = {
                "vehicle": label,
                "cycle": cname,
                "rule_fc_charge_balanced": rule.fc_charge_balanced,
                "rule_cold_pct": 100.0 * rule.cold_share,
                "rule_fc_hot": rule.fc_hot,
                "bound_fc": np.nan,
                "gap_pct": np.nan,
                "ecms_fc": np.nan,
                "ecms_gap_pct": np.nan,
                "ecms_drive_fc_charge_balanced": np.nan,
                "ecms_drive_fc_hot": np.nan,
                "ecms_drive_gap_pct": np.nan,
                "rule_starts": rule.starts,
                "bound_starts": np.nan,
                "ecms_starts": np.nan,
                "ecms_drive_starts": np.nan,
                "soc_init": soc0,
                "bound_soc_end": np.nan,
                "note": "",
            }
            b = None
            if drive.met and drive.balanced:
                row["ecms_drive_fc_charge_balanced"] = drive.fc_charge_balanced
                row["ecms_drive_fc_hot"] = drive.fc_hot
                row["ecms_drive_starts"] = drive.starts
            if not rule.met:
                row["note"] = "does not meet the trace under the rule base"
            elif not rule.balanced:
                row["note"] = "the rule base does not balance its charge"
            else:
                ctl = controls(vehicle, cycle, grid)
                try:
                    b = fuel_bound(vehicle, cycle, grid, soc0, ctl=ctl)
                except Infeasible as err:
                    row["note"] = f"bound: {err}"
                else:
                    row["bound_fc"] = float(b.responses["fc_soc_corrected"])
                    row["gap_pct"] = 100.0 * (row["rule_fc_hot"] / row["bound_fc"] - 1.0)
                    row["bound_starts"] = float(b.responses["n_engine_starts"])
                    row["bound_soc_end"] = b.soc_end
                    row |= _ecms_figures(vehicle, cycle, grid, ecms_gain, soc0, ctl, row["bound_fc"])
                    row["ecms_drive_gap_pct"] = 100.0 * (row["ecms_drive_fc_hot"] / row["bound_fc"] - 1.0)
            if cname == first:
                socs.append(_soc_frame(label, vehicle, cycle, rule, drive, b))
            rows.append(row)
            done += 1
            if progress is not None:
                progress(done, total)
    soc = pd.concat(socs, ignore_index=True) if socs else pd.DataFrame(columns=list(SOC_COLUMNS))
    return GapTable(table=pd.DataFrame(rows, columns=list(GAP_COLUMNS)), soc=soc)


def grid_convergence(
    vehicles: Mapping[str, object],
    cycle_name: str,
    cycle: Cycle,
    grid: BoundGrid,
    table: pd.DataFrame,
    finer_on: Sequence[str],
) -> dict:
    """How far the bound moves, in %, on ``cycle`` when its SOC step is halved (every power-split vehicle of
    ``table`` with a bound there) and when the engine-on candidates are doubled each way (``finer_on`` only: four
    times the work), against the table's own bound from the same start."""
    rows = table[(table["cycle"] == cycle_name) & table["bound_fc"].notna() & (table["vehicle"] != "conventional")]
    out = []
    for _, r in rows.iterrows():
        vehicle, soc0, fc = vehicles[r["vehicle"]], float(r["soc_init"]), float(r["bound_fc"])
        half = fuel_bound(vehicle, cycle, grid._replace(soc_step=grid.soc_step / 2), soc0).responses
        entry = {
            "vehicle": r["vehicle"],
            "fc": fc,
            "soc_step_halved_pct": 100.0 * (half["fc_soc_corrected"] / fc - 1.0),
            "candidates_doubled_pct": None,
        }
        if r["vehicle"] in finer_on:
            finer = grid._replace(n_speed=2 * grid.n_speed, n_torque=2 * grid.n_torque)
            entry["candidates_doubled_pct"] = 100.0 * (
                fuel_bound(vehicle, cycle, finer, soc0).responses["fc_soc_corrected"] / fc - 1.0
            )
        out.append(entry)

    def most(key: str) -> float | None:
        values = [abs(e[key]) for e in out if e[key] is not None]
        return max(values) if values else None

    return {
        "cycle": cycle_name,
        "soc_step_halved_pct_max_abs": most("soc_step_halved_pct"),
        "candidates_doubled_pct_max_abs": most("candidates_doubled_pct"),
        "rows": out,
    }


#: What the bound leaves out (:mod:`hevlib.bound`'s docstring), for the report.
LEAVES_OUT: tuple[str, ...] = (
    "the engine's thermal state: the hot map throughout (the rule base is compared on its hot-map fuel, its cold "
    "start's surplus taken out and reported as rule_cold_pct)",
    "the tailpipe: no emission constraint, fuel only",
    "the carrier's inertia and the generator's rate of moving it: any engine speed of the window within a step",
    "the rule base's minimum on and off times and its thresholds",
    "the driver: the trace is followed exactly (no bound where the rule base does not meet it)",
)


def _spread(values: pd.Series) -> dict[str, float | None]:
    v = values.dropna()
    if not v.size:
        return {"median": None, "min": None, "max": None}
    return {"median": float(v.median()), "min": float(v.min()), "max": float(v.max())}


def gap_report(table: pd.DataFrame, grid: BoundGrid, convergence: Mapping, *, ecms_gain: float) -> dict:
    """The controller's gap as ``reports/bound.json``: the settings, what the bound leaves out, every row of
    :func:`controller_gap`, per cycle the spread over the picks of how much more the rule base, ECMS on the bound's
    model and ECMS in the drive step burn than the bound and of drive-step ECMS against the rule base, the stock
    Prius's and the conventional car's gaps, and the bound's grid convergence (:func:`grid_convergence`). The
    recommended design's figures and the headline saving under each controller are the validate stage's
    (:func:`hevlib.validation.gap.recommended_gap`: the recommendation is made after this table, from the validation
    runs)."""

    def one(rows: pd.DataFrame, vehicle: str, col: str) -> float | None:
        hit = rows.loc[rows["vehicle"] == vehicle, col]
        return finite_or_none(hit.iloc[0]) if len(hit) else None

    by_cycle = {}
    for cname, rows in table.groupby("cycle", sort=False):
        picks = rows[~rows["vehicle"].isin(["prius", "conventional"])]
        drive_over_rule = 100.0 * (picks["ecms_drive_fc_hot"] / picks["rule_fc_hot"] - 1.0)
        by_cycle[cname] = {
            "picks": int(len(picks)),
            "picks_with_bound": int(picks["gap_pct"].notna().sum()),
            "picks_meeting_under_ecms_drive": int(picks["ecms_drive_fc_hot"].notna().sum()),
            "gap_pct": _spread(picks["gap_pct"]),
            "ecms_gap_pct": _spread(picks["ecms_gap_pct"]),
            "ecms_drive_gap_pct": _spread(picks["ecms_drive_gap_pct"]),
            "ecms_drive_over_rule_pct": _spread(drive_over_rule),
            "prius_gap_pct": one(rows, "prius", "gap_pct"),
            "prius_ecms_gap_pct": one(rows, "prius", "ecms_gap_pct"),
            "prius_ecms_drive_gap_pct": one(rows, "prius", "ecms_drive_gap_pct"),
            "conventional_gap_pct": one(rows, "conventional", "gap_pct"),
        }
    return {
        "settings": {**grid._asdict(), "ecms_soc_gain": ecms_gain, "cycles": list(dict.fromkeys(table["cycle"]))},
        "leaves_out": list(LEAVES_OUT),
        "columns": GAP_COLUMNS,
        "by_cycle": by_cycle,
        "convergence": dict(convergence),
        "rows": table.to_dict("records"),
    }


def gap_markdown(report: dict) -> str:
    """``reports/bound.md``: the gap per cycle over the picks and for both cars, and the table of every vehicle."""
    s = report["settings"]

    def pct(x):
        return "—" if x is None or not np.isfinite(x) else f"{x:+.1f} %"

    def spread(d: Mapping) -> str:
        return "—" if d["median"] is None else f"{pct(d['median'])} ({pct(d['min'])} .. {pct(d['max'])})"

    lines = [
        "# The controller's gap: the rule base against the least fuel any controller could burn",
        "",
        f"Dynamic programming over the battery's SOC (`hev bound`, `hevlib/bound.py`): SOC step {s['soc_step']:g}, "
        f"{s['n_speed']} x {s['n_torque']} engine-on candidates per step. Every controller SOC-corrected on the "
        "engine's hot map (the cold-start surplus is taken out and shown). The bound leaves out: "
        + "; ".join(report["leaves_out"])
        + ". The recommended design's gap and the headline saving under each controller are in "
        "`reports/summary.md` and `reports/validation.json` (`controller_gap`).",
        "",
        "How much more each controller burns than the bound, over the picks: median (range):",
        "",
        "| cycle | picks with a bound | rule base | ECMS in the drive step | ECMS on the bound's model "
        "| drive-step ECMS against the rule base | stock Prius: rule / drive-step ECMS / ECMS | conventional (gears) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for cname, c in report["by_cycle"].items():
        prius = f"{pct(c['prius_gap_pct'])} / {pct(c['prius_ecms_drive_gap_pct'])} / {pct(c['prius_ecms_gap_pct'])}"
        lines.append(
            f"| {cname} | {c['picks_with_bound']} of {c['picks']} | {spread(c['gap_pct'])} "
            f"| {spread(c['ecms_drive_gap_pct'])} ({c['picks_meeting_under_ecms_drive']} meet the trace) "
            f"| {spread(c['ecms_gap_pct'])} | {spread(c['ecms_drive_over_rule_pct'])} | {prius} "
            f"| {pct(c['conventional_gap_pct'])} |"
        )
    cv = report["convergence"]
    doubled = [e for e in cv["rows"] if e["candidates_doubled_pct"] is not None]
    lines += [
        "",
        "ECMS on the bound's model (`hevlib.bound.ecms_fuel`) chooses each step the control of least fuel plus battery "
        f"energy at the equivalence factor s0 + {s['ecms_soc_gain']:g} x (target SOC - SOC), s0 the reciprocal of the "
        "engine's best efficiency, on the bound's candidates; ECMS in the drive step (`pms.strategy: ecms`, "
        "`hevlib/sim/ecms.py`) the same cost on the simulator itself (its thermal state, spin-ups, tailpipe, the rule "
        "base's warm-up rule and minimum times). Both are causal: they know nothing of the trace ahead.",
        "",
        f"Grid convergence on {cv['cycle']}: halving the SOC step moves the bound by at most "
        f"{cv['soc_step_halved_pct_max_abs']:.2f} % over {len(cv['rows'])} vehicles; doubling the candidates each "
        f"way by at most {cv['candidates_doubled_pct_max_abs']:.2f} % ("
        + ", ".join(f"{e['vehicle']} {e['candidates_doubled_pct']:+.2f} %" for e in doubled)
        + ").",
        "",
        "The conventional car's controller is its shift logic and its bound the best gear on every step (no battery: "
        "nothing to carry from step to step).",
        "",
        "| vehicle | cycle | rule base, charge-balanced [L/100 km] | cold surplus | rule base, hot [L/100 km] "
        "| ECMS [L/100 km] | ECMS in the drive step, hot [L/100 km] | bound [L/100 km] "
        "| gap: rule base / ECMS / drive-step ECMS | starts: rule / ECMS / drive-step ECMS / bound | note |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in report["rows"]:
        b, e, ed = (
            ("—" if not np.isfinite(r[k]) else f"{r[k]:.3f}") for k in ("bound_fc", "ecms_fc", "ecms_drive_fc_hot")
        )
        b_starts, e_starts, d_starts = (
            ("—" if not np.isfinite(r[k]) else f"{r[k]:.0f}")
            for k in ("bound_starts", "ecms_starts", "ecms_drive_starts")
        )
        starts = f"{r['rule_starts']:.0f} / {e_starts} / {d_starts} / {b_starts}"
        gaps = f"{pct(r['gap_pct'])} / {pct(r['ecms_gap_pct'])} / {pct(r['ecms_drive_gap_pct'])}"
        lines.append(
            f"| {r['vehicle']} | {r['cycle']} | {r['rule_fc_charge_balanced']:.3f} | {r['rule_cold_pct']:.1f} % "
            f"| {r['rule_fc_hot']:.3f} | {e} | {ed} | {b} | {gaps} | {starts} | {r['note']} |"
        )
    return "\n".join(lines) + "\n"


def cold_share(out: np.ndarray) -> float:
    """The share of a run's fuel energy that is the cold start's surplus (an ``O_*`` row)."""
    return float(out[L.O_E_FUEL_COLD] / out[L.O_E_FUEL]) if out[L.O_E_FUEL] > 0.0 else 0.0


def gap_schema() -> pa.Schema:
    """Explicit schema of ``data/bound/gap.parquet`` (:data:`GAP_COLUMNS`; fuel in L/100 km, gaps in %)."""
    text = ("vehicle", "cycle", "note")
    fields = [pa.field(c, pa.string() if c in text else pa.float64(), nullable=c not in text[:2]) for c in GAP_COLUMNS]
    return pa.schema(fields)


def soc_schema() -> pa.Schema:
    """Explicit schema of ``data/bound/soc.parquet`` (:data:`SOC_COLUMNS`)."""
    return pa.schema([pa.field(c, pa.string() if c == "vehicle" else pa.float64()) for c in SOC_COLUMNS])


class BoundStudy(NamedTuple):
    """What ``hev bound`` writes: the report (:func:`gap_report`), the gap table and the SOC traces on the first
    cycle (:class:`GapTable`)."""

    report: dict
    table: pd.DataFrame
    soc: pd.DataFrame


def bound_study(
    sim,
    designs: Mapping[str, np.ndarray],
    cycles: Mapping[str, Cycle],
    grid: BoundGrid,
    progress: Callable[[int, int], None] | None = None,
    *,
    ecms_gain: float,
) -> BoundStudy:
    """The controller's gap of every design (``designs``: id -> its row of the seven variables, the shortlist in its
    order), the stock Prius and the conventional car on ``cycles`` (:func:`controller_gap`, ECMS with SOC feedback
    ``ecms_gain``), and the bound's grid convergence on the first cycle: the SOC step halved for every power-split
    vehicle, the candidates doubled for the stock Prius and the shortlist's first design."""
    vehicles = {"conventional": sim.vehicle(None, "conventional"), "prius": sim.vehicle(None, "prius")}
    vehicles.update({k: sim.vehicle(np.asarray(x, float).reshape(1, -1), "hybrid") for k, x in designs.items()})
    gap = controller_gap(vehicles, cycles, grid, progress, ecms_gain=ecms_gain)
    first = next(iter(cycles))
    finer_on = ["prius", *list(designs)[:1]]
    convergence = grid_convergence(vehicles, first, cycles[first], grid, gap.table, finer_on)
    report = gap_report(gap.table, grid, convergence, ecms_gain=ecms_gain)
    return BoundStudy(report=report, table=gap.table, soc=gap.soc)
