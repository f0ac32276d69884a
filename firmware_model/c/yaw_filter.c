/* See yaw_filter.h: each line is the line of firmware_model/fixed_kernel.py (_predict_raw, _update_raw). */
#include "yaw_filter.h"
#include "fixedpoint.h"

#define W(i) p[(i)], p[(i) + 1]       /* the (word, frac) of a format */
#define F(i) p[(i) + 1]               /* a format's (or a constant's) frac bits */
#define K(i) p[(i)], p[(i) + 1]       /* a constant's (raw, frac) */

static int64_t max1(int64_t x) { return x > 1 ? x : 1; }

void nf_filter_predict(int64_t *st, int64_t rate_raw, const int64_t *p, int64_t *c)
{
    const int64_t fr = F(NF_W_RATE), fb = F(NF_W_BIAS), fyy = F(NF_W_YY), fyb = F(NF_W_YB), fbb = F(NF_W_BB);
    const int64_t yaw = st[NF_I_YAW], bias = st[NF_I_BIAS], p_yy = st[NF_I_PYY], p_yb = st[NF_I_PYB];
    const int64_t p_bb = st[NF_I_PBB];
    int64_t d, inc, new_yaw, y, yb, bb;
    d = fx_sub(rate_raw, fr, bias, fb, W(NF_W_RATE), c, NF_SITE_RATE_BIAS);
    inc = fx_mul(d, fr, K(NF_C_KT), W(NF_W_YAW), c, NF_SITE_YAW_INC);
    new_yaw = fx_wrap(yaw + inc, p[NF_W_YAW]);
    y = fx_add(p_yy, fyy, fx_mul(p_yb, fyb, K(NF_C_2DT), W(NF_W_YY), c, NF_SITE_2DT_PYB), fyy, W(NF_W_YY), c,
               NF_SITE_PYY_PRED);
    y = fx_add(y, fyy, fx_mul(p_bb, fbb, K(NF_C_DT2), W(NF_W_YY), c, NF_SITE_DT2_PBB), fyy, W(NF_W_YY), c,
               NF_SITE_PYY_PRED);
    y = fx_add(y, fyy, K(NF_C_QYY), W(NF_W_YY), c, NF_SITE_PYY_PRED);
    yb = fx_add(p_yb, fyb, fx_mul(p_bb, fbb, K(NF_C_DT), W(NF_W_YB), c, NF_SITE_DT_PBB), fyb, W(NF_W_YB), c,
                NF_SITE_PYB_PRED);
    yb = fx_mul(yb, fyb, K(NF_C_F), W(NF_W_YB), c, NF_SITE_PYB_PRED);
    bb = fx_add(fx_mul(p_bb, fbb, K(NF_C_F2), W(NF_W_BB), c, NF_SITE_F2_PBB), fbb, K(NF_C_QBB), W(NF_W_BB), c,
                NF_SITE_PBB_PRED);
    st[NF_I_YAW] = new_yaw;
    st[NF_I_PYY] = max1(y);
    st[NF_I_PYB] = yb;
    st[NF_I_PBB] = max1(bb);
}

void nf_filter_update(int64_t *st, int64_t ref_raw, int64_t r_raw, const int64_t *p, int64_t *c)
{
    const int64_t fy = F(NF_W_YAW), fb = F(NF_W_BIAS), fyy = F(NF_W_YY), fyb = F(NF_W_YB), fbb = F(NF_W_BB);
    const int64_t fi = F(NF_W_INV), fky = F(NF_W_KY), fkb = F(NF_W_KB), fin = F(NF_W_INN);
    const int64_t yaw = st[NF_I_YAW], bias = st[NF_I_BIAS], p_yy = st[NF_I_PYY], p_yb = st[NF_I_PYB];
    const int64_t p_bb = st[NF_I_PBB];
    int64_t z, s, inv, k_y, k_b, z_deg, new_yaw, new_bias, yy, yb, bb;
    z = fx_wrap(yaw - ref_raw, p[NF_W_YAW]); /* the wrapped innovation */
    s = fx_add(p_yy, fyy, r_raw, fyy, W(NF_W_YY), c, NF_SITE_S);
    inv = fx_div(K(NF_C_ONE), s, fyy, W(NF_W_INV), c, NF_SITE_INV);
    k_y = fx_mul(p_yy, fyy, inv, fi, W(NF_W_KY), c, NF_SITE_KY);
    k_b = fx_mul(p_yb, fyb, inv, fi, W(NF_W_KB), c, NF_SITE_KB);
    z_deg = fx_mul(z, fy, K(NF_C_360), W(NF_W_INN), c, NF_SITE_INNOV);
    new_yaw = fx_wrap(yaw - fx_mul(k_y, fky, z, fy, W(NF_W_YAW), c, NF_SITE_KY_Z), p[NF_W_YAW]);
    new_bias = fx_add(bias, fb, fx_mul(k_b, fkb, z_deg, fin, W(NF_W_BIAS), c, NF_SITE_KB_Z), fb, W(NF_W_BIAS), c,
                      NF_SITE_BIAS_UPD);
    yy = fx_sub(p_yy, fyy, fx_mul(k_y, fky, p_yy, fyy, W(NF_W_YY), c, NF_SITE_KY_PYY), fyy, W(NF_W_YY), c,
                NF_SITE_PYY_UPD);
    yb = fx_sub(p_yb, fyb, fx_mul(k_y, fky, p_yb, fyb, W(NF_W_YB), c, NF_SITE_KY_PYB), fyb, W(NF_W_YB), c,
                NF_SITE_PYB_UPD);
    bb = fx_sub(p_bb, fbb, fx_mul(k_b, fkb, p_yb, fyb, W(NF_W_BB), c, NF_SITE_KB_PYB), fbb, W(NF_W_BB), c,
                NF_SITE_PBB_UPD);
    st[NF_I_YAW] = new_yaw;
    st[NF_I_BIAS] = new_bias;
    st[NF_I_PYY] = max1(yy);
    st[NF_I_PYB] = yb;
    st[NF_I_PBB] = max1(bb);
}

void nf_filter_run(int64_t *st, const int64_t *p, int64_t *c, const int64_t *ops, int64_t n_ops, int64_t *states_out)
{
    /* ops: n_ops rows of (kind, a, b): kind 0 = predict(rate_raw = a), 1 = update(ref_raw = a, r_raw = b) */
    int64_t k;
    int i;
    for (k = 0; k < n_ops; k++) {
        const int64_t *op = ops + 3 * k;
        if (op[0] == 0) nf_filter_predict(st, op[1], p, c);
        else nf_filter_update(st, op[1], op[2], p, c);
        for (i = 0; i < 5; i++) states_out[5 * k + i] = st[i];
    }
}

int32_t nf_filter_layout(int32_t which)
{
    /* the layout constants, for the test that they equal firmware_model.fixed_kernel's */
    switch (which) {
    case 0: return NF_N_KERNEL_PARAMS;
    case 1: return NF_N_FILTER_SITES;
    case 2: return NF_C_360;
    case 3: return NF_W_INN;
    default: return -1;
    }
}
