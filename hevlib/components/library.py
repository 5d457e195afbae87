"""The component library: every part of the study loaded from the files params.yaml names, and its normalised
form (``data/components/*.npz`` + ``library.json``), written by the ``components`` stage and read by the
simulator."""

from __future__ import annotations

import dataclasses
import io
import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hevlib.components.files import (
    load_accessory,
    load_battery,
    load_body,
    load_catalyst,
    load_conventional_control,
    load_engine,
    load_engine_thermal,
    load_machine,
    load_wheel,
    read_component_file,
    required,
)
from hevlib.components.parts import (
    COMPONENT_TYPES,
    RPM,
    Accessory,
    BatteryModule,
    Body,
    Catalyst,
    ConventionalControl,
    EngineMap,
    EngineThermal,
    Gearbox,
    MachineMap,
    PowerSplit,
    Wheel,
    read_only,
)
from hevlib.io import atomic_path, write_json


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
                # a field left at a default of None is not written (load restores it): a body without a coast-down
                # writes the bytes it wrote before bodies could have one
                items = {
                    g.name: getattr(value, g.name)
                    for g in dataclasses.fields(value)
                    if not (g.default is None and getattr(value, g.name) is None)
                }
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
        types = {t.__name__: t for t in COMPONENT_TYPES}
        kwargs = {}
        for f in dataclasses.fields(cls):
            entry = index.get(f.name)
            if isinstance(entry, dict) and "type" in entry:
                path = src_dir / f"{f.name}.npz"
                if not path.exists():
                    raise FileNotFoundError(f"{path}: missing component map; run `hev components`")
                with np.load(path, allow_pickle=False) as npz:
                    arrays = {k: read_only(npz[k]) for k in npz.files}
                kwargs[f.name] = types[entry["type"]](**entry["scalars"], **arrays)
            elif f.name == "meta":
                kwargs[f.name] = entry or {}
            elif entry is None:
                raise ValueError(f"{index_path}: missing entry {f.name!r}; re-run `hev components`")
            else:
                kwargs[f.name] = entry
        return cls(**kwargs)


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
    ptc = read_component_file(raw / files.control_hybrid)
    tx = read_component_file(raw / files.transmission)
    gb = read_component_file(raw / files.gearbox)
    ex = read_component_file(raw / files.exhaust)
    acc_h, acc_c = (
        read_component_file(raw / files.accessory_hybrid),
        read_component_file(raw / files.accessory_conventional),
    )
    doc = required(tx, "from_advisor_documentation", raw / files.transmission)
    reg = required(gb, "loss_regression", raw / files.gearbox)
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
            operating_line_power_w=read_only(ptc["engine_operating_line"]["power_w"]),
            operating_line_speed_rad_s=read_only(ptc["engine_operating_line"]["speed_rad_s"]),
            engine_startup_inertia_kg_m2=float(ptc["engine_startup_effective_inertia_kg_m2"]),
            engine_crank_torque_nm=float(ptc["engine_crank_torque_nm"]),
            engine_firing_speed_rad_s=float(ptc["engine_fuel_cut_below_speed_rad_s"]),
            coolant_warmup_temperature_c=float(ptc["coolant_warmup_temperature_c"]),
        ),
        gearbox=Gearbox(
            name=Path(files.gearbox).stem,
            ratios=read_only(ratios),
            mass_kg=float(gb["transmission_mass_kg"]),
            loss_coefficients=read_only(
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
        accessory_hybrid=load_accessory(acc_h),
        accessory_conventional=load_accessory(acc_c),
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
