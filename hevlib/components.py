"""Component data as typed, immutable objects, loaded from ADVISOR's published data (data/raw/components).

Maps keep the source axes in SI units. The normalised form written by the ``components`` stage
(``data/components/*.npz``) is what the simulator reads; raw YAML is read only by that stage.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from hevlib.io import atomic_path, write_json

RPM = np.pi / 30.0  # rad/s per rpm


def _ro(a) -> np.ndarray:
    arr = np.array(a, dtype=float)
    arr.setflags(write=False)
    return arr


def _read_yaml(path: Path) -> dict:
    if not path.exists():
        raise FileNotFoundError(f"{path}: component file missing")
    data = yaml.safe_load(path.read_text())
    if not isinstance(data, dict):
        raise ValueError(f"{path}: not a component mapping")
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
    max_torque_nm: np.ndarray           # full load, indexed by speed_rad_s
    fuel_g_s: np.ndarray                # (n_speed, n_torque)
    hc_g_s: np.ndarray
    co_g_s: np.ndarray
    nox_g_s: np.ndarray
    peak_power_kw: float                # max of max_torque x speed on the speed axis
    engine_mass_kg: float               # base engine + accessories (scales with power)
    fuel_system_mass_kg: float          # does not scale (ADVISOR rule)
    inertia_kg_m2: float
    lhv_j_per_g: float
    fuel_density_g_per_l: float

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

    @property
    def max_speed_rad_s(self) -> float:
        return float(self.speed_rad_s[-1])

    @property
    def min_speed_rad_s(self) -> float:
        return float(self.speed_rad_s[0])

    def bsfc_g_per_kwh(self) -> np.ndarray:
        """BSFC on the grid (NaN above full load or at zero power)."""
        p_kw = self.speed_rad_s[:, None] * self.torque_nm[None, :] / 1e3
        with np.errstate(divide="ignore", invalid="ignore"):
            bsfc = self.fuel_g_s / p_kw * 3600.0
        above = self.torque_nm[None, :] > self.max_torque_nm[:, None] + 1e-9
        bsfc[above | (p_kw <= 0)] = np.nan
        return bsfc

    def min_bsfc_g_per_kwh(self) -> float:
        """Lowest BSFC over grid points at or below full load."""
        return float(np.nanmin(self.bsfc_g_per_kwh()))


@dataclass(frozen=True)
class MachineMap:
    """Electric machine with inverter: efficiency vs |speed| and |torque| (first quadrant, mirrored)."""

    name: str
    speed_rad_s: np.ndarray             # >= 0
    torque_nm: np.ndarray               # >= 0
    efficiency: np.ndarray              # (n_speed, n_torque), used for motoring (P_e = P_m/eff) and generating (P_e = P_m*eff)
    max_torque_nm: np.ndarray           # magnitude limit vs speed_rad_s
    peak_power_kw: float
    mass_kg: float
    inertia_kg_m2: float

    def __post_init__(self):
        if self.efficiency.shape != (len(self.speed_rad_s), len(self.torque_nm)):
            raise ValueError(f"machine {self.name}: efficiency map shape mismatch")
        if np.any(self.efficiency <= 0) or np.any(self.efficiency > 1):
            raise ValueError(f"machine {self.name}: efficiency must lie in (0, 1]")

    @property
    def max_speed_rad_s(self) -> float:
        return float(self.speed_rad_s[-1])


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
        """Module energy: capacity x mean OCV over SOC (trapezoid)."""
        return float(self.capacity_ah * np.trapezoid(self.ocv_v, self.soc))


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
    inertia_kg_m2: float
    axle_drag_nm_at_0kg: float
    axle_drag_nm_per_kg: float


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
    engine_min_on_speed_rad_s: float    # lowest running speed (PTC_PRIUS_JPN: 1200 rpm)
    operating_line_power_w: np.ndarray  # ADVISOR's 5-point Prius operating line (for comparison)
    operating_line_speed_rad_s: np.ndarray


@dataclass(frozen=True)
class Gearbox:
    """Manual 5-speed (overall ratios, final drive included) with the TX_VW loss regression."""

    name: str
    ratios: np.ndarray
    mass_kg: float
    loss_coefficients: np.ndarray       # a, b, c, d, e, f of P_loss = (a r + b) w + (c/r + d)|T| + e P + f


@dataclass(frozen=True)
class Accessory:
    electrical_w: float
    mechanical_w: float


@dataclass(frozen=True)
class ComponentLibrary:
    """Everything the simulator needs, before sizing."""

    engine_hybrid: EngineMap            # FC_PRIUS_JPN, scaled per design
    engine_conventional: EngineMap      # FC_SI63_emis, scaled to the conventional car's power
    motor: MachineMap
    generator: MachineMap
    battery: BatteryModule
    body_conventional: Body             # the study's conventional car (Table 1) = every design's chassis
    wheel_conventional: Wheel
    body_prius: Body
    wheel_prius: Wheel
    power_split: PowerSplit
    gearbox: Gearbox
    accessory_hybrid: Accessory
    accessory_conventional: Accessory
    exhaust_kg_per_kw: float
    conventional_idle_rad_s: float
    conventional_launch_rad_s: float
    meta: dict = field(default_factory=dict, compare=False)

    # ------------------------------------------------------------------ persistence (normalised form)
    def save(self, out_dir: str | Path) -> list[Path]:
        """Write each component as ``<field>.npz`` (arrays) plus ``library.json`` (scalars, names)."""
        out_dir = Path(out_dir)
        written, index = [], {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if dataclasses.is_dataclass(value):
                arrays = {k: v for k, v in dataclasses.asdict(value).items() if isinstance(v, np.ndarray)}
                scalars = {k: v for k, v in dataclasses.asdict(value).items() if not isinstance(v, np.ndarray)}
                index[f.name] = {"type": type(value).__name__, "scalars": scalars}
                path = out_dir / f"{f.name}.npz"
                with atomic_path(path) as tmp:
                    with open(tmp, "wb") as fh:
                        np.savez(fh, **arrays)
                written.append(path)
            else:
                index[f.name] = value
        write_json(out_dir / "library.json", index)
        return [*written, out_dir / "library.json"]

    @classmethod
    def load(cls, src_dir: str | Path) -> ComponentLibrary:
        src_dir = Path(src_dir)
        index_path = src_dir / "library.json"
        if not index_path.exists():
            raise FileNotFoundError(f"{index_path}: missing; run `hev components` (dvc repro components) first")
        index = json.loads(index_path.read_text())
        types = {t.__name__: t for t in (EngineMap, MachineMap, BatteryModule, Body, Wheel, PowerSplit,
                                         Gearbox, Accessory)}
        kwargs = {}
        for f in dataclasses.fields(cls):
            entry = index.get(f.name)
            if isinstance(entry, dict) and "type" in entry:
                path = src_dir / f"{f.name}.npz"
                if not path.exists():
                    raise FileNotFoundError(f"{path}: missing component map; run `hev components`")
                with np.load(path) as npz:
                    arrays = {k: _ro(npz[k]) for k in npz.files}
                kwargs[f.name] = types[entry["type"]](**entry["scalars"], **arrays)
            else:
                kwargs[f.name] = entry if entry is not None else {}
        return cls(**kwargs)


# ------------------------------------------------------------------------------------- loaders
def _peak_power_kw(speed: np.ndarray, torque: np.ndarray) -> float:
    """Peak power of a piecewise-linear torque curve (checked finely between axis points)."""
    s = np.linspace(speed[0], speed[-1], 4001)
    return float(np.max(s * np.interp(s, speed, torque)) / 1e3)


def load_engine(path: Path) -> EngineMap:
    d = _read_yaml(path)
    mass = _need(d, "mass_model", path)
    speed = _ro(_need(d, "speed_axis_rad_s", path))
    tmax = _ro(_need(d, "max_torque_nm", path))
    fuel_props = _need(d, "fuel_properties", path)
    return EngineMap(
        name=str(d.get("source", path.stem)).split()[-1],
        speed_rad_s=speed,
        torque_nm=_ro(_need(d, "torque_axis_nm", path)),
        max_torque_nm=tmax,
        fuel_g_s=_ro(_need(d, "fuel_map_g_per_s", path)),
        hc_g_s=_ro(_need(d, "hc_map_g_per_s", path)),
        co_g_s=_ro(_need(d, "co_map_g_per_s", path)),
        nox_g_s=_ro(_need(d, "nox_map_g_per_s", path)),
        peak_power_kw=_peak_power_kw(speed, tmax),
        engine_mass_kg=float(mass["base_engine_mass_kg"] + mass["accessories_mass_kg"]),
        fuel_system_mass_kg=float(mass["fuel_system_mass_kg"]),
        inertia_kg_m2=float(d.get("inertia_kg_m2", 0.1)),
        lhv_j_per_g=float(fuel_props["lower_heating_value_j_per_g"]),
        fuel_density_g_per_l=float(fuel_props["density_g_per_l"]),
    )


def load_machine(path: Path, *, generator: bool) -> MachineMap:
    """Motor (speed >= 0, torque +/-) or generator (speed +/-, torque +/-) reduced to |speed|, |torque|."""
    d = _read_yaml(path)
    speed = np.array(_need(d, "speed_axis_rad_s", path), dtype=float)
    torque = np.array(_need(d, "torque_axis_nm", path), dtype=float)
    eff = np.array(_need(d, "efficiency_map", path), dtype=float)
    tmax = np.array(_need(d, "max_torque_nm" if generator else "max_torque_motoring_nm", path), dtype=float)
    rows, cols = speed >= 0, torque >= 0
    speed, tmax, eff = speed[rows], tmax[rows], eff[rows][:, cols]
    torque = torque[cols]
    return MachineMap(
        name=str(d.get("source", path.stem)).split()[-1],
        speed_rad_s=_ro(speed), torque_nm=_ro(torque), efficiency=_ro(eff), max_torque_nm=_ro(tmax),
        peak_power_kw=_peak_power_kw(speed, tmax),
        mass_kg=float(_need(d, "mass_kg", path)), inertia_kg_m2=float(d.get("inertia_kg_m2", 0.0)),
    )


def load_battery(path: Path, temperature_c: float) -> BatteryModule:
    """Battery module at the table row nearest ``temperature_c`` (SPEC: warmest Li-ion row by default)."""
    d = _read_yaml(path)
    temps = np.array(_need(d, "temperature_axis_c", path), dtype=float)
    i = int(np.argmin(np.abs(temps - temperature_c)))
    row = lambda key: _ro(np.array(_need(d, key, path), dtype=float)[i])  # noqa: E731
    return BatteryModule(
        name=str(d.get("source", path.stem)).split()[-1],
        soc=_ro(_need(d, "soc_axis", path)), ocv_v=row("open_circuit_voltage_v"),
        r_dis_ohm=row("discharge_resistance_ohm"), r_chg_ohm=row("charge_resistance_ohm"),
        capacity_ah=float(np.array(d["capacity_ah"])[i]),
        coulombic_efficiency=float(np.array(d["coulombic_efficiency"])[i]),
        v_min=float(_need(d, "min_voltage_v", path)), v_max=float(_need(d, "max_voltage_v", path)),
        mass_kg=float(_need(d, "module_mass_kg", path)), temperature_c=float(temps[i]),
    )


def load_body(path: Path) -> Body:
    d = _read_yaml(path)
    return Body(
        name=str(d.get("source", path.stem)).split()[-1],
        glider_mass_kg=float(_need(d, "glider_mass_kg", path)), cargo_mass_kg=float(_need(d, "cargo_mass_kg", path)),
        drag_coefficient=float(_need(d, "drag_coefficient", path)),
        frontal_area_m2=float(_need(d, "frontal_area_m2", path)), cg_height_m=float(_need(d, "cg_height_m", path)),
        wheelbase_m=float(_need(d, "wheelbase_m", path)),
        front_weight_fraction=float(_need(d, "front_axle_weight_fraction", path)),
        air_density_kg_m3=float(d.get("air_density_kg_per_m3", 1.2)), gravity_m_s2=float(d.get("gravity_m_per_s2", 9.81)),
    )


def load_wheel(path: Path) -> Wheel:
    d = _read_yaml(path)
    axle = _need(d, "axle_loss", path)
    m, t = axle["vehicle_mass_kg"], axle["drag_torque_nm"]
    return Wheel(
        name=str(d.get("source", path.stem)).split()[-1], radius_m=float(_need(d, "rolling_radius_m", path)),
        rolling_resistance=float(_need(d, "rolling_resistance_coefficient", path)),
        inertia_kg_m2=float(d.get("inertia_kg_m2", 0.0)),
        axle_drag_nm_at_0kg=float(t[0]), axle_drag_nm_per_kg=float((t[1] - t[0]) / (m[1] - m[0])),
    )


def load_library(raw_dir: str | Path, *, battery: str = "li_ion", battery_temperature_c: float = 41.0,
                 conventional_body: dict | None = None, gear_ratios: list[float] | None = None,
                 conventional_idle_rpm: float = 800.0) -> ComponentLibrary:
    """Load every component of the study from ``raw_dir`` (ADVISOR YAML).

    ``conventional_body`` overrides body/wheel numbers with the study's Table 1 (the conventional car
    is the EV1 body with the small-car wheel in ADVISOR terms: Cd 0.19, 2.038 m2, CG 0.4 m, r 0.282 m).
    """
    raw = Path(raw_dir)
    ptc = _read_yaml(raw / "PTC_PRIUS_JPN.yaml")
    tx = _read_yaml(raw / "TX_PRIUS_CVT_JPN.yaml")
    gb = _read_yaml(raw / "TX_5SPD_SI.yaml")
    conv_ctl = _read_yaml(raw / "PTC_CONV.yaml")
    ex = _read_yaml(raw / "EX_SI.yaml")
    acc_h, acc_c = _read_yaml(raw / "ACC_PRIUS_JPN.yaml"), _read_yaml(raw / "ACC_CONV.yaml")
    doc = tx["from_advisor_documentation"]
    reg = gb["loss_regression"]
    body_c, wheel_c = load_body(raw / "VEH_EV1.yaml"), load_wheel(raw / "WH_SMCAR.yaml")
    if conventional_body:
        body_c = dataclasses.replace(body_c, **{k: v for k, v in conventional_body.items()
                                                if k in {f.name for f in dataclasses.fields(Body)}})
        if "wheel_radius_m" in conventional_body:
            wheel_c = dataclasses.replace(wheel_c, radius_m=float(conventional_body["wheel_radius_m"]))
    battery_file = {"li_ion": "ESS_LI7_temp.yaml", "nimh": "ESS_NIMH6.yaml"}[battery]
    ratios = np.array(gear_ratios if gear_ratios is not None else gb["overall_gear_ratios"], dtype=float)
    conv_eval = conv_ctl["evaluated_for_FC_SI63_emis_with_700_w_accessory"]
    return ComponentLibrary(
        engine_hybrid=load_engine(raw / "FC_PRIUS_JPN.yaml"),
        engine_conventional=load_engine(raw / "FC_SI63_emis.yaml"),
        motor=load_machine(raw / "MC_PRIUS_JPN.yaml", generator=False),
        generator=load_machine(raw / "GC_PRIUS_JPN.yaml", generator=True),
        battery=load_battery(raw / battery_file, battery_temperature_c),
        body_conventional=body_c, wheel_conventional=wheel_c,
        body_prius=load_body(raw / "VEH_PRIUS_JPN.yaml"), wheel_prius=load_wheel(raw / "WH_PRIUS_JPN.yaml"),
        power_split=PowerSplit(
            n_r=int(tx["ring_gear_teeth"]), n_s=int(tx["sun_gear_teeth"]), i0=float(tx["final_drive_ratio"]),
            n_planets=int(doc["planet_gear_count"]), planet_teeth=int(doc["planet_gear_teeth"]),
            engine_max_speed_rad_s=float(ptc["engine_max_speed_rad_s"]),
            motor_max_speed_rad_s=float(doc["motor_speed_limit_rpm"]) * RPM,
            generator_max_speed_rad_s=float(ptc["generator_max_speed_rad_s"]),
            engine_min_on_speed_rad_s=float(ptc["engine_idle_speed_rad_s"]),
            operating_line_power_w=_ro(ptc["engine_operating_line"]["power_w"]),
            operating_line_speed_rad_s=_ro(ptc["engine_operating_line"]["speed_rad_s"]),
        ),
        gearbox=Gearbox(
            name="TX_5SPD_SI", ratios=_ro(ratios), mass_kg=float(gb["transmission_mass_kg"]),
            loss_coefficients=_ro([reg["a_input_speed"], reg["b_output_speed"], reg["c_input_torque"],
                                   reg["d_output_torque"], reg["e_output_power"], reg["f_constant_w"]]),
        ),
        accessory_hybrid=Accessory(float(acc_h["electrical_load_w"]), float(acc_h["mechanical_load_w"])),
        accessory_conventional=Accessory(float(acc_c["electrical_load_w"]), float(acc_c["mechanical_load_w"])),
        exhaust_kg_per_kw=float(ex["mass_rule"]["exhaust_system_kg_per_engine_kw"]),
        conventional_idle_rad_s=max(float(conventional_idle_rpm) * RPM, float(conv_eval["idle_speed_rad_s"])),
        conventional_launch_rad_s=float(conv_eval["launch_speed_rad_s"]),
        meta={"raw_dir": str(raw), "battery_file": battery_file},
    )
