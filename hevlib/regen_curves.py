"""Regenerative braking of a power split of today: a published regeneration curve written into a wheel file.

ADVISOR's wheel files say how much of the car's braking the driveline is asked to take, against speed: the 1998
Prius's (``WH_PRIUS_JPN``) 0.5 from 10 mph up, with no reason given (docs/reference-cars.md), the small car's 0.8.
A power split of today blends its brakes: the motor takes the braking demand up to its own, the battery's and the
axle's limits and the friction brakes only the rest, fading out at walking pace where the motor cannot hold the
car. What is published of that is FASTSim's regeneration curve (NREL; :data:`CURVES`, each with its source): the
share of the braking power at the wheels the motor is asked to take,

``share(v) = max_regen / (1 + a exp(-b (v_mph + 1)))``,

with ``a`` and ``b`` FASTSim's defaults and ``max_regen`` its vehicle's. :func:`wheel_file` writes a wheel file of
the project's format whose ``braking.driveline_fraction`` is that curve, tabulated finely enough that the kernels'
linear reads follow it (:data:`SPEED_MPH`); the motor's torque limit, the battery's charge limit and the tyres'
adhesion still cap what the driveline takes (the drive step's rule), the friction brakes the rest. Everything else
(radius, inertia, rolling resistance, axle drag, tyre slip) is the source file's. Nothing here is fitted to any test.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hevlib.components.files import read_component_file
from hevlib.engine_curves import rounded

KMH_PER_MPH = 1.609344


@dataclass(frozen=True)
class RegenCurve:
    """FASTSim's share of the braking power taken by the motor against speed, with its source."""

    name: str
    max_regen: float
    a: float
    b: float
    source: str

    def __post_init__(self):
        if not (0.0 < self.max_regen <= 1.0 and self.a > 0.0 and self.b > 0.0):
            raise ValueError(f"curve {self.name}: max_regen must lie in (0, 1], a and b be positive")

    def share(self, speed_mph) -> np.ndarray:
        """Driveline share of the braking demand at ``speed_mph`` (0 at and below standstill)."""
        v = np.asarray(speed_mph, dtype=float)
        return np.where(v > 0.0, self.max_regen / (1.0 + self.a * np.exp(-self.b * (v + 1.0))), 0.0)


CURVES: dict[str, RegenCurve] = {
    "fastsim_prius_2016": RegenCurve(
        name="fastsim_prius_2016",
        max_regen=0.98,
        a=500.0,
        b=0.99,
        source=(
            "FASTSim 2.1.5 (NREL, PyPI fastsim==2.1.5): fastsim/simdrive.py, regen_contrl_lim_kw_perc = max_regen / "
            "(1 + regen_a exp(-regen_b (mph + 1))), the braking power the motor is asked to take (then capped by its "
            "and the battery's limits); regen_a 500, regen_b 0.99 (fastsim/parameters.py); max_regen 0.98 of "
            "fastsim/resources/FASTSim_py_veh_db.csv, vehicle 36 '2016 Toyota Prius Two FWD'"
        ),
    ),
}

#: Speeds the curve is tabulated at, mph: every 0.5 mph through its rise (the linear reads stay within 0.006 of
#: the curve), then on to where it is flat; -1 pads the table below standstill as ADVISOR's files do.
SPEED_MPH = (-1.0, *np.arange(0.0, 20.0 + 1e-9, 0.5).tolist(), 30.0, 60.0, 1000.0)


def blended_wheel(source_path: str | Path, curve: RegenCurve) -> dict:
    """The wheel file (a mapping in the project's component format) of ``source_path`` with ``curve`` as its
    driveline share of braking; the front friction brakes take the source's share or what the driveline leaves,
    whichever is less."""
    source_path = Path(source_path)
    d = read_component_file(source_path)
    braking = d["braking"]
    mph = np.asarray(SPEED_MPH, dtype=float)
    share = curve.share(mph)
    front_src = np.interp(mph, braking["vehicle_speed_mph"], braking["front_friction_fraction"])
    name = f"{source_path.stem}_{curve.name.upper()}_REGEN"
    out = {k: copy.deepcopy(v) for k, v in d.items() if k != "notes"}
    out |= {
        "source": f"derived file {name}",
        "description": f"{d.get('description', source_path.stem)}; braking blended as a power split of today's",
        "extraction": (
            f"written by `hev wheel-regen --source {source_path.name} --curve {curve.name}` "
            f"(hevlib/regen_curves.py): driveline_fraction = {curve.max_regen:g} / (1 + {curve.a:g} exp(-{curve.b:g} "
            f"(mph + 1))); source file: {source_path.name} ({d.get('source', '')}); curve: {curve.source}"
        ),
    }
    out["braking"] = {
        **{k: copy.deepcopy(v) for k, v in braking.items() if k not in _TABLE},
        "vehicle_speed_mph": rounded(mph),
        "vehicle_speed_km_per_h": rounded(mph * KMH_PER_MPH),
        "driveline_fraction": rounded(share),
        "front_friction_fraction": rounded(np.minimum(front_src, 1.0 - share)),
        "note": (
            "share of the braking demand the driveline is asked to take (the motor, up to its torque, the "
            "battery's charge and the tyres' adhesion limits; the friction brakes take the rest) and the front "
            "friction brakes' share, vs vehicle speed; the rest goes to the rear friction brakes"
        ),
    }
    out["notes"] = [
        f"Derived from {source_path.name}; only the braking table is new; nothing in it is fitted to a test.",
        f"The share reaches {curve.share(10.0):.3f} at 10 mph and {curve.share(20.0):.3f} at 20 mph (the "
        f"source's: {np.interp(10.0, braking['vehicle_speed_mph'], braking['driveline_fraction']):g}).",
    ]
    return out


#: The braking table's rows, written anew.
_TABLE = ("vehicle_speed_mph", "vehicle_speed_km_per_h", "driveline_fraction", "front_friction_fraction", "note")


def wheel_file(source_path: str | Path, curve_name: str) -> dict:
    """:func:`blended_wheel` by curve name (KeyError listing the curves if unknown)."""
    if curve_name not in CURVES:
        raise KeyError(f"curve {curve_name!r}: one of {', '.join(CURVES)}")
    return blended_wheel(source_path, CURVES[curve_name])


def tabulation_error(curve: RegenCurve) -> float:
    """Largest gap between the tabulated share, read linearly, and the curve, on a 0.01 mph grid to 100 mph."""
    mph = np.arange(0.0, 100.0, 0.01)
    table = np.asarray(SPEED_MPH, dtype=float)
    return float(np.max(np.abs(np.interp(mph, table, curve.share(table)) - curve.share(mph))))
