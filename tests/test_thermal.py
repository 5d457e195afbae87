"""Engine and catalyst thermal models: lumped-capacity physics, conversion table, heat balance, cold and hot
starts, the FTP soak, a hybrid's engine-off cool-down, tailpipe against engine-out."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from hevlib.cycles import Cycle
from hevlib.doe import lhs_designs
from hevlib.sim.powertrain import thermal as T
from hevlib.sim.powertrain.layout import N_O, OUT_NAMES
from hevlib.sim.simulator import Simulator, energy_balance

PRIUS = [43.0, 31.0, 15.0, 3.93, 25, 78, 30]


def _step(**given) -> T.ThermalStep:
    """A thermal step by keyword: the key on, one second, no exhaust flow or emissions unless ``given``."""
    return T.ThermalStep(**({f: 0.0 for f in T.ThermalStep._fields} | {"key_on": True, "dt_s": 1.0} | given))


@pytest.fixture(scope="module")
def cfg(sim) -> T.ThermalConfig:
    return sim.library.thermal["conventional"]


def _isolated_monolith(cfg: T.ThermalConfig, *, g_shell: float, c_shell: float) -> tuple[np.ndarray, T.ThermalConfig]:
    """Design constants with the monolith coupled only to the gas (manifold, pipe and shell faces removed)
    and to a shell of capacity ``c_shell`` through a constant conductance ``g_shell``; no radiation."""
    k = T.design_constants(40.0, cfg, 1.0, 60.0)
    k[T.K_A_MAN] = 0.0
    k[T.K_A_PIPE] = 0.0
    k[T.K_A_INT] = k[T.K_A_MON]  # no exposed shell surface
    k[T.N_SHELL] = c_shell
    k[T.K_N_SUB] = 50.0
    cfg = cfg._replace(
        m2i_g=np.full(2, g_shell),
        m2i_t_c=np.array([-40.0, 1200.0]),
        eps_m2p=0.0,
        eps_i2x=0.0,
        g_shell2pipe=0.0,
        g_shell2shield=0.0,
        cold_correction=False,
    )
    return k, cfg


def test_catalyst_heats_with_exhaust_and_cools_without_it_as_a_lumped_capacity(cfg):
    """One node between a gas stream of fixed inlet temperature (engine on, no conversion heat) and nothing
    else heats as ``T_g - (T_g - T_0) exp(-UA t / C)``; cut the gas and couple it to an infinite shell at
    ambient and it cools as ``T_amb + (T_0 - T_amb) exp(-G t / C)``."""
    k, c = _isolated_monolith(cfg, g_shell=0.0, c_shell=1e30)
    temp = np.full(T.N_NODES, 20.0)
    fuel, q_waste, w = 1.0, 40e3, 300.0
    flow = fuel * (1 + c.afr)
    c_gas = flow * c.cp_gas
    x = (w - c.w_lo) / (c.w_hi - c.w_lo)
    frac = c.ex_frac_lo + x * (c.ex_frac_hi - c.ex_frac_lo)
    t_gas = c.t_map_c + frac * q_waste / c_gas  # the engine-out gas temperature, the converter's inlet here
    h_c = min(23.0 * (flow / 10.0) ** 0.8, c_gas / (k[T.K_A_MONI] + k[T.K_A_INT] - k[T.K_A_MON]))
    tau = k[T.N_MON] / (h_c * k[T.K_A_MONI])
    o = np.zeros(N_O)
    for _ in range(200):
        T.thermal_step(
            temp,
            k,
            c,
            _step(fuel_g_s=fuel, q_waste_w=q_waste, w_e_rad_s=w),
            o,
        )
    expected = t_gas - (t_gas - 20.0) * np.exp(-200.0 / tau)
    assert temp[T.N_MON] == pytest.approx(expected, rel=2e-3)
    assert 20.0 < temp[T.N_MON] < t_gas
    # cool-down without exhaust: the monolith's heat leaves through a constant conductance into a huge shell
    g = 5.0
    k, c = _isolated_monolith(cfg, g_shell=g, c_shell=1e30)
    t0 = temp[T.N_MON]
    temp = np.full(T.N_NODES, 20.0)
    temp[T.N_MON] = t0
    for _ in range(300):
        T.thermal_step(
            temp,
            k,
            c,
            _step(key_on=False),
            o,
        )
    assert temp[T.N_MON] == pytest.approx(20.0 + (t0 - 20.0) * np.exp(-g * 300.0 / k[T.N_MON]), rel=2e-3)


@pytest.mark.parametrize("t_mon", [-40.0, 100.0, 230.0, 300.0, 415.0, 500.0, 550.0, 900.0])
def test_conversion_follows_the_table_and_breakthrough_caps_it(cfg, t_mon):
    eff = [np.interp(t_mon, cfg.conv_t_c, getattr(cfg, f"conv_{p}")) for p in ("hc", "co", "nox")]
    assert T.conversion(t_mon, cfg) == pytest.approx(tuple(eff), abs=1e-15)
    k = T.design_constants(40.0, cfg, 1.0, 60.0)
    temp = np.full(T.N_NODES, t_mon)
    eo = (0.01, 0.2, 0.05)  # g/s, well below the breakthrough limits
    tp = T.thermal_step(
        temp,
        k,
        cfg._replace(cold_correction=False),
        _step(fuel_g_s=1.0, q_waste_w=3e4, w_e_rad_s=300.0, hc_g_s=eo[0], co_g_s=eo[1], nox_g_s=eo[2], v_mps=10.0),
        np.zeros(N_O),
    )
    assert tp == pytest.approx(tuple(e * (1 - f) for e, f in zip(eo, eff, strict=True)), rel=1e-12)
    # above the limit the converter removes at most the limit
    limits = (cfg.lim_hc, cfg.lim_co, cfg.lim_nox)
    for e_o, f, lim in zip((3.0, 40.0, 5.0), eff, limits, strict=True):
        assert T.tailpipe(e_o, f, lim) == pytest.approx(max(e_o * (1 - f), e_o - lim))
        assert e_o - T.tailpipe(e_o, f, lim) <= lim + 1e-12


def test_exhaust_relations_reproduce_the_engine_files_maps(raw, lib):
    """The kernel's exhaust flow and temperature (fuel x (1 + A/F); share x waste heat / (flow cp) + 20 C)
    equal the exhaust maps stored in both engine files, point by point."""
    for name, th, eng in (
        ("FC_PRIUS_JPN", lib.thermal_hybrid, lib.engine_hybrid),
        ("FC_SI63_emis", lib.thermal_conventional, lib.engine_conventional),
    ):
        d = yaml.safe_load((raw / "components" / f"{name}.yaml").read_text())
        w = np.array(d["speed_axis_rad_s"])[:, None]
        t = np.array(d["torque_axis_nm"])[None, :]
        fuel = np.array(d["fuel_map_g_per_s"])
        flow = fuel * (1 + th.air_fuel_ratio)
        np.testing.assert_allclose(flow, d["thermal_model"]["exhaust_gas_flow_map_g_per_s"], rtol=1e-9)
        x = (w - w.min()) / (w.max() - w.min())
        share = th.exhaust_share_min_speed + x * (th.exhaust_share_max_speed - th.exhaust_share_min_speed)
        waste = fuel * eng.lhv_j_per_g - t * w
        t_ex = th.map_reference_c + share * waste / (flow * 1.089)
        np.testing.assert_allclose(t_ex, d["thermal_model"]["engine_out_exhaust_temperature_map_c"], rtol=1e-6)


def test_heat_into_the_thermal_nodes_balances_and_equals_the_engine_loss(sim, cycles, params):
    X = np.vstack([PRIUS, lhs_designs(params.design_space.space(), 12, seed=5)])
    for name in ("ftp", "udds"):
        for vehicle, designs in (("hybrid", X), ("prius", None), ("conventional", None)):
            res = sim.run_raw(designs, cycles[name], vehicle, performance=False)
            eb = energy_balance(res)
            o = res.frame()
            assert (eb["thermal_residual_share"] < 1e-12).all(), (name, vehicle)
            # the heat the nodes receive from the engine is the engine loss of the energy balance, less the fuel a
            # cold engine burns above its hot map (ADVISOR: waste heat and exhaust flow from the hot map)
            heat = o["q_cyl_j"] + o["q_exhaust_j"]
            np.testing.assert_allclose(heat, o["e_loss_eng_j"] - o["e_fuel_cold_surplus_j"], rtol=1e-12, atol=1e-6)
            assert (o["e_fuel_cold_surplus_j"] > 0).all() if name == "ftp" else True
            assert (o["q_tailpipe_j"] <= o["q_exhaust_j"] + 1e-6).all()
            assert (o["q_tailpipe_j"] >= -1e-6).all() and (o["q_radiator_j"] >= 0).all()


def test_hot_start_tailpipe_is_engine_out_times_the_hot_conversion(sim, cfg):
    """A preconditioned conventional car cruising hard keeps its monolith above the table's hot plateau:
    every such step's tailpipe rate is the engine-out rate times (1 - hot conversion), to round-off."""
    t = np.arange(0.0, 401.0)
    v = np.minimum(t * 2.0, 33.0)  # 0 -> 119 km/h, then cruise
    cyc = Cycle("cruise", t, v, np.full(len(t), 0.03))
    hot = sim.params.model_copy(update={"sim": sim.params.sim.model_copy(update={"start": {"cruise": "hot"}})})
    tr = Simulator(sim.lib, hot).trace(None, cyc, "conventional")
    plateau = tr["t_cat_c"].to_numpy() >= cfg.conv_t_c[np.argmax(cfg.conv_hc)]
    prev = np.r_[False, plateau[:-1]]  # conversion follows the temperature the step starts with
    assert prev.sum() > 200
    for p in ("hc", "co", "nox"):
        eo = tr[f"{p}_engine_out_g_s"].to_numpy()[prev]
        tp = tr[f"{p}_tailpipe_g_s"].to_numpy()[prev]
        np.testing.assert_allclose(tp, eo * (1 - getattr(cfg, f"conv_{p}").max()), rtol=1e-12)


def test_cold_ftp_lights_off_cools_in_the_soak_and_restarts_warm(sim, cycles):
    cyc = cycles["ftp"]
    for vehicle in ("conventional", "prius"):
        tr = sim.trace(None, cyc, vehicle)
        res = sim.run_raw(None, cyc, vehicle, performance=False).frame().iloc[0]
        t = tr["time_s"].to_numpy()
        t_cat, t_cool = tr["t_cat_c"].to_numpy(), tr["t_coolant_c"].to_numpy()
        assert t_cat[0] == t_cool[0] == sim.params.sim.ambient_c  # cold start
        lo = res["t_cat_light_off_s"]
        assert 0 < lo < 505  # lights off within bag 1
        t_lo = sim.light_off_temperature_c()  # 50 % HC conversion: 308.6 C
        assert 300 < t_lo < 310 and t_cat[t == lo][0] >= t_lo > t_cat[t == lo - 1][0]
        soak = ~cyc.key_on & (t > 1000)  # the key is also off at t = 0
        assert soak.sum() == 600
        rows = np.flatnonzero(soak) + 1  # trace row t + 1 holds the step from t (key off at t)
        assert (tr["fuel_g_s"].to_numpy()[rows] == 0).all()
        i0, i1 = rows[[0, -1]]
        assert t_cat[i1] < t_cat[i0] - 50 and t_cool[i1] < t_cool[i0]  # cools while the key is off
        assert t_cat[i1] > 150  # ... but bag 3 starts warm: a hot start
        # bag 3 (the hot start) emits less HC per second of driving than bag 1 (cold start) over the same trace
        bag1, bag3 = (t >= 1) & (t <= 505), t >= 1973
        assert tr["hc_tailpipe_g_s"].to_numpy()[bag3].sum() < 0.5 * tr["hc_tailpipe_g_s"].to_numpy()[bag1].sum()


def test_the_thermal_start_is_an_argument_of_the_drive(sim, cycles):
    """``simulate`` takes its thermal start: the params' by default (the same bits as passing it), a named
    state, or the nine node temperatures; a hot FTP burns less fuel and lights off sooner than the cold one."""
    ftp = cycles["ftp"]
    first = sim.run_raw(None, ftp, "prius", performance=False)
    cold = first.out
    nodes = sim.library.start_temperatures("ftp", "prius")
    assert np.array_equal(sim.run_raw(None, ftp, "prius", performance=False, thermal_start=nodes).out, cold)
    assert np.array_equal(sim.run_raw(None, ftp, "prius", performance=False, thermal_start="cold").out, cold)
    hot = sim.run_raw(None, ftp, "prius", performance=False, thermal_start="hot").frame().iloc[0]
    first = first.frame().iloc[0]
    assert hot["t_cat_light_off_s"] == 0.0 < first["t_cat_light_off_s"]
    assert hot["e_fuel_j"] < first["e_fuel_j"]
    warm = nodes + 40.0  # any start: every node 40 K above ambient lies between the two
    mid = sim.run_raw(None, ftp, "prius", performance=False, thermal_start=warm).frame().iloc[0]
    assert hot["e_fuel_j"] < mid["e_fuel_j"] < first["e_fuel_j"]
    for bad in (nodes[:8], np.r_[nodes[:8], np.nan], "warm"):
        with pytest.raises(ValueError, match="thermal start"):
            sim.run_raw(None, ftp, "prius", performance=False, thermal_start=bad)


def test_a_hybrids_catalyst_cools_while_its_engine_is_off(sim, cycles):
    tr = sim.trace(np.array([PRIUS], float), cycles["ftp"])
    on = tr["eng_on"].to_numpy() > 0
    t_cat = tr["t_cat_c"].to_numpy()
    key = cycles["ftp"].key_on
    # after light-off, every engine-off step with the key on loses catalyst heat (no exhaust, no reaction)
    hot = t_cat > 300
    off = np.flatnonzero(~on[1:] & key[:-1] & hot[:-1]) + 1
    assert len(off) > 100
    assert (t_cat[off] < t_cat[off - 1]).all()


def test_light_off_time_is_the_cycle_duration_when_never_reached(sim):
    t = np.arange(0.0, 61.0)
    cyc = Cycle("creep", t, np.minimum(t, 2.0), np.zeros(len(t)))  # a minute at walking pace from cold
    r = sim.responses(sim.run_raw(None, cyc, "conventional"), cyc)
    assert r["t_cat_light_off_s"].iloc[0] == 60.0
    assert np.isfinite(r[["hc", "co", "nox", "hc_engine_out", "co_engine_out", "nox_engine_out"]].to_numpy()).all()


def test_objectives_are_tailpipe_by_default_and_engine_out_one_param_away(sim, cycles, params):
    cyc = cycles["ftp"]
    X = np.array([PRIUS], float)
    r = sim.responses(sim.run_raw(X, cyc), cyc).iloc[0]
    for p in ("hc", "co", "nox"):
        assert 0 < r[p] < r[f"{p}_engine_out"]
    eo = params.model_copy(update={"sim": params.sim.model_copy(update={"emissions": "engine_out"})})
    r2 = Simulator(sim.lib, eo).run(X, cyc).iloc[0]
    for p in ("hc", "co", "nox"):
        assert r2[p] == r2[f"{p}_engine_out"] == pytest.approx(r[f"{p}_engine_out"], rel=1e-12)


def test_cold_correction_raises_cold_engine_out_and_vanishes_when_hot(sim, cycles, params, cfg):
    assert T.cold_factors(cfg.t_stat_c, cfg) == (1.0, 1.0, 1.0, 1.0)
    f20 = T.cold_factors(20.0, cfg)
    assert f20 == pytest.approx((1.1, 9.05, 3.13, 1.51))
    off = params.model_copy(update={"sim": params.sim.model_copy(update={"cold_correction": "none"})})
    cyc = cycles["ftp"]
    a = sim.run(None, cyc, "conventional").iloc[0]
    b = Simulator(sim.lib, off).run(None, cyc, "conventional").iloc[0]
    assert a["hc_engine_out"] > b["hc_engine_out"] and a["fc"] > b["fc"]
    # a hot start with the block at the thermostat: the correction changes nothing
    hwfet = cycles["hwfet"]
    assert sim.params.sim.start.get("hwfet") == "hot"
    a, b = (
        sim.run(None, hwfet, "conventional").iloc[0],
        Simulator(sim.lib, off).run(None, hwfet, "conventional").iloc[0],
    )
    assert a["fc"] == b["fc"] and a["hc_engine_out"] == b["hc_engine_out"]


def test_thermal_outputs_are_named():
    for name in ("hc_tailpipe_g", "t_cat_light_off_s", "q_exotherm_j", "u_thermal_end_j"):
        assert name in OUT_NAMES
    assert len(OUT_NAMES) == N_O


def test_start_state_must_name_a_cycle(root):
    from hevlib.params import parse_params

    data = yaml.safe_load((root / "params.yaml").read_text())
    data["sim"]["start"]["nosuch"] = "hot"
    with pytest.raises(ValueError, match="sim.start.nosuch"):
        parse_params(data)


def test_catalyst_plot_window_is_ftp_bag_1_and_only_for_cold_starts(sim, cycles):
    from hevlib.plots import plt
    from hevlib.plots.validation import catalyst_figure
    from hevlib.validation import cold_start_window_s

    tr = {
        "prius": sim.trace(None, cycles["ftp"], "prius"),
        "conventional": sim.trace(None, cycles["ftp"], "conventional"),
    }
    assert cold_start_window_s(sim, cycles["ftp"], tr) == 505.0
    assert cold_start_window_s(sim, cycles["udds"], tr) == cycles["udds"].duration_s
    assert cold_start_window_s(sim, cycles["hwfet"], tr) is None  # run hot: no warm-up to show
    assert cold_start_window_s(sim, cycles["ftp"], {"x": tr["prius"].drop(columns="t_cat_c")}) is None
    fig = catalyst_figure(tr, "ftp", 505.0, sim.light_off_temperature_c())
    lines = fig.axes[0].get_lines()
    assert max(line.get_xdata().max() for line in lines if len(line.get_xdata()) > 2) == 505.0
    plt.close(fig)


def test_engine_out_without_cold_factors_does_not_feel_the_thermal_models(sim, cycles, params):
    """``-S sim.emissions=engine_out -S sim.cold_correction=none`` (and sim-4's ``pms.coolant_warmup``,
    ``pms.engine_dynamics`` and ``pms.full_power_above_kw`` off) gives the model before the thermal models: they do
    not feed back into the drive, so a cold and a hot start give the same fuel and engine-out emissions to the last
    digit. (Until sim-4 this compared with the sim-2 figures of b0e5b4e; sim-5's engine maps, clipped at full
    load, and the conventional car's ADVISOR control moved those.)"""
    old = params.model_copy(
        update={
            "sim": params.sim.model_copy(update={"emissions": "engine_out", "cold_correction": "none"}),
            # sim-4's engine starts and coolant warm-up rule off: the study's plain rule base
            "pms": params.pms.model_copy(
                update={"coolant_warmup": False, "engine_dynamics": False, "full_power_above_kw": None}
            ),
        }
    )
    hot = old.model_copy(update={"sim": old.sim.model_copy(update={"start": {"ftp": "hot", "udds": "hot"}})})
    for vehicle, cycle in (("conventional", "ftp"), ("prius", "ftp"), ("prius", "udds")):
        r_cold = Simulator(sim.lib, old).run(None, cycles[cycle], vehicle).iloc[0]
        r_hot = Simulator(sim.lib, hot).run(None, cycles[cycle], vehicle).iloc[0]
        assert r_cold["t_cat_light_off_s"] > 0 and r_hot["t_cat_light_off_s"] == 0  # the thermal states differ
        for k in ("fc", "hc", "co", "nox", "speed_dev", "accel_dev"):
            assert r_cold[k] == r_hot[k], (vehicle, cycle, k)
