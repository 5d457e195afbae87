"""Engine and exhaust-aftertreatment thermal models (numba): coolant warm-up, catalyst light-off, tailpipe
emissions, and the cool-down of a hybrid's engine-off periods and of the FTP's key-off soak.

Both are ADVISOR 2003's lumped-capacity models (``lib_fuel_converter`` ``fc temp`` and ``lib_exhaust``
``exhaust sys``, data ``FC_*`` ``thermal_model`` and ``EX_SI``), nine nodes per design:

* engine ``[cyl, block, ext, hood]``: the cylinder takes the combustion waste heat the exhaust does not
  carry; cylinder -> block (coolant) -> exterior (accessories) by the files' conductances; exterior ->
  hood and ambient, hood -> ambient by conduction, radiation and convection; an ideal thermostat: while the
  key is on and the block is at ``t_stat_c``, the radiator removes what would heat it further.
* exhaust ``[monolith, shell, pipe, shield, manifold]``: the engine-out gas (flow = fuel x (1 + A/F), its
  heat the speed-dependent exhaust share of the waste heat) passes the manifold + downpipe, the inlet pipe
  and the converter (monolith channels and exposed shell), giving heat to each; the converted pollutants'
  reaction heat goes into the monolith; the shell exchanges with monolith, pipe and shield, pipe and shield
  lose heat to ambient, the manifold exchanges with the engine exterior.

The engine's waste heat and the exhaust flow come from the hot map's fuel rate, as in ADVISOR's ``fc temp``: the
surplus fuel a cold engine burns (its cold factor) heats nothing.

Conversion of HC, CO and NOx follows the monolith temperature (``EX_SI`` table) and never exceeds the
breakthrough limit: ``tailpipe = max(EO (1 - eff), EO - limit)``.

Where this differs from ADVISOR (simplest sound choices, see ``docs``/README):

* each gas-to-solid exchange of manifold and pipe uses the exact mean gas temperature of the step
  (``Q = UA (T_s - T_in) / (1 + UA / (2 C_gas))``) instead of ADVISOR's one-step-delayed outlet;
* the thermostat only removes heat (ADVISOR's clamp also froze a block above ``t_stat`` that was losing
  heat);
* all areas and masses follow the design's engine power (ADVISOR leaves the gas-side manifold and pipe areas
  unscaled);
* the reaction heat uses the conversion of the same step (ADVISOR: of the step before);
* the heat the manifold gives the engine's exterior reaches it (ADVISOR takes it from the manifold but never
  adds it to the engine: about 0.3 % of the conventional car's FTP tailpipe figures);
* explicit (forward Euler) integration with as many sub-steps per drive step as keep every node stable
  (:func:`substeps`); every heat flow leaves one node and enters another (or the environment), so the
  stored heat balances to round-off (``q_*`` accumulators).

Temperatures in degC, heat in J, powers in W, masses in kg.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from hevlib.lookup import bracket, interp1
from hevlib.powers import pow_0_3
from hevlib.sim.powertrain import layout as L

SIGMA = 5.670374419e-8  # Stefan-Boltzmann, W/m^2/K^4
KELVIN = 273.15

# node indices
N_CYL, N_BLOCK, N_EXT, N_HOOD, N_MON, N_SHELL, N_PIPE, N_SHIELD, N_MAN = range(9)
N_NODES = 9
NODE_NAMES = ("cyl", "block", "ext", "hood", "monolith", "shell", "pipe", "shield", "manifold")
# per-design constants (index into the array of :func:`design_constants`)
K_AX, K_A_MON, K_A_MONF, K_A_MONI, K_A_INT, K_A_PIPE, K_A_SHIELD, K_A_MAN, K_N_SUB = range(N_NODES, N_NODES + 9)
N_K = N_NODES + 9


#: ADVISOR's hot start (gui/init_conds_hot.m), degC; the block starts at the engine's thermostat temperature
HOT_START_C = {
    "cyl": 150.0,
    "ext": 90.0,
    "hood": 35.0,
    "monolith": 500.0,
    "shell": 500.0,
    "pipe": 300.0,
    "shield": 150.0,
    "manifold": 300.0,
}


def start_temperatures(state: str, ambient_c: float, t_stat_c: float) -> np.ndarray:
    """Node temperatures of a ``cold`` start (all at ambient) or a ``hot`` (preconditioned) one, degC."""
    if state == "cold":
        return np.full(N_NODES, float(ambient_c))
    if state == "hot":
        return np.array([t_stat_c if n == "block" else HOT_START_C[n] for n in NODE_NAMES])
    raise ValueError(f"thermal start state: {state!r} is not cold or hot")


class ThermalConfig(NamedTuple):
    """Thermal data of one engine + the catalyst, as the kernels see it (base engine, unscaled)."""

    ambient_c: float
    p_base_kw: float  # peak power of the base engine map; a design's scale is p_eng / p_base
    # engine (fc temp)
    m_base_kg: float  # base engine (block + head) of the base map; cylinder 20 %, block 80 %
    m_acc_kg: float  # accessories: the exterior node
    m_hood_kg: float  # 10 % of the glider (x the engine's power scale, as ADVISOR)
    cp_eng: float
    cp_hood: float
    a_ext_m2: float  # engine exterior area of the base engine (x scale^0.67)
    a_hood_m2: float
    eps_eng: float
    eps_hood: float
    g_c2i: float  # W/K
    g_i2x: float
    g_h2x: float
    t_stat_c: float
    ex_frac_lo: float  # exhaust share of the waste heat at the map's lowest ...
    ex_frac_hi: float  # ... and highest speed (linear in speed between)
    w_lo: float
    w_hi: float
    afr: float  # exhaust flow = fuel x (1 + afr)
    cp_gas: float  # J/(g K)
    t_map_c: float  # temperature the exhaust maps refer to (ADVISOR: engine tested at 20 C)
    # exhaust (EX_SI), per kW of the design's engine
    ex_kg_per_kw: float
    m_mon_share: float  # shares of the exhaust system mass
    m_shell_share: float
    m_pipe_share: float
    m_shield_share: float
    m_man_share: float
    cp_mon: float
    cp_steel: float
    a_mon_coef: float  # monolith outer area = a_mon_coef (p / 100)^a_mon_exp, m^2
    a_mon_exp: float
    a_man_m2_per_kw: float  # manifold + downpipe area per kW
    eps_m2p: float
    eps_i2x: float
    eps_pipe: float
    eps_shield: float
    eps_man: float
    g_shell2shield: float
    g_shell2pipe: float
    g_pipe2shield: float
    m2i_t_c: np.ndarray  # monolith <-> shell conductance vs the shell temperature
    m2i_g: np.ndarray
    conv_t_c: np.ndarray  # conversion efficiency vs monolith temperature
    conv_hc: np.ndarray
    conv_co: np.ndarray
    conv_nox: np.ndarray
    lim_hc: float  # breakthrough: most a converter converts, g/s
    lim_co: float
    lim_nox: float
    light_off_eff: float  # HC conversion that marks light-off
    fuel_max_g_s: float  # highest fuel rate of the base engine map (bounds the exhaust flow)
    cold_correction: bool  # ADVISOR's equation-based cold-engine factors (engine files without cold maps)


@njit(cache=True, inline="always")
def cold_factors(t_block_c: float, t: ThermalConfig) -> tuple[float, float, float, float]:
    """Multipliers of the hot-map fuel, HC, CO and NOx rates of an engine whose block is at ``t_block_c``.

    ADVISOR's ``fc temp correct`` for engine files without cold maps (``fc_cold = 0``, every shipped file):
    ``lambda = clip((t_stat - T) / (t_stat - 20), 0, 1)``; fuel x (1 + 0.1 lambda^0.65), HC x (1 + 8.05
    lambda^9.46), CO x (1 + 2.13 lambda^4.26), NOx x (1 + 0.51 lambda^1.37). All 1 when switched off.
    """
    if not t.cold_correction:
        return 1.0, 1.0, 1.0, 1.0
    lam = min(max((t.t_stat_c - t_block_c) / (t.t_stat_c - t.t_map_c), 0.0), 1.0)
    if lam == 0.0:  # warm
        return 1.0, 1.0, 1.0, 1.0
    return 1.0 + 0.1 * lam**0.65, 1.0 + 8.05 * lam**9.46, 1.0 + 2.13 * lam**4.26, 1.0 + 0.51 * lam**1.37


class ThermalStep(NamedTuple):
    """What one drive step hands the thermal nodes (:func:`thermal_step`)."""

    key_on: bool
    fuel_g_s: float  # the engine's hot-map fuel rate (0: no exhaust flow)
    q_waste_w: float  # its waste heat: hot-map fuel power - shaft power (a cold engine's surplus fuel heats nothing)
    w_e_rad_s: float  # its speed
    hc_g_s: float  # engine-out emission rates
    co_g_s: float
    nox_g_s: float
    v_mps: float  # vehicle speed (the air-side convection)
    dt_s: float


class ThermalNodes(NamedTuple):
    """One design's thermal nodes while it drives: the views :func:`start` returns and the config."""

    temp_c: np.ndarray  # node temperatures
    k: np.ndarray  # per-design constants (heat capacities, areas, sub-steps; K_* indices)
    cfg: ThermalConfig


#: Length of the scratch row :func:`start` lays out: the per-design constants and the node temperatures.
N_SCRATCH = N_K + N_NODES


@njit(cache=True)
def start(p_eng_kw: float, t: ThermalConfig, t_init_c: np.ndarray, dt: float, o: np.ndarray, scratch: np.ndarray):
    """Per-design constants and the nodes' start temperatures for :func:`thermal_step`, as views ``(k, temp)``
    of the caller's ``scratch`` row (:data:`N_SCRATCH` long, reused design after design: the
    caller owns it for the whole drive); books the stored heat and the light-off at time 0."""
    k = scratch[:N_K]
    temp = scratch[N_K:N_SCRATCH]
    fill_design_constants(k, p_eng_kw, t, dt, t.fuel_max_g_s * p_eng_kw / t.p_base_kw * (1.0 + t.afr))
    temp[:] = t_init_c
    o[L.O_U_THERMAL_START_J] = stored_heat(temp, k)
    o[L.O_T_LIGHT_OFF_S] = -1.0
    o[L.O_T_CAT_MAX_C] = temp[N_MON]
    check_light_off(temp, t, 0.0, o)
    return k, temp


@njit(cache=True)
def finish(temp: np.ndarray, k: np.ndarray, duration_s: float, o: np.ndarray) -> None:
    """End-of-cycle figures: stored heat, end temperatures; light-off = the duration if never reached."""
    o[L.O_U_THERMAL_END_J] = stored_heat(temp, k)
    o[L.O_T_COOLANT_END_C] = temp[N_BLOCK]
    o[L.O_T_CAT_END_C] = temp[N_MON]
    if o[L.O_T_LIGHT_OFF_S] < 0.0:
        o[L.O_T_LIGHT_OFF_S] = duration_s


@njit(cache=True)
def design_constants(p_eng_kw: float, t: ThermalConfig, dt: float, w_flow_max: float) -> np.ndarray:
    """Node heat capacities (J/K), areas (m^2) and sub-steps of the design whose engine makes ``p_eng_kw``;
    ``w_flow_max``: the most exhaust flow it can make, g/s (bounds the gas-side conductances)."""
    k = np.empty(N_K)
    fill_design_constants(k, p_eng_kw, t, dt, w_flow_max)
    return k


@njit(cache=True)
def fill_design_constants(k: np.ndarray, p_eng_kw: float, t: ThermalConfig, dt: float, w_flow_max: float) -> None:
    """:func:`design_constants` written into ``k`` (``N_K`` long)."""
    s = p_eng_kw / t.p_base_kw
    k[N_CYL] = 0.2 * t.m_base_kg * s * t.cp_eng
    k[N_BLOCK] = 0.8 * t.m_base_kg * s * t.cp_eng
    k[N_EXT] = t.m_acc_kg * s * t.cp_eng
    k[N_HOOD] = t.m_hood_kg * s * t.cp_hood
    m_ex = t.ex_kg_per_kw * p_eng_kw
    k[N_MON] = t.m_mon_share * m_ex * t.cp_mon
    k[N_SHELL] = t.m_shell_share * m_ex * t.cp_steel
    k[N_PIPE] = t.m_pipe_share * m_ex * t.cp_steel
    k[N_SHIELD] = t.m_shield_share * m_ex * t.cp_steel
    k[N_MAN] = t.m_man_share * m_ex * t.cp_steel
    a_mon = t.a_mon_coef * (p_eng_kw / 100.0) ** t.a_mon_exp
    k[K_AX] = t.a_ext_m2 * s**0.67
    k[K_A_MON] = a_mon
    k[K_A_MONF] = a_mon / 4.0
    k[K_A_MONI] = a_mon * 50.0
    k[K_A_INT] = a_mon * 1.3
    k[K_A_PIPE] = a_mon / 2.0
    k[K_A_SHIELD] = a_mon * 1.4
    k[K_A_MAN] = t.a_man_m2_per_kw * p_eng_kw
    k[K_N_SUB] = substeps(k, t, dt, w_flow_max)


@njit(cache=True)
def substeps(k: np.ndarray, t: ThermalConfig, dt: float, w_flow_max: float) -> float:
    """Sub-steps per drive step keeping forward Euler stable and monotone: ``dt_sub sum(G) / C <= 0.5`` on
    every node, with each conductance bounded from above (radiation and convection linearised at 1200 C and
    a 60 m/s air speed, the gas side by the largest exhaust flow)."""
    c_gas = w_flow_max * t.cp_gas
    h_max = 6.0 + 6.0 * 1.2**0.3 + 60.0 * 2.0**0.6  # ambient convection bound, W/(m^2 K)
    rad = 4.0 * SIGMA * (1200.0 + KELVIN) ** 3  # linearised radiation bound per m^2 and unit emissivity
    g = np.zeros(N_NODES)
    ax = k[K_AX]
    g[N_CYL] = t.g_c2i
    g[N_BLOCK] = t.g_c2i + t.g_i2x
    g[N_EXT] = t.g_i2x + t.g_h2x + 1.5 * ax * (h_max + t.eps_eng * rad) + k[K_A_MAN] * (h_max + t.eps_man * rad)
    g[N_HOOD] = t.g_h2x + ax * (h_max + t.eps_eng * rad) + t.a_hood_m2 * (h_max + t.eps_hood * rad)
    g_m2i = np.max(t.m2i_g)
    g[N_MON] = g_m2i + c_gas + k[K_A_MONF] * t.eps_m2p * rad
    g[N_SHELL] = g_m2i + c_gas + t.g_shell2shield + t.g_shell2pipe + k[K_A_INT] * t.eps_i2x * rad
    g[N_PIPE] = (
        c_gas
        + t.g_shell2pipe
        + t.g_pipe2shield
        + k[K_A_MONF] * t.eps_m2p * rad
        + k[K_A_PIPE] * (h_max + t.eps_pipe * rad)
    )
    g[N_SHIELD] = t.g_shell2shield + t.g_pipe2shield + k[K_A_INT] * t.eps_i2x * rad + k[K_A_SHIELD] * (h_max + rad)
    g[N_MAN] = c_gas + k[K_A_MAN] * (h_max + t.eps_man * rad)
    worst = 0.0
    for i in range(N_NODES):
        worst = max(worst, g[i] / k[i])
    return float(max(1, int(np.ceil(dt * worst / 0.5))))


#: ADVISOR's forced-convection coefficient ``60 (|share v| / v_ref)^0.6`` W/(m^2 K) (speed in m/s, as its code)
#: of the engine bay (half the vehicle speed, v_ref 30), the hood (full speed, 30) and the exhaust (0.75, 21), as
#: ``FORCED_* v^0.6``: one power of the speed per step serves all three.
FORCED_X, FORCED_H, FORCED_E = (
    60.0 * (share / v_ref) ** 0.6 for share, v_ref in ((0.5, 30.0), (1.0, 30.0), (0.75, 21.0))
)


@njit(cache=True, inline="always")
def _speed_term(v_mps: float) -> float:
    """``|v|^0.6`` of the forced-convection coefficients (exactly 0 at standstill, where the power is not
    evaluated)."""
    if v_mps == 0.0:
        return 0.0
    return abs(v_mps) ** 0.6


@njit(cache=True, inline="always")
def _h_air(dt_k: float, base_forced: float) -> float:
    """ADVISOR's air-side coefficient, W/(m^2 K): ``base_forced`` (its base 6 or 10 plus the forced part, ``FORCED_*``)
    plus natural convection ``6 (|dT| / 1000)^0.3`` (exactly none between equal temperatures, where the power
    is not evaluated)."""
    if dt_k == 0.0:
        return base_forced
    return base_forced + 6.0 * pow_0_3(abs(dt_k) / 1000.0)


@njit(cache=True, inline="always")
def _rad(eps_area: float, t_from: float, t_to: float) -> float:
    """Net radiation from ``t_from`` to ``t_to`` (degC), W, for emissivity x area ``eps_area``."""
    a = t_from + KELVIN
    b = t_to + KELVIN
    return eps_area * SIGMA * (a * a * a * a - b * b * b * b)


@njit(cache=True, inline="always")
def _gas_exchange(ua: float, c_gas: float, t_solid: float, t_in: float) -> float:
    """Heat from a solid to gas flowing past it (W) with the step's mean gas temperature; ``ua <= c_gas``."""
    return ua * (t_solid - t_in) / (1.0 + ua / (2.0 * c_gas))


@njit(cache=True, inline="always")
def conversion(t_mon: float, t: ThermalConfig) -> tuple[float, float, float]:
    """Conversion efficiencies (HC, CO, NOx) at monolith temperature ``t_mon`` (degC), linear in the table."""
    i, f = bracket(t_mon, t.conv_t_c)
    return (
        t.conv_hc[i] + f * (t.conv_hc[i + 1] - t.conv_hc[i]),
        t.conv_co[i] + f * (t.conv_co[i + 1] - t.conv_co[i]),
        t.conv_nox[i] + f * (t.conv_nox[i + 1] - t.conv_nox[i]),
    )


@njit(cache=True, inline="always")
def tailpipe(eo: float, eff: float, limit: float) -> float:
    """Tailpipe rate: the converter removes ``eff`` of the engine-out rate ``eo``, at most ``limit`` (g/s)."""
    return max(eo * (1.0 - eff), eo - limit)


@njit(cache=True)
def stored_heat(temp: np.ndarray, k: np.ndarray) -> float:
    """Heat stored in the nine nodes above 0 degC, J."""
    u = 0.0
    for i in range(N_NODES):
        u += k[i] * temp[i]
    return u


@njit(cache=True, inline="always")
def at_ambient(temp: np.ndarray, ambient_c: float) -> bool:
    """Every node exactly at the ambient temperature (a cold engine before its first fuel)."""
    for i in range(N_NODES):
        if temp[i] != ambient_c:
            return False
    return True


@njit(cache=True)
def thermal_step(
    temp: np.ndarray, k: np.ndarray, t: ThermalConfig, s: ThermalStep, o: np.ndarray
) -> tuple[float, float, float]:
    """Advance the nine nodes ``temp`` over the drive step ``s`` (:class:`ThermalStep`); return the tailpipe
    (HC, CO, NOx) rates, g/s. Accumulates the heat terms ``O_Q_*`` of
    :mod:`hevlib.sim.powertrain.layout` in ``o``.
    """
    key_on, fuel_g_s, q_waste_w, w_e, v_mps, dt = s.key_on, s.fuel_g_s, s.q_waste_w, s.w_e_rad_s, s.v_mps, s.dt_s
    eo_hc, eo_co, eo_nox = s.hc_g_s, s.co_g_s, s.nox_g_s
    amb = t.ambient_c
    if fuel_g_s == 0.0 and q_waste_w == 0.0 and eo_hc + eo_co + eo_nox == 0.0 and at_ambient(temp, amb):
        return 0.0, 0.0, 0.0  # no heat in and every node at ambient: nothing flows, nothing changes
    flow = fuel_g_s * (1.0 + t.afr)
    c_gas = flow * t.cp_gas  # W/K
    # ---- heat the exhaust carries (above ambient) and the rest, into the cylinder
    q_ex = 0.0
    if flow > 0.0 and q_waste_w > 0.0:
        x = min(max((w_e - t.w_lo) / (t.w_hi - t.w_lo), 0.0), 1.0)
        frac = t.ex_frac_lo + x * (t.ex_frac_hi - t.ex_frac_lo)
        t_eo = t.t_map_c + frac * q_waste_w / c_gas  # engine-out gas temperature of the maps
        q_ex = min(max(c_gas * (t_eo - amb), 0.0), q_waste_w)
    q_cyl = q_waste_w - q_ex
    t_gas_in = amb + q_ex / c_gas if flow > 0.0 else amb
    # ---- conversion at the monolith temperature the step starts with; reaction heat into the monolith
    e_hc, e_co, e_nox = conversion(temp[N_MON], t)
    tp_hc = tailpipe(eo_hc, e_hc, t.lim_hc)
    tp_co = tailpipe(eo_co, e_co, t.lim_co)
    tp_nox = tailpipe(eo_nox, e_nox, t.lim_nox)
    q_exo = 0.0
    if flow > 0.0:
        mol_gas = flow / 29.0  # mol/s of exhaust
        x_hc = 100.0 * min(max((eo_hc - tp_hc) / 44.1 / mol_gas, 0.0), 1.0)  # mole-% converted
        x_co = 100.0 * min(max((eo_co - tp_co) / 28.0 / mol_gas, 0.0), 1.0)
        x_nox = 100.0 * min(max((eo_nox - tp_nox) / 46.0 / mol_gas, 0.0), 1.0)
        q_exo = c_gas * (669.0 * x_hc + (93.0 + 79.0 / 3.0) * (x_co - x_nox) + 121.0 * x_nox)
        q_exo = max(q_exo, 0.0)
    h_gas = 23.0 * (flow / 10.0) ** 0.8 if flow > 0.0 else 0.0
    # air-side coefficients' base + forced parts (ADVISOR: engine bay at half, exhaust at 0.75 of the speed)
    v_06 = _speed_term(v_mps)
    hb_x = 6.0 + FORCED_X * v_06
    hb_h = 10.0 + FORCED_H * v_06
    hb_e = 6.0 + FORCED_E * v_06
    n_sub = int(k[K_N_SUB])
    h = dt / n_sub
    ax, a_hood = k[K_AX], t.a_hood_m2
    q_tail = q_rad = q_amb = 0.0
    # the nodes' temperatures and net heats stay in registers through the sub-steps (the array is read and
    # written once per drive step); each net heat sums its flows in the order the model lists them
    tc, ti, tx, th = temp[N_CYL], temp[N_BLOCK], temp[N_EXT], temp[N_HOOD]
    tm, tci, tcp, tcx, tman = temp[N_MON], temp[N_SHELL], temp[N_PIPE], temp[N_SHIELD], temp[N_MAN]
    c_cyl, c_block, c_ext, c_hood = k[N_CYL], k[N_BLOCK], k[N_EXT], k[N_HOOD]
    c_mon, c_shell, c_pipe, c_shield, c_man = k[N_MON], k[N_SHELL], k[N_PIPE], k[N_SHIELD], k[N_MAN]
    a_man, a_pipe, a_shield = k[K_A_MAN], k[K_A_PIPE], k[K_A_SHIELD]
    a_mon, a_monf, a_moni, a_int = k[K_A_MON], k[K_A_MONF], k[K_A_MONI], k[K_A_INT]
    for _ in range(n_sub):
        # ---- engine: combustion heat, cylinder -> block -> exterior -> hood / ambient
        q_c = 0.0 + q_cyl
        f = t.g_c2i * (tc - ti)
        q_c -= f
        q_i = 0.0 + f
        f = t.g_i2x * (ti - tx)
        q_i -= f
        q_x = 0.0 + f
        f = (t.g_h2x + _h_air(th - tx, hb_x) * ax) * (tx - th) + _rad(t.eps_eng * ax, tx, th)
        q_x -= f
        q_h = 0.0 + f
        loss_x = _h_air(amb - tx, hb_x) * 0.5 * ax * (tx - amb) + _rad(t.eps_eng * 0.5 * ax, tx, amb)
        loss_h = _h_air(amb - th, hb_h) * a_hood * (th - amb) + _rad(t.eps_hood * a_hood, th, amb)
        q_x -= loss_x
        q_h -= loss_h
        # ---- exhaust gas: manifold, inlet pipe, converter (monolith channels + exposed shell)
        q_man = q_p = q_m = q_ci = q_cx = 0.0
        t_g = t_gas_in
        if flow > 0.0:
            ua = min(h_gas * a_man, c_gas)
            f = _gas_exchange(ua, c_gas, tman, t_g)
            q_man -= f
            t_g += f / c_gas
            ua = min(h_gas * a_pipe, c_gas)
            f = _gas_exchange(ua, c_gas, tcp, t_g)
            q_p -= f
            t_g += f / c_gas
            a_cat = a_moni + a_int - a_mon
            h_c = min(h_gas, c_gas / a_cat)
            f_m = h_c * a_moni * (tm - t_g)
            f_i = h_c * (a_int - a_mon) * (tci - t_g)
            q_m -= f_m
            q_ci -= f_i
            t_g += (f_m + f_i) / c_gas
            q_m += q_exo
        # ---- exhaust solids
        f = _rad(t.eps_man * a_man, tman, tx) + _h_air(tx - tman, hb_e) * a_man * (tman - tx)
        q_man -= f
        q_x += f
        f = interp1(tci, t.m2i_t_c, t.m2i_g) * (tci - tm)
        q_ci -= f
        q_m += f
        f = _rad(t.eps_m2p * a_monf, tcp, tm)
        q_p -= f
        q_m += f
        f = t.g_shell2pipe * (tcp - tci)
        q_p -= f
        q_ci += f
        f = t.g_shell2shield * (tcx - tci) + _rad(t.eps_i2x * a_int, tcx, tci)
        q_cx -= f
        q_ci += f
        f = t.g_pipe2shield * (tcx - tcp)
        q_cx -= f
        q_p += f
        loss_p = _rad(t.eps_pipe * a_pipe, tcp, amb) + _h_air(amb - tcp, hb_e) * a_pipe * (tcp - amb)
        loss_s = _rad(t.eps_shield * a_shield, tcx, amb) + _h_air(amb - tcx, hb_e) * a_shield * (tcx - amb)
        q_p -= loss_p
        q_cx -= loss_s
        # ---- thermostat: with the key on, the radiator holds the block at t_stat (removes heat only)
        rad = 0.0
        t_block = ti + h * q_i / c_block
        if key_on and t_block > t.t_stat_c and q_i > 0.0:
            rad = min(q_i, (t_block - max(ti, t.t_stat_c)) * c_block / h)
            q_i -= rad
        tc += h * q_c / c_cyl
        ti += h * q_i / c_block
        tx += h * q_x / c_ext
        th += h * q_h / c_hood
        tm += h * q_m / c_mon
        tci += h * q_ci / c_shell
        tcp += h * q_p / c_pipe
        tcx += h * q_cx / c_shield
        tman += h * q_man / c_man
        q_tail += (c_gas * (t_g - amb) if flow > 0.0 else 0.0) * h
        q_rad += rad * h
        q_amb += (loss_x + loss_h + loss_p + loss_s) * h
    temp[N_CYL], temp[N_BLOCK], temp[N_EXT], temp[N_HOOD] = tc, ti, tx, th
    temp[N_MON], temp[N_SHELL], temp[N_PIPE], temp[N_SHIELD], temp[N_MAN] = tm, tci, tcp, tcx, tman
    o[L.O_Q_CYL_J] += q_cyl * dt
    o[L.O_Q_EXHAUST_J] += q_ex * dt
    o[L.O_Q_TAILPIPE_J] += q_tail
    o[L.O_Q_EXOTHERM_J] += q_exo * dt if flow > 0.0 else 0.0
    o[L.O_Q_RADIATOR_J] += q_rad
    o[L.O_Q_AMBIENT_J] += q_amb
    o[L.O_HC_TP_G] += tp_hc * dt
    o[L.O_CO_TP_G] += tp_co * dt
    o[L.O_NOX_TP_G] += tp_nox * dt
    return tp_hc, tp_co, tp_nox


@njit(cache=True, inline="always")
def check_light_off(temp: np.ndarray, t: ThermalConfig, time_s: float, o: np.ndarray) -> None:
    """Record ``time_s`` as the light-off time the first time HC conversion reaches ``light_off_eff``."""
    o[L.O_T_CAT_MAX_C] = max(o[L.O_T_CAT_MAX_C], temp[N_MON])
    if o[L.O_T_LIGHT_OFF_S] < 0.0 and interp1(temp[N_MON], t.conv_t_c, t.conv_hc) >= t.light_off_eff:
        o[L.O_T_LIGHT_OFF_S] = time_s
