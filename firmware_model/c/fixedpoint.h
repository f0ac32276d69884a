/* Fixed-point primitives of the node MCU: the C of firmware_model/fixed_kernel.py (round half to even,
 * saturation), on int64_t intermediates. A format is (word bits w, fraction bits f); a saturation adds 1 to
 * counts[site] (the firmware's per-site overflow counters). Arithmetic right shifts of negative values are
 * implementation-defined in C99; every compiler this firmware targets (GCC/Clang for ARM and the host)
 * shifts arithmetically, and the build uses -fwrapv. */
#ifndef NODESIM_FIXEDPOINT_H
#define NODESIM_FIXEDPOINT_H
#include <stdint.h>

/* cdef-begin */
int64_t fx_sat(int64_t x, int64_t frac_in, int64_t w, int64_t f, int64_t *counts, int64_t site);
int64_t fx_add(int64_t a, int64_t fa, int64_t b, int64_t fb, int64_t w, int64_t f, int64_t *counts, int64_t site);
int64_t fx_sub(int64_t a, int64_t fa, int64_t b, int64_t fb, int64_t w, int64_t f, int64_t *counts, int64_t site);
int64_t fx_mul(int64_t a, int64_t fa, int64_t b, int64_t fb, int64_t w, int64_t f, int64_t *counts, int64_t site);
int64_t fx_div(int64_t a, int64_t fa, int64_t b, int64_t fb, int64_t w, int64_t f, int64_t *counts, int64_t site);
int64_t fx_wrap(int64_t x, int64_t w);
int64_t fx_div_round(int64_t n, int64_t d);
int64_t fx_shift_round(int64_t x, int64_t s);
/* cdef-end */

#endif
