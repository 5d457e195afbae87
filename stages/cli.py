"""The ``hev`` command: one sub-command per pipeline stage."""

from __future__ import annotations

import typer

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="hev-sizing: size a power-split hybrid conversion of a conventional car.")


def _register() -> None:
    from stages import cycles, components  # noqa: F401  (each module adds its command to ``app``)


_register()

if __name__ == "__main__":
    app()
