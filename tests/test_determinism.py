"""The pins of ``hevlib.determinism``: the numeric primitives the project uses give the same bytes under two
emulated CPU kinds once pinned, and different bytes without the pins (so the emulation is real); the environment
is merged, not clobbered; the ``hev`` entry point runs every command pinned."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from conftest import CPU_KINDS, unpinned_environ

from hevlib import determinism

#: Hashes of the primitives whose rounding depends on the CPU: numpy's transcendental functions and sort, BLAS and
#: LAPACK through numpy and scipy, torch (MKL, ATen) and numba's compiled code (which calls glibc's libm).
PROBE = r"""
import sys
from hevlib import determinism
if "pin" in sys.argv:
    determinism.ensure_pinned(sys.argv)
import hashlib, json, math
import numpy as np, scipy.linalg
import numba

def h(a):
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()[:12]

rng = np.random.default_rng(0)
x = rng.uniform(-3.0, 3.0, 100_003)
p = rng.uniform(0.01, 5.0, 100_003)
A = rng.standard_normal((22, 300, 73))
M = A.transpose(0, 2, 1) @ A + np.eye(73)
out = {
    "tanh": h(np.tanh(x)), "exp": h(np.exp(x)), "log": h(np.log(p)), "power": h(np.power(p, 0.3)),
    "argsort_ties": h(np.argsort(np.round(x, 1))), "matmul": h(M), "dot": h(x @ x),
    "solve": h(np.linalg.solve(M, A[:, :73, :1])), "inv": h(np.linalg.inv(M)), "eigvalsh": h(np.linalg.eigvalsh(M)),
    "lstsq": h(np.linalg.lstsq(A[0], x[:300], rcond=None)[0]), "scipy_cho": h(scipy.linalg.cho_factor(M[0])[0]),
    "math_pow": h(np.array([math.pow(v, 0.3) for v in p[:20000]])),
}

@numba.njit(cache=False)
def kernel(x, p):
    o = np.empty_like(x)
    for i in range(x.size):
        o[i] = math.exp(x[i]) * p[i] ** 0.3 + math.tanh(x[i]) + math.log(p[i])
    return o

out["numba"] = h(kernel(x, p))
torch = determinism.torch()
t = torch.as_tensor(A)
out["torch_mm"] = h((t.transpose(1, 2) @ t).numpy())
out["torch_cdist"] = h(torch.cdist(t[:, :60, :7], t[:, :60, :7]).numpy())
out["torch_cholesky"] = h(torch.linalg.cholesky(torch.as_tensor(M)).numpy())
out["torch_sum_exp"] = h(torch.exp(torch.as_tensor(x)).sum().numpy())
out["torch_vector_math"] = h(torch.stack([torch.sqrt(torch.as_tensor(p)), torch.erfinv(torch.as_tensor(x) / 3.1),
                                          torch.erfc(torch.as_tensor(x)), torch.log(torch.as_tensor(p))]).numpy())
out["problems"] = determinism.check()
print(json.dumps(out))
"""


def _probe(script, kind: dict[str, str], pinned: bool) -> dict:
    env = {**unpinned_environ(), **kind}
    if not pinned:
        env[determinism.OFF_SWITCH] = "1"
    args = [sys.executable, str(script), *(["pin"] if pinned else [])]
    out = subprocess.run(args, env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def probes(tmp_path_factory) -> dict[tuple[str, bool], dict]:
    script = tmp_path_factory.mktemp("probe") / "probe.py"
    script.write_text(PROBE)
    return {
        (name, pinned): _probe(script, kind, pinned) for name, kind in CPU_KINDS.items() for pinned in (True, False)
    }


def test_pinned_primitives_give_the_same_bytes_on_both_cpu_kinds(probes):
    a, b = (probes[(name, True)] for name in CPU_KINDS)
    assert a["problems"] == [] and b["problems"] == []
    assert {k for k in a if a[k] != b[k]} == set()


def _host_has_avx512() -> bool:
    """Whether this CPU has AVX-512 (Linux's /proc/cpuinfo flags)."""
    try:
        with open("/proc/cpuinfo") as f:
            return any(line.startswith("flags") and " avx512f" in line for line in f)
    except OSError:
        return False


def test_without_the_pins_the_emulated_kinds_round_differently(probes):
    """The emulation is real: what the ``avx2_nofma`` kind changes on every host changes bytes unpinned (glibc's
    libm without FMA under numpy's and numba's kernels); on an AVX-512 host its AVX2 ceiling changes numpy's sort,
    BLAS and LAPACK (under torch too). A host without AVX-512 (an AMD Zen 2) already runs those at the AVX2 level, so
    there the kind cannot change them, and the test asks only what the kind itself guarantees."""
    a, b = (probes[(name, False)] for name in CPU_KINDS)
    differ = {k for k in a if k != "problems" and a[k] != b[k]}
    assert {"exp", "log", "power", "math_pow", "numba"} <= differ
    if _host_has_avx512():
        assert {"argsort_ties", "matmul", "solve", "torch_cholesky"} <= differ
    assert probes[("host", False)]["problems"] == []  # switched off: nothing is claimed


def test_pinned_environment_keeps_other_glibc_tunables_and_is_idempotent():
    env = {"GLIBC_TUNABLES": "glibc.malloc.check=3:glibc.cpu.hwcaps=-AVX2", "OPENBLAS_NUM_THREADS": "8"}
    pinned = determinism.pinned_environ(env)
    assert pinned["GLIBC_TUNABLES"] == f"glibc.malloc.check=3:{determinism.GLIBC_HWCAPS}"
    assert pinned["OPENBLAS_NUM_THREADS"] == "1" and pinned["PYTHONHASHSEED"] == "1"
    assert determinism.pinned_environ(pinned) == pinned and determinism.is_pinned(pinned)
    assert not determinism.is_pinned(env)
    off = {**env, determinism.OFF_SWITCH: "1"}
    assert determinism.pinned_environ(off) == off and determinism.is_pinned(off)


def test_the_hev_entry_point_runs_every_command_pinned():
    """`hev` re-executes itself under the pins: `hev platform` sees every one in effect (glibc's and the hash
    seed's included, which no in-process setting can give) and says so."""
    hev = os.path.join(os.path.dirname(sys.executable), "hev")
    out = subprocess.run([hev, "platform"], env=unpinned_environ(), capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "every pin in effect" in out.stdout and f"kernel {determinism.OPENBLAS_CORE}" in out.stdout
    off = subprocess.run(
        [hev, "platform"], env={**unpinned_environ(), determinism.OFF_SWITCH: "1"}, capture_output=True, text=True
    )
    assert off.returncode == 0 and "off" in off.stdout


def test_torchs_vector_math_runs_numpys_and_scipys_code():
    """Every function of ``VECTOR_MATH`` (MKL's vector math in ATen) gives numpy's or scipy's bytes, in its
    functional, in-place and ``out=`` forms, on strided and 0-d tensors; float32 stays float32, integers are
    promoted as ATen does; autograd's formulas still apply."""
    import importlib

    import numpy as np

    if determinism.disabled():
        pytest.skip("pins switched off")
    torch = determinism.torch()
    assert determinism.vector_math_routed()
    rng = np.random.default_rng(3)
    x = rng.uniform(0.001, 0.999, 4_099)
    for op, (module, name) in determinism.VECTOR_MATH.items():
        ref = getattr(importlib.import_module(module), name)
        fn = getattr(torch, op)
        t = torch.as_tensor(x)
        assert fn(t).numpy().tobytes() == ref(x).tobytes(), op
        inplace = t.clone()
        getattr(inplace, f"{op}_")()
        assert inplace.numpy().tobytes() == ref(x).tobytes(), op
        out = torch.empty(0, dtype=torch.float64)
        fn(t, out=out)
        assert out.numpy().tobytes() == ref(x).tobytes(), op
        m = torch.as_tensor(x[:12].reshape(3, 4)).T  # strided: the output keeps the input's layout
        assert fn(m).stride() == m.stride() and np.array_equal(fn(m).numpy(), ref(x[:12].reshape(3, 4)).T), op
        assert fn(torch.tensor(0.5, dtype=torch.float64)).shape == ()
        assert fn(torch.as_tensor(x[:9], dtype=torch.float32)).dtype == torch.float32
    assert torch.sqrt(torch.tensor([4, 9])).tolist() == [2.0, 3.0]
    y = torch.as_tensor(x[:50]).requires_grad_(True)
    torch.sqrt(y).sum().backward()
    assert torch.allclose(y.grad, 0.5 / torch.as_tensor(np.sqrt(x[:50])), rtol=1e-15, atol=0)


#: torch's unary float ops, each evaluated on one set of arguments in its domain, unrouted (torch imported directly).
UNARY_PROBE = r"""
import hashlib, json
import numpy as np, torch
torch.set_num_threads(1)
rng = np.random.default_rng(0)
x = torch.as_tensor(rng.uniform(-0.99, 0.99, 10_007))
pos = x.abs() + 1e-3
arg = {"acosh": x.abs() + 1.0, "log": pos, "log10": pos, "log2": pos, "sqrt": pos, "rsqrt": pos, "lgamma": pos,
       "digamma": pos}
names = ["exp", "exp2", "expm1", "log", "log2", "log10", "log1p", "sqrt", "rsqrt", "tanh", "sinh", "cosh", "sin",
         "cos", "tan", "asin", "acos", "atan", "asinh", "acosh", "atanh", "erf", "erfc", "erfinv", "sigmoid",
         "reciprocal", "lgamma", "digamma", "i0"]
print(json.dumps({n: hashlib.sha256(getattr(torch, n)(arg.get(n, x)).numpy().tobytes()).hexdigest() for n in names}))
"""


def test_every_unary_op_whose_bytes_follow_mkls_branch_is_routed(tmp_path):
    """The ops of ``VECTOR_MATH`` are exactly those MKL computes: an op outside it whose bytes change between MKL's
    COMPATIBLE branch and the one it picks for this CPU (AUTO) would be a CPU-dependent path left open."""
    script = tmp_path / "unary.py"
    script.write_text(UNARY_PROBE)

    def run(branch: str) -> dict:
        env = {**unpinned_environ(), "MKL_CBWR": branch, "ATEN_CPU_CAPABILITY": "default", determinism.OFF_SWITCH: "1"}
        out = subprocess.run([sys.executable, str(script)], env=env, capture_output=True, text=True, timeout=300)
        assert out.returncode == 0, out.stderr[-3000:]
        return json.loads(out.stdout.strip().splitlines()[-1])

    compatible, auto = run("COMPATIBLE"), run("AUTO")
    moved = {n for n in compatible if compatible[n] != auto[n]}
    assert moved <= set(determinism.VECTOR_MATH), sorted(moved - set(determinism.VECTOR_MATH))


def test_botorchs_fused_nehvi_kernel_is_never_compiled(tmp_path, monkeypatch):
    """BoTorch 0.18 compiles qLog(N)EHVI's fused C++ kernel with ``-march=native`` the first time such an acquisition
    is built (where a compiler and ninja are found): made through ``determinism.botorch_logei`` it runs the
    pure-PyTorch path on every machine, compiles nothing, and ``check`` flags a fused kernel loaded behind its back."""
    if determinism.disabled():
        pytest.skip("pins switched off")
    monkeypatch.setenv("TORCH_EXTENSIONS_DIR", str(tmp_path))
    torch = determinism.torch()
    logei = determinism.botorch_logei()
    from botorch.models import SingleTaskGP

    X = torch.rand(8, 3, dtype=torch.float64, generator=torch.Generator().manual_seed(0))
    Y = torch.stack([X.sum(-1), (1 - X).prod(-1)], dim=-1)
    acq = logei.qLogNoisyExpectedHypervolumeImprovement(
        SingleTaskGP(X, Y), ref_point=[0.0, 0.0], X_baseline=X, prune_baseline=False
    )
    value = acq(X[:2].unsqueeze(1))
    assert value.shape == (2,) and torch.isfinite(value).all()
    assert logei._C is None and logei._load_attempted
    assert not list(tmp_path.iterdir()), "a torch extension was built"
    assert not [p for p in determinism.check() if p.startswith("botorch")]
    assert determinism.status()["botorch qLogNEHVI"] == "pure PyTorch path"  # what `hev platform` prints
    monkeypatch.setattr(logei, "_C", object())
    assert [p for p in determinism.check() if p.startswith("botorch")]
    assert determinism.status()["botorch qLogNEHVI"].startswith("fused")


def test_every_log_ehvi_acquisition_comes_through_the_pin():
    """No module of the project imports BoTorch's qLog(N)EHVI (whose construction compiles the fused kernel) but
    through ``determinism.botorch_logei``: an import of its own would build the acquisition on whichever path the
    machine has when it runs before any call of the pin."""
    import re
    from pathlib import Path

    root = Path(determinism.__file__).resolve().parents[1]
    pattern = re.compile(r"^\s*(from|import)\s.*(multi_objective\.logei|multi_objective import .*logei|qLog\w*EHVI|"
                         r"qLog\w*HypervolumeImprovement)", re.M)  # fmt: skip
    offenders = [
        str(p.relative_to(root))
        for folder in ("hevlib", "stages", "benchmarks")
        for p in (root / folder).rglob("*.py")
        if p.name != "determinism.py" and ".venv" not in p.parts and pattern.search(p.read_text())
    ]
    assert not offenders, offenders
