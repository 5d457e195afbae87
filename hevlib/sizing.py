"""Sizing: scaled component maps and the mass model of the conversion (SPEC section 4), for whole designs.

Engine, motor and generator are scaled by maximum power with the speed axis fixed (ADVISOR's
torque scaling): torque axis, torque limits, fuel and emission rates all multiply by the power scale
factor ``s = P_target / P_base``; efficiency maps are unchanged on normalised torque. Masses follow
ADVISOR's rules: engine (block + accessories) x s plus a fixed fuel system, exhaust 0.26 kg/kW,
machines x s, battery per module. Every function is vectorised over designs.

The law itself lives once, in the kernels' :mod:`hevlib.scaling`; this module applies it to
whole maps and arrays of designs (reports, plots, the mass model).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from hevlib.components import (
    CarFiles,
    ComponentLibrary,
    EngineMap,
    LibraryFiles,
    MachineMap,
    load_library,
    read_paper_row,
)
from hevlib.design import DESIGN_VARS
from hevlib.scaling import in_series, scaled
from hevlib.scaling import power_scale as kernel_power_scale

if TYPE_CHECKING:
    from hevlib.params import BaselineParams

#: The study's tables (git-tracked copies of ../shared/paper).
PAPER_DIR = Path("data/raw/paper")


def power_scale(p_target_kw, p_base_kw: float) -> np.ndarray:
    """Scale factor(s) ``P_target / P_base`` (torque scaling at a fixed speed axis)."""
    p = np.asarray(p_target_kw, dtype=float)
    if np.any(p <= 0) or not np.all(np.isfinite(p)):
        raise ValueError("scaling: target power must be positive and finite")
    return kernel_power_scale(p.reshape(-1), float(p_base_kw)).reshape(p.shape)


#: The fields of each component that scale with its peak power (torque scaling at the fixed speed axis; a
#: machine's efficiency is read on normalised torque, so its map stays).
ENGINE_SCALED_FIELDS = (
    "torque_nm",
    "max_torque_nm",
    "fuel_g_s",
    "hc_g_s",
    "co_g_s",
    "nox_g_s",
    "peak_power_kw",
    "engine_mass_kg",
    "inertia_kg_m2",
)
MACHINE_SCALED_FIELDS = ("torque_nm", "max_torque_nm", "peak_power_kw", "mass_kg", "inertia_kg_m2")


def _scaled_to(component, p_kw: float, fields: tuple[str, ...]):
    """``component`` (an engine or machine map) scaled to ``p_kw`` peak power: each of ``fields`` x s."""
    s = float(power_scale(p_kw, component.peak_power_kw))
    return dataclasses.replace(
        component, name=f"{component.name}@{p_kw:g}kW", **{f: scaled(getattr(component, f), s) for f in fields}
    )


def scale_engine(engine: EngineMap, p_kw: float) -> EngineMap:
    """The engine scaled to ``p_kw`` peak power (torque scaling at the fixed speed axis)."""
    return _scaled_to(engine, p_kw, ENGINE_SCALED_FIELDS)


def scale_machine(machine: MachineMap, p_kw: float) -> MachineMap:
    """The machine scaled to ``p_kw`` peak power: torques x s, efficiency unchanged on normalised torque."""
    return _scaled_to(machine, p_kw, MACHINE_SCALED_FIELDS)


def engine_system_mass_kg(engine: EngineMap, p_kw, exhaust_kg_per_kw: float) -> np.ndarray:
    """Engine (scaled block + accessories), fixed fuel system, and exhaust/catalyst, in kg."""
    s = power_scale(p_kw, engine.peak_power_kw)
    exhaust_kg = exhaust_kg_per_kw * np.asarray(p_kw, dtype=float)
    return scaled(engine.engine_mass_kg, s) + engine.fuel_system_mass_kg + exhaust_kg


def machine_mass_kg(machine: MachineMap, p_kw) -> np.ndarray:
    """Machine + inverter mass scaled with peak power (ADVISOR: mass x torque scale x speed scale)."""
    return scaled(machine.mass_kg, power_scale(p_kw, machine.peak_power_kw))


@dataclass(frozen=True)
class PackArrays:
    """A pack of ``n_bat`` modules in series (vectorised): SOC tables per pack, in pack units."""

    ocv_v: np.ndarray  # (n, n_soc)
    r_dis_ohm: np.ndarray
    r_chg_ohm: np.ndarray
    v_min: np.ndarray  # (n,)
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
        ocv_v=in_series(m.ocv_v[None, :], n[:, None]),
        r_dis_ohm=in_series(m.r_dis_ohm[None, :], n[:, None]),
        r_chg_ohm=in_series(m.r_chg_ohm[None, :], n[:, None]),
        v_min=in_series(m.v_min, n),
        v_max=in_series(m.v_max, n),
        capacity_ah=m.capacity_ah,
        mass_kg=in_series(m.mass_kg, n),
    )


@dataclass(frozen=True)
class MassBreakdown:
    """Test-mass build-up of hybrid designs (arrays over designs, kg)."""

    chassis_kg: float  # conventional glider + cargo (the conversion keeps it)
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


def with_conventional_glider(lib: ComponentLibrary, test_mass_kg: float, p_eng_kw: float) -> ComponentLibrary:
    """The library with the conventional body's glider mass implied by the conventional car's test mass.

    glider = test mass - engine system (``p_eng_kw``) - gearbox and final drive - cargo, so that the
    conventional car and every conversion share one glider (SPEC section 4, Vehicles).
    """
    glider = conventional_chassis_kg(lib, test_mass_kg, p_eng_kw) - lib.body_conventional.cargo_mass_kg
    if glider <= 0:
        raise ValueError("baseline.conventional.test_mass_kg: leaves no mass for the glider")
    body = dataclasses.replace(lib.body_conventional, glider_mass_kg=glider)
    return dataclasses.replace(lib, body_conventional=body)


def regression_value(coefficients: dict, design: dict) -> float:
    """A study regression (``intercept`` + one coefficient per design variable) at one design."""
    return float(coefficients["intercept"]) + sum(float(coefficients[v]) * float(design[v]) for v in DESIGN_VARS)


def _r(x, nd: int = 3) -> float:
    return round(float(np.squeeze(x)), nd)


def _engine_fig(e: EngineMap) -> dict:
    return {
        "map": e.name,
        "map_peak_power_kw": _r(e.peak_power_kw),
        "min_bsfc_g_per_kwh": _r(e.min_bsfc_g_per_kwh(), 2),
        "max_efficiency": _r(e.max_efficiency(), 4),
    }


def _machine_fig(m: MachineMap) -> dict:
    return {
        "map": m.name,
        "map_peak_power_kw": _r(m.peak_power_kw),
        "max_efficiency": _r(m.efficiency.max(), 4),
        "map_mass_kg": _r(m.mass_kg),
    }


def _mass_fig(mb: MassBreakdown) -> dict:
    return {
        "engine_system_kg": _r(mb.engine_kg),
        "motor_kg": _r(mb.motor_kg),
        "generator_kg": _r(mb.generator_kg),
        "battery_kg": _r(mb.battery_kg),
    }


def components_report(
    lib: ComponentLibrary, *, conventional: dict, prius: dict, l27_design: dict, m_veh_regression: dict
) -> dict:
    """The figures of ``reports/components.json``: maps, both baselines, battery pack, mass-model checks.

    ``conventional``: ``p_eng_kw``, ``test_mass_kg``; ``prius``: ``p_eng_kw``, ``p_mot_kw``, ``p_gen_kw``,
    ``n_bat``, ``test_mass_kg``; ``l27_design``: the seven design variables; ``m_veh_regression``: the
    study's ``m_veh`` regression row (``intercept`` + coefficients).
    """
    sizes = ("p_eng_kw", "p_mot_kw", "p_gen_kw", "n_bat")
    body_c, body_p, mod = lib.body_conventional, lib.body_prius, lib.battery
    chassis = body_c.glider_mass_kg + body_c.cargo_mass_kg
    eng_c = engine_system_mass_kg(lib.engine_conventional, conventional["p_eng_kw"], lib.exhaust_kg_per_kw)
    mp = hybrid_masses(lib, body_p.glider_mass_kg + body_p.cargo_mass_kg, *(prius[k] for k in sizes))
    md = hybrid_masses(lib, chassis, *(l27_design[k] for k in sizes))
    m_reg = regression_value(m_veh_regression, l27_design)
    n_bat = prius["n_bat"]
    pack = battery_pack(lib, n_bat)
    return {
        "maps": {
            "engine_hybrid": _engine_fig(lib.engine_hybrid),
            "engine_conventional": _engine_fig(lib.engine_conventional),
            "motor": _machine_fig(lib.motor),
            "generator": _machine_fig(lib.generator),
        },
        "prius": {
            **{k: prius[k] for k in sizes},
            "min_bsfc_g_per_kwh": _r(lib.engine_hybrid.min_bsfc_g_per_kwh(), 2),
            **_mass_fig(mp),
            "glider_kg": _r(body_p.glider_mass_kg),
            "cargo_kg": _r(body_p.cargo_mass_kg),
            "mass_model_test_mass_kg": _r(mp.test_mass_kg),
            "test_mass_kg": prius["test_mass_kg"],
        },
        "conventional": {
            "p_eng_kw": conventional["p_eng_kw"],
            "min_bsfc_g_per_kwh": _r(lib.engine_conventional.min_bsfc_g_per_kwh(), 2),
            "engine_system_kg": _r(eng_c),
            "gearbox_kg": _r(lib.gearbox.mass_kg),
            "glider_kg": _r(body_c.glider_mass_kg),
            "cargo_kg": _r(body_c.cargo_mass_kg),
            "test_mass_kg": conventional["test_mass_kg"],
        },
        "battery_pack": {
            "module": mod.name,
            "temperature_c": mod.temperature_c,
            "n_bat": n_bat,
            "module_capacity_ah": _r(mod.capacity_ah),
            "module_ocv_mean_v": _r(mod.mean_ocv_v()),
            "module_v_min": mod.v_min,
            "module_v_max": mod.v_max,
            "module_energy_wh": _r(mod.energy_wh(), 2),
            "module_mass_kg": _r(mod.mass_kg, 4),
            "pack_ocv_mean_v": _r(n_bat * mod.mean_ocv_v(), 2),
            "pack_v_min": _r(pack.v_min),
            "pack_v_max": _r(pack.v_max),
            "pack_energy_kwh": _r(n_bat * mod.energy_wh() / 1e3, 4),
            "pack_mass_kg": _r(pack.mass_kg),
        },
        # conventional test mass minus its engine system (engine, fuel system, exhaust) and its gearbox
        # with final drive; the hybrid's planetary set and final drive weigh 0 kg (as in ADVISOR)
        "conversion": {
            "chassis_kg": _r(chassis),
            "glider_kg": _r(body_c.glider_mass_kg),
            "cargo_kg": _r(body_c.cargo_mass_kg),
        },
        "l27_design_1": {
            **{v: l27_design[v] for v in DESIGN_VARS},
            **_mass_fig(md),
            "test_mass_kg": _r(md.test_mass_kg),
            "regression_test_mass_kg": _r(m_reg),
            "difference_kg": _r(md.test_mass_kg - m_reg),
            "difference_pct": _r(100 * (md.test_mass_kg - m_reg) / m_reg, 2),
        },
    }


def library_files(baseline: BaselineParams) -> LibraryFiles:
    """Which component file is which part, from params' ``baseline`` group (the one place the files are named)."""
    conv, prius, kit = baseline.conventional, baseline.prius, baseline.hybrid
    return LibraryFiles(
        conventional=CarFiles(conv.body.file, conv.wheel.file, conv.body.values(), conv.wheel.values()),
        prius=CarFiles(prius.body.file, prius.wheel.file, prius.body.values(), prius.wheel.values()),
        engine_conventional=conv.engine,
        gearbox=conv.gearbox,
        accessory_conventional=conv.accessories,
        control_conventional=conv.control,
        engine_hybrid=kit.engine,
        motor=kit.motor,
        generator=kit.generator,
        control_hybrid=kit.control,
        transmission=kit.transmission,
        accessory_hybrid=kit.accessories,
        battery=baseline.batteries[baseline.battery],
        exhaust=baseline.exhaust,
    )


def study_library(baseline: BaselineParams) -> ComponentLibrary:
    """The component library of params' ``baseline``: each part from its file, bodies and wheels with the
    params' values, the conventional car's glider from its test mass."""
    conv = baseline.conventional
    lib = load_library(
        baseline.components_dir,
        library_files(baseline),
        battery_temperature_c=baseline.battery_temperature_c,
        gear_ratios=list(conv.gear_ratios),
        conventional_idle_rpm=conv.idle_speed_rpm,
    )
    return with_conventional_glider(lib, conv.test_mass_kg, conv.p_eng_kw)


def study_report(lib: ComponentLibrary, baseline: BaselineParams, paper_dir: str | Path = PAPER_DIR) -> dict:
    """:func:`components_report` for the params' baselines and the study's L27 design 1."""
    paper = Path(paper_dir)
    return components_report(
        lib,
        conventional=baseline.conventional.model_dump(),
        prius=baseline.prius.model_dump(),
        l27_design=read_paper_row(paper / "l27_assignment.csv", "exp", 1),
        m_veh_regression=read_paper_row(paper / "regression_equations.csv", "response", "m_veh"),
    )
