/*
 * cg_vmath.h -- elementary functions written as straight-line arithmetic, so
 * that loops calling them vectorise (libm's exp and sin are one call per
 * value). Used by the separable Gaussian path (cg_separable.c) and the ring
 * moments (cg_ring.c).
 */
#ifndef CG_VMATH_H
#define CG_VMATH_H

#include "cg.h"

#include <stdint.h>
#include <string.h>

#if defined(__GNUC__)
#define CG_VMATH_INLINE static inline __attribute__((always_inline))
#else
#define CG_VMATH_INLINE static inline
#endif

/* p <- exp(r) for |r| <= 0.347: the Taylor polynomial of degree 13,
   1 + r (1 + r T) with T = sum_k r^(k-2) / k! for k = 2..13 in two parts,
   T = Tlo + r^6 Thi (k = 2..7 and 8..13), each in Horner form: two chains of
   5 steps side by side, then 3, instead of one chain of 13 (a step waits for
   the previous one's result, so one long chain left the units idle). The
   last steps are Horner's, and so is the rounding of the value (Thi adds
   below 2e-7 of T). (p, r: scalars or GCC vectors of doubles, p's type that
   of the temporaries; cg_separable.c's exp_erfcx_lanes takes the same steps.) */
#define CG_EXP_TAYLOR13(p, r)                                                 \
    do {                                                                      \
        const __typeof__(p) r2_ = (r) * (r), r6_ = r2_ * r2_ * r2_;           \
        __typeof__(p) lo_ = (r) * (1.0 / 5040.0) + 1.0 / 720.0;               \
        __typeof__(p) hi_ = (r) * (1.0 / 6227020800.0) + 1.0 / 479001600.0;   \
        lo_ = lo_ * (r) + 1.0 / 120.0;                                        \
        hi_ = hi_ * (r) + 1.0 / 39916800.0;                                   \
        lo_ = lo_ * (r) + 1.0 / 24.0;                                         \
        hi_ = hi_ * (r) + 1.0 / 3628800.0;                                    \
        lo_ = lo_ * (r) + 1.0 / 6.0;                                          \
        hi_ = hi_ * (r) + 1.0 / 362880.0;                                     \
        lo_ = lo_ * (r) + 0.5;                                                \
        hi_ = hi_ * (r) + 1.0 / 40320.0;                                      \
        p = lo_ + r6_ * hi_;                                                  \
        p = p * (r) + 1.0;                                                    \
        p = p * (r) + 1.0;                                                    \
    } while (0)

/* x[i] = exp(x[i]) for x[i] <= 0, in a loop the compiler vectorises (libm's
   exp is one call per value). exp(x) = 2^k exp(r), k = round(x / ln 2), with
   r = x - k ln 2 (two-part ln 2, exact products) in [-0.347, 0.347] and
   exp(r) by its Taylor polynomial of degree 13 (CG_EXP_TAYLOR13; remainder
   < 5e-18); 2^k is built in the exponent bits from the rounding shifter's
   mantissa. Within 1 ulp of the exact value (tests/test_gauss_exact_fast.py,
   against mpmath); 0 below -708 (where exp is subnormal). */
CG_VMATH_INLINE void cg_exp_in_place(double *restrict x, cg_index n)
{
    const double log2e = 1.4426950408889634, shifter = 0x1.8p52;
    const double ln2_hi = 6.93147180369123816490e-01, ln2_lo = 1.90821492927058770002e-10;
    const uint64_t shifter_bits = UINT64_C(0x4338000000000000);
    for (cg_index i = 0; i < n; ++i) {
        const double x0 = x[i];
        const double v = x0 < -708.0 ? -708.0 : (x0 > 0.0 ? 0.0 : x0);
        const double shifted = v * log2e + shifter; /* k in the low bits of the mantissa */
        const double kd = shifted - shifter;
        const double r = (v - kd * ln2_hi) - kd * ln2_lo;
        double p;
        CG_EXP_TAYLOR13(p, r);
        uint64_t bits;
        memcpy(&bits, &shifted, sizeof bits);
        bits = (bits - shifter_bits + 1023) << 52; /* 2^k */
        double two_k;
        memcpy(&two_k, &bits, sizeof two_k);
        x[i] = x0 < -708.0 ? 0.0 : p * two_k;
    }
}

/* sin(x) for |x| <= pi/2: its Taylor polynomial of degree 23 in Horner form in
   x^2 (remainder (pi/2)^25 / 25! < 6e-21 relative), within 1 ulp or so of
   libm's sin there. */
CG_VMATH_INLINE double cg_sin_half_pi(double x)
{
    const double x2 = x * x;
    double p = -1.0 / 25852016738884976640000.0;   /* -1/23! */
    p = p * x2 + 1.0 / 51090942171709440000.0;      /* 1/21! */
    p = p * x2 - 1.0 / 121645100408832000.0;        /* -1/19! */
    p = p * x2 + 1.0 / 355687428096000.0;           /* 1/17! */
    p = p * x2 - 1.0 / 1307674368000.0;             /* -1/15! */
    p = p * x2 + 1.0 / 6227020800.0;                /* 1/13! */
    p = p * x2 - 1.0 / 39916800.0;                  /* -1/11! */
    p = p * x2 + 1.0 / 362880.0;                    /* 1/9! */
    p = p * x2 - 1.0 / 5040.0;                      /* -1/7! */
    p = p * x2 + 1.0 / 120.0;                       /* 1/5! */
    p = p * x2 - 1.0 / 6.0;                         /* -1/3! */
    return x + x * (x2 * p);
}

#endif
