/*
 * cg_ring.c -- angular moments of the 3-D kernel over the arc of a ring
 * (cylindrical grids averaged over theta; cgbound/cylindrical_ring.py).
 *
 * A source at cylindrical (rho, phi, zeta) is seen from the ring (r, z) at
 * d(t)^2 = d0^2 + 4 r rho sin^2(t/2), d0^2 = (r - rho)^2 + h^2, h = z - zeta,
 * t = theta - phi, and lies in the support on the half arc |t| < Delta,
 * sin^2(Delta/2) = (R^2 - d0^2) / (4 r rho) (Delta = pi when the whole ring
 * does). d is even in t, so the theta-average needs three moments,
 *     M_m = (1/pi) int_0^Delta W(d(t)) cos(m t) dt,  m = 0, 1, 2.
 * Rules, each exact to round-off (tests/test_ring_core.py checks them
 * against 30-digit quadrature and against the NumPy twin):
 *   Heaviside  closed form (W is constant on the arc).
 *   Gaussian   entire in t; the exponent changes by a = 4 r rho sin^2(Delta/2)
 *              / 2 w^2 over the arc: P = ceil(a / 6) equal panels of 20-point
 *              Gauss-Legendre keep each panel's change small.
 *   Lucy       the odd power d^3 has branch points at t = +-i eps,
 *              sinh(eps/2) = d0 / 2 sqrt(r rho), next to t = 0 when the ring
 *              passes close to the source: panels graded by 1/4 towards t = 0,
 *              20 points each, down to one at most 4 eps long (at most 8
 *              panels, the rule of the NumPy twin for every pair).
 * cos t and cos 2t come from s = sin(t/2): cos t = 1 - 2 s^2 (one sine and one
 * exponential or square root per point, in loops that vectorise: cg_vmath.h).
 */
#include "cg.h"
#include "cg_internal.h"
#include "cg_vmath.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define RING_POINTS 20
#define LUCY_PANELS 8
#define LUCY_RATIO 0.25
/* pieces per block of cg_ring_segment_sum: blocks are summed in order, so the
   result does not depend on the thread count */
#define RING_PIECE_BLOCK 32

typedef struct ring_rule {
    double x[RING_POINTS]; /* Gauss-Legendre nodes on [0, 1] */
    double w[RING_POINTS]; /* and weights (sum 1) */
} ring_rule;

/* the exp and sin loops vectorise 8, 4 or 2 wide by the CPU (the same
   arithmetic in every clone: -std=c11 does not contract into FMA) */
#if defined(__GNUC__) && !defined(__clang__) && defined(__has_attribute)
#if __has_attribute(target_clones) && defined(__x86_64__) && !defined(CGBOUND_NO_CLONES)
#define RING_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#endif
#endif
#ifndef RING_CLONES
#define RING_CLONES
#endif

/* the moments of one pair: of W, or with gradient != 0 of G = W'(d) / d (grad W = G (x - q)):
   the Gaussian's G = -W / w^2; Lucy's G = -12 C (1 - x)^2 / R^2, x = d / R, with the same
   branch points as W (odd powers of d), so the same panels. Heaviside has no G (0). */
RING_CLONES static void ring_moments_one(const cg_kernel *k, const ring_rule *rule, double r, double h, double rho,
                                         int gradient, double *M)
{
    const double R = k->radius;
    const double d0sq = (r - rho) * (r - rho) + h * h;
    const double rr = r * rho;
    M[0] = M[1] = M[2] = M[3] = 0.0;
    if (!(d0sq < R * R)) return;
    double half = M_PI; /* Delta */
    if (rr > 0.0) {
        const double s2 = (R * R - d0sq) / (4.0 * rr);
        half = s2 >= 1.0 ? M_PI : 2.0 * asin(sqrt(s2));
    }
    if (k->type == CG_KERNEL_HEAVISIDE) {
        if (gradient) return;
        const double w0 = k->prefactor;
        M[0] = w0 * half / M_PI;
        if (rr > 0.0) {
            M[1] = w0 * sin(half) / M_PI;
            M[2] = w0 * sin(2.0 * half) / (2.0 * M_PI);
            M[3] = w0 * sin(3.0 * half) / (3.0 * M_PI);
        }
        return;
    }
    double m0 = 0.0, m1 = 0.0, m2 = 0.0, m3 = 0.0;
    if (k->type == CG_KERNEL_GAUSSIAN) {
        const double inv = -0.5 / (k->width * k->width);
        const double sh = sin(0.5 * half);
        const double range = -inv * 4.0 * rr * sh * sh; /* the exponent's change over the arc */
        const int panels = range > 6.0 ? (int)ceil(range / 6.0) : 1;
        const double step = half / panels;
        double s2[RING_POINTS], ex[RING_POINTS];
        for (int p = 0; p < panels; ++p) {
            /* a panel's points in loops the compiler vectorises: sin and exp as straight-line arithmetic */
            for (int i = 0; i < RING_POINTS; ++i) {
                const double s = cg_sin_half_pi(0.5 * (step * (p + rule->x[i]))); /* t/2 <= pi/2 */
                s2[i] = s * s;
                ex[i] = inv * (d0sq + 4.0 * rr * s2[i]);
            }
            cg_exp_in_place(ex, RING_POINTS);
            for (int i = 0; i < RING_POINTS; ++i) {
                const double c1 = 1.0 - 2.0 * s2[i];
                const double c2 = 2.0 * c1 * c1 - 1.0;
                const double v = ex[i] * rule->w[i];
                m0 += v;
                m1 += v * c1;
                m2 += v * c2;
                m3 += v * (c1 * (2.0 * c2 - 1.0)); /* cos 3t = cos t (2 cos 2t - 1) */
            }
        }
        m0 *= step;
        m1 *= step;
        m2 *= step;
        m3 *= step;
    } else { /* Lucy */
        /* graded panels [q^(k+1), q^k] of the half arc down to one that is at most 4 eps long, eps the branch
           points' distance from the real axis; the innermost panel [0, q^(K-1)] then keeps them a panel's
           length away (K = 8 when the ring passes through the source) */
        int K = 1;
        if (rr > 0.0) {
            const double eps = 2.0 * asinh(sqrt(d0sq) / (2.0 * sqrt(rr)));
            const double need = eps > 0.0 ? log(half / (4.0 * eps)) / log(1.0 / LUCY_RATIO) : LUCY_PANELS;
            K = need > 0.0 ? 1 + (int)ceil(need) : 1;
            if (K > LUCY_PANELS) K = LUCY_PANELS;
        }
        const double invR = 1.0 / R;
        double top = 1.0;
        for (int p = 0; p < K; ++p) {
            const double bottom = p == K - 1 ? 0.0 : top * LUCY_RATIO;
            const double width = top - bottom;
            double q0 = 0.0, q1 = 0.0, q2 = 0.0, q3 = 0.0, c1s[RING_POINTS], vs[RING_POINTS];
            for (int i = 0; i < RING_POINTS; ++i) { /* vectorised; the sums below keep their order */
                const double t = half * (bottom + width * rule->x[i]);
                const double s = cg_sin_half_pi(0.5 * t);
                c1s[i] = 1.0 - 2.0 * s * s;
                const double x = sqrt(d0sq + 4.0 * rr * s * s) * invR;
                const double om = x < 1.0 ? 1.0 - x : 0.0; /* rounding at the arc's ends */
                const double lead = gradient ? om : (1.0 + 3.0 * x) * om * om;
                vs[i] = lead * om * rule->w[i];
            }
            for (int i = 0; i < RING_POINTS; ++i) {
                const double v = vs[i], c1 = c1s[i];
                const double c2 = 2.0 * c1 * c1 - 1.0;
                q0 += v;
                q1 += v * c1;
                q2 += v * c2;
                q3 += v * (c1 * (2.0 * c2 - 1.0));
            }
            m0 += q0 * width;
            m1 += q1 * width;
            m2 += q2 * width;
            m3 += q3 * width;
            top = bottom;
        }
        m0 *= half;
        m1 *= half;
        m2 *= half;
        m3 *= half;
    }
    double scale = k->prefactor / M_PI;
    if (gradient)
        scale = k->type == CG_KERNEL_GAUSSIAN ? -scale / (k->width * k->width) : -12.0 * scale / (R * R);
    M[0] = m0 * scale;
    if (rr > 0.0) { /* on the axis the distance does not depend on theta: cos m t (m >= 1) average out */
        M[1] = m1 * scale;
        M[2] = m2 * scale;
        M[3] = m3 * scale;
    }
}

static int ring_kernel_ok(const cg_kernel *k)
{
    return k && k->dim == 3 && k->n_resolved == 3 && k->prefactor > 0.0 &&
           (k->type == CG_KERNEL_GAUSSIAN || k->type == CG_KERNEL_LUCY || k->type == CG_KERNEL_HEAVISIDE);
}

static int ring_threads(int n_threads, cg_index work)
{
#ifdef _OPENMP
    int t = n_threads > 0 ? n_threads : omp_get_max_threads();
    if (work < 64) t = 1;
    return t < 1 ? 1 : t;
#else
    (void)n_threads;
    (void)work;
    return 1;
#endif
}

cg_status cg_ring_moments(const cg_kernel *kernel, double r, cg_index n, const double *h, const double *rho,
                          int gradient, int n_moments, double *moments, int n_threads)
{
    if (!ring_kernel_ok(kernel) || !(r >= 0.0) || !isfinite(r) || n < 0 || n_moments < 1 || n_moments > 4)
        return CG_ERR_ARGUMENT;
    if (gradient && kernel->type == CG_KERNEL_HEAVISIDE) return CG_ERR_UNSUPPORTED;
    ring_rule rule;
    cg_gauss_legendre01(RING_POINTS, rule.x, rule.w);
    const int threads = ring_threads(n_threads, n);
    (void)threads;
#ifdef _OPENMP
#pragma omp parallel for schedule(static, 256) num_threads(threads)
#endif
    for (cg_index i = 0; i < n; ++i) {
        double M[4];
        ring_moments_one(kernel, &rule, r, h[i], rho[i], gradient, M);
        for (int m = 0; m < n_moments; ++m) moments[m * n + i] = M[m];
    }
    return CG_OK;
}

/* the theta-average of one source's tensor T (ring frame e_1, e_2, e_z), at angle phi, with moments M */
static void ring_rotate_add(const double *T, double c, double s, double M0, double M1, double M2, double wt,
                            double *acc)
{
    /* T' = B T B^T, B rows e_r = (c, s, 0), e_theta = (-s, c, 0), e_z = (0, 0, 1) */
    const double cc2 = c * c, ss2 = s * s, cs = c * s;
    const double t00 = cc2 * T[0] + cs * (T[1] + T[3]) + ss2 * T[4];
    const double t11 = ss2 * T[0] - cs * (T[1] + T[3]) + cc2 * T[4];
    const double t01 = -cs * T[0] + cc2 * T[1] - ss2 * T[3] + cs * T[4];
    const double t10 = -cs * T[0] - ss2 * T[1] + cc2 * T[3] + cs * T[4];
    const double t02 = c * T[2] + s * T[5], t12 = -s * T[2] + c * T[5];
    const double t20 = c * T[6] + s * T[7], t21 = -s * T[6] + c * T[7];
    /* E[cos t] = M1, E[sin t] = E[sin t cos t] = 0, E[cos^2 t] = (M0 + M2)/2, E[sin^2 t] = (M0 - M2)/2 */
    const double ec = 0.5 * (M0 + M2) * wt, es = 0.5 * (M0 - M2) * wt, e1 = M1 * wt;
    acc[0] += ec * t00 + es * t11;
    acc[1] += ec * t01 - es * t10;
    acc[2] += e1 * t02;
    acc[3] += ec * t10 - es * t01;
    acc[4] += es * t00 + ec * t11;
    acc[5] += e1 * t12;
    acc[6] += e1 * t20;
    acc[7] += e1 * t21;
    acc[8] += M0 * wt * T[8];
}

/* ---- gradients: grad W(x - q) = G(d) (x - q), G = W'(d) / d ----
 * The theta-average of G(d(t)) times a trigonometric polynomial p(t) of degree <= 3 in t (a tensor turned into
 * the local basis, degree 2, times the local components of x - q = (r - rho cos t, rho sin t, h), degree 1)
 * needs the gradient moments N_m, m = 0..3 (sin terms vanish: d is even in t). With the 8 angles
 * t_j = 2 pi j / 8 and omega_j = (N_0 + 2 sum_{m=1..3} N_m cos(m t_j)) / 8, sum_j omega_j p(t_j) is that
 * average exactly (omega p has degree <= 6 < 8, and p's degree <= 3 sees only N_0..N_3). */
#define RING_GRADIENT_ANGLES 8

#define RING_HALF_SQRT2 0.70710678118654752440
static const double ring_angle_cos[RING_GRADIENT_ANGLES] = {1.0,  RING_HALF_SQRT2,  0.0, -RING_HALF_SQRT2,
                                                            -1.0, -RING_HALF_SQRT2, 0.0, RING_HALF_SQRT2};
static const double ring_angle_sin[RING_GRADIENT_ANGLES] = {0.0, RING_HALF_SQRT2,  1.0,  RING_HALF_SQRT2,
                                                            0.0, -RING_HALF_SQRT2, -1.0, -RING_HALF_SQRT2};

/* acc[27] += wt * theta-average of (B T B^T)_ab (B (x - p))_c G(d) over the ring (r, z), [a, b, c] = d T_ab / d x_c
   in the local basis, for the tensor T (ring frame) carried by the point (p1, p2) (ring frame, from the axis,
   radius rho, direction (c, s)) at the axial offset h = z - zeta, gradient moments N */
static void ring_gradient_add(const double *T, double p1, double p2, double h, double r, const double *N, double wt,
                              double *acc)
{
    const double rho = hypot(p1, p2);
    const double cphi = rho > 0.0 ? p1 / rho : 1.0, sphi = rho > 0.0 ? p2 / rho : 0.0;
    for (int j = 0; j < RING_GRADIENT_ANGLES; ++j) {
        const double ct = ring_angle_cos[j], st = ring_angle_sin[j];
        const double c2t = ct * ct - st * st, c3t = ct * (2.0 * c2t - 1.0);
        const double omega = (N[0] + 2.0 * (N[1] * ct + N[2] * c2t + N[3] * c3t)) / RING_GRADIENT_ANGLES * wt;
        if (omega == 0.0) continue;
        const double c = cphi * ct - sphi * st, s = sphi * ct + cphi * st; /* theta = phi + t_j */
        const double B[3][3] = {{c, s, 0.0}, {-s, c, 0.0}, {0.0, 0.0, 1.0}};
        const double x1 = r * c - p1, x2 = r * s - p2;
        const double g[3] = {c * x1 + s * x2, -s * x1 + c * x2, h};
        double BT[3][3];
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) BT[a][b] = B[a][0] * T[b] + B[a][1] * T[3 + b] + B[a][2] * T[6 + b];
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) {
                const double L = (BT[a][0] * B[b][0] + BT[a][1] * B[b][1] + BT[a][2] * B[b][2]) * omega;
                for (int cc = 0; cc < 3; ++cc) acc[9 * a + 3 * b + cc] += L * g[cc];
            }
    }
}

/* acc[width] += the pieces begin .. end - 1 of cg_ring_segment_sum (gradient == 0) or
   cg_ring_segment_gradient_sum, at the ring (r, z), in order */
static void ring_piece_block(const cg_kernel *kernel, const ring_rule *rule, double r, double z, cg_index begin,
                             cg_index end, const cg_index *segment, const double *lo, const double *hi,
                             const cg_index *panels, const double *geometry, const double *tensors, double weight,
                             int gradient, double *acc)
{
    /* Gauss-Legendre in u on each panel, s = lo + (hi - lo) sin^2(pi u / 2), ds/du = (hi - lo) (pi/2) sin(pi u) */
    for (cg_index q = begin; q < end; ++q) {
        const double *g = geometry + 6 * segment[q];
        const double *T = tensors + 9 * segment[q];
        const double a = lo[q], span = hi[q] - lo[q];
        const cg_index P = panels[q];
        const double h0 = z - g[2];
        for (cg_index jp = 0; jp < P; ++jp)
            for (int i = 0; i < RING_POINTS; ++i) {
                const double u = ((double)jp + rule->x[i]) / (double)P;
                const double sh = sin(0.5 * M_PI * u);
                const double s = a + span * sh * sh;
                const double wt = span * rule->w[i] * 0.5 * M_PI * sin(M_PI * u) / (double)P * weight;
                const double p1 = g[0] + s * g[3], p2 = g[1] + s * g[4];
                const double rho = hypot(p1, p2);
                double M[4];
                ring_moments_one(kernel, rule, r, h0 - s * g[5], rho, gradient, M);
                if (gradient) {
                    ring_gradient_add(T, p1, p2, h0 - s * g[5], r, M, wt, acc);
                } else {
                    const double cphi = rho > 0.0 ? p1 / rho : 1.0, sphi = rho > 0.0 ? p2 / rho : 0.0;
                    ring_rotate_add(T, cphi, sphi, M[0], M[1], M[2], wt, acc);
                }
            }
    }
}

/* the pieces' checks of the segment sums: rows of geometry, 0 <= lo <= hi <= 1, 1 <= panels <= 2^20 */
static int ring_pieces_ok(cg_index n_pieces, const cg_index *segment, const double *lo, const double *hi,
                          const cg_index *panels, cg_index n_segments)
{
    for (cg_index i = 0; i < n_pieces; ++i)
        if (segment[i] < 0 || segment[i] >= n_segments || panels[i] < 1 || panels[i] > 1 << 20 ||
            !(lo[i] >= 0.0 && lo[i] <= hi[i] && hi[i] <= 1.0))
            return 0;
    return 1;
}

/* the pieces of cg_ring_segment_sum (width 9) and cg_ring_segment_gradient_sum (width 27, gradient != 0): the same
   s-points, blocks of pieces summed in order */
static cg_status ring_segment_pieces(const cg_kernel *kernel, double r, double z, cg_index n_pieces,
                                     const cg_index *segment, const double *lo, const double *hi,
                                     const cg_index *panels, cg_index n_segments, const double *geometry,
                                     const double *tensors, double weight, int gradient, double *out, int n_threads)
{
    if (!ring_kernel_ok(kernel) || !(r >= 0.0) || !isfinite(r) || !isfinite(z) || !isfinite(weight) ||
        n_pieces < 0 || n_segments < 0)
        return CG_ERR_ARGUMENT;
    if (gradient && kernel->type == CG_KERNEL_HEAVISIDE) return CG_ERR_UNSUPPORTED;
    if (!ring_pieces_ok(n_pieces, segment, lo, hi, panels, n_segments)) return CG_ERR_ARGUMENT;
    const int width = gradient ? 27 : 9;
    ring_rule rule;
    cg_gauss_legendre01(RING_POINTS, rule.x, rule.w);
    const cg_index n_blocks = (n_pieces + RING_PIECE_BLOCK - 1) / RING_PIECE_BLOCK;
    double local[64 * 27];
    double *blocks = local;
    if (n_blocks * width > 64 * 27) {
        blocks = (double *)malloc((size_t)n_blocks * width * sizeof(double));
        if (!blocks) return CG_ERR_NOMEM;
    }
    const int threads = ring_threads(n_threads, n_pieces * RING_POINTS);
    (void)threads;
#ifdef _OPENMP
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
#endif
    for (cg_index blk = 0; blk < n_blocks; ++blk) {
        double acc[27] = {0.0};
        const cg_index end = (blk + 1) * RING_PIECE_BLOCK < n_pieces ? (blk + 1) * RING_PIECE_BLOCK : n_pieces;
        ring_piece_block(kernel, &rule, r, z, blk * RING_PIECE_BLOCK, end, segment, lo, hi, panels, geometry, tensors,
                         weight, gradient, acc);
        for (int c = 0; c < width; ++c) blocks[width * blk + c] = acc[c];
    }
    for (cg_index blk = 0; blk < n_blocks; ++blk)
        for (int c = 0; c < width; ++c) out[c] += blocks[width * blk + c];
    if (blocks != local) free(blocks);
    return CG_OK;
}

cg_status cg_ring_segment_sum(const cg_kernel *kernel, double r, double z, cg_index n_pieces, const cg_index *segment,
                              const double *lo, const double *hi, const cg_index *panels, cg_index n_segments,
                              const double *geometry, const double *tensors, double weight, double *out,
                              int n_threads)
{
    return ring_segment_pieces(kernel, r, z, n_pieces, segment, lo, hi, panels, n_segments, geometry, tensors, weight,
                               0, out, n_threads);
}

cg_status cg_ring_segment_gradient_sum(const cg_kernel *kernel, double r, double z, cg_index n_pieces,
                                       const cg_index *segment, const double *lo, const double *hi,
                                       const cg_index *panels, cg_index n_segments, const double *geometry,
                                       const double *tensors, double weight, double *out, int n_threads)
{
    return ring_segment_pieces(kernel, r, z, n_pieces, segment, lo, hi, panels, n_segments, geometry, tensors, weight,
                               1, out, n_threads);
}

cg_status cg_ring_segment_columns(const cg_kernel *kernel, cg_index n_columns, const double *rings,
                                  const cg_index *first, const cg_index *segment, const double *lo, const double *hi,
                                  const cg_index *panels, cg_index n_segments, const double *geometry,
                                  const double *tensors, int gradient, double *out, int n_threads)
{
    if (!ring_kernel_ok(kernel) || n_columns < 0 || n_segments < 0 || !first || first[0] != 0)
        return CG_ERR_ARGUMENT;
    if (gradient && kernel->type == CG_KERNEL_HEAVISIDE) return CG_ERR_UNSUPPORTED;
    for (cg_index c = 0; c < n_columns; ++c) {
        const double *ring = rings + 3 * c;
        if (first[c + 1] < first[c] || !(ring[0] >= 0.0) || !isfinite(ring[0]) || !isfinite(ring[1]) ||
            !isfinite(ring[2]))
            return CG_ERR_ARGUMENT;
    }
    if (!ring_pieces_ok(first[n_columns], segment, lo, hi, panels, n_segments)) return CG_ERR_ARGUMENT;
    const int width = gradient ? 27 : 9;
    ring_rule rule;
    cg_gauss_legendre01(RING_POINTS, rule.x, rule.w);
    const int threads = ring_threads(n_threads, first[n_columns] * RING_POINTS);
    (void)threads;
#ifdef _OPENMP
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
#endif
    for (cg_index c = 0; c < n_columns; ++c) {
        /* the blocks of cg_ring_segment_sum from the column's first piece, added in order: the same bits */
        double *dst = out + (size_t)width * c;
        for (cg_index begin = first[c]; begin < first[c + 1]; begin += RING_PIECE_BLOCK) {
            double acc[27] = {0.0};
            const cg_index end = begin + RING_PIECE_BLOCK < first[c + 1] ? begin + RING_PIECE_BLOCK : first[c + 1];
            ring_piece_block(kernel, &rule, rings[3 * c], rings[3 * c + 1], begin, end, segment, lo, hi, panels,
                             geometry, tensors, rings[3 * c + 2], gradient, acc);
            for (int k = 0; k < width; ++k) dst[k] += acc[k];
        }
    }
    return CG_OK;
}

/* ---- z-averaged rings: the exact axial average of point sources (cylindrical_ring.axial_rule) ----
 * Per source (rho, zeta) seen from rings of radius r the ring moments are analytic in h = z - zeta between
 * the cuts h = +-{0, H, w} (H = sqrt(R^2 - (r - rho)^2) the support's edge, w = sqrt(R^2 - (r + rho)^2) where
 * the whole ring enters it) and cuts graded by 1/4 towards branch points just off them; each piece [a, b] gets
 * AXIAL_RULE_POINTS-point Gauss-Legendre in u through x = (3u - u^3)/2 (square-root ends made analytic), the
 * Gaussian's in panels of at most AXIAL_WIDTHS_PER_PANEL widths, and a box end inside a piece clips it in u. */
#define AXIAL_RULE_POINTS 24
#define AXIAL_GRADING 0.25
#define AXIAL_GRADING_LEVELS 26
#define AXIAL_WIDTHS_PER_PANEL 5.0
#define AXIAL_CUTS (3 + 2 * AXIAL_GRADING_LEVELS)
/* sources per block of cg_ring_axial_point_sum: blocks are summed in order (thread-count free) */
#define AXIAL_SOURCE_BLOCK 64

/* the u in [-1, 1] with (3u - u^3)/2 = x */
static double end_clustered_inverse(double x)
{
    x = x < -1.0 ? -1.0 : (x > 1.0 ? 1.0 : x);
    return 2.0 * cos((acos(-x) + 4.0 * M_PI) / 3.0);
}

static int double_less(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : (x > y ? 1 : 0);
}

/* M[3] = the average over z in [lo, hi] of the ring moments M_0..M_2 of a source at (rho, zeta) seen from
   rings of radius r (axial_rule's pieces and points) */
static void ring_axial_moments(const cg_kernel *k, const ring_rule *ring, const double *gx, const double *gw,
                               int panels, double r, double rho, double zeta, double lo, double hi, double *M)
{
    const double c = k->radius;
    const double H = sqrt(fmax(c * c - (r - rho) * (r - rho), 0.0));
    const double whole = sqrt(fmax(c * c - (r + rho) * (r + rho), 0.0));
    const double missed = sqrt(fmax((r + rho) * (r + rho) - c * c, 0.0));
    double near_zero = whole > 0.0 ? INFINITY : missed; /* the branch points next to h = 0 */
    if (k->type == CG_KERNEL_LUCY) near_zero = fmin(near_zero, fabs(r - rho));
    const double inner = whole > 0.0 ? whole : H;      /* the piece that ends at h = 0 */
    const double span = H - whole;
    const int to_zero = near_zero < AXIAL_GRADING * inner;
    const int to_whole = whole > 0.0 && 2.0 * whole < AXIAL_GRADING * span;
    double cuts[AXIAL_CUTS], edges[2 * AXIAL_CUTS];
    int n = 0;
    cuts[n++] = 0.0;
    cuts[n++] = H;
    cuts[n++] = whole;
    double grade = 1.0;
    for (int l = 0; l < AXIAL_GRADING_LEVELS; ++l) {
        grade *= AXIAL_GRADING;
        cuts[n++] = to_zero ? fmax(inner * grade, near_zero) : 0.0;
        cuts[n++] = to_whole ? whole + fmax(span * grade, 2.0 * whole) : H;
    }
    for (int i = 0; i < n; ++i) {
        edges[2 * i] = zeta - cuts[i];
        edges[2 * i + 1] = zeta + cuts[i];
    }
    qsort(edges, (size_t)(2 * n), sizeof(double), double_less);
    M[0] = M[1] = M[2] = 0.0;
    for (int e = 0; e + 1 < 2 * n; ++e) {
        const double a = edges[e], b = edges[e + 1];
        if (!(b > a && b > lo && a < hi)) continue; /* repeated cuts, pieces outside [lo, hi] */
        const double u_lo = a >= lo ? -1.0 : end_clustered_inverse(2.0 * (lo - a) / (b - a) - 1.0);
        const double u_hi = b <= hi ? 1.0 : end_clustered_inverse(2.0 * (hi - a) / (b - a) - 1.0);
        const double scale = 0.25 * (b - a) * (u_hi - u_lo) / (hi - lo);
        for (int p = 0; p < panels; ++p)
            for (int i = 0; i < AXIAL_RULE_POINTS; ++i) {
                const double g = ((double)p + gx[i]) / panels;
                const double u = u_lo + (u_hi - u_lo) * g;
                const double x = 0.5 * (3.0 * u - u * u * u), dx = 1.5 * (1.0 - u * u);
                const double z = a + (b - a) * 0.5 * (x + 1.0);
                const double wt = scale * dx * (2.0 * gw[i] / panels);
                double m[4];
                ring_moments_one(k, ring, r, z - zeta, rho, 0, m);
                M[0] += wt * m[0];
                M[1] += wt * m[1];
                M[2] += wt * m[2];
            }
    }
}

cg_status cg_ring_axial_point_sum(const cg_kernel *kernel, double r, double lo, double hi, cg_index n,
                                  const double *xy, const double *zeta, const double *tensors, const double *weights,
                                  double *out, int n_threads)
{
    if (!ring_kernel_ok(kernel) || !(r >= 0.0) || !isfinite(r) || !isfinite(lo) || !isfinite(hi) || !(lo < hi) ||
        n < 0)
        return CG_ERR_ARGUMENT;
    ring_rule rule;
    cg_gauss_legendre01(RING_POINTS, rule.x, rule.w);
    double gx[AXIAL_RULE_POINTS], gw[AXIAL_RULE_POINTS];
    cg_gauss_legendre01(AXIAL_RULE_POINTS, gx, gw);
    int panels = 1;
    if (kernel->type == CG_KERNEL_GAUSSIAN) {
        const double need = ceil(kernel->radius / (AXIAL_WIDTHS_PER_PANEL * kernel->width) - 1e-9);
        panels = need > 1.0 ? (need < 1 << 16 ? (int)need : 1 << 16) : 1;
    }
    const cg_index n_blocks = (n + AXIAL_SOURCE_BLOCK - 1) / AXIAL_SOURCE_BLOCK;
    double *blocks = (double *)malloc((size_t)(n_blocks > 0 ? n_blocks : 1) * 9 * sizeof(double));
    if (!blocks) return CG_ERR_NOMEM;
    const int threads = ring_threads(n_threads, n * 8);
    (void)threads;
#ifdef _OPENMP
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
#endif
    for (cg_index blk = 0; blk < n_blocks; ++blk) {
        double acc[9] = {0.0};
        const cg_index end = (blk + 1) * AXIAL_SOURCE_BLOCK < n ? (blk + 1) * AXIAL_SOURCE_BLOCK : n;
        for (cg_index j = blk * AXIAL_SOURCE_BLOCK; j < end; ++j) {
            const double p1 = xy[2 * j], p2 = xy[2 * j + 1];
            const double rho = hypot(p1, p2);
            double M[3];
            ring_axial_moments(kernel, &rule, gx, gw, panels, r, rho, zeta[j], lo, hi, M);
            const double cphi = rho > 0.0 ? p1 / rho : 1.0, sphi = rho > 0.0 ? p2 / rho : 0.0;
            ring_rotate_add(tensors + 9 * j, cphi, sphi, M[0], M[1], M[2], weights[j], acc);
        }
        for (int c = 0; c < 9; ++c) blocks[9 * blk + c] = acc[c];
    }
    for (cg_index blk = 0; blk < n_blocks; ++blk)
        for (int c = 0; c < 9; ++c) out[c] += blocks[9 * blk + c];
    free(blocks);
    return CG_OK;
}
