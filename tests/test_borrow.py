"""Borrowed (not reference-counted) array views of the kernels, and the exact short cuts of the thermal
step and of the brake-share lookup: the same numbers, bit for bit, with less work."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pytest
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from hevlib.lookup import interp1_np
from hevlib.sim.powertrain import thermal as T
from hevlib.sim.powertrain.borrow import borrowed
from hevlib.sim.powertrain.layout import N_O


def _step(**given) -> T.ThermalStep:
    """A thermal step by keyword: the key on, one second, no exhaust flow or emissions unless ``given``."""
    return T.ThermalStep(**({f: 0.0 for f in T.ThermalStep._fields} | {"key_on": True, "dt_s": 1.0} | given))


@intrinsic
def _counted(typingctx, arr):
    """Whether ``arr`` carries a meminfo (is reference-counted)."""

    def codegen(context, builder, sig, args):
        ary = context.make_array(sig.args[0])(context, builder, args[0])
        return builder.not_(cgutils.is_null(builder, ary.meminfo))

    return types.boolean(arr), codegen


class _Maps(NamedTuple):
    scale: float
    table: np.ndarray
    grid: np.ndarray


@njit
def _views(a, maps):
    b = borrowed(a)
    m = borrowed(maps)
    pair = borrowed((a, (maps, 2.0)))
    same = (
        b.ctypes.data == a.ctypes.data
        and b.shape == a.shape
        and b.strides == a.strides
        and m.table.ctypes.data == maps.table.ctypes.data
        and m.grid.shape == maps.grid.shape
    )
    counted = (
        _counted(a),
        _counted(b),
        _counted(m.table),
        _counted(m.grid),
        _counted(pair[0]),
        _counted(pair[1][0].table),
    )
    total = 0.0
    for i in range(b.shape[0]):
        for j in range(b.shape[1]):
            total += b[i, j] * m.scale
    return same, counted, total, pair[1][1], m.scale


def test_borrowed_views_read_the_same_memory_without_a_reference_count():
    a = np.arange(12.0).reshape(3, 4)[:, ::2]  # a strided view: shape and strides carry over
    maps = _Maps(0.5, np.ones((2, 3)), np.linspace(0.0, 1.0, 5))
    same, counted, total, scalar, scale = _views(a, maps)
    assert same
    # the argument is counted, every borrowed view (plain, in a NamedTuple, in nested tuples) is not
    assert counted == (True, False, False, False, False, False)
    assert total == a.sum() * 0.5 and scalar == 2.0 and scale == 0.5


def test_interp1_np_is_numpys_interp_bit_for_bit():
    rng = np.random.default_rng(3)
    xs = np.array([0.0, 4.4704, 26.8224, 447.04])
    ys = np.array([0.0, 0.15, 0.85, 0.85])
    x = np.concatenate([rng.uniform(-5.0, 460.0, 2000), xs, [-1e-300, 1e9]])
    got = np.array([interp1_np(v, xs, ys) for v in x])
    np.testing.assert_array_equal(got, np.interp(x, xs, ys))


def test_thermal_short_cuts_are_the_formulas_value_exactly():
    # the powers left out at zero are exactly what evaluating them gives
    for base in (6.0, 10.0 + T.FORCED_H * T._speed_term.py_func(13.0)):
        assert T._h_air(0.0, base) == base + 6.0 * (0.0 / 1000.0) ** 0.3
        assert T._h_air(-0.0, base) == base
    assert T._speed_term(0.0) == 0.0**0.6 and T._speed_term(-0.0) == 0.0
    # one power of the speed for the three coefficients: ADVISOR's form to round-off
    for share, ref, c in ((0.5, 30.0, T.FORCED_X), (1.0, 30.0, T.FORCED_H), (0.75, 21.0, T.FORCED_E)):
        for v in (0.3, 12.5, 41.0):
            assert c * T._speed_term(v) == pytest.approx(60.0 * (share * v / ref) ** 0.6, rel=1e-14)


def test_a_step_with_no_heat_at_ambient_changes_nothing_and_one_degree_off_does(sim):
    _ambient_step = _step(v_mps=12.0)
    cfg = sim.library.thermal["hybrid"]
    k = T.design_constants(40.0, cfg, 1.0, 60.0)
    temp = np.full(T.N_NODES, cfg.ambient_c)
    o = np.zeros(N_O)
    tp = T.thermal_step(temp, k, cfg, _ambient_step, o)
    assert tp == (0.0, 0.0, 0.0) and (temp == cfg.ambient_c).all() and not o.any()
    temp[T.N_MON] += 1.0  # one node off ambient: the full step runs and the monolith cools
    T.thermal_step(temp, k, cfg, _ambient_step, o)
    assert cfg.ambient_c < temp[T.N_MON] < cfg.ambient_c + 1.0 and o.any()
