"""``hev exp-show``: ``dvc exp show`` narrowed to what fits a terminal.

Plain ``dvc exp show`` has a column per metric, per params key and per stage dependency: this pipeline's
stages depend on the modules they import (issue 23) and on the params keys they read, about 95 file
columns and 130 params columns, and DVC 3 offers no configured default view (``.dvc/config``'s ``exp``
section holds only ``auto_push`` and ``git_remote``). This command keeps the experiment, its date, the
answer's metrics (reports/answer.json) and the params that differ between the experiments shown, and drops
every file column; any further ``dvc exp show`` option passes through (``hev exp-show -A``, ``--keep``...).
"""

from __future__ import annotations

import os
import shutil
import sys

import typer

from stages.cli import app

#: File columns (every dependency path has a "/", params.yaml is the check stage's whole-file dep).
DROP = r".*/.*|params\.yaml"


def exp_show_args(extra: list[str]) -> list[str]:
    """The ``dvc exp show`` command line: no pager, changed params only, no file columns; the experiment, its
    date and the answer (reports/answer.json's keys) always kept."""
    from hevlib.validation import ANSWER_KEYS

    keep = "|".join(["Experiment", "Created", *ANSWER_KEYS.values()])
    return ["dvc", "exp", "show", "--no-pager", "--only-changed", "--drop", DROP, "--keep", keep, *extra]


@app.command(
    "exp-show", context_settings={"allow_extra_args": True, "ignore_unknown_options": True, "help_option_names": []}
)
def exp_show(ctx: typer.Context) -> None:
    """Show the experiments in 120 columns: the answer's metrics and the params that differ (dvc exp show)."""
    dvc = shutil.which("dvc") or os.path.join(os.path.dirname(sys.executable), "dvc")
    args = exp_show_args(list(ctx.args))
    os.execv(dvc, [dvc, *args[1:]])
