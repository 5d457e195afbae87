"""A fresh clone reproduces the committed results: the README's default pipeline (`dvc repro`) leaves the
tree clean — every report, `dvc.lock` included, byte-identical to the commit; `dvc metrics show` fits a
terminal; and the README's way back from an experiment restores the commit's reports and pictures.

This needs a committed tree whose `dvc.lock` matches its code (as CI has); on a working copy with
uncommitted changes it is skipped. The fast profile against `ci/fast_baseline` is CI's metric gate
(`.ci/run`, `hev check-metrics`)."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
pytestmark = [pytest.mark.slow, pytest.mark.repro, pytest.mark.timeout(4800)]


def _git(*args: str, cwd: Path = REPO) -> str:
    return subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True, check=True).stdout


IDENTITY = {"NAME": "hev-sizing test", "EMAIL": "test@hev-sizing.invalid"}


def _fresh_clone(tmp_path: Path) -> tuple[Path, dict]:
    """A clone of the committed tree and the environment its commands run in (this venv's tools, the clone's
    code, a git identity for `dvc exp run`); skips on uncommitted changes, which a clone would not hold."""
    if _git("status", "--porcelain", "--untracked-files=no").strip():
        pytest.skip("uncommitted changes: the committed dvc.lock does not describe this tree")
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(REPO), str(clone)], check=True)
    env = {
        **os.environ,
        "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
        "DVC_NO_ANALYTICS": "1",
        "PYTHONPATH": str(clone),
        **{f"GIT_{who}_{what}": val for who in ("AUTHOR", "COMMITTER") for what, val in IDENTITY.items()},
    }
    return clone, env


def test_a_fresh_clone_runs_the_default_pipeline_to_the_committed_bytes(tmp_path):
    clone, env = _fresh_clone(tmp_path)
    # about 25 min on CI's 2 cores alone; CI runs it beside the test suite (.ci/run), which slows it by a quarter
    out = subprocess.run(["dvc", "repro"], cwd=clone, env=env, capture_output=True, text=True, timeout=3000)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    status = _git("status", "--porcelain", cwd=clone)
    assert status == "", status
    _assert_dvc_status_is_quiet(clone, env)
    shown = subprocess.run(["dvc", "metrics", "show"], cwd=clone, env=env, capture_output=True, text=True)
    lines = shown.stdout.splitlines()
    assert shown.returncode == 0 and len(lines) == 2, shown.stdout + shown.stderr  # header + answer.json
    assert max(map(len, lines)) <= 120, shown.stdout  # fits a terminal
    # `hev exp-show`: dvc exp show without the ~95 file columns; the answer's figures readable at 120 columns
    exp = subprocess.run(["hev", "exp-show"], cwd=clone, env={**env, "COLUMNS": "120"}, capture_output=True, text=True)
    assert exp.returncode == 0, exp.stderr
    header = next(line for line in exp.stdout.splitlines() if "Experiment" in line)
    assert max(map(len, exp.stdout.splitlines())) <= 120 and "fc_cb_pct" in header and "rec_fc_cb_pct" in header

    # the README's way back from an experiment: git restores params, dvc.lock and reports; DVC the pictures
    plots = _digests(clone / "reports/plots")
    exp = subprocess.run(
        ["dvc", "exp", "run", "-S", "screen.n_pick=3"], cwd=clone, env=env, capture_output=True, text=True
    )
    assert exp.returncode == 0, exp.stdout[-3000:] + exp.stderr[-3000:]
    assert _git("status", "--porcelain", cwd=clone) != "" and _digests(clone / "reports/plots") != plots
    subprocess.run(["git", "checkout", "--", "."], cwd=clone, check=True)
    subprocess.run(["dvc", "checkout"], cwd=clone, env=env, check=True, capture_output=True)
    assert _git("status", "--porcelain", cwd=clone) == ""
    assert _digests(clone / "reports/plots") == plots


#: The pipelines `dvc status` may still list after the README's build of a fresh clone, each with its reason
#: (issue 53). Every other pipeline must be up to date; an entry whose pipeline is no longer listed fails the test,
#: so the list stays true.
KNOWN_STALE = {
    "benchmarks/surrogate/dvc.yaml": "its lock predates the code (the runs were made before the pins of 7db92b8); "
    "rerunning it takes about 2 h, and its run folders (data/benchmark/runs, git-ignored, not cached) are in no clone",
}


def _assert_dvc_status_is_quiet(clone: Path, env: dict) -> None:
    """`dvc status` after the README's build: every pipeline up to date but those of KNOWN_STALE, and the plain
    `dvc status` of the others a line."""
    out = subprocess.run(["dvc", "status", "--json"], cwd=clone, env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    listed = {stage.rpartition(":")[0] or "dvc.yaml" for stage in json.loads(out.stdout or "{}")}
    assert listed == set(KNOWN_STALE), f"dvc status lists {sorted(listed)}; known stale: " + "; ".join(
        f"{k}: {why}" for k, why in KNOWN_STALE.items()
    )
    quiet = sorted(str(p.relative_to(clone)) for p in clone.glob("**/dvc.yaml") if ".venv" not in p.parts)
    quiet = [p for p in quiet if p not in KNOWN_STALE]
    assert {"dvc.yaml", "benchmarks/fleet/dvc.yaml", "benchmarks/robustness/dvc.yaml"} - set(KNOWN_STALE) <= set(quiet)
    shown = subprocess.run(["dvc", "status", *quiet], cwd=clone, env=env, capture_output=True, text=True)
    lines = [line for line in shown.stdout.splitlines() if line.strip()]
    assert shown.returncode == 0 and lines == ["Data and pipelines are up to date."], shown.stdout + shown.stderr


def _digests(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.rglob("*.png"))
    }


def test_the_fast_pipeline_sizes_the_sedan_on_wltc_from_a_fresh_clone(tmp_path):
    """Another car and cycle from params alone (issue 40, docs/your-car.md):
    `dvc exp run $(hev profile fast) $(hev profile sedan)` in a fresh clone runs every stage on the sedan and
    the WLTC, and the answer is written."""
    clone, env = _fresh_clone(tmp_path)
    args = []
    for name in ("fast", "sedan"):
        out = subprocess.run(["hev", "profile", name], cwd=clone, env=env, capture_output=True, text=True, check=True)
        args += out.stdout.split()
    run = subprocess.run(["dvc", "exp", "run", *args], cwd=clone, env=env, capture_output=True, text=True, timeout=2400)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    baselines = json.loads((clone / "reports" / "baselines.json").read_text())
    assert "wltc" in baselines["conventional"] and "wltc" in baselines["prius"]
    answer = json.loads((clone / "reports" / "answer.json").read_text())
    assert answer, "no answer"
