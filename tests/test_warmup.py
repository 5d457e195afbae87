"""`hev warmup`'s compile-time accounting: nested compilations are charged to the function that ran them."""

from __future__ import annotations

from types import SimpleNamespace

from hevlib.warmup import compile_table, compile_times


def _event(fn_name: str, module: str, start: bool):
    def fn():
        return None

    fn.__module__, fn.__qualname__ = module, fn_name
    return SimpleNamespace(data={"dispatcher": SimpleNamespace(py_func=fn)}, is_start=start)


def test_self_time_excludes_the_compilations_started_inside():
    events = [
        (0.0, _event("kernel", "hevlib.sim.drive", True)),
        (1.0, _event("helper", "hevlib.sim.drive", True)),
        (4.0, _event("helper", "hevlib.sim.drive", False)),  # 3 s inside the kernel's 10
        (5.0, _event("interp", "numba.np.arraymath", True)),
        (6.0, _event("interp", "numba.np.arraymath", False)),
        (10.0, _event("kernel", "hevlib.sim.drive", False)),
        (11.0, _event("helper", "hevlib.sim.drive", True)),  # a second signature of the helper
        (13.0, _event("helper", "hevlib.sim.drive", False)),
    ]
    times = {t.function: t for t in compile_times(events)}
    kernel, helper = times["hevlib.sim.drive.kernel"], times["hevlib.sim.drive.helper"]
    interp = times["numba.np.arraymath.interp"]
    assert (kernel.signatures, kernel.total_s, kernel.self_s) == (1, 10.0, 6.0)
    assert (helper.signatures, helper.total_s, helper.self_s) == (2, 5.0, 5.0)
    assert (interp.self_s, interp.ours, kernel.ours) == (1.0, False, True)
    assert sum(t.self_s for t in times.values()) == 12.0  # the whole time in the compiler, counted once
    assert [t.function for t in compile_times(events)][:2] == ["hevlib.sim.drive.kernel", "hevlib.sim.drive.helper"]

    lines = compile_table(compile_times(events), top=1)
    assert "hevlib.sim.drive.kernel" in lines[1] and "1 more hevlib functions" in lines[2]
    assert lines[-1].split()[-1] == "1.00" and "(1 functions)" in lines[-1]


def test_processes_merge_into_one_table():
    """The warm-up's processes (one per vehicle kind) report one table: a helper both compiled counts its
    compiler time twice but its signatures once; the self times still sum to the compiler time spent."""
    from hevlib.warmup import CompileTime, merged

    hybrid = [CompileTime("hevlib.sim.drive.drive_hybrid", 1, 30.0, 20.0), CompileTime("hevlib.t.step", 1, 3.0, 3.0)]
    conventional = [
        CompileTime("hevlib.sim.drive.drive_conventional", 1, 9.0, 6.0),
        CompileTime("hevlib.t.step", 1, 2.5, 2.5),
    ]
    rows = {t.function: t for t in merged([hybrid, conventional])}
    assert (rows["hevlib.t.step"].signatures, rows["hevlib.t.step"].self_s, rows["hevlib.t.step"].total_s) == (
        1,
        5.5,
        5.5,
    )
    assert sum(t.self_s for t in rows.values()) == 31.5
    assert [t.function for t in merged([hybrid, conventional])][0] == "hevlib.sim.drive.drive_hybrid"
    assert merged([]) == []
