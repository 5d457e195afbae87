"""What every stage command shares: params loading, one-line errors, progress bars."""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Callable, Iterable

import typer

from hevlib.params import Params, ParamsError, load_params

PARAMS_OPTION = typer.Option("params.yaml", "--params", help="params file to validate and use")


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

    return wrapper


def params_from(path: str) -> Params:
    return load_params(path)


def interactive() -> bool:
    """Progress bars only for a person at a terminal, never in CI logs."""
    return sys.stderr.isatty() and not os.environ.get("CI")


def progress(items: Iterable, *, total: int | None = None, description: str = "") -> Iterable:
    if not interactive():
        yield from items
        return
    from rich.progress import track

    yield from track(items, total=total, description=description, transient=True)
