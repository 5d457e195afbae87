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
