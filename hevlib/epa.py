"""A car from its certification data (issue 52): one car of the EPA's test car list as the project's car.

The list (``data/raw/epa/test_car_list_2022.csv``, model year 2022; provenance in its README) has one row per
dynamometer test. :func:`read_test_car_list` reads it with explicit dtypes (``utf-8-sig``: the file starts with a
byte-order mark); :func:`find_car` picks one car by make and model (case-insensitive, whole names) and, where the
model has several, by ``Test Vehicle ID`` and ``Test Veh Configuration #``; :func:`car_profile` turns it into
``dvc exp run -S`` overrides (a params profile, ``hev car``).

**Which rows describe the car.** The tests of the car as driven on the road: categories FTP, HWY, US06 and SC03
(not ``CD``, a plug-in's charge-depleting tests) on any fuel but the cold-CO tests' (20 degF: their road load is
the cold one). Their car values (test weight, road load, engine, driveline) must agree; where the tests of one
configuration disagree (13 of the list's 1 272 configurations), the FTP tests' values are the car's, and where
even those disagree (7), ``line`` (``hev car --line``) picks one test. A model with several configurations is
ambiguous until ``--vehicle-id``/``--config`` pick one.

**Powertrain** (:func:`classify`), from the row's own columns, first rule that applies:

1. electric (no engine): displacement below 0.1 L (the list writes 0.001 or 0.010 for most electric cars) or
   every test of the vehicle on electricity or hydrogen;
2. plug-in hybrid: a charge-depleting (``CD``) test of the same make and model (any test vehicle: a plug-in's
   charge-sustaining vehicles have none of their own);
3. power-split hybrid: Toyota or Lexus with a ``Test Vehicle ID`` ending in ``H`` (Toyota's hybrid vehicles: every
   Prius, ``... HYBRID``, Lexus ``...h``, Sienna and Venza, and no other) and a continuously variable
   transmission (``CVT``/``SCV``: the hybrid system's planetary e-CVT; the Tundra hybrid's 10-speed automatic is a
   parallel hybrid); Ford with a ``CVT`` (Ford's only CVT in the list is its FHEV/PHEV e-CVT: Escape FHEV and the
   Maverick hybrid, listed once as plain "Maverick" with its 2.5 L, 162 hp engine);
4. other hybrid: a model name with a hybrid word (``HYBRID``, ``HEV``, ``PHEV``, ``FHEV``, ``MHEV``, ``PLUG-IN``,
   ``E-HYBRID``, ``4XE``, ``RECHARGE``, ``T8``) or a hybrid-only model (``PRIUS``, ``INSIGHT``, ``IONIQ``, ``NIRO``,
   ``NSX``), or a Toyota/Lexus ``...H`` vehicle without a CVT;
5. diesel: a diesel test fuel (the project's engine map is spark-ignition);
6. conventional: everything else (a gasoline engine and a gearbox).

**Conversion** (:func:`car_profile`):

- test mass: ``Equivalent Test Weight (lbs.)`` x 0.45359237 kg/lb (the dynamometer's inertia: curb mass + 300 lb
  in weight classes, the test mass of the study's convention);
- road load: the coast-down ``Target Coef A/B/C`` as the body's ``coast_down`` (params: lbf and mph, SI inside;
  it replaces Cd, frontal area, the tyres' rolling resistance and the axle drag: docs/model.md); the ``Set Coef``
  columns are the dynamometer's own setting, not the car's road load;
- engine power: ``Rated Horsepower`` x 0.745699872 kW/hp (mechanical horsepower, 550 ft lbf/s);
- wheel radius and gears (the list has no tyre size and gives only the top gear's ``N/V Ratio``, engine rpm per
  mph, and the ``Axle Ratio``): ``N/V = i_top x 60 / (2 pi r) x 0.44704``, so ``i_top / r = N/V / K`` with
  ``K = 0.44704 x 60 / (2 pi) = 4.26892`` (m/s per mph x rpm per rad/s). A gearbox known only by its type and gear
  count takes the ratios of a typical box of that count (table below); with its top ratio, the axle ratio and
  N/V the rolling radius is ``r = K x i_box_top x i_axle / N/V``. Where that radius falls outside the radii of
  passenger-car and light-truck tyres (0.29 m, 175/65 R14, to 0.43 m, 275/65 R20; radius = rim / 2 + aspect x
  width) or the box is a CVT (whose variator's overdrive ratio no source gives in general), the radius is a
  typical tyre's instead: 0.316 m (205/55 R16: 203.2 + 112.75 mm) for a ``Car``, 0.369 m (235/65 R17) for a truck.
  The top overall ratio is then ``N/V x r / K`` (exact: the engine turns at N/V in top gear whatever the radius), and
  every overall ratio is the typical box's times ``top overall / box top`` (its spread and steps kept; with the
  derived radius that factor is the axle ratio). The wheel inertia follows the radius as in the wheel file
  (WH_SMCAR: the 181 lb wheel set as a solid cylinder, ``(181 / 2.205) r^2 / 2``).

Typical ratio sets (forward gears, first to top; automated manuals and dual-clutch boxes take the automatic set
of their gear count):

============  ============================================================  ==========================================
box           ratios                                                        source
============  ============================================================  ==========================================
4-speed auto  2.921 1.568 1.000 0.705 (spread 4.14)                         GM 4T60-E/4T65-E (Wikipedia, "GM 4T60-E
                                                                            transmission")
5-speed auto  3.932 2.408 1.486 1.000 0.830 (4.74)                          Mercedes-Benz 722.6 W5A 330 (Wikipedia,
                                                                            "Mercedes-Benz 5G-Tronic transmission")
6-speed auto  4.171 2.340 1.521 1.143 0.867 0.691 (6.04)                    ZF 6HP26 (Wikipedia, "ZF 6HP
                                                                            transmission")
7-speed auto  4.377 2.859 1.921 1.368 1.000 0.820 0.728 (6.01)              Mercedes-Benz 722.9 W7A (Wikipedia,
                                                                            "Mercedes-Benz 7G-Tronic transmission")
8-speed auto  4.714 3.143 2.106 1.667 1.285 1.000 0.839 0.667 (7.07)        ZF 8HP45/8HP70 (Wikipedia, "ZF 8HP
                                                                            transmission")
9-speed auto  4.700 2.842 1.909 1.382 1.000 0.808 0.699 0.580 0.479 (9.81)  ZF 9HP28/9HP48 (Wikipedia, "ZF 9HP
                                                                            transmission")
10-sp. auto   4.696 2.985 2.146 1.769 1.520 1.275 1.000 0.854 0.689 0.636   Ford 10R80 / GM 10L80 (Wikipedia,
              (7.38)                                                        "Ford-GM 10-speed automatic transmission")
5-speed man.  3.25 1.81 1.21 0.86 0.64 (5.08)                               ADVISOR TX_5SPD (Saturn 1.9 L; the
                                                                            study's gearbox, data/raw/components)
6-speed man.  2.66 1.78 1.30 1.00 0.74 0.50 (5.32)                          Tremec T-56 (GM 6-speed 85 mm, RPO MM6:
                                                                            1997 Corvette service manual)
CVT           spread 7.0 in 8 geometric steps                               JATCO CVT8 (JF016E/JF017E) "7.0 ratio
                                                                            coverage" (ATSG technical service
                                                                            information, 2017); JATCO CVT7: 7.3 (SAE
                                                                            Automotive Engineering, 23 Apr 2012);
                                                                            Toyota Direct Shift-CVT: 7.5 (Toyota, Feb
                                                                            2018)
============  ============================================================  ==========================================

A CVT is simulated as its ratio range in :data:`CVT_STEPS` geometric steps from ``spread x top`` to the top overall
ratio, shifted by the load-based logic like any gearbox (the simulator's gearbox is stepped). The speed table
(``upshift_kmh``, read only with ``shift_logic: speed``) upshifts where the engine turns :data:`UPSHIFT_RPM` in the
lower gear (about the study's PTC_CONV table's: 2 460-2 980 rpm). Manual boxes of other gear counts, 1-speed
boxes and the like are refused with one line. A power-split hybrid's row gives the stock Prius's overrides
(``baseline.prius``): its test mass and road load, and its gearing: ``i0``, the reduction from the planetary's
ring to the wheels, is the row's ``Axle Ratio`` (an e-CVT's only fixed reduction between ring and wheels, its
counter and final gears together: 2.83 for the 2022 Prius; its predecessor's P410 transaxle has 3.267, Toyota's
repair manual), and the tyre is a typical one of the vehicle type (:data:`TYPICAL_RADIUS_M`, as for a CVT car: no
ratio turns N/V into a radius; the 2022 Prius's 195/65 R15 is 0.317 m), its wheel set's inertia at that radius.
The 2001 Prius's own 3.93 on its 0.287 m tyre turn the ring 1.5 times as fast at a given road speed, so a scaled
kit drives its generator backwards at highway speed (power circulation) where the real car need not. The list has
no motor, generator or battery sizes, so the Prius's kit stays (its motor on the ring, where today's transaxles
gear it: the 2022 Prius's by 3.118, Toyota at JSAE 2016); every other kind but a conventional car is refused.
"""

from __future__ import annotations

import math
import re
import textwrap
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from hevlib.io import read_yaml_mapping
from hevlib.params import MPS_PER_MPH, BaselineParams, EpaParams, ParamsError, parse_params
from hevlib.profiles import apply_overrides

#: The project's copy of the list (never the shared folder at run time).
TEST_CAR_LIST = Path("data/raw/epa/test_car_list_2022.csv")
#: sha256 of the shipped list (fastsim 2.1.5's ``22-tstcar.csv``), checked by the tests.
TEST_CAR_LIST_SHA256 = "fc5d0178be26eed9c1eac3598018b5808ca14ca1b22daef00106b43f3bcde65b"

KG_PER_LB = 0.45359237  # avoirdupois pound, exact
KW_PER_HP = 0.745699872  # mechanical horsepower (550 ft lbf/s), exact
#: N/V (rpm per mph) = i_top / r x this (m/s per mph x rpm per rad/s = 4.26892)
K_NV = MPS_PER_MPH * 60.0 / (2.0 * math.pi)

MAKE, MODEL = "Represented Test Veh Make", "Represented Test Veh Model"
VEHICLE_ID, CONFIG = "Test Vehicle ID", "Test Veh Configuration #"
CATEGORY, FUEL = "Test Category", "Test Fuel Type Description"
ETW, HP, DISPLACEMENT = "Equivalent Test Weight (lbs.)", "Rated Horsepower", "Test Veh Displacement (L)"
TRANS_CODE, TRANS, GEARS = "Tested Transmission Type Code", "Tested Transmission Type", "# of Gears"
AXLE, NV, DRIVE, VEHICLE_TYPE = "Axle Ratio", "N/V Ratio", "Drive System Description", "Vehicle Type"
COEF_A, COEF_B, COEF_C = "Target Coef A (lbf)", "Target Coef B (lbf/mph)", "Target Coef C (lbf/mph**2)"

#: Every column read, with its dtype (the rest of the file is not read).
COLUMNS: dict[str, str] = {
    MAKE: "str",
    MODEL: "str",
    VEHICLE_ID: "str",
    CONFIG: "int64",
    DISPLACEMENT: "float64",
    VEHICLE_TYPE: "str",
    HP: "float64",
    TRANS_CODE: "str",
    TRANS: "str",
    GEARS: "int64",
    DRIVE: "str",
    ETW: "float64",
    AXLE: "float64",
    NV: "float64",
    "Test Procedure Description": "str",
    FUEL: "str",
    CATEGORY: "str",
    COEF_A: "float64",
    COEF_B: "float64",
    COEF_C: "float64",
}
#: The values that make a car (the tests of one car agree on them).
CAR_VALUES = (ETW, COEF_A, COEF_B, COEF_C, HP, DISPLACEMENT, TRANS_CODE, TRANS, GEARS, AXLE, NV, DRIVE, VEHICLE_TYPE)
#: Test categories of the car on the road (``CD``: a plug-in's charge-depleting tests), first preferred.
ROAD_TESTS = ("FTP", "HWY", "US06", "SC03")

#: Powertrain kinds (:func:`classify`).
CONVENTIONAL, POWER_SPLIT = "conventional", "power-split hybrid"
HYBRID_WORDS = ("HYBRID", "HEV", "PHEV", "FHEV", "MHEV", "PLUG-IN", "E-HYBRID", "4XE", "RECHARGE", "T8")
HYBRID_MODELS = ("PRIUS", "INSIGHT", "IONIQ", "NIRO", "NSX")

#: Typical forward ratios by box and gear count (module docstring: sources).
AUTOMATIC_RATIOS: dict[int, tuple[float, ...]] = {
    4: (2.921, 1.568, 1.000, 0.705),
    5: (3.932, 2.408, 1.486, 1.000, 0.830),
    6: (4.171, 2.340, 1.521, 1.143, 0.867, 0.691),
    7: (4.377, 2.859, 1.921, 1.368, 1.000, 0.820, 0.728),
    8: (4.714, 3.143, 2.106, 1.667, 1.285, 1.000, 0.839, 0.667),
    9: (4.700, 2.842, 1.909, 1.382, 1.000, 0.808, 0.699, 0.580, 0.479),
    10: (4.696, 2.985, 2.146, 1.769, 1.520, 1.275, 1.000, 0.854, 0.689, 0.636),
}
MANUAL_RATIOS: dict[int, tuple[float, ...]] = {
    5: (3.25, 1.81, 1.21, 0.86, 0.64),
    6: (2.66, 1.78, 1.30, 1.00, 0.74, 0.50),
}
RATIO_SOURCES: dict[tuple[str, int], str] = {
    ("automatic", 4): "GM 4T65-E",
    ("automatic", 5): "Mercedes-Benz 722.6",
    ("automatic", 6): "ZF 6HP26",
    ("automatic", 7): "Mercedes-Benz 722.9",
    ("automatic", 8): "ZF 8HP",
    ("automatic", 9): "ZF 9HP",
    ("automatic", 10): "Ford 10R80",
    ("manual", 5): "ADVISOR TX_5SPD",
    ("manual", 6): "Tremec T-56",
}
CVT_SPREAD = 7.0  #: a CVT's ratio spread (JATCO CVT8)
CVT_STEPS = 8  #: steps a CVT's range is simulated in
MANUAL_CODES, CVT_CODES = ("M",), ("CVT", "SCV")
AUTOMATIC_CODES = ("A", "SA", "AM", "AMS", "OT")
#: Rolling radii of passenger-car and light-truck tyres, m: 175/65 R14 to 275/65 R20.
TYRE_RADIUS_M = (0.29, 0.43)
#: A typical tyre's radius where the row's cannot be derived, m: 205/55 R16 (a car), 235/65 R17 (a truck).
TYPICAL_RADIUS_M = {"Car": 0.316, "Truck": 0.369}
#: ... and its size, as the profile's comment names it.
TYPICAL_TYRE = {"Car": "205/55 R16", "Truck": "235/65 R17"}
#: The wheel file's wheel set (WH_SMCAR: 181 lb as a solid cylinder of the rolling radius), kg.
WHEEL_SET_KG = 181.0 / 2.205
UPSHIFT_RPM = 2750.0  #: engine speed of the speed table's upshifts, rpm
#: The params key of a car's engine file, by kind (its file: params' ``epa.engine_<kind>``).
ENGINE_KEYS: dict[str, str] = {CONVENTIONAL: "baseline.conventional.engine", POWER_SPLIT: "baseline.hybrid.engine"}


class CarNotFound(ValueError):
    """No car of the list matches (one line, naming what does exist)."""


class AmbiguousCar(ValueError):
    """Several cars of the list match (one line listing them)."""


class UnsupportedCar(ValueError):
    """A car the project cannot simulate from the list (electric, plug-in, other hybrids, diesel, odd boxes)."""


def read_test_car_list(path: str | Path = TEST_CAR_LIST) -> pd.DataFrame:
    """The columns of the test car list the project reads (:data:`COLUMNS`), with their dtypes, and ``line``: each
    row's line in the file (1: the header)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file (the EPA test car list; see data/raw/epa/README.md)")
    try:
        df = pd.read_csv(path, encoding="utf-8-sig", usecols=list(COLUMNS), dtype=COLUMNS, keep_default_na=False)
    except ValueError as err:  # a missing column or a value of the wrong type
        raise ValueError(f"{path}: {str(err).splitlines()[0]}") from None
    df.insert(0, "line", np.arange(2, len(df) + 2))
    return df


def _a(kind: str) -> str:
    return ("an " if kind[0] in "aeiou" else "a ") + kind


def _same(text: str) -> str:
    return " ".join(str(text).split()).upper()


@dataclass(frozen=True)
class Car:
    """One car of the list: its identity, its values (:data:`CAR_VALUES`), its powertrain kind and the file lines
    of the tests that describe it."""

    make: str
    model: str
    vehicle_id: str
    config: int
    values: Mapping[str, object]
    kind: str
    lines: tuple[int, ...]

    @property
    def name(self) -> str:
        return f"{self.make} {self.model}, test vehicle {self.vehicle_id}, configuration {self.config}"

    def value(self, column: str):
        return self.values[column]


def _label(group: pd.DataFrame) -> str:
    r = group.iloc[0]
    return f"{r[VEHICLE_ID]}/{r[CONFIG]} ({r[ETW]:.0f} lb, {r[TRANS_CODE]}{r[GEARS]})"


def _shorten(items: list[str], most: int = 8) -> str:
    shown = ", ".join(items[:most])
    return shown + (f" and {len(items) - most} more" if len(items) > most else "")


def find_car(
    table: pd.DataFrame,
    make: str,
    model: str,
    *,
    config: int | None = None,
    vehicle_id: str | None = None,
    line: int | None = None,
    source: str | Path = TEST_CAR_LIST,
) -> Car:
    """The one car of ``table`` (:func:`read_test_car_list`) with this make and model (whole names, any case) and,
    where given, test vehicle ID, configuration number and the file line of one of its tests (for a configuration
    whose tests disagree). Raises :class:`CarNotFound` or :class:`AmbiguousCar` with one line naming what the list
    has instead, :class:`UnsupportedCar` for a model with no road test."""
    makes = table[MAKE].map(_same)
    of_make = table[makes == _same(make)]
    if of_make.empty:
        raise CarNotFound(f"{source}: no make {make!r} in the list")
    rows = of_make[of_make[MODEL].map(_same) == _same(model)]
    if rows.empty:
        models = sorted(set(of_make[MODEL].map(_same)))
        raise CarNotFound(f"{source}: no model {model!r} of {make} (its models: {_shorten(models, 12)})")
    whole = rows
    want = []
    if vehicle_id is not None:
        rows = rows[rows[VEHICLE_ID].map(_same) == _same(vehicle_id)]
        want.append(f"test vehicle {vehicle_id}")
    if config is not None:
        rows = rows[rows[CONFIG] == config]
        want.append(f"configuration {config}")
    if line is not None:
        rows = rows[rows["line"] == line]
        want.append(f"a test on line {line}")
    if rows.empty:
        has = [f"{i}/{c}" for i, c in whole[[VEHICLE_ID, CONFIG]].drop_duplicates().itertuples(index=False)]
        raise CarNotFound(
            f"{source}: no {make} {model} with {' and '.join(want)} (test vehicle/configuration: {_shorten(has)})"
        )
    road = rows[rows[CATEGORY].isin(ROAD_TESTS) & ~rows[FUEL].str.upper().str.startswith("COLD CO")]
    if road.empty:  # charge-depleting tests only: an electric car or a plug-in
        kind = classify(rows.iloc[0], whole)
        raise UnsupportedCar(f"{source}: {make} {model}: {_a(kind)} with no road test (FTP, HWY, US06, SC03)")
    cars = []
    for (vid, cfg), group in road.groupby([VEHICLE_ID, CONFIG], sort=True):
        first = min(ROAD_TESTS, key=lambda c: (c not in set(group[CATEGORY]), ROAD_TESTS.index(c)))
        tests = group[group[CATEGORY] == first]
        for _, same in tests.groupby(list(CAR_VALUES), sort=False, dropna=False):
            cars.append((vid, int(cfg), same))
    if len({(v, c) for v, c, _ in cars}) > 1:
        labels = [_label(g) for _, _, g in cars]
        raise AmbiguousCar(
            f"{source}: {len(cars)} cars are {make} {model} (give --vehicle-id and --config): {_shorten(labels)}"
        )
    if len(cars) > 1:
        lines = [", ".join(str(x) for x in g["line"]) for _, _, g in cars]
        raise AmbiguousCar(
            f"{source}: the {ROAD_TESTS[0]} tests of {make} {model} {cars[0][0]}/{cars[0][1]} disagree on its values "
            f"(give --line, one of: {'; '.join(lines)})"
        )
    vid, cfg, group = cars[0]
    first = group.iloc[0]
    return Car(
        make=str(first[MAKE]),
        model=str(first[MODEL]),
        vehicle_id=str(vid),
        config=cfg,
        values={k: (v.item() if isinstance(v, np.generic) else v) for k, v in first[list(CAR_VALUES)].items()},
        kind=classify(first, whole),
        lines=tuple(int(x) for x in group["line"]),
    )


def classify(row: Mapping, model_rows: pd.DataFrame) -> str:
    """The powertrain of a car (module docstring, rules 1-6) from its row and every row of its model (same make and
    model, every test vehicle): :data:`CONVENTIONAL`, :data:`POWER_SPLIT`, or what else it is."""
    make, model, vid = _same(row[MAKE]), _same(row[MODEL]), _same(row[VEHICLE_ID])
    vehicle = model_rows[model_rows[VEHICLE_ID] == row[VEHICLE_ID]]
    fuels = " ".join(vehicle[FUEL].str.upper())
    if float(row[DISPLACEMENT]) < 0.1 or vehicle[FUEL].str.upper().isin(("ELECTRICITY", "HYDROGEN 5")).all():
        return "electric car"
    if (model_rows[CATEGORY] == "CD").any():
        return "plug-in hybrid"
    cvt = str(row[TRANS_CODE]) in CVT_CODES
    if make in ("TOYOTA", "LEXUS") and vid.endswith("H") and cvt:
        return POWER_SPLIT
    if make == "FORD" and cvt:
        return POWER_SPLIT
    words = set(re.split(r"[\s/()]+", model))
    if words & set(HYBRID_WORDS) or words & set(HYBRID_MODELS) or (make in ("TOYOTA", "LEXUS") and vid.endswith("H")):
        return "hybrid that is not a power split"
    if "DIESEL" in fuels and "GASOLINE" not in fuels:
        return "diesel"
    return CONVENTIONAL


@dataclass(frozen=True)
class Driveline:
    """A car's wheel radius and overall gear ratios from its row (module docstring), with how they were found."""

    box: str  #: automatic, manual or cvt
    box_ratios: tuple[float, ...]  #: the typical box's ratios (a CVT: its range's steps, top 1)
    source: str
    radius_m: float
    radius_derived: bool  #: from N/V, axle ratio and the box's top ratio (else a typical tyre's); to the mm
    radius_from_box_m: float  #: what N/V, axle ratio and the box's top ratio give (NaN for a CVT)
    top_overall: float
    ratios: tuple[float, ...]  #: overall ratios, first to top

    @property
    def wheel_inertia_kg_m2(self) -> float:
        return wheel_set_inertia_kg_m2(self.radius_m)


def wheel_set_inertia_kg_m2(radius_m: float) -> float:
    """The wheel file's wheel set (:data:`WHEEL_SET_KG`) as a solid cylinder of rolling radius ``radius_m``."""
    return WHEEL_SET_KG * radius_m**2 / 2.0


def _typical(car: Car) -> str:
    """The key of :data:`TYPICAL_RADIUS_M` and :data:`TYPICAL_TYRE` for the car's vehicle type."""
    return "Car" if car.value(VEHICLE_TYPE) == "Car" else "Truck"


def typical_radius_m(car: Car) -> float:
    """A typical tyre's rolling radius for the car's vehicle type (:data:`TYPICAL_RADIUS_M`), m."""
    return TYPICAL_RADIUS_M[_typical(car)]


def upshift_kmh(radius_m: float, ratios) -> list[float]:
    """Vehicle speeds (km/h, to 0.1) at which the engine turns :data:`UPSHIFT_RPM` in each gear but the top."""
    w = UPSHIFT_RPM * 2.0 * math.pi / 60.0
    return [round(w * radius_m / i * 3.6, 1) for i in list(ratios)[:-1]]


def driveline(car: Car) -> Driveline:
    """The wheel radius and overall ratios of ``car`` (module docstring); :class:`UnsupportedCar` for a box no
    typical set describes."""
    code, gears = str(car.value(TRANS_CODE)), int(car.value(GEARS))
    nv, axle = float(car.value(NV)), float(car.value(AXLE))
    if not (nv > 0 and axle > 0):
        raise UnsupportedCar(f"{car.name}: N/V ratio {nv:g} and axle ratio {axle:g} must be positive")
    if code in CVT_CODES:
        box, source = "cvt", f"a CVT of spread {CVT_SPREAD:g} (JATCO CVT8)"
        ratios = tuple(CVT_SPREAD ** (1.0 - k / (CVT_STEPS - 1)) for k in range(CVT_STEPS))
    elif code in MANUAL_CODES or code in AUTOMATIC_CODES:
        box = "manual" if code in MANUAL_CODES else "automatic"
        table = MANUAL_RATIOS if box == "manual" else AUTOMATIC_RATIOS
        if gears not in table:
            known = ", ".join(str(g) for g in table)
            raise UnsupportedCar(
                f"{car.name}: no typical ratio set for a {gears}-speed {box} box ({car.value(TRANS)}; sets for "
                f"{known} gears)"
            )
        ratios, source = table[gears], RATIO_SOURCES[(box, gears)]
    else:
        raise UnsupportedCar(f"{car.name}: transmission {code!r} ({car.value(TRANS)}) is not one the list's rules know")
    from_box = K_NV * ratios[-1] * axle / nv if box != "cvt" else math.nan
    derived = TYRE_RADIUS_M[0] <= from_box <= TYRE_RADIUS_M[1]
    radius = round(from_box if derived else typical_radius_m(car), 3)  # to the millimetre, as the profile writes it
    top = nv * radius / K_NV
    overall = tuple(i / ratios[-1] * top for i in ratios)
    return Driveline(box, tuple(ratios), source, radius, derived, from_box, top, overall)


def _flow(value) -> str:
    """A value in YAML flow style (as profiles write them)."""
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{k}: {_flow(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_flow(v) for v in value) + "]"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def coast_down(car: Car) -> dict[str, float]:
    """The car's coast-down as params' ``body.coast_down`` (lbf and mph, as the list gives it)."""
    return {
        "a_lbf": float(car.value(COEF_A)),
        "b_lbf_per_mph": float(car.value(COEF_B)),
        "c_lbf_per_mph2": float(car.value(COEF_C)),
    }


def test_mass_kg(car: Car) -> float:
    """``Equivalent Test Weight (lbs.)`` in kg (to 0.1 kg)."""
    return round(float(car.value(ETW)) * KG_PER_LB, 1)


def engine_kw(car: Car) -> float:
    """``Rated Horsepower`` in kW (to 0.1 kW)."""
    return round(float(car.value(HP)) * KW_PER_HP, 1)


def car_profile(
    car: Car, baseline: BaselineParams, source: str | Path = TEST_CAR_LIST, parts: EpaParams | None = None
) -> list[tuple[str, str, object]]:
    """The profile of ``car``: (comment, dotted key, value) in order, for :func:`render_profile`. A conventional car
    gives ``baseline.conventional``, a power-split hybrid ``baseline.prius`` (test mass, road load, tyre and the
    ring-to-wheel ratio ``i0``: module doc); any other kind raises :class:`UnsupportedCar`. ``parts`` (params'
    ``epa``): the parts of today of the car's kind (its engine file; a power split's wheel file, its braking
    blended); without it the car keeps ``baseline``'s (the study's ADVISOR files). The body file and a conventional
    car's wheel file stay ``baseline``'s (params.yaml's: which file is which part is never the code's); the body's
    CG height, wheelbase and weight split are its file's."""
    cd, etw, hp = coast_down(car), float(car.value(ETW)), float(car.value(HP))
    lines = ("line " if len(car.lines) == 1 else "lines ") + ", ".join(str(x) for x in car.lines)
    road = (
        f"road load: the coast-down (Target Coef A/B/C, lbf and mph; {lines} of {source}), in place of Cd, "
        "frontal area, the tyres' rolling resistance and the axle drag"
    )
    mass = f"Equivalent Test Weight {etw:.0f} lb x 0.45359237 kg/lb"
    if car.kind == POWER_SPLIT:
        return [
            *_engine_entry(POWER_SPLIT, parts),
            (
                f"{road}; the Prius body file's CG height, wheelbase and weight split",
                "baseline.prius.body",
                {"file": baseline.prius.body.file, "coast_down": cd},
            ),
            (mass, "baseline.prius.test_mass_kg", test_mass_kg(car)),
            *_split_gearing(car, baseline, parts),
        ]
    if car.kind != CONVENTIONAL:
        raise UnsupportedCar(f"{car.name}: {_a(car.kind)}: only conventional cars and power-split hybrids convert")
    d = driveline(car)
    if d.radius_derived:
        why = (
            f"K x {d.box_ratios[-1]:g} (top of the {d.source}) x {car.value(AXLE):g} (Axle Ratio) / "
            f"{car.value(NV):g} (N/V), K = 4.26892"
        )
    else:
        reason = "a CVT" if d.box == "cvt" else f"N/V, axle and box give {d.radius_from_box_m:.3f} m, not a tyre's"
        tyre = TYPICAL_TYRE[_typical(car)]
        why = f"a typical {car.value(VEHICLE_TYPE)}'s tyre ({tyre}; {reason})"
    ratios = [round(x, 4) for x in d.ratios]
    top = f"the top overall ratio N/V {car.value(NV):g} rpm/mph x r / K = {d.top_overall:.4f}"
    if d.box == "cvt":
        gears = f"{car.value(TRANS)}: {d.source} in {CVT_STEPS} geometric steps down to {top}"
    else:
        scale = d.top_overall / d.box_ratios[-1]
        gears = (
            f"{car.value(TRANS)}, {car.value(GEARS)} gears: the {d.source}'s ratios x {scale:.4f} (its top ratio "
            f"{d.box_ratios[-1]:g} to {top})"
        )
    return [
        (
            f"{road}; the study's body file for CG height, wheelbase and weight split (not in the list)",
            "baseline.conventional.body",
            {"file": baseline.conventional.body.file, "coast_down": cd},
        ),
        (
            f"wheel radius {d.radius_m:.3f} m: {why}; inertia: the wheel file's 181 lb set at this radius",
            "baseline.conventional.wheel",
            {
                "file": baseline.conventional.wheel.file,
                "radius_m": d.radius_m,
                "inertia_kg_m2": round(d.wheel_inertia_kg_m2, 3),
            },
        ),
        *_engine_entry(CONVENTIONAL, parts),
        (
            f"Rated Horsepower {hp:g} hp x 0.745699872 kW/hp (the engine map scaled to it)",
            "baseline.conventional.p_eng_kw",
            engine_kw(car),
        ),
        (mass, "baseline.conventional.test_mass_kg", test_mass_kg(car)),
        (
            gears,
            "baseline.conventional.gear_ratios",
            ratios,
        ),
        (
            f"the speed table (shift_logic: speed only): upshift where the engine turns {UPSHIFT_RPM:.0f} rpm",
            "baseline.conventional.upshift_kmh",
            upshift_kmh(d.radius_m, ratios),
        ),
    ]


def _split_gearing(car: Car, baseline: BaselineParams, parts: EpaParams | None) -> list[tuple[str, str, object]]:
    """A power split's wheels (today's blended braking with ``parts``), tyre and ring-to-wheel ratio (module doc)."""
    axle, kind = float(car.value(AXLE)), car.value(VEHICLE_TYPE)
    if not axle > 0:
        raise UnsupportedCar(f"{car.name}: axle ratio {axle:g} must be positive")
    radius, tyre = typical_radius_m(car), TYPICAL_TYRE[_typical(car)]
    braking = (
        "braking blended as today's power splits do (params' epa.wheel_power_split, hev wheel-regen: the motor asked "
        "for the whole braking demand above walking pace, within its, the battery's and the tyres' limits); "
        if parts is not None
        else ""
    )
    return [
        (
            f"{braking}wheel radius {radius:.3f} m: a typical {kind}'s tyre ({tyre}; the e-CVT gives no radius from "
            "N/V); inertia: the wheel file's 181 lb set at this radius",
            "baseline.prius.wheel",
            {
                "file": baseline.prius.wheel.file if parts is None else parts.wheel_power_split,
                "radius_m": radius,
                "inertia_kg_m2": round(wheel_set_inertia_kg_m2(radius), 3),
            },
        ),
        (
            f"Axle Ratio {axle:g}: the reduction from the planetary's ring to the wheels (the e-CVT's counter and "
            "final gears; the 2001 Prius's is 3.93)",
            "baseline.prius.i0",
            axle,
        ),
    ]


def _engine_entry(kind: str, parts: EpaParams | None) -> list[tuple[str, str, object]]:
    """The profile entry of a 2022 car's engine file (params' ``epa``), none without one."""
    if parts is None:
        return []
    name = parts.engine_conventional if kind == CONVENTIONAL else parts.engine_power_split
    what = "an SI engine of today" if kind == CONVENTIONAL else "the Atkinson engine of a power split of today"
    return [
        (
            f"engine: {what} (params' epa.engine_*: a map re-levelled to a published efficiency curve, "
            "hev engine-map, docs/model.md); the study's own maps are ADVISOR's of the late 1990s",
            ENGINE_KEYS[kind],
            name,
        )
    ]


def profile_overrides(entries: list[tuple[str, str, object]]) -> dict:
    """The dotted-key overrides of :func:`car_profile`'s entries."""
    return {key: value for _, key, value in entries}


def check_profile(entries: list[tuple[str, str, object]], params_path: str | Path = "params.yaml") -> None:
    """Raise :class:`~hevlib.params.ParamsError` (one line naming the key) unless the profile's overrides of
    ``params_path`` validate (a value out of the schema's range: an engine above 300 kW, a test mass above 4 t)."""
    base = read_yaml_mapping(params_path, what="params file", error=ParamsError, missing_error=ParamsError)
    parse_params(apply_overrides(base, profile_overrides(entries)), f"{params_path} with the car's profile")


def render_profile(car: Car, entries: list[tuple[str, str, object]], name: str = "NAME") -> str:
    """The profile file's text: a header saying where the car comes from, then each key with its comment."""
    head = [
        f"# {car.name}: a {'conventional car' if car.kind == CONVENTIONAL else car.kind} of the EPA test",
        "# car list, model year 2022 (data/raw/epa/test_car_list_2022.csv; written by `hev car`, hevlib/epa.py).",
        "# Each dotted key is one `dvc exp run -S` override of params.yaml:",
        "#",
        f"#   dvc exp run $(hev profile {name})",
        "#",
        f"# driven axles on the test: {car.value(DRIVE)} (the simulator drives the front axle);",
        f"# {car.value(VEHICLE_TYPE).lower()}, {car.value(DISPLACEMENT):g} L, {car.value(HP):g} hp",
    ]
    if car.kind == POWER_SPLIT:
        note = (
            "a power-split hybrid: the stock Prius takes its test mass, road load, tyre and ring-to-wheel ratio "
            "(and, with params' epa, today's engine and brakes); its kit stays (the list rates "
            f"the engine at {engine_kw(car):g} kW and gives no motor, generator or battery)"
        )
    else:
        note = "keep screen.mass_max_kg at the car's test mass and widen design_space to its needs (docs/your-car.md)"
    head += _comment(note)
    body = []
    for comment, key, value in entries:
        body += _comment(comment)
        body.append(f"{key}: {_flow(value)}")
    return "\n".join(head + body) + "\n"


def _comment(text: str) -> list[str]:
    return textwrap.wrap(text, 113, initial_indent="# ", subsequent_indent="# ", break_on_hyphens=False)
