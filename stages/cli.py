"""The ``hev`` command: one sub-command per pipeline stage.

Every module in ``stages/`` (other than this one, ``common`` and ``simulating``) registers its commands on ``app`` when
imported. ``hev <command>`` imports only that command's module (found from the sources by
:func:`command_index`, nothing imported), so ``hev --help`` answers at once and a bad input
fails before a stage's heavy imports; :func:`register_all` imports every module (tests, ``CliRunner``).
"""

from __future__ import annotations

import ast
import importlib
import sys
from pathlib import Path

import typer

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="hev-sizing: size a power-split hybrid conversion of a conventional car.",
)
STAGES_ROOT = Path(__file__).resolve().parents[1]


@app.callback()
def _root() -> None:
    """hev-sizing: size a power-split hybrid conversion of a conventional car."""


def command_index(root: Path) -> dict[str, tuple[str, str]]:
    """Each ``hev`` command with the ``stages`` module that registers it (``@app.command("name")``) and the
    first paragraph of its docstring, read from the sources under ``root`` (nothing imported)."""
    return {name: (module, doc) for name, (module, doc, _) in _scan(root).items()}


def command_modules(root: Path) -> dict[str, str]:
    """Each ``hev`` command with the ``stages`` module that registers it, read from the sources under ``root``:
    the index :mod:`hevlib.codedeps` takes to find the code a ``dvc.yaml`` stage runs."""
    return {name: module for name, (module, _) in command_index(root).items()}


def _takes_params(node: ast.FunctionDef) -> bool:
    """Whether a command declares the shared ``--params`` option (a default of ``PARAMS_OPTION``)."""
    defaults = [*node.args.defaults, *[d for d in node.args.kw_defaults if d is not None]]
    return any(isinstance(d, ast.Name) and d.id == "PARAMS_OPTION" for d in defaults)


def _scan(root: Path) -> dict[str, tuple[str, str, bool]]:
    out: dict[str, tuple[str, str, bool]] = {}
    for path in sorted((root / "stages").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.FunctionDef):
                for deco in node.decorator_list:
                    if isinstance(deco, ast.Call) and getattr(deco.func, "attr", None) == "command":
                        name = deco.args[0].value if deco.args else node.name.replace("_", "-")
                        doc = (ast.get_docstring(node) or "").strip().split("\n\n")[0].replace("\n", " ")
                        out[name] = (f"stages.{path.stem}", doc, _takes_params(node))
    return out


def register_all() -> None:
    """Import every stage module, registering all commands on ``app``."""
    for module, _ in sorted(set(command_index(STAGES_ROOT).values())):
        importlib.import_module(module)


def _params_path(args: list[str]) -> str:
    """The ``--params`` value of a command line (``params.yaml`` when not given)."""
    for i, a in enumerate(args):
        if a == "--params" and i + 1 < len(args):
            return args[i + 1]
        if a.startswith("--params="):
            return a.split("=", 1)[1]
    return "params.yaml"


def _check_params(args: list[str]) -> None:
    """Validate a stage's params file before its module (numpy, polars, torch, numba...) is imported: a bad
    one stops the command at once with the stage's one-line error; the stage validates it again to run."""
    if "--help" in args:
        return
    from hevlib.params import ParamsError, load_params

    try:
        load_params(_params_path(args))
    except (ParamsError, ValueError, OSError) as err:
        msg = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        typer.echo(f"error: {msg}", err=True)
        raise SystemExit(1) from None


def _register_for(args: list[str]) -> None:
    """Register what ``args`` needs: the named command's module only (a stage's params checked first); for
    help or an unknown command, a listing of every command (name and first docstring line) without
    importing any stage."""
    index = _scan(STAGES_ROOT)
    name = next((a for a in args if not a.startswith("-")), None)
    if name in index:
        module, _, takes_params = index[name]
        if takes_params:
            _check_params(args)
        importlib.import_module(module)
        return
    for command, (_, doc, _) in sorted(index.items()):
        app.command(command, help=doc, short_help=doc, add_help_option=False)(_listed)


def _listed() -> None:  # pragma: no cover - a listing entry; `hev <command>` imports the real one
    raise typer.Exit(code=2)


def main() -> None:
    """The ``hev`` entry point: re-executes itself once under the pinned environment (one code path and thread
    count per numeric library, glibc's libm without FMA, Python's hash seed: :mod:`hevlib.determinism`), so
    every command gives the same bytes on every x86-64 CPU; then runs the app."""
    from hevlib.determinism import ensure_pinned

    ensure_pinned(["-m", "stages.cli", *sys.argv[1:]])
    _register_for(sys.argv[1:])
    app(prog_name="hev")


if __name__ == "__main__":  # `python -m stages.cli`: run the registered app of the imported module
    from stages.cli import main as _main

    _main()
