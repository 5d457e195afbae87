"""``hevlib.powers.pow_0_3``: the thermal model's ``x ** 0.3`` without libm, against exact arithmetic."""

from __future__ import annotations

from decimal import Decimal, localcontext

import numpy as np
import pytest
from numba import njit

from hevlib import powers
from hevlib.powers import pow_0_3


@njit(cache=False)
def _each(xs):
    out = np.empty_like(xs)
    for i in range(xs.size):
        out[i] = pow_0_3(xs[i])
    return out


@njit(cache=False)
def _chained(xs):
    """The same powers through a loop that cannot be vectorised (each input depends on the last output)."""
    out = np.empty_like(xs)
    prev = 0.0
    for i in range(xs.size):
        prev = pow_0_3(xs[i] + 0.0 * prev)
        out[i] = prev
    return out


def _ulps_from_exact(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    with localcontext() as ctx:
        ctx.prec = 40
        exact = [(powers.EXPONENT * Decimal(float(v)).ln()).exp() for v in x]
        return np.array([float(abs(Decimal(float(b)) - e)) for b, e in zip(y, exact, strict=True)]) / np.spacing(y)


def test_within_one_and_a_half_ulp_of_the_exact_power():
    rng = np.random.default_rng(3)
    # the model's range (|dT| / 1000 from 1e-12 K to 1 500 K), every mantissa bracket, and the whole exponent range
    x = np.concatenate(
        [
            10.0 ** rng.uniform(-15, 0.2, 6000),
            rng.uniform(0.0, 1.5, 3000)[1:],
            np.ldexp(1.0 + (np.arange(128) + rng.uniform(0, 1, 128)) / 128, -3),
            np.ldexp(rng.uniform(1.0, 2.0, 400), rng.integers(-1022, 1023, 400)),
        ]
    )
    ulps = _ulps_from_exact(x, _each(x))
    assert ulps.max() <= 1.5, x[np.argmax(ulps)]
    # and next to libm's pow (which raises to the double nearest 0.3) within a few ulp where the model lives
    small = x[(x > 1e-6) & (x < 2.0)]
    assert np.max(np.abs(_each(small) - small**0.3) / np.spacing(small**0.3)) <= 3.0


def test_edges_and_special_values():
    x = np.array([0.0, 5e-324, 2.0**-1074 * 7, 2.0**-1022, 1.0, 2.0, 10.0, 1000.0, np.finfo(float).max, np.inf])
    y = _each(x)
    assert y[0] == 0.0 and y[4] == 1.0 and y[-1] == np.inf and np.isnan(_each(np.array([np.nan])))[0]
    assert _ulps_from_exact(x[1:-1], y[1:-1]).max() <= 1.5  # subnormals scaled into range exactly
    assert y[5] == pytest.approx(2.0**0.3, rel=2e-16) and y[7] == pytest.approx(10**0.9, rel=2e-16)
    assert np.all(np.diff(y[:-1]) > 0.0)  # increasing


def test_the_exponent_split_is_exact_for_every_biased_exponent():
    n = np.arange(1, 2047) + powers.E_OFFSET  # every normal number's biased exponent, shifted
    q = (n * 6554) >> 16
    np.testing.assert_array_equal(q, n // 10)
    # 2^(3 (q - 103)) stays a normal double
    assert (3 * (q - 103) + 1023).min() >= 1 and (3 * (q - 103) + 1023).max() <= 2046


def test_same_bits_vectorised_or_not():
    """The compiler vectorises a plain loop over the powers (SIMD lanes) and cannot vectorise a chained one:
    both must give the same bits, as every CPU must (no fused or reordered arithmetic)."""
    x = 10.0 ** np.random.default_rng(5).uniform(-12, 0.2, 4096)
    np.testing.assert_array_equal(_each(x), _chained(x))


def test_never_falls_by_more_than_an_ulp_across_bracket_and_octave_edges():
    """Where the table changes (a bracket's or an octave's edge) the power may step back by its last bit (each
    side is within 1.5 ulp of the exact value), never more: the air-side coefficient does not fall as the
    temperature difference grows, beyond round-off."""
    edges = np.concatenate([np.ldexp(1.0 + np.arange(129) / 128, -5), np.ldexp(1.0, np.arange(-40, 2))])
    x = np.sort(np.concatenate([edges, np.nextafter(edges, 0.0), np.nextafter(edges, 1.0)]))
    y = _each(x)
    assert np.all(np.diff(y) >= -np.spacing(y[1:]))
