"""The shape of the code: no import cycle in ``hevlib/`` and ``stages/``, the library never imports the commands,
and imports run down a declared order of layers (with at most two known exceptions, each with its reason).

The import graph is read from the sources with ``ast`` (nothing is imported): every ``import`` and ``from ...
import`` of a project module wherever it stands -- module level, inside a function (a lazy import still runs the
module it names, and ``hev deps`` follows it too) or under ``TYPE_CHECKING`` -- with relative imports resolved.
``from a import b`` is an import of the module ``a.b`` where that is a module, else of ``a``; ``import a.b.c`` of
the deepest of ``a.b.c``, ``a.b``, ``a`` that is a module. Importing a submodule first runs its parent packages'
``__init__``; that is not an edge (a package that imports its own submodules is no cycle), but a submodule that
imports its own package is one.
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("hevlib", "stages")

#: The layers, lowest first: a module may import modules of its own layer and of the layers below. A module
#: belongs to the entry that names it or its nearest package (a top-level package name stands for its
#: ``__init__`` only, so that a new module has to be placed).
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    (
        "foundations",  # names, params, file and table I/O, pinned numerics, build tooling
        (
            "hevlib",
            "hevlib.codedeps",
            "hevlib.design",
            "hevlib.determinism",
            "hevlib.io",
            "hevlib.params",
            "hevlib.profiles",
            "hevlib.proposal",
            "hevlib.pytest_pins",
            "hevlib.regression_check",
            "hevlib.tables",
        ),
    ),
    (
        "physics",  # component data, cycles, sizing, the simulator and what runs it
        (
            "hevlib.baselines",
            "hevlib.bound",
            "hevlib.components",
            "hevlib.controller_gap",
            "hevlib.cycles",
            "hevlib.doe",
            "hevlib.earned",
            "hevlib.engine_curves",
            "hevlib.epa",
            "hevlib.lookup",
            "hevlib.powers",
            "hevlib.regen_curves",
            "hevlib.scaling",
            "hevlib.sim",
            "hevlib.sizing",
            "hevlib.warmup",
        ),
    ),
    ("indicators", ("hevlib.indicators", "hevlib.judging", "hevlib.screen")),  # dominance, hypervolume, the screen
    ("search", ("hevlib.optimise", "hevlib.surrogates")),  # surrogates and the optimisers
    (
        "selection",  # the pareto step, the recommendation, validation, its typed results, report and seed spread
        (
            "hevlib.pareto",
            "hevlib.recommend",
            "hevlib.report",
            "hevlib.results",
            "hevlib.robustness",
            "hevlib.validation",
        ),
    ),
    ("presentation", ("hevlib.explorer", "hevlib.plots")),
    ("studies", ("hevlib.benchmark", "hevlib.fleet")),  # the benchmark (every source) and the fleet (real cars)
    ("commands", ("stages.",)),  # `hev` and every stage command ("stages." : the whole package)
)

#: Imports that run back up the layers (importer, imported): at most two, each with why it stays.
UPWARD: dict[tuple[str, str], str] = {
    ("hevlib.plots.benchmark", "hevlib.benchmark.runs"): (
        "the anytime figure styles each source by its kind (KIND, the benchmark's own table of sources); the "
        "figure lives with the other figures in hevlib/plots, and only hevlib.benchmark.report draws it"
    ),
}
MAX_UPWARD = 2


def modules(root: Path) -> dict[str, Path]:
    """Every module of the project's packages under ``root``, by dotted name (a package by its ``__init__``)."""
    out = {}
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            if "__pycache__" in path.parts:
                continue
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            out[".".join(parts)] = path
    return out


def import_graph(root: Path) -> dict[tuple[str, str], list[str]]:
    """``{(importer, imported): ["path:line", ...]}`` over the project's modules under ``root``."""
    mods = modules(root)

    def resolve(name: str) -> str | None:
        while name and name not in mods:
            name = name.rpartition(".")[0]
        return name or None

    edges: dict[tuple[str, str], list[str]] = defaultdict(list)
    for name, path in mods.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    parts = package.split(".")
                    base = ".".join(parts[: len(parts) - node.level + 1])
                    source = f"{base}.{node.module}" if node.module else base
                else:
                    source = node.module or ""
                targets = [f"{source}.{a.name}" if f"{source}.{a.name}" in mods else source for a in node.names]
            else:
                continue
            for target in targets:
                if target.split(".")[0] not in PACKAGES:
                    continue
                imported = resolve(target)
                where = f"{path.relative_to(root).as_posix()}:{node.lineno}"
                if imported is not None and imported != name and where not in edges[(name, imported)]:
                    edges[(name, imported)].append(where)
    return dict(edges)


def cycles(edges) -> list[tuple[list[str], list[str]]]:
    """Every set of modules that import each other round a cycle (strongly connected, Tarjan's algorithm): one
    cycle through it (its modules in import order, the first repeated at the end) and all its modules."""
    graph: dict[str, list[str]] = defaultdict(list)
    for a, b in sorted(edges):
        graph[a].append(b)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for start in sorted({m for edge in edges for m in edge}):
        if start in index:
            continue
        work = [(start, iter(graph[start]))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            v, successors = work[-1]
            for w in successors:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(graph[w])))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    members = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        members.append(w)
                        if w == v:
                            break
                    if len(members) > 1:
                        found.append((_cycle_through(min(members), set(members), graph), sorted(members)))
    return found


def _cycle_through(first: str, members: set[str], graph) -> list[str]:
    """The shortest path from ``first`` back to itself inside ``members`` (breadth first)."""
    came_from: dict[str, str] = {}
    frontier = [first]
    while frontier:
        following = []
        for v in frontier:
            for w in graph[v]:
                if w == first:
                    path = [v]
                    while path[-1] != first:
                        path.append(came_from[path[-1]])
                    return [*reversed(path), first]
                if w in members and w not in came_from:
                    came_from[w] = v
                    following.append(w)
        frontier = following
    raise AssertionError(f"no cycle through {first}")  # pragma: no cover - members are strongly connected


def layer_of(module: str) -> int | None:
    """Index in :data:`LAYERS` of the entry naming ``module`` or its nearest package (None: unplaced)."""
    best, best_len = None, -1
    for i, (_, names) in enumerate(LAYERS):
        for entry in names:
            if entry.endswith("."):
                hit = module.startswith(entry) or module == entry[:-1]
            elif entry in PACKAGES:
                hit = module == entry
            else:
                hit = module == entry or module.startswith(entry + ".")
            if hit and len(entry) > best_len:
                best, best_len = i, len(entry)
    return best


def upward(edges) -> dict[tuple[str, str], list[str]]:
    """The imports of a module from a higher layer than its own."""
    layers = {(a, b): (layer_of(a), layer_of(b)) for a, b in edges}
    return {
        edge: where
        for edge, where in edges.items()
        if None not in layers[edge] and layers[edge][1] > layers[edge][0]  # unplaced: test_every_module_has_a_layer
    }


EDGES = import_graph(REPO)


def _where(edges, pairs) -> str:
    return "\n".join(f"  {a} -> {b} ({', '.join(edges[(a, b)])})" for a, b in sorted(pairs))


def test_every_module_has_a_layer():
    unplaced = sorted(m for m in modules(REPO) if layer_of(m) is None)
    assert not unplaced, f"modules in no layer of LAYERS (place them): {', '.join(unplaced)}"


def _cycle_report(edges, cycle: list[str], members: list[str]) -> str:
    where = ", ".join(w for a, b in zip(cycle, cycle[1:], strict=False) for w in edges[(a, b)])
    more = f"; all on cycles together: {', '.join(members)}" if len(members) > len(cycle) - 1 else ""
    return f"  {' -> '.join(cycle)} ({where}){more}"


def test_no_import_cycle():
    found = cycles(EDGES)
    assert not found, "import cycles:\n" + "\n".join(_cycle_report(EDGES, *c) for c in found)


def test_the_library_never_imports_the_commands():
    bad = [(a, b) for a, b in EDGES if a.startswith("hevlib") and b.startswith("stages")]
    assert not bad, "hevlib imports stages (pass what it needs in instead):\n" + _where(EDGES, bad)


def test_imports_run_down_the_layers():
    assert len(UPWARD) <= MAX_UPWARD, f"more than {MAX_UPWARD} imports allowed to run back up the layers"
    found = upward(EDGES)
    new = set(found) - set(UPWARD)
    assert not new, "imports running back up the layers (importer's layer below the imported's):\n" + _where(EDGES, new)
    gone = set(UPWARD) - set(found)
    assert not gone, f"no longer imported, remove from UPWARD: {sorted(gone)}"


def test_the_graph_resolves_relative_lazy_and_package_imports_and_names_a_cycle(tmp_path):
    files = {
        "hevlib/__init__.py": "",
        "hevlib/a.py": "from hevlib import b\n",
        "hevlib/b.py": "def f():\n    from .sub import c  # lazy, relative\n",
        "hevlib/sub/__init__.py": "from . import c\nimport numpy\n",
        "hevlib/sub/c.py": "import hevlib.a\nfrom hevlib.sub import helper\n",
        "stages/__init__.py": "",
        "stages/run.py": "from hevlib import a\n",
    }
    for rel, text in files.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(text)
    edges = import_graph(tmp_path)
    assert set(edges) == {
        ("hevlib.a", "hevlib.b"),
        ("hevlib.b", "hevlib.sub.c"),
        ("hevlib.sub", "hevlib.sub.c"),
        ("hevlib.sub.c", "hevlib.a"),
        ("hevlib.sub.c", "hevlib.sub"),  # a submodule importing its own package: a cycle
        ("stages.run", "hevlib.a"),
    }
    assert edges[("hevlib.b", "hevlib.sub.c")] == ["hevlib/b.py:2"]
    members = ["hevlib.a", "hevlib.b", "hevlib.sub", "hevlib.sub.c"]
    assert cycles(edges) == [(["hevlib.a", "hevlib.b", "hevlib.sub.c", "hevlib.a"], members)]
    report = _cycle_report(edges, *cycles(edges)[0])
    assert (
        "hevlib.a -> hevlib.b -> hevlib.sub.c -> hevlib.a (hevlib/a.py:1, hevlib/b.py:2, hevlib/sub/c.py:1)" in report
    )
    assert "all on cycles together: hevlib.a, hevlib.b, hevlib.sub, hevlib.sub.c" in report
    del edges[("hevlib.sub.c", "hevlib.a")], edges[("hevlib.sub.c", "hevlib.sub")]
    assert cycles(edges) == []


@pytest.mark.parametrize(
    ("module", "layer"),
    [("hevlib", "foundations"), ("hevlib.sim.powertrain.thermal", "physics"), ("stages.cli", "commands")],
)
def test_a_module_takes_the_layer_of_its_nearest_named_package(module, layer):
    assert LAYERS[layer_of(module)][0] == layer
