/* The node's 6-state fixed-point error-state filter (thesis eqs 3.21-3.31, issue 24): the C of
 * firmware_model/six_state_kernel.py, nf6_predict = predict_raw, nf6_update = update_raw, nf6_tilt = tilt_raw and
 * nf6_level = level_raw, step by step with the
 * same primitives (fixedpoint.h), CORDIC (cordic.h), parameter vector (six_state_fixed.SixStateFixedConfig.params)
 * and overflow sites (six_state_kernel.SITES, in order). The equations: firmware_model/six_state_fixed.py. */
#ifndef NODESIM_SIX_STATE_FILTER_H
#define NODESIM_SIX_STATE_FILTER_H
#include <stdint.h>

#define NF6_STATE_SIZE 46
#define NF6_I_ATT 0
#define NF6_I_BIAS 3
#define NF6_I_P 6
#define NF6_I_SING 42
#define NF6_I_B0 43 /* the start bias b_0 (x, y, z): the levelling's static test */
/* formats: (word, frac) at 2 i */
#define NF6_W_ANG 0
#define NF6_W_RATE 2
#define NF6_W_BIAS 4
#define NF6_W_RHO 6
#define NF6_W_RHO2 8
#define NF6_W_SER 10
#define NF6_W_UNIT 12
#define NF6_W_TR 14
#define NF6_W_GS 16
#define NF6_W_AA 18
#define NF6_W_AB 20
#define NF6_W_BB 22
#define NF6_W_INV 24
#define NF6_W_KA 26
#define NF6_W_KB 28
#define NF6_W_INN 30
#define NF6_W_LSIG 32
/* constants: (raw, frac, word) */
#define NF6_C_DTR 34
#define NF6_C_DT 37
#define NF6_C_F 40
#define NF6_C_QB 49
#define NF6_C_SV 58
#define NF6_C_360 67
#define NF6_C_LSIG 70
#define NF6_T_SERIES 73
#define NF6_SERIES_TERMS 13
#define NF6_P_ITER 112
#define NF6_P_DECOUPLE 113
#define NF6_P_SINM 114
#define NF6_P_COSM 115
#define NF6_P_ONE_U 116
#define NF6_P_ONE_T 117
#define NF6_P_DT_T 118
#define NF6_P_LEVEL 119
#define NF6_P_LEVEL_RATE 120
#define NF6_N_PARAMS 121
#define NF6_YAW_ONLY 1
#define NF6_ALL_AXES 3
#define NF6_ROLL_PITCH 4
#define NF6_PITCH_ONLY 5
#define NF6_LEVEL_OP 8 /* nf6_run: the levelling op */
#define NF6_LEVEL_DIFF_LIMIT ((int64_t)1 << 30)
/* overflow sites */
enum {
    NF6_S_GYRO, NF6_S_RATE_BIAS, NF6_S_RHO, NF6_S_RHO2, NF6_S_SERIES, NF6_S_EXP, NF6_S_JR, NF6_S_EXPH, NF6_S_DCM,
    NF6_S_INVC, NF6_S_E, NF6_S_PHI11, NF6_S_PHI12, NF6_S_GC, NF6_S_GS, NF6_S_QD, NF6_S_PHIP, NF6_S_PPRED,
    NF6_S_REF_VAR, NF6_S_S, NF6_S_INV, NF6_S_K, NF6_S_INNOV, NF6_S_KZ, NF6_S_PUPD, NF6_S_BIAS_UPD, NF6_S_LSIG, NF6_S_LR,
    NF6_N_SITES
};

/* cdef-begin */
void nf6_predict(int64_t *state, const int64_t *rate_raw, const int64_t *params, int64_t *counts);
void nf6_update(int64_t *state, int64_t axes, const int64_t *ref_raw, const int64_t *var_raw, const int64_t *params,
                int64_t *counts);
void nf6_tilt(int64_t fx, int64_t fy, int64_t fz, int32_t iterations, int64_t *out4);
int64_t nf6_level(int64_t *state, const int64_t *rate_raw, const int64_t *accel_sum, int64_t n_samples,
                  const int64_t *params, int64_t *counts);
void nf6_run(int64_t *state, const int64_t *params, int64_t *counts, const int64_t *ops, int64_t n_ops,
             int64_t *states_out);
int32_t nf6_layout(int32_t which);
/* cdef-end */

#endif
