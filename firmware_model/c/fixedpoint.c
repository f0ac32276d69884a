/* See fixedpoint.h. Each function mirrors the njit function of the same name in firmware_model/fixed_kernel.py
 * (_sat, _add, _sub, _mul, _div, _wrap, shift_right_round, div_round). */
#include "fixedpoint.h"

int64_t fx_shift_round(int64_t x, int64_t s)
{
    /* x / 2^s rounded half to even, s >= 1, no saturation */
    return (x + (((x >> s) & 1) + ((int64_t)1 << (s - 1)) - 1)) >> s;
}

int64_t fx_sat(int64_t x, int64_t frac_in, int64_t w, int64_t f, int64_t *counts, int64_t site)
{
    const int64_t hi = ((int64_t)1 << (w - 1)) - 1;
    const int64_t lo = -hi - 1;
    const int64_t s = frac_in - f;
    if (s > 0) {
        x = fx_shift_round(x, s);
    } else if (s < 0) {
        const int64_t ls = -s;
        if (x > (hi >> ls)) { counts[site] += 1; return hi; }
        if (x < -((-lo) >> ls)) { counts[site] += 1; return lo; }
        return (int64_t)((uint64_t)x << ls);
    }
    if (x > hi) { counts[site] += 1; return hi; }
    if (x < lo) { counts[site] += 1; return lo; }
    return x;
}

static int64_t aligned(int64_t a, int64_t fa, int64_t b, int64_t fb, int sign, int64_t *fm)
{
    const int64_t m = fa > fb ? fa : fb;
    const int64_t xa = (int64_t)((uint64_t)a << (m - fa)), xb = (int64_t)((uint64_t)b << (m - fb));
    *fm = m;
    return sign > 0 ? xa + xb : xa - xb;
}

int64_t fx_add(int64_t a, int64_t fa, int64_t b, int64_t fb, int64_t w, int64_t f, int64_t *counts, int64_t site)
{
    int64_t fm;
    const int64_t x = aligned(a, fa, b, fb, 1, &fm);
    return fx_sat(x, fm, w, f, counts, site);
}

int64_t fx_sub(int64_t a, int64_t fa, int64_t b, int64_t fb, int64_t w, int64_t f, int64_t *counts, int64_t site)
{
    int64_t fm;
    const int64_t x = aligned(a, fa, b, fb, -1, &fm);
    return fx_sat(x, fm, w, f, counts, site);
}

int64_t fx_mul(int64_t a, int64_t fa, int64_t b, int64_t fb, int64_t w, int64_t f, int64_t *counts, int64_t site)
{
    return fx_sat(a * b, fa + fb, w, f, counts, site);
}

int64_t fx_div_round(int64_t n, int64_t d)
{
    /* floor quotient for d > 0, then round half to even from the remainder */
    int64_t q = n / d, r;
    if ((n % d != 0) && ((n < 0) != (d < 0))) q -= 1; /* C99 truncates: make it floor */
    r = 2 * (n - q * d);
    if (r > d || (r == d && (q & 1) == 1)) q += 1;
    return q;
}

int64_t fx_div(int64_t a, int64_t fa, int64_t b, int64_t fb, int64_t w, int64_t f, int64_t *counts, int64_t site)
{
    const int64_t s = f - fa + fb;
    int64_t n = a, d = b;
    if (s >= 0) n = (int64_t)((uint64_t)n << s); else d = (int64_t)((uint64_t)d << (-s));
    if (d < 0) { n = -n; d = -d; }
    if (d == 0) { /* the guarded division: MAX or MIN by the numerator's sign, one overflow */
        counts[site] += 1;
        return n >= 0 ? ((int64_t)1 << (w - 1)) - 1 : -((int64_t)1 << (w - 1));
    }
    return fx_sat(fx_div_round(n, d), f, w, f, counts, site);
}

int64_t fx_wrap(int64_t x, int64_t w)
{
    const uint64_t m = ((uint64_t)1 << w) - 1;
    const uint64_t u = (uint64_t)x & m;
    const uint64_t sign = (uint64_t)1 << (w - 1);
    return (int64_t)(u ^ sign) - (int64_t)sign; /* sign-extend bit w - 1 */
}
