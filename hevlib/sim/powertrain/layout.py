"""Column layout of the per-design accumulators and traces the drive kernels fill.

Module-level integers are compile-time constants for numba. Energies in J, masses in g, distances
in m. The energy terms close the balance

    E_FUEL + E_BATT = E_LOSS_ENG + E_LOSS_MOT + E_LOSS_GEN + E_LOSS_PG + E_LOSS_FD + E_LOSS_GB
                      + E_LOSS_CLUTCH + E_LOSS_BATT + E_ACC + E_BRAKE + E_ROAD + E_GRADE + E_KIN_END
                      + E_MISMATCH + E_ENGINE_START + E_ENGINE_INERTIA

(E_BATT: net chemical energy drawn from the battery; E_MISMATCH: what a force-limited step's fixed
point left unresolved, reported so the tests can bound it). E_ACC is the accessory energy actually
served; what the accessories asked for and no source could give is E_ACC_UNMET (never silently
dropped: it is reported as ``accessory_unmet_kwh`` and fails the cycle). E_ENGINE_START is what the
power-split car's starts cost at the carrier: the spin-up of the carrier's inertia from its speed to firing
speed plus the crank work on the way, from the battery through the generator; the carrier's kinetic energy
runs down in the engine's friction when it stops (not recovered), so it is a sink. E_ENGINE_INERTIA is the
engine's work on the running carrier's inertia as its speed moves (the share of its torque the gear set does
not get; negative when the inertia gives it back), booked at each step's speed. E_SHAFT_FUELLED is the shaft work of
fuelled steps only (the numerator of the fuel-weighted mean engine efficiency). E_FUEL_COLD is the part of
E_FUEL a cold engine burns above its hot map (the cold-engine factor's surplus); it is in E_LOSS_ENG but, as in
ADVISOR, heats nothing: the thermal nodes get the hot map's waste heat and exhaust flow.
"""

# ---- accumulated results per design: the names define the columns (each O_* is its name's index, a
# module-level int numba reads as a compile-time constant), so no second list can drift from them
OUT_NAMES = (
    "fuel_g",
    "hc_g",
    "co_g",
    "nox_g",
    "dist_m",
    "dist_ref_m",
    "speed_err_sum_mps",
    "n_steps",
    "acc_short_sum_mps2",
    "acc_req_sum_mps2",
    "soc_end",
    "max_speed_err_mps",
    "e_fuel_j",
    "e_batt_j",
    "e_eng_shaft_j",
    "e_loss_eng_j",
    "e_loss_mot_j",
    "e_loss_gen_j",
    "e_loss_pg_j",
    "e_loss_fd_j",
    "e_loss_gb_j",
    "e_loss_clutch_j",
    "e_loss_batt_j",
    "e_acc_j",
    "e_brake_j",
    "e_road_j",
    "e_grade_j",
    "e_kin_end_j",
    "e_mismatch_j",
    "e_traction_j",
    "e_regen_j",
    "eng_on_steps",
    "n_starts",
    "soc_min_seen",
    "soc_max_seen",
    "limit_violations",
    "e_acc_unmet_j",
    "e_gen_elec_out_j",
    "e_gen_mech_in_j",
    "n_limited",
    "off_trace_s",
    "stuck_now_s",
    "stuck_max_s",
    "eng_spun_steps",
    "hc_tailpipe_g",
    "co_tailpipe_g",
    "nox_tailpipe_g",
    "t_cat_light_off_s",
    "q_cyl_j",
    "q_exhaust_j",
    "q_tailpipe_j",
    "q_exotherm_j",
    "q_radiator_j",
    "q_ambient_j",
    "u_thermal_start_j",
    "u_thermal_end_j",
    "t_coolant_end_c",
    "t_cat_end_c",
    "t_cat_max_c",
    "e_engine_start_j",
    "e_shaft_fuelled_j",
    "acc_abs_err_sum_mps2",
    "acc_req_max_mps2",
    "e_fuel_cold_surplus_j",
)
N_O = len(OUT_NAMES)
assert len(set(OUT_NAMES)) == N_O, "a column name twice"
O_FUEL_G = OUT_NAMES.index("fuel_g")
O_HC_G = OUT_NAMES.index("hc_g")
O_CO_G = OUT_NAMES.index("co_g")
O_NOX_G = OUT_NAMES.index("nox_g")
O_DIST_M = OUT_NAMES.index("dist_m")
O_DIST_REF_M = OUT_NAMES.index("dist_ref_m")
O_SPEED_ERR_SUM = OUT_NAMES.index("speed_err_sum_mps")
O_N_STEPS = OUT_NAMES.index("n_steps")
O_ACC_SHORT = OUT_NAMES.index("acc_short_sum_mps2")
O_ACC_REQ = OUT_NAMES.index("acc_req_sum_mps2")
O_SOC_END = OUT_NAMES.index("soc_end")
O_MAX_SPEED_ERR = OUT_NAMES.index("max_speed_err_mps")
O_E_FUEL = OUT_NAMES.index("e_fuel_j")
O_E_BATT = OUT_NAMES.index("e_batt_j")
O_E_ENG_SHAFT = OUT_NAMES.index("e_eng_shaft_j")
O_E_LOSS_ENG = OUT_NAMES.index("e_loss_eng_j")
O_E_LOSS_MOT = OUT_NAMES.index("e_loss_mot_j")
O_E_LOSS_GEN = OUT_NAMES.index("e_loss_gen_j")
O_E_LOSS_PG = OUT_NAMES.index("e_loss_pg_j")
O_E_LOSS_FD = OUT_NAMES.index("e_loss_fd_j")
O_E_LOSS_GB = OUT_NAMES.index("e_loss_gb_j")
O_E_LOSS_CLUTCH = OUT_NAMES.index("e_loss_clutch_j")
O_E_LOSS_BATT = OUT_NAMES.index("e_loss_batt_j")
O_E_ACC = OUT_NAMES.index("e_acc_j")
O_E_BRAKE = OUT_NAMES.index("e_brake_j")
O_E_ROAD = OUT_NAMES.index("e_road_j")
O_E_GRADE = OUT_NAMES.index("e_grade_j")
O_E_KIN_END = OUT_NAMES.index("e_kin_end_j")
O_E_MISMATCH = OUT_NAMES.index("e_mismatch_j")
O_E_TRACTION = OUT_NAMES.index("e_traction_j")
O_E_REGEN = OUT_NAMES.index("e_regen_j")
O_ENG_ON_STEPS = OUT_NAMES.index("eng_on_steps")
O_N_STARTS = OUT_NAMES.index("n_starts")
O_SOC_MIN_SEEN = OUT_NAMES.index("soc_min_seen")
O_SOC_MAX_SEEN = OUT_NAMES.index("soc_max_seen")
O_LIMIT_VIOLATIONS = OUT_NAMES.index("limit_violations")
O_E_ACC_UNMET = OUT_NAMES.index("e_acc_unmet_j")
O_E_GEN_ELEC_OUT = OUT_NAMES.index("e_gen_elec_out_j")
O_E_GEN_MECH_IN = OUT_NAMES.index("e_gen_mech_in_j")
O_N_LIMITED = OUT_NAMES.index("n_limited")
O_OFF_TRACE_S = OUT_NAMES.index("off_trace_s")
O_STUCK_NOW_S = OUT_NAMES.index("stuck_now_s")
O_STUCK_MAX_S = OUT_NAMES.index("stuck_max_s")
O_ENG_SPUN_STEPS = OUT_NAMES.index("eng_spun_steps")
O_HC_TP_G = OUT_NAMES.index("hc_tailpipe_g")
O_CO_TP_G = OUT_NAMES.index("co_tailpipe_g")
O_NOX_TP_G = OUT_NAMES.index("nox_tailpipe_g")
O_T_LIGHT_OFF_S = OUT_NAMES.index("t_cat_light_off_s")
O_Q_CYL_J = OUT_NAMES.index("q_cyl_j")
O_Q_EXHAUST_J = OUT_NAMES.index("q_exhaust_j")
O_Q_TAILPIPE_J = OUT_NAMES.index("q_tailpipe_j")
O_Q_EXOTHERM_J = OUT_NAMES.index("q_exotherm_j")
O_Q_RADIATOR_J = OUT_NAMES.index("q_radiator_j")
O_Q_AMBIENT_J = OUT_NAMES.index("q_ambient_j")
O_U_THERMAL_START_J = OUT_NAMES.index("u_thermal_start_j")
O_U_THERMAL_END_J = OUT_NAMES.index("u_thermal_end_j")
O_T_COOLANT_END_C = OUT_NAMES.index("t_coolant_end_c")
O_T_CAT_END_C = OUT_NAMES.index("t_cat_end_c")
O_T_CAT_MAX_C = OUT_NAMES.index("t_cat_max_c")
O_E_ENGINE_START = OUT_NAMES.index("e_engine_start_j")
O_E_SHAFT_FUELLED = OUT_NAMES.index("e_shaft_fuelled_j")
O_ACC_ABS_ERR = OUT_NAMES.index("acc_abs_err_sum_mps2")
O_ACC_REQ_MAX = OUT_NAMES.index("acc_req_max_mps2")
O_E_FUEL_COLD = OUT_NAMES.index("e_fuel_cold_surplus_j")
#: Heat balance of the thermal nodes (hevlib.sim.powertrain.thermal): stored heat change = sources - sinks.
THERMAL_SOURCES = ("q_cyl_j", "q_exhaust_j", "q_exotherm_j")
THERMAL_SINKS = ("q_tailpipe_j", "q_radiator_j", "q_ambient_j")
#: Sinks of the energy balance (sources: e_fuel_j + e_batt_j).
BALANCE_SINKS = (
    "e_loss_eng_j",
    "e_loss_mot_j",
    "e_loss_gen_j",
    "e_loss_pg_j",
    "e_loss_fd_j",
    "e_loss_gb_j",
    "e_loss_clutch_j",
    "e_loss_batt_j",
    "e_acc_j",
    "e_brake_j",
    "e_road_j",
    "e_grade_j",
    "e_kin_end_j",
    "e_mismatch_j",
    "e_engine_start_j",
)

# ---- trace channels (one row per time step, recorded designs only): T_* as O_* above
TRACE_NAMES = (
    "v_ref_mps",
    "v_mps",
    "soc",
    "w_eng_rad_s",
    "t_eng_nm",
    "w_mot_rad_s",
    "t_mot_nm",
    "w_gen_rad_s",
    "t_gen_nm",
    "p_batt_w",
    "fuel_g_s",
    "eng_on",
    "f_pt_n",
    "f_brake_n",
    "gear",
    "a_req_mps2",
    "a_ach_mps2",
    "p_mot_elec_w",
    "p_gen_elec_w",
    "t_eng_max_nm",
    "t_mot_max_nm",
    "t_gen_max_nm",
    "grade",
    "p_acc_unmet_w",
    "m_eff_kg",
    "t_coolant_c",
    "t_cat_c",
    "hc_engine_out_g_s",
    "co_engine_out_g_s",
    "nox_engine_out_g_s",
    "hc_tailpipe_g_s",
    "co_tailpipe_g_s",
    "nox_tailpipe_g_s",
    "p_engine_start_w",
    # a split step's spin-up part (hevlib.sim.drive): its length (0: none; the channels above are then the step's,
    # else the rest of the step's, but for p_batt_w, fuel_g_s, f_pt_n and p_engine_start_w: the step's means),
    # and the engine's (unfuelled: 0 unless the gear set spins it; the spin-up's own work is p_engine_start_w's),
    # motor's, generator's and wheels' state in it
    "spin_part_s",
    "spin_w_eng_rad_s",
    "spin_t_eng_nm",
    "spin_t_mot_nm",
    "spin_p_mot_elec_w",
    "spin_w_gen_rad_s",
    "spin_t_gen_nm",
    "spin_p_gen_elec_w",
    "spin_f_pt_n",
)
N_T = len(TRACE_NAMES)
assert len(set(TRACE_NAMES)) == N_T, "a channel name twice"
T_V_REF = TRACE_NAMES.index("v_ref_mps")
T_V = TRACE_NAMES.index("v_mps")
T_SOC = TRACE_NAMES.index("soc")
T_W_E = TRACE_NAMES.index("w_eng_rad_s")
T_T_E = TRACE_NAMES.index("t_eng_nm")
T_W_M = TRACE_NAMES.index("w_mot_rad_s")
T_T_M = TRACE_NAMES.index("t_mot_nm")
T_W_G = TRACE_NAMES.index("w_gen_rad_s")
T_T_G = TRACE_NAMES.index("t_gen_nm")
T_P_BATT = TRACE_NAMES.index("p_batt_w")
T_FUEL = TRACE_NAMES.index("fuel_g_s")
T_ENG_ON = TRACE_NAMES.index("eng_on")
T_F_PT = TRACE_NAMES.index("f_pt_n")
T_F_BRK = TRACE_NAMES.index("f_brake_n")
T_GEAR = TRACE_NAMES.index("gear")
T_A_REQ = TRACE_NAMES.index("a_req_mps2")
T_A_ACH = TRACE_NAMES.index("a_ach_mps2")
T_P_MOT_E = TRACE_NAMES.index("p_mot_elec_w")
T_P_GEN_E = TRACE_NAMES.index("p_gen_elec_w")
T_T_E_MAX = TRACE_NAMES.index("t_eng_max_nm")
T_T_M_MAX = TRACE_NAMES.index("t_mot_max_nm")
T_T_G_MAX = TRACE_NAMES.index("t_gen_max_nm")
T_GRADE = TRACE_NAMES.index("grade")
T_P_ACC_UNMET = TRACE_NAMES.index("p_acc_unmet_w")
T_M_EFF = TRACE_NAMES.index("m_eff_kg")
T_T_COOLANT = TRACE_NAMES.index("t_coolant_c")
T_T_CAT = TRACE_NAMES.index("t_cat_c")
T_HC_EO = TRACE_NAMES.index("hc_engine_out_g_s")
T_CO_EO = TRACE_NAMES.index("co_engine_out_g_s")
T_NOX_EO = TRACE_NAMES.index("nox_engine_out_g_s")
T_HC_TP = TRACE_NAMES.index("hc_tailpipe_g_s")
T_CO_TP = TRACE_NAMES.index("co_tailpipe_g_s")
T_NOX_TP = TRACE_NAMES.index("nox_tailpipe_g_s")
T_P_ENGINE_START = TRACE_NAMES.index("p_engine_start_w")
T_SPIN_PART_S = TRACE_NAMES.index("spin_part_s")
T_SPIN_W_ENG = TRACE_NAMES.index("spin_w_eng_rad_s")
T_SPIN_T_ENG = TRACE_NAMES.index("spin_t_eng_nm")
T_SPIN_T_MOT = TRACE_NAMES.index("spin_t_mot_nm")
T_SPIN_P_MOT_E = TRACE_NAMES.index("spin_p_mot_elec_w")
T_SPIN_W_GEN = TRACE_NAMES.index("spin_w_gen_rad_s")
T_SPIN_T_GEN = TRACE_NAMES.index("spin_t_gen_nm")
T_SPIN_P_GEN_E = TRACE_NAMES.index("spin_p_gen_elec_w")
T_SPIN_F_PT = TRACE_NAMES.index("spin_f_pt_n")
