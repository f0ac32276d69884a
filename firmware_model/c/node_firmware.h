/* The node firmware around its yaw filter (docs/firmware.md): the C of firmware_model/node_firmware.py, one
 * function per njit function of the same name, over the same int64 state, parameter, input and output vectors
 * (indices below = the Python module's constants). node_firmware_tick() is the one entry point per tick. */
#ifndef NODE_FIRMWARE_H
#define NODE_FIRMWARE_H
#include <stdint.h>

/* state words after the filter's five (yaw, bias, P_yy, P_yb, P_bb) */
#define NF_S_RUNNING 5
#define NF_S_BIAS_SUM 6
#define NF_S_BIAS_N 7
#define NF_S_LAST_RATE 8
#define NF_S_HAVE_LAST 9
#define NF_S_RATE 10
#define NF_STATE_WORDS 11
/* parameters */
#define NF_P_SENS 0
#define NF_P_SIG 1
#define NF_P_SIG_F 2
#define NF_P_OFF2 3
#define NF_P_ENC_VAR 4
#define NF_P_EXTRA 5
#define NF_P_DT_US 6
#define NF_P_P0_YY 7
#define NF_P_P0_BB 8
#define NF_P_SIG_D_F 9
/* phases and reference kinds */
#define NF_ABSENT 0
#define NF_STATIC 1
#define NF_START 2
#define NF_HOLD 3
#define NF_RUN 4
#define NF_NO_REF 0
#define NF_ENCODER_REF 1
#define NF_FORWARDED_REF 2
#define NF_DIRECT_REF 3
/* inputs and outputs */
#define NF_IN_PHASE 0
#define NF_IN_GZ 1
#define NF_IN_N 2
#define NF_IN_YAW0 3
#define NF_IN_REF 4
#define NF_IN_REF_YAW 5
#define NF_IN_REF_AUX 6
#define NF_IN_TRANSFER 7
#define NF_OUT_APPLIED 0
#define NF_OUT_REF 1
#define NF_OUT_R 2
#define NF_OUT_RATE 3

/* cdef-begin */
int32_t nf_abi_version(void);
void nf_init_lane(int64_t *state);
void node_firmware_tick(int64_t *state, const int64_t *params, const int64_t *fparams, int64_t *counts,
                        const int64_t *in, int64_t *out);
void node_firmware_run(int64_t *state, const int64_t *params, const int64_t *fparams, int64_t *counts,
                       const int64_t *inputs, int64_t *outputs, int64_t *states_out, int64_t n_ticks);
/* cdef-end */

#endif
