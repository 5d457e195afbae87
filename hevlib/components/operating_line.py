"""The engine's best-efficiency line: for each shaft power, the speed and torque that burn least fuel."""

from __future__ import annotations

import numpy as np

from hevlib.components.parts import EngineMap


# --------------------------------------------------------------------------- best-efficiency line
def best_efficiency_line(
    engine: EngineMap, *, n_power: int = 61, n_speed: int = 361, load_limit: float = 1.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The engine's minimum-fuel operating line: for each power, the speed and torque that burn least fuel.

    Returns ``(power_w, speed_rad_s, torque_nm)``, ``n_power`` points from 0 to the peak power
    available within ``load_limit`` x full-load torque. Each point minimises the fuel rate (bilinear on
    the map) with torque ``P / w`` at or below ``load_limit`` x full load, over ``n_speed`` speeds
    across the map's speed axis plus the exact speeds where ``P / w`` meets that limit (the optimum of
    a map whose fuel rate rises linearly with torque lies there). At zero power it is the lowest map
    speed at zero torque. The speed is made non-decreasing in power (so a controller can interpolate
    it smoothly) where that stays within the load limit. A scaled engine (torque scaling, fixed speed
    axis) has the same line with power and torque multiplied by the scale factor. For the Prius map
    the line runs along full load; ``load_limit`` < 1 keeps a torque reserve.
    """
    if not 0 < load_limit <= 1:
        raise ValueError(f"load_limit: {load_limit:g} must lie in (0, 1]")

    def t_lim(speed):
        return engine.max_torque_at(speed) * load_limit

    w = np.linspace(engine.speed_rad_s[0], engine.speed_rad_s[-1], n_speed)
    power_w = np.linspace(0.0, float(np.max(w * t_lim(w))), n_power)
    torque = power_w[:, None] / w[None, :]  # (n_power, n_speed)
    fuel = engine.rate_g_s("fuel", np.broadcast_to(w, torque.shape), torque)
    fuel = np.where(torque <= t_lim(w)[None, :] * (1 + 1e-12), fuel, np.inf)
    best = np.argmin(fuel, axis=1)
    speed, best_fuel = w[best], fuel[np.arange(n_power), best]
    # candidates on the load limit: bisect w * t_lim(w) = P in every grid interval where it crosses P
    margin = w[None, :] * t_lim(w)[None, :] - power_w[:, None]
    k, i = np.nonzero((margin[:, :-1] >= 0) != (margin[:, 1:] >= 0))
    lo, hi, p_k = w[i], w[i + 1], power_w[k]
    lo_ok = margin[k, i] >= 0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        same_as_lo = (mid * t_lim(mid) - p_k >= 0) == lo_ok
        lo, hi = np.where(same_as_lo, mid, lo), np.where(same_as_lo, hi, mid)
    w_b = np.where(lo_ok, lo, hi)  # the feasible end
    f_b = engine.rate_g_s("fuel", w_b, p_k / w_b)
    for kk, wb, fb in zip(k, w_b, f_b, strict=True):
        if fb < best_fuel[kk]:
            speed[kk], best_fuel[kk] = wb, fb
    # non-decreasing speed where the running maximum stays feasible
    for kk in range(1, n_power):
        if speed[kk] < speed[kk - 1] and power_w[kk] / speed[kk - 1] <= t_lim(speed[kk - 1]):
            speed[kk] = speed[kk - 1]
    return power_w, speed, power_w / speed
