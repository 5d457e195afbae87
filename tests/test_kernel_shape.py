"""The simulator's shape (FASTSim 3's): the accumulator and trace layouts are one list of names each."""

from __future__ import annotations

from hevlib.sim.powertrain import layout as L


def test_layout_names_define_the_columns():
    for prefix, names, n in (("O_", L.OUT_NAMES, L.N_O), ("T_", L.TRACE_NAMES, L.N_T)):
        cols = {k: v for k, v in vars(L).items() if k.startswith(prefix) and isinstance(v, int)}
        assert len(names) == n == len(set(names)) == len(cols)
        assert sorted(cols.values()) == list(range(n)), prefix
