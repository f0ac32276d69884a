/* Integer CORDIC, vectoring mode (and rotation mode, cordic_sin_cos = cordic.sin_cos): the C of firmware_model/cordic.py (docstring there: pre-shift, pre-rotation,
 * iterations, gain removal). Binary angles: 2^32 = one turn, returned as the wrapped 32-bit value in an int64.
 * Every intermediate of the iterations fits an int32 (|x|, |y| < 2^31 after the pre-shift); they are held in
 * int64_t here so the gain product x * K_INV needs no cast. */
#ifndef NODESIM_CORDIC_H
#define NODESIM_CORDIC_H
#include <stdint.h>

#define CORDIC_MIN_ITERATIONS 8
#define CORDIC_MAX_ITERATIONS 30
#define CORDIC_DEFAULT_ITERATIONS 24
#define CORDIC_NORM_BITS 29
#define CORDIC_GAIN_FRAC 30

/* cdef-begin */
int64_t cordic_atan_entry(int32_t i);
int64_t cordic_gain_inv(int32_t iterations);
int64_t cordic_wrap32(int64_t x);
int32_t cordic_norm_shift(int64_t m, int32_t bits);
int64_t cordic_shift(int64_t x, int32_t s);
int32_t cordic_vectoring(int64_t x, int64_t y, int32_t iterations, int64_t *angle, int64_t *magnitude);
int32_t cordic_sin_cos(int64_t angle, int32_t iterations, int64_t *sin_q30, int64_t *cos_q30);
/* cdef-end */

#endif
