"""The simulator's joints have names (issue 54, part 2): every record the kernels read is built by keyword and read
by name, so two swapped values of one type cannot compile and run; each value of ``params.yaml`` the kernels read
lives in one record under one name; component scale factors come from :func:`hevlib.scaling.power_scale` alone."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from hevlib.sim.vehicles import KernelLibrary, Vehicle

ROOT = Path(__file__).resolve().parents[1]
#: Where records are built: the library, the stages, the benchmarks (not their peers' virtual environments), the tests.
SOURCES = (
    sorted((ROOT / "hevlib").rglob("*.py"))
    + sorted((ROOT / "stages").rglob("*.py"))
    + sorted(p for p in (ROOT / "benchmarks").rglob("*.py") if ".venv" not in p.parts)
    + sorted((ROOT / "tests").glob("*.py"))
)
#: The kernels: their records may not be unpacked by position either.
KERNEL_SOURCES = sorted((ROOT / "hevlib" / "sim").rglob("*.py")) + [ROOT / "hevlib" / "bound.py"]
#: Plain tuples the kernels unpack (not records), each with what it is.
PLAIN_TUPLES = {
    "env": "a point of the full-power force envelope: (speed, force, slope)",
    "bracket": "a root's bracket: (p_a, g_a, p_b, g_b)",
    "abc": "a body's coast-down coefficients A, B, C",
    "pack": "the pack's state and limits at one SOC grid point of the bound",
    "item": "one batch handed to a worker: (designs, cycle, charge balanced)",
}


def _records() -> set[str]:
    """Every ``NamedTuple`` class defined in ``hevlib``."""
    names = set()
    for path in sorted((ROOT / "hevlib").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef) and any(getattr(b, "id", None) == "NamedTuple" for b in node.bases):
                names.add(node.name)
    return names


def positional_builds(source: str, records: set[str]) -> list[tuple[int, str]]:
    """(line, record) of each call in ``source`` that builds one of ``records`` with a positional or starred
    argument."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Call):
            f = node.func
            name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else None
            if name in records and node.args:
                found.append((node.lineno, name))
    return found


def positional_unpacks(source: str) -> list[tuple[int, str]]:
    """(line, name) of each ``a, b, ... = name`` (or ``= x.name``, ``= x[i]``) outside :data:`PLAIN_TUPLES`."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Tuple):
            v = node.value
            name = v.id if isinstance(v, ast.Name) else v.attr if isinstance(v, ast.Attribute) else None
            if isinstance(v, ast.Subscript) or (name is not None and name not in PLAIN_TUPLES):
                found.append((node.lineno, ast.unparse(v)))
    return found


def test_the_checks_see_a_positional_record_and_pass_a_named_one():
    records = {"SplitLimits"}
    assert positional_builds("lim = SplitLimits(w, t, lo, hi, p, 0.0, 0.0)", records) == [(1, "SplitLimits")]
    assert positional_builds("lim = split.SplitLimits(*xs)", records) == [(1, "SplitLimits")]
    assert positional_builds("lim = SplitLimits(w_r=w, t_m_cap=t, lo=lo)", records) == []
    assert positional_unpacks("sn, cs, dt = road") == [(1, "road")]
    assert positional_unpacks("a, b = ctl[:2]") == [(1, "ctl[:2]")]
    assert positional_unpacks("lo, hi = engine_window(w_r, d)") == []  # a function's result
    assert positional_unpacks("v_e, f_e, slope = env") == []


def test_every_record_is_built_by_keyword():
    records = _records()
    assert {"SplitDesign", "PmsConfig", "PackLimits", "SplitLimits", "SplitCommand", "HybridRec"} <= records
    bad = [
        f"{path.relative_to(ROOT)}:{line}: {name}(...) by position"
        for path in SOURCES
        for line, name in positional_builds(path.read_text(), records)
    ]
    assert not bad, "\n".join(bad)


def test_no_kernel_unpacks_a_record_by_position():
    bad = [
        f"{path.relative_to(ROOT)}:{line}: ... = {what}"
        for path in KERNEL_SOURCES
        for line, what in positional_unpacks(path.read_text())
    ]
    assert not bad, "\n".join(bad)


def _leaves(x, path: str = "") -> dict[str, np.ndarray]:
    """A record's values by path (nested records walked, arrays and scalars as arrays)."""
    if isinstance(x, tuple) and hasattr(x, "_fields"):
        out = {}
        for f in x._fields:
            out |= _leaves(getattr(x, f), f"{path}.{f}" if path else f)
        return out
    return {path: np.asarray(x)}


def _changed(a, b) -> list[str]:
    la, lb = _leaves(a), _leaves(b)
    return sorted(k for k in la if la[k].shape != lb[k].shape or not np.array_equal(la[k], lb[k], equal_nan=True))


#: params keys the power-split kernel reads, and where each must land (the one record field, or the rows' column).
ONE_PLACE = {
    ("sim", "soc_init"): ["rows"],  # the drive's (and the performance tests') start, per design
    ("sim", "soc_min"): ["sc.soc_min"],  # the pack's window, which the controller's charge deficit reads too
    ("sim", "soc_max"): ["sc.soc_max"],
    ("sim", "adhesion_coefficient"): ["c.adhesion_coefficient"],
    ("sim", "planetary_efficiency"): ["sc.planetary_efficiency"],
    ("sim", "final_drive_efficiency"): ["sc.final_drive_efficiency"],
    ("sim", "pack_current_max_a"): ["sc.pack_current_max_a"],
    ("sim", "cycle_met_tolerance_kmh"): ["c.cycle_met_tolerance_mps"],
    ("sim", "ambient_c"): ["X.ambient_c"],
    ("pms", "engine_on_threshold"): ["pc.engine_on_threshold"],
    ("pms", "engine_min_on_s"): ["pc.engine_min_on_s"],
    ("pms", "engine_min_off_s"): ["pc.engine_min_off_s"],
    ("pms", "engine_min_power_kw"): ["pc.engine_min_power_w"],
    ("pms", "charge_power_fraction"): ["pc.charge_power_fraction"],
    ("pms", "soc_target"): ["pc.soc_target"],
    ("pms", "full_power_above_kw"): ["pc.full_power_above_w"],
    ("pms", "soc_low"): ["th.soc_low"],
    ("pms", "soc_high"): ["th.soc_high"],  # the rule base's threshold, which also stops the engine's charging
    ("pms", "speed_high_kmh"): ["th.speed_high_kmh"],
    ("pms", "torque_high"): ["th.torque_high"],
}


@pytest.mark.parametrize(("group", "key"), list(ONE_PLACE), ids=[".".join(k) for k in ONE_PLACE])
def test_each_param_lands_in_one_place(lib, params, group, key):
    """Moving one params value moves exactly the record fields listed, nothing else: no copy under another name."""
    design = {"p_eng_kw": [40.0], "p_mot_kw": [35.0], "p_gen_kw": [15.0], "i0": [4.1], "n_bat": [30.0]}
    design |= {"n_r": [78.0], "n_s": [30.0]}
    grp = getattr(params, group)
    value = getattr(grp, key)
    moved = value.model_copy(update={"value": value.value * 0.9}) if hasattr(value, "value") else value * 0.9
    other = params.model_copy(update={group: grp.model_copy(update={key: moved})})
    a = Vehicle.from_design(KernelLibrary.build(lib, params), design).kernel
    b = Vehicle.from_design(KernelLibrary.build(lib, other), design).kernel
    assert _changed(a, b) == sorted(ONE_PLACE[group, key])
    for where in ONE_PLACE[group, key]:
        if where != "rows":  # the design rows' start SOC column (R_SOC0)
            # the rule base reads its thresholds in the params' own units (the speed it sees is in km/h)
            name = key if where.startswith("th.") else _si(key)
            assert where.split(".")[-1] == name, f"{group}.{key} is called {where} in the kernel"


def _si(key: str) -> str:
    """A params key's name in the kernels: the same, its unit in SI where the params give kW or km/h."""
    for unit, si in (("_kw", "_w"), ("_kmh", "_mps")):
        if key.endswith(unit):
            return key.removesuffix(unit) + si
    return key


def test_scale_factors_come_from_power_scale_alone():
    """No module but :mod:`hevlib.scaling` divides by a component's ``peak_power_kw`` (the scaling law, once)."""
    bad = []
    for path in SOURCES:
        if path.name == "scaling.py" or path.parent.name == "tests":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if (
                isinstance(node, ast.BinOp)
                and isinstance(node.op, ast.Div)
                and isinstance(node.right, ast.Attribute)
                and node.right.attr == "peak_power_kw"
            ):
                bad.append(f"{path.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}")
    assert not bad, "\n".join(bad)
