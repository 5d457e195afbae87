"""What every stage command shares: params loading, one-line errors, progress bars, the files one stage writes
and another reads. The simulator and the cycles are :mod:`stages.simulating`'s, imported only by the stages
that simulate (so that only their code deps hold ``hevlib/sim``)."""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import typer

from hevlib.params import Params, ParamsError, load_params

PARAMS_OPTION = typer.Option("params.yaml", "--params", help="params file to validate and use")
#: The judged scale's reference set (``hev judge``): it normalises every hypervolume the optimise, pareto and
#: benchmark stages report.
REFERENCE = Path("data/judge/reference.parquet")
#: Where ``hev benchmark-run`` writes each run and ``hev benchmark-report`` reads them.
BENCHMARK_RUNS_DIR = Path("data/benchmark/runs")
_OPEN: list = []  # what a running stage opened (a simulator's executor: a Dask cluster): closed with it


def stage(fn: Callable) -> Callable:
    """Wrap a stage command: any known input error becomes one line on stderr and exit code 1."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except (ParamsError, ValueError, OSError, KeyError) as err:
            msg = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
            typer.echo(f"error: {msg}", err=True)
            raise typer.Exit(code=1) from None
        finally:
            while _OPEN:
                _OPEN.pop().close()

    return wrapper


def close_with_stage(resource):
    """``resource`` (anything with ``close()``), closed when the running stage ends (:func:`stage`)."""
    _OPEN.append(resource)
    return resource


def params_from(path: str) -> Params:
    return load_params(path)


def interactive() -> bool:
    """Progress bars only for a person at a terminal, never in CI logs."""
    return sys.stderr.isatty() and not os.environ.get("CI")


@contextmanager
def progress_callback(description: str) -> Iterator[Callable[[int, int], None] | None]:
    """A ``progress(n_done, n_total[, what])`` callback drawing a bar for a person at a terminal, else None;
    ``what`` replaces the bar's label (e.g. ``moead: round 2/4, 120/200 gen``)."""
    if not interactive():
        yield None
        return
    from rich.progress import Progress

    with Progress(transient=True) as bar:
        task = bar.add_task(description, total=None)

        def update(done: int, total: int, what: str | None = None) -> None:
            bar.update(task, completed=done, total=total, **({"description": what} if what else {}))

        yield update
