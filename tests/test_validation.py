"""Improvement table (sign convention, SOC points, not-applicable cases), validation table, summary, stage."""

from __future__ import annotations

import json
import shutil
import sys
import traceback
import types
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from test_pareto import synthetic_front
from typer.testing import CliRunner

from hevlib.controller_gap import GAP_COLUMNS, gap_schema, soc_schema
from hevlib.cycles import Cycle
from hevlib.design import CHARGE_BALANCE_RESPONSES, DESIGN_VARS, OBJECTIVES, RESPONSES
from hevlib.io import write_parquet
from hevlib.params import DesignSpaceParams, ScreenParams
from hevlib.pareto import select_designs
from hevlib.report import build_summary
from hevlib.results import Recommendation, ValidationSummary, from_json, to_json
from hevlib.validation import (
    ANSWER_KEYS,
    IMPROVEMENT_RESPONSES,
    best_design,
    improvement,
    improvement_table,
    prius_design,
    summarise,
    validation_schema,
    validation_table,
)

REPO = Path(__file__).resolve().parents[1]

CONVENTIONAL = {
    "m_veh": 1195.0,
    "fc": 8.0,
    "fc_soc_corrected": 8.0,
    "fc_charge_balanced": 8.0,
    "diff_soc": 0.0,
    "hc": 0.4,
    "co": 2.0,
    "nox": 0.3,
    "v_max": 180.0,
    "f_max": 3.0,
    "eta_drivetrain": 0.2,
}
PRIUS = {
    "m_veh": 1404.0,
    "fc": 4.5,
    "fc_soc_corrected": 4.6,
    "fc_charge_balanced": 4.7,
    "diff_soc": 0.02,
    "hc": 0.2,
    "co": 1.0,
    "nox": 0.1,
    "v_max": 170.0,
    "f_max": 2.8,
    "eta_drivetrain": 0.3,
}


class FakeSimulator:
    """Deterministic stand-in for hevlib.sim.simulator.Simulator: responses are simple functions of the design."""

    calls: list = []

    @classmethod
    def from_params(cls, params, components_dir="data/components"):
        return cls()

    def close(self):  # a stage closes the simulators it made (their executor)
        pass

    def _row(self, x, cycle, vehicle):
        k = 1.0 if cycle.name == "ftp" else 0.8
        if vehicle == "conventional":
            base = dict(CONVENTIONAL)
        elif vehicle == "prius":
            base = dict(PRIUS)
        else:
            p_eng, p_mot, p_gen, i0, n_bat, n_r, n_s = x
            base = {
                "m_veh": 900 + 3 * p_eng + n_bat,
                "fc": 2 + p_eng / 20,
                "diff_soc": 0.001 * n_bat,
                "hc": 0.1 + p_eng / 500,
                "co": 0.5 + p_eng / 100,
                "nox": 0.05 + p_gen / 1000,
                "v_max": 120 + p_mot,
                "f_max": 2 + p_mot / 60,
                "eta_drivetrain": 0.25 + i0 / 100,
            }
            base["fc_soc_corrected"] = base["fc"] + 0.5 * base["diff_soc"]
        row = {r: float(base.get(r, 1.0)) for r in RESPONSES}
        row["fc"] *= k
        row["cycle_met"] = vehicle != "hybrid" or bool(x[0] > 40)
        row["stalled"] = False
        row["fc_charge_balanced"] = row["fc_soc_corrected"]
        row["charge_balance_runs"] = 2.0
        row["charge_balance_residual"] = 0.001
        row["charge_balanced"] = True
        row["soc_init_charge_balanced"] = 0.6
        return row

    def run(self, X, cycle, vehicle="hybrid", batch_size=1000, progress=None, charge_balanced=False):
        FakeSimulator.calls.append((vehicle, cycle.name, len(X)))
        X = np.atleast_2d(X)
        rows = [self._row(x, cycle, vehicle) for x in (X if vehicle == "hybrid" else X[:1])]
        cols = list(RESPONSES) + (list(CHARGE_BALANCE_RESPONSES) if charge_balanced else [])
        return pd.DataFrame(rows, columns=cols)

    library = types.SimpleNamespace(
        lib=types.SimpleNamespace(engine_hybrid=types.SimpleNamespace(fuel_density_g_per_l=749.0))
    )

    def trace(self, X, cycle, vehicle, soc_init=None):
        t = cycle.time_s
        return pd.DataFrame(
            {
                "time_s": t,
                "v_ref_mps": cycle.speed_mps,
                "v_mps": cycle.speed_mps * 0.98,
                "soc": np.full(len(t), 0.6 if soc_init is None else soc_init),
                "fuel_g_s": np.full(len(t), 0.3),
                **{f"{gas}_tailpipe_g_s": np.full(len(t), 0.001) for gas in ("hc", "co", "nox")},
            }
        )


def _cycle(name: str, n: int = 60) -> Cycle:
    t = np.arange(n, dtype=float)
    return Cycle(name, t, 10 * np.sin(np.pi * t / (n - 1)) ** 2, np.zeros(n))


# ----------------------------------------------------------------------------------- improvement
def test_improvement_sign_convention_on_a_hand_made_case():
    # lower fc and higher v_max than the base: '+' for both
    assert improvement("fc", [8.0], 10.0)[0] == pytest.approx(20.0)
    assert improvement("v_max", [180.0], 150.0)[0] == pytest.approx(20.0)
    assert improvement("eta_drivetrain", [0.3], 0.25)[0] == pytest.approx(20.0)
    # worse: '-'
    assert improvement("m_veh", [1300.0], 1000.0)[0] == pytest.approx(-30.0)
    assert improvement("f_max", [2.0], 4.0)[0] == pytest.approx(-50.0)
    # a negative base is divided by its magnitude: still '+' = better
    assert improvement("fc", [-2.0], -1.0)[0] == pytest.approx(100.0)


def test_soc_difference_is_in_soc_points_and_not_applicable_without_battery():
    # design ends 3 SOC points less depleted than the Prius: +3 points (not a percentage of 0.05)
    assert improvement("diff_soc", [0.02], 0.05)[0] == pytest.approx(3.0)
    assert improvement("diff_soc", [0.02], -0.01)[0] == pytest.approx(-3.0)
    assert np.isnan(improvement("diff_soc", [0.02], 0.0, base_has_battery=False)[0])
    assert np.isnan(improvement("hc", [0.1], 0.0)[0])  # zero base: no division by zero


def test_improvement_table_groups_by_algorithm_and_counts_shared_designs_for_each():
    designs = pd.DataFrame(
        {
            "algo": ["nsga3", "nsga3+moead", "moga"],
            "fc": [8.0, 6.0, 9.0],
            **{r: [1.0, 1.0, 1.0] for r in IMPROVEMENT_RESPONSES if r != "fc"},
        }
    )
    bases = {"conventional": pd.Series({**CONVENTIONAL, "fc": 10.0}), "prius": pd.Series({**PRIUS, "fc": 5.0})}
    table = improvement_table(designs, bases, ["nsga3", "moead", "moga"])
    assert table["nsga3"]["vs_conventional"]["fc"] == pytest.approx(30.0)  # (20 + 40) / 2
    assert table["moead"]["vs_conventional"]["fc"] == pytest.approx(40.0)
    assert table["all"]["vs_conventional"]["fc"] == pytest.approx((20 + 40 + 10) / 3)
    assert table["moga"]["vs_prius"]["fc"] == pytest.approx(-80.0)
    assert table["all"]["vs_conventional"]["diff_soc"] is None
    assert table["all"]["vs_prius"]["diff_soc"] == pytest.approx(100 * (0.02 - 1.0))
    empty = improvement_table(designs.iloc[:0], bases, ["nsga3"])
    assert empty["nsga3"]["vs_prius"]["fc"] is None


# ---------------------------------------------------------------------------------- validation
def _selected() -> pd.DataFrame:
    X = np.array(
        [[42.0, 31.0, 15.0, 3.93, 25, 78, 30], [30.0, 50.0, 20.0, 3.0, 40, 64, 24], [55.0, 40.0, 10.0, 2.5, 20, 78, 30]]
    )
    df = pd.DataFrame(X, columns=list(DESIGN_VARS))
    df.insert(0, "algo", ["nsga3", "moead+nsga3", "moga"])
    df.insert(0, "design_id", ["nsga3-1", "moead-4", "moga-0"])
    return df


def test_validation_table_has_one_row_per_vehicle_and_cycle(tmp_path):
    prius_x = np.array([43.0, 31.0, 15.0, 3.93, 25, 78, 30])
    table = validation_table(FakeSimulator(), _selected(), [_cycle("ftp"), _cycle("hwfet")], prius_x)
    assert len(table) == 2 * (3 + 2)
    assert list(table.columns) == ["vehicle", "algo", "cycle", *DESIGN_VARS, *RESPONSES, *CHARGE_BALANCE_RESPONSES]
    conv = table[(table["vehicle"] == "conventional")]
    assert conv[list(DESIGN_VARS)].isna().all().all() and (conv["algo"] == "baseline").all()
    prius = table[(table["vehicle"] == "prius") & (table["cycle"] == "ftp")].iloc[0]
    np.testing.assert_allclose(prius[list(DESIGN_VARS)].to_numpy(dtype=float), prius_x)
    write_parquet(tmp_path / "v.parquet", table, validation_schema())  # schema matches exactly
    back = pd.read_parquet(tmp_path / "v.parquet")
    assert back["cycle_met"].dtype == bool and back["fc"].dtype == float
    # moead-4 uses the least fuel but misses the cycle: the best is the thriftiest of those meeting it
    assert best_design(table, "ftp") == "nsga3-1"


def test_summary_reports_the_study_table_and_downsizing():
    table = validation_table(
        FakeSimulator(), _selected(), [_cycle("ftp"), _cycle("hwfet")], np.array([43.0, 31.0, 15.0, 3.93, 25, 78, 30])
    )
    s = summarise(table, ["nsga3", "moead", "moga"], ["ftp", "hwfet"], 70.0)
    assert s.cycle == "ftp" and set(s.improvement) == {"nsga3", "moead", "moga", "all"}
    assert set(s.improvement["all"]["vs_prius"]) == set(IMPROVEMENT_RESPONSES)
    assert s.improvement["all"]["vs_conventional"]["diff_soc"] is None
    fc = 2 + np.array([42.0, 30.0, 55.0]) / 20
    assert s.improvement["all"]["vs_conventional"]["fc"] == pytest.approx(np.mean(100 * (8 - fc) / 8))
    assert s.engine_downsizing_pct["all"] == pytest.approx(100 * (70 - np.mean([42, 30, 55])) / 70)
    assert s.engine_downsizing_pct["nsga3"] == pytest.approx(100 * (70 - 36) / 70)
    assert s.counts.by_algo == {"nsga3": 2, "moead": 1, "moga": 1}
    assert s.counts.cycle_met["ftp"] == {"picked": 2, "conventional": True, "prius": True}
    assert "hwfet" in s.by_cycle and "ftp" not in s.by_cycle
    # one JSON form: plain JSON types, no recommendation key without one, read back to the same summary
    data = json.loads(json.dumps(to_json(s)))
    assert "recommendation" not in data and from_json(ValidationSummary, data) == s
    pareto = select_designs(
        {"nsga3": synthetic_front(40, 1)}, ScreenParams(n_keep=5, n_pick=3, speed_dev_max=1.0, mass_max_kg=2000)
    ).summary
    text = build_summary(pareto, s, table, _selected().assign(rank=[1, 2, 3]), {"Trade-offs": "plots/x.png"})
    assert "| m_veh | % |" in text and "n/a" in text and "![Trade-offs](plots/x.png)" in text
    assert "## Robustness check: hwfet" in text and "moga-0" in text and "conventional" in text


def test_prius_design_follows_params_order(params):
    np.testing.assert_array_equal(prius_design(params.baseline.prius), [43.0, 31.0, 15.0, 3.93, 25, 78, 30])


# --------------------------------------------------------------------------------------- stage
def test_validate_stage_writes_table_metrics_summary_and_plots(tmp_path, monkeypatch):
    from stages.cli import app

    shutil.copy(REPO / "params.yaml", tmp_path / "params.yaml")
    monkeypatch.chdir(tmp_path)
    fake = types.ModuleType("hevlib.sim.simulator")
    fake.Simulator = FakeSimulator
    monkeypatch.setitem(sys.modules, "hevlib.sim.simulator", fake)
    runner = CliRunner()
    assert runner.invoke(app, ["validate"]).exit_code == 1  # nothing there yet: one-line error
    for name in ("ftp", "hwfet", "us06", "udds"):
        _cycle(name).to_parquet(f"data/cycles/{name}.parquet")
    res = select_designs(
        {"nsga3": synthetic_front(40, 1), "moead": synthetic_front(30, 2), "moga": synthetic_front(30, 3)},
        ScreenParams(n_keep=10, n_pick=4, speed_dev_max=1.0, mass_max_kg=2000),
    )
    write_parquet("data/pareto/selected.parquet", res.selected)
    write_parquet("data/pareto/merged.parquet", res.merged)
    Path("reports").mkdir()
    Path("reports/pareto.json").write_text(json.dumps(to_json(res.summary)))
    # what each source searched on, and the BNN worse than a constant on fc: nsga3 and moead are flagged
    Path("reports/surrogate_metrics.json").write_text(json.dumps(_surrogate_metrics({"fc": -3.99}, {})))
    for source in ("nsga3", "moead", "moga"):
        Path(f"reports/optimise_{source}.json").write_text(json.dumps(OPTIMISE_REPORTS[source]))
    FakeSimulator.calls.clear()
    out = runner.invoke(app, ["validate"])  # no controller's gap yet: one line naming the file and the command
    assert out.exit_code == 1 and "data/bound/gap.parquet: no such file; run `hev bound` first" in out.output
    ids = [str(d) for d in res.selected["design_id"]]
    write_parquet("data/bound/gap.parquet", _gap_table(ids[1:]), gap_schema())  # another shortlist's table
    write_parquet("data/bound/soc.parquet", _soc_table(ids), soc_schema())
    out = runner.invoke(app, ["validate"])
    assert out.exit_code == 1 and f"has no row for {ids[0]} (another shortlist?)" in out.output
    assert not FakeSimulator.calls  # both stopped before simulating anything
    gap = _gap_table(ids)
    write_parquet("data/bound/gap.parquet", gap, gap_schema())
    out = runner.invoke(app, ["validate"])
    assert out.exit_code == 0, "".join(traceback.format_exception(*out.exc_info)) if out.exc_info else out.output
    table = pd.read_parquet("reports/validation.parquet")
    assert len(table) == 3 * (len(res.selected) + 2)  # ftp, hwfet, us06
    metrics = json.loads(Path("reports/validation.json").read_text())
    assert metrics["improvement"]["all"]["vs_conventional"]["diff_soc"] is None
    head = json.loads(Path("reports/headline.json").read_text())  # the declared DVC metric: the answer only
    assert head == {
        "fc_saving_charge_balanced_pct": metrics["improvement"]["all"]["vs_conventional"]["fc_charge_balanced"],
        "fc_saving_pct": metrics["improvement"]["all"]["vs_conventional"]["fc"],
        "fc_saving_vs_prius_pct": metrics["improvement"]["all"]["vs_prius"]["fc"],
        "mass_saving_pct": metrics["improvement"]["all"]["vs_conventional"]["m_veh"],
        "p_eng_kw": metrics["mean_p_eng_kw"]["all"],
        "n_picks": len(res.selected),
        "recommended_design": metrics["recommendation"]["design"]["design_id"],
        "recommended_fc_saving_charge_balanced_pct": metrics["recommendation"]["design"]["by_cycle"]["ftp"][
            "vs_conventional"
        ]["fc_charge_balanced"],
    }
    short = json.loads(Path("reports/answer.json").read_text())  # the declared DVC metric: short keys
    assert short == {ANSWER_KEYS[k]: v for k, v in head.items() if k in ANSWER_KEYS}
    assert set(head) - set(ANSWER_KEYS) == {"recommended_design"}  # the one string stays in the headline
    rec = metrics["recommendation"]
    assert rec["design"]["fails"] == [] and rec["design"]["design_id"] in set(res.selected["design_id"])
    assert set(rec["design"]["by_cycle"]) == {"ftp", "hwfet", "us06"}
    assert [b["bag"] for b in rec["design"]["ftp_bags"]["prius"]] == [1, 2, 3]
    # the model's noise from the eligible picks' twins, and the near-equivalents with what separates them
    twins = pd.read_parquet("reports/validation_twins.parquet")
    assert len(twins) == rec["eligible"] * rec["noise"]["twins"] and set(twins["vehicle"]) <= set(
        res.selected["design_id"]
    )
    assert set(rec["noise"]["knee_share"]) == set(twins["vehicle"])
    assert sum(rec["noise"]["knee_share"].values()) == pytest.approx(1.0)
    for e in rec["equivalents"]:
        assert e["knee_share"] >= rec["noise"]["min_share"] and e["design_id"] != rec["design"]["design_id"]
    assert Path("reports/explorer.html").stat().st_size > 1_000_000  # Plotly inlined
    summary = Path("reports/summary.md").read_text()
    assert summary.startswith(
        f"# hev-sizing: selection and validation summary\n\n## Build this\n\n**{rec['design']['design_id']}**"
    )
    assert "**Within the model's noise.**" in summary and "### Across seeds" in summary
    assert summary.index("### Across seeds") < summary.index("### ftp (headline cycle)")
    assert "No robustness study on disk" in summary
    assert metrics["seed_spread"] is None and metrics["seed_spread_status"].startswith("not measured")
    # the trust of each source, and of the recommended design's
    assert metrics["trust"]["flagged"] == ["nsga3", "moead"] and "flagged sources" in out.output
    assert summary.index("## Trust of each source") < summary.index("## How to read the rest")
    algo = rec["design"]["algo"]
    flagged = all(a in ("nsga3", "moead") for a in algo.split("+"))
    assert ("**Trust: flagged.** From " if flagged else "Trust: From ") in summary
    for png in ("improvement_ftp.png", "improvement_hwfet.png", "traces_ftp.png"):
        assert Path(f"reports/plots/validation/{png}").stat().st_size > 0
        assert f"plots/validation/{png}" in summary
    assert set(OBJECTIVES) - {"accel_dev", "e_l", "speed_dev"} <= {r for r in IMPROVEMENT_RESPONSES}
    # the controller's gap in the answer: every pick and both cars under each controller, the saving under each
    cg = metrics["controller_gap"]
    assert cg["recommended"] == rec["design"]["design_id"] and list(cg["by_cycle"]) == ["ftp", "hwfet"]
    g = gap.set_index(["vehicle", "cycle"])
    for cycle, c in cg["by_cycle"].items():
        assert list(c["vehicles"]) == [*ids, "prius", "conventional"]
        r, conv = g.loc[(cg["recommended"], cycle)], g.loc[("conventional", cycle)]
        assert c["saving_pct"]["rule"] == pytest.approx(100 * (1 - r["rule_fc_hot"] / conv["rule_fc_hot"]))
        assert c["saving_pct"]["ecms_drive"] == pytest.approx(100 * (1 - r["ecms_drive_fc_hot"] / conv["rule_fc_hot"]))
        assert c["saving_pct"]["bound"] == pytest.approx(100 * (1 - r["bound_fc"] / conv["rule_fc_hot"]))
        assert c["saving_pct"]["bound_both"] == pytest.approx(100 * (1 - r["bound_fc"] / conv["bound_fc"]))
        assert c["saving_pct"]["rule"] < c["saving_pct"]["ecms_drive"] < c["saving_pct"]["bound"]
        for v, e in c["vehicles"].items():
            row = g.loc[(v, cycle)]
            assert e["fc_l_100km"]["rule"] == pytest.approx(row["rule_fc_hot"])
            assert e["over_bound_pct"]["rule"] == pytest.approx(100 * (row["rule_fc_hot"] / row["bound_fc"] - 1))
        assert c["vehicles"]["conventional"]["fc_l_100km"]["ecms_drive"] is None  # no battery: no ECMS
    assert "### How much the controller leaves on the table" in summary
    assert f"| ftp | {cg['recommended']} (recommended) |" in summary
    assert f"ftp: rule {cg['by_cycle']['ftp']['saving_pct']['rule']:.1f} %" in summary
    assert Path("reports/plots/validation/soc_controllers_ftp.png").stat().st_size > 0
    assert "plots/validation/soc_controllers_ftp.png" in summary
    # the seed-spread replicates validate without it
    assert runner.invoke(app, ["validate", "--no-gap"]).exit_code == 0
    assert "controller_gap" not in json.loads(Path("reports/validation.json").read_text())
    assert "How much the controller leaves" not in Path("reports/summary.md").read_text()


def _gap_table(picks: list[str]) -> pd.DataFrame:
    """A hand-made ``hev bound`` table: on FTP and HWFET each pick's rule base 5 % above ECMS in the drive step, 8 %
    above ECMS on the bound's model and 12 % above its bound; the Prius a little dearer; the conventional car 8.0 /
    6.0 L/100 km under its shift logic, 2 % above its best gears."""
    rows = []
    for cycle, scale in (("ftp", 1.0), ("hwfet", 0.8)):
        for i, v in enumerate([*picks, "prius", "conventional"]):
            rule = scale * (8.0 if v == "conventional" else 4.0 + 0.1 * i)
            hybrid = v != "conventional"
            rows.append(
                dict.fromkeys(GAP_COLUMNS, np.nan)
                | {
                    "vehicle": v,
                    "cycle": cycle,
                    "rule_fc_charge_balanced": rule * 1.03,
                    "rule_fc_hot": rule,
                    "bound_fc": rule / (1.12 if hybrid else 1.02),
                    "ecms_fc": rule / 1.08 if hybrid else np.nan,
                    "ecms_drive_fc_hot": rule / 1.05 if hybrid else np.nan,
                    "note": "",
                }
            )
    return pd.DataFrame(rows, columns=list(GAP_COLUMNS))


def _soc_table(picks: list[str]) -> pd.DataFrame:
    t = np.arange(0.0, 50.0)
    frames = [
        pd.DataFrame({"vehicle": v, "time_s": t, "soc_rule": 0.6, "soc_ecms_drive": 0.61, "soc_bound": 0.59})
        for v in [*picks, "prius"]
    ]
    return pd.concat(frames, ignore_index=True)


def test_summary_says_so_when_nothing_passed_screening():
    prius_x = np.array([43.0, 31.0, 15.0, 3.93, 25, 78, 30])
    table = validation_table(FakeSimulator(), _selected().iloc[:0], [_cycle("ftp")], prius_x)
    s = summarise(table, ["nsga3"], ["ftp"], 70.0)
    assert s.improvement["nsga3"]["vs_prius"]["fc"] is None and s.best_design is None
    res = select_designs({"nsga3": synthetic_front(20, 1)}, ScreenParams(speed_dev_max=1e-6))
    assert res.summary.counts.picked == 0
    text = build_summary(res.summary, s, table, res.selected.to_pandas(), {})
    assert "No design passed the screening" in text and "`speed_dev_max`" in text


def _surrogate_metrics(bnn: dict[str, float], regression: dict[str, float]) -> dict:
    """``reports/surrogate_metrics.json`` in small: held-out R² 0.9 on every objective but those given."""

    def split(worse: dict[str, float]) -> dict:
        return {o: {"r2": worse.get(o, 0.9), "rmse": 1.0, "mae": 1.0, "spearman": 0.8} for o in OBJECTIVES}

    return {
        "bnn": {"heldout": split(bnn), "heldout_followers": split({})},
        "regression": {"heldout": split(regression), "heldout_followers": split({"fc": -2709.0})},
        "n_designs": {"train": 19, "test": 8, "heldout": 200, "heldout_followers": 47},
    }


#: What each source searched on, as its ``reports/optimise_<source>.json`` says.
OPTIMISE_REPORTS = {
    "nsga3": {"surrogate": "bnn"},
    "moead": {"surrogate": "bnn"},
    "moga": {"surrogate": "regression"},
    "parego": {"surrogate": "gp", "objectives_modelled": list(OBJECTIVES)},
    "oracle": {"surrogate": None, "algorithm": "nsga3"},
}


def test_a_surrogate_worse_than_a_constant_flags_the_sources_that_optimise_on_it():
    """Held-out R² below 0 on an objective the source optimises: the source is flagged in validation.json and
    summary.md (the R² table's cell in bold, a line for the source, its picks marked in the shortlist); the
    oracle searched the simulator, BoTorch's Gaussian processes are not measured (said so, not flagged)."""
    from hevlib.validation import found_by, source_trust

    table = validation_table(
        FakeSimulator(), _selected(), [_cycle("ftp")], np.array([43.0, 31.0, 15.0, 3.93, 25, 78, 30])
    )
    metrics = _surrogate_metrics({"fc": -3.99, "speed_dev": -60.0}, {})
    sources = ["nsga3", "moead", "moga", "parego", "nehvi", "oracle"]  # nehvi: no report on disk
    trust = source_trust(metrics, {**OPTIMISE_REPORTS, "nehvi": None}, sources)
    s = summarise(table, ["nsga3", "moead", "moga"], ["ftp"], 70.0, trust=trust)
    data = json.loads(json.dumps(to_json(s)))
    assert from_json(ValidationSummary, data) == s
    t = data["trust"]
    assert t["flagged"] == ["nsga3", "moead"] and t["r2"]["bnn"]["fc"] == -3.99
    assert t["r2_followers"]["regression"]["fc"] == -2709.0  # shown, but the rule reads every held-out design
    nsga3 = t["sources"]["nsga3"]
    assert nsga3["flagged"] and nsga3["model"] == "bnn" and nsga3["worse_than_constant"] == ["fc", "speed_dev"]
    assert nsga3["searched_on"] == "NSGA-III on the BNN" and nsga3["heldout_r2"]["speed_dev"] == -60.0
    assert not t["sources"]["moga"]["flagged"] and t["sources"]["moga"]["heldout_r2"]["fc"] == 0.9
    parego = t["sources"]["parego"]
    assert parego["model"] == "gp" and parego["heldout_r2"] is None and not parego["flagged"]
    assert "not measured" in parego["note"]
    assert t["sources"]["oracle"]["model"] == "simulator" and not t["sources"]["oracle"]["flagged"]
    assert t["sources"]["nehvi"]["model"] == "unknown" and "not known" in t["sources"]["nehvi"]["note"]
    from stages.surrogates import _worse_than_constant  # the surrogates stage says so too, in one line

    assert _worse_than_constant(metrics) == {"bnn": ["fc", "speed_dev"]}
    # a design found by several sources is flagged only if every one of them is
    assert found_by("moead+nsga3", trust) == ("MOEA/D on the BNN and NSGA-III on the BNN", True)
    assert found_by("moead+oracle", trust)[1] is False and found_by("moga", trust)[1] is False

    pareto = select_designs(
        {"nsga3": synthetic_front(40, 1)}, ScreenParams(n_keep=5, n_pick=3, speed_dev_max=1.0, mass_max_kg=2000)
    ).summary
    text = build_summary(pareto, s, table, _selected().assign(rank=[1, 2, 3]), {})
    section = text[text.index("## Trust of each source") : text.index("## How to read the rest")]
    assert "| the BNN, all 200 held-out designs | 0.9 | **-3.99** |" in section
    assert "**-60**" in section and "**-2709**" in section
    assert "- **nsga3** (NSGA-III on the BNN): **flagged**: worse than a constant" in section
    assert "fc -3.99, speed_dev -60." in section
    assert "- **moga** (the weighted-sum GA on the regressions): held-out R² at least 0" in section
    assert "- **parego** (BoTorch's qLogNParEGO on its own Gaussian processes): held-out quality not measured" in (
        section
    )
    assert "**Flagged: nsga3, moead.**" in section
    assert "| nsga3-1 | nsga3 **(flagged)** |" in text and "| moead-4 | moead+nsga3 **(flagged)** |" in text
    assert "| moga-0 | moga |" in text
    # on sound surrogates nothing is flagged
    sound = source_trust(_surrogate_metrics({}, {}), OPTIMISE_REPORTS, ["nsga3", "moga", "oracle"])
    assert sound.flagged == [] and not any(t.flagged for t in sound.sources.values())
    text = build_summary(pareto, summarise(table, ["nsga3"], ["ftp"], 70.0, trust=sound), table, _selected(), {})
    assert "No source is flagged" in text and "**(flagged)** |" not in text


#: ``reports/robustness/summary.json`` in small (``hev robustness report``), made for another car.
ROBUSTNESS = {
    "fingerprint": "a31b0827035d91aa",
    "replicates": 2,
    "seeds_per_source": 2,
    "family_share_of_range": 0.05,
    "default_answer_share": 0.5,
    "default_family_share": 0.5,
    "recommended_by_source": {"moead": 1, "oracle": 1},
    "runs": [
        {"replicate": 0, "recommended": "moead-2", "answer": {"rec_fc_cb_pct": 34.2828740812}},
        {"replicate": 1, "recommended": "oracle-169", "answer": {"rec_fc_cb_pct": 32.2701797634}},
    ],
    "recommended": [
        {
            "replicate": r,
            "design_id": d,
            "algo": d.split("-")[0],
            "default_answer": r == 0,
            "default_answer_as": "itself" if r == 0 else None,
            "design": {"p_eng_kw": 44.9436672875},
        }
        for r, d in ((0, "moead-2"), (1, "oracle-169"))
    ],
    "spread": {
        "rec_fc_cb_pct": {
            "n": 2,
            "replicate_0": 34.2828740812,
            "mean": 33.2765269223,
            "std": 1.42,
            "min": 32.2701797634,
            "max": 34.2828740812,
        }
    },
    "variable_range": {"p_eng_kw": {"min": 44.8182783193, "max": 49.3286294435, "share_of_range": 0.1}},
}


def test_a_seed_spread_made_with_other_settings_shows_no_figures_only_how_to_make_it():
    """summary.md shows the seed-spread study's figures only where it was made with this run's settings and
    code; otherwise one line says how to make it, and validation.json keeps ``seed_spread: null`` with the
    status."""
    from hevlib.report import _seed_spread_lines

    table = validation_table(
        FakeSimulator(), _selected(), [_cycle("ftp")], np.array([43.0, 31.0, 15.0, 3.93, 25, 78, 30])
    )
    stale = {**ROBUSTNESS, "current": False}
    s = summarise(table, ["nsga3", "moead", "moga"], ["ftp"], 70.0, robustness=stale)
    lines = [x for x in _seed_spread_lines(s, stale) if x]
    assert lines[0] == "### Across seeds (the seed spread of this answer)" and len(lines) == 2
    assert "made with other settings or code" in lines[1] and "`dvc repro benchmarks/robustness/dvc.yaml`" in lines[1]
    for figure in ("34.28", "32.27", "oracle-169", "moead-2", "44.9", "|"):
        assert figure not in lines[1]
    data = json.loads(json.dumps(to_json(s)))
    assert data["seed_spread"] is None and "other settings or code" in data["seed_spread_status"]
    assert "dvc repro benchmarks/robustness/dvc.yaml" in data["seed_spread_status"]
    assert from_json(ValidationSummary, data) == s
    # none on disk: null too, and one line
    s = summarise(table, ["nsga3"], ["ftp"], 70.0)
    assert to_json(s)["seed_spread"] is None and to_json(s)["seed_spread_status"].startswith("not measured")
    assert len([x for x in _seed_spread_lines(s, None) if x]) == 2
    # made with these settings and code: the figures, in summary.md and validation.json
    current = {**ROBUSTNESS, "current": True}
    s = summarise(table, ["nsga3"], ["ftp"], 70.0, robustness=current)
    text = "\n".join(_seed_spread_lines(s, current))
    assert "made with these settings and code" in text and "| 34.28 |" in text and "oracle-169" in text
    data = json.loads(json.dumps(to_json(s)))
    assert data["seed_spread_status"] == "made with these settings and code"
    assert data["seed_spread"]["spread"]["rec_fc_cb_pct"]["mean"] == pytest.approx(33.2765269223)
    assert data["seed_spread"]["fingerprint"] == ROBUSTNESS["fingerprint"] and "runs" not in data["seed_spread"]


def test_twins_stay_near_their_design_and_near_ties_become_equivalents():
    """Twins move only the continuous variables, within the share of their ranges; a pick whose knee criteria
    tie the recommended one's within that noise is listed as its equivalent, one far away is not."""
    from hevlib.params import EquivalenceParams, ScreenParams, ValidateParams
    from hevlib.validation import eligible_ids, recommendation, simulate_twins

    space = DesignSpaceParams()
    sel = pd.DataFrame(
        [[50.0, 40.0, 15.0, 3.0, 30, 70, 30], [50.2, 40.0, 15.0, 3.0, 30, 70, 30], [41.0, 60.0, 15.0, 3.0, 60, 70, 30]],
        columns=list(DESIGN_VARS),
    )
    sel.insert(0, "algo", ["oracle", "nsga3", "moga"])
    sel.insert(0, "design_id", ["a", "b", "c"])
    sel["rank"] = [1, 2, 3]
    for o in OBJECTIVES:  # the sizing-cycle figures the reasons read (screen margins)
        sel[f"sim_{o}"] = {"m_veh": 1100.0, "v_max": 150.0}.get(o, 0.1)
    cycles = [_cycle("ftp")]
    table = validation_table(FakeSimulator(), sel, cycles, np.array([43.0, 31.0, 15.0, 3.93, 25, 78, 30]))
    table.loc[table["vehicle"] != "conventional", "t_0_100_s"] = 10.0 + table["p_mot_kw"].fillna(0) / 100
    eq = EquivalenceParams(twins=6, share=0.01, draws=500, min_share=0.05, seed=3)
    ids = eligible_ids(table, ["ftp"], ScreenParams())
    assert ids == ["a", "b", "c"]
    twins = simulate_twins(FakeSimulator(), sel, ids, cycles[0], space.space(), eq)
    assert len(twins) == 18 and twins["twin"].tolist()[:6] == [1, 2, 3, 4, 5, 6]
    moved = twins[list(DESIGN_VARS)].to_numpy() - np.repeat(sel[list(DESIGN_VARS)].to_numpy(), 6, axis=0)
    span = space.space().upper - space.space().lower
    assert np.all(np.abs(moved) <= 0.01 * span + 1e-12) and np.all(moved[:, 4:] == 0)  # integers kept
    assert np.mean(np.abs(moved[:, :4]) > 0) > 0.9  # moved (but where the box clips them)
    twins["t_0_100_s"] = 10.0 + twins["p_mot_kw"] / 100
    rec = recommendation(table, sel, ["ftp"], ScreenParams(), space, twins, eq)
    chosen = rec.design.design_id
    assert chosen in {"a", "b"}  # a and b are one design to the model: 0.2 kW apart, far inside its noise
    other = {"a": "b", "b": "a"}[chosen]
    assert [e.design_id for e in rec.equivalents] == [other]
    e = rec.equivalents[0]
    assert e.same_family and e.separated_by == [] and abs(e.vs_recommended["m_veh"]["pct"]) < 0.1
    assert rec.noise.knee_share[chosen] + e.knee_share + rec.noise.knee_share["c"] == pytest.approx(1)
    assert rec.noise.sigma["m_veh"] > 0 and ValidateParams().equivalence.twins == 8
    # the typed recommendation round-trips through its JSON form
    assert from_json(Recommendation, json.loads(json.dumps(to_json(rec)))) == rec
