"""Stage code deps follow the imports: `dvc.yaml` lists, per stage, the modules its command imports (generated
by `hev deps --write`); a stage that imports a module its deps omit fails the check; and an edit to a plot
module reruns only the stages that draw that plot (DVC's own `dvc status` in a fresh clone)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from hevlib.codedeps import (
    check_deps,
    compact,
    declared_deps,
    generated_deps,
    import_closure,
    stage_commands,
    write_deps,
)
from stages.cli import command_modules

REPO = Path(__file__).resolve().parents[1]
DVC_YAML = (REPO / "dvc.yaml").read_text()
COMMANDS = command_modules(REPO)  # the CLI's index, handed to the library (which never imports stages)
BIN = Path(sys.executable).parent


@pytest.mark.parametrize("pipeline", ["dvc.yaml", "benchmarks/fleet/dvc.yaml", "benchmarks/robustness/dvc.yaml"])
def test_every_stage_declares_exactly_the_code_it_imports(pipeline):
    problems = check_deps(REPO, (REPO / pipeline).read_text(), COMMANDS)
    assert not problems, "\n".join(map(str, problems))


def test_the_fleet_simulates_outside_the_default_pipeline():
    """The fleet validation's stages import the simulator; no stage of the default pipeline imports the fleet."""
    fleet = generated_deps(REPO, (REPO / "benchmarks/fleet/dvc.yaml").read_text(), COMMANDS)
    assert "hevlib/sim" in fleet["simulate"] and "hevlib/fleet.py" in fleet["report"]
    assert not [s for s, d in generated_deps(REPO, DVC_YAML, COMMANDS).items() if "hevlib/fleet.py" in d]


def test_every_stage_runs_a_registered_command_module():
    commands = stage_commands(DVC_YAML, COMMANDS)
    assert commands["heldout"] == "stages.heldout" and commands["oracle"] == commands["optimise"] == "stages.optimise"
    assert set(COMMANDS.values()) >= set(commands.values())


def test_the_simulating_stages_do_not_depend_on_plots_reports_or_surrogates():
    deps = generated_deps(REPO, DVC_YAML, COMMANDS)
    for stage in ("doe", "heldout"):
        assert not [d for d in deps[stage] if d.startswith(("hevlib/plots", "hevlib/report", "hevlib/surrogates"))]
        assert "hevlib/sim" in deps[stage]  # the simulator wing, whole
    assert "hevlib/plots/validation.py" in deps["validate"]
    assert not [s for s, d in deps.items() if "hevlib/plots/validation.py" in d and s != "validate"]


def test_only_the_stages_that_simulate_depend_on_the_simulator():
    deps = generated_deps(REPO, DVC_YAML, COMMANDS)
    simulating = {s for s, d in deps.items() if "hevlib/sim" in d or "hevlib/sim/simulator.py" in d}
    calls_it = {
        "baselines",
        "doe",
        "heldout",
        "judge",
        "surrogates",
        "oracle",
        "optimise",
        "bayes",
        "validate",
        "bound",
    }
    assert simulating == calls_it  # surrogates: the held-out set, simulated again when params changed
    for stage in ("cycles", "pareto"):
        assert not [d for d in deps[stage] if d.startswith(("hevlib/sim", "stages/simulating.py"))], stage
    report = generated_deps(REPO, (REPO / "benchmarks/surrogate/dvc.yaml").read_text(), COMMANDS)["report"]
    assert not [d for d in report if d.startswith(("hevlib/sim", "stages/simulating.py"))]


def _package(root: Path, files: dict[str, str]) -> None:
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def test_the_closure_follows_lazy_relative_and_parent_package_imports(tmp_path):
    _package(
        tmp_path,
        {
            "stages/__init__.py": "",
            "stages/run.py": "import numpy\nfrom hevlib import a\n",
            "hevlib/__init__.py": "",
            "hevlib/a.py": "def f():\n    from hevlib.sub.b import g  # lazy\n    return g()\n",
            "hevlib/sub/__init__.py": "from . import c\n",
            "hevlib/sub/b.py": "from .c import h\ndef g():\n    return h\n",
            "hevlib/sub/c.py": "h = 1\n",
            "hevlib/unused.py": "import hevlib.a\n",
        },
    )
    closure = import_closure(tmp_path, "stages.run")
    assert set(closure) == {"stages", "stages.run", "hevlib", "hevlib.a", "hevlib.sub", "hevlib.sub.b", "hevlib.sub.c"}
    deps = compact(tmp_path, set(closure.values()))  # the whole of hevlib/sub is reached: one folder dep
    assert deps == ["hevlib/__init__.py", "hevlib/a.py", "hevlib/sub", "stages/__init__.py", "stages/run.py"]


def test_a_stage_whose_deps_omit_an_imported_module_fails_the_check():
    line = "      - hevlib/plots/validation.py\n"
    assert line in DVC_YAML
    problems = check_deps(REPO, DVC_YAML.replace(line, ""), COMMANDS)
    assert [p.stage for p in problems] == ["validate"]
    assert problems[0].missing == ("hevlib/plots/validation.py",) and "hev deps --write" in str(problems[0])
    # the old blanket deps are no longer what the stages import either
    blanket = write_deps(DVC_YAML, {s: ["hevlib", "stages"] for s in declared_deps(DVC_YAML)})
    assert {p.stage for p in check_deps(REPO, blanket, COMMANDS)} == set(declared_deps(DVC_YAML))


def test_write_deps_replaces_only_the_code_deps_and_is_idempotent():
    blanket = write_deps(DVC_YAML, {s: ["hevlib", "stages"] for s in declared_deps(DVC_YAML)})
    assert "      - hevlib\n      - stages\n" in blanket
    regenerated = write_deps(blanket, generated_deps(REPO, blanket, COMMANDS))
    assert regenerated == DVC_YAML
    assert write_deps(regenerated, generated_deps(REPO, regenerated, COMMANDS)) == regenerated


def test_hev_deps_check_exits_1_naming_the_stage(tmp_path):
    bad = tmp_path / "dvc.yaml"
    bad.write_text(DVC_YAML.replace("      - hevlib/plots/validation.py\n", ""))
    for name in ("hevlib", "stages"):
        (tmp_path / name).symlink_to(REPO / name)
    out = subprocess.run([str(BIN / "hev"), "deps", "--check", "--dvc-yaml", str(bad)], capture_output=True, text=True)
    assert out.returncode == 1
    assert "stage 'validate' imports hevlib/plots/validation.py but its deps omit them" in out.stderr
    ok = subprocess.run([str(BIN / "hev"), "deps", "--check"], cwd=REPO, capture_output=True, text=True)
    assert ok.returncode == 0, ok.stderr


def _git(*args: str, cwd: Path = REPO) -> str:
    return subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True, check=True).stdout


def _stages_rerun_by(clone: Path, env: dict, edited: str) -> set[str]:
    """Stages of the default pipeline (./dvc.yaml; the benchmark's own pipeline in benchmarks/surrogate/
    is not run by `dvc repro`) whose deps `dvc status` reports changed at ``edited`` (the file or a folder
    holding it)."""
    out = subprocess.run(
        [str(BIN / "dvc"), "status", "--json"], cwd=clone, env=env, capture_output=True, text=True, check=True
    )
    stages = set()
    for stage, changes in json.loads(out.stdout).items():
        if ":" in stage and not stage.startswith("dvc.yaml:"):
            continue
        for change in changes if isinstance(changes, list) else []:
            deps = change.get("changed deps", {}) if isinstance(change, dict) else {}
            if any(edited == d or edited.startswith(d.rstrip("/") + "/") for d in deps):
                stages.add(stage.split("@")[0].split(":")[-1])
    return stages


@pytest.mark.slow
def test_a_docstring_edit_in_a_plot_module_reruns_only_the_stages_that_draw_plots(tmp_path):
    if _git("status", "--porcelain", "--untracked-files=no", "--", "dvc.yaml", "dvc.lock", "hevlib", "stages").strip():
        pytest.skip("uncommitted code or pipeline changes: the committed dvc.lock does not describe this tree")
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(REPO), str(clone)], check=True)
    env = {**os.environ, "DVC_NO_ANALYTICS": "1"}
    plotting = {
        "cycles",
        "components",
        "baselines",
        "surrogates",
        "oracle",
        "optimise",
        "bayes",
        "pareto",
        "validate",
        "bound",
    }
    assert _stages_rerun_by(clone, env, "hevlib/plots/__init__.py") == set()  # the committed lock is current

    def edit_docstring(rel: str) -> None:
        path = clone / rel
        text = path.read_text()
        path.write_text(text.replace('"""', '"""Edited. ', 1))

    edit_docstring("hevlib/plots/validation.py")
    assert _stages_rerun_by(clone, env, "hevlib/plots/validation.py") == {"validate"}
    edit_docstring("hevlib/plots/__init__.py")
    assert _stages_rerun_by(clone, env, "hevlib/plots/__init__.py") == plotting
