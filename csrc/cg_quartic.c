/*
 * cg_quartic.c -- the complex roots of many quartics at once (the breakpoints
 * of the ring segment rules, cgbound/cylindrical_ring.py: where a segment's
 * point enters the torus of a ring's support, and the branch points next to it).
 *
 * Aberth-Ehrlich iteration on the monic quartic, no companion matrix: from four
 * points on a circle of the Fujiwara radius (which holds every root), each
 * sweep updates z_k -= w_k, w_k = N_k / (1 - N_k sum_{j != k} 1 / (z_k - z_j)),
 * N_k = p(z_k) / p'(z_k), the roots in turn (Gauss-Seidel). Convergence is cubic
 * at simple roots and linear at multiple ones (a grazing segment: a close
 * pair, as the eigenvalues of the companion matrix give it); the sweeps stop
 * when every step is at most 2^-52 of its root (or zero), after at most
 * QUARTIC_SWEEPS. Only +, -, *, / and sqrt, in a fixed order, so the NumPy twin
 * (tests/oracle.py) has the same bits, and rows are independent of each other
 * and of the thread count.
 */
#include "cg.h"
#include "cg_internal.h"

#include <math.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#define QUARTIC_SWEEPS 200
#define QUARTIC_TOLERANCE 2.220446049250313e-16

/* cos and sin of pi k / 2 + 0.4, k = 0..3: the starting angles (off the axes, where real roots sit) */
static const double quartic_cos[4] = {0.92106099400288510, -0.38941834230865050, -0.92106099400288510,
                                      0.38941834230865050};
static const double quartic_sin[4] = {0.38941834230865050, 0.92106099400288510, -0.38941834230865050,
                                      -0.92106099400288510};

/* the roots of x^4 + b[0] x^3 + b[1] x^2 + b[2] x + b[3] */
static void quartic_one(const double *b, double *re, double *im)
{
    /* Fujiwara: every root has |z| <= 2 max(|b0|, |b1|^(1/2), |b2|^(1/3), |b3 / 2|^(1/4)) */
    double R = fabs(b[0]);
    const double r1 = sqrt(fabs(b[1])), r2 = cbrt(fabs(b[2])), r3 = sqrt(sqrt(fabs(b[3]) * 0.5));
    if (r1 > R) R = r1;
    if (r2 > R) R = r2;
    if (r3 > R) R = r3;
    R = R > 0.0 ? 2.0 * R : 1.0;
    for (int k = 0; k < 4; ++k) {
        re[k] = R * quartic_cos[k];
        im[k] = R * quartic_sin[k];
    }
    for (int sweep = 0; sweep < QUARTIC_SWEEPS; ++sweep) {
        int done = 1;
        for (int k = 0; k < 4; ++k) {
            const double x = re[k], y = im[k];
            /* Horner for p and p' at z = x + i y */
            double pr = 1.0, pi = 0.0, dr = 0.0, di = 0.0;
            for (int j = 0; j < 4; ++j) {
                const double ndr = dr * x - di * y + pr, ndi = dr * y + di * x + pi;
                const double npr = pr * x - pi * y + b[j], npi = pr * y + pi * x;
                dr = ndr;
                di = ndi;
                pr = npr;
                pi = npi;
            }
            if (pr == 0.0 && pi == 0.0) continue; /* a root */
            double nr, ni;                        /* N = p / p' */
            const double dd = dr * dr + di * di;
            if (dd > 0.0) {
                nr = (pr * dr + pi * di) / dd;
                ni = (pi * dr - pr * di) / dd;
            } else {
                nr = pr;
                ni = pi;
            }
            double sr = 0.0, si = 0.0; /* sum_{j != k} 1 / (z_k - z_j) */
            for (int j = 0; j < 4; ++j) {
                if (j == k) continue;
                const double ur = x - re[j], ui = y - im[j];
                const double uu = ur * ur + ui * ui;
                if (uu > 0.0) {
                    sr += ur / uu;
                    si -= ui / uu;
                }
            }
            const double qr = 1.0 - (nr * sr - ni * si), qi = -(nr * si + ni * sr); /* 1 - N S */
            const double qq = qr * qr + qi * qi;
            double wr = nr, wi = ni;
            if (qq > 0.0) {
                wr = (nr * qr + ni * qi) / qq;
                wi = (ni * qr - nr * qi) / qq;
            }
            re[k] = x - wr;
            im[k] = y - wi;
            if (wr * wr + wi * wi > QUARTIC_TOLERANCE * QUARTIC_TOLERANCE * (re[k] * re[k] + im[k] * im[k]))
                done = 0;
        }
        if (done) break;
    }
}

cg_status cg_quartic_roots(cg_index n, const double *coef, double *roots, int n_threads)
{
    if (n < 0) return CG_ERR_ARGUMENT;
    for (cg_index i = 0; i < 5 * n; ++i)
        if (!isfinite(coef[i])) return CG_ERR_ARGUMENT;
    for (cg_index i = 0; i < n; ++i)
        if (coef[5 * i] == 0.0) return CG_ERR_ARGUMENT;
    int threads = 1;
#ifdef _OPENMP
    threads = n_threads > 0 ? n_threads : omp_get_max_threads();
    if (n < 256 || threads < 1) threads = 1;
#else
    (void)n_threads;
#endif
    (void)threads;
#ifdef _OPENMP
#pragma omp parallel for schedule(static, 64) num_threads(threads)
#endif
    for (cg_index i = 0; i < n; ++i) {
        const double *a = coef + 5 * i;
        const double b[4] = {a[1] / a[0], a[2] / a[0], a[3] / a[0], a[4] / a[0]};
        double re[4], im[4];
        quartic_one(b, re, im);
        for (int k = 0; k < 4; ++k) {
            roots[8 * i + 2 * k] = re[k];
            roots[8 * i + 2 * k + 1] = im[k];
        }
    }
    return CG_OK;
}
