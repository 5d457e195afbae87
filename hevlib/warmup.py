"""What ``hev warmup`` compiled and how long each function took, from numba's ``numba:compile`` events.

Kept apart from :mod:`hevlib.sim.simulator`: timing and printing the compiler are not part of the simulator,
whose source fingerprint goes into every simulated table.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from hevlib.params import Params


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


def timed_warm_up(params: Params, paper_dir: str | Path = "data/raw/paper") -> list[CompileTime]:
    """:func:`hevlib.sim.simulator.warm_up` with numba's compile events recorded: what it compiled, how long."""
    from numba.core.event import install_recorder

    from hevlib.sim.simulator import warm_up

    with install_recorder("numba:compile") as recorder:
        warm_up(params, paper_dir)
    return compile_times(recorder.buffer)


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
