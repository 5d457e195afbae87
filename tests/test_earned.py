"""`hev simulate` says where the user looks that a design did not drive the cycle: one warning line on stderr,
and the per-km figures of that design left empty in its table (column not_earned gives why), while the
simulator's own responses (what the DOE and the optimisers rank on) stay as they were."""

from __future__ import annotations

import numpy as np
import pandas as pd

from hevlib.cycles import build_cycles
from hevlib.design import DESIGN_VARS
from hevlib.earned import NOT_EARNED, PER_KM, mark_unearned, not_earned, unearned_warning


def _simulate(*args: str):
    from typer.testing import CliRunner

    from stages.cli import app

    return CliRunner().invoke(app, ["simulate", *args])


def test_per_km_columns_are_fuel_and_emissions():
    assert set(PER_KM) == {
        "fc",
        "hc",
        "co",
        "nox",
        "fc_soc_corrected",
        "hc_engine_out",
        "co_engine_out",
        "nox_engine_out",
        "fc_charge_balanced",
    }


def test_the_smallest_design_on_us06_warns_and_reports_no_fuel_figure(stage_dir, params, sim):
    """The lower corner of the default design space cannot follow US06: one warning line naming the count, the
    row and how far off it was; fuel and emissions per km empty, the reason beside them; everything else (and
    the simulator's own responses) as the simulator gave it."""
    small = params.design_space.space().lower
    pd.DataFrame([small], columns=list(DESIGN_VARS)).to_csv("small.csv", index=False)
    res = _simulate("--designs", "small.csv", "--cycle", "us06", "--out", "x.csv")
    assert res.exit_code == 0, res.output
    assert res.stdout.strip() == "simulate: 1 design(s) on us06 -> wrote x.csv"
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    out = pd.read_csv("x.csv")
    err = out.loc[0, "speed_err_mean_kmh"]
    assert err > 5.0  # far off the trace
    assert lines[0] == (
        "simulate: warning: 1 of 1 design(s) did not drive us06 (missed the trace by more than 3.2 km/h); worst: "
        f"row 0, off the trace {100 * out.loc[0, 'speed_dev']:.0f} % of the time, mean speed error {err:.1f} km/h: "
        "their per-km figures are left empty (column not_earned)"
    )
    assert out.loc[0, NOT_EARNED] == "missed the trace" and not out.loc[0, "cycle_met"]
    assert out[[k for k in PER_KM if k in out.columns]].isna().all(axis=None)
    assert "fc" in out.columns and "fc_soc_corrected" in out.columns
    # the simulator itself still returns its figures: only the table a person reads leaves them empty
    raw = sim.run(np.atleast_2d(small), build_cycles(params.cycles)["us06"])
    assert np.isfinite(raw.loc[0, "fc"]) and raw.loc[0, "fc"] > 0
    kept = [c for c in raw.columns if c not in PER_KM and c not in ("cycle_met", "stalled")]
    np.testing.assert_allclose(out.loc[0, kept].to_numpy(dtype=float), raw.loc[0, kept].to_numpy(dtype=float))


def test_the_stock_prius_on_ftp_keeps_its_figures_without_a_warning(stage_dir):
    res = _simulate("--vehicle", "prius", "--cycle", "ftp", "--out", "p.parquet")
    assert res.exit_code == 0, res.output
    assert res.stderr == ""
    out = pd.read_parquet("p.parquet")
    assert out.loc[0, "cycle_met"] and out.loc[0, NOT_EARNED] == ""
    assert 3.0 < out.loc[0, "fc"] < 7.0 and out[[k for k in PER_KM if k in out.columns]].notna().all(axis=None)


def _responses(**cols) -> pd.DataFrame:
    base = {"cycle_met": True, "stalled": False, "e_l": 0.0, "speed_dev": 0.0, "speed_err_mean_kmh": 0.1}
    n = max(len(v) for v in cols.values())
    frame = pd.DataFrame({k: cols.get(k, [v] * n) for k, v in base.items()})
    for k in ("fc", "hc", "fc_charge_balanced", "m_veh"):
        frame[k] = 5.0
    return frame


def test_each_reason_is_told_apart_and_the_worst_is_named(params):
    """Stalled and short of the distance (the simulator's failure: e_l at least the cycle's distance) before a
    missed trace, a missed trace (speed_dev > 0) before unpowered accessories; the warning counts each reason
    and names the worst row."""
    sim = params.sim
    table = _responses(
        cycle_met=[True, False, False, False, False, False],
        stalled=[False, False, False, True, False, False],
        e_l=[0.1, 0.5, 0.0, 12.0, 12.0, 0.2],
        speed_dev=[0.0, 0.3, 0.0, 1.0, 1.0, 0.4],
        speed_err_mean_kmh=[0.1, 4.0, 0.0, 30.0, 25.0, 9.0],
    )
    reasons = not_earned(table, distance_m=12_000.0, sim=sim)
    assert list(reasons) == [
        "",
        "missed the trace",
        "accessories unpowered",
        "stalled",
        "short of the distance",
        "missed the trace",
    ]
    marked = mark_unearned(table, distance_m=12_000.0, sim=sim)
    assert list(marked.columns) == [*table.columns, NOT_EARNED]
    assert marked.loc[0, ["fc", "hc", "fc_charge_balanced"]].tolist() == [5.0, 5.0, 5.0]
    assert marked.loc[1:, ["fc", "hc", "fc_charge_balanced"]].isna().all(axis=None)
    assert (marked["m_veh"] == 5.0).all() and (table["fc"] == 5.0).all()  # not per km; the input untouched
    assert unearned_warning(marked, cycle="udds", sim=sim) == (
        "simulate: warning: 5 of 6 design(s) did not drive udds (1 stalled (stood still over 10 s), 1 drove less "
        "than 10 % of it, 2 missed the trace by more than 3.2 km/h, 1 left the accessories unpowered); worst: "
        "row 3 (stalled), off the trace 100 % of the time, mean speed error 30.0 km/h: their per-km figures are "
        "left empty (column not_earned)"
    )
    assert unearned_warning(mark_unearned(table.iloc[:1], distance_m=12_000.0, sim=sim), cycle="udds", sim=sim) is None
    one = mark_unearned(table.iloc[[5]].reset_index(drop=True), distance_m=12_000.0, sim=sim)
    assert unearned_warning(one, cycle="us06", sim=sim, vehicle="prius") == (
        "simulate: warning: the prius did not drive us06 (missed the trace by more than 3.2 km/h; off the trace "
        "40 % of the time, mean speed error 9.0 km/h): its per-km figures are left empty (column not_earned)"
    )
