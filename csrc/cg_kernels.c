/*
 * cg_kernels.c -- kernel values, marginals over averaged axes, line integrals
 * along contact branches and their gradients. See cg.h for the definitions.
 *
 * Line integrals are written in the frame of the segment (segment_frame,
 * cg_internal.h): psi = int_s0^s1 M(a^2 + t(s)^2) ds where [s0, s1] is [0, 1]
 * clipped to the support ball of radius R. Lucy's full-dimensional kernel is
 * integrated in closed form (cg_lucy.c); the polynomial marginals over two
 * axes by Gauss-Legendre rules that are exact for them; Lucy's marginal over
 * one axis by graded Gauss-Legendre panels converged to round-off.
 */
#include "cg.h"
#include "cg_internal.h"

#include <math.h>
#include <stddef.h>

#ifndef M_SQRT2
#define M_SQRT2 1.41421356237309504880
#endif
#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* Gauss-Legendre rules on [-1, 1]; only the non-negative half (symmetric). */
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
    if (k->line_points < 0 || k->line_points > CG_MAX_LINE_POINTS) return CG_ERR_ARGUMENT;
    if (k->lower_dimensional != 0 && k->lower_dimensional != 1) return CG_ERR_ARGUMENT;
    if (k->mercurycg_line != 0 &&
        (k->mercurycg_line != 1 || k->type != CG_KERNEL_GAUSSIAN || k->n_resolved != 1))
        return CG_ERR_ARGUMENT;
    const int n_avg = cg_kernel_marginal_axes(k);
    const int kernel_dim = k->lower_dimensional ? k->n_resolved : k->dim; /* the kernel's own dimension */
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
        /* marginal over n_avg axes of the kernel_dim-dimensional kernel, in units of R */
        double C = lucy_constant(kernel_dim, R);
        if (n_avg == 1) C *= R;                 /* M = C R m1(rho/R) */
        else if (n_avg == 2) C *= 2.0 * M_PI * R * R; /* M = 2 pi C R^2 g2(|z|/R) */
        k->prefactor = C / k->avg_extent;
        return CG_OK;
    }
    case CG_KERNEL_HEAVISIDE:
        k->prefactor = 1.0 / (ball_volume(kernel_dim, R) * k->avg_extent);
        return CG_OK;
    default:
        return CG_ERR_ARGUMENT;
    }
}

/* ------------------------------------------------------------------ */
/* Lucy and its marginals, in units of the support radius               */

/* (1 + 3x)(1 - x)^3 (cg_internal.h) */
#define lucy_profile cg_lucy_profile

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

/* ------------------------------------------------------------------ */
/* point values and gradients                                           */

double cg_kernel_value(const cg_kernel *k, double rho2)
{
    const double R = k->radius;
    if (k->n_resolved == 0) return k->prefactor;
    if (!(rho2 < R * R)) return 0.0;
    const int n_avg = cg_kernel_marginal_axes(k);
    switch (k->type) {
    case CG_KERNEL_GAUSSIAN:
        return k->prefactor * exp(-0.5 * rho2 / (k->width * k->width));
    case CG_KERNEL_LUCY: {
        const double x = sqrt(rho2) / R;
        if (n_avg == 0) return k->prefactor * lucy_profile(x);
        if (n_avg == 1) return k->prefactor * lucy_marginal1(x);
        return cg_marginal2_value(1, k->prefactor, R, rho2);
    }
    default: { /* Heaviside */
        if (n_avg == 0) return k->prefactor;
        if (n_avg == 1) return k->prefactor * 2.0 * sqrt(R * R - rho2);
        return cg_marginal2_value(0, k->prefactor, R, rho2);
    }
    }
}

double cg_kernel_gradient(const cg_kernel *k, const double *x, double *grad)
{
    const int n = k->n_resolved;
    if (k->type == CG_KERNEL_LUCY && n > 0 && cg_kernel_marginal_axes(k) > 0) return cg_lucy_marginal_gradient(k, x, grad);
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
/* Gauss-Legendre rules of any order                                    */

/* Gauss-Legendre rules on [0, 1] for n = 1..CG_MAX_LINE_POINTS, nodes increasing:
   node i of rule n is GL_NODES[n*(n-1)/2 + i] (generated with numpy.polynomial.legendre.leggauss) */
static const double GL_NODES[136] = {
    0.5, 0.21132486540518713, 0.7886751345948129,
    0.1127016653792583, 0.5, 0.8872983346207417,
    0.06943184420297371, 0.33000947820757187, 0.6699905217924281,
    0.9305681557970262, 0.04691007703066802, 0.23076534494715845,
    0.5, 0.7692346550528415, 0.9530899229693319,
    0.03376524289842403, 0.16939530676686776, 0.38069040695840156,
    0.6193095930415985, 0.8306046932331322, 0.9662347571015759,
    0.0254460438286207, 0.12923440720030277, 0.2970774243113014,
    0.5, 0.7029225756886985, 0.8707655927996972,
    0.9745539561713793, 0.019855071751231912, 0.10166676129318664,
    0.2372337950418355, 0.4082826787521751, 0.5917173212478248,
    0.7627662049581645, 0.8983332387068134, 0.9801449282487681,
    0.015919880246186957, 0.08198444633668212, 0.19331428364970482,
    0.33787328829809554, 0.5, 0.6621267117019045,
    0.8066857163502952, 0.9180155536633179, 0.984080119753813,
    0.013046735741414128, 0.06746831665550773, 0.16029521585048778,
    0.2833023029353764, 0.4255628305091844, 0.5744371694908156,
    0.7166976970646236, 0.8397047841495122, 0.9325316833444923,
    0.9869532642585859, 0.010885670926971514, 0.05646870011595234,
    0.13492399721297532, 0.2404519353965941, 0.36522842202382755,
    0.5, 0.6347715779761725, 0.7595480646034058,
    0.8650760027870247, 0.9435312998840477, 0.9891143290730284,
    0.009219682876640378, 0.0479413718147626, 0.11504866290284765,
    0.20634102285669126, 0.31608425050090994, 0.43738329574426554,
    0.5626167042557344, 0.6839157494990901, 0.7936589771433087,
    0.8849513370971523, 0.9520586281852375, 0.9907803171233596,
    0.007908472640705932, 0.04120080038851104, 0.09921095463334506,
    0.17882533027982989, 0.27575362448177654, 0.3847708420224326,
    0.5, 0.6152291579775674, 0.7242463755182235,
    0.8211746697201701, 0.9007890453666549, 0.958799199611489,
    0.9920915273592941, 0.006858095651593787, 0.03578255816821324,
    0.08639934246511749, 0.15635354759415726, 0.24237568182092295,
    0.3404438155360551, 0.44597252564632817, 0.5540274743536718,
    0.6595561844639448, 0.757624318179077, 0.8436464524058427,
    0.9136006575348825, 0.9642174418317868, 0.9931419043484062,
    0.006003740989757311, 0.03136330379964708, 0.0758967082947864,
    0.13779113431991497, 0.21451391369573058, 0.3029243264612183,
    0.39940295300128276, 0.5, 0.6005970469987173,
    0.6970756735387817, 0.7854860863042694, 0.862208865680085,
    0.9241032917052137, 0.968636696200353, 0.9939962590102427,
    0.005299532504175031, 0.0277124884633837, 0.06718439880608412,
    0.1222977958224985, 0.19106187779867811, 0.2709916111713863,
    0.35919822461037054, 0.4524937450811813, 0.5475062549188188,
    0.6408017753896295, 0.7290083888286136, 0.8089381222013219,
    0.8777022041775016, 0.9328156011939159, 0.9722875115366163,
    0.994700467495825,
};
static const double GL_WEIGHTS[136] = {
    1.0, 0.5, 0.5,
    0.27777777777777785, 0.4444444444444444, 0.27777777777777785,
    0.17392742256872679, 0.3260725774312732, 0.3260725774312732,
    0.17392742256872679, 0.11846344252809464, 0.23931433524968315,
    0.28444444444444433, 0.23931433524968315, 0.11846344252809464,
    0.08566224618958514, 0.18038078652406936, 0.23395696728634552,
    0.23395696728634552, 0.18038078652406936, 0.08566224618958514,
    0.06474248308443487, 0.13985269574463843, 0.19091502525255935,
    0.20897959183673465, 0.19091502525255935, 0.13985269574463843,
    0.06474248308443487, 0.05061426814518853, 0.11119051722668721,
    0.15685332293894344, 0.18134189168918083, 0.18134189168918083,
    0.15685332293894344, 0.11119051722668721, 0.05061426814518853,
    0.04063719418078708, 0.09032408034742868, 0.1303053482014678,
    0.15617353852000146, 0.16511967750062992, 0.15617353852000146,
    0.1303053482014678, 0.09032408034742868, 0.04063719418078708,
    0.03333567215434407, 0.0747256745752902, 0.109543181257991,
    0.13463335965499826, 0.1477621123573764, 0.1477621123573764,
    0.13463335965499826, 0.109543181257991, 0.0747256745752902,
    0.03333567215434407, 0.027834283558086963, 0.06279018473245217,
    0.09314510546386714, 0.11659688229599528, 0.13140227225512327,
    0.13646254338895025, 0.13140227225512327, 0.11659688229599528,
    0.09314510546386714, 0.06279018473245217, 0.027834283558086963,
    0.023587668193255706, 0.05346966299765953, 0.08003916427167321,
    0.10158371336153287, 0.1167462682691773, 0.12457352290670134,
    0.12457352290670134, 0.1167462682691773, 0.10158371336153287,
    0.08003916427167321, 0.05346966299765953, 0.023587668193255706,
    0.020242002382657786, 0.0460607499188644, 0.06943675510989367,
    0.08907299038097276, 0.10390802376844425, 0.11314159013144869,
    0.11627577661543696, 0.11314159013144869, 0.10390802376844425,
    0.08907299038097276, 0.06943675510989367, 0.0460607499188644,
    0.020242002382657786, 0.017559730165875875, 0.04007904357987999,
    0.060759285343951655, 0.07860158357909681, 0.09276919873896894,
    0.10259923186064786, 0.10763192673157897, 0.10763192673157897,
    0.10259923186064786, 0.09276919873896894, 0.07860158357909681,
    0.060759285343951655, 0.04007904357987999, 0.017559730165875875,
    0.015376620998058602, 0.0351830237440542, 0.053579610233585706,
    0.06978533896307722, 0.08313460290849699, 0.0930805000077811,
    0.0992157426635558, 0.10128912096278064, 0.0992157426635558,
    0.0930805000077811, 0.08313460290849699, 0.06978533896307722,
    0.053579610233585706, 0.0351830237440542, 0.015376620998058602,
    0.013576229705877088, 0.031126761969323728, 0.0475792558412463,
    0.062314485627767036, 0.07479799440828835, 0.08457825969750132,
    0.09130170752246182, 0.09472530522753432, 0.09472530522753432,
    0.09130170752246182, 0.08457825969750132, 0.07479799440828835,
    0.062314485627767036, 0.0475792558412463, 0.031126761969323728,
    0.013576229705877088,
};

/* P_n(z) and P_n'(z) by the three-term recurrence */
static void legendre(int n, double z, double *p, double *dp)
{
    double p0 = 1.0, p1 = z;
    for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
    }
    *p = p1;
    *dp = n * (z * p1 - p0) / (z * z - 1.0);
}

void cg_gauss_legendre01(int n, double *x, double *w)
{
    if (n <= CG_MAX_LINE_POINTS) {
        const int first = n * (n - 1) / 2;
        for (int i = 0; i < n; ++i) {
            x[i] = GL_NODES[first + i];
            w[i] = GL_WEIGHTS[first + i];
        }
        return;
    }
    /* longer rules (the rings of cg_ring.c): Newton on P_n from the usual first guesses */
    for (int i = 0; i < (n + 1) / 2; ++i) {
        double z = cos(M_PI * (i + 0.75) / (n + 0.5)), p, dp;
        for (int it = 0; it < 100; ++it) {
            legendre(n, z, &p, &dp);
            const double step = p / dp;
            z -= step;
            if (fabs(step) < 1e-17) break;
        }
        legendre(n, z, &p, &dp);
        const double weight = 1.0 / ((1.0 - z * z) * dp * dp); /* on [0, 1]: half of 2 / ((1 - z^2) P'^2) */
        x[i] = 0.5 * (1.0 - z);
        x[n - 1 - i] = 0.5 * (1.0 + z);
        w[i] = w[n - 1 - i] = weight;
    }
}

/* Error bound of the n-point rule for int_0^L exp(-t^2/2w^2) dt relative to
   its length L (the peak of the integrand is 1): (L/w)^2n (n!)^3 / ((2n+1)
   ((2n)!)^2 2^n), the Gauss-Legendre remainder with |d^2n/dt^2n exp(-t^2/2)|
   <= (2n)! / (2^n n!). The largest L/w for which it is below 1e-16, for
   n = 4, 5, 6, 8, 10, 12, 16 (checked against erf differences): */
#define N_ROUNDOFF_RULES 7
static const int ROUNDOFF_POINTS[N_ROUNDOFF_RULES] = {4, 5, 6, 8, 10, 12, 16};
static const double ROUNDOFF_MAX_RATIO[N_ROUNDOFF_RULES] = {0.08, 0.22, 0.438, 1.068, 1.867, 2.752, 4.601};

int cg_gaussian_roundoff_points(double L, double w)
{
    for (int i = 0; i < N_ROUNDOFF_RULES; ++i)
        if (L <= ROUNDOFF_MAX_RATIO[i] * w) return ROUNDOFF_POINTS[i];
    return 0;
}

/* ------------------------------------------------------------------ */
/* line integrals                                                        */

/* int_{s0}^{s1} exp(-t(s)^2 / 2w^2) ds, stable for every length and position; on a short interval its length
   s1 - s0 from exact differences (cg_cut_span_lane of the node q3 and the segment e3, 3 slots, in the cutoff
   ball R: a sliver of the segment inside the ball keeps its digits) */
static double gaussian_segment_integral(const segment_frame *f, double w, double s0, double s1, const double *q3,
                                        const double *e3, double R)
{
    const double t0 = t_at(f, s0), t1 = t_at(f, s1); /* t0 >= t1 */
    const double span = (s1 - s0) * f->L;
    const double tmax = fmax(fabs(t0), fabs(t1));
    const double inv2w2 = 0.5 / (w * w);
    if (span * (tmax + w) < w * w) {
        /* the integrand varies little over the interval: Gauss-Legendre is
           exact to round-off and avoids the erf(a) - erf(b) cancellation */
        cg_cut_span_frame cf;
        cg_cut_span_frame_of(e3, R, &cf);
        const double half = 0.5 * cg_cut_span_lane(q3[0], q3[1], q3[2], &cf), mid = s0 + half;
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
            integrand(c, mid + sign * half * CG_GL8_X[k], v);
            acc[0] += CG_GL8_W[k] * half * v[0];
            if (c->want_grad) {
                acc[1] += CG_GL8_W[k] * half * v[1];
                acc[2] += CG_GL8_W[k] * half * v[2];
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
    const int n_avg = cg_kernel_marginal_axes(k);
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

/* One resolved axis, two averaged (D = 3): Lucy's and Heaviside's marginals
   are polynomials in |t| of degree <= 6 on each side of t = 0, so 8-point
   Gauss-Legendre on each side is exact; its terms have one sign (no
   cancellation). */
static double polynomial_line_1d(const cg_kernel *k, const segment_frame *f, double s0, double s1)
{
    const double t0 = t_at(f, s0), t1 = t_at(f, s1), span = (s1 - s0) * f->L;
    double lo[2], len[2];
    int pieces = 1;
    if (t1 >= 0.0) { lo[0] = t1; len[0] = span; }
    else if (t0 <= 0.0) { lo[0] = -t0; len[0] = span; }
    else { lo[0] = lo[1] = 0.0; len[0] = t0; len[1] = -t1; pieces = 2; }
    /* (cg_kernel_value's arithmetic, without its dispatch per value) */
    const int lucy = k->type == CG_KERNEL_LUCY;
    const double C = k->prefactor, R = k->radius;
    double sum = 0.0;
    for (int i = 0; i < pieces; ++i) {
        const double half = 0.5 * len[i], mid = lo[i] + half;
        for (int j = 0; j < 4; ++j) {
            const double ta = mid + half * CG_GL8_X[j], tb = mid - half * CG_GL8_X[j];
            sum += CG_GL8_W[j] * half * (cg_marginal2_value(lucy, C, R, ta * ta) + cg_marginal2_value(lucy, C, R, tb * tb));
        }
    }
    return sum / f->L;
}

/* Heaviside with one averaged axis: M = 2 C sqrt(b^2 - t^2); exact. */
static double heaviside_chord_integral(const segment_frame *f, double b, double s0, double s1)
{
    const double t0 = t_at(f, s0), t1 = t_at(f, s1);
    const double c0 = fmin(1.0, fmax(-1.0, t0 / b)), c1 = fmin(1.0, fmax(-1.0, t1 / b));
    /* int sqrt(b^2 - t^2) dt = b^2 F(x) / 2, F(x) = x sqrt(1-x^2) + asin x, x = t / b */
    const double dc = c0 - c1; /* >= 0: t decreases along the segment */
    if (dc >= 0.5) {
        const double F0 = c0 * sqrt(fmax(0.0, 1.0 - c0 * c0)) + asin(c0);
        const double F1 = c1 * sqrt(fmax(0.0, 1.0 - c1 * c1)) + asin(c1);
        return b * b * (F0 - F1) / f->L; /* 2 * (1/2) */
    }
    /* F0 - F1 for a short chord would cancel (F0 ~ F1); with S = sqrt(1 - c^2) and
       S0 - S1 = -dc (c0 + c1) / (S0 + S1), both parts are dc times sums of one sign:
         c0 S0 - c1 S1     = dc [(S0 + S1) / 2 - (c0 + c1)^2 / 2(S0 + S1)]
         asin c0 - asin c1 = asin(c0 S1 - c1 S0) = asin(dc [(S0 + S1) / 2 + (c0 + c1)^2 / 2(S0 + S1)])
       (the asin identity holds as c0 c1 >= 0 or c0^2 + c1^2 <= 1 when dc < 1/2). dc itself
       is taken from the length, t0 - t1 = (s1 - s0) L, not from c0 - c1, which cancels. */
    const double S0 = sqrt(fmax(0.0, 1.0 - c0 * c0)), S1 = sqrt(fmax(0.0, 1.0 - c1 * c1));
    const double sum = S0 + S1;
    if (!(sum > 0.0)) return 0.0; /* both ends at the same pole: an empty chord */
    const double d = (s1 - s0) * f->L / b;
    const double half = 0.5 * sum, skew = 0.5 * (c0 + c1) * (c0 + c1) / sum;
    return b * b * (d * (half - skew) + asin(d * (half + skew))) / f->L;
}

/* the n-point Gauss-Legendre rule applied to the (cut-off) kernel along the segment */
static double gauss_legendre_line(const cg_kernel *k, const double *q, const double *e, double *grad, int n_points)
{
    const int n = k->n_resolved;
    double xs[CG_MAX_LINE_POINTS], ws[CG_MAX_LINE_POINTS], p[3], g[3];
    cg_gauss_legendre01(n_points, xs, ws);
    if (grad) for (int d = 0; d < n; ++d) grad[d] = 0.0;
    double psi = 0.0;
    for (int i = 0; i < n_points; ++i) {
        for (int d = 0; d < n; ++d) p[d] = q[d] - xs[i] * e[d];
        if (grad) {
            psi += ws[i] * cg_kernel_gradient(k, p, g);
            for (int d = 0; d < n; ++d) grad[d] += ws[i] * g[d];
        } else {
            double rho2 = 0.0;
            for (int d = 0; d < n; ++d) rho2 += p[d] * p[d];
            psi += ws[i] * cg_kernel_value(k, rho2);
        }
    }
    return psi;
}

double cg_kernel_line(const cg_kernel *k, const double *q, const double *e, double *grad)
{
    const int rule = k->type != CG_KERNEL_GAUSSIAN ? 0 : k->mercurycg_line ? CG_LINE_MERCURYCG : k->line_points;
    return cg_kernel_line_rule(k, q, e, grad, rule);
}

double cg_kernel_line_rule(const cg_kernel *k, const double *q, const double *e, double *grad, int n_points)
{
    const int n = k->n_resolved;
    if (n == 0) return k->prefactor;
    if (n_points > 0 && k->type == CG_KERNEL_GAUSSIAN) return gauss_legendre_line(k, q, e, grad, n_points);
    if (n_points == CG_LINE_MERCURYCG && k->type == CG_KERNEL_GAUSSIAN && n == 1 && !grad)
        return cg_mercurycg_gauss_line(k, q[0], e[0]);
    double L2 = 0.0;
    for (int d = 0; d < n; ++d) L2 += e[d] * e[d];
    if (L2 == 0.0) {
        /* zero-length branch: psi is the point value, exactly */
        if (grad) return cg_kernel_gradient(k, q, grad);
        double rho2 = 0.0;
        for (int d = 0; d < n; ++d) rho2 += q[d] * q[d];
        return cg_kernel_value(k, rho2);
    }
    if (k->type == CG_KERNEL_LUCY && cg_kernel_marginal_axes(k) == 0) {
        /* the full-dimensional (or lower-dimensional) kernel: closed form */
        segment_axis ax;
        segment_axis_of(n, e, &ax);
        return cg_lucy_segment(k, &ax, q, e, grad);
    }
    segment_frame f;
    make_frame(n, q, e, &f);
    if (grad) for (int d = 0; d < n; ++d) grad[d] = 0.0;
    double s0, s1, b;
    const double R = k->radius;
    if (!clip_to_support(&f, R, &s0, &s1, &b)) return 0.0;
    const int n_avg = cg_kernel_marginal_axes(k);

    if (k->type == CG_KERNEL_GAUSSIAN) {
        const double w = k->width;
        const double amp = k->prefactor * exp(-0.5 * f.a2 / (w * w));
        double q3[3] = {0.0, 0.0, 0.0}, e3[3] = {0.0, 0.0, 0.0};
        for (int d = 0; d < n; ++d) {
            q3[d] = q[d];
            e3[d] = e[d];
        }
        const double psi = amp * gaussian_segment_integral(&f, w, s0, s1, q3, e3, R);
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
    if (n_avg == 2) return polynomial_line_1d(k, &f, s0, s1);
    /* Lucy's marginal over one axis (an algebraic edge): quadrature */
    double acc[3] = {0.0, 0.0, 0.0};
    quadrature_line(k, &f, s0, s1, s0 > 0.0, s1 < 1.0, grad != NULL && k->type == CG_KERNEL_LUCY, acc);
    if (grad && k->type == CG_KERNEL_LUCY) {
        const double factor = -12.0 * k->prefactor / (R * R);
        for (int d = 0; d < n; ++d)
            grad[d] = factor * (f.qperp[d] * acc[1] + f.unit[d] * acc[2]);
    }
    return acc[0];
}
