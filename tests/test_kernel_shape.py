"""The simulator's shape (FASTSim 3's): no kernel function takes more than ``MAX_PARAMS`` arguments (what travels
together goes in one named record), and the accumulator and trace layouts are one list of names each."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from hevlib.sim.powertrain import layout as L

SIM = Path(__file__).resolve().parents[1] / "hevlib" / "sim"
MAX_PARAMS = 10


def n_params(fn: ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda) -> int:
    a = fn.args
    return len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs) + (a.vararg is not None) + (a.kwarg is not None)


def too_many(source: str, where: str = "<source>", limit: int = MAX_PARAMS) -> list[str]:
    """``where:line name(count)`` of every function (methods and nested ones included) over ``limit``."""
    return [
        f"{where}:{node.lineno} {node.name}({n_params(node)})"
        for node in ast.walk(ast.parse(source))
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and n_params(node) > limit
    ]


def test_no_kernel_function_takes_more_than_ten_parameters():
    files = sorted(SIM.rglob("*.py"))
    assert len(files) > 10
    found = [hit for f in files for hit in too_many(f.read_text(), str(f.relative_to(SIM)))]
    assert not found, "group what travels together into a NamedTuple record: " + ", ".join(found)


@pytest.mark.parametrize(
    ("source", "n"),
    [
        ("def f(a, b, c, d, e, f, g, h, i, j):\n    pass\n", 0),
        ("def f(a, b, c, d, e, f, g, h, i, j, k):\n    pass\n", 1),
        ("def f(a, b, c, d, e, f, g, h, i, /, j, *, k):\n    pass\n", 1),
        ("class C:\n    def m(self, a, b, c, d, e, f, g, h, i, *args, **kw):\n        pass\n", 1),
        ("def outer():\n    def inner(a, b, c, d, e, f, g, h, i, j, k):\n        pass\n", 1),
    ],
)
def test_the_count_sees_every_kind_of_parameter(source, n):
    assert len(too_many(source)) == n


def test_layout_names_define_the_columns():
    for prefix, names, n in (("O_", L.OUT_NAMES, L.N_O), ("T_", L.TRACE_NAMES, L.N_T)):
        cols = {k: v for k, v in vars(L).items() if k.startswith(prefix) and isinstance(v, int)}
        assert len(names) == n == len(set(names)) == len(cols)
        assert sorted(cols.values()) == list(range(n)), prefix


def test_each_vehicle_record_holds_only_what_its_kernels_read(sim):
    from hevlib.sim.drive import ConventionalRec, HybridRec

    assert {"ratios", "shift", "cd"}.isdisjoint(HybridRec._fields)  # no gearbox or shift logic
    assert {"th", "pc", "M", "G", "B"}.isdisjoint(ConventionalRec._fields)  # no controller, machines or battery
    assert type(sim.vehicle(None, "conventional").kernel) is ConventionalRec
    assert type(sim.vehicle(None, "prius").kernel) is HybridRec is type(sim.vehicle(sim.space.lower[None, :]).kernel)
