"""Shared fixtures: the repository root, the default params, the study's component library."""

from __future__ import annotations

from pathlib import Path

import pytest

from hevlib.components import ComponentLibrary
from hevlib.params import Params, load_params
from hevlib.sizing import study_library
from stages.cli import register_all

register_all()  # `hev <command>` imports only its own module; CliRunner tests invoke any command on `app`

ROOT = Path(__file__).resolve().parents[1]
RAW = ROOT / "data" / "raw"


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
    return study_library(params.baseline, RAW / "paper")


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
