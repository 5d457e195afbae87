"""One answer on CPUs of another vendor and generation: the torch primitives the BoTorch sources use, and a small
BoTorch ParEGO run and a small batch Thompson-sampling ParEGO run, give the same bytes natively and under QEMU's
user-mode emulation of an Intel Haswell and an AMD EPYC (Milan) CPU.

The emulator answers the CPUID instruction as that CPU would (vendor, model, features), and the numeric libraries
pick their code paths from it when they load, as they would on that machine; the arithmetic itself is IEEE in
software. It complements ``tests/test_cpu_kinds.py``, whose kinds are environment variables: MKL's vector math
(``torch.exp``, ``torch.sqrt``...) does not follow those, and under ``MKL_CBWR=COMPATIBLE`` it still gave other
bytes here (on an Intel Sapphire Rapids: ``torch.sqrt`` 1 ulp off on 1 332 of 100 003 values natively, on 14 487
emulated), which moved the default pipeline's ParEGO front from one machine to another. ``hevlib.determinism``
routes those functions to numpy and scipy (``VECTOR_MATH``); this test is the check that it holds.

Needs ``qemu-x86_64`` (Debian's ``qemu-user``; ``.ci/run`` installs it); about 2 min on 2 cores.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import unpinned_environ

from hevlib import determinism

QEMU = shutil.which("qemu-x86_64")
pytestmark = [pytest.mark.slow, pytest.mark.skipif(QEMU is None, reason="qemu-x86_64 (qemu-user) not installed")]
TESTS = Path(__file__).resolve().parent
#: QEMU CPU models: another generation of Intel's, and AMD's (neither has AVX-512; both AVX2 and FMA).
EMULATED = ("Haswell-v4", "EPYC-Milan-v1")

PROBE = r"""
import sys
sys.path.insert(0, sys.argv[1])
from hevlib import determinism
import hashlib, json
import numpy as np
from numpy._core._multiarray_umath import __cpu_features__

torch = determinism.torch()

def h(t):
    a = t.detach().numpy() if hasattr(t, "detach") else np.asarray(t)
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()[:12]

rng = np.random.default_rng(0)
x = torch.as_tensor(rng.uniform(-3.0, 3.0, 20_011))
p = x.abs() + 1e-3
u = torch.as_tensor(rng.uniform(-0.999, 0.999, 20_011))
A = torch.as_tensor(rng.standard_normal((11, 37, 37)))
M = A @ A.transpose(1, 2) + 37.0 * torch.eye(37, dtype=torch.float64)
L = torch.linalg.cholesky(M)
B = torch.as_tensor(rng.standard_normal((11, 37, 5)))
out = {
    "vector_math": h(torch.stack([torch.exp(x), torch.log(p), torch.sqrt(p), torch.tanh(x), torch.erf(x),
                                  torch.erfc(x), torch.erfinv(u), torch.sin(x), torch.cos(x), torch.log10(p)])),
    "other_unary": h(torch.stack([torch.expm1(x), torch.log1p(p), torch.sigmoid(x), torch.special.log_ndtr(x),
                                  torch.special.ndtr(x), torch.nn.functional.softplus(x), p.pow(0.3)])),
    "matmul": h(A @ A.transpose(1, 2)), "cholesky": h(L), "cdist": h(torch.cdist(A[..., :7], A[..., :7])),
    "triangular": h(torch.linalg.solve_triangular(L, B, upper=False)), "cholesky_solve": h(torch.cholesky_solve(B, L)),
    "reductions": h(torch.stack([x.sum(), x.mean(), torch.logsumexp(x, 0), x.std()])),
}
g = torch.Generator().manual_seed(7)
out["random"] = h(torch.cat([torch.randn(1000, generator=g, dtype=torch.float64),
                             torch.empty(1000, dtype=torch.float64).exponential_(generator=g),
                             torch.multinomial(p[:500], 50, generator=g).double()]))
y = x[:64].clone().requires_grad_(True)
(torch.exp(y).sum() + torch.sqrt(y.abs() + 1).sum() + torch.erfc(y).sum()).backward()
out["gradient"] = h(y.grad)
if "bo" in sys.argv:  # a whole BoTorch ParEGO loop (GP fits, qLogNParEGO, the mixed optimiser) on a stand-in model
    sys.path.insert(0, sys.argv[2])
    import test_bayesopt
    run = test_bayesopt._run("parego", seed=1, budget=23)
    out["parego_designs"] = h(run.X)
    import test_tsparego  # batch Thompson-sampling ParEGO: fits, pathwise samples, picks (one round of 10)
    out["tsparego_designs"] = h(test_tsparego._run(3, budget=40).X)
out["cpu"] = {k: bool(__cpu_features__.get(k)) for k in ("AVX2", "FMA3", "AVX512F")}
out["routed"] = determinism.vector_math_routed()
out["problems"] = determinism.check()
print(json.dumps(out))
"""


def _env() -> dict[str, str]:
    """Pinned, without anything a CPU kind of ``test_cpu_kinds`` sets; the re-execution guard set, so that the
    probe never re-executes (QEMU user mode would run the new image natively)."""
    return {**determinism.pinned_environ(unpinned_environ()), "HEV_PINNED_EXEC": "1"}


def _start(script: Path, cpu: str | None, *extra: str) -> subprocess.Popen:
    cmd = [sys.executable, str(script), str(TESTS.parent), str(TESTS), *extra]
    if cpu is not None:
        cmd = [QEMU, "-cpu", cpu, *cmd]
    return subprocess.Popen(cmd, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _result(proc: subprocess.Popen) -> dict:
    stdout, stderr = proc.communicate(timeout=1500)
    assert proc.returncode == 0, stderr[-3000:]
    return json.loads(stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def probes(tmp_path_factory) -> dict[str, dict]:
    script = tmp_path_factory.mktemp("probe") / "probe.py"
    script.write_text(PROBE)
    procs = {cpu or "native": _start(script, cpu, "bo") for cpu in (None, *EMULATED)}  # side by side
    return {name: _result(proc) for name, proc in procs.items()}


def test_the_emulated_cpus_are_what_the_libraries_see(probes):
    """Neither emulated CPU has AVX-512: whatever the host has, numpy reads the emulated CPUID."""
    for cpu in EMULATED:
        assert probes[cpu]["cpu"] == {"AVX2": True, "FMA3": True, "AVX512F": False}, cpu


def test_torch_and_a_botorch_run_give_the_same_bytes_on_other_vendors_cpus(probes):
    native = probes["native"]
    assert native["routed"] and native["problems"] == []
    for cpu in EMULATED:
        differ = sorted(k for k in native if k not in ("cpu", "problems") and probes[cpu][k] != native[k])
        assert not differ, f"{cpu}: {differ} differ from the native bytes"
