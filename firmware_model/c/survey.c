/* Survey resolution and moving average (firmware_model/node_survey.py, bit for bit). */
#include <math.h>
#include "cordic.h"
#include "fixedpoint.h"
#include "survey.h"

#define SURVEY_MASK32 ((int64_t)0xFFFFFFFF)

int64_t survey_yaw_to_ba32(int64_t yaw_raw, int32_t yaw_frac_bits)
{
    int64_t y;
    if (yaw_frac_bits <= 32) y = (int64_t)((uint64_t)yaw_raw << (32 - yaw_frac_bits));
    else y = fx_shift_round(yaw_raw, yaw_frac_bits - 32);
    return y & SURVEY_MASK32;
}

static int32_t survey_resolve_cordic(int64_t fx, int64_t fy, int64_t fz, int64_t yaw32, int32_t iterations,
                                     int64_t *inc, int64_t *azi)
{
    int64_t ax = fx < 0 ? -fx : fx, ay = fy < 0 ? -fy : fy, az = fz < 0 ? -fz : fz, m, toolface, h, i_raw, unused;
    int32_t rc;
    m = ax > ay ? ax : ay;
    m = m > az ? m : az;
    if (m > (int64_t)(((uint64_t)1 << 62) - 1)) return -2;
    if (m > 0) {
        const int32_t s = cordic_norm_shift(m, SURVEY_NORM_BITS);
        fx = cordic_shift(fx, s);
        fy = cordic_shift(fy, s);
        fz = cordic_shift(fz, s);
    }
    rc = cordic_vectoring(fx, fy, iterations, &toolface, &h);
    if (rc != 0) return rc;
    rc = cordic_vectoring(fz, h, iterations, &i_raw, &unused);
    if (rc != 0) return rc;
    *inc = i_raw < 0 ? -i_raw : i_raw;
    *azi = (toolface + yaw32) & SURVEY_MASK32;
    return 0;
}

static void survey_resolve_fpu(int64_t fx, int64_t fy, int64_t fz, int64_t yaw32, int64_t *inc, int64_t *azi)
{
    const float k = 683565275.57643158f; /* float32(2^32 / (2 pi)) */
    const float x = (float)fx, y = (float)fy, z = (float)fz;
    const float toolface = atan2f(y, x);
    const float h = sqrtf(x * x + y * y);
    const float i_rad = atan2f(h, z);
    const int64_t tf_raw = (int64_t)rintf(toolface * k);
    *inc = (int64_t)rintf(i_rad * k);
    *azi = (tf_raw + yaw32) & SURVEY_MASK32;
}

int32_t survey_resolve(int64_t fx, int64_t fy, int64_t fz, int64_t yaw32, int32_t mode, int32_t iterations,
                       int64_t *inc, int64_t *azi)
{
    if (mode == SURVEY_MODE_CORDIC) return survey_resolve_cordic(fx, fy, fz, yaw32, iterations, inc, azi);
    if (mode == SURVEY_MODE_FPU) {
        survey_resolve_fpu(fx, fy, fz, yaw32, inc, azi);
        return 0;
    }
    return -3;
}

void survey_ma_reset(int64_t *state)
{
    int32_t i;
    for (i = 0; i < SURVEY_MA_RING; i++) state[i] = 0;
    state[SURVEY_MA_PREV_YAW] = -1;
}

void survey_ma_push(int64_t *state, int32_t points, int64_t inc, int64_t azi, int64_t *inc_avg, int64_t *azi_avg)
{
    const int64_t head = state[SURVEY_MA_HEAD];
    int64_t *ring_i = state + SURVEY_MA_RING, *ring_a = state + SURVEY_MA_RING + points;
    int64_t n, d = 0, j;
    if (state[SURVEY_MA_COUNT] == points) state[SURVEY_MA_SUM_I] -= ring_i[head];
    else state[SURVEY_MA_COUNT] += 1;
    ring_i[head] = inc;
    ring_a[head] = azi;
    state[SURVEY_MA_SUM_I] += inc;
    state[SURVEY_MA_HEAD] = (head + 1) % points;
    n = state[SURVEY_MA_COUNT];
    for (j = 0; j < n; j++) d += cordic_wrap32(ring_a[j] - azi);
    *inc_avg = fx_div_round(state[SURVEY_MA_SUM_I], n);
    *azi_avg = (azi + fx_div_round(d, n)) & SURVEY_MASK32;
}

static int64_t survey_mid_yaw(int64_t *state, int64_t yaw32)
{
    const int64_t prev = state[SURVEY_MA_PREV_YAW];
    state[SURVEY_MA_PREV_YAW] = yaw32;
    if (prev < 0) return yaw32;
    return (prev + fx_shift_round(cordic_wrap32(yaw32 - prev), 1)) & SURVEY_MASK32;
}

static int64_t survey_abs(int64_t x) { return x < 0 ? -x : x; }

static int32_t survey_align_collect(int64_t *state, int32_t points, int64_t fx, int64_t fy, int64_t n)
{
    const int64_t lim = (int64_t)1 << 40, head = state[SURVEY_AL_HEAD];
    int64_t *rx = state + SURVEY_MA_RING + 2 * (int64_t)points, *ry = state + SURVEY_MA_RING + 3 * (int64_t)points;
    int64_t mx, my, ax, ay;
    if (survey_abs(fx) > lim || survey_abs(fy) > lim) return -6;
    mx = fx_div_round(fx * ((int64_t)1 << SURVEY_ALIGN_FRAC), n);
    my = fx_div_round(fy * ((int64_t)1 << SURVEY_ALIGN_FRAC), n);
    if (state[SURVEY_AL_COUNT] == points) {
        state[SURVEY_AL_SUM_X] -= rx[head];
        state[SURVEY_AL_SUM_Y] -= ry[head];
    } else {
        state[SURVEY_AL_COUNT] += 1;
    }
    rx[head] = mx;
    ry[head] = my;
    state[SURVEY_AL_SUM_X] += mx;
    state[SURVEY_AL_SUM_Y] += my;
    state[SURVEY_AL_HEAD] = (head + 1) % points;
    if (state[SURVEY_AL_COUNT] < points) return 0;
    ax = fx_div_round(state[SURVEY_AL_SUM_X], points);
    ay = fx_div_round(state[SURVEY_AL_SUM_Y], points);
    if (state[SURVEY_AL_PHASE] == SURVEY_ALIGN_IDLE) {
        state[SURVEY_AL_MAX_X] = ax;
        state[SURVEY_AL_MIN_X] = ax;
        state[SURVEY_AL_MAX_Y] = ay;
        state[SURVEY_AL_MIN_Y] = ay;
        state[SURVEY_AL_PHASE] = SURVEY_ALIGN_COLLECTING;
    } else {
        if (ax > state[SURVEY_AL_MAX_X]) state[SURVEY_AL_MAX_X] = ax;
        if (ax < state[SURVEY_AL_MIN_X]) state[SURVEY_AL_MIN_X] = ax;
        if (ay > state[SURVEY_AL_MAX_Y]) state[SURVEY_AL_MAX_Y] = ay;
        if (ay < state[SURVEY_AL_MIN_Y]) state[SURVEY_AL_MIN_Y] = ay;
    }
    return 0;
}

static int32_t survey_align_correction(int64_t *state, int64_t n, int64_t *cx, int64_t *cy)
{
    const int64_t max_input = (int64_t)(((uint64_t)1 << 62) - 1);
    int64_t ox, oy;
    if (state[SURVEY_AL_PHASE] == SURVEY_ALIGN_COLLECTING) {
        state[SURVEY_AL_OFF_X] = fx_shift_round(state[SURVEY_AL_MAX_X] + state[SURVEY_AL_MIN_X], 1);
        state[SURVEY_AL_OFF_Y] = fx_shift_round(state[SURVEY_AL_MAX_Y] + state[SURVEY_AL_MIN_Y], 1);
        state[SURVEY_AL_PHASE] = SURVEY_ALIGN_APPLIED;
    }
    *cx = 0;
    *cy = 0;
    if (state[SURVEY_AL_PHASE] != SURVEY_ALIGN_APPLIED) return 0;
    ox = state[SURVEY_AL_OFF_X];
    oy = state[SURVEY_AL_OFF_Y];
    if ((ox != 0 && n > max_input / survey_abs(ox)) || (oy != 0 && n > max_input / survey_abs(oy))) return -7;
    *cx = fx_shift_round(ox * n, SURVEY_ALIGN_FRAC);
    *cy = fx_shift_round(oy * n, SURVEY_ALIGN_FRAC);
    return 0;
}

int32_t survey_tick(int64_t *state, int32_t points, int64_t fx, int64_t fy, int64_t fz, int64_t n, int64_t yaw32,
                    int32_t aligning, int32_t mode, int32_t iterations, int64_t *inc_avg, int64_t *azi_avg)
{
    int64_t psi, cx, cy, i_raw = 0, a_raw = 0;
    int32_t rc;
    if (n < 1) return -5;
    psi = survey_mid_yaw(state, yaw32);
    if (aligning) {
        rc = survey_align_collect(state, points, fx, fy, n);
        if (rc != 0) return rc;
    } else {
        rc = survey_align_correction(state, n, &cx, &cy);
        if (rc != 0) return rc;
        fx -= cx;
        fy -= cy;
    }
    rc = survey_resolve(fx, fy, fz, psi, mode, iterations, &i_raw, &a_raw);
    if (rc != 0) return rc;
    survey_ma_push(state, points, i_raw, a_raw, inc_avg, azi_avg);
    return 0;
}

int32_t survey_run(const int64_t *accel, const int64_t *yaw_raw, const int64_t *samples, int64_t n_ticks,
                   int64_t align_lo, int64_t align_hi, int32_t points, int32_t mode, int32_t iterations,
                   int32_t yaw_frac_bits, int64_t *state, int64_t *inc_out, int64_t *azi_out)
{
    int64_t k;
    int32_t rc;
    if (points < 1) return -4;
    survey_ma_reset(state);
    for (k = 0; k < n_ticks; k++) {
        rc = survey_tick(state, points, accel[3 * k], accel[3 * k + 1], accel[3 * k + 2], samples[k],
                         survey_yaw_to_ba32(yaw_raw[k], yaw_frac_bits), align_lo <= k && k < align_hi, mode,
                         iterations, inc_out + k, azi_out + k);
        if (rc != 0) return rc;
    }
    return 0;
}
