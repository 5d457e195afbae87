"""Column layout of the per-design accumulators and traces the drive kernels fill.

Module-level integers are compile-time constants for numba. Energies in J, masses in g, distances
in m. The energy terms close the balance

    E_FUEL + E_BATT = E_LOSS_ENG + E_LOSS_MOT + E_LOSS_GEN + E_LOSS_PG + E_LOSS_FD + E_LOSS_GB
                      + E_LOSS_CLUTCH + E_LOSS_BATT + E_ACC + E_BRAKE + E_ROAD + E_GRADE + E_KIN_END
                      + E_MISMATCH

(E_BATT: net chemical energy drawn from the battery; E_MISMATCH: what a force-limited step's fixed
point left unresolved, reported so the tests can bound it). E_ACC is the accessory energy actually
served; what the accessories asked for and no source could give is E_ACC_UNMET (never silently
dropped: it is reported as ``accessory_unmet_kwh`` and fails the cycle).
"""

# ---- accumulated results per design
(O_FUEL_G, O_HC_G, O_CO_G, O_NOX_G, O_DIST_M, O_DIST_REF_M, O_SPEED_ERR_SUM, O_N_STEPS, O_ACC_SHORT,
 O_ACC_REQ, O_SOC_END, O_MAX_SPEED_ERR, O_E_FUEL, O_E_BATT, O_E_ENG_SHAFT, O_E_LOSS_ENG, O_E_LOSS_MOT,
 O_E_LOSS_GEN, O_E_LOSS_PG, O_E_LOSS_FD, O_E_LOSS_GB, O_E_LOSS_CLUTCH, O_E_LOSS_BATT, O_E_ACC,
 O_E_BRAKE, O_E_ROAD, O_E_GRADE, O_E_KIN_END, O_E_MISMATCH, O_E_TRACTION, O_E_REGEN, O_ENG_ON_STEPS,
 O_N_STARTS, O_SOC_MIN_SEEN, O_SOC_MAX_SEEN, O_LIMIT_VIOLATIONS, O_E_ACC_UNMET, O_E_GEN_ELEC_OUT,
 O_E_GEN_MECH_IN, O_N_LIMITED, O_OFF_TRACE_S, O_STUCK_NOW_S, O_STUCK_MAX_S, O_ENG_SPUN_STEPS) = range(44)
N_O = 44
OUT_NAMES = (
    "fuel_g", "hc_g", "co_g", "nox_g", "dist_m", "dist_ref_m", "speed_err_sum_mps", "n_steps",
    "acc_short_sum_mps2", "acc_req_sum_mps2", "soc_end", "max_speed_err_mps", "e_fuel_j", "e_batt_j",
    "e_eng_shaft_j", "e_loss_eng_j", "e_loss_mot_j", "e_loss_gen_j", "e_loss_pg_j", "e_loss_fd_j",
    "e_loss_gb_j", "e_loss_clutch_j", "e_loss_batt_j", "e_acc_j", "e_brake_j", "e_road_j", "e_grade_j",
    "e_kin_end_j", "e_mismatch_j", "e_traction_j", "e_regen_j", "eng_on_steps", "n_starts", "soc_min_seen",
    "soc_max_seen", "limit_violations", "e_acc_unmet_j", "e_gen_elec_out_j", "e_gen_mech_in_j", "n_limited",
    "off_trace_s", "stuck_now_s", "stuck_max_s", "eng_spun_steps",
)
#: Sinks of the energy balance (sources: e_fuel_j + e_batt_j).
BALANCE_SINKS = ("e_loss_eng_j", "e_loss_mot_j", "e_loss_gen_j", "e_loss_pg_j", "e_loss_fd_j", "e_loss_gb_j",
                 "e_loss_clutch_j", "e_loss_batt_j", "e_acc_j", "e_brake_j", "e_road_j", "e_grade_j",
                 "e_kin_end_j", "e_mismatch_j")

# ---- trace channels (one row per time step, recorded designs only)
(T_V_REF, T_V, T_SOC, T_W_E, T_T_E, T_W_M, T_T_M, T_W_G, T_T_G, T_P_BATT, T_FUEL, T_ENG_ON, T_F_PT,
 T_F_BRK, T_GEAR, T_A_REQ, T_A_ACH, T_P_MOT_E, T_P_GEN_E, T_T_E_MAX, T_T_M_MAX, T_T_G_MAX, T_GRADE,
 T_P_ACC_UNMET, T_M_EFF) = range(25)
N_T = 25
TRACE_NAMES = ("v_ref_mps", "v_mps", "soc", "w_eng_rad_s", "t_eng_nm", "w_mot_rad_s", "t_mot_nm",
               "w_gen_rad_s", "t_gen_nm", "p_batt_w", "fuel_g_s", "eng_on", "f_pt_n", "f_brake_n", "gear",
               "a_req_mps2", "a_ach_mps2", "p_mot_elec_w", "p_gen_elec_w", "t_eng_max_nm", "t_mot_max_nm",
               "t_gen_max_nm", "grade", "p_acc_unmet_w", "m_eff_kg")
