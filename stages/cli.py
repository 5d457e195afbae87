"""The ``hev`` command: one sub-command per pipeline stage.

Every module in ``stages/`` (other than this one and ``common``) registers its command on ``app``
when imported; :func:`_register` imports them all, so adding a stage is adding a module.
"""

from __future__ import annotations

import importlib
import pkgutil

import typer

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="hev-sizing: size a power-split hybrid conversion of a conventional car.",
)

_NOT_STAGES = {"cli", "common"}


def _register() -> None:
    import stages

    for mod in sorted(pkgutil.iter_modules(stages.__path__), key=lambda m: m.name):
        if mod.name not in _NOT_STAGES and not mod.name.startswith("_"):
            importlib.import_module(f"stages.{mod.name}")


_register()

if __name__ == "__main__":
    app()
