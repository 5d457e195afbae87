"""Reading ADVISOR's component files (data/raw/components, YAML): every file checked (a unit-named key holds
numbers only; errors name the file and the key) and normalised as the package documents."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from hevlib.components.parts import (
    AREA_EXPONENT,
    DEFAULT_ENGINE_INERTIA_KG_M2,
    DEFAULT_MACHINE_INERTIA_KG_M2,
    DEFAULT_WHEEL_INERTIA_KG_M2,
    EXHAUST_AIR_FUEL_RATIO,
    EXHAUST_MAP_REFERENCE_C,
    RPM,
    Accessory,
    BatteryModule,
    Body,
    Catalyst,
    ConventionalControl,
    EngineMap,
    EngineThermal,
    MachineMap,
    Wheel,
    read_only,
)
from hevlib.io import read_yaml_mapping

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


def read_component_file(path: Path) -> dict:
    data = read_yaml_mapping(path, what="component file")
    check_numeric_keys(data, path)
    return data


def required(data: dict, key: str, path: Path):
    if key not in data or data[key] is None:
        raise ValueError(f"{path}: missing key {key!r}")
    return data[key]


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
    d = read_component_file(path)
    mass = required(d, "mass_model", path)
    speed = read_only(required(d, "speed_axis_rad_s", path))
    tmax = read_only(required(d, "max_torque_nm", path))
    fuel_props = required(d, "fuel_properties", path)
    maps = {k: np.array(required(d, f"{k}_map_g_per_s", path), dtype=float) for k in ("fuel", "hc", "co", "nox")}
    torque_src = np.array(required(d, "torque_axis_nm", path), dtype=float)
    torque, maps, extended = _cover_full_load(torque_src, tmax, maps)
    maps, continued = _continue_above_full_load(torque, tmax, maps)
    extended.append(f"values above full load continued linearly in {len(continued)} of {len(tmax)} speed rows")
    name = str(d.get("source", path.stem)).split()[-1]
    if notes is not None:
        notes.extend(f"{name}: {n}" for n in extended)
    return EngineMap(
        name=name,
        speed_rad_s=speed,
        torque_nm=read_only(torque),
        max_torque_nm=tmax,
        fuel_g_s=read_only(maps["fuel"]),
        hc_g_s=read_only(maps["hc"]),
        co_g_s=read_only(maps["co"]),
        nox_g_s=read_only(maps["nox"]),
        peak_power_kw=_peak_power_kw(speed, tmax),
        engine_mass_kg=float(mass["base_engine_mass_kg"] + mass["accessories_mass_kg"]),
        fuel_system_mass_kg=float(mass["fuel_system_mass_kg"]),
        inertia_kg_m2=float(d.get("inertia_kg_m2", DEFAULT_ENGINE_INERTIA_KG_M2)),
        lhv_j_per_g=float(fuel_props["lower_heating_value_j_per_g"]),
        fuel_density_g_per_l=float(fuel_props["density_g_per_l"]),
        closed_throttle_torque_nm=read_only(d.get("closed_throttle_torque_nm", np.zeros(len(speed)))),
    )


def load_engine_thermal(path: Path) -> EngineThermal:
    """The engine file's ``thermal_model`` (ADVISOR ``fc_*`` thermal data) and its mass split.

    Exhaust gas: ADVISOR's maps are flow = fuel x (1 + 14.5) and temperature = exhaust share x waste heat /
    (flow x 1.089 J/(g K)) + 20 C; the kernels use the same relations on the (scaled, extended) fuel map, so
    the stored maps only serve as a check (``tests/test_thermal.py``).
    """
    d = read_component_file(path)
    th = required(d, "thermal_model", path)
    mass = required(d, "mass_model", path)
    lo, hi = (float(x) for x in required(th, "exhaust_share_of_waste_heat_at_min_and_max_speed", path))
    return EngineThermal(
        base_engine_mass_kg=float(mass["base_engine_mass_kg"]),
        accessories_mass_kg=float(mass["accessories_mass_kg"]),
        specific_heat_j_per_kg_k=float(required(th, "engine_specific_heat_j_per_kg_k", path)),
        hood_specific_heat_j_per_kg_k=float(required(th, "hood_compartment_specific_heat_j_per_kg_k", path)),
        exterior_area_m2=float(required(th, "engine_exterior_surface_area_m2", path)),
        hood_area_m2=float(required(th, "hood_surface_area_m2", path)),
        emissivity=float(required(th, "engine_surface_emissivity", path)),
        hood_emissivity=float(required(th, "hood_exterior_emissivity", path)),
        cyl_to_block_w_per_k=float(required(th, "cylinder_to_interior_conductance_w_per_k", path)),
        block_to_exterior_w_per_k=float(required(th, "interior_to_exterior_conductance_w_per_k", path)),
        exterior_to_hood_w_per_k=float(required(th, "engine_to_compartment_conductance_w_per_k", path)),
        thermostat_c=float(required(th, "thermostat_temperature_c", path)),
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
    d = read_component_file(path)
    shift = required(d, "load_based_shift_logic", path)

    def curve(kind: str) -> tuple[np.ndarray, np.ndarray]:
        w = np.array([_shift_speed_rad_s(p, max_map_speed_rad_s, path) for p in shift[f"{kind}_engine_speed_points"]])
        load = np.array(shift[f"{kind}_load"], dtype=float)
        if len(w) != len(load) or len(w) < 2 or np.any(np.diff(w) <= 0):
            raise ValueError(f"{path}: {kind} curve needs increasing speeds, one load per speed")
        return read_only(w), read_only(load)

    up_w, up_load = curve("upshift")
    dn_w, dn_load = curve("downshift")
    return ConventionalControl(
        idle_allowed=bool(required(d, "engine_idling_allowed", path)),
        clutch_opens_without_torque=bool(
            required(d, "clutch_disengaged_when_engine_torque_request_not_positive", path)
        ),
        upshift_speed_rad_s=up_w,
        upshift_load=up_load,
        downshift_speed_rad_s=dn_w,
        downshift_load=dn_load,
        shift_delay_s=float(required(d, "shift_delay_s", path)),
    )


def load_catalyst(path: Path) -> Catalyst:
    """``EX_SI``: conversion table, breakthrough limits, mass/area rules and thermal data."""
    d = read_component_file(path)
    conv = required(d, "conversion_efficiency", path)
    rule = required(d, "mass_rule", path)
    shares = rule["shares_of_catalyst_mass"]
    cat = float(rule["catalyst_share_of_exhaust_mass"])
    th = required(d, "thermal", path)
    eps = th["emissivity"]
    lim = [float(x) for x in required(d, "breakthrough_limit_g_per_s", path)["values_hc_co_nox_pm"]]
    # the area rules as evaluated for the Prius engine: monolith 0.1 (p / 100)^0.67, manifold (p / 600) (0.3 + 0.7)
    ev = required(d, "evaluated_with_FC_PRIUS_JPN", path)
    p_ev = float(ev["engine_peak_power_kw"])
    t = np.array(required(d, "catalyst_temperature_axis_c", path), dtype=float)
    return Catalyst(
        temperature_c=read_only(t),
        conversion_hc=read_only(np.array(conv["hc"], dtype=float)),
        conversion_co=read_only(np.array(conv["co"], dtype=float)),
        conversion_nox=read_only(np.array(conv["nox"], dtype=float)),
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
        monolith_shell_temperature_c=read_only(
            np.array(th["monolith_to_interior_conductance_temperature_c"], dtype=float)
        ),
        monolith_shell_w_per_k=read_only(np.array(th["monolith_to_interior_conductance_w_per_k"], dtype=float)),
        shell_shield_w_per_k=float(th["interior_to_shield_conductance_w_per_k"]),
        shell_pipe_w_per_k=float(th["interior_to_pipe_conductance_w_per_k"]),
        pipe_shield_w_per_k=float(th["pipe_to_shield_conductance_w_per_k"]),
    )


def load_machine(path: Path, *, generator: bool, notes: list[str] | None = None) -> MachineMap:
    """Motor (speed >= 0, torque +/-) or generator (speed +/-, torque +/-) reduced to |speed|, |torque|.

    The zero-speed row and zero-torque column are fills in both sources (not measurements); they take
    the nearest measured row / column, so low-speed and low-torque efficiency is not overstated.
    """
    d = read_component_file(path)
    speed = np.array(required(d, "speed_axis_rad_s", path), dtype=float)
    torque = np.array(required(d, "torque_axis_nm", path), dtype=float)
    eff = np.array(required(d, "efficiency_map", path), dtype=float)
    tmax_key = "max_torque_nm" if generator else "max_torque_motoring_nm"
    tmax = np.abs(np.array(required(d, tmax_key, path), dtype=float))
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
        speed_rad_s=read_only(speed),
        torque_nm=read_only(torque),
        efficiency=read_only(eff),
        max_torque_nm=read_only(tmax),
        peak_power_kw=_peak_power_kw(speed, tmax),
        mass_kg=float(required(d, "mass_kg", path)),
        inertia_kg_m2=float(d.get("inertia_kg_m2", DEFAULT_MACHINE_INERTIA_KG_M2)),
    )


def load_battery(path: Path, temperature_c: float) -> BatteryModule:
    """Battery module at the table row nearest ``temperature_c`` (SPEC: warmest Li-ion row by default)."""
    d = read_component_file(path)
    temps = np.array(required(d, "temperature_axis_c", path), dtype=float)
    i = int(np.argmin(np.abs(temps - temperature_c)))

    def row(key: str) -> np.ndarray:
        return read_only(np.array(required(d, key, path), dtype=float)[i])

    return BatteryModule(
        name=str(d.get("source", path.stem)).split()[-1],
        soc=read_only(required(d, "soc_axis", path)),
        ocv_v=row("open_circuit_voltage_v"),
        r_dis_ohm=row("discharge_resistance_ohm"),
        r_chg_ohm=row("charge_resistance_ohm"),
        capacity_ah=float(np.array(required(d, "capacity_ah", path))[i]),
        coulombic_efficiency=float(np.array(required(d, "coulombic_efficiency", path))[i]),
        v_min=float(required(d, "min_voltage_v", path)),
        v_max=float(required(d, "max_voltage_v", path)),
        mass_kg=float(required(d, "module_mass_kg", path)),
        temperature_c=float(temps[i]),
    )


def load_body(path: Path) -> Body:
    d = read_component_file(path)
    return Body(
        name=str(d.get("source", path.stem)).split()[-1],
        glider_mass_kg=float(required(d, "glider_mass_kg", path)),
        cargo_mass_kg=float(required(d, "cargo_mass_kg", path)),
        drag_coefficient=float(required(d, "drag_coefficient", path)),
        frontal_area_m2=float(required(d, "frontal_area_m2", path)),
        cg_height_m=float(required(d, "cg_height_m", path)),
        wheelbase_m=float(required(d, "wheelbase_m", path)),
        front_weight_fraction=float(required(d, "front_axle_weight_fraction", path)),
        air_density_kg_m3=float(d.get("air_density_kg_per_m3", 1.2)),
        gravity_m_s2=float(d.get("gravity_m_per_s2", 9.81)),
    )


def load_wheel(path: Path) -> Wheel:
    d = read_component_file(path)
    axle = required(d, "axle_loss", path)
    m, t = axle["vehicle_mass_kg"], axle["drag_torque_nm"]
    braking = required(d, "braking", path)
    v_kmh = np.array(required(braking, "vehicle_speed_km_per_h", path), dtype=float)
    share = np.array(required(braking, "driveline_fraction", path), dtype=float)
    keep = v_kmh >= 0.0  # the file's -1 mph point only pads the table
    if v_kmh.shape != share.shape or np.any(np.diff(v_kmh[keep]) <= 0) or np.any((share < 0) | (share > 1)):
        raise ValueError(f"{path}: braking: speed axis must increase and driveline_fraction lie in [0, 1]")
    return Wheel(
        name=str(d.get("source", path.stem)).split()[-1],
        radius_m=float(required(d, "rolling_radius_m", path)),
        rolling_resistance=float(required(d, "rolling_resistance_coefficient", path)),
        inertia_kg_m2=float(d.get("inertia_kg_m2", DEFAULT_WHEEL_INERTIA_KG_M2)),
        axle_drag_nm_at_0kg=float(t[0]),
        axle_drag_nm_per_kg=float((t[1] - t[0]) / (m[1] - m[0])),
        brake_speed_mps=read_only(v_kmh[keep] / 3.6),
        brake_driveline_share=read_only(share[keep]),
    )


def load_accessory(d: dict) -> Accessory:
    return Accessory(float(d["electrical_load_w"]), float(d["mechanical_load_w"]))
