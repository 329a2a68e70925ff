/*
 * cg_moment.c -- the kernel's first moment along a segment,
 *   chi(q) = int_0^1 s M(|q - s e|^2) ds,
 * and its gradient with respect to the node (cg.h, cg_kernel_line_moment). The
 * branch-line couple stress needs it (docs/theory.md, "Rotation and couple
 * stress").
 *
 * In the frame of the segment (segment_frame: the node offset q = q_perp + t n
 * with t(s) = u - s L along the unit vector n, a^2 = |q_perp|^2), with [s0, s1]
 * the part of [0, 1] inside the support and t0 = t(s0) >= t1 = t(s1):
 *   chi = (u I0 - I1) / L^2,  I_k = int_{t1}^{t0} t^k W dt,
 * and with grad W(y) = g(rho) y (g = W'(rho) / rho), G_k = int t^k g dt,
 *   grad chi = (q_perp (u G0 - G1) + n (u G1 - G2)) / L^2,
 *   I1 = [Phi]_{t1}^{t0} (Phi' = rho W),  G1 = [W]_{t1}^{t0},  G2 = [t W]_{t1}^{t0} - I0.
 * I0 is the line integral (cg_kernel_line's exact paths), G0 = -I0 / w^2 for the
 * Gaussian and -12 C / R^2 int (1 - x)^2 dt for Lucy (cg_lucy_line). The
 * differences of end values are formed without cancellation (expm1 for the
 * Gaussian, divided differences of Lucy's polynomials).
 *
 * u I0 - I1 cancels when the closest approach t = 0 is far from [t1, t0]
 * compared with its length (short segments seen from afar), and the gradient's
 * combinations cancel like R / (t0 - t1) on short pieces: there 16-point
 * Gauss-Legendre panels integrate s M and s grad M to round-off, split at the
 * closest approach and, for Lucy, graded toward it (its profile has a kink
 * where the line meets the node, a near-singularity of scale a near it).
 *
 * Lucy's and Heaviside's marginals over averaged axes (values only): the same
 * panels of s M (marginal_moment): exact for the polynomial marginals over two
 * axes, graded toward both ends of each piece for Lucy's over one axis (its
 * kink and its (R - rho)^(7/2) edge), and for Heaviside's chord over one axis
 * a change of variable that removes its square-root edge (chord_half).
 */
#include "cg.h"
#include "cg_internal.h"

#include <math.h>

/* the closed form is used when the closest approach is within FAR_RATIO interval
   lengths of the interval (the cancellation of u I0 - I1 is then at most ~2 FAR_RATIO) */
#define FAR_RATIO 8.0
/* the closed form's gradient cancels like R / (t0 - t1): pieces shorter than
   SHORT_RATIO R are integrated by quadrature */
#define SHORT_RATIO 0.0625
#define GL_POINTS 16

/* 16-point Gauss-Legendre over [lo, hi] of s M(q - s e) (and s grad M), added into *chi, grad */
static void moment_panel(const cg_kernel *k, const double *q, const double *e, double lo, double hi, double *chi,
                         double *grad)
{
    const int n = k->n_resolved;
    double xs[GL_POINTS], ws[GL_POINTS], y[3], g[3];
    cg_gauss_legendre01(GL_POINTS, xs, ws);
    const double width = hi - lo;
    for (int i = 0; i < GL_POINTS; ++i) {
        const double s = lo + xs[i] * width, w = ws[i] * width * s;
        for (int d = 0; d < n; ++d) y[d] = q[d] - s * e[d];
        if (grad) {
            *chi += w * cg_kernel_gradient(k, y, g);
            for (int d = 0; d < n; ++d) grad[d] += w * g[d];
        } else {
            double rho2 = 0.0;
            for (int d = 0; d < n; ++d) rho2 += y[d] * y[d];
            *chi += w * cg_kernel_value(k, rho2);
        }
    }
}

/* [lo, hi] in panels: `uniform` equal ones, or (levels > 0) graded geometrically
   (ratio 2) toward lo (toward_lo) or hi, the smallest 2^-levels of the length */
static void moment_piece(const cg_kernel *k, const double *q, const double *e, double lo, double hi, int uniform,
                         int levels, int toward_lo, double *chi, double *grad)
{
    if (!(hi > lo)) return;
    const double len = hi - lo;
    if (levels <= 0) {
        for (int p = 0; p < uniform; ++p)
            moment_panel(k, q, e, lo + len * p / uniform, p + 1 == uniform ? hi : lo + len * (p + 1) / uniform, chi,
                         grad);
        return;
    }
    double near = 0.0;   /* distance from the graded end, in units of len */
    for (int l = levels; l >= 0; --l) {
        const double far = l == 0 ? 1.0 : ldexp(1.0, -l);
        if (toward_lo) moment_panel(k, q, e, lo + near * len, l == 0 ? hi : lo + far * len, chi, grad);
        else moment_panel(k, q, e, l == 0 ? lo : hi - far * len, hi - near * len, chi, grad);
        near = far;
    }
}

/* levels of grading for a piece of length len (in t) toward a near-singularity of scale `scale` */
static int grading_levels(double len, double scale)
{
    if (!(len > scale)) return 0;
    const int levels = (int)ceil(log2(len / scale));
    return levels > 60 ? 60 : levels;
}

/* Gauss-Legendre quadrature of chi (and grad chi) over [s0, s1], split at the
   closest approach s* = u / L when it is inside. Lucy: panels graded toward s*
   (or toward the nearer end when s* is outside), where its profile has a kink
   (at a = 0) or a near-singularity of scale sqrt(a^2 + dist^2). Gaussian:
   entire, a panel per 4 of the change of its exponent. */
static double moment_quadrature(const cg_kernel *k, const segment_frame *f, const double *q, const double *e,
                                double s0, double s1, double dist, double *grad)
{
    const int n = k->n_resolved;
    double chi = 0.0;
    if (grad) for (int d = 0; d < n; ++d) grad[d] = 0.0;
    const double star = f->u / f->L;
    const int split = star > s0 && star < s1;
    double pieces[2][2] = {{s0, split ? star : s1}, {split ? star : s1, s1}};
    for (int i = 0; i < 1 + split; ++i) {
        const double lo = pieces[i][0], hi = pieces[i][1];
        const double ta = fabs(f->u - lo * f->L), tb = fabs(f->u - hi * f->L);
        if (k->type == CG_KERNEL_GAUSSIAN) {
            const double change = fabs(ta * ta - tb * tb) / (2.0 * k->width * k->width);
            const int panels = change > 4.0 * 64 ? 64 : 1 + (int)(change / 4.0);
            moment_piece(k, q, e, lo, hi, panels, 0, 0, &chi, grad);
        } else {
            const double scale = fmax(sqrt(f->a2 + dist * dist), 1e-9 * k->radius);
            const int toward_lo = ta <= tb;
            moment_piece(k, q, e, lo, hi, 1, grading_levels((hi - lo) * f->L, scale), toward_lo, &chi, grad);
        }
    }
    return chi;
}

/* the n-point Gauss-Legendre rule over the whole segment (the Gaussian's line_points) */
static double moment_rule(const cg_kernel *k, const double *q, const double *e, double *grad, int n_points)
{
    const int n = k->n_resolved;
    double xs[CG_MAX_LINE_POINTS], ws[CG_MAX_LINE_POINTS], y[3], g[3];
    cg_gauss_legendre01(n_points, xs, ws);
    double chi = 0.0;
    if (grad) for (int d = 0; d < n; ++d) grad[d] = 0.0;
    for (int i = 0; i < n_points; ++i) {
        const double w = ws[i] * xs[i];
        for (int d = 0; d < n; ++d) y[d] = q[d] - xs[i] * e[d];
        if (grad) {
            chi += w * cg_kernel_gradient(k, y, g);
            for (int d = 0; d < n; ++d) grad[d] += w * g[d];
        } else {
            double rho2 = 0.0;
            for (int d = 0; d < n; ++d) rho2 += y[d] * y[d];
            chi += w * cg_kernel_value(k, rho2);
        }
    }
    return chi;
}

/* Lucy's profile P(x) = 1 - 6x^2 + 8x^3 - 3x^4 and phi(x) = int_0^x x' P(x') dx'
   = x^2/2 - 3x^4/2 + 8x^5/5 - x^6/2: their differences between x0 and x1 as
   (x0 - x1) times divided differences, dx = x0 - x1 given accurately */
static void lucy_differences(double x0, double x1, double dx, double *dP, double *dphi)
{
    /* h_k = sum_{j=0}^{k} x0^j x1^(k-j), the divided difference of x^(k+1) */
    double h[6];
    h[0] = 1.0;
    double p0 = 1.0;
    for (int m = 1; m < 6; ++m) {
        p0 *= x0;
        h[m] = h[m - 1] * x1 + p0;
    }
    *dP = dx * (-6.0 * h[1] + 8.0 * h[2] - 3.0 * h[3]);
    *dphi = dx * (0.5 * h[1] - 1.5 * h[3] + 1.6 * h[4] - 0.5 * h[5]);
}

/* [lo, hi] split at its midpoint, each half graded toward its own end (levels as grading_levels) */
static void moment_two_ended(const cg_kernel *k, const double *q, const double *e, double lo, double hi,
                             int levels_lo, int levels_hi, double *chi)
{
    const double mid = 0.5 * (lo + hi);
    moment_piece(k, q, e, lo, mid, 1, levels_lo, 1, chi, NULL);
    moment_piece(k, q, e, mid, hi, 1, levels_hi, 0, chi, NULL);
}

/* sqrt(b^2 - t^2) at s, as sqrt((b - |t|)(b + |t|)); with `edge`, b - |t| = |s - se| L, the distance from
   the support's edge se (a clipped end), without the cancellation of b - |t| there */
static double chord_at(const segment_frame *f, double b, double s, int edge, double se)
{
    const double t = fabs(t_at(f, s));
    const double gap = edge ? fabs(s - se) * f->L : b - t;
    return gap > 0.0 ? sqrt(gap * (edge ? 2.0 * b - gap : b + t)) : 0.0;
}

/* int s sqrt(b^2 - t^2) ds over [lo, hi], whose end `outer` (0: lo, 1: hi) may be the support's edge
   (clipped): there s = edge + (inward) (hi - lo) w^2 makes the integrand smooth in w (the chord is w times a
   smooth factor); otherwise panels graded toward the outer end by its distance to the edge */
static double chord_half(const segment_frame *f, double b, double R, double lo, double hi, int outer, int clipped)
{
    double xs[GL_POINTS], ws[GL_POINTS];
    cg_gauss_legendre01(GL_POINTS, xs, ws);
    const double span = hi - lo, se = outer ? hi : lo, inward = outer ? -1.0 : 1.0;
    double sum = 0.0;
    if (clipped) {
        for (int p = 0; p < 2; ++p)
            for (int i = 0; i < GL_POINTS; ++i) {
                const double w = 0.5 * (p + xs[i]), s = se + inward * span * w * w;
                sum += 0.5 * ws[i] * 2.0 * span * w * s * chord_at(f, b, s, 1, se);
            }
        return sum;
    }
    /* down to 1e-15 R: an end on the edge itself leaves sqrt(x) on the finest panel, ~(1e-15)^1.5 of the rest */
    const double to_edge = fmax(b - fabs(t_at(f, se)), 1e-15 * R);
    const int levels = grading_levels(span * f->L, to_edge);
    double near = 0.0;   /* distance from the outer end, in units of span */
    for (int l = levels; l >= 0; --l) {
        const double far = l == 0 ? 1.0 : ldexp(1.0, -l);
        const double a = se + inward * near * span, c = se + inward * far * span;
        const double plo = fmin(a, c), width = fabs(c - a);
        for (int i = 0; i < GL_POINTS; ++i) {
            const double s = plo + xs[i] * width;
            sum += ws[i] * width * s * chord_at(f, b, s, 0, se);
        }
        near = far;
    }
    return sum;
}

/* Heaviside's marginal over one averaged axis, M = 2 C sqrt(b^2 - t^2) (smooth inside the support, a square-root
   edge where the support clips the segment): the two halves of [s0, s1], each toward its own end */
static double heaviside_chord_moment(const cg_kernel *k, const segment_frame *f, double s0, double s1, double b)
{
    const double mid = 0.5 * (s0 + s1), R = k->radius;
    const double sum = chord_half(f, b, R, s0, mid, 0, s0 > 0.0) + chord_half(f, b, R, mid, s1, 1, s1 < 1.0);
    return 2.0 * k->prefactor * sum;
}

/* Lucy's and Heaviside's marginals over averaged axes (no gradient): split at the closest approach; Lucy over
   two axes and Heaviside over two are polynomials in |t| (degree <= 6) on each side, so one 16-point panel per
   side is exact; Lucy over one axis has a near-singularity of scale sqrt(a^2 + t^2) at the closest approach
   (its r^3 term gives x^4 log x) and the branch point (R - rho)^(7/2) at the support's edge, so each piece is
   graded toward both ends, as cg_kernel_line grades the same marginal */
static double marginal_moment(const cg_kernel *k, const segment_frame *f, const double *q, const double *e,
                              double s0, double s1, double b)
{
    const int n_avg = cg_kernel_marginal_axes(k);
    if (k->type == CG_KERNEL_HEAVISIDE && n_avg == 1) return heaviside_chord_moment(k, f, s0, s1, b);
    const double R = k->radius, star = f->u / f->L;
    const int split = star > s0 && star < s1;
    const double cuts[3] = {s0, split ? star : s1, s1};
    const int graded = k->type == CG_KERNEL_LUCY && n_avg == 1;
    double chi = 0.0;
    for (int i = 0; i < 1 + split; ++i) {
        const double lo = cuts[i], hi = cuts[i + 1];
        if (!graded) {
            moment_piece(k, q, e, lo, hi, 1, 0, 0, &chi, NULL);
            continue;
        }
        int levels[2];
        const double half = 0.5 * (hi - lo) * f->L;
        for (int end = 0; end < 2; ++end) {
            const double s = end ? hi : lo, t = fabs(t_at(f, s));
            const int clipped = end ? s1 < 1.0 && hi == s1 : s0 > 0.0 && lo == s0;
            const double to_kink = fmax(sqrt(f->a2 + t * t), 1e-9 * R);
            const double to_edge = fmax(clipped ? 0.0 : b - t, 1e-7 * R);
            levels[end] = grading_levels(half, fmin(to_kink, to_edge));
        }
        moment_two_ended(k, q, e, lo, hi, levels[0], levels[1], &chi);
    }
    return chi;
}

double cg_kernel_line_moment(const cg_kernel *k, const double *q, const double *e, double *grad)
{
    const int rule = k->type == CG_KERNEL_GAUSSIAN ? k->line_points : 0;
    return cg_kernel_line_moment_rule(k, q, e, grad, rule);
}

double cg_kernel_line_moment_rule(const cg_kernel *k, const double *q, const double *e, double *grad, int n_points)
{
    const int n = k->n_resolved;
    if (n == 0) return 0.5 * k->prefactor;
    if (n_points > 0 && k->type == CG_KERNEL_GAUSSIAN) return moment_rule(k, q, e, grad, n_points);
    double L2 = 0.0;
    for (int d = 0; d < n; ++d) L2 += e[d] * e[d];
    if (L2 == 0.0) {
        /* zero length: int_0^1 s ds times the point value */
        if (grad) {
            const double v = cg_kernel_gradient(k, q, grad);
            for (int d = 0; d < n; ++d) grad[d] *= 0.5;
            return 0.5 * v;
        }
        double rho2 = 0.0;
        for (int d = 0; d < n; ++d) rho2 += q[d] * q[d];
        return 0.5 * cg_kernel_value(k, rho2);
    }
    if (grad) for (int d = 0; d < n; ++d) grad[d] = 0.0;
    segment_frame f;
    make_frame(n, q, e, &f);
    double s0, s1, b;
    const double R = k->radius;
    if (!clip_to_support(&f, R, &s0, &s1, &b)) return 0.0;
    const double t0 = t_at(&f, s0), t1 = t_at(&f, s1), span = (s1 - s0) * f.L;
    if (k->type != CG_KERNEL_GAUSSIAN && cg_kernel_marginal_axes(k) > 0) {
        if (grad) for (int d = 0; d < n; ++d) grad[d] = NAN;   /* not offered: the scatter refuses it */
        return marginal_moment(k, &f, q, e, s0, s1, b);
    }
    if (k->type == CG_KERNEL_HEAVISIDE) /* constant: C (s1^2 - s0^2) / 2; no gradient */
        return k->prefactor * 0.5 * (s1 - s0) * (s1 + s0);
    const double dist = t1 > 0.0 ? t1 : (t0 < 0.0 ? -t0 : 0.0);
    if (dist > FAR_RATIO * span || span < SHORT_RATIO * R)
        return moment_quadrature(k, &f, q, e, s0, s1, dist, grad);
    const double u = f.u, Lsq = f.L * f.L;
    double I0, I1, G0 = 0.0, G1 = 0.0, W0 = 0.0, W1 = 0.0;
    if (k->type == CG_KERNEL_GAUSSIAN) {
        const double w2 = k->width * k->width, c = 0.5 / w2;
        I0 = f.L * cg_kernel_line_rule(k, q, e, NULL, 0);
        const double amp = k->prefactor * exp(-f.a2 * c);
        W0 = amp * exp(-t0 * t0 * c);
        /* W(t1) - W(t0) = W(t0) expm1((t0 - t1)(t0 + t1) / 2w^2) */
        const double diff = W0 * expm1(span * (t0 + t1) * c);
        W1 = W0 + diff;
        I1 = w2 * diff;          /* Phi = -w^2 W */
        G0 = -I0 / w2;
        G1 = -diff;
    } else {
        /* Lucy, the full-dimensional kernel */
        double acc[3];
        cg_lucy_line(f.a2, t0, t1, span, R, grad != NULL, acc);
        const double C = k->prefactor;
        I0 = C * R * acc[0];
        const double x0 = fmin(1.0, sqrt(f.a2 + t0 * t0) / R), x1 = fmin(1.0, sqrt(f.a2 + t1 * t1) / R);
        double dP = 0.0, dphi = 0.0;
        if (x0 + x1 > 0.0) {
            /* x0 - x1 = (t0 - t1)(t0 + t1) / (R^2 (x0 + x1)) */
            const double dx = span * (t0 + t1) / (R * R * (x0 + x1));
            lucy_differences(x0, x1, dx, &dP, &dphi);
        }
        I1 = C * R * R * dphi;
        if (grad) {
            const double om0 = 1.0 - x0, om1 = 1.0 - x1;
            W0 = C * (1.0 + 3.0 * x0) * om0 * om0 * om0;
            W1 = C * (1.0 + 3.0 * x1) * om1 * om1 * om1;
            G0 = -12.0 * C / R * acc[1];
            G1 = C * dP;
        }
    }
    const double chi = (u * I0 - I1) / Lsq;
    if (grad) {
        const double G2 = t0 * W0 - t1 * W1 - I0;
        const double perp = (u * G0 - G1) / Lsq, along = (u * G1 - G2) / Lsq;
        for (int d = 0; d < n; ++d) grad[d] = f.qperp[d] * perp + f.unit[d] * along;
    }
    return chi;
}
