/* Survey resolution (thesis eqs 1.1-1.3) and the N-point moving average: the C of firmware_model/node_survey.py
 * (docstring there), bit for bit. Modes: SURVEY_MODE_CORDIC (integer CORDIC, the default) or SURVEY_MODE_FPU
 * (single-precision float: atan2f, sqrtf, rintf). Words: I in [0, 2^31], A in [0, 2^32) (2^32 = one turn).
 * State (firmware_model.node_survey.MA_STATE): int64 words count, head, sum_I, prev_yaw, align, al_count, al_head,
 * al_sum_x, al_sum_y, max_x, min_x, max_y, min_y, off_x, off_y, then the rings of I, A, M_x, M_y (N words each).
 * survey_tick(): mid-window yaw, alignment offset (thesis sec 4.2.3), resolution, average (docstring there).
 * Return codes: 0 ok, -2 an input beyond 2^62, -3 bad mode, -4 points < 1, -5 n < 1, -6 an alignment sum beyond
 * 2^40, -7 offset x n beyond 2^62 (the model raises FirmwareError). */
#ifndef NODESIM_SURVEY_H
#define NODESIM_SURVEY_H
#include <stdint.h>

#define SURVEY_MODE_CORDIC 0
#define SURVEY_MODE_FPU 1
#define SURVEY_NORM_BITS 28
#define SURVEY_MA_COUNT 0
#define SURVEY_MA_HEAD 1
#define SURVEY_MA_SUM_I 2
#define SURVEY_MA_PREV_YAW 3
#define SURVEY_AL_PHASE 4
#define SURVEY_AL_COUNT 5
#define SURVEY_AL_HEAD 6
#define SURVEY_AL_SUM_X 7
#define SURVEY_AL_SUM_Y 8
#define SURVEY_AL_MAX_X 9
#define SURVEY_AL_MIN_X 10
#define SURVEY_AL_MAX_Y 11
#define SURVEY_AL_MIN_Y 12
#define SURVEY_AL_OFF_X 13
#define SURVEY_AL_OFF_Y 14
#define SURVEY_MA_RING 15
#define SURVEY_ALIGN_IDLE 0
#define SURVEY_ALIGN_COLLECTING 1
#define SURVEY_ALIGN_APPLIED 2
#define SURVEY_ALIGN_FRAC 8

/* cdef-begin */
int64_t survey_yaw_to_ba32(int64_t yaw_raw, int32_t yaw_frac_bits);
int32_t survey_resolve(int64_t fx, int64_t fy, int64_t fz, int64_t yaw32, int32_t mode, int32_t iterations,
                       int64_t *inc, int64_t *azi);
void survey_ma_reset(int64_t *state);
void survey_ma_push(int64_t *state, int32_t points, int64_t inc, int64_t azi, int64_t *inc_avg, int64_t *azi_avg);
int32_t survey_tick(int64_t *state, int32_t points, int64_t fx, int64_t fy, int64_t fz, int64_t n, int64_t yaw32,
                    int32_t aligning, int32_t mode, int32_t iterations, int64_t *inc_avg, int64_t *azi_avg);
int32_t survey_run(const int64_t *accel, const int64_t *yaw_raw, const int64_t *samples, int64_t n_ticks,
                   int64_t align_lo, int64_t align_hi, int32_t points, int32_t mode, int32_t iterations,
                   int32_t yaw_frac_bits, int64_t *state, int64_t *inc_out, int64_t *azi_out);
/* cdef-end */

#endif
