/* See node_firmware.h and firmware_model/node_firmware.py (the same steps, line by line). */
#include "node_firmware.h"
#include "fixedpoint.h"
#include "yaw_filter.h"

/* overflow sites after the filter's (firmware_model.node_firmware.FIRMWARE_SITES) */
#define X_RATE (NF_N_FILTER_SITES + 0)
#define X_BIAS0 (NF_N_FILTER_SITES + 1)
#define X_TRANSFER (NF_N_FILTER_SITES + 2)
#define X_GAIN (NF_N_FILTER_SITES + 3)
#define X_OMEGA (NF_N_FILTER_SITES + 4)
#define X_SIGMA_D (NF_N_FILTER_SITES + 5)
#define X_R_TRANSFER (NF_N_FILTER_SITES + 6)
#define X_R_SUM (NF_N_FILTER_SITES + 7)
#define ADVANCE_FRAC 35
#define MAX_TRANSFER_US (((int64_t)1 << 24) - 1)
#define US_PER_TURN_DEG 360000000LL

int32_t nf_abi_version(void) { return 1; }

static int64_t counts_to_rate(int64_t count_sum, int64_t n, int64_t frac, int64_t sens_x10)
{
    return fx_div_round(count_sum * 10 * ((int64_t)1 << frac), n * sens_x10);
}

void nf_init_lane(int64_t *state)
{
    int i;
    for (i = 0; i < NF_STATE_WORDS; i++) state[i] = 0;
    state[NF_S_HAVE_LAST] = -1;
}

static void read_gyro(int64_t *st, int64_t gz, int64_t n, const int64_t *p, const int64_t *fp, int64_t *counts)
{
    const int64_t fr = fp[NF_W_RATE + 1], wr = fp[NF_W_RATE];
    st[NF_S_LAST_RATE] = st[NF_S_RATE];
    st[NF_S_HAVE_LAST] = st[NF_S_HAVE_LAST] >= 0 ? 1 : 0;
    st[NF_S_RATE] = fx_sat(counts_to_rate(gz, n, fr, p[NF_P_SENS]), fr, wr, fr, counts, X_RATE);
}

static void start_filter(int64_t *st, int64_t yaw0, const int64_t *p, const int64_t *fp, int64_t *counts)
{
    const int64_t fb = fp[NF_W_BIAS + 1], wb = fp[NF_W_BIAS];
    int64_t bias = 0;
    if (st[NF_S_BIAS_N] > 0)
        bias = fx_sat(counts_to_rate(st[NF_S_BIAS_SUM], st[NF_S_BIAS_N], fb, p[NF_P_SENS]), fb, wb, fb, counts, X_BIAS0);
    st[NF_I_YAW] = fx_wrap(yaw0, fp[NF_W_YAW]);
    st[NF_I_BIAS] = bias;
    st[NF_I_PYY] = p[NF_P_P0_YY];
    st[NF_I_PYB] = 0;
    st[NF_I_PBB] = p[NF_P_P0_BB];
    st[NF_S_RUNNING] = 1;
}

static int64_t transfer_us_sat(int64_t us, int64_t *counts)
{
    if (us > MAX_TRANSFER_US) { counts[X_TRANSFER] += 1; return MAX_TRANSFER_US; }
    if (us < 0) { counts[X_TRANSFER] += 1; return 0; }
    return us;
}

static int64_t advance(int64_t yaw, int64_t omega, int64_t us, const int64_t *fp, int64_t *counts)
{
    const int64_t fr = fp[NF_W_RATE + 1], wy = fp[NF_W_YAW], fy = fp[NF_W_YAW + 1];
    int64_t k = fx_div_round((int64_t)((uint64_t)us << ADVANCE_FRAC), US_PER_TURN_DEG);
    int64_t inc;
    k = fx_sat(k, ADVANCE_FRAC, 32, ADVANCE_FRAC, counts, X_GAIN);
    inc = fx_shift_round(omega * k, fr + ADVANCE_FRAC - fy); /* not saturated: exact modulo one turn */
    return fx_wrap(yaw + inc, wy);
}

static int64_t omega_of(const int64_t *st, const int64_t *p, const int64_t *fp, int64_t *counts, int64_t us)
{
    const int64_t fr = fp[NF_W_RATE + 1], wr = fp[NF_W_RATE], fb = fp[NF_W_BIAS + 1];
    int64_t w = fx_sub(st[NF_S_RATE], fr, st[NF_I_BIAS], fb, wr, fr, counts, X_OMEGA);
    if (p[NF_P_EXTRA] != 0 && st[NF_S_HAVE_LAST] != 0) {
        const int64_t dt_us = p[NF_P_DT_US];
        const int64_t slope = fx_div_round((st[NF_S_RATE] - st[NF_S_LAST_RATE]) * (dt_us - us), 2 * dt_us);
        w = fx_sat(w + slope, fr, wr, fr, counts, X_OMEGA);
    }
    return w;
}

static int64_t reference_variance(int64_t var_prev, int64_t us, const int64_t *p, const int64_t *fp, int64_t *counts)
{
    const int64_t fyy = fp[NF_W_YY + 1], wyy = fp[NF_W_YY], fd = p[NF_P_SIG_D_F];
    const int64_t d = fx_sat(us * p[NF_P_SIG], p[NF_P_SIG_F], 32, fd, counts, X_SIGMA_D);
    const int64_t d2 = fx_sat(d * d, 2 * fd, wyy, fyy, counts, X_R_TRANSFER);
    const int64_t r = fx_add(var_prev, fyy, d2, fyy, wyy, fyy, counts, X_R_SUM);
    return fx_add(r, fyy, p[NF_P_OFF2], fyy, wyy, fyy, counts, X_R_SUM);
}

void node_firmware_tick(int64_t *st, const int64_t *p, const int64_t *fp, int64_t *counts, const int64_t *in,
                        int64_t *out)
{
    const int64_t phase = in[NF_IN_PHASE];
    out[NF_OUT_APPLIED] = 0;
    out[NF_OUT_REF] = 0;
    out[NF_OUT_R] = 0;
    if (phase == NF_ABSENT) return;
    read_gyro(st, in[NF_IN_GZ], in[NF_IN_N], p, fp, counts);
    if (phase == NF_STATIC) {
        st[NF_S_BIAS_SUM] += in[NF_IN_GZ];
        st[NF_S_BIAS_N] += in[NF_IN_N];
    } else if (phase == NF_START) {
        start_filter(st, in[NF_IN_YAW0], p, fp, counts);
    } else if (phase == NF_RUN) {
        const int64_t kind = in[NF_IN_REF];
        nf_filter_predict(st, st[NF_S_RATE], fp, counts);
        if (kind == NF_ENCODER_REF || kind == NF_FORWARDED_REF) {
            const int64_t us = transfer_us_sat(in[NF_IN_TRANSFER], counts);
            int64_t ref, r;
            if (kind == NF_ENCODER_REF) {
                ref = advance(in[NF_IN_REF_YAW], -in[NF_IN_REF_AUX], us, fp, counts);
                r = p[NF_P_ENC_VAR];
            } else {
                const int64_t w = omega_of(st, p, fp, counts, us);
                ref = advance(in[NF_IN_REF_YAW], w, us, fp, counts);
                r = reference_variance(in[NF_IN_REF_AUX], us, p, fp, counts);
            }
            nf_filter_update(st, ref, r, fp, counts);
            out[NF_OUT_APPLIED] = 1;
            out[NF_OUT_REF] = ref;
            out[NF_OUT_R] = r;
        } else if (kind == NF_DIRECT_REF) {
            nf_filter_update(st, in[NF_IN_REF_YAW], in[NF_IN_REF_AUX], fp, counts);
            out[NF_OUT_APPLIED] = 1;
            out[NF_OUT_REF] = in[NF_IN_REF_YAW];
            out[NF_OUT_R] = in[NF_IN_REF_AUX];
        }
    }
    if (st[NF_S_RUNNING] != 0)
        out[NF_OUT_RATE] = fx_sub(st[NF_S_RATE], fp[NF_W_RATE + 1], st[NF_I_BIAS], fp[NF_W_BIAS + 1], fp[NF_W_RATE],
                                  fp[NF_W_RATE + 1], counts, X_OMEGA);
}

void node_firmware_run(int64_t *st, const int64_t *p, const int64_t *fp, int64_t *counts, const int64_t *inputs,
                       int64_t *outputs, int64_t *states_out, int64_t n_ticks)
{
    int64_t k;
    int i;
    for (k = 0; k < n_ticks; k++) {
        node_firmware_tick(st, p, fp, counts, inputs + 8 * k, outputs + 4 * k);
        for (i = 0; i < NF_STATE_WORDS; i++) states_out[NF_STATE_WORDS * k + i] = st[i];
    }
}
