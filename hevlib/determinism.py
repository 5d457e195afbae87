"""One answer on every x86-64 CPU: the numeric libraries pinned to one code path and one thread count.

Each library below picks, at load time, the fastest code its CPU offers, and those paths round differently.
Round-off alone is harmless, but the searches amplify it: on an AVX-512 machine the BNN's weights differed from
the 12th digit and the recommended design changed (issue 36). What depends on the CPU, and how it is pinned
(each measured on the primitives the project uses, ``tests/test_determinism.py``; the fast pipeline end to end
under two emulated CPU kinds, ``tests/test_cpu_kinds.py``):

=====================  ==========================================  ==============================================
library                what changes with the CPU                   pinned to
=====================  ==========================================  ==============================================
numpy                  SIMD kernels of exp, log, power, tanh (AVX2  the baseline build (``NPY_DISABLE_CPU_FEATURES``:
                       and AVX-512 polynomials, SVML) and of sort   every dispatched target off), which every CPU
                       (tie order of ``argsort``)                   numpy runs on executes alike
OpenBLAS (numpy's and  the kernel (SkylakeX, Haswell, Zen...):      ``OPENBLAS_CORETYPE=Nehalem`` (SSE kernels every
scipy's)               ``@``, solve, inv, eigvalsh, lstsq; the      x86-64-v2 CPU runs) and one thread
                       thread count (split dot products)
torch (ATen, MKL)      ATen's vector width, MKL's code path and     ``ATEN_CPU_CAPABILITY=default``,
                       both thread pools; MKL's vector math         ``MKL_CBWR=COMPATIBLE``, one thread; the
                       (``exp``, ``sqrt``, ``erfinv``...), which    vector math runs numpy's and scipy's
                       ``MKL_CBWR`` does not fix                    code (:func:`torch`, :data:`VECTOR_MATH`)
glibc's libm           ``exp``, ``log``, ``pow``, ``sin``... have   ``GLIBC_TUNABLES=glibc.cpu.hwcaps=-FMA,-FMA4``:
                       FMA variants chosen per CPU; numba's         the SSE2 variants on every CPU
                       kernels and numpy's baseline call them
Python                 string hashing (pymoo's resumed NSGA-III)    ``PYTHONHASHSEED=1``
BoTorch                qLog(N)EHVI's fused C++ kernel, compiled at  its pure-PyTorch path (:func:`botorch_logei`):
                       run time with ``-march=native`` where a      the fused and pure values differ by up to
                       compiler and ninja are found                 9e-16, so ``nehvi`` took the machine's path
=====================  ==========================================  ==============================================

Left free, because it does not change a result: numba's target CPU (no fast-math anywhere, so LLVM neither
contracts to FMA nor reorders a sum; ``NUMBA_CPU_NAME=haswell`` gives the same bytes) and its thread count (the
kernels write disjoint rows), Dask's workers (they inherit this environment).

:data:`PINNED` is set in one place: the ``hev`` entry point re-executes itself with it (:func:`ensure_pinned`,
``stages/cli.py``), which is the only way the loader's ``GLIBC_TUNABLES`` and Python's hash seed take effect.
Importing :mod:`hevlib` also sets the variables a library reads when it loads (:func:`pin_in_process`), for
libraries not loaded yet: tests, notebooks and scripts then get every pin but glibc's and the hash seed's.
``HEV_NATIVE_CPU=1`` switches every pin off (each library's fastest path; results then depend on the CPU).
"""

from __future__ import annotations

import ctypes
import functools
import glob
import os
import sys
from collections.abc import Mapping, Sequence

#: numpy's dispatched targets (numpy 2.4 on x86-64: ``__cpu_dispatch__``); all off leaves its baseline (X86_V2).
NUMPY_DISPATCH_OFF = "X86_V3 X86_V4 AVX512_ICL AVX512_SPR"
#: OpenBLAS's kernel set for every x86-64-v2 CPU (SSE2/SSE3/SSSE3 kernels).
OPENBLAS_CORE = "Nehalem"
#: glibc's libm without its FMA (and AMD FMA4) variants.
GLIBC_HWCAPS = "glibc.cpu.hwcaps=-FMA,-FMA4"
#: Every variable pinned, with its value. Thread counts are 1: a fixed count is what reproducibility needs, and
#: one is what the small matrices here run fastest on beside numba's simulator threads.
PINNED: dict[str, str] = {
    "PYTHONHASHSEED": "1",
    "NPY_DISABLE_CPU_FEATURES": NUMPY_DISPATCH_OFF,
    "OPENBLAS_CORETYPE": OPENBLAS_CORE,
    "OPENBLAS_NUM_THREADS": "1",
    "ATEN_CPU_CAPABILITY": "default",
    "MKL_CBWR": "COMPATIBLE",
    "MKL_NUM_THREADS": "1",
    "GLIBC_TUNABLES": GLIBC_HWCAPS,
}
#: The variables read only when a process starts (the dynamic loader, the interpreter): re-execution needed.
AT_EXEC = ("PYTHONHASHSEED", "GLIBC_TUNABLES")
#: Which library reads which variable when it loads (the in-process pin is only possible before that).
READ_BY: dict[str, tuple[str, ...]] = {
    "NPY_DISABLE_CPU_FEATURES": ("numpy",),
    "OPENBLAS_CORETYPE": ("numpy", "scipy"),
    "OPENBLAS_NUM_THREADS": ("numpy", "scipy"),
    "ATEN_CPU_CAPABILITY": ("torch",),
    "MKL_CBWR": ("torch",),
    "MKL_NUM_THREADS": ("torch",),
}
OFF_SWITCH = "HEV_NATIVE_CPU"
#: Set in a re-executed process, so that a pin the environment does not keep cannot loop.
_REEXECUTED = "HEV_PINNED_EXEC"


def disabled(env: Mapping[str, str] | None = None) -> bool:
    """Whether the user switched the pins off (``HEV_NATIVE_CPU=1``)."""
    return (os.environ if env is None else env).get(OFF_SWITCH, "") not in ("", "0")


def _tunables(existing: str | None) -> str:
    """``GLIBC_TUNABLES`` with glibc's hwcaps pinned and every other tunable of ``existing`` kept."""
    kept = [t for t in (existing or "").split(":") if t and not t.startswith("glibc.cpu.hwcaps=")]
    return ":".join([*kept, GLIBC_HWCAPS])


def pinned_environ(env: Mapping[str, str]) -> dict[str, str]:
    """``env`` with :data:`PINNED` applied (other glibc tunables kept); unchanged when the pins are off."""
    out = dict(env)
    if disabled(env):
        return out
    out.update(PINNED)
    out["GLIBC_TUNABLES"] = _tunables(env.get("GLIBC_TUNABLES"))
    return out


def is_pinned(env: Mapping[str, str] | None = None) -> bool:
    """Whether ``env`` (default: this process's) already carries every pin (or the pins are off)."""
    env = os.environ if env is None else env
    return all(env.get(k) == v for k, v in pinned_environ(env).items() if k in PINNED)


def ensure_pinned(argv: Sequence[str]) -> None:
    """Re-execute this process as ``argv`` under the pinned environment, unless it already runs under it.

    Call first thing in an entry point (``hev``, the benchmark scripts): the loader reads ``GLIBC_TUNABLES``
    and Python ``PYTHONHASHSEED`` only at start."""
    if is_pinned() or os.environ.get(_REEXECUTED):
        return
    sys.stdout.flush()
    sys.stderr.flush()
    os.execve(sys.executable, [sys.executable, *argv], {**pinned_environ(os.environ), _REEXECUTED: "1"})


def pin_in_process() -> list[str]:
    """Set each pinned variable whose library is not loaded yet (called when :mod:`hevlib` is imported);
    returns the libraries already loaded whose pins came too late (empty when every pin is in effect but
    those needing re-execution). Does nothing when the pins are off."""
    if disabled():
        return []
    late = set()
    for name, value in PINNED.items():
        if name in AT_EXEC:
            continue
        loaded = [lib for lib in READ_BY[name] if lib in sys.modules]
        if os.environ.get(name) == value:
            continue
        if loaded:
            late.update(loaded)
        else:
            os.environ[name] = value
    return sorted(late)


@functools.cache
def torch():
    """The ``torch`` module with one intra- and inter-op thread (its OpenMP pool otherwise follows whatever
    count another library's OpenMP, numba's, set first). Import torch through this."""
    import torch as _torch

    if not disabled():
        _torch.set_num_threads(1)
        try:
            _torch.set_num_interop_threads(1)
        except RuntimeError:  # already set, or parallel work already started: the intra-op count is what rounds
            pass
        _route_vector_math(_torch)
    return _torch


@functools.cache
def botorch_logei():
    """BoTorch's ``acquisition.multi_objective.logei`` module with its fused C++ kernel off: import
    qLogNoisyExpectedHypervolumeImprovement through this. BoTorch 0.18 builds ``csrc/logei_fused.cpp`` with
    ``-O3 -march=native`` into ``~/.cache/torch_extensions`` the first time such an acquisition is made, wherever a
    compiler and ninja are found, and runs the pure-PyTorch path elsewhere: machine-specific SIMD code on one
    machine, another rounding on the next (and a process killed mid-compile leaves a lock every later run waits on
    for ever). Marking the load as attempted with no module keeps every machine on the pure path."""
    torch()  # the pins of torch itself first
    from botorch.acquisition.multi_objective import logei

    if not disabled():
        logei._load_attempted = True
        logei._C = None
    return logei


# ------------------------------------------------------------------------- torch's vector math (MKL VM)
#: The elementwise functions ATen hands to MKL's vector math (``aten/src/ATen/cpu/vml.h``: ``vmdExp``... in high
#: accuracy mode) for every contiguous or buffered float tensor, and the numpy / scipy function each is routed to
#: instead. ``MKL_CBWR=COMPATIBLE`` pins MKL's BLAS and LAPACK but not these: ``torch.sqrt`` is not even correctly
#: rounded (1 332 of 100 003 values 1 ulp off on an Intel Sapphire Rapids; 14 487 under an emulated Haswell or
#: EPYC, whose matmul, Cholesky and triangular solves gave the native bytes), and the BoTorch ParEGO source's
#: third round picked other designs on such a machine than on the one that made the committed bytes. numpy's
#: baseline loops and scipy's special functions run the same instructions on every CPU and call glibc's libm
#: (pinned above) or IEEE ``sqrt``. Which ops: those whose bytes change with ``MKL_CBWR`` (AVX2, AVX512 against
#: COMPATIBLE), ``tests/test_determinism.py``.
VECTOR_MATH: dict[str, tuple[str, str]] = {
    "exp": ("numpy", "exp"),
    "log": ("numpy", "log"),
    "log2": ("numpy", "log2"),
    "log10": ("numpy", "log10"),
    "sqrt": ("numpy", "sqrt"),
    "tanh": ("numpy", "tanh"),
    "sin": ("numpy", "sin"),
    "cos": ("numpy", "cos"),
    "tan": ("numpy", "tan"),
    "asin": ("numpy", "arcsin"),
    "acos": ("numpy", "arccos"),
    "atan": ("numpy", "arctan"),
    "erf": ("scipy.special", "erf"),
    "erfc": ("scipy.special", "erfc"),
    "erfinv": ("scipy.special", "erfinv"),
}
_ROUTED: list = []  # the torch.library registrations (kept alive: dropping one restores ATen's kernel)


def _numpy_kernels(torch_mod, fn):
    """ATen CPU kernels (functional, in place, out) computing ``fn`` (a numpy ufunc) on a tensor's values."""
    import numpy as np

    def compute(x):
        if not (x.is_floating_point() or x.is_complex()):
            x = x.to(torch_mod.get_default_dtype())  # ATen's promotion of integer inputs
        wide = x.dtype in (torch_mod.float16, torch_mod.bfloat16)  # computed in float32, as ATen does
        a = (x.float() if wide else x).detach().contiguous().numpy()
        with np.errstate(all="ignore"):  # ATen's kernels return nan / inf silently
            y = torch_mod.from_numpy(np.asarray(fn(a)).reshape(a.shape))
        return y.to(x.dtype) if wide else y

    def functional(x):
        y = compute(x)
        if x.is_contiguous():
            return y
        strided = torch_mod.empty_like(x, dtype=y.dtype)  # ATen's output keeps the input's layout
        return strided.copy_(y)

    def inplace(x):
        x.copy_(compute(x))
        return x

    def out(x, *, out):
        y = compute(x)
        if out.shape != y.shape:
            out.resize_(y.shape)
        out.copy_(y)
        return out

    return functional, inplace, out


def _route_vector_math(torch_mod) -> None:
    """Register :data:`VECTOR_MATH` as the CPU kernels of those ATen ops (once per process); autograd's formulas
    are untouched (they sit above the CPU kernel and call these ops through the dispatcher)."""
    if _ROUTED:
        return
    import importlib
    import warnings

    lib = torch_mod.library.Library("aten", "IMPL")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "Overriding a previously registered kernel": intended
        for op, (module, name) in VECTOR_MATH.items():
            functional, inplace, out = _numpy_kernels(torch_mod, getattr(importlib.import_module(module), name))
            lib.impl(op, functional, "CPU")
            lib.impl(f"{op}_", inplace, "CPU")
            lib.impl(f"{op}.out", out, "CPU")
    _ROUTED.append(lib)


def vector_math_routed() -> bool:
    """Whether torch's vector math runs through numpy / scipy in this process (:data:`VECTOR_MATH`)."""
    return bool(_ROUTED)


# ------------------------------------------------------------------------------------------- status
def _openblas_corenames() -> dict[str, str]:
    """The kernel name of every OpenBLAS that numpy and scipy bundle (loading them if needed)."""
    import numpy as np

    out = {}
    for pkg, mod in (("numpy", np), ("scipy", None)):
        if mod is None:
            try:
                import scipy as mod
            except ImportError:  # pragma: no cover - scipy is a dependency
                continue
        libs = os.path.join(os.path.dirname(os.path.dirname(mod.__file__)), f"{pkg}.libs")
        for path in sorted(glob.glob(os.path.join(libs, "*openblas*"))):
            lib = ctypes.CDLL(path)
            for sym in ("scipy_openblas_get_corename64_", "scipy_openblas_get_corename", "openblas_get_corename"):
                fn = getattr(lib, sym, None)
                if fn is not None:
                    fn.restype = ctypes.c_char_p
                    out[pkg] = fn().decode()
                    break
    return out


def status() -> dict[str, str]:
    """What is in effect in this process: numpy's dispatched targets, OpenBLAS's kernels, torch's capability
    and threads (when loaded), glibc's tunables, the hash seed. For ``hev warmup``'s report and the tests."""
    import numpy as np
    from numpy._core._multiarray_umath import __cpu_baseline__, __cpu_dispatch__, __cpu_features__

    on = [t for t in __cpu_dispatch__ if __cpu_features__.get(t)]
    out = {
        "pins": "off (HEV_NATIVE_CPU)" if disabled() else "on",
        "numpy": f"{np.__version__}: baseline {' '.join(__cpu_baseline__)}, dispatched {' '.join(on) or 'none'}",
        **{f"openblas ({k})": f"kernel {v}" for k, v in _openblas_corenames().items()},
        "glibc tunables": os.environ.get("GLIBC_TUNABLES", "(none)"),
        "PYTHONHASHSEED": os.environ.get("PYTHONHASHSEED", "(random)"),
    }
    if "torch" in sys.modules:
        t = sys.modules["torch"]
        out["torch"] = f"{t.backends.cpu.get_cpu_capability()}, {t.get_num_threads()} thread(s)"
        routed = f"numpy / scipy ({len(VECTOR_MATH)} functions)" if vector_math_routed() else "MKL"
        out["torch vector math"] = routed
    logei = sys.modules.get("botorch.acquisition.multi_objective.logei")
    if logei is not None:
        fused = getattr(logei, "_C", None) is not None
        out["botorch qLogNEHVI"] = "fused C++ kernel (loaded)" if fused else "pure PyTorch path"
    return out


def check() -> list[str]:
    """Problems: each pin that is not in effect in this process (empty when all are, or when switched off)."""
    if disabled():
        return []
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__

    problems = []
    if any(__cpu_features__.get(t) for t in __cpu_dispatch__):
        problems.append("numpy: dispatched SIMD targets are on (numpy was imported before hevlib)")
    for pkg, core in _openblas_corenames().items():
        if core != OPENBLAS_CORE:
            problems.append(f"openblas ({pkg}): kernel {core}, not {OPENBLAS_CORE}")
    for name in AT_EXEC:
        if os.environ.get(name) != pinned_environ(os.environ)[name]:
            problems.append(f"{name} not set at start: run through `hev` (or hevlib.determinism.ensure_pinned)")
    if "torch" in sys.modules:
        t = sys.modules["torch"]
        if t.backends.cpu.get_cpu_capability() != "DEFAULT":
            problems.append(f"torch: capability {t.backends.cpu.get_cpu_capability()}, not DEFAULT")
        if not vector_math_routed():
            problems.append("torch: exp, log, sqrt... on MKL's vector math (import it through determinism.torch)")
    logei = sys.modules.get("botorch.acquisition.multi_objective.logei")
    if logei is not None and getattr(logei, "_C", None) is not None:
        problems.append("botorch: qLogNEHVI's fused C++ kernel is loaded (import it through determinism.botorch_logei)")
    return problems


__all__ = [
    "AT_EXEC",
    "OFF_SWITCH",
    "PINNED",
    "VECTOR_MATH",
    "botorch_logei",
    "check",
    "disabled",
    "ensure_pinned",
    "is_pinned",
    "pin_in_process",
    "pinned_environ",
    "status",
    "torch",
    "vector_math_routed",
]
