"""Properties the physics must have whatever the design: more mass or more grade never lowers the fuel a car
burns on a cycle, and the result converges as the time step shrinks.

Hybrids are compared on charge-balanced fuel, balanced far tighter than the pipeline's SAE J1711 1 % (so a
run's leftover battery energy cannot hide a trend), over 40 designs spread over the whole design space.
"""

from __future__ import annotations

import numpy as np
import pytest

from hevlib.cycles import Cycle, resample
from hevlib.doe import lhs_designs
from hevlib.sim.drive import R_MASS
from hevlib.sim.simulator import charge_balance, simulate
from hevlib.sim.vehicles import Vehicle

#: Net battery energy / fuel energy at which a run counts as balanced here (the pipeline: 1e-2; the stock Prius
#: on FTP at 1 % grade settles at 1.1e-3).
TIGHT_BALANCE = 2e-3
MAX_RUNS = 12


@pytest.fixture(scope="module")
def designs(params) -> np.ndarray:
    return lhs_designs(params.design_space.space(), 40, seed=5)


def balanced_fuel(vehicle: Vehicle, cycle: Cycle) -> np.ndarray:
    """Charge-balanced fuel (L/100 km) of every vehicle of the batch; NaN where it did not balance."""
    _, cb = charge_balance(vehicle, cycle, simulate(vehicle, cycle), tolerance=TIGHT_BALANCE, max_runs=MAX_RUNS)
    return cb["fc_charge_balanced"].to_numpy()


def heavier(vehicle: Vehicle, extra_kg: float) -> Vehicle:
    """The same vehicles carrying ``extra_kg`` more test mass (what a passenger or cargo adds)."""
    rows = vehicle.kernel.rows.copy()
    rows[:, R_MASS] += extra_kg
    return Vehicle(vehicle.kind, vehicle.design, vehicle.kernel._replace(rows=rows), vehicle.library)


def resampled(cycle: Cycle, dt_s: float) -> Cycle:
    """The cycle at a time step of ``dt_s``: speed and grade linear between its points (:func:`resample`), the key
    state held from the point before (the FTP's key-off soak stays where it is)."""
    t, speed_mps = resample(cycle.time_s, cycle.speed_mps, dt_s)
    key_on = cycle.key_on[np.searchsorted(cycle.time_s, t + 1e-9) - 1]
    return Cycle(cycle.name, t, speed_mps, np.interp(t, cycle.time_s, cycle.grade), key_on)


def _never_lower(fuel: np.ndarray, what: str) -> None:
    """Rows: increasing load; columns: vehicles. Each step up never lowers any vehicle's fuel."""
    ok = ~np.isnan(fuel).any(axis=0)
    assert ok.mean() >= 0.9, f"{what}: {np.count_nonzero(~ok)} vehicles did not balance"
    step = np.diff(fuel[:, ok], axis=0)
    worst = np.unravel_index(np.argmin(step), step.shape)
    assert (step >= 0.0).all(), f"{what}: load step {worst[0]} lowers vehicle {worst[1]}'s fuel by {-step[worst]:.4g}"


@pytest.mark.parametrize("cycle_name", ["ftp", "udds"])
def test_more_mass_never_lowers_fuel(sim, cycles, designs, cycle_name):
    cycle = cycles[cycle_name]
    extra_kg = (0.0, 50.0, 100.0, 200.0)
    for kind in ("hybrid", "prius", "conventional"):
        vehicle = sim.vehicle(designs if kind == "hybrid" else None, kind)
        fuel = np.array([balanced_fuel(heavier(vehicle, m), cycle) for m in extra_kg])
        _never_lower(fuel, f"{kind} on {cycle_name}, +{extra_kg} kg")
        # and the trend is not flat: 200 kg more costs every vehicle that follows the cycle fuel
        assert np.nanmedian(fuel[-1] / fuel[0]) > 1.02, kind


def test_more_grade_never_lowers_fuel(sim, cycles, designs):
    grades = (0.0, 0.005, 0.01, 0.02)
    for kind in ("hybrid", "prius", "conventional"):
        vehicle = sim.vehicle(designs if kind == "hybrid" else None, kind)
        fuel = np.array([balanced_fuel(vehicle, cycles["ftp"].with_grade(g)) for g in grades])
        _never_lower(fuel, f"{kind} on FTP at grades {grades}")
        assert np.nanmedian(fuel[-1] / fuel[0]) > 1.1, kind


def _step_changes(cycle: Cycle, vehicle: Vehicle) -> tuple[np.ndarray, np.ndarray]:
    """Relative fuel change from a 1 s to a 0.5 s step and from 0.5 s to 0.25 s."""
    f1, f2, f4 = (balanced_fuel(vehicle, resampled(cycle, dt)) for dt in (1.0, 0.5, 0.25))
    return (f2 - f1) / f1, (f4 - f2) / f2


@pytest.mark.parametrize("cycle_name", ["ftp", "udds"])
def test_conventional_car_converges_with_the_time_step(sim, cycles, cycle_name):
    first, second = _step_changes(cycles[cycle_name], sim.vehicle(None, "conventional"))
    # halving the step moves the fuel by at most 0.2 %, and the second halving no more than about the first
    assert abs(first[0]) < 2e-3 and abs(second[0]) < 2e-3, (first, second)


@pytest.mark.xfail(
    strict=True,
    reason=(
        "known defect (issue 52; docs/model.md, benchmarks/step_convergence.py): simulator v6 spreads a start's "
        "spin-up over its duration (FTP fuel of the fixed set within 2 % between 1 s and 0.1 s, median +0.3 %), but "
        "designs whose pack can barely crank and drive at once (11 modules, among these 8) still burn 5-6 % more on "
        "FTP at 0.5 s than at 1 s: their spin-up at the torque the pack can spare leaves the wheels short for longer"
    ),
)
def test_hybrid_converges_with_the_time_step(sim, cycles, designs):
    vehicle = sim.vehicle(designs[:8])
    first, second = _step_changes(cycles["ftp"], vehicle)
    assert np.nanmax(np.abs(second)) < 5e-3, (first, second)
