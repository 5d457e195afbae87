"""``hev warmup``: compile the simulator's numba kernels into their on-disk cache (run once after install)."""

from __future__ import annotations

import time

import typer

from hevlib import numba_cache_dir
from hevlib.warmup import compile_table, timed_warm_up
from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, stage


@app.command("warmup")
@stage
def warmup(
    params_path: str = PARAMS_OPTION,
    top: int = typer.Option(12, "--top", min=0, help="how many of the project's functions to list"),
    processes: int = typer.Option(
        0, "--processes", min=0, help="processes compiling side by side, one vehicle kind each (0: one per CPU)"
    ),
) -> None:
    """Compile and cache the simulator kernels, so the first `dvc repro` runs as fast as the next; print
    what was compiled and how long each function took (the hybrid and the conventional kernels compile in
    processes of their own, side by side)."""
    start = time.perf_counter()
    times = timed_warm_up(params_from(params_path), processes=processes or None)
    wall = time.perf_counter() - start
    if not times:
        typer.echo(f"warmup: every kernel loaded from the cache {numba_cache_dir()} in {wall:.1f} s, nothing compiled")
        return
    typer.echo(f"warmup: compile time per function (self: less what it compiled inside), cache {numba_cache_dir()}")
    for line in compile_table(times, top):
        typer.echo(line)
    in_numba = sum(t.self_s for t in times)
    typer.echo(
        f"warmup: simulator kernels compiled and cached in {wall:.0f} s "
        f"({in_numba:.1f} s in numba's compiler, summed over the processes)"
    )
