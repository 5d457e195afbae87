"""A fresh clone reproduces the committed results: the README's default pipeline (`dvc repro`) leaves the
tree clean — every report, `dvc.lock` included, byte-identical to the commit.

This needs a committed tree whose `dvc.lock` matches its code (as CI has); on a working copy with
uncommitted changes it is skipped. The fast profile against `ci/fast_baseline` is CI's metric gate
(`.ci/run`, `hev check-metrics`)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.slow


def _git(*args: str, cwd: Path = REPO) -> str:
    return subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True, check=True).stdout


def test_a_fresh_clone_runs_the_default_pipeline_to_the_committed_bytes(tmp_path):
    if _git("status", "--porcelain", "--untracked-files=no").strip():
        pytest.skip("uncommitted changes: the committed dvc.lock does not describe this tree")
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(REPO), str(clone)], check=True)
    env = {
        **os.environ,
        "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
        "DVC_NO_ANALYTICS": "1",
        "PYTHONPATH": str(clone),
    }
    out = subprocess.run(["dvc", "repro"], cwd=clone, env=env, capture_output=True, text=True, timeout=1800)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    status = _git("status", "--porcelain", cwd=clone)
    assert status == "", status
