"""The metric regression gate: a guarded metric beyond its tolerance fails, within it passes."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from hevlib.regression_check import compare, flatten, load_tolerances
from stages.cli import app

BASE = {"prius": {"ftp": {"fc": 4.10, "cycle_met": True}}, "conventional": {"ftp": {"fc": 7.75}}}
TOL = """
baselines.json:
  "prius.ftp.fc": {rel: 0.002}
  "*.cycle_met": {}
  "conventional.*": {abs: 0.05}
optimise_*.json:
  hypervolume: {rel: 0.5}
"""


def _setup(tmp_path, current: dict, hv_new: float = 0.012):
    base, cur = tmp_path / "base", tmp_path / "cur"
    base.mkdir(parents=True)
    cur.mkdir(parents=True)
    (base / "baselines.json").write_text(json.dumps(BASE))
    (cur / "baselines.json").write_text(json.dumps(current))
    (base / "optimise_nsga3.json").write_text(json.dumps({"hypervolume": 0.010, "runtime_s": 5.0}))
    (cur / "optimise_nsga3.json").write_text(json.dumps({"hypervolume": hv_new, "runtime_s": 9.0}))
    tol = tmp_path / "tol.yaml"
    tol.write_text(TOL)
    return base, cur, tol


def _run(base, cur, tol):
    return CliRunner().invoke(
        app, ["check-metrics", "--baseline", str(base), "--current", str(cur), "--tolerances", str(tol)]
    )


def test_flatten_uses_dotted_keys():
    assert flatten(BASE) == {"prius.ftp.fc": 4.10, "prius.ftp.cycle_met": True, "conventional.ftp.fc": 7.75}


def test_unchanged_and_within_tolerance_pass(tmp_path):
    cur = json.loads(json.dumps(BASE))
    cur["prius"]["ftp"]["fc"] = 4.10 * 1.0015  # 0.15 % < 0.2 %
    cur["conventional"]["ftp"]["fc"] = 7.79  # 0.04 < 0.05
    res = _run(*_setup(tmp_path, cur))
    assert res.exit_code == 0, res.output
    assert "within tolerance" in res.output
    assert "runtime_s" in res.output and "unguarded" in res.output  # changed but not guarded: shown only


@pytest.mark.parametrize(
    "mutate, key",
    [
        (lambda c: c["prius"]["ftp"].__setitem__("fc", 4.10 * 1.003), "prius.ftp.fc"),  # 0.3 % > 0.2 %
        (lambda c: c["conventional"]["ftp"].__setitem__("fc", 7.85), "conventional.ftp.fc"),  # 0.10 > 0.05
        (lambda c: c["prius"]["ftp"].__setitem__("cycle_met", False), "prius.ftp.cycle_met"),  # flag flipped
        (lambda c: c["prius"]["ftp"].pop("fc"), "prius.ftp.fc"),  # metric vanished
    ],
)
def test_a_guarded_metric_beyond_tolerance_fails(tmp_path, mutate, key):
    cur = json.loads(json.dumps(BASE))
    mutate(cur)
    base, cur_dir, tol = _setup(tmp_path, cur)
    res = _run(base, cur_dir, tol)
    assert res.exit_code == 1
    assert "REGRESSION" in res.output
    bad = [r.key for r in compare(base, cur_dir, load_tolerances(tol)) if not r.ok]
    assert bad == [key]


def test_stochastic_metric_has_a_loose_tolerance(tmp_path):
    assert _run(*_setup(tmp_path, BASE, hv_new=0.014)).exit_code == 0  # +40 % < 50 %
    assert _run(*_setup(tmp_path / "b", BASE, hv_new=0.016)).exit_code == 1  # +60 % > 50 %


def test_bad_tolerance_file_names_the_entry(tmp_path):
    base, cur, tol = _setup(tmp_path, BASE)
    tol.write_text("baselines.json:\n  prius.ftp.fc: {rel: -1}\n")
    res = _run(base, cur, tol)
    assert res.exit_code == 1 and "prius.ftp.fc" in res.output
