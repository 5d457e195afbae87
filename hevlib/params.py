"""The params contract: ``params.yaml`` validated by a typed schema at the start of every stage.

An unknown key, a wrong type or an out-of-range value raises :class:`ParamsError` whose message is a
single line naming the key (``doe.n_lhs: ...``). Stages catch it, print it, exit non-zero and write
nothing.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, model_validator

from hevlib.design import DESIGN_VARS, OBJECTIVES, DesignSpace, objective_indices
from hevlib.io import read_yaml_mapping


class ParamsError(ValueError):
    """A one-line, key-naming error in params.yaml."""


class _Strict(BaseModel):
    """Unknown keys forbidden; strict types: no bool or float for an int, no bool or string for a float
    (an int is a valid float), no number for a string."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)


def _list_to_tuple(v):
    """YAML has no tuples: a list of the right length stands for one (its items stay strictly typed)."""
    return tuple(v) if isinstance(v, list) else v


Pos = Annotated[float, Field(gt=0)]
NonNeg = Annotated[float, Field(ge=0)]
Frac = Annotated[float, Field(ge=0, le=1)]
Seed = Annotated[int, Field(ge=0, le=2**32 - 1)]


# --------------------------------------------------------------------------------------------- cycles
class CycleSpec(_Strict):
    file: str = Field(pattern=r"^[A-Za-z0-9_.-]+\.csv$", description="raw CSV in cycles.raw_dir")
    # road grade in percent (rise/run x 100), constant over the cycle; null: the file's grade column (or flat)
    grade_pct: Annotated[float, Field(ge=-30, le=30)] | None = None


#: A cycle key names its output file (data/cycles/<name>.parquet).
CycleName = Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]*$")]


class CyclesParams(_Strict):
    raw_dir: str = "data/raw/cycles"
    step_s: Annotated[float, Field(gt=0, le=10)] = 1.0
    sizing: str = "udds"
    validation: str = "ftp"
    cycles: dict[CycleName, CycleSpec] = Field(min_length=1)

    @model_validator(mode="after")
    def _known_roles(self):
        for role in ("sizing", "validation"):
            if getattr(self, role) not in self.cycles:
                raise ValueError(f"{role}: {getattr(self, role)!r} is not one of cycles.cycles")
        return self


# ------------------------------------------------------------------------------------------- baseline
#: A component file in ``baseline.components_dir`` (ADVISOR data as YAML). No file name lives in the code: the
#: study's choices are params.yaml's, and the components stage lists every key below as a DVC dep.
ComponentFile = Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]+\.ya?ml$")]


class _PartValues(_Strict):
    def values(self) -> dict[str, float]:
        """The values that replace the file's (the keys given, not null)."""
        return {k: float(v) for k, v in self.model_dump(exclude={"file", "coast_down"}).items() if v is not None}


#: Newtons per pound-force and metres per second per mile per hour (both exact by definition: the avoirdupois
#: pound 0.45359237 kg under standard gravity 9.80665 m/s^2; the international mile 1609.344 m per 3600 s).
N_PER_LBF = 0.45359237 * 9.80665
MPS_PER_MPH = 0.44704


class CoastDownParams(_Strict):
    """A body's road load from its coast-down: ``F = A + B v + C v^2`` with v in mph and F in lbf (the EPA's
    target coefficients, ``Target Coef A/B/C`` of the test car list; :mod:`hevlib.epa`). It replaces drag
    coefficient x frontal area, the wheel file's rolling resistance and its axle drag: a coast-down in neutral
    includes the tyres', the bearings', the brakes' and the driveline's drag."""

    a_lbf: Annotated[float, Field(gt=0, le=300)]  # constant term: rolling resistance and friction, lbf
    b_lbf_per_mph: Annotated[float, Field(ge=-3, le=3)]  # linear term, lbf per mph (may be negative)
    c_lbf_per_mph2: Annotated[float, Field(gt=0, le=0.5)]  # quadratic term: aerodynamic drag, lbf per mph^2

    @model_validator(mode="after")
    def _positive(self):
        a, b, c = self.a_lbf, self.b_lbf_per_mph, self.c_lbf_per_mph2
        if b < 0 and a - b * b / (4 * c) <= 0:
            raise ValueError(f"b_lbf_per_mph: {b:g} makes A + B v + C v^2 negative at {-b / (2 * c):.3g} mph")
        return self

    def si(self) -> tuple[float, float, float]:
        """(A in N, B in N per m/s, C in N per (m/s)^2)."""
        return (
            self.a_lbf * N_PER_LBF,
            self.b_lbf_per_mph * N_PER_LBF / MPS_PER_MPH,
            self.c_lbf_per_mph2 * N_PER_LBF / (MPS_PER_MPH * MPS_PER_MPH),
        )


class BodyParams(_PartValues):
    """A body: its file (ADVISOR ``VEH_*``), and values replacing the file's; null keeps the file's. The road load
    is either drag coefficient x frontal area (with the wheel's rolling resistance and axle drag) or ``coast_down``,
    never both."""

    file: ComponentFile
    drag_coefficient: Annotated[float, Field(gt=0, le=2)] | None = None
    frontal_area_m2: Annotated[float, Field(gt=0.3, le=15)] | None = None
    cg_height_m: Annotated[float, Field(gt=0, le=3)] | None = None
    wheelbase_m: Annotated[float, Field(gt=0.5, le=10)] | None = None
    front_weight_fraction: Annotated[float, Field(gt=0, lt=1)] | None = None  # static share on the driven axle
    cargo_mass_kg: Annotated[float, Field(ge=0, le=3000)] | None = None
    coast_down: CoastDownParams | None = None  # road load from a coast-down instead of Cd, area and tyres

    @model_validator(mode="after")
    def _one_road_load(self):
        given = [k for k in ("drag_coefficient", "frontal_area_m2") if getattr(self, k) is not None]
        if self.coast_down is not None and given:
            raise ValueError(f"coast_down: give the road load as coast_down or as {' and '.join(given)}, not both")
        return self

    def values(self) -> dict[str, float]:
        """The values that replace the file's, the coast-down's in SI (``Body.road_load_*``)."""
        out = super().values()
        if self.coast_down is not None:
            a, b, c = self.coast_down.si()
            out.update(road_load_a_n=a, road_load_b_n_per_mps=b, road_load_c_n_per_mps2=c)
        return out


class WheelParams(_PartValues):
    """Wheels and tyres: their file (ADVISOR ``WH_*``: braking split, axle losses), and values replacing the file's."""

    file: ComponentFile
    radius_m: Annotated[float, Field(gt=0.1, le=1.5)] | None = None  # rolling radius
    rolling_resistance: Annotated[float, Field(gt=0, le=0.1)] | None = None  # coefficient
    inertia_kg_m2: Annotated[float, Field(ge=0, le=100)] | None = None  # all wheels, tyres and axles


def _one_rolling_resistance(body: BodyParams, wheel: WheelParams) -> None:
    """A coast-down body's A term is its rolling resistance: the wheel may not give one too."""
    if body.coast_down is not None and wheel.rolling_resistance is not None:
        raise ValueError("wheel: rolling_resistance must be left out: body.coast_down gives the rolling term")


class HybridKitParams(_Strict):
    """The hybrid system every design scales and the stock Prius carries (files in ``components_dir``)."""

    engine: ComponentFile  # fuel, emission and thermal maps (ADVISOR FC_*)
    motor: ComponentFile  # MC_*
    generator: ComponentFile  # GC_*
    control: ComponentFile  # the power-split control and engine operating line (PTC_*)
    transmission: ComponentFile  # the planetary set and final drive (TX_*)
    accessories: ComponentFile  # ACC_*


class ConventionalParams(_Strict):
    """The conventional car the study converts: each part a component file, and values with units."""

    body: BodyParams
    wheel: WheelParams
    engine: ComponentFile  # fuel, emission and thermal maps (ADVISOR FC_*), scaled to p_eng_kw
    gearbox: ComponentFile  # mass and loss regression (TX_*); ratios from gear_ratios
    accessories: ComponentFile  # ACC_*
    control: ComponentFile  # shift and clutch logic (PTC_*)
    p_eng_kw: Annotated[float, Field(gt=10, le=300)] = 70.0
    test_mass_kg: Annotated[float, Field(gt=500, le=4000)] = 1195.0
    gear_ratios: list[Pos] = [13.195, 7.3486, 4.9126, 3.4916, 2.5984]
    shift_logic: Literal["load", "speed"] = "load"
    upshift_kmh: list[Pos] = [24.0, 40.0, 64.0, 75.0]
    idle_speed_rpm: Annotated[float, Field(gt=300, le=2000)] = 800.0

    @model_validator(mode="after")
    def _one_rolling_resistance(self):
        _one_rolling_resistance(self.body, self.wheel)
        return self

    @model_validator(mode="after")
    def _shift_table(self):
        if len(self.upshift_kmh) != len(self.gear_ratios) - 1:
            raise ValueError("upshift_kmh: needs one speed fewer than gear_ratios")
        if sorted(self.upshift_kmh) != list(self.upshift_kmh):
            raise ValueError("upshift_kmh: speeds must increase")
        if sorted(self.gear_ratios, reverse=True) != list(self.gear_ratios):
            raise ValueError("gear_ratios: ratios must decrease from first to top gear")
        return self


class PriusParams(_Strict):
    """The stock Prius, the hybrid reference: its body and wheels, and the sizes of the hybrid kit's parts."""

    body: BodyParams
    wheel: WheelParams
    p_eng_kw: Pos = 43.0
    p_mot_kw: Pos = 31.0
    p_gen_kw: Pos = 15.0
    i0: Pos = 3.93
    n_bat: Annotated[int, Field(ge=1, le=400)] = 25
    n_r: Annotated[int, Field(ge=20, le=200)] = 78
    n_s: Annotated[int, Field(ge=10, le=200)] = 30
    test_mass_kg: Annotated[float, Field(gt=500, le=4000)] = 1404.0

    @model_validator(mode="after")
    def _one_rolling_resistance(self):
        _one_rolling_resistance(self.body, self.wheel)
        return self

    @model_validator(mode="after")
    def _gear_set(self):
        if self.n_s >= self.n_r:
            raise ValueError(f"n_s: {self.n_s} sun teeth must be fewer than n_r = {self.n_r} ring teeth")
        return self


class BaselineParams(_Strict):
    components_dir: str = "data/raw/components"
    battery: Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]*$")]  # one of batteries
    batteries: dict[str, ComponentFile] = Field(min_length=1)  # name -> battery module file (ADVISOR ESS_*)
    battery_temperature_c: float = Field(41.0, ge=-20, le=60)
    exhaust: ComponentFile  # catalyst and exhaust-system mass rule, both cars (EX_*)
    hybrid: HybridKitParams
    conventional: ConventionalParams
    prius: PriusParams

    @model_validator(mode="after")
    def _known_battery(self):
        if self.battery not in self.batteries:
            raise ValueError(f"battery: {self.battery!r} is not one of batteries ({', '.join(self.batteries)})")
        return self


# --------------------------------------------------------------------------------------- simulation
#: ``sim`` keys that choose where batches run, never what they compute (left out of the simulation fingerprint)
EXECUTION_KEYS = ("executor", "scheduler", "workers")
#: ``sim`` keys only the charge-balanced runs read (validation, baselines), never a sizing-cycle simulation
CHARGE_BALANCE_KEYS = ("charge_balance_tolerance", "charge_balance_max_runs")
#: ``baseline`` keys a hybrid design's simulation reads from params (the rest reach it through data/components,
#: or describe the baselines only): the conventional car it converts (engine rated power, test mass).
CONVERSION_KEYS = ("baseline.conventional.p_eng_kw", "baseline.conventional.test_mass_kg")


def sizing_simulation_keys(params) -> dict[str, object]:
    """Every params key (dotted, DVC's spelling) a hybrid design's simulated responses on the sizing cycle
    depend on, with its value: the ``sim`` keys less where batches run, the charge-balance loop and the start
    state of other cycles; ``sim.start.<sizing>``; ``pms``; :data:`CONVERSION_KEYS`; ``cycles.sizing`` and
    ``cycles.cycles.<sizing>`` (its file and grade). The
    simulating stages of ``dvc.yaml`` list exactly these (a test holds them to it) and
    :func:`hevlib.doe.simulation_fingerprint` hashes them, so a key that changes neither never reruns them."""
    sizing = params.cycles.sizing
    sim = params.sim.model_dump(mode="json")
    out: dict[str, object] = {
        f"sim.{k}": v for k, v in sim.items() if k not in (*EXECUTION_KEYS, *CHARGE_BALANCE_KEYS, "start")
    }
    out[f"sim.start.{sizing}"] = params.sim.start.get(sizing, "cold")
    out["pms"] = params.pms.model_dump(mode="json")
    conv = params.baseline.conventional
    out.update({CONVERSION_KEYS[0]: conv.p_eng_kw, CONVERSION_KEYS[1]: conv.test_mass_kg})
    out["cycles.sizing"] = sizing
    out[f"cycles.cycles.{sizing}"] = params.cycles.cycles[sizing].model_dump(mode="json")
    return out


class SimParams(_Strict):
    soc_init: Frac = 0.7  # ADVISOR's initial SOC
    soc_min: Frac = 0.45  # PTC_PRIUS_JPN SOC window
    soc_max: Frac = 0.75
    adhesion_coefficient: Annotated[float, Field(gt=0, le=1.5)] = 0.9
    planetary_efficiency: Annotated[float, Field(gt=0.8, le=1.0)] = 0.98
    final_drive_efficiency: Annotated[float, Field(gt=0.8, le=1.0)] = 0.97
    pack_current_max_a: Pos = 200.0
    perf_dt_s: Annotated[float, Field(gt=0, le=1)] = 0.1
    perf_max_time_s: Annotated[float, Field(gt=10, le=300)] = 60.0
    cycle_met_tolerance_kmh: Annotated[float, Field(gt=0, le=50)] = 3.2
    stall_time_s: Annotated[float, Field(gt=0, le=3600)] = 10.0  # stood still this long while asked to move
    min_distance_share: Annotated[float, Field(gt=0, le=1)] = 0.1  # per-km figures below: failure ceiling
    ambient_c: Annotated[float, Field(ge=-40, le=50)] = 20.0  # air, and every thermal node at a cold start
    emissions: Literal["tailpipe", "engine_out"] = "tailpipe"  # what the hc, co, nox objectives are
    start: dict[str, Literal["cold", "hot"]] = {}  # thermal start state per cycle name (absent: cold)
    cold_correction: Literal["none", "advisor"] = "advisor"  # cold-engine fuel/emission factors (no cold maps)
    # charge-balanced fuel (validation, baselines): rerun from the end SOC until |net battery energy| is within
    # this share of the fuel energy (SAE J1711: 1 %), at most max_runs runs in all
    charge_balance_tolerance: Annotated[float, Field(gt=0, le=0.2)] = 0.01
    charge_balance_max_runs: Annotated[int, Field(ge=1, le=50)] = 10
    # where batches of designs run (hevlib/sim/executor.py); results do not depend on it
    executor: Literal["local", "dask"] = "local"
    scheduler: str | None = None  # dask: scheduler address (tcp://host:8786); unset: a LocalCluster per stage
    workers: Annotated[int, Field(ge=1, le=4096)] | None = None  # LocalCluster worker processes (unset: 1 per core)

    @model_validator(mode="after")
    def _window(self):
        if not self.soc_min < self.soc_init < self.soc_max:
            raise ValueError("soc_init: must lie strictly inside (soc_min, soc_max)")
        for key in ("scheduler", "workers"):
            if self.executor == "local" and getattr(self, key) is not None:
                raise ValueError(f"{key}: set only with executor: dask")
        return self


class Trapezoid(_Strict):
    """Fuzzy threshold: the membership of 'above' rises linearly over ``value -/+ width/2``."""

    value: float
    width: NonNeg = 0.0


class PmsParams(_Strict):
    soc_low: Trapezoid = Trapezoid(value=0.5, width=0.04)
    soc_high: Trapezoid = Trapezoid(value=0.7, width=0.04)
    grade_low: Trapezoid = Trapezoid(value=0.02, width=0.01)
    grade_high: Trapezoid = Trapezoid(value=0.08, width=0.02)
    speed_high_kmh: Trapezoid = Trapezoid(value=45.0, width=6.0)
    torque_low: Trapezoid = Trapezoid(value=0.15, width=0.05)
    torque_high: Trapezoid = Trapezoid(value=0.7, width=0.1)
    engine_on_threshold: Frac = 0.5
    engine_min_on_s: NonNeg = 5.0
    engine_min_off_s: NonNeg = 3.0
    engine_min_power_kw: NonNeg = 6.0
    charge_power_fraction: Frac = 0.25
    soc_target: Frac = 0.6
    # ADVISOR's Prius control beyond the rule base (PTC_PRIUS_JPN); false = the study's plain rule base
    coolant_warmup: bool = True  # below the file's warm-up coolant temperature the engine stays on until warm
    engine_dynamics: bool = True  # starts spin the carrier up over their duration (start-up inertia, crank torque)
    full_power_above_kw: Annotated[float, Field(gt=0, le=500)] | None = 25.0  # ADVISOR: road power -> full engine
    # the supervisory controller: the study's fuzzy rule base (above), or ECMS in the drive step (hevlib/sim/ecms.py:
    # fuel plus battery energy at an equivalence factor with SOC feedback; the same warm-up rule and minimum times)
    strategy: Literal["fuzzy", "ecms"] = "fuzzy"
    ecms_soc_gain: Annotated[float, Field(ge=0.0, le=1000.0)] = 20.0  # per unit of SOC below soc_target
    ecms_n_speed: Annotated[int, Field(ge=1, le=100)] = 12  # engine-on candidates per step: speeds ...
    ecms_n_torque: Annotated[int, Field(ge=2, le=100)] = 12  # ... by torques (zero to the most at each speed)

    @model_validator(mode="after")
    def _ordered(self):
        for lo, hi in (("soc_low", "soc_high"), ("grade_low", "grade_high"), ("torque_low", "torque_high")):
            if getattr(self, lo).value >= getattr(self, hi).value:
                raise ValueError(f"{lo}: value must be below {hi}.value")
        return self


# ----------------------------------------------------------------------------------- design space
Bounds = Annotated[tuple[float, float], BeforeValidator(_list_to_tuple)]


class DesignSpaceParams(_Strict):
    p_eng_kw: Bounds = (25.0, 70.0)
    p_mot_kw: Bounds = (20.0, 60.0)
    p_gen_kw: Bounds = (5.0, 30.0)
    i0: Bounds = (2.0, 4.5)
    n_bat: Bounds = (10, 60)
    n_r: Bounds = (50, 90)
    n_s: Bounds = (18, 40)

    @model_validator(mode="after")
    def _bounds(self):
        for name in DESIGN_VARS:
            lo, hi = getattr(self, name)
            if not lo < hi:
                raise ValueError(f"{name}: lower bound {lo:g} must be below upper bound {hi:g}")
            if lo <= 0:
                raise ValueError(f"{name}: bounds must be positive")
        return self

    def space(self) -> DesignSpace:
        return DesignSpace.from_bounds({v: getattr(self, v) for v in DESIGN_VARS})


# --------------------------------------------------------------------------------------------- doe
class DoeParams(_Strict):
    """Designs simulated for the surrogates (SPEC 6): the study's L27 array, a seeded LHS, or both."""

    method: Literal["l27", "lhs", "both"] = "l27"
    n_lhs: Annotated[int, Field(ge=1, le=1_000_000)] = 300  # Latin-hypercube designs (lhs, both)
    seed: Seed = 42  # seed of the Latin hypercube
    batch_size: Annotated[int, Field(ge=1, le=100_000)] = 1000  # designs per simulator batch
    l27_file: str = "data/raw/paper/l27_assignment.csv"


# -------------------------------------------------------------------------------------- surrogates
class BnnParams(_Strict):
    """Bayesian-regularised MLP (SPEC 7), trained as the study's MATLAB ``trainbr``: Levenberg-Marquardt with
    MacKay's evidence re-estimation of alpha, beta after every accepted step (hevlib/surrogates/lm.py)."""

    networks: Literal["per_objective", "shared"] = "per_objective"  # 11 nets 7-h-1, or one net 7-h-11
    hidden: Annotated[int, Field(ge=1, le=256)] = 8  # tanh hidden units (fewer where n_w would exceed N/2)
    mu: Annotated[float, Field(gt=0, le=1e10)] = 0.005  # initial LM damping (trainbr: 0.005)
    mu_dec: Annotated[float, Field(gt=0, lt=1)] = 0.1  # mu *= mu_dec after a step that lowers F
    mu_inc: Annotated[float, Field(gt=1, le=1000)] = 10.0  # mu *= mu_inc after a step that does not
    mu_max: Annotated[float, Field(gt=0, le=1e20)] = 1e10  # a network stops when mu exceeds it
    max_epochs: Annotated[int, Field(ge=1, le=100_000)] = 1000
    window: Annotated[int, Field(ge=1, le=10_000)] = 10  # epochs over which gamma and E_D must be stable
    gamma_tol: Annotated[float, Field(gt=0, lt=1)] = 0.01  # relative spread of gamma and E_D over the window
    restarts: Annotated[int, Field(ge=1, le=100)] = 2  # seeded starts per network; highest evidence kept
    seed: Seed = 0  # weight initialisation
    # objectives fitted as log(y + c) (heavy-tailed per-km figures); see hevlib/surrogates/transform.py
    log_targets: list[str] = ["fc", "hc", "co", "nox"]

    @model_validator(mode="after")
    def _known_log_targets(self):
        objective_indices(self.log_targets, what="log_targets")
        return self

    @model_validator(mode="after")
    def _mu_below_max(self):
        if self.mu >= self.mu_max:
            raise ValueError(f"mu: initial damping {self.mu:g} must be below mu_max = {self.mu_max:g}")
        return self


class HeldoutParams(_Strict):
    """Fresh seeded LHS designs simulated only to judge the surrogates (never trained on)."""

    n: Annotated[int, Field(ge=2, le=100_000)] = 200
    seed: Seed = 1234


class SurrogateParams(_Strict):
    """Both surrogates: the split that judges them (fitted on ``train_fraction`` of the DOE, scored on the rest);
    the models saved for the optimisers are refitted on every DOE design; ``heldout`` is never fitted on."""

    train_fraction: Annotated[float, Field(gt=0, lt=1)] = 0.7  # DOE share the judged models are fitted on
    split_seed: Seed = 0  # seed of the train/test split
    bnn: BnnParams = BnnParams()
    heldout: HeldoutParams = HeldoutParams()


# ---------------------------------------------------------------------------------------- optimise
class AlgoParams(_Strict):
    """One optimiser's settings (``optimise.algorithms.<algo>``; see hevlib.optimise for their use)."""

    pop_size: Annotated[int, Field(ge=4, le=100_000)] = 200
    n_gen: Annotated[int, Field(ge=1, le=100_000)] = 500
    crossover_prob: Frac = 0.6  # SBX probability per mating
    mutation_prob: Frac = 0.05  # polynomial-mutation probability per variable
    seed: Seed = 1
    surrogate: Literal["bnn", "regression"] = "bnn"
    # algorithm-specific knobs; unused ones must keep their defaults
    ref_dirs_partitions: Annotated[list[Annotated[int, Field(ge=1, le=20)]], Field(min_length=1, max_length=3)] = [
        2,
        1,
    ]  # nsga3: Das-Dennis layers
    n_neighbors: Annotated[int, Field(ge=2, le=1000)] = 20  # moead: neighbourhood size T
    delta: Frac = 0.9  # moead: probability of mating and replacing within the neighbourhood
    n_replace: Annotated[int, Field(ge=1, le=1000)] = 2  # moead: most slots one offspring may take
    decomposition: Literal["tchebycheff", "pbi"] = "tchebycheff"  # moead
    n_weights: Annotated[int, Field(ge=1, le=10_000)] = 50  # moga: weight vectors (one GA each)
    norm_samples: Annotated[int, Field(ge=2, le=1_000_000)] = 2000  # moga: designs for ideal/nadir


class OracleParams(AlgoParams):
    """The oracle: ``algorithm`` with the simulator in the loop (no surrogate), same problem and repair."""

    algorithm: Literal["nsga3", "moead", "moga"] = "nsga3"


class InfillParams(_Strict):
    """Model management of every surrogate-assisted optimiser (hevlib/optimise/infill.py).

    Round 0 is the study's one-shot protocol (surrogate fitted on the DOE, full ``n_gen`` search, front
    re-simulated); each further round adds the simulated candidates to the training data, refits the
    surrogate and resumes the search from the last population for ``n_gen`` generations.
    """

    rounds: Annotated[int, Field(ge=0, le=100)] = 4  # infill rounds after round 0
    designs_per_round: Annotated[int, Field(ge=1, le=100_000)] = 200  # candidates simulated per round
    n_gen: Annotated[int, Field(ge=1, le=100_000)] = 100  # generations of each resumed search
    criterion: Literal["diverse", "uncertainty"] = "uncertainty"  # see hevlib.optimise.infill.select_candidates


class BayesParams(_Strict):
    """One Bayesian-optimisation source on BoTorch (``optimise.bayes.<name>``; hevlib/optimise/bayesopt.py):
    rounds of ``batch`` designs from the DOE until ``budget`` simulations (the DOE's included)."""

    acquisition: Literal["parego", "nehvi"]  # qLogNParEGO on all 11 objectives | qLogNEHVI on a reduced set
    budget: Annotated[int, Field(ge=2, le=10_000_000)]  # simulations, the DOE's included
    batch: Annotated[int, Field(ge=1, le=100)] = 10  # designs per round (chosen greedily, pending points)
    num_restarts: Annotated[int, Field(ge=1, le=1000)] = 2  # acquisition-optimiser restarts per design
    raw_samples: Annotated[int, Field(ge=2, le=100_000)] = 64  # initial candidates the restarts start from
    mc_samples: Annotated[int, Field(ge=2, le=10_000)] = 32  # quasi-Monte Carlo posterior samples
    n_objectives: Annotated[int, Field(ge=1, le=11)] = 4  # nehvi: the reduced set's size (chosen from the DOE)
    seed: Seed = 0


class TsParegoParams(_Strict):
    """Batch Thompson-sampling ParEGO on pathwise GP samples (``optimise.tsparego``; hevlib/optimise/tsparego.py),
    the large-budget source: rounds of ``batch`` designs from the DOE until the run's budget. Run by the benchmark
    (benchmarks/surrogate/dvc.yaml, at ``benchmark.budget``); not yet a source of the default pipeline."""

    batch: Annotated[int, Field(ge=1, le=10_000)] = 100  # designs per round (one pathwise sample each)
    pool: Annotated[int, Field(ge=1, le=1_000_000)] = 4000  # admissible Latin-hypercube candidates per round
    local_pool: Annotated[int, Field(ge=0, le=1_000_000)] = 2000  # candidates around the front, in the trust region
    subset: Annotated[int, Field(ge=2, le=100_000)] = 300  # designs the hyperparameters are fitted on
    refit_every: Annotated[int, Field(ge=1, le=1000)] = 4  # rounds between fits (warm-started)
    n_features: Annotated[int, Field(ge=16, le=100_000)] = 1024  # random Fourier features of each prior path
    tr_init: Annotated[float, Field(gt=0, le=1)] = 0.2  # trust region's edge, share of each variable's range
    tr_min: Annotated[float, Field(gt=0, le=1)] = 0.02
    tr_max: Annotated[float, Field(gt=0, le=1)] = 0.8

    @model_validator(mode="after")
    def _trust_region(self):
        if not self.tr_min <= self.tr_init <= self.tr_max:
            raise ValueError(f"tr_init: must lie in [tr_min, tr_max] = [{self.tr_min}, {self.tr_max}]")
        return self


class JudgeParams(_Strict):
    """The judged scale (``hev judge``): a Latin hypercube of admissible designs (exact rules met, integers
    and gear sets repaired) simulated once; its screen-passing designs' ideal and nadir normalise every
    hypervolume and IGD+ figure. No search produces or sees it."""

    n: Annotated[int, Field(ge=10, le=10_000_000)] = 10_000
    seed: Seed = 38


class OptimiseParams(_Strict):
    hv_samples: Annotated[int, Field(ge=100, le=100_000_000)] = 1_000_000  # Monte Carlo fallback's samples
    # exact hypervolume up to this many non-dominated designs (measured cost: hevlib.indicators.hypervolume)
    hv_exact_max_points: Annotated[int, Field(ge=0, le=10_000)] = 50
    hv_seed: Seed = 7
    hv_reference: Annotated[float, Field(gt=0, le=10)] = 1.1  # reference point, normalised units
    apply_screen_rules: bool = True  # the screen's rules (switched on there) as optimiser constraints
    algorithms: dict[Literal["nsga3", "moead", "moga"], AlgoParams]
    oracle: OracleParams = OracleParams()
    infill: InfillParams = InfillParams()
    judge: JudgeParams = JudgeParams()
    bayes: dict[Literal["parego", "nehvi"], BayesParams] = {}  # BoTorch sources (their own stage)
    tsparego: TsParegoParams = TsParegoParams()  # the large-budget source (the benchmark's, not yet a default one)
    sources: list[Literal["nsga3", "moead", "moga", "parego", "nehvi", "oracle"]] = ["nsga3", "moead", "moga", "oracle"]

    @model_validator(mode="after")
    def _sources_configured(self):
        for name in self.sources:
            if name != "oracle" and name not in self.algorithms and name not in self.bayes:
                raise ValueError(f"sources: {name} is not in optimise.algorithms or optimise.bayes")
        for name, b in self.bayes.items():
            if b.acquisition != name:
                raise ValueError(f"bayes.{name}.acquisition: must be {name}, got {b.acquisition}")
        if len(set(self.sources)) != len(self.sources) or not self.sources:
            raise ValueError("sources: must name at least one source, each once")
        return self


# --------------------------------------------------------------------------------------- benchmark
# a new source goes at the end: a run's seed depends on its source's position (hevlib.benchmark.runs.run_seed)
BENCHMARK_SOURCES = (
    "nsga3", "moead", "moga", "parego", "nsga3_direct", "moead_direct", "lhs", "oracle", "nehvi", "tsparego",
)  # fmt: skip


class DirectParams(_Strict):
    """A search run directly on the simulator at a small population (the benchmark's direct searches)."""

    pop_size: Annotated[int, Field(ge=4, le=100_000)]
    n_neighbors: Annotated[int, Field(ge=2, le=1000)] = 10  # moead only


class BenchmarkParams(_Strict):
    """The equal-budget, many-seed benchmark of every source (benchmarks/surrogate/dvc.yaml; not in the
    default pipeline). Every simulation counts, the DOE's included; the judged normalisation is the judged
    scale's (``hev judge``'s reference set, which no source produced) and is never given to a search."""

    sources: list[Literal[BENCHMARK_SOURCES]] = list(BENCHMARK_SOURCES)  # type: ignore[valid-type]
    seeds: Annotated[int, Field(ge=1, le=1000)] = 7  # runs per source (the oracle: oracle_seeds)
    oracle_seeds: Annotated[int, Field(ge=1, le=1000)] = 3
    seed: Seed = 2026  # root of every run's seed
    budget: Annotated[int, Field(ge=10, le=10_000_000)] = 2000  # simulations per SAEA and LHS run
    direct_budget: Annotated[int, Field(ge=10, le=10_000_000)] = 5000  # per direct-search run
    budgets: Annotated[list[Annotated[int, Field(ge=1)]], Field(min_length=1)] = [250, 500, 1000, 2000, 5000]
    nsga3_direct: DirectParams = DirectParams(pop_size=77)
    moead_direct: DirectParams = DirectParams(pop_size=50)
    hv_samples: Annotated[int, Field(ge=1000, le=100_000_000)] = 2_000_000  # common Monte Carlo samples
    hv_seed: Seed = 5
    alpha: Annotated[float, Field(gt=0, lt=1)] = 0.05  # Holm-corrected significance level
    a12_large: Annotated[float, Field(gt=0.5, lt=1)] = 0.71  # Vargha-Delaney's "large" effect


# -------------------------------------------------------------------------------------- robustness
class RobustnessParams(_Strict):
    """How stable the answer is across seeds (``hev robustness``, benchmarks/robustness/dvc.yaml; not in the
    default pipeline): the optimise -> pareto -> validate chain rerun with other seeds of every source."""

    seeds: Annotated[int, Field(ge=2, le=1000)] = 6  # replicates; replicate 0 keeps the params' own seeds
    seed: Seed = 3636  # root of the other replicates' seeds (numpy SeedSequence([seed, source, replicate]))


# ------------------------------------------------------------------------------------------ screen
class ScreenParams(_Strict):
    """Screening of the merged non-dominated designs, ranking, and the pick for validation (SPEC 9)."""

    gen_below_motor: bool = True  # rule p_gen_kw < p_mot_kw (reported even when off)
    speed_dev_max: Frac = 0.4  # rule sim_speed_dev (share of the cycle off the trace) <= this
    mass_max_kg: Pos = 1195.0  # rule sim_m_veh <= this
    buildable_gear_set: bool = True  # rule hevlib.design.gear_set_buildable (reported even when off)
    n_keep: Annotated[int, Field(ge=1, le=1_000_000)] = 78
    n_pick: Annotated[int, Field(ge=1, le=1_000_000)] = 15
    min_v_max_kmh: Annotated[float, Field(gt=0, le=400)] | None = None  # rule sim_v_max >= this; null: off
    pick: Literal["recommend", "random", "diverse"] = "recommend"
    seed: Seed = 2024

    @model_validator(mode="after")
    def _pick_within_keep(self):
        if self.n_pick > self.n_keep:
            raise ValueError(f"n_pick: {self.n_pick} must not exceed n_keep ({self.n_keep})")
        return self


# ---------------------------------------------------------------------------------------- validate
class EquivalenceParams(_Strict):
    """The recommendation's near-equivalents (hevlib/recommend.py): the model's noise at each eligible design,
    from twins whose continuous variables differ by at most ``share`` of their ranges, and the knee drawn among
    them ``draws`` times; designs that are the knee in at least ``min_share`` of the draws are equivalents."""

    twins: Annotated[int, Field(ge=1, le=1000)] = 8
    share: Annotated[float, Field(gt=0, le=0.05)] = 0.02
    draws: Annotated[int, Field(ge=10, le=1_000_000)] = 2000
    min_share: Annotated[float, Field(gt=0, le=0.5)] = 0.05
    seed: Seed = 36


class ValidateParams(_Strict):
    """Cycles the picked designs and both baselines are simulated on; the first is the headline cycle."""

    cycles: list[Annotated[str, Field(pattern=r"^[A-Za-z0-9_]+$")]] = ["ftp", "hwfet", "us06"]
    equivalence: EquivalenceParams = EquivalenceParams()

    @model_validator(mode="after")
    def _cycles(self):
        if not self.cycles:
            raise ValueError("cycles: needs at least one cycle")
        if len(set(self.cycles)) != len(self.cycles):
            raise ValueError("cycles: a cycle is listed twice")
        return self


class EpaParams(_Strict):
    """``hev car`` and the fleet validation (``benchmarks/fleet``): the parts of today a car of EPA's 2022 test car
    list gets, by kind, in ``baseline.components_dir``: its engine file (``hev engine-map``: a map of today's
    engines) and a power split's wheel file (``hev wheel-regen``: braking blended as today's power splits blend it);
    the study's own cars keep ``baseline``'s."""

    engine_conventional: ComponentFile
    engine_power_split: ComponentFile
    wheel_power_split: ComponentFile


class BoundParams(_Strict):
    """``hev bound``: the charge-sustaining fuel bound by dynamic programming over the battery's SOC
    (:mod:`hevlib.bound`) for the picks and the stock Prius, against the rule base. Its resolution: the SOC grid's
    step and the engine-on candidates per step (a grid of speeds across the engine's window, of torques up to
    what the engine and the generator take); the cycles it is computed on (cycles the picks drive: a bound needs a
    trace that the design meets); and the ECMS controller run beside it on the same candidates
    (:func:`hevlib.bound.ecms_fuel`): its equivalence factor's SOC feedback, per unit of SOC below the control
    file's target."""

    soc_step: Annotated[float, Field(gt=0.0, le=0.01)] = 0.0005
    n_speed: Annotated[int, Field(ge=2, le=200)] = 24
    n_torque: Annotated[int, Field(ge=2, le=200)] = 24
    cycles: list[Annotated[str, Field(pattern=r"^[A-Za-z0-9_]+$")]] = ["ftp", "hwfet"]

    @model_validator(mode="after")
    def _cycles(self):
        if not self.cycles:
            raise ValueError("cycles: needs at least one cycle")
        if len(set(self.cycles)) != len(self.cycles):
            raise ValueError("cycles: a cycle is listed twice")
        return self


class Params(_Strict):
    cycles: CyclesParams
    baseline: BaselineParams
    sim: SimParams = SimParams()
    pms: PmsParams = PmsParams()
    design_space: DesignSpaceParams = DesignSpaceParams()
    doe: DoeParams = DoeParams()
    surrogate: SurrogateParams = SurrogateParams()
    optimise: OptimiseParams | None = None
    screen: ScreenParams = ScreenParams()
    validation: ValidateParams = Field(ValidateParams(), alias="validate")
    benchmark: BenchmarkParams = BenchmarkParams()
    robustness: RobustnessParams = RobustnessParams()
    epa: EpaParams | None = None
    bound: BoundParams = BoundParams()

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True, strict=True)

    @model_validator(mode="after")
    def _start_states_name_cycles(self):
        for name in self.sim.start:
            if name not in self.cycles.cycles:
                raise ValueError(f"sim.start.{name}: not one of cycles.cycles")
        for name in self.bound.cycles:
            if name not in self.cycles.cycles:
                raise ValueError(f"bound.cycles: {name!r} is not one of cycles.cycles")
        return self


def _format_error(err: ValidationError, source: str = "params.yaml") -> str:
    first = err.errors()[0]
    parts = [str(p) for p in first["loc"] if p not in ("function-after",)]
    msg = first["msg"]
    if parts and parts[-1] == "[key]":  # a mapping key failed its pattern (e.g. a cycle name)
        parts.pop()
        msg = f"invalid key name ({msg[0].lower()}{msg[1:]})"
    loc = ".".join(parts)
    if first["type"] == "extra_forbidden":
        msg = "unknown key"
    elif msg.startswith("Value error, "):
        msg = msg[len("Value error, ") :]
        head, sep, rest = msg.partition(": ")
        if sep and head.isidentifier():  # a model check naming its own field: fold into the key path
            loc, msg = (f"{loc}.{head}" if loc else head), rest
    n = len(err.errors())
    more = f" (and {n - 1} more error{'s' if n > 2 else ''})" if n > 1 else ""
    return f"{source}: {loc}: {msg}{more}" if loc else f"{source}: {msg}{more}"


def parse_params(data: dict, source: str = "params.yaml") -> Params:
    """Validate a params mapping; ``source`` names the file in error messages."""
    try:
        return Params.model_validate(data)
    except ValidationError as err:
        raise ParamsError(_format_error(err, source)) from None


def load_params(path: str | Path = "params.yaml") -> Params:
    """Read and validate the params file; raise ParamsError (one line naming the key) on any problem."""
    data = read_yaml_mapping(path, what="params file", error=ParamsError, missing_error=ParamsError)
    return parse_params(data, str(path))


__all__ = ["Params", "ParamsError", "load_params", "parse_params", "OBJECTIVES"]
