"""``hev deps``: each stage's code deps in ``dvc.yaml``, generated from the import closure of its command."""

from __future__ import annotations

from pathlib import Path

import typer

from hevlib.codedeps import check_deps, generated_deps, write_deps
from hevlib.io import atomic_path
from stages.cli import app, command_modules


@app.command("deps")
def deps(
    dvc_yaml: Path = typer.Option(Path("dvc.yaml"), "--dvc-yaml", help="the pipeline file"),
    write: bool = typer.Option(False, "--write", help="rewrite the stages' hevlib/stages deps in place"),
    check: bool = typer.Option(False, "--check", help="exit 1 when a stage imports code its deps omit"),
) -> None:
    """Print (or --write, or --check) every stage's code deps: the modules its `hev` command imports."""
    root = next(p for p in dvc_yaml.resolve().parents if (p / "stages").is_dir() and (p / "hevlib").is_dir())
    text = dvc_yaml.read_text()
    if check:
        problems = check_deps(root, text, command_modules(root))
        for p in problems:
            typer.echo(f"error: {p}", err=True)
        if problems:
            raise typer.Exit(code=1)
        typer.echo(f"deps: every stage of {dvc_yaml} declares the code it imports")
        return
    lists = generated_deps(root, text, command_modules(root))
    if write:
        new = write_deps(text, lists)
        if new != text:
            with atomic_path(dvc_yaml) as tmp:
                Path(tmp).write_text(new)
        typer.echo(f"deps: {dvc_yaml} {'rewritten' if new != text else 'already up to date'}")
        return
    for stage, files in lists.items():
        typer.echo(f"{stage}: {' '.join(files)}")
