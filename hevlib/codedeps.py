"""Which source files each pipeline stage runs: the static import closure of its command module.

A stage in ``dvc.yaml`` depends on the code it imports, not on the whole ``hevlib`` and ``stages``
packages, so an edit to a plot or a report reruns only the stages that draw or write it. The lists are
generated, never hand-kept: :func:`stage_code_deps` follows every ``import`` and ``from … import`` of the
project's own packages (module level and inside functions, since the stages import heavy modules lazily)
from ``stages/<command>.py``, adds each parent package's ``__init__``, and names a whole package folder
when every module in it is reached. ``hev deps`` prints the lists, ``hev deps --write`` puts them into
``dvc.yaml``, ``hev deps --check`` (and the test suite) fails when a stage imports a module its deps omit.

Which ``stages`` module each ``hev`` command lives in is the CLI's to say: the functions that read
``dvc.yaml`` take that index (``{command: module}``, :func:`stages.cli.command_modules`, read from the sources)
as an argument, so this library never imports the command layer. The entry point (``stages/cli.py``) imports
only the module of the command it runs; that dynamic import is not followed.
"""

from __future__ import annotations

import ast
import hashlib
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

#: The project's own packages: imports of anything else (numpy, pymoo, …) are pinned by requirements.lock.
PACKAGES: tuple[str, ...] = ("hevlib", "stages")


def module_file(root: Path, name: str) -> Path | None:
    """The file that defines module ``name`` under ``root`` (a package's ``__init__.py``), or None."""
    path = root.joinpath(*name.split("."))
    if (path / "__init__.py").is_file():
        return path / "__init__.py"
    if path.with_suffix(".py").is_file():
        return path.with_suffix(".py")
    return None


def imported_names(path: Path, name: str) -> set[str]:
    """Every project module name that ``path`` (module ``name``) imports, wherever the import stands.

    ``from a.b import c`` yields ``a.b`` and ``a.b.c`` (``c`` may be a submodule); names that are not
    modules are dropped later by :func:`module_file`.
    """
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = package.split(".")
                base = parts[: len(parts) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            found.add(module)
            found.update(f"{module}.{alias.name}" for alias in node.names)
    return {m for m in found if m.split(".")[0] in PACKAGES}


def import_closure(root: Path, module: str) -> dict[str, Path]:
    """Every project module that importing ``module`` can run, by name, with its file."""
    seen: dict[str, Path] = {}
    todo = [module]
    while todo:
        parts = todo.pop().split(".")
        for i in range(1, len(parts) + 1):  # importing a.b.c runs a/__init__ and a/b/__init__ first
            name = ".".join(parts[:i])
            if name in seen:
                continue
            path = module_file(root, name)
            if path is None:
                continue
            seen[name] = path
            todo.extend(imported_names(path, name))
    return seen


def closure_hash(root: Path, modules: Iterable[str], files: Iterable[str] = ()) -> str:
    """Short hash of the source of every project module that importing ``modules`` can run (their
    :func:`import_closure`) and of ``files`` (paths relative to ``root``): a stored result that code computed
    is current only while this is unchanged."""
    paths = {root / f for f in files}
    for module in modules:
        paths.update(import_closure(root, module).values())
    h = hashlib.sha256()
    for rel, path in sorted((p.relative_to(root).as_posix(), p) for p in paths):
        h.update(rel.encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:16]


def compact(root: Path, files: set[Path]) -> list[str]:
    """``files`` as ``dvc.yaml`` deps: a package folder where every module under it is in ``files``,
    the single files elsewhere; paths relative to ``root``, sorted."""

    def whole(folder: Path) -> bool:
        return _modules(folder) <= files

    out: set[str] = set()
    for f in files:
        top = f.parent
        folder = None
        while (top / "__init__.py").is_file() and top != root and top.parent != root:  # never a top package
            if whole(top):
                folder = top
            top = top.parent
        out.add((folder or f).relative_to(root).as_posix())
    return sorted(out)


_CMD = re.compile(r"^\s*cmd:\s*hev\s+([\w-]+)")
_STAGE = re.compile(r"^  ([\w-]+):")
_SECTION = re.compile(r"^\s+(deps|params|outs|plots|metrics|cmd|do|foreach|wdir|desc|always_changed|frozen|vars)\b")
_CODE_DEP = re.compile(r"^(\s*)- (hevlib|stages)(/\S*)?\s*(#.*)?$")


def stage_commands(dvc_yaml: str, commands: Mapping[str, str]) -> dict[str, str]:
    """Each stage of ``dvc.yaml`` (text) with the ``stages`` module its ``hev`` command runs (``commands``:
    each command with the module that registers it)."""
    out: dict[str, str] = {}
    for stage, _section, line in _walk(dvc_yaml):
        if stage and (m := _CMD.match(line)):
            if m.group(1) not in commands:
                raise ValueError(f"dvc.yaml: stage {stage!r} runs `hev {m.group(1)}`, which no stages module defines")
            out[stage] = commands[m.group(1)]
    return out


def stage_code_deps(root: Path, module: str) -> list[str]:
    """The code deps of the stage whose command lives in ``module`` (``stages.doe``)."""
    return compact(root, set(import_closure(root, module).values()))


def generated_deps(root: Path, dvc_yaml: str, commands: Mapping[str, str]) -> dict[str, list[str]]:
    """Every stage's code deps, generated from its command's import closure (``commands``: each command with the
    module that registers it)."""
    return {stage: stage_code_deps(root, module) for stage, module in stage_commands(dvc_yaml, commands).items()}


def declared_deps(dvc_yaml: str) -> dict[str, list[str]]:
    """The ``hevlib``/``stages`` entries each stage of ``dvc.yaml`` (text) declares under ``deps``."""
    out: dict[str, list[str]] = {}
    for stage, section, line in _walk(dvc_yaml):
        if stage and section == "deps" and (m := _CODE_DEP.match(line)):
            out.setdefault(stage, []).append(m.group(2) + (m.group(3) or ""))
    return out


def _walk(dvc_yaml: str):
    """``(stage, section, line)`` for every line of ``dvc.yaml`` (text); stage is None outside ``stages``."""
    stage = section = None
    in_stages = False
    for line in dvc_yaml.splitlines():
        if re.match(r"^\S", line):
            in_stages, stage, section = line.startswith("stages:"), None, None
        elif in_stages and (m := _STAGE.match(line)):
            stage, section = m.group(1), None
        elif stage and (m := _SECTION.match(line)):
            section = m.group(1)
        yield stage, section, line


def write_deps(dvc_yaml: str, deps: dict[str, list[str]]) -> str:
    """``dvc.yaml`` (text) with each stage's code deps replaced by ``deps[stage]``, at the place of the
    first code dep it declared (or at the end of its ``deps``), comments and everything else kept."""
    lines: list[str] = []
    done: set[str] = set()
    last_dep: dict[str, int] = {}
    indent: dict[str, str] = {}
    for stage, section, line in _walk(dvc_yaml):
        if stage in deps and section == "deps" and (m := _CODE_DEP.match(line)):
            if stage not in done:
                done.add(stage)
                lines.extend(f"{m.group(1)}- {d}" for d in deps[stage])
            continue
        lines.append(line)
        if stage in deps and section == "deps" and (m := re.match(r"^(\s*)- ", line)):
            last_dep[stage], indent[stage] = len(lines), m.group(1)
    for stage in sorted(set(deps) - done, key=lambda s: -last_dep.get(s, -1)):  # stages that had none
        if stage not in last_dep:
            raise ValueError(f"dvc.yaml: stage {stage!r} has no deps list to add its code to")
        at = last_dep[stage]
        lines[at:at] = [f"{indent[stage]}- {d}" for d in deps[stage]]
    return "\n".join(lines) + ("\n" if dvc_yaml.endswith("\n") else "")


@dataclass(frozen=True)
class DepsProblem:
    stage: str
    missing: tuple[str, ...]
    extra: tuple[str, ...]

    def __str__(self) -> str:
        parts = []
        if self.missing:
            parts.append(f"imports {', '.join(self.missing)} but its deps omit them")
        if self.extra:
            parts.append(f"declares {', '.join(self.extra)} that it does not import")
        return f"dvc.yaml: stage {self.stage!r} " + "; ".join(parts) + " (run `hev deps --write`)"


def check_deps(root: Path, dvc_yaml: str, commands: Mapping[str, str]) -> list[DepsProblem]:
    """Stages whose declared code deps differ from their import closure (covered file by file; ``commands``: each
    command with the module that registers it)."""
    declared = declared_deps(dvc_yaml)
    problems = []
    for stage, wanted in generated_deps(root, dvc_yaml, commands).items():
        have = declared.get(stage, [])
        covered = {f for d in have for f in _files(root, d)}
        needed = {f for d in wanted for f in _files(root, d)}
        missing = tuple(sorted(f.relative_to(root).as_posix() for f in needed - covered))
        extra = tuple(sorted(set(have) - set(wanted)))
        if missing or extra:
            problems.append(DepsProblem(stage, missing, extra))
    return problems


def _modules(folder: Path) -> set[Path]:
    """Every Python module under ``folder`` (bytecode caches aside)."""
    return {f for f in folder.rglob("*.py") if "__pycache__" not in f.parts}


def _files(root: Path, dep: str) -> set[Path]:
    """The modules a ``dvc.yaml`` code dep stands for: a folder's modules, or the one file."""
    path = root / dep
    return _modules(path) if path.is_dir() else {path}
