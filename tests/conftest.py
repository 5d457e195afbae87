"""Shared fixtures: the repository root, the default params, the study's component library."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from hevlib import determinism
from hevlib.components import ComponentLibrary
from hevlib.params import Params, load_params
from hevlib.sizing import study_library
from stages.cli import register_all

register_all()  # `hev <command>` imports only its own module; CliRunner tests invoke any command on `app`

ROOT = Path(__file__).resolve().parents[1]
RAW = ROOT / "data" / "raw"


#: Two CPU kinds, as the libraries would see them. ``host``: this machine as it is (here an AVX-512 CPU:
#: numpy's X86_V4 kernels, OpenBLAS SkylakeX, torch AVX512, glibc's FMA libm, numba for the host, every core).
#: ``avx2_nofma``: a CPU without AVX-512 (numpy's AVX2 kernels, OpenBLAS Haswell, torch and MKL AVX2, numba
#: code for haswell) whose libm takes glibc's non-FMA variants, one numba thread, four BLAS / OpenMP threads.
CPU_KINDS: dict[str, dict[str, str]] = {
    "host": {},
    "avx2_nofma": {
        "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",
        "OPENBLAS_CORETYPE": "Haswell",
        "OPENBLAS_NUM_THREADS": "4",
        "OMP_NUM_THREADS": "4",
        "MKL_NUM_THREADS": "4",
        "ATEN_CPU_CAPABILITY": "avx2",
        "MKL_ENABLE_INSTRUCTIONS": "AVX2",
        "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-FMA,-FMA4",
        "NUMBA_CPU_NAME": "haswell",
        "NUMBA_NUM_THREADS": "1",
    },
}


def unpinned_environ() -> dict[str, str]:
    """This process's environment without anything a CPU kind sets or the pins set (tests import hevlib, which
    pins in process; pytest re-executes itself pinned): the base of a subprocess that sets its own."""
    drop = {n for kind in CPU_KINDS.values() for n in kind} | set(determinism.PINNED) | {"HEV_PINNED_EXEC"}
    return {k: v for k, v in os.environ.items() if k not in drop}


def copy_repo(root: Path, dest: Path) -> None:
    """The files git tracks or would track (new, not ignored): what a clone plus this change holds."""
    listed = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard", "-z"],
        cwd=root,
        capture_output=True,
        check=True,
    ).stdout.decode()
    for rel in filter(None, listed.split("\0")):
        src = root / rel
        if src.is_file():
            (dest / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / rel)


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


@pytest.fixture(scope="session")
def params() -> Params:
    """The repository's params.yaml, with data paths made absolute (tests may run from any folder)."""
    p = load_params(ROOT / "params.yaml")
    return p.model_copy(
        update={
            "cycles": p.cycles.model_copy(update={"raw_dir": str(ROOT / p.cycles.raw_dir)}),
            "baseline": p.baseline.model_copy(update={"components_dir": str(ROOT / p.baseline.components_dir)}),
        }
    )


@pytest.fixture(scope="session")
def lib(params: Params) -> ComponentLibrary:
    """The library the ``components`` stage builds (ADVISOR data, Table 1 bodies, derived glider)."""
    return study_library(params.baseline)


@pytest.fixture(scope="session")
def sim(lib: ComponentLibrary, params: Params):
    """The simulator on the study's library and the repository's params."""
    from hevlib.sim.simulator import Simulator

    return Simulator(lib, params)


@pytest.fixture(scope="session")
def cycles(params: Params) -> dict:
    """Every cycle of params.yaml, resampled and graded as the ``cycles`` stage builds them."""
    from hevlib.cycles import build_cycles

    return build_cycles(params.cycles)


@pytest.fixture(scope="session")
def raw() -> Path:
    """``data/raw`` of this checkout (git-tracked inputs)."""
    return RAW


@pytest.fixture()
def stage_dir(tmp_path, monkeypatch, lib, params, root):
    """A working folder holding what `hev simulate` reads: data/cycles and data/components."""
    from hevlib.cycles import build_cycles, write_cycles

    monkeypatch.chdir(tmp_path)
    write_cycles(build_cycles(params.cycles), tmp_path / "data/cycles", tmp_path / "reports/cycles.json")
    lib.save(tmp_path / "data/components")
    (tmp_path / "params.yaml").write_text((root / "params.yaml").read_text())
    return tmp_path


@pytest.fixture()
def project(tmp_path, monkeypatch, root) -> Path:
    """A working folder holding only this checkout's params.yaml (for commands that write a profile)."""
    shutil.copy(root / "params.yaml", tmp_path / "params.yaml")
    monkeypatch.chdir(tmp_path)
    return tmp_path
