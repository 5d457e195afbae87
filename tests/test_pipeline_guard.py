"""`dvc repro` on bad input stops at the `check` stage with one line naming the file and key, and every
output already built stays byte-identical (DVC removes a stage's outputs only when it runs that stage,
and every stage depends on `check`)."""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.slow


def _run(cmd: list[str], cwd: Path, env: dict) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """A copy of this checkout (tracked and untracked, not ignored, files) in a fresh git repository, with
    the first stages built."""
    root = tmp_path_factory.mktemp("guard") / "repo"
    files = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard", "-z"],
        cwd=REPO,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split("\0")
    for f in filter(None, files):
        src = REPO / f
        if src.is_file():
            (root / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, root / f)
    env = {
        **os.environ,
        "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
        "DVC_NO_ANALYTICS": "1",
        "GIT_AUTHOR_NAME": "t",
        "GIT_AUTHOR_EMAIL": "t@t.invalid",
        "GIT_COMMITTER_NAME": "t",
        "GIT_COMMITTER_EMAIL": "t@t.invalid",
    }
    for cmd in (["git", "init", "-q"], ["git", "add", "-A"], ["git", "commit", "-qm", "copy"]):
        subprocess.run(cmd, cwd=root, env=env, check=True, capture_output=True)
    out = _run(["dvc", "repro", "components", "cycles"], root, env)
    assert out.returncode == 0, out.stdout + out.stderr
    return root, env


def _digest(root: Path) -> dict[str, str]:
    """Every output file's hash (data/, reports/) and dvc.lock."""
    files = [p for d in ("data", "reports") for p in (root / d).rglob("*") if p.is_file()]
    files = [p for p in files if "raw" not in p.relative_to(root).parts] + [root / "dvc.lock"]
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest() for p in files}


def _edit(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


def _n_lhs(new: str):
    return lambda t: _edit(t, "  n_lhs: 300", new)


INT_MSG = "doe.n_lhs: Input should be a valid integer"
PARAMS_CASES = {
    "unknown top-level key": (lambda t: t + "\nsurrogates_typo: {}\n", "params.yaml: surrogates_typo: unknown key"),
    "unknown nested key": (_n_lhs("  n_lhs: 300\n  n_lsh: 20"), "doe.n_lsh: unknown key"),
    # DVC reads params.yaml itself and refuses the duplicate first (its message names file, key and line)
    "duplicate key": (_n_lhs("  n_lhs: 300\n  n_lhs: 20"), "params.yaml|n_lhs|uplicate key"),
    "bool for an int": (_n_lhs("  n_lhs: true"), INT_MSG),
    "float for an int": (_n_lhs("  n_lhs: 300.5"), INT_MSG),
    "string for a float": (
        lambda t: _edit(t, "  step_s: 1.0", "  step_s: one"),
        "cycles.step_s: Input should be a valid number",
    ),
    "out of range": (lambda t: _edit(t, "  soc_init: 0.7", "  soc_init: 1.7"), "sim.soc_init"),
}


def _repro_with(root: Path, env: dict, path: Path, corrupt, message: str) -> None:
    """Corrupt ``path``, run ``dvc repro``, restore it; the run must fail naming ``message`` (``|``-separated
    parts) and leave every output byte-identical."""
    before = _digest(root)
    good = path.read_text()
    path.write_text(corrupt(good))
    try:
        out = _run(["dvc", "repro"], root, env)
    finally:
        path.write_text(good)
    text = out.stdout + out.stderr
    assert out.returncode != 0, text
    assert all(m in text for m in message.split("|")), text
    assert _digest(root) == before


@pytest.mark.parametrize("case", list(PARAMS_CASES))
def test_bad_params_stop_dvc_repro_before_any_output_is_touched(built, case):
    root, env = built
    corrupt, message = PARAMS_CASES[case]
    _repro_with(root, env, root / "params.yaml", corrupt, message)


def test_hev_check_names_a_duplicate_key_in_one_line(built, tmp_path):
    root, env = built
    bad = tmp_path / "params.yaml"
    bad.write_text(_edit((root / "params.yaml").read_text(), "  n_lhs: 300", "  n_lhs: 300\n  n_lhs: 20"))
    out = _run(["hev", "check", "--params", str(bad)], root, env)
    assert out.returncode == 1
    line = [i for i, ln in enumerate(bad.read_text().splitlines(), 1) if ln.startswith("  n_lhs:")][1]
    assert out.stderr.strip() == f"error: {bad}: not valid YAML (duplicate key 'n_lhs' (line {line}))"


RAW_CASES = {
    "truncated cycle": (
        "data/raw/cycles/CYC_US06.csv",
        lambda t: "".join(t.splitlines(True)[:600]),
        "CYC_US06.csv: 599 data rows, but cycles.yaml gives 601 points",
    ),
    "text in a cycle's number": (
        "data/raw/cycles/CYC_HWFET.csv",
        lambda t: "".join(ln if i != 9 else "8.0,abc\n" for i, ln in enumerate(t.splitlines(True))),
        "CYC_HWFET.csv: speed_kmh is missing, NaN or infinite at line 10",
    ),
    "text in a component number": (
        "data/raw/components/FC_PRIUS_JPN.yaml",
        lambda t: _edit(t, "peak_power_kw: 42.7135963730314", "peak_power_kw: forty"),
        "FC_PRIUS_JPN.yaml: peak_power_kw: 'forty' is not a number",
    ),
}


@pytest.mark.parametrize("case", list(RAW_CASES))
def test_bad_raw_files_stop_dvc_repro_before_any_output_is_touched(built, case):
    root, env = built
    rel, corrupt, message = RAW_CASES[case]
    _repro_with(root, env, root / rel, corrupt, message)
