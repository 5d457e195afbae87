"""Scaling laws (SPEC section 4) and the mass model of the conversion.

Engine, motor and generator are scaled by maximum power with the speed axis fixed (ADVISOR's
torque scaling): torque axis, torque limits, fuel and emission rates all multiply by the power scale
factor ``s = P_target / P_base``; efficiency maps are unchanged on normalised torque. Masses follow
ADVISOR's rules: engine (block + accessories) x s plus a fixed fuel system, exhaust 0.26 kg/kW,
machines x s, battery per module. Every function is vectorised over designs.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from hevlib.components import ComponentLibrary, EngineMap, MachineMap


def power_scale(p_target_kw, p_base_kw: float) -> np.ndarray:
    p = np.asarray(p_target_kw, dtype=float)
    if np.any(p <= 0) or not np.all(np.isfinite(p)):
        raise ValueError("scaling: target power must be positive and finite")
    return p / p_base_kw


def scale_engine(engine: EngineMap, p_kw: float) -> EngineMap:
    """The engine scaled to ``p_kw`` peak power (torque scaling at the fixed speed axis)."""
    s = float(power_scale(p_kw, engine.peak_power_kw))
    return dataclasses.replace(
        engine, name=f"{engine.name}@{p_kw:g}kW",
        torque_nm=engine.torque_nm * s, max_torque_nm=engine.max_torque_nm * s,
        fuel_g_s=engine.fuel_g_s * s, hc_g_s=engine.hc_g_s * s, co_g_s=engine.co_g_s * s, nox_g_s=engine.nox_g_s * s,
        peak_power_kw=engine.peak_power_kw * s, engine_mass_kg=engine.engine_mass_kg * s,
        inertia_kg_m2=engine.inertia_kg_m2 * s,
    )


def scale_machine(machine: MachineMap, p_kw: float) -> MachineMap:
    s = float(power_scale(p_kw, machine.peak_power_kw))
    return dataclasses.replace(
        machine, name=f"{machine.name}@{p_kw:g}kW", torque_nm=machine.torque_nm * s,
        max_torque_nm=machine.max_torque_nm * s, peak_power_kw=machine.peak_power_kw * s,
        mass_kg=machine.mass_kg * s, inertia_kg_m2=machine.inertia_kg_m2 * s,
    )


def engine_system_mass_kg(engine: EngineMap, p_kw, exhaust_kg_per_kw: float) -> np.ndarray:
    """Engine (scaled block + accessories), fixed fuel system, and exhaust/catalyst, in kg."""
    s = power_scale(p_kw, engine.peak_power_kw)
    return engine.engine_mass_kg * s + engine.fuel_system_mass_kg + exhaust_kg_per_kw * np.asarray(p_kw, float)


def machine_mass_kg(machine: MachineMap, p_kw) -> np.ndarray:
    return machine.mass_kg * power_scale(p_kw, machine.peak_power_kw)


@dataclass(frozen=True)
class PackArrays:
    """A pack of ``n_bat`` modules in series (vectorised): SOC tables per pack, in pack units."""

    ocv_v: np.ndarray        # (n, n_soc)
    r_dis_ohm: np.ndarray
    r_chg_ohm: np.ndarray
    v_min: np.ndarray        # (n,)
    v_max: np.ndarray
    capacity_ah: float
    mass_kg: np.ndarray


def battery_pack(lib: ComponentLibrary, n_bat) -> PackArrays:
    """Series pack: voltages and resistances x n_bat, capacity unchanged, mass x n_bat."""
    n = np.atleast_1d(np.asarray(n_bat, dtype=float))
    if np.any(n < 1) or np.any(n != np.round(n)):
        raise ValueError("n_bat: module count must be a positive integer")
    m = lib.battery
    return PackArrays(
        ocv_v=n[:, None] * m.ocv_v[None, :], r_dis_ohm=n[:, None] * m.r_dis_ohm[None, :],
        r_chg_ohm=n[:, None] * m.r_chg_ohm[None, :], v_min=n * m.v_min, v_max=n * m.v_max,
        capacity_ah=m.capacity_ah, mass_kg=n * m.mass_kg,
    )


@dataclass(frozen=True)
class MassBreakdown:
    """Test-mass build-up of hybrid designs (arrays over designs, kg)."""

    chassis_kg: float        # conventional glider + cargo (the conversion keeps it)
    engine_kg: np.ndarray
    motor_kg: np.ndarray
    generator_kg: np.ndarray
    battery_kg: np.ndarray

    @property
    def test_mass_kg(self) -> np.ndarray:
        return self.chassis_kg + self.engine_kg + self.motor_kg + self.generator_kg + self.battery_kg


def conventional_chassis_kg(lib: ComponentLibrary, test_mass_kg: float, p_eng_kw: float) -> float:
    """Glider + cargo of the conventional car: its test mass minus its engine system and gearbox."""
    eng = engine_system_mass_kg(lib.engine_conventional, p_eng_kw, lib.exhaust_kg_per_kw)
    chassis = float(test_mass_kg - eng - lib.gearbox.mass_kg)
    if chassis <= 0:
        raise ValueError("baseline.conventional.test_mass_kg: leaves no mass for the glider")
    return chassis


def hybrid_masses(lib: ComponentLibrary, chassis_kg: float, p_eng_kw, p_mot_kw, p_gen_kw, n_bat) -> MassBreakdown:
    """SPEC section 4: conventional glider + cargo + scaled engine system, motor, generator, battery.

    ADVISOR gives the planetary set and final drive no mass; we keep that (reported in components.json).
    """
    return MassBreakdown(
        chassis_kg=chassis_kg,
        engine_kg=engine_system_mass_kg(lib.engine_hybrid, p_eng_kw, lib.exhaust_kg_per_kw),
        motor_kg=machine_mass_kg(lib.motor, p_mot_kw),
        generator_kg=machine_mass_kg(lib.generator, p_gen_kw),
        battery_kg=battery_pack(lib, n_bat).mass_kg,
    )
