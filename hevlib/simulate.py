"""The vehicle simulator's Python face: designs in, responses (SPEC section 5) out.

:class:`Simulator` packs the component library and the params into the arrays the numba kernels read
(:mod:`hevlib.drive`, :mod:`hevlib.performance`), runs batches of designs in parallel and turns the
per-design accumulators into the eleven objectives and the extra responses. Three vehicles:

- ``hybrid``: a conversion design (seven variables) on the conventional car's chassis;
- ``prius``: the stock Prius on its own body, wheels and test mass;
- ``conventional``: the 70 kW five-speed baseline.

Full traces are recorded only on request (:meth:`Simulator.trace`), so memory per design is a few
hundred bytes whatever the cycle length.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd

from hevlib import MODEL_VERSION
from hevlib.components import Catalyst, ComponentLibrary, EngineMap, EngineThermal, MachineMap, best_efficiency_line
from hevlib.control import PmsConfig, thresholds
from hevlib.cycles import Cycle
from hevlib.design import BOOL_RESPONSES, DESIGN_VARS, OBJECTIVES, RESPONSES, design_vector
from hevlib.drive import N_R, BatteryArrays, DriveConfig, drive_conventional, drive_hybrid
from hevlib.executor import LocalExecutor, executor_for
from hevlib.params import Params
from hevlib.performance import performance_batch
from hevlib.powertrain.conventional import ConvDesign
from hevlib.powertrain.engine import EngineArrays
from hevlib.powertrain.layout import BALANCE_SINKS, N_O, N_T, OUT_NAMES, THERMAL_SINKS, THERMAL_SOURCES, TRACE_NAMES
from hevlib.powertrain.lookup import resample, uniform_axis
from hevlib.powertrain.machines import MachineArrays
from hevlib.powertrain.thermal import ThermalConfig, cold_factors, start_temperatures
from hevlib.powertrain.vehicle import grade_trig
from hevlib.sizing import conventional_chassis_kg, hybrid_masses

Vehicle = Literal["hybrid", "prius", "conventional"]
VEHICLES: tuple[str, ...] = ("hybrid", "prius", "conventional")

#: Designs that drive less than this share of the cycle get their per-km figures on this distance
#: (they are flagged ``cycle_met = False`` and carry a large ``e_l``), so no response is infinite.
MIN_DISTANCE_SHARE = 0.01
#: Unmet accessory energy (kWh) above which a run does not count as having met the cycle (round-off only).
UNMET_TOL_KWH = 1e-9
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
    return EngineArrays(
        float(gw[0]),
        float(gw[1] - gw[0]),
        float(gt[1]),
        f(resample(engine.speed_rad_s, None, engine.max_torque_nm, gw)),
        *(f(m) for m in maps),
        f(p, float),
        f(w, float),
        f(t, float),
        f(resample(engine.speed_rad_s, None, engine.closed_throttle_torque_nm, gw)),
    )


def thermal_config(
    engine: EngineMap, th: EngineThermal, cat: Catalyst, glider_kg: float, amb_c: float, cold_correction: bool
) -> ThermalConfig:
    """The engine's and the catalyst's thermal data as the kernels read them (ADVISOR's rules)."""
    return ThermalConfig(
        amb_c=float(amb_c),
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
        float(gw[1]),
        float(gt[1]),
        f(resample(machine.speed_rad_s, machine.torque_nm, machine.efficiency, gw, gt)),
        f(resample(machine.speed_rad_s, None, machine.max_torque_nm, gw)),
    )


def battery_arrays(module) -> BatteryArrays:
    if module.soc[0] != 0.0:
        raise ValueError(f"battery {module.name}: SOC axis must start at 0")
    g = uniform_axis(module.soc)
    return BatteryArrays(
        float(g[1]),
        *(
            np.ascontiguousarray(resample(module.soc, None, a, g))
            for a in (module.ocv_v, module.r_dis_ohm, module.r_chg_ohm)
        ),
    )


@dataclass(frozen=True)
class RunOutput:
    """Raw kernel output of one batch: accumulators (n, N_O), performance (n, 3), masses, traces."""

    out: np.ndarray
    perf: np.ndarray
    mass_kg: np.ndarray
    traces: np.ndarray | None

    def frame(self) -> pd.DataFrame:
        return pd.DataFrame(self.out, columns=list(OUT_NAMES))


class Simulator:
    """Simulate batches of designs (and the two baselines) on drive cycles."""

    def __init__(self, lib: ComponentLibrary, params: Params):
        self.lib, self.params = lib, params
        self.space = params.design_space.space()
        sim, base = params.sim, params.baseline
        self.chassis_kg = conventional_chassis_kg(lib, base.conventional.test_mass_kg, base.conventional.p_eng_kw)
        self._E_h, self._E_c = engine_arrays(lib.engine_hybrid), engine_arrays(lib.engine_conventional)
        self._M, self._G = machine_arrays(lib.motor), machine_arrays(lib.generator)
        self._B = battery_arrays(lib.battery)
        self._th = thresholds(params.pms)
        pms = params.pms
        self._pc = PmsConfig(
            pms.engine_on_threshold,
            pms.engine_min_on_s,
            pms.engine_min_off_s,
            pms.engine_min_power_kw * 1e3,
            pms.charge_power_fraction,
            pms.soc_target,
            sim.soc_min,
            pms.soc_high.value,
        )
        self._cfg = {
            "hybrid": self._config(
                lib.body_conventional, lib.wheel_conventional, lib.accessory_hybrid.electrical_w, lib.engine_hybrid
            ),
            "prius": self._config(
                lib.body_prius, lib.wheel_prius, lib.accessory_hybrid.electrical_w, lib.engine_hybrid
            ),
            "conventional": self._config(
                lib.body_conventional,
                lib.wheel_conventional,
                lib.accessory_conventional.mechanical_w,
                lib.engine_conventional,
            ),
        }
        amb, cold = sim.ambient_c, sim.cold_correction == "advisor"
        self._thermal = {
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
        gb = lib.gearbox.loss_coefficients
        e = lib.engine_conventional
        self._conv = ConvDesign(
            base.conventional.p_eng_kw / e.peak_power_kw,
            lib.wheel_conventional.radius_m,
            lib.conventional_idle_rad_s,
            lib.conventional_launch_rad_s,
            e.max_speed_rad_s,
            lib.accessory_conventional.mechanical_w,
            *map(float, gb),
        )
        self._ratios = np.ascontiguousarray(base.conventional.gear_ratios, float)
        self._upshift = np.ascontiguousarray(base.conventional.upshift_kmh, float)
        #: where :meth:`run` sends its batches (``sim.executor``); close with :meth:`close` or ``with``
        self.executor = executor_for(sim)

    def close(self) -> None:
        """Close the executor (a Dask ``LocalCluster`` it started)."""
        self.executor.close()

    def __enter__(self) -> Simulator:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __getstate__(self) -> dict:
        # what a Dask worker receives: everything but the executor (the workers simulate locally)
        state = dict(self.__dict__)
        state["executor"] = LocalExecutor()
        return state

    @classmethod
    def from_params(cls, params: Params, components_dir: str | Path = "data/components") -> Simulator:
        return cls(ComponentLibrary.load(components_dir), params)

    # ----------------------------------------------------------------------------- configuration
    def _config(self, body, wheel, p_acc_w: float, engine: EngineMap, dt: float = 1.0) -> DriveConfig:
        sim, lib = self.params.sim, self.lib
        ps, bat = lib.power_split, lib.battery
        return DriveConfig(
            dt=dt,
            mu=sim.adhesion_coefficient,
            rho=body.air_density_kg_m3,
            g=body.gravity_m_s2,
            cda=body.drag_coefficient * body.frontal_area_m2,
            crr=wheel.rolling_resistance,
            r=wheel.radius_m,
            axle0_nm=wheel.axle_drag_nm_at_0kg,
            axle_per_kg_nm=wheel.axle_drag_nm_per_kg,
            h_over_l=body.cg_height_m / body.wheelbase_m,
            f_front=body.front_weight_fraction,
            soc_init=sim.soc_init,
            soc_min=sim.soc_min,
            soc_max=sim.soc_max,
            eta_pg=sim.planetary_efficiency,
            eta_fd=sim.final_drive_efficiency,
            i_max_a=sim.pack_current_max_a,
            brake_v_mps=np.ascontiguousarray(wheel.brake_speed_mps, float),
            brake_share=np.ascontiguousarray(wheel.brake_driveline_share, float),
            p_acc_w=float(p_acc_w),
            lhv_j_per_g=lib.engine_hybrid.lhv_j_per_g,
            w_e_min=ps.engine_min_on_speed_rad_s,
            w_e_max=min(ps.engine_max_speed_rad_s, lib.engine_hybrid.max_speed_rad_s),
            w_m_max=min(ps.motor_max_speed_rad_s, lib.motor.max_speed_rad_s),
            w_g_max=min(ps.generator_max_speed_rad_s, lib.generator.max_speed_rad_s),
            cap_as=bat.capacity_ah * 3600.0,
            eta_c=bat.coulombic_efficiency,
            v_min_mod=bat.v_min,
            v_max_mod=bat.v_max,
            w_idle=lib.conventional_idle_rad_s,
            w_launch=lib.conventional_launch_rad_s,
            j_wheel=wheel.inertia_kg_m2,
            j_eng=engine.inertia_kg_m2,
            j_mot=lib.motor.inertia_kg_m2,
            j_gen=lib.generator.inertia_kg_m2,
            off_trace_mps=sim.cycle_met_tolerance_kmh / 3.6,
        )

    def _report_failure(self, r: pd.DataFrame, failed: np.ndarray, cycle: Cycle, dist_ref_m: np.ndarray) -> None:
        """Give the designs of ``failed`` (stalled, or drove less than ``sim.min_distance_share`` of the
        cycle) the worst value every cycle objective can take, in place, so that a design that failed never
        scores better than one that worked: per-km figures the failure ceiling (:meth:`_failure_ceilings`),
        ``diff_soc`` the whole SOC window below the start, ``speed_dev`` 1 (off the trace throughout),
        ``e_l`` the cycle's distance, ``accel_dev`` 100 %, ``eta_drivetrain`` 0. What the design really did
        stays in ``speed_err_mean_kmh``, ``accessory_unmet_kwh`` and the traces; ``m_veh``, ``v_max``,
        ``f_max`` and ``t_0_100_s`` are properties of the design (flat-road tests), not of the cycle run.
        """
        sim = self.params.sim
        ceil = self._failure_ceilings(cycle)
        for key in ("fc", "hc", "co", "nox", "hc_engine_out", "co_engine_out", "nox_engine_out"):
            r.loc[failed, key] = np.maximum(r.loc[failed, key].to_numpy(), ceil[key.removesuffix("_engine_out")])
        r.loc[failed, "fc_soc_corrected"] = np.maximum(r.loc[failed, "fc_soc_corrected"].to_numpy(), ceil["fc"])
        r.loc[failed, "diff_soc"] = np.maximum(r.loc[failed, "diff_soc"].to_numpy(), sim.soc_init - sim.soc_min)
        r.loc[failed, "speed_dev"] = 1.0
        r.loc[failed, "e_l"] = np.maximum(r.loc[failed, "e_l"].to_numpy(), dist_ref_m[failed] / 1e3)
        r.loc[failed, "accel_dev"] = 100.0
        r.loc[failed, "eta_drivetrain"] = 0.0

    def _failure_ceilings(self, cycle: Cycle) -> dict[str, float]:
        """Per-km ceilings reported for a design that stalled or drove less than ``sim.min_distance_share``
        of ``cycle``.

        Each is what the largest engine of the study (the design space's top ``p_eng_kw`` or the
        conventional car's, whichever burns more) would burn or emit at its map's highest rate for the
        whole cycle, over ``min_distance_share`` of the cycle's distance. A working design (one that drove
        at least that share) can never exceed it, so a failed design never scores better than any
        working one; all failed designs share it (they failed; their own per-km figures mean nothing).
        """
        lib, sim = self.lib, self.params.sim
        j = DESIGN_VARS.index("p_eng_kw")
        engines = (
            (lib.engine_hybrid, self.space.upper[j] / lib.engine_hybrid.peak_power_kw),
            (
                lib.engine_conventional,
                self.params.baseline.conventional.p_eng_kw / lib.engine_conventional.peak_power_kw,
            ),
        )
        km = sim.min_distance_share * cycle.distance_m / 1e3
        # a cold engine burns and emits more: ADVISOR's cold factors at their largest (lambda = 1, a block at
        # the maps' own reference temperature or colder)
        th = self._thermal["hybrid"]
        cold = dict(zip(("fc", "hc", "co", "nox"), cold_factors(th.t_map_c, th), strict=True))
        out = {}
        for key, rate in (("fc", "fuel_g_s"), ("hc", "hc_g_s"), ("co", "co_g_s"), ("nox", "nox_g_s")):
            grams = max(float(np.max(getattr(e, rate))) * s for e, s in engines) * cycle.duration_s * cold[key]
            out[key] = grams / km if key != "fc" else 100.0 * grams / lib.engine_hybrid.fuel_density_g_per_l / km
        return out

    # ------------------------------------------------------------------------------- design rows
    def mass_kg(self, X: np.ndarray) -> np.ndarray:
        """Exact test mass of hybrid conversions (SPEC section 4 mass model), kg."""
        X = self.space.check(X, integers=False)
        return hybrid_masses(self.lib, self.chassis_kg, X[:, 0], X[:, 1], X[:, 2], X[:, 4]).test_mass_kg

    def _rows(self, X: np.ndarray, vehicle: Vehicle) -> np.ndarray:
        lib = self.lib
        if vehicle == "conventional":
            c = self.params.baseline.conventional
            row = np.zeros((1, N_R))
            row[0, 0] = c.p_eng_kw / lib.engine_conventional.peak_power_kw
            row[0, 7] = c.test_mass_kg
            return row
        if vehicle == "prius":
            X = design_vector(self.params.baseline.prius)[None, :]
            mass = np.array([self.params.baseline.prius.test_mass_kg])
        elif vehicle == "hybrid":
            X = self.space.check(X, what="designs")
            mass = self.mass_kg(X)
        else:
            raise ValueError(f"vehicle: {vehicle!r} is not one of {', '.join(VEHICLES)}")
        rows = np.empty((X.shape[0], N_R))
        rows[:, 0] = X[:, 0] / lib.engine_hybrid.peak_power_kw
        rows[:, 1] = X[:, 1] / lib.motor.peak_power_kw
        rows[:, 2] = X[:, 2] / lib.generator.peak_power_kw
        rows[:, 3:7] = X[:, 3:7]
        rows[:, 7] = mass
        return rows

    def design_of(self, vehicle: Vehicle) -> dict[str, float]:
        """The seven design variables of a baseline (NaN for the conventional car's hybrid-only ones)."""
        if vehicle == "prius":
            return dict(zip(DESIGN_VARS, design_vector(self.params.baseline.prius).tolist(), strict=True))
        if vehicle == "conventional":
            return {v: (self.params.baseline.conventional.p_eng_kw if v == "p_eng_kw" else np.nan) for v in DESIGN_VARS}
        raise ValueError(f"vehicle: {vehicle!r} has no fixed design")

    # ----------------------------------------------------------------------------------- running
    def run_raw(
        self,
        X: np.ndarray | None,
        cycle: Cycle,
        vehicle: Vehicle = "hybrid",
        *,
        record: bool = False,
        performance: bool = True,
    ) -> RunOutput:
        """Kernel outputs for one batch (all designs of ``X``; traces for all if ``record``)."""
        rows = self._rows(X if X is not None else np.empty((0, 7)), vehicle)
        n = rows.shape[0]
        cfg = self._cfg[vehicle]
        if abs(cycle.dt_s - cfg.dt) > 1e-12:
            cfg = cfg._replace(dt=cycle.dt_s)
        out = np.zeros((n, N_O))
        traces = np.zeros((n if record else 1, cycle.n_steps, N_T))
        rec = np.arange(n) if record else np.full(n, -1)
        v_ref = np.ascontiguousarray(cycle.speed_mps, float)
        grade = np.ascontiguousarray(cycle.grade, float)
        sin_g, cos_g = grade_trig(grade)
        key_on = np.ascontiguousarray(cycle.key_on, bool)
        X_th = self._thermal[vehicle]
        t_init = self.start_temperatures(cycle, vehicle)
        if vehicle == "conventional":
            drive_conventional(
                rows,
                cfg,
                self._ratios,
                self._upshift,
                self._conv,
                self._E_c,
                v_ref,
                grade,
                sin_g,
                cos_g,
                key_on,
                X_th,
                t_init,
                out,
                traces,
                rec,
            )
        else:
            drive_hybrid(
                rows,
                cfg,
                self._th,
                self._pc,
                self._E_h,
                self._M,
                self._G,
                self._B,
                v_ref,
                grade,
                sin_g,
                cos_g,
                key_on,
                X_th,
                t_init,
                out,
                traces,
                rec,
            )
        perf = self.performance_rows(rows, vehicle) if performance else np.full((n, 3), np.nan)
        return RunOutput(out, perf, rows[:, 7].copy(), traces if record else None)

    def start_state(self, cycle: Cycle) -> str:
        """``cold`` or ``hot``: the thermal start of ``cycle`` (params ``sim.start``; cold if not listed)."""
        return self.params.sim.start.get(cycle.name, "cold")

    def start_temperatures(self, cycle: Cycle, vehicle: Vehicle) -> np.ndarray:
        """The nine thermal nodes' start temperatures of ``vehicle`` on ``cycle``, degC."""
        return start_temperatures(self.start_state(cycle), self.params.sim.ambient_c, self._thermal[vehicle].t_stat_c)

    def light_off_temperature_c(self) -> float:
        """Monolith temperature (degC) at which the catalyst first converts ``LIGHT_OFF_HC_CONVERSION`` of
        the HC (linear in the ``EX_SI`` table, as the kernels read it)."""
        cat = self.lib.catalyst
        t, eff = cat.temperature_c, cat.conversion_hc
        i = int(np.argmax(eff >= LIGHT_OFF_HC_CONVERSION))
        return float(t[i - 1] + (LIGHT_OFF_HC_CONVERSION - eff[i - 1]) / (eff[i] - eff[i - 1]) * (t[i] - t[i - 1]))

    def performance_rows(self, rows: np.ndarray, vehicle: Vehicle) -> np.ndarray:
        sim = self.params.sim
        kind = 1 if vehicle == "conventional" else 0
        E = self._E_c if kind else self._E_h
        return performance_batch(
            kind,
            rows,
            self._cfg[vehicle],
            self._ratios,
            self._conv,
            E,
            self._M,
            self._G,
            self._B,
            sim.perf_dt_s,
            sim.perf_max_time_s,
        )

    def run(
        self,
        X: np.ndarray | None,
        cycle: Cycle,
        vehicle: Vehicle = "hybrid",
        *,
        batch_size: int = 1000,
        progress: Callable[[int, int], None] | None = None,
    ) -> pd.DataFrame:
        """Responses (``hevlib.design.RESPONSES`` columns), one row per design of ``X`` in order.

        ``X``: (n, 7) in ``DESIGN_VARS`` order, checked against the design space (ignored for the two
        baselines, which give one row). ``progress(n_done, n_total)`` is called after each batch.
        """
        if vehicle != "hybrid":
            frames = [self.responses(self.run_raw(None, cycle, vehicle), cycle)]
        else:
            X = self.space.check(X, what="designs")
            step = max(int(batch_size), 1)
            batches = [X[start : start + step] for start in range(0, X.shape[0], step)]
            frames = self.executor.map(
                _batch_responses, self, [(b, cycle) for b in batches], [len(b) for b in batches], progress
            )
        if not frames:
            return pd.DataFrame({k: pd.Series(dtype=bool if k in BOOL_RESPONSES else float) for k in RESPONSES})
        return pd.concat(frames, ignore_index=True)

    def trace(self, X: np.ndarray | None, cycle: Cycle, vehicle: Vehicle = "hybrid") -> pd.DataFrame:
        """Per-step traces (``TRACE_NAMES`` plus ``time_s``, ``design``) of a few designs."""
        res = self.run_raw(X, cycle, vehicle, record=True, performance=False)
        frames = []
        for i, tr in enumerate(res.traces):
            df = pd.DataFrame(tr, columns=list(TRACE_NAMES))
            df.insert(0, "time_s", cycle.time_s)
            df.insert(0, "design", i)
            frames.append(df)
        return pd.concat(frames, ignore_index=True)

    # --------------------------------------------------------------------------------- responses
    def responses(self, res: RunOutput, cycle: Cycle) -> pd.DataFrame:
        """The eleven objectives (SPEC section 5) and the extra responses from raw kernel output."""
        o = res.frame()
        sim = self.params.sim
        lib = self.lib
        lhv = lib.engine_hybrid.lhv_j_per_g
        rho_fuel = lib.engine_hybrid.fuel_density_g_per_l
        dist_km = np.maximum(o["dist_m"].to_numpy(), MIN_DISTANCE_SHARE * cycle.distance_m) / 1e3
        fuel_l = o["fuel_g"].to_numpy() / rho_fuel
        e_fuel, e_batt = o["e_fuel_j"].to_numpy(), o["e_batt_j"].to_numpy()
        # SOC correction (SAE J1711 spirit): net battery energy as the fuel the engine would have burnt
        # to put it back through the generator, at this run's own mean engine and generator efficiency.
        eta_eng = np.where(
            e_fuel > 0,
            o["e_eng_shaft_j"].to_numpy() / np.where(e_fuel > 0, e_fuel, 1.0),
            lib.engine_hybrid.max_efficiency(),
        )
        gen_in = o["e_gen_mech_in_j"].to_numpy()
        eta_gen = np.where(gen_in > 0, o["e_gen_elec_out_j"].to_numpy() / np.where(gen_in > 0, gen_in, 1.0), 0.9)
        fuel_equiv_l = e_batt / (np.clip(eta_eng * eta_gen, 0.05, 1.0) * lhv) / rho_fuel
        acc_req = o["acc_req_sum_mps2"].to_numpy()
        in_energy = e_fuel + e_batt
        stalled = o["stuck_max_s"].to_numpy() > sim.stall_time_s
        src = "_tailpipe" if sim.emissions == "tailpipe" else ""  # the hc, co, nox objectives
        unmet_kwh = o["e_acc_unmet_j"].to_numpy() / 3.6e6
        r = pd.DataFrame(
            {
                "m_veh": res.mass_kg,
                "fc": 100.0 * fuel_l / dist_km,
                "accel_dev": 100.0 * o["acc_short_sum_mps2"].to_numpy() / np.where(acc_req > 0, acc_req, 1.0),
                **{k: o[f"{k}{src}_g"].to_numpy() / dist_km for k in ("hc", "co", "nox")},
                "e_l": np.maximum(o["dist_ref_m"].to_numpy() - o["dist_m"].to_numpy(), 0.0) / 1e3,
                # share of the cycle's duration off the trace by more than the tolerance (ADVISOR's 2 mph)
                "speed_dev": o["off_trace_s"].to_numpy() / cycle.duration_s,
                "diff_soc": sim.soc_init - o["soc_end"].to_numpy(),
                "v_max": res.perf[:, 2],
                "f_max": res.perf[:, 0],
                "fc_soc_corrected": 100.0 * (fuel_l + fuel_equiv_l) / dist_km,
                # no energy in (never started, never drew on the battery): no tractive energy out either
                "eta_drivetrain": np.where(
                    in_energy > 0, o["e_traction_j"].to_numpy() / np.where(in_energy > 0, in_energy, 1.0), 0.0
                ),
                "t_0_100_s": res.perf[:, 1],
                "cycle_met": (
                    (o["max_speed_err_mps"].to_numpy() * 3.6 <= sim.cycle_met_tolerance_kmh)
                    & ~stalled
                    & (unmet_kwh <= UNMET_TOL_KWH)
                ),
                "speed_err_mean_kmh": 3.6
                * o["speed_err_sum_mps"].to_numpy()
                / np.maximum(o["n_steps"].to_numpy(), 1.0),
                "stalled": stalled,
                "accessory_unmet_kwh": unmet_kwh,
                **{f"{k}_engine_out": o[f"{k}_g"].to_numpy() / dist_km for k in ("hc", "co", "nox")},
                "t_cat_light_off_s": o["t_cat_light_off_s"].to_numpy(),
            }
        )
        failed = stalled | (o["dist_m"].to_numpy() < sim.min_distance_share * cycle.distance_m)
        if failed.any():
            self._report_failure(r, failed, cycle, o["dist_ref_m"].to_numpy())
        bad = r[list(OBJECTIVES) + ["fc_soc_corrected", "eta_drivetrain"]].isna().any(axis=1)
        if bad.any():
            i = int(np.argmax(bad.to_numpy()))
            col = r.columns[r.iloc[i].isna()][0]
            raise FloatingPointError(f"simulation produced NaN for {col} (design row {i}, cycle {cycle.name})")
        return r


def _batch_responses(sim: Simulator, item: tuple[np.ndarray, Cycle]) -> pd.DataFrame:
    """One batch's responses (an executor's task)."""
    X, cycle = item
    return sim.responses(sim.run_raw(X, cycle, "hybrid"), cycle)


def warm_up(params: Params, paper_dir: str | Path = "data/raw/paper") -> None:
    """Compile (and cache on disk) every numba kernel the stages call, on a two-step cycle.

    numba caches each kernel per argument types; the stages always pass the same types (float64
    C-contiguous arrays), so one small run per vehicle kind fills the cache the pipeline reads.
    """
    from hevlib.sizing import study_library

    sim = Simulator(study_library(params.baseline, paper_dir), params)
    cycle = Cycle("warm-up", np.arange(3.0), np.array([0.0, 1.0, 0.0]), np.zeros(3))
    for vehicle in ("prius", "conventional"):  # the hybrid kernel (any design) and the conventional one
        sim.run_raw(None, cycle, vehicle)


def energy_balance(res: RunOutput) -> pd.DataFrame:
    """Sources, sinks and the residual of the energy balance per design.

    ``residual_share`` and ``mismatch_share`` are relative to the energy put in, fuel plus the
    magnitude of the net battery energy (the fuel energy whenever the engine runs; a design whose
    engine never starts is judged on its battery energy).
    """
    o = res.frame()
    sources = o["e_fuel_j"] + o["e_batt_j"]
    sinks = o[list(BALANCE_SINKS)].sum(axis=1)
    scale = (o["e_fuel_j"] + o["e_batt_j"].abs()).clip(lower=1.0)
    out = o[["e_fuel_j", "e_batt_j", *BALANCE_SINKS]].copy()
    out["residual_j"] = sources - sinks
    out["residual_share"] = out["residual_j"].abs() / scale
    out["mismatch_share"] = o["e_mismatch_j"].abs() / scale
    # heat balance of the thermal nodes: stored heat change = heat in (combustion, exhaust, reaction) - heat out
    stored = o["u_thermal_end_j"] - o["u_thermal_start_j"]
    heat_in = o[list(THERMAL_SOURCES)].sum(axis=1)
    out["thermal_residual_j"] = stored - heat_in + o[list(THERMAL_SINKS)].sum(axis=1)
    out["thermal_residual_share"] = out["thermal_residual_j"].abs() / heat_in.clip(lower=1.0)
    return out


def with_inputs(X: np.ndarray, responses: pd.DataFrame) -> pd.DataFrame:
    """The seven design-variable columns followed by the responses."""
    return pd.concat([pd.DataFrame(np.asarray(X, float), columns=list(DESIGN_VARS)), responses], axis=1)


__all__ = ["Simulator", "RunOutput", "energy_balance", "with_inputs", "VEHICLES", "MODEL_VERSION"]
