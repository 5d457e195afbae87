"""``hev check``: validate params.yaml and every raw input before any stage runs (the pipeline's first stage).

DVC removes a stage's outputs just before it runs that stage; every stage depends on this one's stamp,
so a bad params key (unknown, duplicate, wrong type, out of range) or a malformed raw file stops
``dvc repro`` here, with one line naming the file and key (or column and row), and every earlier output
stays as it was. The stamp's content never changes, so a passing check reruns nothing downstream.
"""

from __future__ import annotations

from pathlib import Path

from hevlib.cycles import build_cycles
from hevlib.doe import doe_designs
from hevlib.io import write_text
from hevlib.sizing import study_library
from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, stage

STAMP = Path("data/checked.txt")
STAMP_TEXT = "params.yaml and the raw inputs passed hev check\n"


@app.command("check")
@stage
def check(params: str = PARAMS_OPTION) -> None:
    """Validate params.yaml, the raw cycles (against cycles.yaml), the component files and the DOE inputs."""
    cfg = params_from(params)
    cycles = build_cycles(cfg.cycles)
    study_library(cfg.baseline)
    doe_designs(cfg.doe.method, cfg.doe.n_lhs, cfg.doe.seed, cfg.design_space.space(), cfg.doe.l27_file)
    write_text(STAMP, STAMP_TEXT)
    print(f"check: {params} and the raw inputs are valid ({len(cycles)} cycles) -> {STAMP}")
