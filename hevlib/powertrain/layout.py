"""Column layout of the arrays the numba kernels exchange with Python.

Kernels take one float64 row per design (``D_*``), one shared config vector (``C_*``), and fill one
row of accumulated results per design (``O_*``) and, for recorded designs, a trace (``T_*``).
Module-level integers are compile-time constants for numba.
"""

# ---- per-design row
D_S_ENG, D_S_MOT, D_S_GEN, D_I0, D_N_BAT, D_N_R, D_N_S, D_MASS = range(8)
D_CDA, D_CRR, D_RADIUS, D_CG_H, D_WHEELBASE, D_F_FRONT, D_F_MAX_DESIGN, D_S_BAT = range(8, 16)
N_D = 16

# ---- shared config
(C_DT, C_MASS_FACTOR, C_MU, C_RHO, C_G, C_SOC_INIT, C_SOC_MIN, C_SOC_MAX, C_ETA_PG, C_ETA_FD,
 C_I_PACK_MAX, C_REGEN_MAX, C_P_ACC_E, C_P_ACC_M, C_LHV, C_AXLE0, C_AXLE_PER_KG, C_W_E_MIN_ON,
 C_W_E_MAX, C_W_M_MAX, C_W_G_MAX, C_CAP_AS, C_ETA_C, C_V_MIN_MOD, C_V_MAX_MOD,
 C_SOC_LOW_V, C_SOC_LOW_W, C_SOC_HIGH_V, C_SOC_HIGH_W, C_GRADE_LOW_V, C_GRADE_LOW_W, C_GRADE_HIGH_V,
 C_GRADE_HIGH_W, C_SPEED_HIGH_V, C_SPEED_HIGH_W, C_TQ_LOW_V, C_TQ_LOW_W, C_TQ_HIGH_V, C_TQ_HIGH_W,
 C_ON_THRESHOLD, C_MIN_ON_S, C_MIN_OFF_S, C_P_MIN_W, C_CHARGE_FRAC, C_SOC_TARGET,
 C_W_IDLE, C_W_LAUNCH, C_GB_A, C_GB_B, C_GB_C, C_GB_D, C_GB_E, C_GB_F, C_P_ENG_BASE_W) = range(54)
N_C = 54

# ---- accumulated results per design
(O_FUEL_G, O_HC_G, O_CO_G, O_NOX_G, O_DIST_M, O_DIST_REF_M, O_SPEED_ERR_SUM, O_N_STEPS, O_ACC_SHORT,
 O_ACC_REQ, O_SOC_END, O_MAX_SPEED_ERR, O_E_FUEL, O_E_BATT, O_E_TRAC_POS, O_E_WHEEL_PT, O_E_BRAKE,
 O_E_ROAD, O_E_KIN_END, O_E_LOSS_ENG, O_E_LOSS_MOT, O_E_LOSS_GEN, O_E_LOSS_PG, O_E_LOSS_FD,
 O_E_LOSS_BATT, O_E_ACC, O_E_LOSS_GB, O_E_ENG_SHAFT, O_ENG_ON_STEPS, O_N_STARTS, O_SOC_MIN_SEEN,
 O_SOC_MAX_SEEN, O_E_MISMATCH, O_LIMIT_VIOLATIONS) = range(34)
N_O = 34

# ---- trace channels
(T_VREF, T_V, T_SOC, T_W_E, T_T_E, T_W_M, T_T_M, T_W_G, T_T_G, T_P_BATT, T_FUEL, T_ENG_ON, T_F_PT,
 T_F_BRK, T_GEAR, T_A_REQ, T_A_ACH, T_P_MOT_E, T_P_GEN_E, T_T_E_MAX, T_T_M_MAX, T_T_G_MAX) = range(22)
N_T = 22
TRACE_NAMES = ("v_ref_mps", "v_mps", "soc", "w_eng_rad_s", "t_eng_nm", "w_mot_rad_s", "t_mot_nm",
               "w_gen_rad_s", "t_gen_nm", "p_batt_w", "fuel_g_s", "eng_on", "f_pt_n", "f_brake_n", "gear",
               "a_req_mps2", "a_ach_mps2", "p_mot_elec_w", "p_gen_elec_w", "t_eng_max_nm", "t_mot_max_nm",
               "t_gen_max_nm")
