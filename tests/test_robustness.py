"""The seed-spread study (hevlib/robustness.py, ``hev robustness``): replicate seeds, replicate params, the
summary's counting of designs and families on hand-made replicates, and the command's one-line errors. The study
itself runs end to end, under two CPU kinds, in ``tests/test_cpu_kinds.py``."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from hevlib.design import DESIGN_VARS
from hevlib.params import DesignSpaceParams, parse_params
from hevlib.results import (
    Counts,
    Equivalent,
    HighwayRule,
    Noise,
    Pick,
    Recommendation,
    ValidationSummary,
    to_json,
)
from hevlib.robustness import collect, replicate_params, replicate_seed, replicate_seeds, summarise

REPO = Path(__file__).resolve().parents[1]
SPACE = DesignSpaceParams().space()


def _raw() -> dict:
    return yaml.safe_load((REPO / "params.yaml").read_text())


def test_replicate_0_keeps_the_params_seeds_and_the_others_are_new_fixed_and_distinct():
    raw = _raw()
    own = replicate_seeds(raw, 0)
    assert own == {
        "nsga3": raw["optimise"]["algorithms"]["nsga3"]["seed"],
        "moead": raw["optimise"]["algorithms"]["moead"]["seed"],
        "moga": raw["optimise"]["algorithms"]["moga"]["seed"],
        "parego": raw["optimise"]["bayes"]["parego"]["seed"],
        "nehvi": raw["optimise"]["bayes"]["nehvi"]["seed"],
        "oracle": raw["optimise"]["oracle"]["seed"],
    }
    seeds = [replicate_seeds(raw, k) for k in range(1, 6)]
    values = [v for s in seeds for v in s.values()]
    assert len(set(values)) == len(values) and not set(values) & set(own.values())
    assert replicate_seeds(raw, 3) == seeds[2]  # the same every time
    assert replicate_seed(raw["robustness"]["seed"], "oracle", 3) == seeds[2]["oracle"]
    p = replicate_params(raw, 2)
    assert p["optimise"]["oracle"]["seed"] == seeds[1]["oracle"] and raw["optimise"]["oracle"]["seed"] == 11
    assert p["optimise"]["bayes"]["nehvi"]["seed"] == seeds[1]["nehvi"]
    assert {k: v for k, v in p.items() if k != "optimise"} == {k: v for k, v in raw.items() if k != "optimise"}
    parse_params(p)  # still valid params


def _result(k: int, x, algo="oracle", fc=43.0, equivalents=()) -> dict:
    design = dict(zip(DESIGN_VARS, map(float, x), strict=True))
    return {
        "replicate": k,
        "fingerprint": "f",
        "seeds": {"oracle": k},
        "recommended": {
            "design_id": f"{algo}-{k}",
            "algo": algo,
            "design": design,
            "criteria": {"fc_charge_balanced": 4.5, "m_veh": 1140.0, "t_0_100_s": 11.5},
            "knee_share": 0.8,
        },
        "equivalents": [
            {"design_id": f"e{j}", "algo": "oracle", "design": dict(zip(DESIGN_VARS, map(float, e), strict=True))}
            for j, e in enumerate(equivalents)
        ],
        "answer": {"rec_fc_cb_pct": fc, "fc_cb_pct": fc - 1, "fc_pct": 50.0, "fc_vs_prius_pct": 20.0},
        "archive_hypervolume": {"oracle": 2.4},
    }


def test_the_summary_counts_designs_families_and_the_default_answer():
    span = SPACE.upper - SPACE.lower
    a = np.array([48.0, 33.0, 23.0, 3.9, 20, 53, 31])
    near_a = a + 0.02 * span  # the same family (every variable within 5 % of its range)
    b = np.array([30.0, 50.0, 10.0, 2.5, 50, 80, 25])  # another car
    eq = a.copy()
    eq[0] += 0.2 * span[0]  # the default's near-equivalent: a 9 kW bigger engine
    near_eq = eq + 0.01 * span
    results = [
        _result(0, a, fc=43.5, equivalents=[eq]),
        _result(1, a, fc=43.5),  # the very same design
        _result(2, near_a, algo="nsga3", fc=44.0),
        _result(3, b, fc=40.0),
        _result(4, near_eq, fc=45.0),
    ]
    s = summarise(results[::-1], SPACE.lower, SPACE.upper)  # any order
    assert s["replicates"] == s["seeds_per_source"] == 5
    by = {d["replicate"]: d for d in s["recommended"]}
    assert by[0]["same_design_replicates"] == [0, 1] and by[0]["family_replicates"] == [0, 1, 2]
    assert by[0]["family_share"] == pytest.approx(0.6) and s["default_family_share"] == pytest.approx(0.6)
    assert [by[k]["default_answer_as"] for k in range(5)] == [
        "recommended",
        "recommended",
        "recommended",
        None,
        "equivalent e0",
    ]
    assert s["default_answer_share"] == pytest.approx(0.8)
    assert s["modal_family"] == {"replicate": 0, "design_id": "oracle-0", "share": pytest.approx(0.6)}
    assert s["recommended_by_source"] == {"nsga3": 1, "oracle": 4}
    sp = s["spread"]["rec_fc_cb_pct"]
    vals = [43.5, 43.5, 44.0, 40.0, 45.0]
    assert sp["replicate_0"] == 43.5 and sp["n"] == 5 and sp["min"] == 40.0 and sp["max"] == 45.0
    assert sp["mean"] == pytest.approx(np.mean(vals)) and sp["std"] == pytest.approx(np.std(vals, ddof=1))
    assert s["spread"]["mass_pct"] == {"n": 0}
    assert s["archive_hypervolume_spread"]["oracle"]["mean"] == pytest.approx(2.4)
    r = s["variable_range"]["p_eng_kw"]
    assert (r["min"], r["max"]) == (30.0, near_eq[0]) and r["share_of_range"] == pytest.approx((near_eq[0] - 30) / 45)
    json.dumps(s)
    with pytest.raises(ValueError, match="replicate 0"):
        summarise(results[1:], SPACE.lower, SPACE.upper)


def test_a_replicate_is_read_from_its_reports(tmp_path):
    """``collect`` reads what the chain's own stages wrote: the recommended design with its knee criteria and
    share, its near-equivalents, the answer and every source's archive hypervolume (not its front's)."""
    x = dict(zip(DESIGN_VARS, [48.0, 33.0, 23.0, 3.9, 20.0, 53.0, 31.0], strict=True))
    crit = {"fc_charge_balanced": 4.4, "m_veh": 1150.0, "t_0_100_s": 11.2}
    pick = Pick("oracle-7", "oracle", 1, x, [], {}, [], [], {"udds": {"design": crit}})
    twin = Equivalent("nsga3-2", "nsga3", 0.1, x, crit, {}, [], True)
    noise = Noise("twins", 8, 0.02, 2000, 0.1, 1, {}, {}, {"oracle-7": 0.9, "nsga3-2": 0.1})
    rec = Recommendation("udds", "knee", [], {}, 2, "eligible", HighwayRule(False, 0.0, []), pick, {}, noise, [twin])
    counts = Counts(2, {"oracle": 1, "nsga3": 1}, {}, {}, {})
    summary = ValidationSummary("udds", {}, {}, counts, {}, {}, 70.0, {}, {}, "oracle-7", rec)
    (tmp_path / "reports").mkdir()
    (tmp_path / "reports/validation.json").write_text(json.dumps(to_json(summary)))
    (tmp_path / "reports/answer.json").write_text(json.dumps({"rec_fc_cb_pct": 44.0, "p_eng_kw": 48.0}))
    pareto = {
        "sources": {"oracle": {"hypervolume": 2.47, "front_hypervolume": 1.7}, "moga": {"hypervolume": 0.04}},
        "by_algo": {"oracle": {"kept": 3}},
    }
    (tmp_path / "reports/pareto.json").write_text(json.dumps(pareto))
    r = collect(tmp_path, 2, {"oracle": 5}, "fp")
    assert r["recommended"]["design_id"] == "oracle-7" and r["recommended"]["criteria"] == crit
    assert r["recommended"]["knee_share"] == 0.9 and r["equivalents"][0]["design_id"] == "nsga3-2"
    assert r["answer"]["rec_fc_cb_pct"] == 44.0 and r["answer"]["mass_pct"] is None
    assert r["archive_hypervolume"] == {"oracle": 2.47, "moga": 0.04}
    assert (r["replicate"], r["fingerprint"], r["seeds"]) == (2, "fp", {"oracle": 5})


def test_the_command_says_what_is_wrong_in_one_line(tmp_path, monkeypatch):
    from stages.cli import app

    shutil.copy(REPO / "params.yaml", tmp_path / "params.yaml")
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    out = runner.invoke(app, ["robustness", "walk"])
    assert out.exit_code == 1 and "unknown action 'walk'" in out.output
    out = runner.invoke(app, ["robustness", "report"])
    assert out.exit_code == 1 and "rep_0/result.json: no such replicate" in out.output
    out = runner.invoke(app, ["robustness", "run"])
    assert out.exit_code == 1 and "data/cycles: no such input; run `dvc repro` first" in out.output
    Path("data/robustness/runs/rep_0").mkdir(parents=True)
    Path("data/robustness/runs/rep_0/result.json").write_text(json.dumps({"fingerprint": "old"}))
    out = runner.invoke(app, ["robustness", "report"])
    assert out.exit_code == 1 and "made with other settings or code" in out.output


def test_a_replicate_is_current_until_the_code_that_computes_it_changes(tmp_path):
    """Editing a plot, the summary's wording or this study's own summary keeps every replicate; editing the
    code that computes a recommendation runs them again."""
    from conftest import copy_repo

    from hevlib.robustness import chain_code_hash

    copy_repo(REPO, tmp_path)
    before = chain_code_hash(tmp_path)
    for rel in ("hevlib/report.py", "hevlib/plots/validation.py", "hevlib/robustness.py"):
        (tmp_path / rel).write_text((tmp_path / rel).read_text() + "\n# edited\n")
    assert chain_code_hash(tmp_path) == before
    (tmp_path / "hevlib/recommend.py").write_text((tmp_path / "hevlib/recommend.py").read_text() + "\n# edited\n")
    assert chain_code_hash(tmp_path) != before
