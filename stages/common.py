"""What every stage command shares: params loading, one-line errors, progress bars, the files one stage writes
and another reads. The simulator and the cycles are :mod:`stages.simulating`'s, imported only by the stages
that simulate (so that only their code deps hold ``hevlib/sim``)."""

from __future__ import annotations

import functools
import os
import sys
import warnings
from collections.abc import Callable, Iterator, Sequence
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


def warning_lines(caught: Sequence[warnings.WarningMessage]) -> list[str]:
    """One line per warning category, in the order each first appeared: the category, how many times it was
    caught (as Python would have shown them: a warning repeated from one place under the default filter, once)
    and the first line of its first message (BoTorch's ``InputDataWarning`` spans several lines)."""
    first: dict[type, tuple[int, str]] = {}
    for w in caught:
        n, text = first.get(w.category, (0, None))
        if text is None:
            lines = str(w.message).strip().splitlines()
            text = lines[0].strip() if lines else ""
        first[w.category] = (n + 1, text)
    return [
        f"warning: {cat.__module__.split('.')[0]}.{cat.__name__} x{n}: {text}"
        if cat.__module__ != "builtins"
        else f"warning: {cat.__name__} x{n}: {text}"
        for cat, (n, text) in first.items()
    ]


@contextmanager
def summarised_warnings(echo: Callable[[str], None] | None = None) -> Iterator[list[warnings.WarningMessage]]:
    """Catch the warnings raised inside (library ones: BoTorch, scikit-learn, torch...) and, on leaving, echo
    :func:`warning_lines` (to stderr by default) instead of each multi-line warning. The filters in force stay as
    they are: an ignored warning stays ignored, one turned into an error still raises. Warnings raised in other
    processes (a Dask worker's) are theirs to print."""
    echo = echo or functools.partial(typer.echo, err=True)
    with warnings.catch_warnings(record=True) as caught:
        try:
            yield caught
        finally:  # also when the stage fails: what it warned of may be why
            for line in warning_lines(caught):
                echo(line)


def stage(fn: Callable) -> Callable:
    """Wrap a stage command: any known input error becomes one line on stderr and exit code 1; the warnings it
    raised become one line each (:func:`summarised_warnings`)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            with summarised_warnings():
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
