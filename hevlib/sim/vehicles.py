"""Vehicles as the kernels read them: the component library and the params packed once into arrays
(:class:`KernelLibrary`), and one typed record per batch of designs (:class:`Vehicle`, its
:class:`~hevlib.sim.drive.HybridRec` or :class:`~hevlib.sim.drive.ConventionalRec`) built from named design
columns.

Three kinds of vehicle:

- ``hybrid``: conversion designs (the seven variables) on the conventional car's chassis;
- ``prius``: the stock Prius on its own body, wheels and test mass;
- ``conventional``: the 70 kW five-speed baseline.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
import pandas as pd

from hevlib.components import (
    Body,
    Catalyst,
    ComponentLibrary,
    EngineMap,
    EngineThermal,
    MachineMap,
    Wheel,
    best_efficiency_line,
)
from hevlib.design import DESIGN_VARS, DesignSpace, design_vector
from hevlib.lookup import resample, uniform_axis
from hevlib.params import Params
from hevlib.scaling import power_scale
from hevlib.sim.control import PmsConfig, Thresholds, thresholds
from hevlib.sim.drive import (
    N_R,
    R_I0,
    R_MASS,
    R_N_BAT,
    R_N_R,
    R_N_S,
    R_S_ENG,
    R_S_GEN,
    R_S_MOT,
    R_SOC0,
    BatteryArrays,
    ConventionalRec,
    DriveConfig,
    HybridRec,
    SplitConfig,
)
from hevlib.sim.ecms import equivalence_factor
from hevlib.sim.powertrain.conventional import ConvDesign, ShiftLogic
from hevlib.sim.powertrain.engine import EngineArrays
from hevlib.sim.powertrain.machines import MachineArrays
from hevlib.sim.powertrain.thermal import ThermalConfig, start_temperatures
from hevlib.sizing import conventional_chassis_kg, hybrid_masses

Kind = Literal["hybrid", "prius", "conventional"]
VEHICLES: tuple[str, ...] = ("hybrid", "prius", "conventional")
#: HC conversion that marks the catalyst's light-off (``t_cat_light_off_s``).
LIGHT_OFF_HC_CONVERSION = 0.5


def engine_arrays(engine: EngineMap) -> EngineArrays:
    """The engine's tables on uniform grids (exact where the grid holds every breakpoint) and its
    best-efficiency line, for the kernels."""
    p, w, t = best_efficiency_line(engine)
    if p[0] != 0.0 or not np.allclose(np.diff(p), p[1]):
        raise ValueError(f"engine {engine.name}: best-efficiency line must be on a uniform power grid from 0")
    t = np.maximum.accumulate(t)
    t[1:] = np.maximum(t[1:], t[:-1] + 1e-9)  # strictly increasing for the inverse lookup
    if engine.torque_nm[0] != 0.0:
        raise ValueError(f"engine {engine.name}: torque axis must start at 0 N m")
    gw, gt = uniform_axis(engine.speed_rad_s), uniform_axis(engine.torque_nm)
    maps = [
        resample(engine.speed_rad_s, engine.torque_nm, m, gw, gt)
        for m in (engine.fuel_g_s, engine.hc_g_s, engine.co_g_s, engine.nox_g_s)
    ]
    f = np.ascontiguousarray
    fuel, hc, co, nox = (f(m) for m in maps)
    return EngineArrays(
        w0=float(gw[0]),
        dw=float(gw[1] - gw[0]),
        dt=float(gt[1]),
        t_max=f(resample(engine.speed_rad_s, None, engine.max_torque_nm, gw)),
        fuel=fuel,
        hc=hc,
        co=co,
        nox=nox,
        line_p=f(p, float),
        line_w=f(w, float),
        line_t=f(t, float),
        t_drag=f(resample(engine.speed_rad_s, None, engine.closed_throttle_torque_nm, gw)),
    )


def thermal_config(
    engine: EngineMap, th: EngineThermal, cat: Catalyst, glider_kg: float, ambient_c: float, cold_correction: bool
) -> ThermalConfig:
    """The engine's and the catalyst's thermal data as the kernels read them (ADVISOR's rules)."""
    return ThermalConfig(
        ambient_c=float(ambient_c),
        p_base_kw=engine.peak_power_kw,
        m_base_kg=th.base_engine_mass_kg,
        m_acc_kg=th.accessories_mass_kg,
        m_hood_kg=0.1 * glider_kg,
        cp_eng=th.specific_heat_j_per_kg_k,
        cp_hood=th.hood_specific_heat_j_per_kg_k,
        a_ext_m2=th.exterior_area_m2,
        a_hood_m2=th.hood_area_m2,
        eps_eng=th.emissivity,
        eps_hood=th.hood_emissivity,
        g_c2i=th.cyl_to_block_w_per_k,
        g_i2x=th.block_to_exterior_w_per_k,
        g_h2x=th.exterior_to_hood_w_per_k,
        t_stat_c=th.thermostat_c,
        ex_frac_lo=th.exhaust_share_min_speed,
        ex_frac_hi=th.exhaust_share_max_speed,
        w_lo=engine.min_speed_rad_s,
        w_hi=engine.max_speed_rad_s,
        afr=th.air_fuel_ratio,
        cp_gas=cat.gas_cp_j_per_g_k,
        t_map_c=th.map_reference_c,
        ex_kg_per_kw=cat.exhaust_kg_per_kw,
        m_mon_share=cat.monolith_share,
        m_shell_share=cat.shell_share,
        m_pipe_share=cat.pipe_share,
        m_shield_share=cat.shield_share,
        m_man_share=cat.manifold_share,
        cp_mon=cat.monolith_cp_j_per_kg_k,
        cp_steel=cat.steel_cp_j_per_kg_k,
        a_mon_coef=cat.monolith_area_coef_m2,
        a_mon_exp=cat.monolith_area_exp,
        a_man_m2_per_kw=cat.manifold_area_m2_per_kw,
        eps_m2p=cat.emissivity_monolith_pipe,
        eps_i2x=cat.emissivity_shell_shield,
        eps_pipe=cat.emissivity_pipe,
        eps_shield=cat.emissivity_shield,
        eps_man=cat.emissivity_manifold,
        g_shell2shield=cat.shell_shield_w_per_k,
        g_shell2pipe=cat.shell_pipe_w_per_k,
        g_pipe2shield=cat.pipe_shield_w_per_k,
        m2i_t_c=np.ascontiguousarray(cat.monolith_shell_temperature_c, float),
        m2i_g=np.ascontiguousarray(cat.monolith_shell_w_per_k, float),
        conv_t_c=np.ascontiguousarray(cat.temperature_c, float),
        conv_hc=np.ascontiguousarray(cat.conversion_hc, float),
        conv_co=np.ascontiguousarray(cat.conversion_co, float),
        conv_nox=np.ascontiguousarray(cat.conversion_nox, float),
        lim_hc=cat.breakthrough_hc_g_s,
        lim_co=cat.breakthrough_co_g_s,
        lim_nox=cat.breakthrough_nox_g_s,
        light_off_eff=LIGHT_OFF_HC_CONVERSION,
        fuel_max_g_s=float(np.max(engine.fuel_g_s)),
        cold_correction=bool(cold_correction),
    )


def machine_arrays(machine: MachineMap) -> MachineArrays:
    """Efficiency map and torque limit on uniform grids from 0 (the machine maps' axes start at 0)."""
    if machine.speed_rad_s[0] != 0.0 or machine.torque_nm[0] != 0.0:
        raise ValueError(f"machine {machine.name}: speed and torque axes must start at 0")
    gw, gt = uniform_axis(machine.speed_rad_s), uniform_axis(machine.torque_nm)
    f = np.ascontiguousarray
    return MachineArrays(
        dw=float(gw[1]),
        dt=float(gt[1]),
        eff=f(resample(machine.speed_rad_s, machine.torque_nm, machine.efficiency, gw, gt)),
        t_max=f(resample(machine.speed_rad_s, None, machine.max_torque_nm, gw)),
    )


def battery_arrays(module) -> BatteryArrays:
    if module.soc[0] != 0.0:
        raise ValueError(f"battery {module.name}: SOC axis must start at 0")
    g = uniform_axis(module.soc)

    def on_grid(a):
        return np.ascontiguousarray(resample(module.soc, None, a, g))

    return BatteryArrays(
        dsoc=float(g[1]),
        ocv_v=on_grid(module.ocv_v),
        r_dis_ohm=on_grid(module.r_dis_ohm),
        r_chg_ohm=on_grid(module.r_chg_ohm),
    )


class RoadLoad(NamedTuple):
    """A body's road-load terms as the kernels read them (:class:`~hevlib.sim.powertrain.vehicle.Chassis`)."""

    cda: float  #: drag coefficient x frontal area, m^2
    crr: float  #: rolling-resistance coefficient
    k_lin: float  #: linear term, N per m/s (a coast-down's B; 0 otherwise)
    axle0_nm: float  #: driven-axle drag torque at 0 kg, N m ...
    axle_per_kg_nm: float  #: ... and its rise per kg of test mass


def road_load(body: Body, wheel: Wheel, test_mass_kg: float) -> RoadLoad:
    """The road load of a body on its wheels: drag coefficient x frontal area with the wheel file's rolling
    resistance and axle drag, or the body's coast-down ``F = A + B v + C v^2`` (SI, ``Body.coast_down``):

    - ``C`` is the aerodynamic term: ``CdA = 2 C / rho``, so ``1/2 rho CdA v^2 = C v^2``;
    - ``A`` is the rolling term: ``crr = A / (m g)`` at the car's test mass ``m``, so the car itself meets
      ``A cos(theta)``, and a conversion of another mass on its chassis ``A m' / m cos(theta)``;
    - ``B`` is the linear term ``k_lin`` (booked with rolling resistance);
    - no axle drag: a coast-down in neutral includes the bearings', the brakes' and the driveline's drag.
    """
    abc = body.coast_down
    if abc is None:
        cda = body.drag_coefficient * body.frontal_area_m2
        return RoadLoad(
            cda=cda,
            crr=wheel.rolling_resistance,
            k_lin=0.0,
            axle0_nm=wheel.axle_drag_nm_at_0kg,
            axle_per_kg_nm=wheel.axle_drag_nm_per_kg,
        )
    a, b, c = abc
    crr = a / (test_mass_kg * body.gravity_m_s2)
    return RoadLoad(cda=2.0 * c / body.air_density_kg_m3, crr=crr, k_lin=b, axle0_nm=0.0, axle_per_kg_nm=0.0)


def drive_config(params: Params, body: Body, wheel: Wheel, engine: EngineMap, test_mass_kg: float) -> DriveConfig:
    """The scalars every design of a batch shares, for either car: chassis, road, brakes, fuel (one-second
    step). ``test_mass_kg``: the car's, which a coast-down's rolling term belongs to (:func:`road_load`)."""
    sim = params.sim
    rl = road_load(body, wheel, test_mass_kg)
    return DriveConfig(
        dt=1.0,
        adhesion_coefficient=sim.adhesion_coefficient,
        rho=body.air_density_kg_m3,
        g=body.gravity_m_s2,
        cda=rl.cda,
        crr=rl.crr,
        r=wheel.radius_m,
        axle0_nm=rl.axle0_nm,
        axle_per_kg_nm=rl.axle_per_kg_nm,
        h_over_l=body.cg_height_m / body.wheelbase_m,
        f_front=body.front_weight_fraction,
        brake_v_mps=np.ascontiguousarray(wheel.brake_speed_mps, float),
        brake_share=np.ascontiguousarray(wheel.brake_driveline_share, float),
        lhv_j_per_g=engine.lhv_j_per_g,
        j_wheel=wheel.inertia_kg_m2,
        j_eng=engine.inertia_kg_m2,
        cycle_met_tolerance_mps=sim.cycle_met_tolerance_kmh / 3.6,
        k_lin=rl.k_lin,
    )


def split_config(lib: ComponentLibrary, params: Params) -> SplitConfig:
    """The power split's scalars every design of a batch shares: gear set, machines, pack, controller window,
    electrical accessories, engine start."""
    sim = params.sim
    ps, bat = lib.power_split, lib.battery
    return SplitConfig(
        soc_min=sim.soc_min,
        soc_max=sim.soc_max,
        planetary_efficiency=sim.planetary_efficiency,
        final_drive_efficiency=sim.final_drive_efficiency,
        pack_current_max_a=sim.pack_current_max_a,
        p_acc_w=float(lib.accessory_hybrid.electrical_w),
        w_e_min=ps.engine_min_on_speed_rad_s,
        w_e_max=min(ps.engine_max_speed_rad_s, lib.engine_hybrid.max_speed_rad_s),
        w_m_max=min(ps.motor_max_speed_rad_s, lib.motor.max_speed_rad_s),
        w_g_max=min(ps.generator_max_speed_rad_s, lib.generator.max_speed_rad_s),
        cap_as=bat.capacity_ah * 3600.0,
        eta_c=bat.coulombic_efficiency,
        v_min_mod=bat.v_min,
        v_max_mod=bat.v_max,
        j_mot=lib.motor.inertia_kg_m2,
        j_gen=lib.generator.inertia_kg_m2,
        engine_dynamics=bool(params.pms.engine_dynamics),
        j_start=ps.engine_startup_inertia_kg_m2,
        t_crank=ps.engine_crank_torque_nm,
        w_fire=ps.engine_firing_speed_rad_s,
    )


@dataclass(frozen=True, eq=False)
class KernelLibrary:
    """The component library and the params as the kernels read them, packed once (:meth:`build`): engine,
    machine and pack tables on uniform grids, each vehicle kind's drive and thermal settings, the controller,
    the conventional car's gearbox."""

    lib: ComponentLibrary
    params: Params
    space: DesignSpace
    chassis_kg: float  #: the conventional car less its powertrain: the chassis every conversion keeps
    engines: Mapping[str, EngineArrays]  #: per kind (the hybrids share the Prius engine map)
    motor: MachineArrays
    generator: MachineArrays
    pack: BatteryArrays
    thresholds: Thresholds  #: the fuzzy rule base's thresholds
    pms: PmsConfig
    configs: Mapping[str, DriveConfig]  #: per kind: body, wheels, brakes, fuel
    split: SplitConfig  #: the power split's gear set, machines, pack and engine start (both hybrid kinds)
    thermal: Mapping[str, ThermalConfig]  #: per kind: engine and catalyst thermal data
    gearbox: ConvDesign  #: the conventional car's engine scale, wheel, idle, launch and gearbox losses
    ratios: np.ndarray  #: its overall gear ratios ...
    shift: ShiftLogic  #: ... and its shift logic (PTC_CONV)

    @classmethod
    def build(cls, lib: ComponentLibrary, params: Params) -> KernelLibrary:
        sim, base, pms = params.sim, params.baseline, params.pms
        e_h, e_c = engine_arrays(lib.engine_hybrid), engine_arrays(lib.engine_conventional)
        m_conv, m_prius = base.conventional.test_mass_kg, base.prius.test_mass_kg
        body_c, wheel_c = lib.body_conventional, lib.wheel_conventional
        configs = {
            "hybrid": drive_config(params, body_c, wheel_c, lib.engine_hybrid, m_conv),
            "prius": drive_config(params, lib.body_prius, lib.wheel_prius, lib.engine_hybrid, m_prius),
            "conventional": drive_config(params, body_c, wheel_c, lib.engine_conventional, m_conv),
        }
        amb, cold = sim.ambient_c, sim.cold_correction == "advisor"
        thermal = {
            "hybrid": thermal_config(
                lib.engine_hybrid, lib.thermal_hybrid, lib.catalyst, lib.body_conventional.glider_mass_kg, amb, cold
            ),
            "prius": thermal_config(
                lib.engine_hybrid, lib.thermal_hybrid, lib.catalyst, lib.body_prius.glider_mass_kg, amb, cold
            ),
            "conventional": thermal_config(
                lib.engine_conventional,
                lib.thermal_conventional,
                lib.catalyst,
                lib.body_conventional.glider_mass_kg,
                amb,
                cold,
            ),
        }
        e = lib.engine_conventional
        ctl = lib.conventional_control
        gb_a, gb_b, gb_c, gb_d, gb_e, gb_f = map(float, lib.gearbox.loss_coefficients)  # the file's a .. f
        gearbox = ConvDesign(
            s_eng=power_scale(base.conventional.p_eng_kw, e.peak_power_kw),
            r=lib.wheel_conventional.radius_m,
            w_idle=lib.conventional_idle_rad_s,
            w_launch=lib.conventional_launch_rad_s,
            w_e_max=e.max_speed_rad_s,
            p_acc_w=lib.accessory_conventional.mechanical_w,
            gb_a=gb_a,
            gb_b=gb_b,
            gb_c=gb_c,
            gb_d=gb_d,
            gb_e=gb_e,
            gb_f=gb_f,
            idle_allowed=ctl.idle_allowed,
            clutch_opens=ctl.clutch_opens_without_torque,
        )
        if ctl.shift_delay_s != 0.0:
            raise ValueError(f"PTC_CONV: shift_delay_s {ctl.shift_delay_s} s: only instant shifts are modelled")
        f = np.ascontiguousarray
        shift = ShiftLogic(
            load_based=base.conventional.shift_logic == "load",
            up_w=f(ctl.upshift_speed_rad_s, float),
            up_load=f(ctl.upshift_load, float),
            dn_w=f(ctl.downshift_speed_rad_s, float),
            dn_load=f(ctl.downshift_load, float),
            upshift_kmh=f(base.conventional.upshift_kmh, float),
        )
        return cls(
            lib=lib,
            params=params,
            space=params.design_space.space(),
            chassis_kg=conventional_chassis_kg(lib, base.conventional.test_mass_kg, base.conventional.p_eng_kw),
            engines={"hybrid": e_h, "prius": e_h, "conventional": e_c},
            motor=machine_arrays(lib.motor),
            generator=machine_arrays(lib.generator),
            pack=battery_arrays(lib.battery),
            thresholds=thresholds(pms),
            pms=PmsConfig(
                engine_on_threshold=pms.engine_on_threshold,
                engine_min_on_s=pms.engine_min_on_s,
                engine_min_off_s=pms.engine_min_off_s,
                engine_min_power_w=pms.engine_min_power_kw * 1e3,
                charge_power_fraction=pms.charge_power_fraction,
                soc_target=pms.soc_target,
                t_warmup_c=lib.power_split.coolant_warmup_temperature_c if pms.coolant_warmup else -np.inf,
                full_power_above_w=pms.full_power_above_kw * 1e3 if pms.full_power_above_kw is not None else np.inf,
                ecms=pms.strategy == "ecms",
                ecms_s0=equivalence_factor(e_h, lib.engine_hybrid.lhv_j_per_g),
                ecms_soc_gain=pms.ecms_soc_gain,
                ecms_n_speed=pms.ecms_n_speed,
                ecms_n_torque=pms.ecms_n_torque,
            ),
            configs=configs,
            split=split_config(lib, params),
            thermal=thermal,
            gearbox=gearbox,
            ratios=np.ascontiguousarray(base.conventional.gear_ratios, float),
            shift=shift,
        )

    def mass_kg(self, X: np.ndarray) -> np.ndarray:
        """Exact test mass of hybrid conversions (SPEC section 4 mass model), kg."""
        X = self.space.check(X, integers=False)
        return hybrid_masses(self.lib, self.chassis_kg, X[:, 0], X[:, 1], X[:, 2], X[:, 4]).test_mass_kg

    def start_state(self, cycle_name: str) -> str:
        """``cold`` or ``hot``: the thermal start of a cycle (params ``sim.start``; cold if not listed)."""
        return self.params.sim.start.get(cycle_name, "cold")

    def start_temperatures(self, cycle_name: str, kind: Kind, state: str | None = None) -> np.ndarray:
        """The nine thermal nodes' start temperatures of a ``kind`` of vehicle on a cycle, degC: of the params'
        start for the cycle, or of ``state`` (``cold`` or ``hot``) where given."""
        state = self.start_state(cycle_name) if state is None else state
        return start_temperatures(state, self.params.sim.ambient_c, self.thermal[kind].t_stat_c)


def design_frame(design, space: DesignSpace) -> np.ndarray:
    """Designs as an (n, 7) array in ``DESIGN_VARS`` order, from named columns (a DataFrame or a mapping of
    arrays; extra columns ignored) or an array already in that order; checked against the design space."""
    if isinstance(design, pd.DataFrame | Mapping):
        missing = [v for v in DESIGN_VARS if v not in design]
        if missing:
            raise ValueError(f"designs: missing column(s) {', '.join(missing)}")
        X = np.column_stack([np.asarray(design[v], dtype=float).reshape(-1) for v in DESIGN_VARS])
    else:
        X = np.asarray(design, dtype=float)
    return space.check(X, what="designs")


@dataclass(frozen=True, eq=False)
class Vehicle:
    """A batch of vehicles of one kind: the designs (``DESIGN_VARS`` columns; NaN for what a conventional car
    lacks) and the record the kernels read: a :class:`~hevlib.sim.drive.HybridRec` (``hybrid``, ``prius``) or a
    :class:`~hevlib.sim.drive.ConventionalRec` (``conventional``)."""

    kind: Kind
    design: pd.DataFrame
    kernel: HybridRec | ConventionalRec
    library: KernelLibrary

    @property
    def n(self) -> int:
        return self.kernel.rows.shape[0]

    @property
    def mass_kg(self) -> np.ndarray:
        """Test mass of each vehicle, kg."""
        return self.kernel.rows[:, R_MASS].copy()

    @classmethod
    def from_design(cls, library: KernelLibrary, design) -> Vehicle:
        """Hybrid conversions of the conventional car, one per design (named columns, see :func:`design_frame`):
        engine, motor and generator scaled to their powers, the gear set, final drive and pack of the design, the
        test mass of the mass model."""
        X = design_frame(design, library.space)
        return cls._make(library, "hybrid", X, library.mass_kg(X))

    @classmethod
    def baseline(cls, library: KernelLibrary, kind: Kind) -> Vehicle:
        """One of the two reference vehicles: ``prius`` (the stock car on its own body) or ``conventional``."""
        base = library.params.baseline
        if kind == "prius":
            X = design_vector(base.prius)[None, :]
            return cls._make(library, kind, X, np.array([base.prius.test_mass_kg]))
        if kind == "conventional":
            X = np.array([[base.conventional.p_eng_kw] + [np.nan] * (len(DESIGN_VARS) - 1)])
            return cls._make(library, kind, X, np.array([base.conventional.test_mass_kg]))
        raise ValueError(f"vehicle: {kind!r} is not one of {', '.join(VEHICLES)}")

    @classmethod
    def _make(cls, library: KernelLibrary, kind: Kind, X: np.ndarray, mass_kg: np.ndarray) -> Vehicle:
        lib = library.lib
        rows = np.zeros((X.shape[0], N_R))
        d = dict(zip(DESIGN_VARS, X.T, strict=True))
        if kind == "conventional":
            rows[:, R_S_ENG] = power_scale(d["p_eng_kw"], lib.engine_conventional.peak_power_kw)
        else:
            rows[:, R_S_ENG] = power_scale(d["p_eng_kw"], lib.engine_hybrid.peak_power_kw)
            rows[:, R_S_MOT] = power_scale(d["p_mot_kw"], lib.motor.peak_power_kw)
            rows[:, R_S_GEN] = power_scale(d["p_gen_kw"], lib.generator.peak_power_kw)
            rows[:, R_I0] = d["i0"]
            rows[:, R_N_BAT] = d["n_bat"]
            rows[:, R_N_R] = d["n_r"]
            rows[:, R_N_S] = d["n_s"]
        rows[:, R_MASS] = mass_kg
        rows[:, R_SOC0] = library.params.sim.soc_init
        c, E, th = library.configs[kind], library.engines[kind], library.thermal[kind]
        if kind == "conventional":
            kernel = ConventionalRec(
                rows=rows, c=c, E=E, ratios=library.ratios, shift=library.shift, cd=library.gearbox, X=th
            )
        else:
            kernel = HybridRec(
                rows=rows,
                c=c,
                sc=library.split,
                th=library.thresholds,
                pc=library.pms,
                E=E,
                M=library.motor,
                G=library.generator,
                B=library.pack,
                X=th,
            )
        return cls(kind, pd.DataFrame(X, columns=list(DESIGN_VARS)), kernel, library)

    def with_soc_init(self, soc: np.ndarray | float) -> Vehicle:
        """The same vehicles starting their drive at SOC ``soc`` (one per vehicle, or one for all)."""
        rows = self.kernel.rows.copy()
        rows[:, R_SOC0] = soc
        return Vehicle(self.kind, self.design, self.kernel._replace(rows=rows), self.library)

    def with_strategy(self, strategy: Literal["fuzzy", "ecms"]) -> Vehicle:
        """The same power-split vehicles under supervisory controller ``strategy`` (``pms.strategy``'s values: the
        study's rule base or ECMS, :mod:`hevlib.sim.ecms`), the rest of ``pms`` as the params give it."""
        if self.kind == "conventional" or strategy not in ("fuzzy", "ecms"):
            raise ValueError(
                f"with_strategy: a power split's strategy is fuzzy or ecms, not {strategy!r} ({self.kind})"
            )
        kernel = self.kernel._replace(pc=self.kernel.pc._replace(ecms=strategy == "ecms"))
        return Vehicle(self.kind, self.design, kernel, self.library)

    def take(self, index: np.ndarray) -> Vehicle:
        """The vehicles at ``index`` (integer positions or a boolean mask), as a batch of their own."""
        rows = np.ascontiguousarray(self.kernel.rows[index])
        return Vehicle(
            self.kind, self.design.iloc[index].reset_index(drop=True), self.kernel._replace(rows=rows), self.library
        )

    def with_step(self, dt_s: float) -> Vehicle:
        """The same vehicles driven at a time step of ``dt_s`` (the drive settings' default is 1 s)."""
        if abs(dt_s - self.kernel.c.dt) <= 1e-12:
            return self
        kernel = self.kernel._replace(c=self.kernel.c._replace(dt=float(dt_s)))
        return Vehicle(self.kind, self.design, kernel, self.library)
