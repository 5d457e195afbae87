"""End to end: the two foundation stages as commands and through ``dvc repro`` in a copy of the repository."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pyarrow.parquet as pq
import pytest
import yaml
from conftest import copy_repo
from typer.testing import CliRunner

from hevlib.components import ComponentLibrary
from hevlib.cycles import CYCLE_SCHEMA, Cycle
from stages.cli import app

BIN = Path(sys.executable).parent
OUTPUTS = [
    "data/cycles",
    "data/components",
    "reports/cycles.json",
    "reports/components.json",
    "reports/plots/cycles.png",
    "reports/plots/maps_engine.png",
    "reports/plots/maps_emissions.png",
    "reports/plots/maps_motor.png",
    "reports/plots/maps_generator.png",
]


def _snapshot(base: Path) -> dict[str, bytes]:
    files = {}
    for out in OUTPUTS:
        p = base / out
        for f in sorted(p.rglob("*")) if p.is_dir() else [p]:
            files[str(f.relative_to(base))] = f.read_bytes()
    return files


def test_stages_build_their_outputs_and_rebuild_the_same_bytes(root, tmp_path, monkeypatch):
    shutil.copytree(root / "data" / "raw", tmp_path / "data" / "raw")
    shutil.copy(root / "params.yaml", tmp_path / "params.yaml")
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    for stage in ("cycles", "components"):
        result = runner.invoke(app, [stage])
        assert result.exit_code == 0, result.output
    first = _snapshot(tmp_path)
    names = yaml.safe_load((root / "params.yaml").read_text())["cycles"]["cycles"]
    built = sorted(p.name for p in (tmp_path / "data/cycles").iterdir())
    assert built == sorted(f"{n}.parquet" for n in names)
    assert pq.read_schema(tmp_path / "data/cycles/udds.parquet").remove_metadata().equals(CYCLE_SCHEMA)
    report = json.loads((tmp_path / "reports/cycles.json").read_text())
    assert set(report["udds"]) == {"duration_s", "distance_km", "v_mean_kmh", "v_max_kmh", "grade"}
    assert (report["udds"]["duration_s"], report["udds"]["grade"]) == (1369.0, 0.2)
    assert Cycle.from_parquet(tmp_path / "data/cycles/ftp.parquet").distance_m == pytest.approx(17769.437664)
    lib = ComponentLibrary.load(tmp_path / "data/components")
    assert lib.body_conventional.glider_mass_kg == pytest.approx(707.37, abs=0.01)
    for stage in ("cycles", "components"):
        assert runner.invoke(app, [stage]).exit_code == 0
    assert _snapshot(tmp_path) == first  # deterministic, byte for byte


@pytest.mark.slow
def test_dvc_repro_builds_both_stages_in_a_copy_of_the_repo(root, tmp_path):
    repo = tmp_path / "repo"
    copy_repo(root, repo)
    env = {
        **os.environ,
        "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}",
        "PYTHONPATH": str(repo),
        "DVC_NO_ANALYTICS": "1",
    }

    def run(*cmd: str) -> subprocess.CompletedProcess:
        return subprocess.run(cmd, cwd=repo, env=env, capture_output=True, text=True, timeout=600)

    assert run("git", "init", "-q").returncode == 0
    if not (repo / ".dvc").is_dir():
        assert run(str(BIN / "dvc"), "init", "-q").returncode == 0
    for out in OUTPUTS:  # start from nothing built
        if (repo / out).is_dir():
            shutil.rmtree(repo / out)
        else:
            (repo / out).unlink(missing_ok=True)
    result = run(str(BIN / "dvc"), "repro", "cycles", "components")
    assert result.returncode == 0, result.stdout + result.stderr
    for out in OUTPUTS:
        assert (repo / out).exists(), out
    lock = yaml.safe_load((repo / "dvc.lock").read_text())
    assert {"cycles", "components"} <= set(lock["stages"])
    again = run(str(BIN / "dvc"), "repro", "cycles", "components")
    assert again.returncode == 0 and "didn't change, skipping" in again.stdout, again.stdout + again.stderr
    metrics = json.loads((repo / "reports/components.json").read_text())
    assert metrics["conversion"]["chassis_kg"] == pytest.approx(843.366, abs=1e-3)
