"""``hev warmup``: compile the simulator's numba kernels into their on-disk cache (run once after install)."""

from __future__ import annotations

import time

import typer

from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, stage


@app.command("warmup")
@stage
def warmup(params_path: str = PARAMS_OPTION) -> None:
    """Compile and cache the simulator kernels, so the first `dvc repro` runs as fast as the next."""
    from hevlib.simulate import warm_up

    start = time.perf_counter()
    warm_up(params_from(params_path))
    typer.echo(f"warmup: simulator kernels compiled and cached in {time.perf_counter() - start:.0f} s")
