"""``hev warmup``: compile every simulator kernel into numba's on-disk cache, each vehicle kind's kernels in a
process of its own side by side, and report what was compiled and how long each function took (numba's
``numba:compile`` events).

numba compiles on one core, and the hybrid and the conventional kernels share only small helpers, so on two
cores the warm-up takes about as long as the hybrid kernel alone. Kept apart from
:mod:`hevlib.sim.simulator`: timing and printing the compiler are not part of the simulator, whose source
fingerprint goes into every simulated table.
"""

from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context

from hevlib.params import Params

#: The vehicle kinds whose kernels the warm-up compiles (``Simulator.run_raw``'s ``vehicle``): the hybrid
#: kernel (any design) and the conventional one; together they are every kernel the stages call.
KINDS = ("prius", "conventional")


@dataclass(frozen=True)
class CompileTime:
    """One compiled function's share of the warm-up."""

    function: str  #: module.qualname of the Python function numba compiled (or loaded from its cache)
    signatures: int  #: how many times it was compiled (one per argument-type signature)
    total_s: float  #: wall time inside its compilation, the functions it compiled on the way included
    self_s: float  #: the same less the nested compilations of other dispatchers

    @property
    def ours(self) -> bool:
        return self.function.startswith("hevlib.")


def compile_times(events) -> list[CompileTime]:
    """Per-function compile times from numba's recorded ``numba:compile`` events, longest ``self_s`` first.

    Compilations nest (a kernel compiles the non-inlined functions it calls), so each function's own
    share is its time less that of the compilations started inside it; the ``self_s`` column sums to the
    whole time numba spent compiling.
    """
    stack: list[list] = []
    acc: dict[str, list] = {}
    for ts, event in events:
        fn = event.data["dispatcher"].py_func
        name = f"{fn.__module__}.{fn.__qualname__}"
        if event.is_start:
            stack.append([name, ts, 0.0])
            continue
        name, start, nested = stack.pop()
        if stack:
            stack[-1][2] += ts - start
        row = acc.setdefault(name, [0, 0.0, 0.0])
        row[0] += 1
        row[1] += ts - start
        row[2] += ts - start - nested
    rows = [CompileTime(n, c, t, s) for n, (c, t, s) in acc.items()]
    return sorted(rows, key=lambda r: (-r.self_s, r.function))


def warm_up_kind(params: Params, vehicle: str) -> list[CompileTime]:
    """Compile (and cache) the kernels of one vehicle kind on a two-step cycle, as
    :func:`hevlib.sim.simulator.warm_up` does for every kind, with numba's compile events recorded."""
    import numpy as np
    from numba.core.event import install_recorder

    from hevlib.cycles import Cycle
    from hevlib.sim.simulator import Simulator, performance_tests
    from hevlib.sizing import study_library

    sim = Simulator(study_library(params.baseline), params)
    with install_recorder("numba:compile") as recorder:
        sim.run_raw(None, Cycle("warm-up", np.arange(3.0), np.array([0.0, 1.0, 0.0]), np.zeros(3)), vehicle)
        if vehicle == "conventional":
            # then the hybrid's performance tests: the hybrid's process gets to them only after its drive kernel,
            # the longest compile, and finds them in the cache (side by side: the two processes share the work)
            performance_tests(sim.vehicle(None, "prius"))
    return compile_times(recorder.buffer)


def merged(parts: list[list[CompileTime]]) -> list[CompileTime]:
    """One table from the processes' own: times summed (compiler time, whichever process spent it),
    ``signatures`` the most any one process compiled (a helper both kinds call is compiled in both, for the
    same argument types)."""
    acc: dict[str, list] = {}
    for part in parts:
        for t in part:
            row = acc.setdefault(t.function, [0, 0.0, 0.0])
            row[0] = max(row[0], t.signatures)
            row[1] += t.total_s
            row[2] += t.self_s
    rows = [CompileTime(n, c, tot, s) for n, (c, tot, s) in acc.items()]
    return sorted(rows, key=lambda r: (-r.self_s, r.function))


def timed_warm_up(params: Params, processes: int | None = None) -> list[CompileTime]:
    """Every kind of :data:`KINDS` compiled and cached by :func:`warm_up_kind`, on up to ``processes``
    processes side by side (default: one per kind, at most the CPU count; 1: in this process, one after the
    other). The processes inherit this one's ``NUMBA_CACHE_DIR`` (:func:`hevlib.numba_cache_dir`), so they fill
    the cache every stage reads. Returns the :func:`merged` compile times."""
    n = min(len(KINDS), processes or os.cpu_count() or 1)
    if n <= 1:
        return merged([warm_up_kind(params, kind) for kind in KINDS])
    with ProcessPoolExecutor(n, mp_context=get_context("spawn")) as pool:
        return merged(list(pool.map(warm_up_kind, [params] * len(KINDS), KINDS)))


def compile_table(times: list[CompileTime], top: int = 12) -> list[str]:
    """The warm-up's compile times as text lines: the ``top`` project functions by own time, then the
    rest of the project's and numba's internals summed."""
    ours = [t for t in times if t.ours]
    lines = [f"  {'function':<52} {'sigs':>4} {'self s':>7} {'total s':>8}"]
    lines += [f"  {t.function:<52} {t.signatures:>4} {t.self_s:>7.2f} {t.total_s:>8.2f}" for t in ours[:top]]
    rest = ours[top:]
    if rest:
        lines.append(f"  {f'{len(rest)} more hevlib functions':<52} {'':>4} {sum(t.self_s for t in rest):>7.2f}")
    lib = [t for t in times if not t.ours]
    internals = f"numba and numpy internals ({len(lib)} functions)"
    lines.append(f"  {internals:<52} {'':>4} {sum(t.self_s for t in lib):>7.2f}")
    return lines
