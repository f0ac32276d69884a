/* See six_state_filter.h: each block is the block of firmware_model/six_state_kernel.py (predict_raw, update_raw). */
#include "six_state_filter.h"
#include "cordic.h"
#include "fixedpoint.h"

#define W(i) p[(i)], p[(i) + 1]  /* the (word, frac) of a format */
#define F(i) p[(i) + 1]          /* a format's (or a constant's) frac bits */
#define K(i) p[(i)], p[(i) + 1]  /* a constant's (raw, frac) */

static int64_t blk(int i, int j)
{
    if (i < 3 && j < 3) return NF6_W_AA;
    if (i >= 3 && j >= 3) return NF6_W_BB;
    return NF6_W_AB;
}

static int64_t series(const int64_t *p, int64_t table, int64_t u, int64_t fu, int64_t *c)
{
    const int64_t fs = F(NF6_W_SER);
    int64_t acc = p[table + NF6_SERIES_TERMS - 1];
    int k;
    for (k = NF6_SERIES_TERMS - 2; k >= 0; k--)
        acc = fx_add(p[table + k], fs, fx_mul(u, fu, acc, fs, W(NF6_W_SER), c, NF6_S_SERIES), fs, W(NF6_W_SER), c,
                     NF6_S_SERIES);
    return acc;
}

static int64_t skew(const int64_t *rho, int i, int j)
{
    int k, s;
    if (i == j) return 0;
    k = 3 - i - j;
    s = (((j - i) % 3 + 3) % 3) == 1 ? 1 : -1;
    return -s * rho[k];
}

static void matmul3(const int64_t *a, int64_t fa, int ta, const int64_t *b, int64_t fb, int64_t *o, const int64_t *p,
                    int64_t w, int64_t *c, int64_t site)
{
    const int64_t fo = p[w + 1];
    int i, j, k;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            int64_t acc = 0;
            for (k = 0; k < 3; k++) {
                const int64_t x = ta ? a[3 * k + i] : a[3 * i + k];
                acc = fx_add(acc, fo, fx_mul(x, fa, b[3 * k + j], fb, p[w], fo, c, site), fo, p[w], fo, c, site);
            }
            o[3 * i + j] = acc;
        }
}

static int64_t dot3(int64_t a0, int64_t a1, int64_t a2, const int64_t *b, int j, int64_t fa, int64_t fb,
                    const int64_t *p, int64_t w, int64_t *c, int64_t site)
{
    const int64_t fo = p[w + 1];
    int64_t acc = fx_mul(a0, fa, b[j], fb, p[w], fo, c, site);
    acc = fx_add(acc, fo, fx_mul(a1, fa, b[3 + j], fb, p[w], fo, c, site), fo, p[w], fo, c, site);
    return fx_add(acc, fo, fx_mul(a2, fa, b[6 + j], fb, p[w], fo, c, site), fo, p[w], fo, c, site);
}

void nf6_predict(int64_t *st, const int64_t *rate_raw, const int64_t *p, int64_t *c)
{
    const int64_t fr = F(NF6_W_RATE), fb = F(NF6_W_BIAS), frho = F(NF6_W_RHO), frho2 = F(NF6_W_RHO2);
    const int64_t fs = F(NF6_W_SER), fu = F(NF6_W_UNIT), ft = F(NF6_W_TR), fgs = F(NF6_W_GS);
    const int32_t it = (int32_t)p[NF6_P_ITER];
    const int64_t one_u = p[NF6_P_ONE_U];
    int64_t rho[3], s = 0, c1, c2, c3, c1h, c2h;
    int64_t ex[9], jr[9], eh[9], einv[9], e[9], m[9], phi11[9], phi12[9], gc[9], gs[9], t6[36];
    int64_t sp, cp, sn, cs, spst, cpst, spct, cpct, c00, c10, c20, c21, c22, d_psi, phi_new, theta_new, mag, mag2;
    int64_t *P = st + NF6_I_P;
    int i, j, k, mm, near;
    for (i = 0; i < 3; i++) {
        const int64_t d = fx_sub(rate_raw[i], fr, st[NF6_I_BIAS + i], fb, W(NF6_W_RATE), c, NF6_S_RATE_BIAS);
        rho[i] = fx_mul(d, fr, K(NF6_C_DTR), W(NF6_W_RHO), c, NF6_S_RHO);
    }
    for (i = 0; i < 3; i++)
        s = fx_add(s, frho2, fx_mul(rho[i], frho, rho[i], frho, W(NF6_W_RHO2), c, NF6_S_RHO2), frho2, W(NF6_W_RHO2), c,
                   NF6_S_RHO2);
    c1 = series(p, NF6_T_SERIES, s, frho2 + 4, c);
    c2 = series(p, NF6_T_SERIES + NF6_SERIES_TERMS, s, frho2 + 4, c);
    c3 = series(p, NF6_T_SERIES + 2 * NF6_SERIES_TERMS, s, frho2 + 4, c);
    c1h = series(p, NF6_T_SERIES, s, frho2 + 6, c);
    c2h = series(p, NF6_T_SERIES + NF6_SERIES_TERMS, s, frho2 + 6, c);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            const int64_t kk = skew(rho, i, j);
            int64_t k2 = fx_mul(rho[i], frho, rho[j], frho, W(NF6_W_RHO2), c, NF6_S_RHO2), x, y, z;
            if (i == j) k2 = fx_sub(k2, frho2, s, frho2, W(NF6_W_RHO2), c, NF6_S_RHO2);
            x = fx_add(fx_mul(c1, fs, kk, frho, W(NF6_W_UNIT), c, NF6_S_EXP), fu,
                       fx_mul(c2, fs, k2, frho2, W(NF6_W_UNIT), c, NF6_S_EXP), fu, W(NF6_W_UNIT), c, NF6_S_EXP);
            y = fx_sub(fx_mul(c3, fs, k2, frho2, W(NF6_W_UNIT), c, NF6_S_JR), fu,
                       fx_mul(c2, fs, kk, frho, W(NF6_W_UNIT), c, NF6_S_JR), fu, W(NF6_W_UNIT), c, NF6_S_JR);
            z = fx_sub(fx_mul(c2h, fs, k2, frho2 + 2, W(NF6_W_UNIT), c, NF6_S_EXPH), fu,
                       fx_mul(c1h, fs, kk, frho + 1, W(NF6_W_UNIT), c, NF6_S_EXPH), fu, W(NF6_W_UNIT), c, NF6_S_EXPH);
            if (i == j) {
                x = fx_add(x, fu, one_u, fu, W(NF6_W_UNIT), c, NF6_S_EXP);
                y = fx_add(y, fu, one_u, fu, W(NF6_W_UNIT), c, NF6_S_JR);
                z = fx_add(z, fu, one_u, fu, W(NF6_W_UNIT), c, NF6_S_EXPH);
            }
            ex[3 * i + j] = x;
            jr[3 * i + j] = y;
            eh[3 * i + j] = z;
        }
    /* the strapdown: C+ = C_b^n(phi, theta, 0) Exp(rho), its Z-Y-X angles by CORDIC vectoring */
    cordic_sin_cos(st[NF6_I_ATT], it, &sp, &cp);
    cordic_sin_cos(st[NF6_I_ATT + 1], it, &sn, &cs);
    spst = fx_mul(sp, fu, sn, fu, W(NF6_W_UNIT), c, NF6_S_DCM);
    cpst = fx_mul(cp, fu, sn, fu, W(NF6_W_UNIT), c, NF6_S_DCM);
    spct = fx_mul(sp, fu, cs, fu, W(NF6_W_UNIT), c, NF6_S_DCM);
    cpct = fx_mul(cp, fu, cs, fu, W(NF6_W_UNIT), c, NF6_S_DCM);
    c00 = dot3(cs, spst, cpst, ex, 0, fu, fu, p, NF6_W_UNIT, c, NF6_S_DCM);
    c10 = dot3(0, cp, -sp, ex, 0, fu, fu, p, NF6_W_UNIT, c, NF6_S_DCM);
    c20 = dot3(-sn, spct, cpct, ex, 0, fu, fu, p, NF6_W_UNIT, c, NF6_S_DCM);
    c21 = dot3(-sn, spct, cpct, ex, 1, fu, fu, p, NF6_W_UNIT, c, NF6_S_DCM);
    c22 = dot3(-sn, spct, cpct, ex, 2, fu, fu, p, NF6_W_UNIT, c, NF6_S_DCM);
    cordic_vectoring(c00, c10, it, &d_psi, &mag);
    cordic_vectoring(c22, c21, it, &phi_new, &mag);
    cordic_vectoring(mag, -c20, it, &theta_new, &mag2);
    for (i = 0; i < 9; i++) einv[i] = 0;
    einv[0] = one_u; einv[2] = -sn;
    einv[4] = cp; einv[5] = spct; einv[7] = -sp; einv[8] = cpct;
    st[NF6_I_ATT] = phi_new;
    st[NF6_I_ATT + 1] = theta_new;
    st[NF6_I_ATT + 2] = fx_wrap(st[NF6_I_ATT + 2] + d_psi, p[NF6_W_ANG]);
    /* E at the posterior, the pitch held at the margin where singular */
    cordic_sin_cos(phi_new, it, &sp, &cp);
    cordic_sin_cos(theta_new, it, &sn, &cs);
    near = (cs < 0 ? -cs : cs) < p[NF6_P_SINM];
    if (near) {
        st[NF6_I_SING] += 1;
        cs = cs < 0 ? -p[NF6_P_SINM] : p[NF6_P_SINM];
        sn = sn < 0 ? -p[NF6_P_COSM] : p[NF6_P_COSM];
    }
    if (near && p[NF6_P_DECOUPLE] != 0) {
        for (i = 0; i < 9; i++) phi11[i] = phi12[i] = gc[i] = 0;
        for (i = 0; i < 3; i++) { phi11[4 * i] = p[NF6_P_ONE_T]; phi12[4 * i] = p[NF6_P_DT_T]; gc[4 * i] = p[NF6_P_ONE_T]; }
    } else {
        const int64_t inv_c = fx_div(one_u, fu, cs, fu, W(NF6_W_TR), c, NF6_S_INVC);
        const int64_t t = fx_mul(sn, fu, inv_c, ft, W(NF6_W_TR), c, NF6_S_E);
        e[0] = p[NF6_P_ONE_T];
        e[1] = fx_mul(sp, fu, t, ft, W(NF6_W_TR), c, NF6_S_E);
        e[2] = fx_mul(cp, fu, t, ft, W(NF6_W_TR), c, NF6_S_E);
        e[3] = 0;
        e[4] = fx_sat(cp, fu, W(NF6_W_TR), c, NF6_S_E);
        e[5] = fx_sat(-sp, fu, W(NF6_W_TR), c, NF6_S_E);
        e[6] = 0;
        e[7] = fx_mul(sp, fu, inv_c, ft, W(NF6_W_TR), c, NF6_S_E);
        e[8] = fx_mul(cp, fu, inv_c, ft, W(NF6_W_TR), c, NF6_S_E);
        matmul3(ex, fu, 1, einv, fu, m, p, NF6_W_UNIT, c, NF6_S_PHI11);
        matmul3(e, ft, 0, m, fu, phi11, p, NF6_W_TR, c, NF6_S_PHI11);
        matmul3(e, ft, 0, jr, fu, phi12, p, NF6_W_TR, c, NF6_S_PHI12);
        for (i = 0; i < 9; i++) phi12[i] = fx_mul(phi12[i], ft, K(NF6_C_DT), W(NF6_W_TR), c, NF6_S_PHI12);
        matmul3(e, ft, 0, eh, fu, gc, p, NF6_W_TR, c, NF6_S_GC);
    }
    for (i = 0; i < 3; i++)
        for (k = 0; k < 3; k++)
            gs[3 * i + k] = fx_mul(gc[3 * i + k], ft, K(NF6_C_SV + 3 * k), W(NF6_W_GS), c, NF6_S_GS);
    /* T = Phi P */
    for (i = 0; i < 6; i++)
        for (k = 0; k < 6; k++) {
            const int64_t w = blk(i, k), fo = p[w + 1];
            int64_t acc = 0;
            if (i < 3) {
                for (mm = 0; mm < 6; mm++) {
                    const int64_t ph = mm < 3 ? phi11[3 * i + mm] : phi12[3 * i + mm - 3];
                    acc = fx_add(acc, fo, fx_mul(ph, ft, P[6 * mm + k], p[blk(mm, k) + 1], p[w], fo, c, NF6_S_PHIP), fo,
                                 p[w], fo, c, NF6_S_PHIP);
                }
            } else {
                acc = fx_mul(K(NF6_C_F + 3 * (i - 3)), P[6 * i + k], p[blk(i, k) + 1], p[w], fo, c, NF6_S_PHIP);
            }
            t6[6 * i + k] = acc;
        }
    /* P = T Phi^T + Q_d, upper triangle, mirrored */
    for (i = 0; i < 6; i++)
        for (j = i; j < 6; j++) {
            const int64_t w = blk(i, j), fo = p[w + 1];
            int64_t acc = 0;
            if (j < 3) {
                for (mm = 0; mm < 6; mm++) {
                    const int64_t ph = mm < 3 ? phi11[3 * j + mm] : phi12[3 * j + mm - 3];
                    acc = fx_add(acc, fo, fx_mul(t6[6 * i + mm], p[blk(i, mm) + 1], ph, ft, p[w], fo, c, NF6_S_PPRED),
                                 fo, p[w], fo, c, NF6_S_PPRED);
                }
                for (k = 0; k < 3; k++) {
                    const int64_t q = fx_mul(gs[3 * i + k], fgs, gs[3 * j + k], fgs, W(NF6_W_AA), c, NF6_S_QD);
                    acc = fx_add(acc, fo, q, fo, p[w], fo, c, NF6_S_PPRED);
                }
            } else {
                acc = fx_mul(t6[6 * i + j], p[blk(i, j) + 1], K(NF6_C_F + 3 * (j - 3)), p[w], fo, c, NF6_S_PPRED);
                if (i == j) acc = fx_add(acc, fo, K(NF6_C_QB + 3 * (j - 3)), p[w], fo, c, NF6_S_PPRED);
            }
            if (i == j && acc < 1) acc = 1; /* P_ii >= 1 LSB */
            P[6 * i + j] = acc;
            P[6 * j + i] = acc;
        }
}

void nf6_update(int64_t *st, int64_t axes, const int64_t *ref_raw, const int64_t *var_raw, const int64_t *p,
                int64_t *c)
{
    const int64_t fa = F(NF6_W_ANG), fb = F(NF6_W_BIAS), finv = F(NF6_W_INV), fka = F(NF6_W_KA), fkb = F(NF6_W_KB);
    const int64_t finn = F(NF6_W_INN), faa = F(NF6_W_AA);
    int64_t *P = st + NF6_I_P;
    int64_t dxv[6] = {0, 0, 0, 0, 0, 0}, row[6], kg[6];
    int a, j, k, lo = 0, hi = 3; /* the rows of axes (six_state_kernel._axes_range) */
    if (axes == NF6_YAW_ONLY) lo = 2;
    else if (axes == NF6_ROLL_PITCH) hi = 2;
    else if (axes == NF6_PITCH_ONLY) { lo = 1; hi = 2; }
    for (a = lo; a < hi; a++) {
        const int64_t z = fx_wrap(st[NF6_I_ATT + a] - ref_raw[a], p[NF6_W_ANG]);
        const int64_t r = fx_wrap(z - dxv[a], p[NF6_W_ANG]);
        const int64_t sv = fx_add(P[7 * a], faa, var_raw[a], faa, W(NF6_W_AA), c, NF6_S_S);
        const int64_t inv = fx_div(p[NF6_P_ONE_U], F(NF6_W_UNIT), sv, faa, W(NF6_W_INV), c, NF6_S_INV);
        int64_t r_deg;
        for (k = 0; k < 6; k++) row[k] = P[6 * a + k];
        for (j = 0; j < 6; j++)
            kg[j] = fx_mul(row[j], p[blk(a, j) + 1], inv, finv, W(j < 3 ? NF6_W_KA : NF6_W_KB), c, NF6_S_K);
        r_deg = fx_mul(r, fa, K(NF6_C_360), W(NF6_W_INN), c, NF6_S_INNOV);
        for (j = 0; j < 6; j++) {
            if (j < 3) {
                const int64_t d = fx_mul(kg[j], fka, r, fa, W(NF6_W_ANG), c, NF6_S_KZ);
                dxv[j] = fx_add(dxv[j], fa, d, fa, W(NF6_W_ANG), c, NF6_S_KZ);
            } else {
                const int64_t d = fx_mul(kg[j], fkb, r_deg, finn, W(NF6_W_BIAS), c, NF6_S_KZ);
                dxv[j] = fx_add(dxv[j], fb, d, fb, W(NF6_W_BIAS), c, NF6_S_KZ);
            }
        }
        for (j = 0; j < 6; j++) {
            const int64_t fk = j < 3 ? fka : fkb;
            for (k = j; k < 6; k++) {
                const int64_t w = blk(j, k), fo = p[w + 1];
                int64_t v = fx_sub(P[6 * j + k], fo, fx_mul(kg[j], fk, row[k], p[blk(a, k) + 1], p[w], fo, c, NF6_S_PUPD),
                                   fo, p[w], fo, c, NF6_S_PUPD);
                if (j == k && v < 1) v = 1;
                P[6 * j + k] = v;
                P[6 * k + j] = v;
            }
        }
    }
    for (j = 0; j < 3; j++) {
        st[NF6_I_ATT + j] = fx_wrap(st[NF6_I_ATT + j] - dxv[j], p[NF6_W_ANG]);
        st[NF6_I_BIAS + j] = fx_add(st[NF6_I_BIAS + j], fb, dxv[3 + j], fb, W(NF6_W_BIAS), c, NF6_S_BIAS_UPD);
    }
}

void nf6_tilt(int64_t fx, int64_t fy, int64_t fz, int32_t it, int64_t *out)
{
    /* out = (phi, theta, |(f_y, f_z)|, |f|): phi = atan2(f_y, f_z), theta = atan2(-f_x, |(f_y, f_z)|) */
    cordic_vectoring(fz, fy, it, &out[0], &out[2]);
    cordic_vectoring(out[2], -fx, it, &out[1], &out[3]);
}

int64_t nf6_level(int64_t *st, const int64_t *rate_raw, const int64_t *acc, int64_t n_samples, const int64_t *p,
                  int64_t *c)
{
    const int64_t thr = p[NF6_P_LEVEL_RATE], fc = F(NF6_C_LSIG), fl = F(NF6_W_LSIG);
    int64_t w2 = 0, tilt[4], sig, r, ref[3], var[3], sn, cs, axes = NF6_PITCH_ONLY;
    int i;
    if (p[NF6_P_LEVEL] == 0) return 0;
    for (i = 0; i < 3; i++) { /* static: sum clamp(w - b_0)^2 < w_thr^2, exact */
        int64_t d = rate_raw[i] - st[NF6_I_B0 + i];
        if (d > NF6_LEVEL_DIFF_LIMIT) d = NF6_LEVEL_DIFF_LIMIT;
        else if (d < -NF6_LEVEL_DIFF_LIMIT) d = -NF6_LEVEL_DIFF_LIMIT;
        w2 += d * d;
    }
    if (w2 >= thr * thr) return 0;
    nf6_tilt(acc[0], acc[1], acc[2], (int32_t)p[NF6_P_ITER], tilt);
    if (tilt[3] == 0) return 0;
    sig = p[NF6_C_LSIG] * n_samples; /* the sums' noise sigma_F = c_sigma n (deg counts) */
    ref[0] = tilt[0]; ref[1] = tilt[1]; ref[2] = 0;
    var[0] = 0; var[2] = 0;
    r = fx_div(sig, fc, tilt[3], 0, W(NF6_W_LSIG), c, NF6_S_LSIG);
    var[1] = fx_mul(r, fl, r, fl, W(NF6_W_AA), c, NF6_S_LR);
    cordic_sin_cos(tilt[1], (int32_t)p[NF6_P_ITER], &sn, &cs);
    if (cs >= p[NF6_P_SINM]) { /* roll defined: |(f_y, f_z)| >= |f| sin(margin) */
        r = fx_div(sig, fc, tilt[2], 0, W(NF6_W_LSIG), c, NF6_S_LSIG);
        var[0] = fx_mul(r, fl, r, fl, W(NF6_W_AA), c, NF6_S_LR);
        axes = NF6_ROLL_PITCH;
    }
    nf6_update(st, axes, ref, var, p, c);
    return 1;
}

void nf6_run(int64_t *st, const int64_t *p, int64_t *c, const int64_t *ops, int64_t n_ops, int64_t *states_out)
{
    /* ops: n_ops rows of (kind, a0, a1, a2, v0, v1, v2, n): kind 0 = predict(rates a), 1 / 3 / 4 / 5 = update(axes =
     * kind), NF6_LEVEL_OP = level(rates a, accelerometer sums v, n samples) */
    int64_t n;
    int i;
    for (n = 0; n < n_ops; n++) {
        const int64_t *op = ops + 8 * n;
        if (op[0] == 0) nf6_predict(st, op + 1, p, c);
        else if (op[0] == NF6_LEVEL_OP) nf6_level(st, op + 1, op + 4, op[7], p, c);
        else nf6_update(st, op[0], op + 1, op + 4, p, c);
        for (i = 0; i < NF6_STATE_SIZE; i++) states_out[NF6_STATE_SIZE * n + i] = st[i];
    }
}

int32_t nf6_layout(int32_t which)
{
    /* the layout constants, for the test that they equal firmware_model.six_state_kernel's */
    switch (which) {
    case 0: return NF6_N_PARAMS;
    case 1: return NF6_N_SITES;
    case 2: return NF6_STATE_SIZE;
    case 3: return NF6_T_SERIES;
    case 4: return NF6_P_DT_T;
    case 5: return NF6_C_360;
    default: return -1;
    }
}
