"""``hev warmup``: compile the simulator's numba kernels into their on-disk cache (run once after install)."""

from __future__ import annotations

import time

import typer

from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, stage


@app.command("warmup")
@stage
def warmup(
    params_path: str = PARAMS_OPTION,
    top: int = typer.Option(12, "--top", min=0, help="how many of the project's functions to list"),
) -> None:
    """Compile and cache the simulator kernels, so the first `dvc repro` runs as fast as the next; print
    what was compiled and how long each function took."""
    from hevlib import numba_cache_dir
    from hevlib.simulate import warm_up

    start = time.perf_counter()
    times = warm_up(params_from(params_path))
    wall = time.perf_counter() - start
    ours = [t for t in times if t.ours]
    typer.echo(
        f"warmup: compile time per function (self = less the functions compiled inside it), cache {numba_cache_dir()}"
    )
    typer.echo(f"  {'function':<52} {'sigs':>4} {'self s':>7} {'total s':>8}")
    for t in ours[:top]:
        typer.echo(f"  {t.function:<52} {t.signatures:>4} {t.self_s:>7.2f} {t.total_s:>8.2f}")
    rest = ours[top:]
    if rest:
        typer.echo(f"  {f'{len(rest)} more hevlib functions':<52} {'':>4} {sum(t.self_s for t in rest):>7.2f}")
    lib = [t for t in times if not t.ours]
    typer.echo(
        f"  {f'numba and numpy internals ({len(lib)} functions)':<52} {'':>4} {sum(t.self_s for t in lib):>7.2f}"
    )
    in_numba = sum(t.self_s for t in times)
    typer.echo(f"warmup: simulator kernels compiled and cached in {wall:.0f} s ({in_numba:.1f} s in numba's compiler)")
