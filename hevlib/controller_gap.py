"""The controller's gap (issue 56, ``hev bound``): each pick's, the stock Prius's and the conventional car's fuel
under their own controller (the study's rule base; the conventional car's shift logic) and under ECMS (a causal
controller that minimises fuel plus the battery's energy at an equivalence factor, :func:`hevlib.bound.ecms_fuel`)
against the bound of :mod:`hevlib.bound` on the same hardware and trace, on one yardstick (SOC-corrected fuel on the
engine's hot map), the headline saving under each, and the bound's grid convergence where it is reported."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import NamedTuple

import numpy as np
import pandas as pd

from hevlib.bound import Bound, BoundGrid, Infeasible, controls, ecms_fuel, fuel_bound, gear_bound
from hevlib.cycles import Cycle
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


def controller_gap(
    vehicles: Mapping[str, object],
    cycles: Mapping[str, Cycle],
    grid: BoundGrid,
    progress: Callable[[int, int], None] | None = None,
    *,
    ecms_gain: float,
) -> pd.DataFrame:
    """For each vehicle (label -> a :class:`hevlib.sim.vehicles.Vehicle` of one design) and cycle: a power-split
    car's rule base, charge-balanced (``sim.charge_balance_*`` as every stage balances), its bound and ECMS (SOC
    feedback ``ecms_gain``, balanced as the rule base) from the SOC that run starts from; the conventional car's
    shift logic and its gear bound (:func:`gear_bound`); side by side on one yardstick (SOC-corrected fuel on the
    hot map), :data:`GAP_COLUMNS`.

    A vehicle that does not meet a cycle's trace under the rule base gets no bound there (the bound follows the
    trace exactly: a controller's fuel on a trace it does not drive is not comparable); nor one whose trace the
    bound finds no admissible control for on its grid (said in ``note``)."""
    rows = []
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
            rows.append(row)
            done += 1
            if progress is not None:
                progress(done, total)
    return pd.DataFrame(rows, columns=list(GAP_COLUMNS))


def grid_convergence(vehicle, cycle: Cycle, grid: BoundGrid, soc_init: float) -> tuple[Bound, dict[str, float]]:
    """The bound of ``vehicle`` on ``cycle`` and how far it moves, in %, when the SOC step is halved and when the
    engine-on candidates are doubled in each direction (the bound's resolution, measured where it is reported)."""
    base = fuel_bound(vehicle, cycle, grid, soc_init)
    fc = base.responses["fc_soc_corrected"]
    half = fuel_bound(vehicle, cycle, grid._replace(soc_step=grid.soc_step / 2), soc_init).responses
    finer = fuel_bound(
        vehicle, cycle, grid._replace(n_speed=2 * grid.n_speed, n_torque=2 * grid.n_torque), soc_init
    ).responses
    return base, {
        "fc": float(fc),
        "soc_step_halved_pct": 100.0 * (half["fc_soc_corrected"] / fc - 1.0),
        "candidates_doubled_pct": 100.0 * (finer["fc_soc_corrected"] / fc - 1.0),
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


def gap_report(
    table: pd.DataFrame, grid: BoundGrid, recommended: str, convergence: Mapping[str, float], *, ecms_gain: float
) -> dict:
    """The controller's gap as ``reports/bound.json``: the settings, what the bound leaves out, every row of
    :func:`controller_gap`, per cycle the spread of the gap over the picks and the gaps of the recommended design,
    the stock Prius and the conventional car, the headline saving (the recommended design against the conventional
    car, both on the hot map) under the rule base, under ECMS, with the hybrid at its bound, and with both at their
    bounds, ECMS's distance from the bound, and the bound's grid convergence (``convergence``, on the recommended
    design and the first cycle)."""

    def one(rows: pd.DataFrame, vehicle: str, col: str) -> float:
        hit = rows.loc[rows["vehicle"] == vehicle, col]
        return float(hit.iloc[0]) if len(hit) else np.nan

    by_cycle = {}
    for cname, rows in table.groupby("cycle", sort=False):
        picks = rows[~rows["vehicle"].isin(["prius", "conventional"])]
        gaps, ecms_gaps = picks["gap_pct"].dropna(), picks["ecms_gap_pct"].dropna()
        drive_gaps = picks["ecms_drive_gap_pct"].dropna()
        drive_over_rule = (picks["ecms_drive_fc_hot"] / picks["rule_fc_hot"] - 1.0).dropna() * 100.0
        conv_rule, conv_bound = one(rows, "conventional", "rule_fc_hot"), one(rows, "conventional", "bound_fc")
        rec_rule, rec_bound = one(rows, recommended, "rule_fc_hot"), one(rows, recommended, "bound_fc")
        rec_ecms, rec_drive = one(rows, recommended, "ecms_fc"), one(rows, recommended, "ecms_drive_fc_hot")
        by_cycle[cname] = {
            "picks_with_bound": int(gaps.size),
            "picks": int(len(picks)),
            "gap_pct_median": float(gaps.median()) if gaps.size else None,
            "gap_pct_min": float(gaps.min()) if gaps.size else None,
            "gap_pct_max": float(gaps.max()) if gaps.size else None,
            "recommended_gap_pct": one(rows, recommended, "gap_pct"),
            "prius_gap_pct": one(rows, "prius", "gap_pct"),
            "conventional_gap_pct": one(rows, "conventional", "gap_pct"),
            "ecms_gap_pct_median": float(ecms_gaps.median()) if ecms_gaps.size else None,
            "ecms_gap_pct_max": float(ecms_gaps.max()) if ecms_gaps.size else None,
            "recommended_ecms_gap_pct": one(rows, recommended, "ecms_gap_pct"),
            "prius_ecms_gap_pct": one(rows, "prius", "ecms_gap_pct"),
            "ecms_drive_gap_pct_median": float(drive_gaps.median()) if drive_gaps.size else None,
            "ecms_drive_gap_pct_max": float(drive_gaps.max()) if drive_gaps.size else None,
            "recommended_ecms_drive_gap_pct": one(rows, recommended, "ecms_drive_gap_pct"),
            "prius_ecms_drive_gap_pct": one(rows, "prius", "ecms_drive_gap_pct"),
            "ecms_drive_over_rule_pct_median": float(drive_over_rule.median()) if drive_over_rule.size else None,
            "ecms_drive_over_rule_pct_min": float(drive_over_rule.min()) if drive_over_rule.size else None,
            "ecms_drive_over_rule_pct_max": float(drive_over_rule.max()) if drive_over_rule.size else None,
            "picks_meeting_under_ecms_drive": int(picks["ecms_drive_fc_hot"].notna().sum()),
            "saving_rule_pct": 100.0 * (1.0 - rec_rule / conv_rule),
            "saving_ecms_pct": 100.0 * (1.0 - rec_ecms / conv_rule),
            "saving_ecms_drive_pct": 100.0 * (1.0 - rec_drive / conv_rule),
            "saving_bound_pct": 100.0 * (1.0 - rec_bound / conv_rule),
            "saving_both_bounds_pct": 100.0 * (1.0 - rec_bound / conv_bound),
        }
    return {
        "settings": {**grid._asdict(), "ecms_soc_gain": ecms_gain, "cycles": list(dict.fromkeys(table["cycle"]))},
        "recommended": recommended,
        "leaves_out": list(LEAVES_OUT),
        "columns": GAP_COLUMNS,
        "by_cycle": by_cycle,
        "convergence": dict(convergence),
        "rows": table.to_dict("records"),
    }


def gap_markdown(report: dict) -> str:
    """``reports/bound.md``: the gap per cycle and the table of every pick."""
    rec = report["recommended"]
    s = report["settings"]
    lines = [
        "# The controller's gap: the rule base against the least fuel any controller could burn",
        "",
        f"Dynamic programming over the battery's SOC (`hev bound`, `hevlib/bound.py`): SOC step {s['soc_step']:g}, "
        f"{s['n_speed']} x {s['n_torque']} engine-on candidates per step. Both sides SOC-corrected on the engine's "
        "hot map (the rule base's cold-start surplus is taken out and shown). The bound leaves out: "
        + "; ".join(report["leaves_out"])
        + ".",
        "",
        "| cycle | picks with a bound | gap median (range) | recommended (" + rec + ") | stock Prius "
        "| conventional (gears) | saving vs conventional: rule base | hybrid under ECMS | hybrid at its bound "
        "| both at their bounds |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]

    def pct(x):
        return "—" if x is None or not np.isfinite(x) else f"{x:+.1f} %"

    def num(x):
        return "—" if x is None or not np.isfinite(x) else f"{x:.1f} %"

    for cname, c in report["by_cycle"].items():
        spread = (
            f"{pct(c['gap_pct_median'])} ({pct(c['gap_pct_min'])} .. {pct(c['gap_pct_max'])})"
            if c["gap_pct_median"] is not None
            else "—"
        )
        lines.append(
            f"| {cname} | {c['picks_with_bound']} of {c['picks']} | {spread} | {pct(c['recommended_gap_pct'])} "
            f"| {pct(c['prius_gap_pct'])} | {pct(c['conventional_gap_pct'])} | {num(c['saving_rule_pct'])} "
            f"| {num(c['saving_ecms_pct'])} | {num(c['saving_bound_pct'])} | {num(c['saving_both_bounds_pct'])} |"
        )
    lines += [
        "",
        "ECMS (`hevlib.bound.ecms_fuel`): each step the control of least fuel plus battery energy at the equivalence "
        f"factor s0 + {report['settings']['ecms_soc_gain']:g} x (target SOC - SOC), s0 the reciprocal of the engine's "
        "best efficiency, on the bound's model and candidates (a causal controller: it knows nothing of the trace "
        "ahead), charge-balanced as the rule base. How much more it burns than the bound:",
        "",
        "| cycle | picks: median (most) | recommended | stock Prius |",
        "|---|---|---|---|",
    ]
    for cname, c in report["by_cycle"].items():
        lines.append(
            f"| {cname} | {pct(c['ecms_gap_pct_median'])} ({pct(c['ecms_gap_pct_max'])}) "
            f"| {pct(c['recommended_ecms_gap_pct'])} | {pct(c['prius_ecms_gap_pct'])} |"
        )
    lines += [
        "",
        "ECMS in the drive step (`pms.strategy: ecms`, `hevlib/sim/ecms.py`): the same cost on the simulator itself "
        "(its thermal state, spin-ups, tailpipe, the rule base's warm-up rule and minimum times), charge-balanced "
        "from its own start, SOC-corrected on the hot map as the rule base:",
        "",
        "| cycle | picks meeting the trace | over the bound: picks median (most) | recommended | stock Prius "
        "| against the rule base: picks median (range) | saving vs conventional |",
        "|---|---|---|---|---|---|---|",
    ]
    for cname, c in report["by_cycle"].items():
        lines.append(
            f"| {cname} | {c['picks_meeting_under_ecms_drive']} of {c['picks']} "
            f"| {pct(c['ecms_drive_gap_pct_median'])} ({pct(c['ecms_drive_gap_pct_max'])}) "
            f"| {pct(c['recommended_ecms_drive_gap_pct'])} | {pct(c['prius_ecms_drive_gap_pct'])} "
            f"| {pct(c['ecms_drive_over_rule_pct_median'])} ({pct(c['ecms_drive_over_rule_pct_min'])} .. "
            f"{pct(c['ecms_drive_over_rule_pct_max'])}) | {num(c['saving_ecms_drive_pct'])} |"
        )
    cv = report["convergence"]
    lines += [
        "",
        f"Grid convergence ({rec}, {s['cycles'][0]}): halving the SOC step moves the bound by "
        f"{cv['soc_step_halved_pct']:+.2f} %, doubling the candidates each way by "
        f"{cv['candidates_doubled_pct']:+.2f} %.",
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


class BoundStudy(NamedTuple):
    """What ``hev bound`` writes: the report (:func:`gap_report`), the gap table, the recommended design's bound
    on the first cycle and the rule base's trace there from the same start."""

    report: dict
    table: pd.DataFrame
    recommended_bound: Bound
    recommended_rule_trace: pd.DataFrame


def bound_study(
    sim,
    designs: Mapping[str, np.ndarray],
    recommended: str,
    cycles: Mapping[str, Cycle],
    grid: BoundGrid,
    progress: Callable[[int, int], None] | None = None,
    *,
    ecms_gain: float,
) -> BoundStudy:
    """The controller's gap of every design (``designs``: id -> its row of the seven variables), the stock Prius
    and the conventional car on ``cycles`` (:func:`controller_gap`, ECMS with SOC feedback ``ecms_gain``), and the
    grid convergence of the recommended design's bound on the first cycle."""
    vehicles = {"conventional": sim.vehicle(None, "conventional"), "prius": sim.vehicle(None, "prius")}
    vehicles.update({k: sim.vehicle(np.asarray(x, float).reshape(1, -1), "hybrid") for k, x in designs.items()})
    table = controller_gap(vehicles, cycles, grid, progress, ecms_gain=ecms_gain)
    first = next(iter(cycles))
    row = table[(table["vehicle"] == recommended) & (table["cycle"] == first)].iloc[0]
    if not np.isfinite(row["bound_fc"]):
        raise ValueError(f"bound: the recommended design {recommended} has no bound on {first} ({row['note']})")
    soc0 = float(row["soc_init"])
    rec_bound, convergence = grid_convergence(vehicles[recommended], cycles[first], grid, soc0)
    rule_trace = sim.trace(np.asarray(designs[recommended], float).reshape(1, -1), cycles[first], soc_init=soc0)
    report = gap_report(table, grid, recommended, convergence, ecms_gain=ecms_gain)
    return BoundStudy(report=report, table=table, recommended_bound=rec_bound, recommended_rule_trace=rule_trace)
