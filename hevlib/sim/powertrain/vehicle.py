"""Longitudinal vehicle dynamics (numba): road loads, front-axle adhesion, and the speed a force buys.

Forces in N, speeds in m/s; the road grade enters as ``sin_t``/``cos_t`` of its angle
(``theta = atan(rise/run)``, precomputed once per cycle step by :func:`hevlib.cycles.grade_trig`). ``m`` is the
test mass; ``m_eff`` adds the rotating inertias the vehicle accelerates (wheels, and the driveline's rotors
reflected through its ratios: :func:`hevlib.sim.drive.split_equivalent_mass_kg`,
:func:`hevlib.sim.drive.conventional_equivalent_mass_kg`) to the translational mass. Road loads are
evaluated at the step's mean speed ``v_avg``, so that with ``a = 2 (v_avg - v0) / dt``

    F_traction + F_brake = m_eff * a + F_road(v_avg)

holds exactly and the work done over the step, ``F * v_avg * dt``, balances the kinetic energy change.

Road load: ``F_road = 1/2 rho CdA v^2 + m g cos(theta) crr + k_lin v + axle drag / r`` (moving only), plus the
grade ``m g sin(theta)``. ``k_lin`` (N per m/s) is the linear term of a coast-down road load (the EPA target
coefficient B, :mod:`hevlib.epa`); it is booked with rolling resistance, and it is 0 for a body given by drag
coefficient and frontal area, where every force is bit for bit what it was without it (``x + 0.0 == x``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

from numba import njit


class Chassis(NamedTuple):
    """Per-design chassis scalars."""

    m: float  # test mass, kg
    m_eff: float  # with rotating inertia, kg
    cda: float  # drag coefficient x frontal area, m^2
    crr: float  # rolling-resistance coefficient
    r: float  # wheel rolling radius, m
    axle_drag_nm: float  # driven-axle drag torque at this mass, N m
    h_over_l: float  # CG height / wheelbase
    f_front: float  # static front-axle weight fraction
    adhesion_coefficient: float  # tyre-road adhesion (sim.adhesion_coefficient)
    rho: float  # air density, kg/m^3
    g: float  # gravity, m/s^2
    k_lin: float  # linear road-load term (a coast-down's B), N per m/s; booked with rolling resistance


@njit(cache=True, inline="always")
def rolling_force(cos_t: float, c: Chassis) -> float:
    """The speed-independent rolling resistance ``m g cos(theta) crr`` (N) of a moving vehicle."""
    return c.m * c.g * cos_t * c.crr


@njit(cache=True, inline="always")
def road_force(v: float, sin_t: float, cos_t: float, c: Chassis) -> tuple[float, float, float, float]:
    """(aero, rolling, grade, axle-drag) forces in N at speed ``v`` (rolling and drag only when moving); rolling
    includes the linear term ``k_lin v``."""
    f_grade = c.m * c.g * sin_t
    if v <= 0.0:
        return 0.0, 0.0, f_grade, 0.0
    f_aero = 0.5 * c.rho * c.cda * v * v
    f_roll = rolling_force(cos_t, c) + c.k_lin * v
    return f_aero, f_roll, f_grade, c.axle_drag_nm / c.r


@njit(cache=True, inline="always")
def road_total(v: float, sin_t: float, cos_t: float, c: Chassis) -> float:
    a, b, g, d = road_force(v, sin_t, cos_t, c)
    return a + b + g + d


@njit(cache=True, inline="always")
def adhesion_limit(sin_t: float, cos_t: float, f_road: float, c: Chassis) -> float:
    """Largest front-axle tractive (or regenerative braking) force magnitude before the tyres slip.

    Front normal load with the grade and the load transfer of the acceleration the force produces:
    ``N_f = m g (f cos(theta) - h/L sin(theta)) - m a h/L`` with ``a = (F - F_road) / m_eff``; solve ``F = mu N_f``.
    """
    k = c.h_over_l * c.m / c.m_eff
    n_static = c.m * c.g * (c.f_front * cos_t - c.h_over_l * sin_t)
    f = c.adhesion_coefficient * (n_static + k * f_road) / (1.0 + c.adhesion_coefficient * k)
    return max(f, 0.0)


@njit(cache=True)
def mean_speed_for_force(v0: float, f: float, sin_t: float, cos_t: float, dt: float, c: Chassis) -> float:
    """Mean speed over a step that starts at ``v0`` with net powertrain+brake force ``f``.

    Solves ``f - F_road(v_avg) = 2 m_eff (v_avg - v0) / dt`` (aero quadratic in v_avg; the linear road-load term
    ``k_lin`` joins the inertia's linear coefficient). The vehicle does not roll back: if the force cannot hold
    it, the step ends at standstill (v_avg = v0 / 2).
    """
    f_aero_k = 0.5 * c.rho * c.cda
    f_roll = rolling_force(cos_t, c)  # the moving vehicle's speed-independent terms (as road_force's at v > 0)
    f_grade = c.m * c.g * sin_t
    f_axle = c.axle_drag_nm / c.r
    b = 2.0 * c.m_eff / dt
    rhs = f - f_roll - f_grade - f_axle + b * v0  # f_aero_k u^2 + (b + k_lin) u = rhs
    if rhs <= 0.0:
        return 0.5 * v0 if v0 > 0.0 else 0.0
    b_lin = b + c.k_lin
    u = 2.0 * rhs / (b_lin + math.sqrt(b_lin * b_lin + 4.0 * f_aero_k * rhs))
    if 2.0 * u - v0 < 0.0:
        return 0.5 * v0
    return u
