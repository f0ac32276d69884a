/* The node's fixed-point yaw filter (2-state indirect Kalman filter, thesis eqs 3.27-3.28 near vertical): the C
 * of firmware_model/fixed_kernel.py, nf_filter_predict = _predict_raw and nf_filter_update = _update_raw, step
 * by step with the same primitives (fixedpoint.h), the same parameter vector (fixed_kernel.kernel_params) and
 * the same overflow sites (fixed_kernel.SITES, in order). */
#ifndef NODESIM_YAW_FILTER_H
#define NODESIM_YAW_FILTER_H
#include <stdint.h>

/* state words */
#define NF_I_YAW 0
#define NF_I_BIAS 1
#define NF_I_PYY 2
#define NF_I_PYB 3
#define NF_I_PBB 4
/* parameter vector: (word, frac bits) of each format at 2 i, then (raw, frac, word bits) of each constant */
#define NF_W_YAW 0
#define NF_W_RATE 2
#define NF_W_BIAS 4
#define NF_W_YY 6
#define NF_W_YB 8
#define NF_W_BB 10
#define NF_W_INV 12
#define NF_W_KY 14
#define NF_W_KB 16
#define NF_W_INN 18
#define NF_C_KT 20
#define NF_C_2DT 23
#define NF_C_DT2 26
#define NF_C_QYY 29
#define NF_C_DT 32
#define NF_C_F 35
#define NF_C_F2 38
#define NF_C_QBB 41
#define NF_C_ONE 44
#define NF_C_360 47
#define NF_N_KERNEL_PARAMS 50
/* overflow sites */
#define NF_SITE_GYRO 0
#define NF_SITE_RATE_BIAS 1
#define NF_SITE_YAW_INC 2
#define NF_SITE_2DT_PYB 3
#define NF_SITE_PYY_PRED 4
#define NF_SITE_DT2_PBB 5
#define NF_SITE_DT_PBB 6
#define NF_SITE_PYB_PRED 7
#define NF_SITE_F2_PBB 8
#define NF_SITE_PBB_PRED 9
#define NF_SITE_REF_VAR 10
#define NF_SITE_S 11
#define NF_SITE_INV 12
#define NF_SITE_KY 13
#define NF_SITE_KB 14
#define NF_SITE_INNOV 15
#define NF_SITE_KY_Z 16
#define NF_SITE_KB_Z 17
#define NF_SITE_BIAS_UPD 18
#define NF_SITE_KY_PYY 19
#define NF_SITE_PYY_UPD 20
#define NF_SITE_KY_PYB 21
#define NF_SITE_PYB_UPD 22
#define NF_SITE_KB_PYB 23
#define NF_SITE_PBB_UPD 24
#define NF_N_FILTER_SITES 25

/* cdef-begin */
void nf_filter_predict(int64_t *state, int64_t rate_raw, const int64_t *params, int64_t *counts);
void nf_filter_update(int64_t *state, int64_t ref_raw, int64_t r_raw, const int64_t *params, int64_t *counts);
void nf_filter_run(int64_t *state, const int64_t *params, int64_t *counts, const int64_t *ops, int64_t n_ops,
                   int64_t *states_out);
int32_t nf_filter_layout(int32_t which);
/* cdef-end */

#endif
