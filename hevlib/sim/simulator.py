"""The vehicle simulator's Python face: designs in, responses (SPEC section 5) out.

Simulation is a separate step from the data it runs on (FASTSim 3's shape): a :class:`~hevlib.sim.vehicles.Vehicle`
(one typed kernel record per batch, :meth:`~hevlib.sim.vehicles.Vehicle.from_design`) and a cycle
(:meth:`hevlib.cycles.Cycle.to_kernel`) go into the pure :func:`simulate`, which runs the numba kernels
(:mod:`hevlib.sim.drive`, :mod:`hevlib.sim.performance`) and returns the per-design accumulators;
:func:`responses` turns those into the eleven objectives and the extra responses. :class:`Simulator` keeps the
packed library and an executor and runs batches of designs through both, in parallel.

Full traces are recorded only on request (``record``), so memory per design is a few hundred bytes whatever the
cycle length.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numba
import numpy as np
import pandas as pd

from hevlib import MODEL_VERSION
from hevlib.components import ComponentLibrary
from hevlib.cycles import Cycle
from hevlib.design import BOOL_RESPONSES, CHARGE_BALANCE_RESPONSES, DESIGN_VARS, OBJECTIVES, RESPONSES
from hevlib.params import Params
from hevlib.scaling import power_scale
from hevlib.sim.drive import R_SOC0, drive_conventional, drive_hybrid
from hevlib.sim.executor import LocalExecutor, executor_for
from hevlib.sim.performance import performance_batch
from hevlib.sim.powertrain.layout import (
    BALANCE_SINKS,
    N_O,
    N_T,
    O_E_BATT,
    O_E_FUEL,
    O_SOC_END,
    OUT_NAMES,
    THERMAL_SINKS,
    THERMAL_SOURCES,
    TRACE_NAMES,
)
from hevlib.sim.powertrain.thermal import KELVIN, N_NODES, cold_factors
from hevlib.sim.vehicles import LIGHT_OFF_HC_CONVERSION, VEHICLES, KernelLibrary, Kind, Vehicle

#: Designs that drive less than this share of the cycle get their per-km figures on this distance
#: (they are flagged ``cycle_met = False`` and carry a large ``e_l``), so no response is infinite.
MIN_DISTANCE_SHARE = 0.01
#: Unmet accessory energy (kWh) above which a run does not count as having met the cycle (round-off only).
UNMET_TOL_KWH = 1e-9


@dataclass(frozen=True)
class RunOutput:
    """Raw kernel output of one batch: accumulators (n, N_O), performance (n, 3), masses, traces."""

    out: np.ndarray
    perf: np.ndarray
    mass_kg: np.ndarray
    traces: np.ndarray | None
    soc_init: np.ndarray  #: each vehicle's SOC at the start of the drive

    def frame(self) -> pd.DataFrame:
        return pd.DataFrame(self.out, columns=list(OUT_NAMES))


def thermal_start_c(vehicle: Vehicle, cycle: Cycle, thermal_start: str | np.ndarray | None = None) -> np.ndarray:
    """The nine thermal nodes' start temperatures (degC) of ``vehicle`` on ``cycle``: ``None``, the start the
    params give that cycle (``sim.start``); ``"cold"`` (every node at ambient) or ``"hot"`` (ADVISOR's
    preconditioned engine); or the temperatures themselves, in :data:`~hevlib.sim.powertrain.thermal.NODE_NAMES`
    order."""
    if thermal_start is None or isinstance(thermal_start, str):
        return vehicle.library.start_temperatures(cycle.name, vehicle.kind, thermal_start)
    t = np.array(thermal_start, dtype=float)
    if t.shape != (N_NODES,) or not np.isfinite(t).all() or (t < -KELVIN).any():
        raise ValueError(f"thermal start: {N_NODES} finite node temperatures in degC expected, got {thermal_start!r}")
    return t


def simulate(
    vehicle: Vehicle,
    cycle: Cycle,
    *,
    thermal_start: str | np.ndarray | None = None,
    record: bool = False,
    performance: bool = True,
) -> RunOutput:
    """Drive every vehicle of the batch over ``cycle`` and run the flat-road performance tests (NaN unless
    ``performance``); traces of every vehicle if ``record``. The settings are the vehicle's (its record, built
    from the params: chassis, limits, controller, step); the thermal start is ``thermal_start``
    (:func:`thermal_start_c`: the params' start for the cycle unless given). Pure: the same inputs give the same
    output, bit for bit."""
    veh = vehicle.with_step(cycle.dt_s)
    n = veh.n
    out = np.zeros((n, N_O))
    traces = np.zeros((n if record else 1, cycle.n_steps, N_T))
    rec = np.arange(n) if record else np.full(n, -1)
    t_init = thermal_start_c(veh, cycle, thermal_start)
    kernel = drive_conventional if veh.kind == "conventional" else drive_hybrid
    in_parallel(kernel, n, veh.kernel, cycle.to_kernel(), t_init, out, traces, rec)
    perf = performance_tests(vehicle) if performance else np.full((n, 3), np.nan)
    return RunOutput(out, perf, vehicle.mass_kg, traces if record else None, veh.kernel.rows[:, R_SOC0].copy())


def _ratio(num: np.ndarray, den: np.ndarray, default) -> np.ndarray:
    """``num / den`` where ``den > 0``, else ``default`` (never a division by zero)."""
    ok = den > 0
    return np.where(ok, num / np.where(ok, den, 1.0), default)


def battery_share(out: np.ndarray) -> np.ndarray:
    """Net chemical energy drawn from the battery as a share of the fuel energy (signed; +inf or -inf where the
    battery moved and no fuel was burnt, 0 where neither)."""
    e_fuel, e_batt = out[:, O_E_FUEL], out[:, O_E_BATT]
    with np.errstate(invalid="ignore"):  # sign(0) * inf
        return _ratio(e_batt, e_fuel, np.sign(e_batt) * np.inf)


def charge_balance(
    vehicle: Vehicle, cycle: Cycle, first: RunOutput, *, tolerance: float, max_runs: int
) -> tuple[RunOutput, pd.DataFrame]:
    """Charge-balanced fuel, as FASTSim does for hybrids (``soc_bal_iters``): each vehicle whose net battery
    energy on ``first`` (its run from ``sim.soc_init``) is more than ``tolerance`` of its fuel energy (SAE J1711:
    1 %) is driven again from the SOC it ended at, until it balances or has been driven ``max_runs`` times.

    Returns the last run of every vehicle (accumulators, performance of ``first``) and the
    :data:`CHARGE_BALANCE_RESPONSES`: ``fc_charge_balanced`` (L/100 km of the balanced run; NaN where it did not
    balance), the runs it took, the residual (net battery energy / fuel energy of the last run) and whether it
    balanced, and the SOC its last run started from (``soc_init_charge_balanced``). A vehicle without a battery
    balances on its first run."""
    out = first.out.copy()
    soc0 = first.soc_init.copy()
    runs = np.ones(vehicle.n, dtype=np.int64)
    resid = battery_share(out) if vehicle.kind != "conventional" else np.zeros(vehicle.n)
    todo = ~(np.abs(resid) <= tolerance)
    sim = vehicle.library.params.sim
    for _ in range(max_runs - 1):
        if not todo.any():
            break
        idx = np.flatnonzero(todo)
        soc0[idx] = np.clip(out[idx, O_SOC_END], sim.soc_min + 1e-6, sim.soc_max - 1e-6)
        again = simulate(vehicle.take(idx).with_soc_init(soc0[idx]), cycle, performance=False)
        out[idx] = again.out
        runs[idx] += 1
        resid[idx] = battery_share(again.out)
        todo[idx] = ~(np.abs(resid[idx]) <= tolerance)
    last = RunOutput(out, first.perf, first.mass_kg, None, soc0)
    fc = responses(last, cycle, vehicle.library)["fc"].to_numpy()
    frame = pd.DataFrame(
        {
            "fc_charge_balanced": np.where(todo, np.nan, fc),
            "charge_balance_runs": runs.astype(float),
            "charge_balance_residual": resid,
            "charge_balanced": ~todo,
            "soc_init_charge_balanced": soc0,
        }
    )
    return last, frame


def performance_tests(vehicle: Vehicle) -> np.ndarray:
    """(n, 3): highest launch acceleration (m/s^2), 0-100 km/h time (s) and top speed (km/h) on a flat road."""
    sim = vehicle.library.params.sim
    out = np.empty((vehicle.n, 3))
    in_parallel(performance_batch, vehicle.n, vehicle.kernel, sim.perf_dt_s, sim.perf_max_time_s, out)
    return out


#: Chunks per thread of a batch: designs differ in cost (force-limited steps), so threads take chunks as they
#: finish rather than one equal share each.
CHUNKS_PER_THREAD = 4
_POOLS: dict[tuple[int, int], ThreadPoolExecutor] = {}  # by (process, threads): a forked child makes its own


def in_parallel(kernel: Callable, n: int, *args) -> None:
    """``kernel(*args, start, stop)`` over chunks of ``range(n)`` on as many threads as numba's thread count
    (``NUMBA_NUM_THREADS``); the kernels release the GIL and write disjoint rows, so the result does not depend
    on the split."""
    threads = numba.get_num_threads()
    if threads <= 1 or n <= 1:
        kernel(*args, 0, n)
        return
    key = (os.getpid(), threads)
    if key not in _POOLS:
        _POOLS[key] = ThreadPoolExecutor(threads, thread_name_prefix="hev-sim")
    edges = np.linspace(0, n, min(n, CHUNKS_PER_THREAD * threads) + 1).astype(int)
    jobs = [_POOLS[key].submit(kernel, *args, int(a), int(b)) for a, b in zip(edges[:-1], edges[1:], strict=True)]
    for job in jobs:
        job.result()


def responses(res: RunOutput, cycle: Cycle, library: KernelLibrary) -> pd.DataFrame:
    """The eleven objectives (SPEC section 5) and the extra responses of a run (:func:`simulate`) on ``cycle``."""
    o = res.frame()
    sim = library.params.sim
    lib = library.lib
    lhv = lib.engine_hybrid.lhv_j_per_g
    rho_fuel = lib.engine_hybrid.fuel_density_g_per_l
    dist_km = np.maximum(o["dist_m"].to_numpy(), MIN_DISTANCE_SHARE * cycle.distance_m) / 1e3
    fuel_l = o["fuel_g"].to_numpy() / rho_fuel
    e_fuel, e_batt = o["e_fuel_j"].to_numpy(), o["e_batt_j"].to_numpy()
    # SOC correction (SAE J1711 spirit): net battery energy as the fuel the engine would have burnt
    # to put it back through the generator, at this run's own mean engine and generator efficiency.
    eta_eng = _ratio(o["e_eng_shaft_j"].to_numpy(), e_fuel, lib.engine_hybrid.max_efficiency())
    eta_gen = _ratio(o["e_gen_elec_out_j"].to_numpy(), o["e_gen_mech_in_j"].to_numpy(), 0.9)
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
            "diff_soc": res.soc_init - o["soc_end"].to_numpy(),
            "v_max": res.perf[:, 2],
            "f_max": res.perf[:, 0],
            "fc_soc_corrected": 100.0 * (fuel_l + fuel_equiv_l) / dist_km,
            # no energy in (never started, never drew on the battery): no tractive energy out either
            "eta_drivetrain": _ratio(o["e_traction_j"].to_numpy(), in_energy, 0.0),
            "t_0_100_s": res.perf[:, 1],
            "cycle_met": (
                (o["max_speed_err_mps"].to_numpy() * 3.6 <= sim.cycle_met_tolerance_kmh)
                & ~stalled
                & (unmet_kwh <= UNMET_TOL_KWH)
            ),
            "speed_err_mean_kmh": 3.6 * o["speed_err_sum_mps"].to_numpy() / np.maximum(o["n_steps"].to_numpy(), 1.0),
            "stalled": stalled,
            "accessory_unmet_kwh": unmet_kwh,
            **{f"{k}_engine_out": o[f"{k}_g"].to_numpy() / dist_km for k in ("hc", "co", "nox")},
            "t_cat_light_off_s": o["t_cat_light_off_s"].to_numpy(),
            "n_engine_starts": o["n_starts"].to_numpy(),
            "e_engine_start_j": o["e_engine_start_j"].to_numpy(),
            # fuel-weighted mean efficiency of the engine while fuelled (shaft work of fuelled steps / fuel energy)
            "eta_engine_mean": _ratio(o["e_shaft_fuelled_j"].to_numpy(), e_fuel, 0.0),
            # the candidate for the study's acceleration deviation whose scale matches its regression best
            # (benchmarks/accel_dev_review.py): mean |a_req - a_ach| over the cycle's steps / the cycle's peak a_req
            "accel_dev_mean_abs": 100.0
            * o["acc_abs_err_sum_mps2"].to_numpy()
            / np.maximum(o["n_steps"].to_numpy(), 1.0)
            / np.where(o["acc_req_max_mps2"].to_numpy() > 0, o["acc_req_max_mps2"].to_numpy(), 1.0),
        }
    )
    failed = stalled | (o["dist_m"].to_numpy() < sim.min_distance_share * cycle.distance_m)
    if failed.any():
        _report_failure(r, failed, cycle, o["dist_ref_m"].to_numpy(), library)
    bad = r[list(OBJECTIVES) + ["fc_soc_corrected", "eta_drivetrain"]].isna().any(axis=1)
    if bad.any():
        i = int(np.argmax(bad.to_numpy()))
        col = r.columns[r.iloc[i].isna()][0]
        raise FloatingPointError(f"simulation produced NaN for {col} (design row {i}, cycle {cycle.name})")
    return r


def failure_ceilings(cycle: Cycle, library: KernelLibrary) -> dict[str, float]:
    """Per-km ceilings reported for a design that stalled or drove less than ``sim.min_distance_share``
    of ``cycle``.

    Each is what the largest engine of the study (the design space's top ``p_eng_kw`` or the
    conventional car's, whichever burns more) would burn or emit at its map's highest rate for the
    whole cycle, over ``min_distance_share`` of the cycle's distance. A working design (one that drove
    at least that share) can never exceed it, so a failed design never scores better than any
    working one; all failed designs share it (they failed; their own per-km figures mean nothing).
    """
    lib, sim = library.lib, library.params.sim
    j = DESIGN_VARS.index("p_eng_kw")
    engines = (
        (lib.engine_hybrid, power_scale(library.space.upper[j], lib.engine_hybrid.peak_power_kw)),
        (
            lib.engine_conventional,
            power_scale(library.params.baseline.conventional.p_eng_kw, lib.engine_conventional.peak_power_kw),
        ),
    )
    km = sim.min_distance_share * cycle.distance_m / 1e3
    # a cold engine burns and emits more: ADVISOR's cold factors at their largest (lambda = 1, a block at
    # the maps' own reference temperature or colder)
    th = library.thermal["hybrid"]
    cold = dict(zip(("fc", "hc", "co", "nox"), cold_factors(th.t_map_c, th), strict=True))
    out = {}
    for key, rate in (("fc", "fuel_g_s"), ("hc", "hc_g_s"), ("co", "co_g_s"), ("nox", "nox_g_s")):
        grams = max(float(np.max(getattr(e, rate))) * s for e, s in engines) * cycle.duration_s * cold[key]
        out[key] = grams / km if key != "fc" else 100.0 * grams / lib.engine_hybrid.fuel_density_g_per_l / km
    return out


def _report_failure(
    r: pd.DataFrame, failed: np.ndarray, cycle: Cycle, dist_ref_m: np.ndarray, library: KernelLibrary
) -> None:
    """Give the designs of ``failed`` (stalled, or drove less than ``sim.min_distance_share`` of the
    cycle) the worst value every cycle objective can take, in place, so that a design that failed never
    scores better than one that worked: per-km figures the failure ceiling (:func:`failure_ceilings`),
    ``diff_soc`` the whole SOC window below the start, ``speed_dev`` 1 (off the trace throughout),
    ``e_l`` the cycle's distance, ``accel_dev`` 100 %, ``eta_drivetrain`` 0. What the design really did
    stays in ``speed_err_mean_kmh``, ``accessory_unmet_kwh`` and the traces; ``m_veh``, ``v_max``,
    ``f_max`` and ``t_0_100_s`` are properties of the design (flat-road tests), not of the cycle run.
    """
    sim = library.params.sim
    ceil = failure_ceilings(cycle, library)
    for key in ("fc", "hc", "co", "nox", "hc_engine_out", "co_engine_out", "nox_engine_out"):
        r.loc[failed, key] = np.maximum(r.loc[failed, key].to_numpy(), ceil[key.removesuffix("_engine_out")])
    r.loc[failed, "fc_soc_corrected"] = np.maximum(r.loc[failed, "fc_soc_corrected"].to_numpy(), ceil["fc"])
    r.loc[failed, "diff_soc"] = np.maximum(r.loc[failed, "diff_soc"].to_numpy(), sim.soc_init - sim.soc_min)
    r.loc[failed, "speed_dev"] = 1.0
    r.loc[failed, "e_l"] = np.maximum(r.loc[failed, "e_l"].to_numpy(), dist_ref_m[failed] / 1e3)
    r.loc[failed, "accel_dev"] = 100.0
    r.loc[failed, "eta_drivetrain"] = 0.0


class Simulator:
    """Simulate batches of designs (and the two baselines) on drive cycles: the packed library
    (:class:`~hevlib.sim.vehicles.KernelLibrary`), :func:`simulate` and :func:`responses`, and the executor the
    batches run on (``sim.executor``)."""

    def __init__(self, lib: ComponentLibrary, params: Params):
        self.lib, self.params = lib, params
        self.library = KernelLibrary.build(lib, params)
        self.space = self.library.space
        self.chassis_kg = self.library.chassis_kg
        #: where :meth:`run` sends its batches (``sim.executor``); close with :meth:`close` or ``with``
        self.executor = executor_for(params.sim)

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

    # ----------------------------------------------------------------------------------- vehicles
    def vehicle(self, X: np.ndarray | pd.DataFrame | None, kind: Kind = "hybrid") -> Vehicle:
        """The kernel record of designs ``X`` (``hybrid``: named columns, or an array in ``DESIGN_VARS`` order)
        or of a baseline (``prius``, ``conventional``: ``X`` ignored)."""
        if kind == "hybrid":
            return Vehicle.from_design(self.library, X if X is not None else np.empty((0, len(DESIGN_VARS))))
        return Vehicle.baseline(self.library, kind)

    def mass_kg(self, X: np.ndarray) -> np.ndarray:
        """Exact test mass of hybrid conversions (SPEC section 4 mass model), kg."""
        return self.library.mass_kg(X)

    def design_of(self, vehicle: Kind) -> dict[str, float]:
        """The seven design variables of a baseline (NaN for the conventional car's hybrid-only ones)."""
        if vehicle not in ("prius", "conventional"):
            raise ValueError(f"vehicle: {vehicle!r} has no fixed design")
        return {k: float(v) for k, v in Vehicle.baseline(self.library, vehicle).design.iloc[0].items()}

    def start_state(self, cycle: Cycle) -> str:
        """``cold`` or ``hot``: the thermal start of ``cycle`` (params ``sim.start``; cold if not listed)."""
        return self.library.start_state(cycle.name)

    def start_temperatures(self, cycle: Cycle, vehicle: Kind) -> np.ndarray:
        """The nine thermal nodes' start temperatures of ``vehicle`` on ``cycle``, degC."""
        return self.library.start_temperatures(cycle.name, vehicle)

    def light_off_temperature_c(self) -> float:
        """Monolith temperature (degC) at which the catalyst first converts ``LIGHT_OFF_HC_CONVERSION`` of
        the HC (linear in the ``EX_SI`` table, as the kernels read it)."""
        cat = self.lib.catalyst
        t, eff = cat.temperature_c, cat.conversion_hc
        i = int(np.argmax(eff >= LIGHT_OFF_HC_CONVERSION))
        return float(t[i - 1] + (LIGHT_OFF_HC_CONVERSION - eff[i - 1]) / (eff[i] - eff[i - 1]) * (t[i] - t[i - 1]))

    # ----------------------------------------------------------------------------------- running
    def run_raw(
        self,
        X: np.ndarray | None,
        cycle: Cycle,
        vehicle: Kind = "hybrid",
        *,
        record: bool = False,
        performance: bool = True,
        thermal_start: str | np.ndarray | None = None,
    ) -> RunOutput:
        """Kernel outputs for one batch (all designs of ``X``; traces for all if ``record``), from the params'
        thermal start for the cycle unless ``thermal_start`` (:func:`thermal_start_c`) says otherwise."""
        veh = self.vehicle(X, vehicle)
        return simulate(veh, cycle, thermal_start=thermal_start, record=record, performance=performance)

    def on_cycle(self, cycle: Cycle, batch_size: int) -> Callable[[np.ndarray], pd.DataFrame]:
        """The hybrid designs' responses on ``cycle`` as a function of the designs alone (what the optimisers
        and their simulation log call): :meth:`run` in batches of ``batch_size``."""
        return partial(self.run, cycle=cycle, vehicle="hybrid", batch_size=batch_size)

    def run(
        self,
        X: np.ndarray | None,
        cycle: Cycle,
        vehicle: Kind = "hybrid",
        *,
        batch_size: int = 1000,
        progress: Callable[[int, int], None] | None = None,
        charge_balanced: bool = False,
    ) -> pd.DataFrame:
        """Responses (``hevlib.design.RESPONSES`` columns), one row per design of ``X`` in order; with
        ``charge_balanced`` also the :data:`CHARGE_BALANCE_RESPONSES` (:func:`charge_balance`).

        ``X``: (n, 7) in ``DESIGN_VARS`` order, checked against the design space (ignored for the two
        baselines, which give one row). ``progress(n_done, n_total)`` is called after each batch.
        """
        if vehicle != "hybrid":
            frames = [self.drive(self.vehicle(None, vehicle), cycle, charge_balanced=charge_balanced)[1]]
        else:
            X = self.space.check(X, what="designs")
            step = max(int(batch_size), 1)
            batches = [X[start : start + step] for start in range(0, X.shape[0], step)]
            frames = self.executor.map(
                _batch_responses,
                self,
                [(b, cycle, charge_balanced) for b in batches],
                [len(b) for b in batches],
                progress,
            )
        if not frames:
            cols = RESPONSES + (CHARGE_BALANCE_RESPONSES if charge_balanced else ())
            return pd.DataFrame({k: pd.Series(dtype=bool if k in BOOL_RESPONSES else float) for k in cols})
        return pd.concat(frames, ignore_index=True)

    def drive(self, vehicle: Vehicle, cycle: Cycle, *, charge_balanced: bool = False) -> tuple[RunOutput, pd.DataFrame]:
        """(raw run from ``sim.soc_init``, its responses) of ``vehicle`` on ``cycle``; with ``charge_balanced`` the
        responses gain the :data:`CHARGE_BALANCE_RESPONSES` (``sim.charge_balance_*`` settings)."""
        res = simulate(vehicle, cycle)
        r = responses(res, cycle, self.library)
        if charge_balanced:
            sim = self.params.sim
            _, cb = charge_balance(
                vehicle,
                cycle,
                res,
                tolerance=sim.charge_balance_tolerance,
                max_runs=sim.charge_balance_max_runs,
            )
            r = pd.concat([r, cb], axis=1)
        return res, r

    def trace(
        self, X: np.ndarray | None, cycle: Cycle, vehicle: Kind = "hybrid", *, soc_init: float | None = None
    ) -> pd.DataFrame:
        """Per-step traces (``TRACE_NAMES`` plus ``time_s``, ``design``) of a few designs, from ``sim.soc_init``
        or from ``soc_init`` (e.g. a charge-balanced run's ``soc_init_charge_balanced``)."""
        return vehicle_trace(self.vehicle(X, vehicle), cycle, soc_init=soc_init)

    def responses(self, res: RunOutput, cycle: Cycle) -> pd.DataFrame:
        """:func:`responses` of a run of this simulator."""
        return responses(res, cycle, self.library)


def vehicle_trace(vehicle: Vehicle, cycle: Cycle, *, soc_init: float | None = None) -> pd.DataFrame:
    """Per-step traces (``TRACE_NAMES`` plus ``time_s``, ``design``) of every vehicle of ``vehicle``, from its own
    start SOC or from ``soc_init``."""
    res = simulate(
        vehicle if soc_init is None else vehicle.with_soc_init(soc_init), cycle, record=True, performance=False
    )
    frames = []
    for i, tr in enumerate(res.traces):
        df = pd.DataFrame(tr, columns=list(TRACE_NAMES))
        df.insert(0, "time_s", cycle.time_s)
        df.insert(0, "design", i)
        frames.append(df)
    return pd.concat(frames, ignore_index=True)


def _batch_responses(sim: Simulator, item: tuple[np.ndarray, Cycle, bool]) -> pd.DataFrame:
    """One batch's responses (an executor's task)."""
    X, cycle, charge_balanced = item
    return sim.drive(sim.vehicle(X, "hybrid"), cycle, charge_balanced=charge_balanced)[1]


def warm_up(params: Params) -> None:
    """Compile (and cache on disk) every numba kernel the stages call, on a two-step cycle.

    numba caches each kernel per argument types; the stages always pass the same types (float64
    C-contiguous arrays), so one small run per vehicle kind fills the cache the pipeline reads.
    """
    from hevlib.sizing import study_library

    sim = Simulator(study_library(params.baseline), params)
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


__all__ = [
    "Simulator",
    "RunOutput",
    "simulate",
    "performance_tests",
    "responses",
    "failure_ceilings",
    "energy_balance",
    "charge_balance",
    "CHARGE_BALANCE_RESPONSES",
    "with_inputs",
    "Vehicle",
    "KernelLibrary",
    "VEHICLES",
    "MODEL_VERSION",
]
