"""Single planetary gear set of a power-split hybrid: engine on the carrier, generator on the sun,
motor and final drive on the ring.

Willis: ``w_ring * N_r + w_sun * N_s = w_carrier * (N_r + N_s)``. With ``k = N_r / N_s`` an engine
(carrier) torque ``T`` reaches the ring as ``T * k / (1 + k)`` and must be reacted on the sun by the
generator with ``T / (1 + k)``; the powers then balance exactly (lossless set).
"""

from __future__ import annotations

from numba import njit


@njit(cache=True, inline="always")
def sun_speed(w_carrier: float, w_ring: float, n_r: float, n_s: float) -> float:
    """Generator (sun) speed from the Willis relation, rad/s."""
    return ((n_r + n_s) * w_carrier - n_r * w_ring) / n_s


@njit(cache=True, inline="always")
def carrier_speed(w_ring: float, w_sun: float, n_r: float, n_s: float) -> float:
    """Engine (carrier) speed, rad/s."""
    return (n_r * w_ring + n_s * w_sun) / (n_r + n_s)


@njit(cache=True, inline="always")
def carrier_speed_window(w_ring: float, n_r: float, n_s: float, w_sun_max: float) -> tuple[float, float]:
    """Engine speeds (lo, hi) that keep the generator within +/- ``w_sun_max`` at this ring speed."""
    lo = (n_r * w_ring - n_s * w_sun_max) / (n_r + n_s)
    hi = (n_r * w_ring + n_s * w_sun_max) / (n_r + n_s)
    return lo, hi


@njit(cache=True, inline="always")
def split_torque(t_carrier: float, n_r: float, n_s: float) -> tuple[float, float]:
    """(ring, sun) torques delivered by a carrier torque: T k/(1+k) and T/(1+k)."""
    k = n_r / n_s
    return t_carrier * k / (1.0 + k), t_carrier / (1.0 + k)
