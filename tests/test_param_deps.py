"""Each stage depends on the params keys it reads, not on whole groups: a simulating stage lists exactly the
keys a sizing-cycle simulation reads (hevlib.params.sizing_simulation_keys, which the simulation fingerprint
hashes), and changing a key in a clone makes `dvc status` list only the stages that read it."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest
import yaml

from hevlib.params import EXECUTION_KEYS, SimParams, load_params, sizing_simulation_keys

REPO = Path(__file__).resolve().parents[1]
BIN = Path(os.environ.get("VIRTUAL_ENV", REPO / ".venv")) / "bin"
PIPELINE = yaml.safe_load((REPO / "dvc.yaml").read_text())["stages"]
SIMULATING = ("doe", "heldout", "judge", "oracle", "optimise", "bayes")


def _params_of(stage: str, sizing: str) -> list[str]:
    spec = PIPELINE[stage].get("do", PIPELINE[stage])
    return [str(p).replace("${cycles.sizing}", sizing).replace("${key}", "nsga3") for p in spec.get("params", [])]


def test_the_simulating_stages_list_exactly_what_a_sizing_simulation_reads():
    params = load_params(REPO / "params.yaml")
    needed = set(sizing_simulation_keys(params))
    for stage in SIMULATING:
        listed = _params_of(stage, params.cycles.sizing)
        assert needed <= set(listed), f"{stage}: misses {sorted(needed - set(listed))}"
        extra = {p for p in listed if p.split(".")[0] in ("sim", "pms", "baseline") and p not in needed}
        assert not extra, f"{stage}: depends on {sorted(extra)}, which no sizing-cycle simulation reads"
        assert "cycles.cycles" not in listed


def test_the_validating_stages_list_every_simulation_key_but_where_batches_run():
    every = {f"sim.{k}" for k in SimParams.model_fields if k not in EXECUTION_KEYS}
    for stage in ("baselines", "validate", "bound"):
        sims = {p for p in _params_of(stage, "udds") if p.startswith("sim")}
        assert sims == every, stage
        assert "pms" in _params_of(stage, "udds") and "baseline" in _params_of(stage, "udds")


def _git(*args: str, cwd: Path = REPO) -> str:
    return subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True, check=True).stdout


#: key -> (new value, the stages that must rerun; `check` validates the whole file and is left out)
CHANGES = {
    "sim.start.hwfet": ("cold", {"baselines", "validate", "bound"}),
    "sim.charge_balance_tolerance": (0.02, {"baselines", "validate", "bound"}),
    "sim.workers": (1, set()),
    "sim.soc_min": (
        0.44,
        {"baselines", "doe", "heldout", "judge", "oracle", "optimise", "bayes", "validate", "bound"},
    ),
    "baseline.prius.n_r": (80, {"baselines", "validate", "bound"}),
    "baseline.conventional.gear_ratios": (
        [13.2, 7.35, 4.91, 3.49, 2.6],
        {"components", "baselines", "validate", "bound"},
    ),
    "baseline.conventional.body.drag_coefficient": (0.3, {"components", "baselines", "validate", "bound"}),
    "bound.soc_step": (0.001, {"bound"}),
    "screen.seed": (7, {"pareto"}),
    "screen.min_v_max_kmh": (120.0, {"judge", "oracle", "optimise", "bayes", "pareto", "validate"}),
    "validate.cycles": (["ftp", "hwfet"], {"validate"}),
    "optimise.infill.rounds": (3, {"optimise"}),
    "optimise.bayes.nehvi.batch": (3, {"bayes"}),
}


def _set(tree: dict, dotted: str, value) -> None:
    *parents, leaf = dotted.split(".")
    for p in parents:
        tree = tree[p]
    assert leaf in tree, dotted
    tree[leaf] = value


@pytest.mark.slow
def test_changing_a_key_reruns_only_the_stages_that_read_it(tmp_path):
    if _git("status", "--porcelain", "--untracked-files=no", "--", "dvc.yaml", "dvc.lock", "params.yaml").strip():
        pytest.skip("uncommitted pipeline changes: the committed dvc.lock does not describe this tree")
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(REPO), str(clone)], check=True)
    tree = yaml.safe_load((clone / "params.yaml").read_text())
    for key, (value, _) in CHANGES.items():
        _set(tree, key, value)
    (clone / "params.yaml").write_text(yaml.safe_dump(tree, sort_keys=False))
    env = {**os.environ, "DVC_NO_ANALYTICS": "1"}
    out = subprocess.run(
        [str(BIN / "dvc"), "status", "--json", "dvc.yaml"], cwd=clone, env=env, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    listed: dict[str, set[str]] = {key: set() for key in CHANGES}
    for stage, changes in json.loads(out.stdout).items():
        for change in changes if isinstance(changes, list) else []:
            names = (change.get("changed deps", {}) if isinstance(change, dict) else {}).get("params.yaml", {})
            for key in CHANGES:
                if any(key == n or key.startswith(n + ".") for n in names):
                    listed[key].add(stage.split("@")[0].split(":")[-1])
    assert listed == {key: stages for key, (_, stages) in CHANGES.items()}
