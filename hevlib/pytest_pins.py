"""pytest plugin: the test suite runs under the pins every ``hev`` command runs under (:mod:`hevlib.determinism`).

Loaded first (``-p hevlib.pytest_pins`` in ``pyproject.toml``'s ``addopts``, before pytest captures output or
imports a conftest). Importing :mod:`hevlib` pins what it can in-process, but glibc's libm (which numba's kernels
and torch's default ATen path call) and Python's hash seed are read only when a process starts: without them a
test that follows a search (BoTorch, NSGA-III) took another path on another CPU. So the ``pytest`` command
re-executes itself once, under every pin (``python -m pytest`` too); ``pytest.main()`` inside another program is
left alone, and ``HEV_NATIVE_CPU=1`` switches the pins off.
"""

from __future__ import annotations

import sys
from pathlib import Path

from hevlib import determinism

if Path(sys.argv[0]).name in ("pytest", "py.test", "__main__.py"):
    determinism.ensure_pinned(sys.orig_argv[1:])
