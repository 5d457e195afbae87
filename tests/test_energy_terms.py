"""Each named energy term is the physics its name says, recomputed from the per-step traces and the
component data, one term at a time.

The energy-balance tests sum every sink, so two sinks swapped in the output layout (``e_loss_mot_j`` <->
``e_loss_gen_j``, say) still close the balance; these tests do not: each accumulator is checked against its
own formula (shaft work, machine electrical minus mechanical power, road and grade forces at the step's mean
speed, the pack's chemical minus terminal energy, ...), and the terms a powertrain does not have are zero.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from hevlib.sim.powertrain.layout import TRACE_NAMES
from hevlib.sim.simulator import simulate

#: The stock Prius's sizing on the study's chassis, and a larger design (both well inside the space).
DESIGNS = np.array([[43.0, 31.0, 15.0, 3.93, 25, 78, 30], [60.0, 50.0, 25.0, 4.0, 40, 80, 30]])
RTOL = 1e-9


def _close(measured: float, expected: float, name: str, scale: float, rtol: float = RTOL) -> None:
    """``measured`` equals ``expected`` to ``rtol`` of ``scale`` (the run's fuel energy)."""
    assert abs(measured - expected) <= rtol * scale, f"{name}: {measured:.6g} J, its physics gives {expected:.6g} J"


def _traces(res, i: int) -> pd.DataFrame:
    return pd.DataFrame(res.traces[i], columns=list(TRACE_NAMES))


def _mean_speed(tr: pd.DataFrame) -> np.ndarray:
    """The speed each step's forces act at: the mean of its start and end speeds (the first step starts at its
    own end speed's predecessor, zero on every cycle here)."""
    v = tr["v_mps"].to_numpy()
    return np.r_[0.5 * v[0], 0.5 * (v[1:] + v[:-1])]


@pytest.fixture(scope="module", params=["udds", "ftp"])
def hybrid_run(request, sim, cycles):
    cycle = cycles[request.param]
    return cycle, simulate(sim.vehicle(DESIGNS), cycle, record=True, performance=False)


@pytest.fixture(scope="module")
def conventional_run(sim, cycles):
    cycle = cycles["udds"]
    return cycle, simulate(sim.vehicle(None, "conventional"), cycle, record=True, performance=False)


def test_hybrid_terms_are_their_physics(hybrid_run, lib, params):
    cycle, res = hybrid_run
    o, dt = res.frame(), cycle.dt_s
    body, wheel = lib.body_conventional, lib.wheel_conventional
    g, rho, cda = body.gravity_m_s2, body.air_density_kg_m3, body.drag_coefficient * body.frontal_area_m2
    for i in range(len(DESIGNS)):
        tr, row, m = _traces(res, i), o.iloc[i], res.mass_kg[i]
        scale = row["e_fuel_j"]
        v = _mean_speed(tr)
        # a step in which a start's spin-up ends is split (simulator v6): the spin-up's part (spin_* channels, its
        # length spin_part_s; the engine unfuelled) and the rest (the other channels)
        tau = tr["spin_part_s"].to_numpy()
        h = dt - tau
        assert (tau > 0).any() and (tau < dt).all()
        shaft = (tr["t_eng_nm"] * tr["w_eng_rad_s"] * h + tr["spin_t_eng_nm"] * tr["spin_w_eng_rad_s"] * tau).sum()
        p_start = tr["p_engine_start_w"].sum() * dt
        _close(row["e_fuel_j"], tr["fuel_g_s"].sum() * dt * lib.engine_hybrid.lhv_j_per_g, "e_fuel_j", scale)
        _close(row["e_eng_shaft_j"], shaft, "e_eng_shaft_j", scale)
        _close(row["e_loss_eng_j"], row["e_fuel_j"] - shaft, "e_loss_eng_j", scale)
        _close(
            row["e_loss_mot_j"],
            ((tr["p_mot_elec_w"] - tr["t_mot_nm"] * tr["w_mot_rad_s"]) * h).sum()
            + ((tr["spin_p_mot_elec_w"] - tr["spin_t_mot_nm"] * tr["w_mot_rad_s"]) * tau).sum(),
            "e_loss_mot_j",
            scale,
        )
        # the generator's loss includes what it loses cranking the engine (the start's electrical energy less
        # the mechanical work booked as e_engine_start_j)
        _close(
            row["e_loss_gen_j"],
            ((tr["p_gen_elec_w"] - tr["t_gen_nm"] * tr["w_gen_rad_s"]) * h).sum()
            + ((tr["spin_p_gen_elec_w"] - tr["spin_t_gen_nm"] * tr["spin_w_gen_rad_s"]) * tau).sum()
            + p_start
            - row["e_engine_start_j"],
            "e_loss_gen_j",
            scale,
        )
        assert 0.0 <= row["e_engine_start_j"] <= p_start * (1 + 1e-12), "e_engine_start_j"
        # the pack: chemical energy drawn less what reached its terminals
        _close(row["e_loss_batt_j"], row["e_batt_j"] - tr["p_batt_w"].sum() * dt, "e_loss_batt_j", scale)
        _close(row["e_brake_j"], -(tr["f_brake_n"] * v).sum() * dt, "e_brake_j", scale)
        sin_t = np.sin(np.arctan(tr["grade"].to_numpy()))
        cos_t = np.cos(np.arctan(tr["grade"].to_numpy()))
        _close(row["e_grade_j"], (m * g * sin_t * v).sum() * dt, "e_grade_j", scale)
        # road: aerodynamic drag and rolling resistance at the mean speed, plus the driven axle's drag (a constant
        # force at this mass) over the distance
        moving = v > 0.0
        aero_roll = ((0.5 * rho * cda * v**2 + m * g * cos_t * wheel.rolling_resistance) * v)[moving].sum() * dt
        f_axle = (row["e_road_j"] - aero_roll) / (v[moving].sum() * dt)
        axle = (wheel.axle_drag_nm_at_0kg + wheel.axle_drag_nm_per_kg * m) / wheel.radius_m
        assert f_axle == pytest.approx(axle, rel=1e-6), "e_road_j"
        v_end = tr["v_mps"].iloc[-1]
        _close(row["e_kin_end_j"], 0.5 * tr["m_eff_kg"].iloc[-1] * v_end**2, "e_kin_end_j", scale)
        # the power-split car has no gearbox and no clutch
        assert row["e_loss_gb_j"] == 0.0 and row["e_loss_clutch_j"] == 0.0
        # gear set and final drive: each loses its own efficiency's share of the power through it (the gear set:
        # the engine's share at the ring)
        eta_pg, eta_fd = params.sim.planetary_efficiency, params.sim.final_drive_efficiency
        n_r, n_s = DESIGNS[i, 5], DESIGNS[i, 6]
        ring_work = (tr["t_eng_nm"] * n_r / (n_r + n_s) * tr["w_mot_rad_s"] * h).abs().sum()
        wheel_work = (tr["f_pt_n"] * tr["v_mps"]).abs().sum() * dt
        assert row["e_loss_pg_j"] == pytest.approx((1 - eta_pg) * ring_work, rel=0.01), "e_loss_pg_j"
        assert row["e_loss_fd_j"] == pytest.approx((1 - eta_fd) * wheel_work, rel=0.03), "e_loss_fd_j"


def test_conventional_terms_are_their_physics(conventional_run, lib):
    cycle, res = conventional_run
    row, dt = res.frame().iloc[0], cycle.dt_s
    tr = _traces(res, 0)
    scale = row["e_fuel_j"]
    shaft = (tr["t_eng_nm"] * tr["w_eng_rad_s"]).sum() * dt
    lhv = lib.engine_conventional.lhv_j_per_g
    _close(row["e_fuel_j"], tr["fuel_g_s"].sum() * dt * lhv, "e_fuel_j", scale)
    _close(row["e_loss_eng_j"], row["e_fuel_j"] - shaft, "e_loss_eng_j", scale)
    _close(row["e_brake_j"], -(tr["f_brake_n"] * _mean_speed(tr)).sum() * dt, "e_brake_j", scale)
    # no motor, generator, gear set or pack, and the final drive's loss is in the gearbox's map: those terms are
    # exactly zero; the gearbox and the clutch lose energy
    zero = (
        "e_loss_mot_j",
        "e_loss_gen_j",
        "e_loss_pg_j",
        "e_loss_fd_j",
        "e_loss_batt_j",
        "e_batt_j",
        "e_engine_start_j",
    )
    for name in zero:
        assert row[name] == 0.0, name
    assert row["e_loss_gb_j"] > 0.0 and row["e_loss_clutch_j"] > 0.0
