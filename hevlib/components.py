"""Component data as typed, immutable objects, loaded from ADVISOR's published data (data/raw/components).

Maps keep the source axes in SI units. The normalised form written by the ``components`` stage
(``data/components/*.npz`` + ``library.json``) is what the simulator reads; raw YAML is read only by
that stage. Loading normalises the raw maps in four documented ways (listed in ``library.meta``):

- engine maps are extended linearly in torque (each row's Willans line) down to zero torque and up to
  the peak of the full-load curve, so every operating point at or below full load lies inside the grid
  (FC_PRIUS_JPN starts at 8.5 N*m; FC_SI63_emis stops at 135.8 N*m below its 145.2 N*m full-load peak).
  ADVISOR instead clamps the torque to the map's axis before every fuel and emission lookup
  (``lib_fuel_converter.mdl``, 'fuel use and EO emis', Saturation L2332-2339), so more torque there
  would cost no more fuel: up to 12 % less fuel than ours for the 63 kW engine at full load, 1500-4000 rpm;
- engine map values above each speed row's full-load torque are replaced by the row's last segment at
  or below full load, continued linearly, so no lookup ever blends in a value from above the full-load
  curve (FC_PRIUS_JPN's cells there are the source's flat fill, up to 0.475 efficiency);
- machine efficiency maps are reduced to the first quadrant (|speed|, |torque|; the source maps are
  mirror-symmetric), and the zero-speed row and zero-torque column, which the sources fill with a
  constant instead of a measurement, take the nearest measured row / column;
- the conventional body takes the study's Table 1 (Cd, frontal area, CG height, wheel radius).
"""

from __future__ import annotations

import dataclasses
import io
import json
import re
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hevlib.io import atomic_path, read_table, read_yaml_mapping, write_json
from hevlib.sim.powertrain.lookup import interp_map

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


def _ro(a) -> np.ndarray:
    arr = np.array(a, dtype=float)
    arr.setflags(write=False)
    return arr


#: Keys whose name carries a unit (or is a coefficient, efficiency, ratio or share) hold numbers: a number,
#: or (nested) lists of numbers; null stands for a value the source leaves undefined.
_NUMERIC_KEY = re.compile(
    r"_(kw|w|nm|kg|rad_s|rpm|v|a|ohm|ah|m|m2|kg_m2|s|c|g_per_s|g_per_kwh|kmh|km_per_h|mph|"
    r"m_per_s|coefficient|efficiency|ratio|g_per_l|j_per_g|pct|n|j|w_per_k|kg_per_kw|fraction)$"
)
#: Unit-named keys the ADVISOR extract fills with words on purpose (the source leaves the value undefined).
_TEXT_ALLOWED = frozenset({"planetary_efficiency"})


def _numbers_only(value) -> bool:
    if value is None:  # undefined in the source (e.g. no voltage limit)
        return True
    if isinstance(value, bool):
        return False
    if isinstance(value, (int, float)):
        return True
    return isinstance(value, list) and all(_numbers_only(v) for v in value)


def check_numeric_keys(data: dict, path: Path, prefix: str = "") -> None:
    """Raise ValueError naming file and key when a unit-named key holds anything but numbers."""
    for key, value in data.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            check_numeric_keys(value, path, f"{name}.")
        elif _NUMERIC_KEY.search(str(key)) and key not in _TEXT_ALLOWED and not _numbers_only(value):
            shown = repr(value) if not isinstance(value, list) else "a list with a non-number"
            raise ValueError(f"{path}: {name}: {shown} is not a number")


def _read_yaml(path: Path) -> dict:
    data = read_yaml_mapping(path, what="component file")
    check_numeric_keys(data, path)
    return data


def _need(data: dict, key: str, path: Path):
    if key not in data or data[key] is None:
        raise ValueError(f"{path}: missing key {key!r}")
    return data[key]


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


_COMPONENT_TYPES = (
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


def _write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """``np.savez`` with fixed zip timestamps and key order, so equal arrays give equal bytes."""
    with atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_STORED) as zf:
        for key in sorted(arrays):
            buf = io.BytesIO()
            np.lib.format.write_array(buf, np.ascontiguousarray(arrays[key]), allow_pickle=False)
            zf.writestr(zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0)), buf.getvalue())


@dataclass(frozen=True)
class ComponentLibrary:
    """Everything the simulator needs, before sizing."""

    engine_hybrid: EngineMap  # FC_PRIUS_JPN, scaled per design
    engine_conventional: EngineMap  # FC_SI63_emis, scaled to the conventional car's power
    motor: MachineMap
    generator: MachineMap
    battery: BatteryModule
    body_conventional: Body  # the study's conventional car (Table 1) = every design's chassis
    wheel_conventional: Wheel
    body_prius: Body
    wheel_prius: Wheel
    power_split: PowerSplit
    gearbox: Gearbox
    accessory_hybrid: Accessory
    accessory_conventional: Accessory
    exhaust_kg_per_kw: float
    thermal_hybrid: EngineThermal
    thermal_conventional: EngineThermal
    catalyst: Catalyst
    conventional_idle_rad_s: float
    conventional_launch_rad_s: float
    conventional_control: ConventionalControl
    meta: dict = field(default_factory=dict, compare=False)

    # ------------------------------------------------------------------ persistence (normalised form)
    def save(self, out_dir: str | Path) -> list[Path]:
        """Write each component as ``<field>.npz`` (arrays) plus ``library.json`` (scalars, names).

        Byte-for-byte deterministic; other ``*.npz`` files left in ``out_dir`` by older runs are removed.
        """
        out_dir = Path(out_dir)
        written, index = [], {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if dataclasses.is_dataclass(value):
                items = {g.name: getattr(value, g.name) for g in dataclasses.fields(value)}
                arrays = {k: v for k, v in items.items() if isinstance(v, np.ndarray)}
                scalars = {k: v for k, v in items.items() if not isinstance(v, np.ndarray)}
                index[f.name] = {"type": type(value).__name__, "scalars": scalars}
                path = out_dir / f"{f.name}.npz"
                _write_npz(path, arrays)
                written.append(path)
            else:
                index[f.name] = value
        write_json(out_dir / "library.json", index, digits=None)  # exact: the simulator reads it
        for stale in set(out_dir.glob("*.npz")) - set(written):
            stale.unlink()
        return [*written, out_dir / "library.json"]

    @classmethod
    def load(cls, src_dir: str | Path) -> ComponentLibrary:
        src_dir = Path(src_dir)
        index_path = src_dir / "library.json"
        if not index_path.exists():
            raise FileNotFoundError(f"{index_path}: missing; run `hev components` (dvc repro components)")
        try:
            index = json.loads(index_path.read_text())
        except json.JSONDecodeError as err:
            raise ValueError(f"{index_path}: not valid JSON ({err.msg})") from None
        types = {t.__name__: t for t in _COMPONENT_TYPES}
        kwargs = {}
        for f in dataclasses.fields(cls):
            entry = index.get(f.name)
            if isinstance(entry, dict) and "type" in entry:
                path = src_dir / f"{f.name}.npz"
                if not path.exists():
                    raise FileNotFoundError(f"{path}: missing component map; run `hev components`")
                with np.load(path, allow_pickle=False) as npz:
                    arrays = {k: _ro(npz[k]) for k in npz.files}
                kwargs[f.name] = types[entry["type"]](**entry["scalars"], **arrays)
            elif f.name == "meta":
                kwargs[f.name] = entry or {}
            elif entry is None:
                raise ValueError(f"{index_path}: missing entry {f.name!r}; re-run `hev components`")
            else:
                kwargs[f.name] = entry
        return cls(**kwargs)


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


# ------------------------------------------------------------------------------------- loaders
def _peak_power_kw(speed: np.ndarray, torque: np.ndarray) -> float:
    """Peak power of a piecewise-linear torque curve (checked finely between axis points)."""
    s = np.linspace(speed[0], speed[-1], 4001)
    return float(np.max(s * np.interp(s, speed, torque)) / 1e3)


def _cover_full_load(
    torque: np.ndarray, max_torque: np.ndarray, maps: dict[str, np.ndarray]
) -> tuple[np.ndarray, dict[str, np.ndarray], list[str]]:
    """Extend the torque axis linearly to 0 N*m and to the full-load peak (clipped at >= 0)."""
    notes = []
    if torque[0] > 0:
        f = torque[0] / (torque[1] - torque[0])
        maps = {k: np.hstack([np.maximum(m[:, :1] - f * (m[:, 1:2] - m[:, :1]), 0.0), m]) for k, m in maps.items()}
        torque = np.concatenate([[0.0], torque])
        notes.append(f"torque axis extended linearly from {torque[1]:.4g} down to 0 N*m")
    t_top = float(np.max(max_torque))
    if t_top > torque[-1] * (1 + 1e-9):
        f = (t_top - torque[-1]) / (torque[-1] - torque[-2])
        maps = {k: np.hstack([m, np.maximum(m[:, -1:] + f * (m[:, -1:] - m[:, -2:-1]), 0.0)]) for k, m in maps.items()}
        notes.append(f"torque axis extended linearly from {torque[-1]:.4g} up to the full-load peak {t_top:.4g} N*m")
        torque = np.concatenate([torque, [t_top]])
    return torque, maps, notes


def _continue_above_full_load(
    torque: np.ndarray, max_torque: np.ndarray, maps: dict[str, np.ndarray]
) -> tuple[dict[str, np.ndarray], list[str]]:
    """Replace every map value above a speed row's full-load torque by the row's last segment at or below it,
    continued linearly (clipped at >= 0), so that no value measured (or filled) above the full-load curve is
    ever read: bilinear reads just below full load would otherwise blend in cells above it (the Prius map's
    cells above full load carry up to 0.475 efficiency, the source's flat fill; its stated peak is 0.36-0.39)."""
    notes = []
    out = {k: m.copy() for k, m in maps.items()}
    for i, t_lim in enumerate(max_torque):
        k = int(np.searchsorted(torque, t_lim * (1 + 1e-9), side="right")) - 1  # last node at or below full load
        if k >= len(torque) - 1:
            continue
        if k < 1:
            raise ValueError(f"full-load torque {t_lim:.4g} N*m at row {i} leaves fewer than two map columns")
        for m in out.values():
            slope = (m[i, k] - m[i, k - 1]) / (torque[k] - torque[k - 1])
            m[i, k + 1 :] = np.maximum(m[i, k] + slope * (torque[k + 1 :] - torque[k]), 0.0)
        notes.append(f"row {i}: {len(torque) - k - 1} cells above full load ({t_lim:.4g} N*m) continued linearly")
    return out, notes


def load_engine(path: Path, notes: list[str] | None = None) -> EngineMap:
    """Engine map from ADVISOR YAML, its torque axis extended to cover 0 .. full load (see module doc)."""
    d = _read_yaml(path)
    mass = _need(d, "mass_model", path)
    speed = _ro(_need(d, "speed_axis_rad_s", path))
    tmax = _ro(_need(d, "max_torque_nm", path))
    fuel_props = _need(d, "fuel_properties", path)
    maps = {k: np.array(_need(d, f"{k}_map_g_per_s", path), dtype=float) for k in ("fuel", "hc", "co", "nox")}
    torque_src = np.array(_need(d, "torque_axis_nm", path), dtype=float)
    torque, maps, extended = _cover_full_load(torque_src, tmax, maps)
    maps, continued = _continue_above_full_load(torque, tmax, maps)
    extended.append(f"values above full load continued linearly in {len(continued)} of {len(tmax)} speed rows")
    name = str(d.get("source", path.stem)).split()[-1]
    if notes is not None:
        notes.extend(f"{name}: {n}" for n in extended)
    return EngineMap(
        name=name,
        speed_rad_s=speed,
        torque_nm=_ro(torque),
        max_torque_nm=tmax,
        fuel_g_s=_ro(maps["fuel"]),
        hc_g_s=_ro(maps["hc"]),
        co_g_s=_ro(maps["co"]),
        nox_g_s=_ro(maps["nox"]),
        peak_power_kw=_peak_power_kw(speed, tmax),
        engine_mass_kg=float(mass["base_engine_mass_kg"] + mass["accessories_mass_kg"]),
        fuel_system_mass_kg=float(mass["fuel_system_mass_kg"]),
        inertia_kg_m2=float(d.get("inertia_kg_m2", DEFAULT_ENGINE_INERTIA_KG_M2)),
        lhv_j_per_g=float(fuel_props["lower_heating_value_j_per_g"]),
        fuel_density_g_per_l=float(fuel_props["density_g_per_l"]),
        closed_throttle_torque_nm=_ro(d.get("closed_throttle_torque_nm", np.zeros(len(speed)))),
    )


def load_engine_thermal(path: Path) -> EngineThermal:
    """The engine file's ``thermal_model`` (ADVISOR ``fc_*`` thermal data) and its mass split.

    Exhaust gas: ADVISOR's maps are flow = fuel x (1 + 14.5) and temperature = exhaust share x waste heat /
    (flow x 1.089 J/(g K)) + 20 C; the kernels use the same relations on the (scaled, extended) fuel map, so
    the stored maps only serve as a check (``tests/test_thermal.py``).
    """
    d = _read_yaml(path)
    th = _need(d, "thermal_model", path)
    mass = _need(d, "mass_model", path)
    lo, hi = (float(x) for x in _need(th, "exhaust_share_of_waste_heat_at_min_and_max_speed", path))
    return EngineThermal(
        base_engine_mass_kg=float(mass["base_engine_mass_kg"]),
        accessories_mass_kg=float(mass["accessories_mass_kg"]),
        specific_heat_j_per_kg_k=float(_need(th, "engine_specific_heat_j_per_kg_k", path)),
        hood_specific_heat_j_per_kg_k=float(_need(th, "hood_compartment_specific_heat_j_per_kg_k", path)),
        exterior_area_m2=float(_need(th, "engine_exterior_surface_area_m2", path)),
        hood_area_m2=float(_need(th, "hood_surface_area_m2", path)),
        emissivity=float(_need(th, "engine_surface_emissivity", path)),
        hood_emissivity=float(_need(th, "hood_exterior_emissivity", path)),
        cyl_to_block_w_per_k=float(_need(th, "cylinder_to_interior_conductance_w_per_k", path)),
        block_to_exterior_w_per_k=float(_need(th, "interior_to_exterior_conductance_w_per_k", path)),
        exterior_to_hood_w_per_k=float(_need(th, "engine_to_compartment_conductance_w_per_k", path)),
        thermostat_c=float(_need(th, "thermostat_temperature_c", path)),
        exhaust_share_min_speed=lo,
        exhaust_share_max_speed=hi,
        air_fuel_ratio=EXHAUST_AIR_FUEL_RATIO,
        map_reference_c=EXHAUST_MAP_REFERENCE_C,
        has_cold_maps=bool(d.get("has_cold_start_maps", False)),
    )


def _shift_speed_rad_s(point: str, max_map_speed_rad_s: float, path: Path) -> float:
    """One breakpoint of ``PTC_CONV``'s shift curves: ``'<n> rpm'`` or ``'<f> x max map speed x speed scale'``
    (the engine is scaled in torque at a fixed speed axis, so its speed scale is 1)."""
    m = re.fullmatch(r"\s*([0-9.]+)\s*rpm\s*", point)
    if m:
        return float(m.group(1)) * RPM
    m = re.fullmatch(r"\s*([0-9.]+)\s*x\s*max map speed x speed scale\s*", point)
    if m:
        return float(m.group(1)) * max_map_speed_rad_s
    raise ValueError(f"{path}: shift-curve speed {point!r} is not '<n> rpm' or '<f> x max map speed x speed scale'")


def load_conventional_control(path: Path, max_map_speed_rad_s: float) -> ConventionalControl:
    """``PTC_CONV``: clutch and idle flags, and the load-based shift curves evaluated for an engine whose map
    ends at ``max_map_speed_rad_s`` (PTC_CONV.m: 800/1500 rpm and 0.5/0.501/0.98 x the map's top speed)."""
    d = _read_yaml(path)
    shift = _need(d, "load_based_shift_logic", path)

    def curve(kind: str) -> tuple[np.ndarray, np.ndarray]:
        w = np.array([_shift_speed_rad_s(p, max_map_speed_rad_s, path) for p in shift[f"{kind}_engine_speed_points"]])
        load = np.array(shift[f"{kind}_load"], dtype=float)
        if len(w) != len(load) or len(w) < 2 or np.any(np.diff(w) <= 0):
            raise ValueError(f"{path}: {kind} curve needs increasing speeds, one load per speed")
        return _ro(w), _ro(load)

    up_w, up_load = curve("upshift")
    dn_w, dn_load = curve("downshift")
    return ConventionalControl(
        idle_allowed=bool(_need(d, "engine_idling_allowed", path)),
        clutch_opens_without_torque=bool(_need(d, "clutch_disengaged_when_engine_torque_request_not_positive", path)),
        upshift_speed_rad_s=up_w,
        upshift_load=up_load,
        downshift_speed_rad_s=dn_w,
        downshift_load=dn_load,
        shift_delay_s=float(_need(d, "shift_delay_s", path)),
    )


def load_catalyst(path: Path) -> Catalyst:
    """``EX_SI``: conversion table, breakthrough limits, mass/area rules and thermal data."""
    d = _read_yaml(path)
    conv = _need(d, "conversion_efficiency", path)
    rule = _need(d, "mass_rule", path)
    shares = rule["shares_of_catalyst_mass"]
    cat = float(rule["catalyst_share_of_exhaust_mass"])
    th = _need(d, "thermal", path)
    eps = th["emissivity"]
    lim = [float(x) for x in _need(d, "breakthrough_limit_g_per_s", path)["values_hc_co_nox_pm"]]
    # the area rules as evaluated for the Prius engine: monolith 0.1 (p / 100)^0.67, manifold (p / 600) (0.3 + 0.7)
    ev = _need(d, "evaluated_with_FC_PRIUS_JPN", path)
    p_ev = float(ev["engine_peak_power_kw"])
    t = np.array(_need(d, "catalyst_temperature_axis_c", path), dtype=float)
    return Catalyst(
        temperature_c=_ro(t),
        conversion_hc=_ro(np.array(conv["hc"], dtype=float)),
        conversion_co=_ro(np.array(conv["co"], dtype=float)),
        conversion_nox=_ro(np.array(conv["nox"], dtype=float)),
        breakthrough_hc_g_s=lim[0],
        breakthrough_co_g_s=lim[1],
        breakthrough_nox_g_s=lim[2],
        exhaust_kg_per_kw=float(rule["exhaust_system_kg_per_engine_kw"]),
        monolith_share=cat * float(shares["monolith"]),
        shell_share=cat * float(shares["inner_shell"]),
        pipe_share=cat * float(shares["pipes"]),
        shield_share=cat * float(shares["outer_shell"]),
        manifold_share=float(rule["manifold_share_of_exhaust_mass"]),
        monolith_cp_j_per_kg_k=float(th["monolith_specific_heat_j_per_kg_k"]),
        steel_cp_j_per_kg_k=float(th["inner_shell_specific_heat_j_per_kg_k"]),
        gas_cp_j_per_g_k=float(th["exhaust_gas_specific_heat_j_per_kg_k"]) / 1000.0,
        monolith_area_coef_m2=float(ev["monolith_outer_area_m2"]) / (p_ev / 100.0) ** AREA_EXPONENT,
        monolith_area_exp=AREA_EXPONENT,
        manifold_area_m2_per_kw=float(ev["manifold_area_m2"]) / p_ev,
        emissivity_monolith_pipe=float(eps["monolith_to_pipes"]),
        emissivity_shell_shield=float(eps["interior_to_shield"]),
        emissivity_pipe=float(eps["pipe"]),
        emissivity_shield=float(eps["shield"]),
        emissivity_manifold=float(eps["manifold"]),
        monolith_shell_temperature_c=_ro(np.array(th["monolith_to_interior_conductance_temperature_c"], dtype=float)),
        monolith_shell_w_per_k=_ro(np.array(th["monolith_to_interior_conductance_w_per_k"], dtype=float)),
        shell_shield_w_per_k=float(th["interior_to_shield_conductance_w_per_k"]),
        shell_pipe_w_per_k=float(th["interior_to_pipe_conductance_w_per_k"]),
        pipe_shield_w_per_k=float(th["pipe_to_shield_conductance_w_per_k"]),
    )


def load_machine(path: Path, *, generator: bool, notes: list[str] | None = None) -> MachineMap:
    """Motor (speed >= 0, torque +/-) or generator (speed +/-, torque +/-) reduced to |speed|, |torque|.

    The zero-speed row and zero-torque column are fills in both sources (not measurements); they take
    the nearest measured row / column, so low-speed and low-torque efficiency is not overstated.
    """
    d = _read_yaml(path)
    speed = np.array(_need(d, "speed_axis_rad_s", path), dtype=float)
    torque = np.array(_need(d, "torque_axis_nm", path), dtype=float)
    eff = np.array(_need(d, "efficiency_map", path), dtype=float)
    tmax_key = "max_torque_nm" if generator else "max_torque_motoring_nm"
    tmax = np.abs(np.array(_need(d, tmax_key, path), dtype=float))
    rows, cols = speed >= 0, torque >= 0
    speed, tmax, eff = speed[rows], tmax[rows], eff[rows][:, cols]
    torque = torque[cols]
    name = str(d.get("source", path.stem)).split()[-1]
    changed = []
    if speed[0] == 0 and not np.array_equal(eff[0], eff[1]):
        eff[0] = eff[1]
        changed.append(f"zero-speed row set to the {speed[1] / RPM:g} rpm row")
    if torque[0] == 0 and not np.array_equal(eff[:, 0], eff[:, 1]):
        eff[:, 0] = eff[:, 1]
        changed.append(f"zero-torque column set to the {torque[1]:g} N*m column")
    if notes is not None:
        notes.extend(f"{name}: {n} (source fill replaced)" for n in changed)
    return MachineMap(
        name=name,
        speed_rad_s=_ro(speed),
        torque_nm=_ro(torque),
        efficiency=_ro(eff),
        max_torque_nm=_ro(tmax),
        peak_power_kw=_peak_power_kw(speed, tmax),
        mass_kg=float(_need(d, "mass_kg", path)),
        inertia_kg_m2=float(d.get("inertia_kg_m2", DEFAULT_MACHINE_INERTIA_KG_M2)),
    )


def load_battery(path: Path, temperature_c: float) -> BatteryModule:
    """Battery module at the table row nearest ``temperature_c`` (SPEC: warmest Li-ion row by default)."""
    d = _read_yaml(path)
    temps = np.array(_need(d, "temperature_axis_c", path), dtype=float)
    i = int(np.argmin(np.abs(temps - temperature_c)))

    def row(key: str) -> np.ndarray:
        return _ro(np.array(_need(d, key, path), dtype=float)[i])

    return BatteryModule(
        name=str(d.get("source", path.stem)).split()[-1],
        soc=_ro(_need(d, "soc_axis", path)),
        ocv_v=row("open_circuit_voltage_v"),
        r_dis_ohm=row("discharge_resistance_ohm"),
        r_chg_ohm=row("charge_resistance_ohm"),
        capacity_ah=float(np.array(_need(d, "capacity_ah", path))[i]),
        coulombic_efficiency=float(np.array(_need(d, "coulombic_efficiency", path))[i]),
        v_min=float(_need(d, "min_voltage_v", path)),
        v_max=float(_need(d, "max_voltage_v", path)),
        mass_kg=float(_need(d, "module_mass_kg", path)),
        temperature_c=float(temps[i]),
    )


def load_body(path: Path) -> Body:
    d = _read_yaml(path)
    return Body(
        name=str(d.get("source", path.stem)).split()[-1],
        glider_mass_kg=float(_need(d, "glider_mass_kg", path)),
        cargo_mass_kg=float(_need(d, "cargo_mass_kg", path)),
        drag_coefficient=float(_need(d, "drag_coefficient", path)),
        frontal_area_m2=float(_need(d, "frontal_area_m2", path)),
        cg_height_m=float(_need(d, "cg_height_m", path)),
        wheelbase_m=float(_need(d, "wheelbase_m", path)),
        front_weight_fraction=float(_need(d, "front_axle_weight_fraction", path)),
        air_density_kg_m3=float(d.get("air_density_kg_per_m3", 1.2)),
        gravity_m_s2=float(d.get("gravity_m_per_s2", 9.81)),
    )


def load_wheel(path: Path) -> Wheel:
    d = _read_yaml(path)
    axle = _need(d, "axle_loss", path)
    m, t = axle["vehicle_mass_kg"], axle["drag_torque_nm"]
    braking = _need(d, "braking", path)
    v_kmh = np.array(_need(braking, "vehicle_speed_km_per_h", path), dtype=float)
    share = np.array(_need(braking, "driveline_fraction", path), dtype=float)
    keep = v_kmh >= 0.0  # the file's -1 mph point only pads the table
    if v_kmh.shape != share.shape or np.any(np.diff(v_kmh[keep]) <= 0) or np.any((share < 0) | (share > 1)):
        raise ValueError(f"{path}: braking: speed axis must increase and driveline_fraction lie in [0, 1]")
    return Wheel(
        name=str(d.get("source", path.stem)).split()[-1],
        radius_m=float(_need(d, "rolling_radius_m", path)),
        rolling_resistance=float(_need(d, "rolling_resistance_coefficient", path)),
        inertia_kg_m2=float(d.get("inertia_kg_m2", DEFAULT_WHEEL_INERTIA_KG_M2)),
        axle_drag_nm_at_0kg=float(t[0]),
        axle_drag_nm_per_kg=float((t[1] - t[0]) / (m[1] - m[0])),
        brake_speed_mps=_ro(v_kmh[keep] / 3.6),
        brake_driveline_share=_ro(share[keep]),
    )


#: Table 1 of the study (``data/raw/paper/table1_baseline_vehicles.csv``): row name -> (our key, unit).
TABLE1_ROWS = {
    "vehicle_mass": ("test_mass_kg", "kg"),
    "engine_max_power": ("p_eng_kw", "kW"),
    "motor_max_power": ("p_mot_kw", "kW"),
    "generator_max_power": ("p_gen_kw", "kW"),
    "drag_coefficient": ("drag_coefficient", "-"),
    "frontal_area": ("frontal_area_m2", "m2"),
    "cg_height": ("cg_height_m", "m"),
    "wheel_radius": ("wheel_radius_m", "m"),
    "overall_gear_ratios": ("gear_ratios", "-"),
    "final_drive_ratio": ("final_drive_ratio", "-"),
}


def read_baseline_table(path: str | Path) -> dict[str, dict]:
    """The study's Table 1 as ``{"conventional": {...}, "prius": {...}}`` in our key names (SI units).

    Empty cells are left out; ``gear_ratios`` is a list (``;``-separated in the file).
    """
    path = Path(path)
    df = read_table(path)
    for col in ("parameter", "unit", "conventional", "prius"):
        if col not in df.columns:
            raise ValueError(f"{path}: missing column {col!r}")
    out: dict[str, dict] = {"conventional": {}, "prius": {}}
    for _, r in df.iterrows():
        if r["parameter"] not in TABLE1_ROWS:
            continue
        key, unit = TABLE1_ROWS[r["parameter"]]
        if str(r["unit"]) != unit:
            raise ValueError(f"{path}: {r['parameter']}: unit {r['unit']!r}, expected {unit!r}")
        for car in out:
            cell = r[car]
            if cell is None or (isinstance(cell, float) and np.isnan(cell)) or str(cell).strip() == "":
                continue
            try:
                vals = [float(v) for v in str(cell).split(";")]
            except ValueError:
                raise ValueError(f"{path}: {r['parameter']} ({car}): {cell!r} is not a number") from None
            out[car][key] = vals if key == "gear_ratios" else vals[0]
    for car in out:
        missing = [
            k for k in ("drag_coefficient", "frontal_area_m2", "cg_height_m", "wheel_radius_m") if k not in out[car]
        ]
        if missing:
            raise ValueError(f"{path}: {car}: missing {', '.join(missing)}")
    return out


def read_paper_row(path: str | Path, column: str, value) -> dict:
    """The row of a study table (CSV) whose ``column`` equals ``value``, as a dict (errors name the file)."""
    path = Path(path)
    df = read_table(path)
    if column not in df.columns:
        raise ValueError(f"{path}: missing column {column!r}")
    rows = df[df[column] == value]
    if rows.empty:
        raise ValueError(f"{path}: no row with {column} = {value!r}")
    cells = {k: df[k].at[rows.index[0]] for k in df.columns}  # per column: keeps int columns int
    return {k: (v.item() if isinstance(v, np.generic) else v) for k, v in cells.items()}


def _accessory(d: dict) -> Accessory:
    return Accessory(float(d["electrical_load_w"]), float(d["mechanical_load_w"]))


@dataclass(frozen=True)
class CarFiles:
    """One car's body and wheel files, with the values that replace the files' (``Body`` / ``Wheel`` field
    names, SI)."""

    body: str
    wheel: str
    body_values: dict = dataclasses.field(default_factory=dict)
    wheel_values: dict = dataclasses.field(default_factory=dict)

    def load(self, raw: Path) -> tuple[Body, Wheel]:
        body, wheel = load_body(raw / self.body), load_wheel(raw / self.wheel)
        return dataclasses.replace(body, **self.body_values), dataclasses.replace(wheel, **self.wheel_values)


@dataclass(frozen=True)
class LibraryFiles:
    """Which component file is which part (file names in the component directory; params.yaml's
    ``baseline`` group, :func:`hevlib.sizing.library_files`)."""

    conventional: CarFiles
    prius: CarFiles
    engine_conventional: str
    gearbox: str
    accessory_conventional: str
    control_conventional: str
    engine_hybrid: str
    motor: str
    generator: str
    control_hybrid: str
    transmission: str
    accessory_hybrid: str
    battery: str
    exhaust: str


def load_library(
    raw_dir: str | Path,
    files: LibraryFiles,
    *,
    battery_temperature_c: float = 41.0,
    gear_ratios: list[float] | None = None,
    conventional_idle_rpm: float = 800.0,
) -> ComponentLibrary:
    """Load every component of the study from ``raw_dir`` (ADVISOR YAML), each part from the file ``files``
    names, bodies and wheels with ``files``' values in place of the files' own. The conventional car's glider
    mass is its body file's here; :func:`hevlib.sizing.with_conventional_glider` replaces it by the one the
    conventional car's test mass implies.
    """
    raw = Path(raw_dir)
    if not raw.is_dir():
        raise FileNotFoundError(f"{raw}: component directory missing")
    notes: list[str] = []
    ptc = _read_yaml(raw / files.control_hybrid)
    tx = _read_yaml(raw / files.transmission)
    gb = _read_yaml(raw / files.gearbox)
    ex = _read_yaml(raw / files.exhaust)
    acc_h, acc_c = _read_yaml(raw / files.accessory_hybrid), _read_yaml(raw / files.accessory_conventional)
    doc = _need(tx, "from_advisor_documentation", raw / files.transmission)
    reg = _need(gb, "loss_regression", raw / files.gearbox)
    body_c, wheel_c = files.conventional.load(raw)
    body_p, wheel_p = files.prius.load(raw)
    ratios = np.array(gear_ratios if gear_ratios is not None else gb["overall_gear_ratios"], dtype=float)
    engine_hybrid = load_engine(raw / files.engine_hybrid, notes)
    engine_conventional = load_engine(raw / files.engine_conventional, notes)
    motor = load_machine(raw / files.motor, generator=False, notes=notes)
    generator = load_machine(raw / files.generator, generator=True, notes=notes)
    # PTC_CONV rules: idle = the configured idle speed (ADVISOR: at least 800 rpm and enough for twice the
    # accessory load, which any engine of this size meets at 800 rpm); launch = max(w_max / 5, 1.5 idle)
    idle = float(conventional_idle_rpm) * RPM
    return ComponentLibrary(
        engine_hybrid=engine_hybrid,
        engine_conventional=engine_conventional,
        motor=motor,
        generator=generator,
        battery=load_battery(raw / files.battery, battery_temperature_c),
        body_conventional=body_c,
        wheel_conventional=wheel_c,
        body_prius=body_p,
        wheel_prius=wheel_p,
        power_split=PowerSplit(
            n_r=int(tx["ring_gear_teeth"]),
            n_s=int(tx["sun_gear_teeth"]),
            i0=float(tx["final_drive_ratio"]),
            n_planets=int(doc["planet_gear_count"]),
            planet_teeth=int(doc["planet_gear_teeth"]),
            engine_max_speed_rad_s=float(ptc["engine_max_speed_rad_s"]),
            motor_max_speed_rad_s=float(doc["motor_speed_limit_rpm"]) * RPM,
            generator_max_speed_rad_s=float(ptc["generator_max_speed_rad_s"]),
            # the engine runs wherever its map has data (ADVISOR's 1200 rpm idle/fuel-cut speed is a control
            # choice of the stock Prius, not a limit of the engine: with the generator's speed limit it leaves
            # no running speed at standstill for k > 3.58 and would stall such designs)
            engine_min_on_speed_rad_s=engine_hybrid.min_speed_rad_s,
            operating_line_power_w=_ro(ptc["engine_operating_line"]["power_w"]),
            operating_line_speed_rad_s=_ro(ptc["engine_operating_line"]["speed_rad_s"]),
            engine_startup_inertia_kg_m2=float(ptc["engine_startup_effective_inertia_kg_m2"]),
            engine_crank_torque_nm=float(ptc["engine_crank_torque_nm"]),
            engine_firing_speed_rad_s=float(ptc["engine_fuel_cut_below_speed_rad_s"]),
            coolant_warmup_temperature_c=float(ptc["coolant_warmup_temperature_c"]),
        ),
        gearbox=Gearbox(
            name=Path(files.gearbox).stem,
            ratios=_ro(ratios),
            mass_kg=float(gb["transmission_mass_kg"]),
            loss_coefficients=_ro(
                [
                    reg["a_input_speed"],
                    reg["b_output_speed"],
                    reg["c_input_torque"],
                    reg["d_output_torque"],
                    reg["e_output_power"],
                    reg["f_constant_w"],
                ]
            ),
        ),
        accessory_hybrid=_accessory(acc_h),
        accessory_conventional=_accessory(acc_c),
        exhaust_kg_per_kw=float(ex["mass_rule"]["exhaust_system_kg_per_engine_kw"]),
        thermal_hybrid=load_engine_thermal(raw / files.engine_hybrid),
        thermal_conventional=load_engine_thermal(raw / files.engine_conventional),
        catalyst=load_catalyst(raw / files.exhaust),
        conventional_idle_rad_s=idle,
        conventional_launch_rad_s=max(engine_conventional.max_speed_rad_s / 5.0, 1.5 * idle),
        conventional_control=load_conventional_control(
            raw / files.control_conventional, engine_conventional.max_speed_rad_s
        ),
        meta={"raw_dir": str(raw), "battery_file": files.battery, "normalisation": notes},
    )
