"""``x ** 0.3`` for the thermal model's natural convection, from IEEE add, multiply and integer operations only.

The air-side coefficients (:mod:`hevlib.sim.powertrain.thermal`) take six powers ``(|dT| / 1000) ** 0.3`` per
thermal sub-step; through libm's general ``pow`` (a call, then extra-precise arithmetic for its last bit) they
were the largest single item of the FTP kernel's profile (about a quarter of its samples). This one is
specialised to the exponent 3/10: ``x = 2^e m`` with ``m`` in [1, 2); ``e = 10 q + s`` so that
``2^(0.3 e) = 2^(3 q) 2^(0.3 s)`` (``2^(3 q)`` exact); ``m = c_j (1 + r)`` with ``c_j`` the centre of ``m``'s
1/128-wide bracket ``j`` (``|r| < 1/256``); then ``x^0.3 = 2^(3 q) T[s, j] (1 + r)^0.3`` with
``T[s, j] = 2^(0.3 s) c_j^0.3`` tabulated (correctly rounded, from :mod:`decimal`) and the binomial series to
``r^6`` (truncation below 1e-18 relative). Within 1.5 ulp of the exact power (``tests/test_powers.py``). libm's
``x ** 0.3`` raises to the double nearest 0.3, which differs from 3/10 by 1.1e-17: a relative difference of
``1.1e-17 |ln x|``, below an ulp for every ``x`` the model meets.

Every operation is an IEEE-754 double add, subtract or multiply, rounded to nearest, none fused (numba compiles
without fast-math: LLVM neither contracts to FMA nor reorders), plus integer bit operations and table loads:
the same bits on every x86-64 CPU, with or without FMA or AVX-512, inlined where it is called. Zero and
subnormal arguments are scaled into the normal range (exactly); infinity and NaN return themselves.
"""

from __future__ import annotations

from decimal import Decimal, localcontext

import numpy as np
from numba import njit, types
from numba.extending import intrinsic

N_BRACKET = 128  # brackets of the mantissa: |r| < 1 / (2 N_BRACKET)
_SHIFT = 52 - 7  # the mantissa's top 7 bits index the bracket
EXPONENT = Decimal(3) / 10


def _binomial(k: int) -> float:
    """``C(3/10, k)``, the coefficient of ``r^k`` in ``(1 + r)^0.3``, correctly rounded."""
    c = Decimal(1)
    for i in range(k):
        c = c * (EXPONENT - i) / (i + 1)
    return float(c)


A1, A2, A3, A4, A5, A6 = (_binomial(k) for k in range(1, 7))
E_OFFSET = 1030 - 1023  # biased exponent + this = e + 1030 = 10 (q + 103) + s, non-negative for every normal x


def _tables() -> tuple[np.ndarray, np.ndarray]:
    """``INV_C[j] = 1 / c_j`` and ``TABLE[s * N_BRACKET + j] = 2^(0.3 s) c_j^0.3``, each correctly rounded."""
    with localcontext() as ctx:
        ctx.prec = 50
        inv_c, table, ln2 = [], np.empty(10 * N_BRACKET), Decimal(2).ln()
        for j in range(N_BRACKET):
            c = Decimal(1) + (Decimal(j) + Decimal("0.5")) / N_BRACKET
            inv_c.append(float(1 / c))
            ln_c = c.ln()
            for s in range(10):
                table[s * N_BRACKET + j] = float((EXPONENT * (s * ln2 + ln_c)).exp())
    return np.array(inv_c), table


INV_C, TABLE = _tables()


def _bitcast(src, dst):
    """A numba intrinsic reading a value of type ``src`` as the same 64 bits of type ``dst``."""

    @intrinsic
    def cast(typingctx, x):
        if x != src:
            return None

        def codegen(context, builder, sig, args):
            return builder.bitcast(args[0], context.get_value_type(dst))

        return dst(src), codegen

    return cast


_bits = _bitcast(types.float64, types.int64)  # the IEEE-754 bits of a double
_from_bits = _bitcast(types.int64, types.float64)  # the double of those bits


@njit(cache=True, inline="always")
def pow_0_3(x: float) -> float:
    """``x ** 0.3`` for ``x >= 0`` (see the module's docstring); within 1.5 ulp."""
    b = _bits(x)
    biased = (b >> 52) & 0x7FF
    scale = 1.0
    if biased == 0:  # zero or subnormal: 2^60 x is normal and (2^60 x)^0.3 = 2^18 x^0.3, both scalings exact
        if x == 0.0:
            return 0.0
        b = _bits(x * 2.0**60)
        biased = (b >> 52) & 0x7FF
        scale = 2.0**-18
    elif biased == 0x7FF:
        return x + x  # inf or NaN
    j = (b >> _SHIFT) & (N_BRACKET - 1)
    m = _from_bits((b & 0xFFFFFFFFFFFFF) | (1023 << 52))
    n = biased + E_OFFSET
    q = (n * 6554) >> 16  # n // 10 for 0 <= n < 2^14 (checked in the tests)
    s = n - 10 * q
    r = m * INV_C[j] - 1.0
    r2 = r * r
    p = r * ((A1 + A2 * r) + r2 * ((A3 + A4 * r) + r2 * (A5 + A6 * r)))
    tab = TABLE[s * N_BRACKET + j]
    return (tab + tab * p) * _from_bits((3 * (q - 103) + 1023) << 52) * scale
