"""hev-sizing: size a power-split hybrid conversion of a conventional car.

All logic lives in this package; ``stages/`` holds thin typer commands only.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from hevlib import determinism as _determinism

__version__ = "0.1.0"
#: Bumped whenever the simulator's physics change: stored with every simulated artifact.
MODEL_VERSION = "sim-5"

#: Modules compiled by numba. Its on-disk cache keys a kernel on its own file only, not on the
#: modules it calls, so the cache lives in a folder named after a hash of all of them: editing any
#: kernel module starts a fresh cache instead of silently reusing stale machine code.
_KERNEL_SOURCES = (
    "lookup.py",
    "powers.py",
    "scaling.py",
    "sim/control.py",
    "sim/drive.py",
    "sim/ecms.py",
    "sim/performance.py",
    "sim/powertrain",
)
#: Everything that changes a simulated response (kernels, responses, component data handling).
SIMULATOR_SOURCES = (
    *_KERNEL_SOURCES,
    "sim/simulator.py",
    "sim/vehicles.py",
    "components",
    "sizing.py",
    "cycles.py",
)


def source_hash(names=_KERNEL_SOURCES) -> str:
    """Short hash of the named hevlib modules (files or packages)."""
    root = Path(__file__).parent
    h = hashlib.sha256()
    for name in names:
        path = root / name
        for f in sorted(path.rglob("*.py")) if path.is_dir() else [path]:
            h.update(f.name.encode())
            h.update(f.read_bytes())
    return h.hexdigest()[:16]


if "NUMBA_CACHE_DIR" not in os.environ:
    _base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "hev-sizing" / "numba"
    os.environ["NUMBA_CACHE_DIR"] = str(_base / source_hash())


# one code path and one thread count for every numeric library on every CPU (hevlib/determinism.py): the
# variables a library reads when it loads, for those not loaded yet (`hev` re-executes itself with all of them)
_late = _determinism.pin_in_process()
if _late:
    import warnings

    warnings.warn(
        f"hevlib imported after {', '.join(_late)}: their CPU-dependent code paths are not pinned, so results may "
        "differ from another CPU's in the last digits (import hevlib first, or run through `hev`)",
        RuntimeWarning,
        stacklevel=2,
    )


def numba_cache_dir() -> str:
    """Where numba keeps the compiled kernels of this process (one folder per version of the kernel sources)."""
    return os.environ["NUMBA_CACHE_DIR"]
