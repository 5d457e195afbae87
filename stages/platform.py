"""``hev platform``: what this machine's numeric libraries run, and whether every pin of
:mod:`hevlib.determinism` is in effect (one code path per library, so every x86-64 CPU gives the same bytes)."""

from __future__ import annotations

import typer

from stages.cli import app


@app.command("platform")
def platform() -> None:
    """Print the code paths and thread counts in effect (numpy, OpenBLAS, torch, glibc's libm, the hash seed);
    exit 1 when a pin is not in effect."""
    from hevlib import determinism

    determinism.torch()  # loaded, so that its capability and threads are shown
    for name, value in determinism.status().items():
        typer.echo(f"{name:>16}: {value}")
    problems = determinism.check()
    for p in problems:
        typer.echo(f"error: {p}", err=True)
    if problems:
        raise typer.Exit(code=1)
    typer.echo(
        "platform: "
        + (
            "pins off (HEV_NATIVE_CPU): results depend on the CPU"
            if determinism.disabled()
            else "every pin in effect: the same bytes on every x86-64 CPU"
        )
    )
