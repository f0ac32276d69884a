/* Survey resolution (thesis eqs 1.1-1.3) and the N-point moving average: the C of firmware_model/node_survey.py
 * (docstring there), bit for bit. Modes: SURVEY_MODE_CORDIC (integer CORDIC, the default) or SURVEY_MODE_FPU
 * (single-precision float: atan2f, sqrtf, rintf). Words: I in [0, 2^31], A in [0, 2^32) (2^32 = one turn).
 * Moving-average state: int64 words count, head, sum_I, then the I ring and the A ring (N words each). */
#ifndef NODESIM_SURVEY_H
#define NODESIM_SURVEY_H
#include <stdint.h>

#define SURVEY_MODE_CORDIC 0
#define SURVEY_MODE_FPU 1
#define SURVEY_NORM_BITS 28
#define SURVEY_MA_COUNT 0
#define SURVEY_MA_HEAD 1
#define SURVEY_MA_SUM_I 2
#define SURVEY_MA_RING 3

/* cdef-begin */
int64_t survey_yaw_to_ba32(int64_t yaw_raw, int32_t yaw_frac_bits);
int32_t survey_resolve(int64_t fx, int64_t fy, int64_t fz, int64_t yaw32, int32_t mode, int32_t iterations,
                       int64_t *inc, int64_t *azi);
void survey_ma_reset(int64_t *state);
void survey_ma_push(int64_t *state, int32_t points, int64_t inc, int64_t azi, int64_t *inc_avg, int64_t *azi_avg);
int32_t survey_run(const int64_t *accel, const int64_t *yaw_raw, int64_t n_ticks, int32_t points, int32_t mode,
                   int32_t iterations, int32_t yaw_frac_bits, int64_t *state, int64_t *inc_out, int64_t *azi_out);
/* cdef-end */

#endif
