/*
 * cg_kernels.c -- kernel values, marginals over averaged axes, line integrals
 * along contact branches and their gradients. See cg.h for the definitions.
 *
 * Line integrals are written in the frame of the segment: with L = |e|,
 * unit vector n = e/L, u = q.n and q_perp = q - u n (component-wise, which
 * keeps |q_perp| accurate when q is nearly parallel to e), the point of the
 * segment at parameter s is at signed distance t(s) = u - s L along n from
 * the node's foot, and psi = int_s0^s1 M(a^2 + t(s)^2) ds where [s0, s1] is
 * [0, 1] clipped to the support ball of radius R.
 */
#include "cg.h"

#include <math.h>
#include <stddef.h>

#ifndef M_SQRT2
#define M_SQRT2 1.41421356237309504880
#endif
#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* Gauss-Legendre rules on [-1, 1]; only the non-negative half (symmetric). */
static const double GL8_X[4] = {0.18343464249564978, 0.525532409916329,
                                0.7966664774136267, 0.9602898564975362};
static const double GL8_W[4] = {0.36268378337836166, 0.3137066458778869,
                                0.22238103445337443, 0.10122853629037706};
static const double GL12_X[6] = {0.1252334085114689, 0.3678314989981802,
                                 0.5873179542866175, 0.7699026741943047,
                                 0.9041172563704748, 0.9815606342467192};
static const double GL12_W[6] = {0.2491470458134027, 0.2334925365383546,
                                 0.20316742672306573, 0.16007832854334642,
                                 0.10693932599531907, 0.04717533638651141};

/* ------------------------------------------------------------------ */
/* normalisation                                                        */

/* Integral of exp(-rho^2/2w^2) over the ball of radius c*w in n dimensions. */
static double gaussian_ball_integral(int n, double w, double c)
{
    const double s2pi = sqrt(2.0 * M_PI);
    switch (n) {
    case 1: return s2pi * w * erf(c / M_SQRT2);
    case 2: return 2.0 * M_PI * w * w * (-expm1(-0.5 * c * c));
    case 3: return pow(s2pi * w, 3) * (erf(c / M_SQRT2) - sqrt(2.0 / M_PI) * c * exp(-0.5 * c * c));
    default: return 1.0;
    }
}

/* Lucy normalisation C_D for support radius R. */
static double lucy_constant(int dim, double R)
{
    switch (dim) {
    case 1: return 5.0 / (4.0 * R);
    case 2: return 5.0 / (M_PI * R * R);
    default: return 105.0 / (16.0 * M_PI * R * R * R);
    }
}

/* Volume of the D-ball of radius R. */
static double ball_volume(int dim, double R)
{
    switch (dim) {
    case 1: return 2.0 * R;
    case 2: return M_PI * R * R;
    default: return 4.0 / 3.0 * M_PI * R * R * R;
    }
}

cg_status cg_kernel_init(cg_kernel *k)
{
    if (k->dim < 2 || k->dim > 3 || k->n_resolved < 0 || k->n_resolved > k->dim)
        return CG_ERR_ARGUMENT;
    if (!(k->radius > 0.0) || !isfinite(k->radius) || !(k->avg_extent > 0.0) || !isfinite(k->avg_extent))
        return CG_ERR_ARGUMENT;
    if (k->type != CG_KERNEL_GAUSSIAN && k->type != CG_KERNEL_LUCY && k->type != CG_KERNEL_HEAVISIDE)
        return CG_ERR_ARGUMENT;
    if (k->type == CG_KERNEL_GAUSSIAN && (!(k->width > 0.0) || !isfinite(k->width)))
        return CG_ERR_ARGUMENT;
    const int n_avg = k->dim - k->n_resolved;
    const double R = k->radius;
    if (k->n_resolved == 0) {
        /* everything averaged: each object contributes 1 / volume */
        k->prefactor = 1.0 / k->avg_extent;
        return CG_OK;
    }
    switch (k->type) {
    case CG_KERNEL_GAUSSIAN: {
        const double w = k->width;
        if (!(w > 0.0) || !isfinite(w)) return CG_ERR_ARGUMENT;
        double norm;
        if (k->truncated_norm)
            norm = gaussian_ball_integral(k->n_resolved, w, R / w);
        else
            norm = pow(sqrt(2.0 * M_PI) * w, k->n_resolved);
        k->prefactor = 1.0 / (norm * k->avg_extent);
        return CG_OK;
    }
    case CG_KERNEL_LUCY: {
        /* marginal over n_avg axes of the D-dimensional kernel, in units of R */
        double C = lucy_constant(k->dim, R);
        if (n_avg == 1) C *= R;                 /* M = C R m1(rho/R) */
        else if (n_avg == 2) C *= 2.0 * M_PI * R * R; /* M = 2 pi C R^2 g2(|z|/R) */
        k->prefactor = C / k->avg_extent;
        return CG_OK;
    }
    case CG_KERNEL_HEAVISIDE:
        k->prefactor = 1.0 / (ball_volume(k->dim, R) * k->avg_extent);
        return CG_OK;
    default:
        return CG_ERR_ARGUMENT;
    }
}

/* ------------------------------------------------------------------ */
/* Lucy and its marginals, in units of the support radius               */

/* (1 + 3x)(1 - x)^3 */
static double lucy_profile(double x)
{
    const double om = 1.0 - x;
    return (1.0 + 3.0 * x) * om * om * om;
}

/* m1(x) = int_{-h}^{h} lucy_profile(sqrt(x^2 + y^2)) dy, h = sqrt(1 - x^2). */
static double lucy_marginal1(double x)
{
    if (x >= 1.0) return 0.0;
    const double h = sqrt((1.0 - x) * (1.0 + x));
    if (x < 0.5) {
        /* closed form: polynomial part plus the r^3 part with its asinh term */
        const double x2 = x * x, h3 = h * h * h, h5 = h3 * h * h;
        double poly = 2.0 * h * (1.0 - 6.0 * x2 - 3.0 * x2 * x2) - 4.0 * (1.0 + x2) * h3 - 1.2 * h5;
        double cube = 4.0 * h + 6.0 * x2 * h;
        if (x > 0.0) cube += 6.0 * x2 * x2 * log((1.0 + h) / x);
        return poly + cube;
    }
    /* near the edge the closed form cancels to h^7: integrate the smooth
       integrand instead (two 12-point panels are exact to round-off here) */
    double sum = 0.0;
    for (int panel = 0; panel < 2; ++panel) {
        const double a = 0.5 * h * panel, half = 0.25 * h, mid = a + half;
        for (int k = 0; k < 6; ++k) {
            const double y1 = mid + half * GL12_X[k], y2 = mid - half * GL12_X[k];
            sum += GL12_W[k] * half * (lucy_profile(sqrt(x * x + y1 * y1)) + lucy_profile(sqrt(x * x + y2 * y2)));
        }
    }
    return 2.0 * sum;
}

/* g2(z) = int_z^1 lucy_profile(r) r dr = (1-z)^4 (0.1 + 0.4 z + 0.5 z^2). */
static double lucy_marginal2(double z)
{
    if (z >= 1.0) return 0.0;
    const double om = 1.0 - z, om2 = om * om;
    return om2 * om2 * (0.1 + z * (0.4 + 0.5 * z));
}

/* ------------------------------------------------------------------ */
/* point values and gradients                                           */

double cg_kernel_value(const cg_kernel *k, double rho2)
{
    const double R = k->radius;
    if (k->n_resolved == 0) return k->prefactor;
    if (!(rho2 < R * R)) return 0.0;
    const int n_avg = k->dim - k->n_resolved;
    switch (k->type) {
    case CG_KERNEL_GAUSSIAN:
        return k->prefactor * exp(-0.5 * rho2 / (k->width * k->width));
    case CG_KERNEL_LUCY: {
        const double x = sqrt(rho2) / R;
        if (n_avg == 0) return k->prefactor * lucy_profile(x);
        if (n_avg == 1) return k->prefactor * lucy_marginal1(x);
        return k->prefactor * lucy_marginal2(x);
    }
    default: { /* Heaviside */
        if (n_avg == 0) return k->prefactor;
        if (n_avg == 1) return k->prefactor * 2.0 * sqrt(R * R - rho2);
        return k->prefactor * M_PI * (R * R - rho2);
    }
    }
}

double cg_kernel_gradient(const cg_kernel *k, const double *x, double *grad)
{
    const int n = k->n_resolved;
    double rho2 = 0.0;
    for (int d = 0; d < n; ++d) rho2 += x[d] * x[d];
    const double value = cg_kernel_value(k, rho2);
    double factor = 0.0; /* grad = factor * x */
    if (value != 0.0) {
        if (k->type == CG_KERNEL_GAUSSIAN)
            factor = -value / (k->width * k->width);
        else if (k->type == CG_KERNEL_LUCY) {
            /* d/dr of C(1+3x)(1-x)^3 = -12 C x (1-x)^2 / R: smooth at r = 0 */
            const double R = k->radius, om = 1.0 - sqrt(rho2) / R;
            factor = -12.0 * k->prefactor * om * om / (R * R);
        }
    }
    for (int d = 0; d < n; ++d) grad[d] = factor * x[d];
    return value;
}

/* ------------------------------------------------------------------ */
/* line integrals                                                        */

typedef struct segment_frame {
    int n;
    double L;        /* |e| */
    double u;        /* q . n */
    double t_far;    /* (q - e) . n, = u - L but without its cancellation */
    double a2;       /* |q_perp|^2 */
    double qperp[3];
    double unit[3];  /* n */
} segment_frame;

static void make_frame(int n, const double *q, const double *e, segment_frame *f)
{
    double L2 = 0.0;
    for (int d = 0; d < n; ++d) L2 += e[d] * e[d];
    f->n = n;
    f->L = sqrt(L2);
    double u = 0.0, t_far = 0.0;
    for (int d = 0; d < n; ++d) {
        f->unit[d] = e[d] / f->L;
        u += q[d] * f->unit[d];
        t_far += (q[d] - e[d]) * f->unit[d];
    }
    double a2 = 0.0;
    for (int d = 0; d < n; ++d) {
        f->qperp[d] = q[d] - u * f->unit[d];
        a2 += f->qperp[d] * f->qperp[d];
    }
    f->u = u;
    f->t_far = t_far;
    f->a2 = a2;
}

/* t at parameter s, taking the accurate end values at s = 0 and s = 1 */
static double t_at(const segment_frame *f, double s)
{
    if (s == 0.0) return f->u;
    if (s == 1.0) return f->t_far;
    return f->u - s * f->L;
}

/* Clip [0, 1] to the support: |t(s)| <= b. Returns 0 if empty. */
static int clip_to_support(const segment_frame *f, double R, double *s0, double *s1, double *b)
{
    const double b2 = R * R - f->a2;
    if (!(b2 > 0.0)) return 0;
    *b = sqrt(b2);
    double lo = 0.0, hi = 1.0;
    if (f->u > *b) lo = (f->u - *b) / f->L;          /* t <= b */
    if (f->t_far < -*b) hi = (f->u + *b) / f->L;     /* t >= -b */
    if (lo > 1.0 || hi < 0.0 || !(lo < hi)) return 0;
    *s0 = lo;
    *s1 = hi;
    return 1;
}

/* int_{s0}^{s1} exp(-t(s)^2 / 2w^2) ds, stable for every length and position */
static double gaussian_segment_integral(const segment_frame *f, double w, double s0, double s1)
{
    const double t0 = t_at(f, s0), t1 = t_at(f, s1); /* t0 >= t1 */
    const double span = (s1 - s0) * f->L;
    const double tmax = fmax(fabs(t0), fabs(t1));
    const double inv2w2 = 0.5 / (w * w);
    if (span * (tmax + w) < w * w) {
        /* the integrand varies little over the interval: Gauss-Legendre is
           exact to round-off and avoids the erf(a) - erf(b) cancellation */
        const double half = 0.5 * (s1 - s0), mid = s0 + half;
        double sum = 0.0;
        for (int k = 0; k < 6; ++k) {
            const double ta = f->u - (mid + half * GL12_X[k]) * f->L;
            const double tb = f->u - (mid - half * GL12_X[k]) * f->L;
            sum += GL12_W[k] * (exp(-ta * ta * inv2w2) + exp(-tb * tb * inv2w2));
        }
        return sum * half;
    }
    const double x0 = t0 / (M_SQRT2 * w), x1 = t1 / (M_SQRT2 * w);
    double bracket;
    if (x1 >= 0.0) bracket = erfc(x1) - erfc(x0);        /* both on the positive side */
    else if (x0 <= 0.0) bracket = erfc(-x0) - erfc(-x1); /* both on the negative side */
    else bracket = erf(x0) - erf(x1);
    return w * sqrt(0.5 * M_PI) * bracket / f->L;
}

typedef struct integrand_ctx {
    const cg_kernel *k;
    const segment_frame *f;
    int want_grad;
} integrand_ctx;

/* values at parameter s: [0] = M(a^2 + t^2); with want_grad also
   [1] = (1 - r/R)^2 and [2] = t (1 - r/R)^2 (Lucy's gradient factors). */
static void integrand(const integrand_ctx *c, double s, double *out)
{
    const double t = c->f->u - s * c->f->L;
    const double rho2 = c->f->a2 + t * t;
    out[0] = cg_kernel_value(c->k, rho2);
    if (c->want_grad) {
        double om = 1.0 - sqrt(rho2) / c->k->radius;
        if (om < 0.0) om = 0.0;
        out[1] = om * om;
        out[2] = t * om * om;
    }
}

/* Gauss-Legendre (8 points) on [lo, hi], adding into acc[0..2]. */
static void gl8_panel(const integrand_ctx *c, double lo, double hi, double *acc)
{
    const double half = 0.5 * (hi - lo), mid = lo + half;
    double v[3];
    for (int k = 0; k < 4; ++k) {
        for (int sign = -1; sign <= 1; sign += 2) {
            integrand(c, mid + sign * half * GL8_X[k], v);
            acc[0] += GL8_W[k] * half * v[0];
            if (c->want_grad) {
                acc[1] += GL8_W[k] * half * v[1];
                acc[2] += GL8_W[k] * half * v[2];
            }
        }
    }
}

/* Integrate over [lo, hi] with panels graded geometrically (ratio 2) toward
   the ends that carry a (near-)singularity: levels_lo panels toward lo,
   levels_hi toward hi. */
static void graded(const integrand_ctx *c, double lo, double hi, int levels_lo, int levels_hi, double *acc)
{
    if (!(hi > lo)) return;
    if (levels_lo > 0 && levels_hi > 0) {
        const double mid = 0.5 * (lo + hi);
        graded(c, lo, mid, levels_lo, 0, acc);
        graded(c, mid, hi, 0, levels_hi, acc);
        return;
    }
    const double len = hi - lo;
    if (levels_lo > 0) {
        double a = lo, step = len * ldexp(1.0, -levels_lo);
        gl8_panel(c, lo, lo + step, acc);
        a = lo + step;
        for (int l = levels_lo - 1; l >= 1; --l) {
            const double b = lo + len * ldexp(1.0, -l);
            gl8_panel(c, a, b, acc);
            a = b;
        }
        gl8_panel(c, a, hi, acc);
    } else if (levels_hi > 0) {
        double b = hi, step = len * ldexp(1.0, -levels_hi);
        gl8_panel(c, hi - step, hi, acc);
        b = hi - step;
        for (int l = levels_hi - 1; l >= 1; --l) {
            const double a = hi - len * ldexp(1.0, -l);
            gl8_panel(c, a, b, acc);
            b = a;
        }
        gl8_panel(c, lo, b, acc);
    } else {
        gl8_panel(c, lo, hi, acc);
    }
}

static int levels_for(double piece_length_in_t, double scale)
{
    if (!(piece_length_in_t > scale)) return 1;
    int levels = (int)ceil(log2(piece_length_in_t / scale)) + 1;
    return levels > 60 ? 60 : levels;
}

/* Quadrature for the polynomial kernels (Lucy and its marginals, Heaviside's
   polynomial marginal): split at the closest approach t = 0, where the
   integrand has a kink or a near-singularity at scale a, and grade toward it;
   grade toward clipped ends where the marginal has an algebraic edge. */
static void quadrature_line(const cg_kernel *k, const segment_frame *f, double s0, double s1,
                            int clipped0, int clipped1, int want_grad, double *acc)
{
    const integrand_ctx c = {k, f, want_grad};
    const int n_avg = k->dim - k->n_resolved;
    const double R = k->radius;
    const int smooth_kink = (k->type == CG_KERNEL_HEAVISIDE); /* polynomial in t on each side */
    const double scale = fmax(sqrt(f->a2), 1e-5 * R);
    /* Lucy's one-axis marginal has an algebraic branch point, (R - rho)^(7/2),
       at the support edge t = +-b: grade toward an end by its distance to it */
    int e0 = 0, e1 = 0;
    if (k->type == CG_KERNEL_LUCY && n_avg == 1) {
        const double b = sqrt(fmax(R * R - f->a2, 0.0)), len = (s1 - s0) * f->L;
        const double d0 = clipped0 ? 0.0 : b - fabs(t_at(f, s0));
        const double d1 = clipped1 ? 0.0 : b - fabs(t_at(f, s1));
        e0 = levels_for(len, fmax(d0, 1e-7 * R));
        e1 = levels_for(len, fmax(d1, 1e-7 * R));
    }
    const double s_star = f->u / f->L;
    if (s_star > s0 && s_star < s1) {
        const int l0 = smooth_kink ? 0 : levels_for((s_star - s0) * f->L, scale);
        const int l1 = smooth_kink ? 0 : levels_for((s1 - s_star) * f->L, scale);
        graded(&c, s0, s_star, e0, l0, acc);
        graded(&c, s_star, s1, l1, e1, acc);
    } else {
        int l0 = 0, l1 = 0;
        if (!smooth_kink) {
            /* closest approach outside: grade toward the nearer end if the
               near-singularity at distance a from it matters */
            const double dist0 = fabs(t_at(f, s0)), dist1 = fabs(t_at(f, s1));
            const double len = (s1 - s0) * f->L;
            if (dist0 <= dist1) l0 = levels_for(len, fmax(scale, dist0));
            else l1 = levels_for(len, fmax(scale, dist1));
        }
        graded(&c, s0, s1, l0 > e0 ? l0 : e0, l1 > e1 ? l1 : e1, acc);
    }
}

/* Heaviside with one averaged axis: M = 2 C sqrt(b^2 - t^2); exact. */
static double heaviside_chord_integral(const segment_frame *f, double b, double s0, double s1)
{
    const double t0 = t_at(f, s0), t1 = t_at(f, s1);
    const double c0 = fmin(1.0, fmax(-1.0, t0 / b)), c1 = fmin(1.0, fmax(-1.0, t1 / b));
    /* int sqrt(b^2 - t^2) dt = b^2 (x sqrt(1-x^2) + asin x) / 2, x = t / b */
    const double F0 = c0 * sqrt(fmax(0.0, 1.0 - c0 * c0)) + asin(c0);
    const double F1 = c1 * sqrt(fmax(0.0, 1.0 - c1 * c1)) + asin(c1);
    return b * b * (F0 - F1) / f->L; /* 2 * (1/2) */
}

double cg_kernel_line(const cg_kernel *k, const double *q, const double *e, double *grad)
{
    const int n = k->n_resolved;
    if (n == 0) return k->prefactor;
    double L2 = 0.0;
    for (int d = 0; d < n; ++d) L2 += e[d] * e[d];
    if (L2 == 0.0) {
        /* zero-length branch: psi is the point value, exactly */
        if (grad) return cg_kernel_gradient(k, q, grad);
        double rho2 = 0.0;
        for (int d = 0; d < n; ++d) rho2 += q[d] * q[d];
        return cg_kernel_value(k, rho2);
    }
    segment_frame f;
    make_frame(n, q, e, &f);
    if (grad) for (int d = 0; d < n; ++d) grad[d] = 0.0;
    double s0, s1, b;
    const double R = k->radius;
    if (!clip_to_support(&f, R, &s0, &s1, &b)) return 0.0;
    const int n_avg = k->dim - n;

    if (k->type == CG_KERNEL_GAUSSIAN) {
        const double w = k->width;
        const double amp = k->prefactor * exp(-0.5 * f.a2 / (w * w));
        const double psi = amp * gaussian_segment_integral(&f, w, s0, s1);
        if (grad) {
            /* grad psi = -q_perp psi / w^2 + n [E(t0) - E(t1)] / L, with
               E(t0) - E(t1) = -E(t0) expm1((t0 - t1)(t0 + t1) / 2w^2) */
            const double t0 = t_at(&f, s0), t1 = t_at(&f, s1);
            const double inv2w2 = 0.5 / (w * w);
            const double diff = -amp * exp(-t0 * t0 * inv2w2) * expm1((s1 - s0) * (t0 + t1) * inv2w2 * f.L);
            for (int d = 0; d < n; ++d)
                grad[d] = -f.qperp[d] * psi / (w * w) + f.unit[d] * diff / f.L;
        }
        return psi;
    }
    if (k->type == CG_KERNEL_HEAVISIDE) {
        if (n_avg == 0) return k->prefactor * (s1 - s0);
        if (n_avg == 1) return k->prefactor * heaviside_chord_integral(&f, b, s0, s1);
    }
    /* Lucy (any marginal) and Heaviside's polynomial marginal */
    double acc[3] = {0.0, 0.0, 0.0};
    quadrature_line(k, &f, s0, s1, s0 > 0.0, s1 < 1.0, grad != NULL && k->type == CG_KERNEL_LUCY, acc);
    if (grad && k->type == CG_KERNEL_LUCY) {
        const double factor = -12.0 * k->prefactor / (R * R);
        for (int d = 0; d < n; ++d)
            grad[d] = factor * (f.qperp[d] * acc[1] + f.unit[d] * acc[2]);
    }
    return acc[0];
}
