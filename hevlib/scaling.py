"""The component scaling law, once (numba): the kernels call it per step, :mod:`hevlib.sizing` on arrays.

ADVISOR's torque scaling at a fixed speed axis: a component of ``p_kw`` peak power built from a base map
of ``p_base_kw`` has the scale factor ``s = p_kw / p_base_kw``; its torques and torque limits, fuel and
emission rates, mass and rotor inertia are the base values times ``s``, and its maps are read at the
base-map torque ``t / s`` (so efficiency is unchanged on normalised torque). A battery pack is ``n_bat``
identical modules in series: voltages, resistances and mass are the module's times ``n_bat``, capacity
(A h) the module's. Each function accepts scalars (the kernels) or numpy arrays (reports, plots, masses).
"""

from __future__ import annotations

from numba import njit


@njit(cache=True, inline="always")
def power_scale(p_kw, p_base_kw):
    """Scale factor ``s`` of a component of ``p_kw`` peak power built from a base map of ``p_base_kw``."""
    return p_kw / p_base_kw


@njit(cache=True, inline="always")
def scaled(x_base, s):
    """A torque, torque limit, fuel or emission rate, mass or inertia of the base component, scaled by ``s``."""
    return x_base * s


@njit(cache=True, inline="always")
def base_torque(t, s):
    """The torque on the base map's axis at which a component scaled by ``s`` giving torque ``t`` is read."""
    return t / s


@njit(cache=True, inline="always")
def in_series(x_module, n_bat):
    """A pack of ``n_bat`` modules in series: its voltage, resistance or mass from the module's."""
    return x_module * n_bat
