"""The components as typed, immutable data: engine and machine maps, the battery module, bodies, wheels, the
gear set, the gearbox, controls, accessories and the thermal and exhaust data (SI units, source axes)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hevlib.lookup import interp_map

RPM = np.pi / 30.0  # rad/s per rpm

#: Rotor inertias used where a component file gives none (ADVISOR's defaults: ``fc_inertia`` 0.1 kg m^2 of
#: its generic engines, ``mc_inertia`` / ``gc_inertia`` 0.0226 kg m^2 of its Prius machines, and the
#: 181 lb solid-cylinder wheel set of its wheel files at r = 0.282 m). Every shipped file has its own.
DEFAULT_ENGINE_INERTIA_KG_M2 = 0.1
#: ADVISOR's exhaust maps of spark-ignition engines: flow = fuel x (1 + stoichiometric A/F), temperature
#: relative to the 20 C the engines were tested at (the engine files' thermal_model note)
EXHAUST_AIR_FUEL_RATIO = 14.5
EXHAUST_MAP_REFERENCE_C = 20.0
#: ADVISOR's area exponent: areas follow engine power^0.67
AREA_EXPONENT = 0.67
DEFAULT_MACHINE_INERTIA_KG_M2 = 0.0226
DEFAULT_WHEEL_INERTIA_KG_M2 = 3.264


def read_only(a) -> np.ndarray:
    arr = np.array(a, dtype=float)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class EngineMap:
    """Spark-ignition engine: fuel and engine-out emission rates on a (speed x torque) grid."""

    name: str
    speed_rad_s: np.ndarray
    torque_nm: np.ndarray
    max_torque_nm: np.ndarray  # full load, indexed by speed_rad_s
    fuel_g_s: np.ndarray  # (n_speed, n_torque)
    hc_g_s: np.ndarray
    co_g_s: np.ndarray
    nox_g_s: np.ndarray
    peak_power_kw: float  # max of max_torque x speed (torque curve linear between axis points)
    engine_mass_kg: float  # base engine + accessories (scales with power)
    fuel_system_mass_kg: float  # does not scale (ADVISOR rule)
    inertia_kg_m2: float
    lhv_j_per_g: float
    fuel_density_g_per_l: float
    closed_throttle_torque_nm: np.ndarray  # motored (fuel-cut) drag torque, <= 0, indexed by speed_rad_s

    def __post_init__(self):
        ns, nt = len(self.speed_rad_s), len(self.torque_nm)
        for key in ("fuel_g_s", "hc_g_s", "co_g_s", "nox_g_s"):
            m = getattr(self, key)
            if m.shape != (ns, nt):
                raise ValueError(f"engine {self.name}: {key} has shape {m.shape}, expected {(ns, nt)}")
            if not np.all(np.isfinite(m)) or np.any(m < 0):
                raise ValueError(f"engine {self.name}: {key} must be finite and non-negative")
        if len(self.max_torque_nm) != ns or np.any(np.diff(self.speed_rad_s) <= 0):
            raise ValueError(f"engine {self.name}: max_torque_nm / speed axis inconsistent")
        if len(self.closed_throttle_torque_nm) != ns or np.any(self.closed_throttle_torque_nm > 0):
            raise ValueError(f"engine {self.name}: closed_throttle_torque_nm must be <= 0, one value per speed")
        if np.any(np.diff(self.torque_nm) <= 0):
            raise ValueError(f"engine {self.name}: torque axis must be strictly increasing")

    @property
    def max_speed_rad_s(self) -> float:
        return float(self.speed_rad_s[-1])

    @property
    def min_speed_rad_s(self) -> float:
        return float(self.speed_rad_s[0])

    def max_torque_at(self, speed_rad_s) -> np.ndarray:
        """Full-load torque at ``speed_rad_s`` (linear between axis points, clamped at the ends)."""
        return np.interp(speed_rad_s, self.speed_rad_s, self.max_torque_nm)

    def rate_g_s(self, key: str, speed_rad_s, torque_nm) -> np.ndarray:
        """Map ``key`` (``fuel``, ``hc``, ``co``, ``nox``) in g/s at the given points (bilinear, clamped)."""
        z = getattr(self, f"{key}_g_s")
        return interp_map(self.speed_rad_s, self.torque_nm, z, speed_rad_s, torque_nm)

    def bsfc_g_per_kwh(self) -> np.ndarray:
        """BSFC on the grid (NaN above full load or at zero power)."""
        p_kw = self.speed_rad_s[:, None] * self.torque_nm[None, :] / 1e3
        with np.errstate(divide="ignore", invalid="ignore"):
            bsfc = self.fuel_g_s / p_kw * 3600.0
        above = self.torque_nm[None, :] > self.max_torque_nm[:, None] * (1 + 1e-9)
        bsfc[above | (p_kw <= 0)] = np.nan
        return bsfc

    def min_bsfc_g_per_kwh(self) -> float:
        """Lowest BSFC over grid points at or below full load."""
        return float(np.nanmin(self.bsfc_g_per_kwh()))

    def max_efficiency(self) -> float:
        """Peak brake efficiency (fuel LHV to shaft) at the minimum BSFC."""
        return 3.6e6 / (self.min_bsfc_g_per_kwh() * self.lhv_j_per_g)


@dataclass(frozen=True)
class MachineMap:
    """Electric machine with inverter: efficiency vs |speed| and |torque| (first quadrant, mirrored)."""

    name: str
    speed_rad_s: np.ndarray  # >= 0
    torque_nm: np.ndarray  # >= 0
    efficiency: np.ndarray  # (n_speed, n_torque); motoring P_e = P_m/eff, generating P_m*eff
    max_torque_nm: np.ndarray  # magnitude limit vs speed_rad_s
    peak_power_kw: float
    mass_kg: float
    inertia_kg_m2: float

    def __post_init__(self):
        if self.efficiency.shape != (len(self.speed_rad_s), len(self.torque_nm)):
            raise ValueError(f"machine {self.name}: efficiency map shape mismatch")
        if np.any(self.efficiency <= 0) or np.any(self.efficiency > 1):
            raise ValueError(f"machine {self.name}: efficiency must lie in (0, 1]")
        if len(self.max_torque_nm) != len(self.speed_rad_s) or np.any(np.diff(self.speed_rad_s) <= 0):
            raise ValueError(f"machine {self.name}: max_torque_nm / speed axis inconsistent")

    @property
    def max_speed_rad_s(self) -> float:
        return float(self.speed_rad_s[-1])

    def max_torque_at(self, speed_rad_s) -> np.ndarray:
        """Torque magnitude limit at ``|speed_rad_s|`` (linear between axis points, clamped)."""
        return np.interp(np.abs(speed_rad_s), self.speed_rad_s, self.max_torque_nm)

    def efficiency_at(self, speed_rad_s, torque_nm) -> np.ndarray:
        """Efficiency at ``(|speed|, |torque|)`` (bilinear, clamped)."""
        return interp_map(self.speed_rad_s, self.torque_nm, self.efficiency, np.abs(speed_rad_s), np.abs(torque_nm))


@dataclass(frozen=True)
class BatteryModule:
    """Rint battery module: OCV and resistances vs SOC at one temperature."""

    name: str
    soc: np.ndarray
    ocv_v: np.ndarray
    r_dis_ohm: np.ndarray
    r_chg_ohm: np.ndarray
    capacity_ah: float
    coulombic_efficiency: float
    v_min: float
    v_max: float
    mass_kg: float
    temperature_c: float

    def energy_wh(self) -> float:
        """Module energy: capacity x OCV integrated over SOC 0..1 (trapezoid)."""
        return float(self.capacity_ah * np.trapezoid(self.ocv_v, self.soc))

    def mean_ocv_v(self) -> float:
        """OCV averaged over the SOC range (the module's 'nominal' voltage)."""
        return float(np.trapezoid(self.ocv_v, self.soc) / (self.soc[-1] - self.soc[0]))


@dataclass(frozen=True)
class Body:
    name: str
    glider_mass_kg: float
    cargo_mass_kg: float
    drag_coefficient: float
    frontal_area_m2: float
    cg_height_m: float
    wheelbase_m: float
    front_weight_fraction: float
    air_density_kg_m3: float = 1.2
    gravity_m_s2: float = 9.81
    # a coast-down road load F = A + B v + C v^2 (N, N per m/s, N per (m/s)^2; params' body.coast_down), which
    # replaces drag coefficient x frontal area and the wheels' rolling resistance and axle drag; None: none given
    road_load_a_n: float | None = None
    road_load_b_n_per_mps: float | None = None
    road_load_c_n_per_mps2: float | None = None

    @property
    def coast_down(self) -> tuple[float, float, float] | None:
        """(A, B, C) of the body's coast-down road load in SI, or None (drag coefficient and frontal area)."""
        abc = (self.road_load_a_n, self.road_load_b_n_per_mps, self.road_load_c_n_per_mps2)
        if all(x is None for x in abc):
            return None
        if any(x is None for x in abc):
            raise ValueError(f"body {self.name}: a coast-down road load needs all of A, B and C")
        return abc


@dataclass(frozen=True)
class Wheel:
    name: str
    radius_m: float
    rolling_resistance: float
    inertia_kg_m2: float  # all wheels, tyres and axles together
    axle_drag_nm_at_0kg: float
    axle_drag_nm_per_kg: float
    brake_speed_mps: np.ndarray  # vehicle speed axis of the braking split (>= 0, increasing)
    brake_driveline_share: np.ndarray  # share of the braking demand the driveline may take (regeneration)

    def driveline_brake_share(self, speed_mps) -> np.ndarray:
        """Share of a braking request the driveline may take at ``speed_mps`` (linear, clamped)."""
        return np.interp(speed_mps, self.brake_speed_mps, self.brake_driveline_share)


@dataclass(frozen=True)
class PowerSplit:
    """Prius planetary gear set and final drive (stock values; designs override n_r, n_s, i0)."""

    n_r: int
    n_s: int
    i0: float
    n_planets: int
    planet_teeth: int
    engine_max_speed_rad_s: float
    motor_max_speed_rad_s: float
    generator_max_speed_rad_s: float
    engine_min_on_speed_rad_s: float  # lowest running speed: the engine map's lowest speed (FC_PRIUS_JPN: 1000 rpm)
    operating_line_power_w: np.ndarray  # ADVISOR's 5-point Prius operating line (for comparison)
    operating_line_speed_rad_s: np.ndarray
    engine_startup_inertia_kg_m2: float  # PTC_PRIUS_JPN: the engine's effective inertia while started
    engine_crank_torque_nm: float  # ... the torque it resists cranking with
    engine_firing_speed_rad_s: float  # ... the speed below which its fuel is cut (fuel flows from here up)
    coolant_warmup_temperature_c: float  # ... below which the engine stays on until warm


@dataclass(frozen=True)
class Gearbox:
    """Manual 5-speed (overall ratios, final drive included) with the TX_VW loss regression."""

    name: str
    ratios: np.ndarray
    mass_kg: float  # gearbox + final drive (TX_5SPD_SI transmission mass)
    loss_coefficients: np.ndarray  # a, b, c, d, e, f of P_loss = (a r + b) w + (c/r + d)|T| + e P + f


@dataclass(frozen=True)
class ConventionalControl:
    """ADVISOR's ``PTC_CONV``: the conventional car's clutch, idle and load-based shift logic.

    The shift curves give, against the engine speed in the gear held, the engine load (torque over full-load
    torque) below which an upshift and above which a downshift is called for; the same for every gear.
    """

    idle_allowed: bool  # vc_idle_bool: the engine idles (else it stops) while the clutch is open
    clutch_opens_without_torque: bool  # vc_clutch_bool: the clutch opens whenever no torque is asked of it
    upshift_speed_rad_s: np.ndarray
    upshift_load: np.ndarray
    downshift_speed_rad_s: np.ndarray
    downshift_load: np.ndarray
    shift_delay_s: float  # gb_shift_delay: no torque while a shift lasts


@dataclass(frozen=True)
class Accessory:
    electrical_w: float
    mechanical_w: float


@dataclass(frozen=True)
class EngineThermal:
    """ADVISOR's four-node engine thermal model of one engine file (``thermal_model``), base engine."""

    base_engine_mass_kg: float  # cylinder (20 %) and block (80 %) nodes
    accessories_mass_kg: float  # exterior node
    specific_heat_j_per_kg_k: float
    hood_specific_heat_j_per_kg_k: float
    exterior_area_m2: float
    hood_area_m2: float
    emissivity: float
    hood_emissivity: float
    cyl_to_block_w_per_k: float
    block_to_exterior_w_per_k: float
    exterior_to_hood_w_per_k: float
    thermostat_c: float
    exhaust_share_min_speed: float  # share of the waste heat the exhaust carries at the lowest map speed
    exhaust_share_max_speed: float  # ... and at the highest
    air_fuel_ratio: float  # exhaust flow = fuel x (1 + A/F)
    map_reference_c: float  # temperature the exhaust maps refer to
    has_cold_maps: bool


@dataclass(frozen=True)
class Catalyst:
    """ADVISOR's ``EX_SI`` three-way catalyst: conversion vs monolith temperature, breakthrough limits,
    the exhaust system's mass and area rules (per kW of engine power) and its thermal data."""

    temperature_c: np.ndarray
    conversion_hc: np.ndarray
    conversion_co: np.ndarray
    conversion_nox: np.ndarray
    breakthrough_hc_g_s: float
    breakthrough_co_g_s: float
    breakthrough_nox_g_s: float
    exhaust_kg_per_kw: float
    monolith_share: float  # of the exhaust system mass
    shell_share: float
    pipe_share: float
    shield_share: float
    manifold_share: float
    monolith_cp_j_per_kg_k: float
    steel_cp_j_per_kg_k: float
    gas_cp_j_per_g_k: float
    monolith_area_coef_m2: float  # outer area = coef x (p_eng / 100 kW)^exp
    monolith_area_exp: float
    manifold_area_m2_per_kw: float
    emissivity_monolith_pipe: float
    emissivity_shell_shield: float
    emissivity_pipe: float
    emissivity_shield: float
    emissivity_manifold: float
    monolith_shell_temperature_c: np.ndarray
    monolith_shell_w_per_k: np.ndarray
    shell_shield_w_per_k: float
    shell_pipe_w_per_k: float
    pipe_shield_w_per_k: float


COMPONENT_TYPES = (
    EngineMap,
    MachineMap,
    BatteryModule,
    Body,
    Wheel,
    PowerSplit,
    Gearbox,
    ConventionalControl,
    Accessory,
    EngineThermal,
    Catalyst,
)
