"""``hev profile NAME``: print a params profile as ``dvc exp run`` overrides (``dvc exp run $(hev profile fast)``)."""

from __future__ import annotations

import typer

from hevlib.profiles import load_profile, set_args
from stages.cli import app
from stages.common import PARAMS_OPTION, stage


@app.command("profile")
@stage
def profile(
    name: str = typer.Argument(..., help="profile name: profiles/<name>.yaml"), params: str = PARAMS_OPTION
) -> None:
    """Check profiles/NAME.yaml against the params schema and print its -S overrides for dvc exp run."""
    typer.echo(" ".join(set_args(load_profile(name, params))))
