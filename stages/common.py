"""What every stage command shares: params loading, one-line errors, progress bars."""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import typer

from hevlib.params import Params, ParamsError, load_params

CYCLES_DIR = Path("data/cycles")
COMPONENTS_DIR = Path("data/components")
PARAMS_OPTION = typer.Option("params.yaml", "--params", help="params file to validate and use")
_OPEN: list = []  # simulators a running stage created: their executors (a Dask cluster) close with it


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


def cycle_named(name: str):
    """The processed cycle ``data/cycles/<name>.parquet`` (grade and key-off periods attached)."""
    from hevlib.cycles import Cycle

    return Cycle.from_parquet(CYCLES_DIR / f"{name}.parquet", name)


def simulator(params):
    """The simulator on the components stage's normalised maps."""
    from hevlib.sim.simulator import Simulator  # numba kernels: only loaded to simulate

    sim = Simulator.from_params(params, components_dir=str(COMPONENTS_DIR))
    _OPEN.append(sim)  # closed when the stage ends (stage)
    return sim


def sizing_setup(params):
    """The simulator and the sizing cycle (``cycles.sizing``, grade attached)."""
    return simulator(params), cycle_named(params.cycles.sizing)
