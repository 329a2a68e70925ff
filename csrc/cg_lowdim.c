/*
 * cg_lowdim.c -- MercuryCG's line integral of its Gauss kernel along one
 * resolved axis (its X, Y and Z profiles), for reproducing MercuryCG's
 * ContactStress exactly (cg_kernel.mercurycg_line, see cg.h).
 *
 * MercuryCG (MercuryDPM's Gauss<Coordinates>::evaluateCGIntegral1D with
 * Base_X_Y_Z::getGaussIntegralPrefactor) does not integrate its cut-off 1-D
 * Gaussian along the branch. With the branch's ends at signed distances
 * lo <= hi from the node along the resolved axis, its extent d = hi - lo,
 * s = sqrt(2) w and cutoff c it takes
 *
 *   psi = P(d) [erf(hi / s) - erf(lo / s)],  0 if hi < -c or lo > c,
 *   P(d) = 1 / (2 [G(c + d) - G(-c)]),  G(x) = x erf(x / s) + s / sqrt(pi) exp(-x^2 / s^2)
 *
 * (G is an antiderivative of erf(x / s): psi integrates to 1 over the nodes
 * it reaches), and a branch with no extent along the axis is the kernel's
 * point value. The exact integral of the cut-off Gaussian differs from it by
 * 1e-3 to 1e-2 near the cutoff. Divided by avg_extent like every kernel.
 */
#include "cg.h"
#include "cg_internal.h"

#include <math.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* x erf(x / s) + s / sqrt(pi) exp(-x^2 / s^2) */
static double erf_antiderivative(double x, double s)
{
    const double y = x / s;
    return x * erf(y) + s / sqrt(M_PI) * exp(-y * y);
}

/* erf(b) - erf(a), a <= b, without the cancellation of two tails of one sign */
static double erf_difference(double a, double b)
{
    if (a >= 0.0) return erfc(a) - erfc(b);
    if (b <= 0.0) return erfc(-b) - erfc(-a);
    return erf(b) - erf(a);
}

double cg_mercurycg_gauss_line(const cg_kernel *k, double q, double e)
{
    /* the ends' positions relative to the node: start at -q, end at e - q */
    const double u0 = -q, u1 = e - q;
    const double lo = fmin(u0, u1), hi = fmax(u0, u1), d = hi - lo;
    const double c = k->radius, w = k->width, s = sqrt(2.0) * w;
    if (!(d > 1e-10 * c)) return cg_kernel_value(k, q * q); /* no extent: the point value */
    if (hi < -c || lo > c) return 0.0;
    const double norm = 2.0 * (erf_antiderivative(c + d, s) - erf_antiderivative(-c, s));
    return erf_difference(lo / s, hi / s) / (norm * k->avg_extent);
}
