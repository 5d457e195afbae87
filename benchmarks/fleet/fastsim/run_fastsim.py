"""Simulate EPA 2022 Test Car List rows with FASTSim 2.1.5 (peer-tool runner).

Run with the isolated venv made by ``setup.sh`` (never the project's .venv)::

    benchmarks/fleet/fastsim/.venv/bin/python benchmarks/fleet/fastsim/run_fastsim.py \
        --cases CASES.csv --out OUT.csv

CASES.csv: selected rows of EPA's Test Car List (all original columns, read with
``encoding="utf-8-sig"``) plus a first column ``case_id`` (string) and a column
``powertrain`` (``conventional`` or ``power_split``). One output row per case, in input
order, with the columns listed in ``OUT_COLUMNS``. Deterministic and silent on success.

API used (read from the installed fastsim 2.1.5 source): templates are loaded with
``fastsim.vehicle.Vehicle.from_vehdb(id, to_rust=True).to_rust()`` into the Rust-backed
``fastsim.fastsimrust.RustVehicle``; after overriding fields ``RustVehicle.set_derived()``
recomputes the derived arrays and the mass; cycles are ``RustCycle`` and the simulation
is ``fastsimrust.RustSimDrive(cyc, veh).sim_drive()``.

Vehicle construction: where each number comes from
--------------------------------------------------
* Template. Conventional: FASTSim vehicle-db entry 3, "2016 TOYOTA Camry 4cyl 2WD"
  (``resources/FASTSim_py_veh_db.csv``; a 2016 conventional midsize car, SI engine, the
  FASTSim default SI efficiency curve ``params.fc_eff_map_si``). Power-split hybrid: entry
  36, "2016 Toyota Prius Two FWD" (the db's Toyota power-split HEV, Atkinson engine with its
  own NREL map, 53 kW motor, 0.75 kWh / 1000 kW battery). Everything not listed below
  (frontal area, wheel inertia and radius, aux load, transmission efficiency, engine
  transient, HEV control thresholds, motor and battery) is the template's.
* Mass: ``Equivalent Test Weight (lbs.)`` x 0.45359237 -> ``veh_override_kg`` (FASTSim
  then uses it as the whole test mass, ``veh_kg``); ``cargo_kg`` = 0. FASTSim adds the
  template's wheel rotational inertia on top (4 x 0.815 kg m^2, 29-32 kg equivalent).
* Road load: FASTSim's own ABC-to-drag conversion, ``fastsimrust.abc_to_drag_coeffs``
  (the Rust twin of ``fastsim.auxiliaries.abc_to_drag_coeffs``; same least-squares fit
  of a simulated 70->0 mph coast-down, same result to 1e-5, 3-4x faster) from
  ``Target Coef A (lbf)``, ``Target Coef B (lbf/mph)``, ``Target Coef C (lbf/mph**2)``.
  It fits ``drag_coef`` (with the template's ``frontal_area_m2``) and ``wheel_rr_coef``
  (with the test mass); FASTSim's road load has no linear term, so B is absorbed.
  The ``Set Coef`` columns (dyno settings) are not used.
* Engine: ``Rated Horsepower`` x 0.745699872 -> ``fc_max_kw``. Conventional: FASTSim's
  default SI curve. Hybrid: the template's Atkinson curve is kept. FASTSim's convention
  is that ``fc_max_kw`` is the engine alone. For the Toyota/Lexus power-split rows of the
  2022 list the rated figure is the engine's (Prius/Corolla Hybrid 1.8 L: 96 hp, Toyota's
  system rating 121 hp; Camry/Avalon/RAV4 Hybrid 2.5 L: 176 hp, system 208-219 hp); if a
  row carried a system rating it would overstate the engine, and it is still used as is.
* Transmission: FASTSim 2 has one fixed efficiency (``trans_eff``), kept from the
  template (0.92 conventional, 0.98 Prius). Gears, axle ratio and N/V are not modelled.
* Powertrain type: ``veh_pt_type`` "Conv" (conventional) or "HEV" (power_split).

Tests and results
-----------------
* ``Test Category`` FTP: the 3-bag FTP-75 built from FASTSim's ``udds`` cycle: the full
  UDDS (bag 1 = 0-505 s, bag 2 = 505-1369 s) followed directly by its first 505 s again
  (bag 3). FASTSim 2 has no thermal model, so there is no cold start and the 10-minute
  soak is omitted (nothing in FASTSim would change during it; a hybrid's SOC carries
  over, as it does on the dynamometer). ``Test Procedure`` "Cold CO" (20 F) FTP rows are
  refused. HWY: FASTSim's ``hwfet``; US06: FASTSim's ``us06`` (whole cycle).
* Hybrids: ``sim_drive()`` with ``init_soc=None`` runs FASTSim's own charge-balancing loop
  for HEVs (re-runs the whole test from the previous final SOC until |dE_ess| / E_fuel <=
  ``veh.ess_to_fuel_ok_error`` = 0.5 %, at most ``sim_params.sim_count_max`` = 30 runs).
  For the FTP the whole 3-bag test is balanced as one. That loop is a fixed-point
  iteration and can cycle without converging (the Prius template on US06 does); then,
  and only then, the result is SOC-corrected instead, in the manner of SAE J1711's
  linear correction: the test is run from 13 initial SOCs spread over [min_soc,
  max_soc], runs with |net battery energy| <= 5 % of fuel energy are kept, and each
  phase's fuel is regressed on the net battery energy and read at zero. Column
  ``charge_balance`` says which was used ("fastsim_loop(k runs)", "soc_regression(...)",
  "n/a" for conventional cars).
* Fuel economy is FASTSim's mpgge (miles per gasoline gallon equivalent of 33.7 kWh,
  ``props.kwh_per_gge``), unadjusted (no 5-cycle/label factors). EPA's ``RND_ADJ_FE`` is
  mpg of the test fuel (Tier 2 certification gasoline) from a carbon balance. For the
  CFR's example test fuel (NHV 18,478 Btu/lb, SG 0.745; 40 CFR 600 appendix II) a gallon
  holds about 114,900 Btu = 33.67 kWh, so the gallons differ by about 0.1 %. Reported
  as is, not converted.
* FTP composite: 40 CFR 600.113-12(a) takes the weighted g/mi from 40 CFR 1066.820(b)
  (formerly 86.144-94):
  ``Y_w = 0.43 * (Y_ct + Y_cs) / (D_ct + D_cs) + 0.57 * (Y_ht + Y_hs) / (D_ht + D_hs)``,
  with the hot-stabilised phase taken from bag 2 when bag 4 is not run (Y_hs = Y_cs,
  D_hs = D_cs). Fuel is proportional to carbon, so applied to gallons:
  ``1/mpg_FTP = 0.43 * (F1 + F2) / (D1 + D2) + 0.57 * (F3 + F2) / (D3 + D2)``.
  This is NOT total distance / total fuel. HWY and US06: total distance / total fuel.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import warnings
from functools import cache

# FASTSim logs through Python logging (also from Rust, via pyo3-log): an import-time
# warning about optional pymoo, energy-audit warnings from every coast-down fit and
# trace-miss warnings. Silence WARNING and below before importing it; trace misses are
# reported in the output instead.
logging.disable(logging.WARNING)
warnings.filterwarnings("ignore", category=RuntimeWarning)

import fastsim as fsim  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from fastsim import fsr  # noqa: E402

FASTSIM_VERSION = "2.1.5"
LB_TO_KG = 0.45359237  # exact, by definition of the avoirdupois pound
HP_TO_KW = 0.745699872  # mechanical horsepower (550 ft lbf/s) in kW

# (FASTSim vehicle-db 'selection' id, expected 'Scenario name', veh_pt_type)
TEMPLATES = {
    "conventional": (3, "2016 TOYOTA Camry 4cyl 2WD", "Conv"),
    "power_split": (36, "2016 Toyota Prius Two FWD", "HEV"),
}

FTP_BAG_S = 505  # bags 1 and 3 are UDDS seconds 0-505; bag 2 is 505-end
FTP_WEIGHT_COLD, FTP_WEIGHT_HOT = 0.43, 0.57  # 40 CFR 1066.820(b)
N_SOC_GRID = 13  # initial SOCs for the fallback SOC regression (hybrids only)
SOC_REGRESSION_MAX = 0.05  # keep runs with |net battery energy| <= 5 % of fuel energy

COL_ETW = "Equivalent Test Weight (lbs.)"
COL_A, COL_B, COL_C = (
    "Target Coef A (lbf)",
    "Target Coef B (lbf/mph)",
    "Target Coef C (lbf/mph**2)",
)
COL_HP = "Rated Horsepower"
COL_CAT = "Test Category"
COL_PROC = "Test Procedure Description"

OUT_COLUMNS = [
    "case_id",
    "fastsim_mpg",
    "fastsim_mpg_bag1",
    "fastsim_mpg_bag2",
    "fastsim_mpg_bag3",
    "trace_met",
    "status",
    "mass_kg",
    "drag_coef",
    "frontal_area_m2",
    "wheel_rr_coef",
    "fc_max_kw",
    "mc_max_kw",
    "ess_max_kw",
    "ess_max_kwh",
    "pt_type",
    "fastsim_template",
    "charge_balance",
]


# --------------------------------------------------------------------------- cycles
@cache
def _cycle_dict(name: str) -> dict:
    return fsim.cycle.Cycle.from_file(name).to_dict()


@cache
def cycle_for(category: str) -> fsr.RustCycle:
    """The FASTSim cycle for an EPA test category (FASTSim's shipped cycles)."""
    if category == "FTP":
        udds = _cycle_dict("udds")
        # UDDS seconds 0..505 (506 points); concat drops the first point and shifts
        # time, so bag 3 is exactly the UDDS intervals (0, 505] again.
        first = {k: (np.asarray(v)[: FTP_BAG_S + 1] if k != "name" else v) for k, v in udds.items()}
        return fsim.cycle.Cycle.from_dict(fsim.cycle.concat([udds, first], name="ftp75_3bag")).to_rust()
    if category == "HWY":
        return fsim.cycle.Cycle.from_file("hwfet").to_rust()
    if category == "US06":
        return fsim.cycle.Cycle.from_file("us06").to_rust()
    raise ValueError(f"unsupported Test Category {category!r} (FTP, HWY, US06 only)")


# -------------------------------------------------------------------------- vehicle
@cache
def _template(powertrain: str) -> fsr.RustVehicle:
    if powertrain not in TEMPLATES:
        raise ValueError(f"unknown powertrain {powertrain!r} (conventional or power_split)")
    vid, name, pt = TEMPLATES[powertrain]
    veh = fsim.vehicle.Vehicle.from_vehdb(vid, to_rust=True).to_rust()
    if veh.scenario_name != name or veh.veh_pt_type != pt:
        raise RuntimeError(f"FASTSim vehdb id {vid} is {veh.scenario_name!r}/{veh.veh_pt_type}, expected {name!r}/{pt}")
    return veh


def _num(row: pd.Series, col: str) -> float:
    val = pd.to_numeric(row.get(col), errors="coerce")
    if val is None or not math.isfinite(val):
        raise ValueError(f"missing or non-numeric {col!r}: {row.get(col)!r}")
    return float(val)


@cache
def build_vehicle(powertrain: str, etw_lb: float, hp: float, a: float, b: float, c: float) -> fsr.RustVehicle:
    """FASTSim vehicle for one EPA test configuration (see module docstring)."""
    if etw_lb <= 0 or hp <= 0:
        raise ValueError(f"non-positive test weight {etw_lb} or rated hp {hp}")
    veh = _template(powertrain).copy()
    veh.veh_pt_type = TEMPLATES[powertrain][2]
    if powertrain == "conventional":
        veh.fc_eff_type = "SI"
        veh.fc_eff_map = fsim.params.fc_eff_map_si  # FASTSim's default SI curve
        veh.stop_start = False
    veh.veh_override_kg = etw_lb * LB_TO_KG
    veh.cargo_kg = 0.0
    veh.fc_max_kw = hp * HP_TO_KW
    veh.set_derived()
    # Road load last: the fit uses the final mass (rolling resistance) and frontal area.
    drag_coef, wheel_rr_coef = fsr.abc_to_drag_coeffs(veh, a, b, c)
    veh.drag_coef = float(drag_coef)
    veh.wheel_rr_coef = float(wheel_rr_coef)
    veh.set_derived()
    return veh


# ------------------------------------------------------------------------- simulate
def simulate(row: pd.Series) -> dict:
    """Run one case; returns every output field except case_id. Raises on bad input."""
    category = str(row.get(COL_CAT, "")).strip()
    if "cold co" in str(row.get(COL_PROC, "")).lower():
        raise ValueError("Cold CO (20 F) FTP is not modelled (FASTSim 2 has no thermal model)")
    cyc = cycle_for(category)
    powertrain = str(row.get("powertrain", "")).strip()
    veh = build_vehicle(
        powertrain,
        _num(row, COL_ETW),
        _num(row, COL_HP),
        _num(row, COL_A),
        _num(row, COL_B),
        _num(row, COL_C),
    )
    out = {
        "mass_kg": veh.veh_kg,
        "drag_coef": veh.drag_coef,
        "frontal_area_m2": veh.frontal_area_m2,
        "wheel_rr_coef": veh.wheel_rr_coef,
        "fc_max_kw": veh.fc_max_kw,
        "mc_max_kw": veh.mc_max_kw,
        "ess_max_kw": veh.ess_max_kw,
        "ess_max_kwh": veh.ess_max_kwh,
        "pt_type": veh.veh_pt_type,
        "fastsim_template": TEMPLATES[powertrain][1],
    }

    sd = fsr.RustSimDrive(cyc, veh.copy())
    sd.sim_drive()  # init_soc=None: FASTSim's own SOC-balancing loop for HEVs
    out["trace_met"] = not bool(sd.trace_miss)
    phases = _phases(category, len(sd.dist_mi))
    fuel_gge, dist_mi, _ = _phase_totals(sd, phases)
    out["charge_balance"] = "n/a"
    if veh.veh_pt_type == "HEV":
        imbalance = _imbalance(sd, veh)
        if imbalance <= veh.ess_to_fuel_ok_error:
            out["charge_balance"] = f"fastsim_loop({sd.hev_sim_count} runs)"
        else:
            fuel_gge, dist_mi, n, met = _soc_regression(cyc, veh, phases)
            out["trace_met"] = out["trace_met"] and met
            out["charge_balance"] = f"soc_regression({n} runs; fastsim_loop ended at {imbalance:.2%})"

    if category == "FTP":
        (f1, f2, f3), (d1, d2, d3) = fuel_gge, dist_mi
        # 40 CFR 600.113-12(a) -> 1066.820(b): bag 2 stands in for the hot-stabilised phase.
        gal_per_mi = FTP_WEIGHT_COLD * (f1 + f2) / (d1 + d2) + FTP_WEIGHT_HOT * (f3 + f2) / (d3 + d2)
        out["fastsim_mpg"] = 1.0 / gal_per_mi
        for k, (f, d) in enumerate(zip(fuel_gge, dist_mi, strict=True), start=1):
            out[f"fastsim_mpg_bag{k}"] = d / f if f > 0 else math.inf
    else:
        out["fastsim_mpg"] = dist_mi.sum() / fuel_gge.sum() if fuel_gge.sum() > 0 else math.inf
    out["status"] = "ok"
    return out


def _phases(category: str, n: int) -> list[slice]:
    """Time-step slices of the reported phases (step i covers t[i-1]..t[i])."""
    if category == "FTP":
        n_udds = len(_cycle_dict("udds")["time_s"])
        return [slice(1, FTP_BAG_S + 1), slice(FTP_BAG_S + 1, n_udds), slice(n_udds, n)]
    return [slice(1, n)]


def _phase_totals(sd, phases) -> tuple[np.ndarray, np.ndarray, float]:
    """Fuel (gge) and distance (mi) per phase, and net battery energy out (kWh)."""
    fuel = np.asarray(sd.fs_kwh_out_ach) / sd.props.kwh_per_gge  # gge per step
    dist = np.asarray(sd.dist_mi)  # miles per step
    soc = np.asarray(sd.soc)
    ess_out_kwh = (soc[0] - soc[-1]) * sd.veh.ess_max_kwh
    return (
        np.array([fuel[s].sum() for s in phases]),
        np.array([dist[s].sum() for s in phases]),
        float(ess_out_kwh),
    )


def _imbalance(sd, veh) -> float:
    """|net battery energy| / fuel energy of a finished run (FASTSim's criterion)."""
    fuel_kwh = float(np.sum(sd.fs_kwh_out_ach))
    soc = np.asarray(sd.soc)
    ess_kwh = abs(soc[0] - soc[-1]) * veh.ess_max_kwh
    return ess_kwh / fuel_kwh if fuel_kwh > 0 else math.inf


def _soc_regression(cyc, veh, phases) -> tuple[np.ndarray, np.ndarray, int, bool]:
    """Fallback when FASTSim's SOC loop does not converge (it can cycle between a few
    initial SOCs, e.g. the Prius template on US06): SOC-corrected fuel in the manner of
    SAE J1711's linear correction. The test is run from N_SOC_GRID initial SOCs evenly
    spaced over [min_soc, max_soc]; runs whose |net battery energy| is within
    SOC_REGRESSION_MAX of their fuel energy are kept; each phase's fuel is regressed
    linearly on the net battery energy of the run and taken at zero net energy.
    """
    rows, met = [], True
    for soc0 in np.linspace(veh.min_soc, veh.max_soc, N_SOC_GRID):
        sd = fsr.RustSimDrive(cyc, veh.copy())
        sd.sim_drive(float(soc0))
        fuel_gge, dist_mi, ess_kwh = _phase_totals(sd, phases)
        total_kwh = fuel_gge.sum() * sd.props.kwh_per_gge
        if total_kwh > 0 and abs(ess_kwh) <= SOC_REGRESSION_MAX * total_kwh:
            rows.append((ess_kwh, fuel_gge, dist_mi))
            met = met and not bool(sd.trace_miss)
    ess = np.array([r[0] for r in rows])
    if len(rows) < 2 or not (ess.min() < 0 < ess.max()):
        raise RuntimeError(
            "charge balance failed: FASTSim SOC loop did not converge and the SOC "
            f"sweep gave no runs bracketing zero net battery energy ({len(rows)} usable)"
        )
    fuel = np.array([r[1] for r in rows])  # runs x phases
    design = np.column_stack([np.ones_like(ess), ess])
    coef, *_ = np.linalg.lstsq(design, fuel, rcond=None)
    dist = np.array([r[2] for r in rows]).mean(axis=0)
    return coef[0], dist, len(rows), met


def run(cases: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for _, row in cases.iterrows():
        rec = {"case_id": row["case_id"]}
        try:
            rec.update(simulate(row))
        except Exception as exc:  # one bad row must not stop the batch
            rec["status"] = f"{type(exc).__name__}: {exc}"
        rows.append(rec)
    return pd.DataFrame(rows, columns=OUT_COLUMNS)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", required=True, help="CSV: EPA test car list rows + case_id, powertrain")
    ap.add_argument("--out", required=True, help="output CSV")
    args = ap.parse_args(argv)

    if fsim.__version__ != FASTSIM_VERSION:
        print(f"error: fastsim {fsim.__version__} found, {FASTSIM_VERSION} required", file=sys.stderr)
        return 2
    cases = pd.read_csv(args.cases, encoding="utf-8-sig", dtype={"case_id": str})
    missing = {"case_id", "powertrain", COL_CAT} - set(cases.columns)
    if missing:
        print(f"error: {args.cases} lacks columns {sorted(missing)}", file=sys.stderr)
        return 2
    out = run(cases)
    out.to_csv(args.out, index=False, float_format="%.6g")
    return 0


if __name__ == "__main__":
    sys.exit(main())
