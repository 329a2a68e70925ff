/*
 * cg_gradient.c -- gradients of the marginal kernels over averaged axes
 * (D_avg > 0), for point objects. The Gaussian's marginal is a Gaussian in
 * the resolved axes, whose gradient cg_kernel_gradient already gives; this
 * file adds Lucy's two marginals. Heaviside has no gradient (its full kernel
 * jumps at R, its marginals are not differentiable at the edge) and is
 * refused by the Python layer.
 *
 * Lucy, W = C P(r/R), P(x) = (1 + 3x)(1 - x)^3, P'(x) = -12 x (1 - x)^2.
 * With x = rho/R the resolved distance in units of R and the marginal M of
 * cg_kernels.c (prefactor K = the kernel's prefactor):
 *
 *   one averaged axis:  M = K m1(x),  m1(x) = int_{-h}^{h} P(sqrt(x^2 + y^2)) dy,
 *                       h = sqrt(1 - x^2). P(1) = 0, so the moving limits add
 *                       nothing and dm1/dx = -12 x G(x) with
 *                       G(x) = int_{-h}^{h} (1 - r)^2 dy, r = sqrt(x^2 + y^2)
 *                            = 2 x^2 h + (2/3) h^3 - 2 x^2 ln((1 + h) / x).
 *                       grad M = K m1'(x) (r_vec / rho) / R = -12 K G(x) r_vec / R^2.
 *   two averaged axes:  M = K g2(x),  g2(x) = int_x^1 P(s) s ds, g2'(x) = -x P(x),
 *                       grad M = -K P(x) r_vec / R^2.
 *
 * Both are smooth at rho = 0 (G(0) = 2/3, P(0) = 1) and vanish at the edge.
 * G's closed form cancels like h^5 near x = 1: there the smooth integrand
 * (1 - r)^2 is integrated by two 12-point Gauss-Legendre panels on [0, h],
 * as cg_kernels.c does for m1 itself.
 */
#include "cg.h"
#include "cg_internal.h"

#include <math.h>

/* G(x) = int_{-h}^{h} (1 - sqrt(x^2 + y^2))^2 dy, 0 <= x < 1 */
static double lucy_gradient_chord(double x)
{
    const double h = sqrt((1.0 - x) * (1.0 + x));
    if (x < 0.5) {
        const double x2 = x * x;
        double g = 2.0 * x2 * h + 2.0 / 3.0 * h * h * h;
        if (x > 0.0) g -= 2.0 * x2 * log((1.0 + h) / x);
        return g;
    }
    /* G = 2 int_0^h: two panels of the 12-point rule on [0, 1] */
    double xs[12], ws[12], sum = 0.0;
    cg_gauss_legendre01(12, xs, ws);
    for (int panel = 0; panel < 2; ++panel) {
        const double lo = 0.5 * h * panel, len = 0.5 * h;
        for (int k = 0; k < 12; ++k) {
            const double y = lo + len * xs[k], o = 1.0 - sqrt(x * x + y * y);
            sum += ws[k] * len * o * o;
        }
    }
    return 2.0 * sum;
}

double cg_lucy_marginal_gradient(const cg_kernel *k, const double *x, double *grad)
{
    const int n = k->n_resolved;
    const double R = k->radius;
    double rho2 = 0.0;
    for (int d = 0; d < n; ++d) rho2 += x[d] * x[d];
    const double value = cg_kernel_value(k, rho2);
    double factor = 0.0; /* grad = factor * x */
    if (rho2 < R * R) {
        const double s = sqrt(rho2) / R;
        if (cg_kernel_marginal_axes(k) == 1) {
            factor = -12.0 * k->prefactor * lucy_gradient_chord(s) / (R * R);
        } else {
            const double om = 1.0 - s;
            factor = -k->prefactor * (1.0 + 3.0 * s) * om * om * om / (R * R);
        }
    }
    for (int d = 0; d < n; ++d) grad[d] = factor * x[d];
    return value;
}
