/*
 * cg_profile.c -- Lucy's and Heaviside's kernels on a grid with one resolved
 * axis and the other two averaged (a profile, such as W2's Z profile): the
 * kernel is the marginal over two axes (cg_marginal2_value), a polynomial in
 * the distance along the resolved axis.
 *
 * The node-by-node path (cg_scatter.c's visit_nodes) calls
 * cg_kernel_line_rule once per node: the segment's length and direction, the
 * node's frame, the clip to the support and 8-point Gauss-Legendre on each
 * side of the closest approach (polynomial_line_1d, cg_kernels.c), each
 * behind a dispatch on the kernel. Here the segment's constants are taken
 * once per object, and each node's value is the same sequence of operations
 * written without branches over a batch of the stencil's nodes, so that the
 * compiler vectorises it over the nodes (an AVX-512 build where job.wide says so, else
 * AVX2 or baseline, chosen like cg_lucy_line.c's; ISO C: no FMA contraction; IEEE
 * square roots and divisions are exact in any width): the node-by-node
 * numbers bit for bit. Points likewise (cg_kernel_value's arithmetic), their
 * values added by cg_ball_add, and the gradients of Lucy's (those of
 * cg_lucy_marginal_gradient).
 */
#include "cg_internal.h"

#include <math.h>

#if defined(__GNUC__) && !defined(__clang__) && defined(__has_attribute)
#if __has_attribute(target_clones) && defined(__x86_64__) && !defined(CGBOUND_NO_CLONES)
#define PROFILE_CLONES __attribute__((target_clones("avx2", "default")))
#endif
#endif
#ifndef PROFILE_CLONES
#define PROFILE_CLONES
#endif

/* nodes per batch (a stencil longer than this is done in several) */
#define PROFILE_BATCH 64

/* batches are computed in whole vectors of this many nodes (the widest build's) */
#define PROFILE_PAD 8

#if defined(__GNUC__)
#define INLINE static inline __attribute__((always_inline))
#else
#define INLINE static inline
#endif

/* cg_marginal2_value without its branches (rho2 = t^2, z = |t| / R) */
INLINE double marginal2(int lucy, double C, double R, double RR, double rho2)
{
    double m;
    if (lucy) {
        const double z = sqrt(rho2) / R, om = 1.0 - z, om2 = om * om;
        const double p = om2 * om2 * (0.1 + z * (0.4 + 0.5 * z));
        m = C * (z >= 1.0 ? 0.0 : p);
    } else {
        m = C * 3.14159265358979323846 * (RR - rho2);
    }
    return rho2 < RR ? m : 0.0;
}

/* one piece of polynomial_line_1d: its 8 Gauss-Legendre terms added to sum in its order */
INLINE double piece_terms(int lucy, double C, double R, double RR, double lo, double len, double sum)
{
    const double half = 0.5 * len, mid = lo + half;
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC unroll 4
#endif
    for (int j = 0; j < 4; ++j) {
        const double ta = mid + half * CG_GL8_X[j], tb = mid - half * CG_GL8_X[j];
        sum += CG_GL8_W[j] * half * (marginal2(lucy, C, R, RR, ta * ta) + marginal2(lucy, C, R, RR, tb * tb));
    }
    return sum;
}

/* The line integral of the two-axis marginal along the segment from the node
   offsets q[i] (node minus segment start), segment e (length L, unit =
   e / L), times scale, into w[i] (0 outside the support): the arithmetic of
   cg_kernel_line_rule -> make_frame, clip_to_support, polynomial_line_1d for
   one resolved axis, operation for operation. Where the node-by-node path
   takes one piece, the second piece here has length 0 and adds exact zeros
   (every term is >= +0). */
INLINE void segment_values_body(int count, const double *restrict q, double e, double L, double unit, double R,
                                double C, int lucy, double scale, double *restrict w)
{
    const double RR = R * R;
    for (int i = 0; i < count; ++i) {
        /* node_frame with n = 1 (its sums start from 0.0) */
        const double u = 0.0 + q[i] * unit;
        const double t_far = 0.0 + (q[i] - e) * unit;
        const double qperp = q[i] - u * unit;
        const double a2 = 0.0 + qperp * qperp;
        /* clip_to_support */
        const double b2 = RR - a2;
        const double b = sqrt(b2 > 0.0 ? b2 : 0.0);
        const double s0 = u > b ? (u - b) / L : 0.0;
        const double s1 = t_far < -b ? (u + b) / L : 1.0;
        const int inside = b2 > 0.0 && !(s0 > 1.0 || s1 < 0.0 || !(s0 < s1));
        /* polynomial_line_1d: t_at at both ends, the pieces on each side of t = 0 */
        const double t0 = s0 == 0.0 ? u : (s0 == 1.0 ? t_far : u - s0 * L);
        const double t1 = s1 == 0.0 ? u : (s1 == 1.0 ? t_far : u - s1 * L);
        const double span = (s1 - s0) * L;
        const int one_side_t1 = t1 >= 0.0, one_side_t0 = !one_side_t1 && t0 <= 0.0;
        const int one_side = one_side_t1 || one_side_t0;
        const double lo0 = one_side_t1 ? t1 : (one_side_t0 ? -t0 : 0.0);
        double sum = piece_terms(lucy, C, R, RR, lo0, one_side ? span : t0, 0.0);
        sum = piece_terms(lucy, C, R, RR, 0.0, one_side ? 0.0 : -t1, sum);
        w[i] = inside ? sum / L * scale : 0.0;
    }
}

PROFILE_CLONES static void segment_values_narrow(int count, const double *restrict q, double e, double L,
                                                 double unit, double R, double C, int lucy, double scale,
                                                 double *restrict w)
{
    if (lucy) segment_values_body(count, q, e, L, unit, R, C, 1, scale, w);
    else segment_values_body(count, q, e, L, unit, R, C, 0, scale, w);
}

#ifdef CG_HAVE_WIDE_SEPARABLE
__attribute__((target("avx512f"))) static void segment_values_wide(int count, const double *restrict q, double e,
                                                                   double L, double unit, double R, double C,
                                                                   int lucy, double scale, double *restrict w)
{
    if (lucy) segment_values_body(count, q, e, L, unit, R, C, 1, scale, w);
    else segment_values_body(count, q, e, L, unit, R, C, 0, scale, w);
}
#endif

/* the AVX-512 build where the job asks for it (jb->wide), else the AVX2/baseline one */
static void segment_values(int wide, int count, const double *q, double e, double L, double unit, double R, double C,
                           int lucy, double scale, double *w)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (wide) {
        segment_values_wide(count, q, e, L, unit, R, C, lucy, scale, w);
        return;
    }
#endif
    (void)wide;
    segment_values_narrow(count, q, e, L, unit, R, C, lucy, scale, w);
}

/* The two-axis marginal at the node offsets q[i] into w[i] (cg_kernel_value
   with rho2 = 0.0 + q^2, as cg_visit_ball_points forms it) */
INLINE void point_values_body(int count, const double *restrict q, double R, double C, int lucy, double *restrict w)
{
    const double RR = R * R;
    for (int i = 0; i < count; ++i) w[i] = marginal2(lucy, C, R, RR, 0.0 + q[i] * q[i]);
}

PROFILE_CLONES static void point_values_narrow(int count, const double *restrict q, double R, double C, int lucy,
                                               double *restrict w)
{
    if (lucy) point_values_body(count, q, R, C, 1, w);
    else point_values_body(count, q, R, C, 0, w);
}

#ifdef CG_HAVE_WIDE_SEPARABLE
__attribute__((target("avx512f"))) static void point_values_wide(int count, const double *restrict q, double R,
                                                                 double C, int lucy, double *restrict w)
{
    if (lucy) point_values_body(count, q, R, C, 1, w);
    else point_values_body(count, q, R, C, 0, w);
}
#endif

static void point_values(int wide, int count, const double *q, double R, double C, int lucy, double *w)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (wide) {
        point_values_wide(count, q, R, C, lucy, w);
        return;
    }
#endif
    (void)wide;
    point_values_narrow(count, q, R, C, lucy, w);
}

/* Lucy's two-axis marginal and its gradient at the node offsets q[i]: v[i]
   as point_values, g[i] the gradient along the resolved axis as
   cg_lucy_marginal_gradient forms it (factor * q) */
INLINE void gradient_values_body(int count, const double *restrict q, double R, double C, double *restrict v,
                                 double *restrict g)
{
    const double RR = R * R;
    for (int i = 0; i < count; ++i) {
        const double rho2 = 0.0 + q[i] * q[i];
        v[i] = marginal2(1, C, R, RR, rho2);
        const double s = sqrt(rho2) / R, om = 1.0 - s;
        const double factor = -C * (1.0 + 3.0 * s) * om * om * om / RR;
        g[i] = (rho2 < RR ? factor : 0.0) * q[i];
    }
}

PROFILE_CLONES static void gradient_values_narrow(int count, const double *restrict q, double R, double C,
                                                  double *restrict v, double *restrict g)
{
    gradient_values_body(count, q, R, C, v, g);
}

#ifdef CG_HAVE_WIDE_SEPARABLE
__attribute__((target("avx512f"))) static void gradient_values_wide(int count, const double *restrict q, double R,
                                                                    double C, double *restrict v, double *restrict g)
{
    gradient_values_body(count, q, R, C, v, g);
}
#endif

static void gradient_values(int wide, int count, const double *q, double R, double C, double *v, double *g)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (wide) {
        gradient_values_wide(count, q, R, C, v, g);
        return;
    }
#endif
    (void)wide;
    gradient_values_narrow(count, q, R, C, v, g);
}

int cg_visit_profile(const job *jb, double *out, cg_index obj, const double *x, const double *e, double scale)
{
    const cg_target *t = jb->target;
    const cg_kernel *k = jb->kernel;
    const double R = k->radius, C = k->prefactor;
    const int lucy = k->type == CG_KERNEL_LUCY;
    double L = 0.0, unit = 0.0, ez = 0.0;
    if (jb->is_segment) {
        ez = e[0];
        const double L2 = 0.0 + ez * ez;
        if (L2 != 0.0) { /* else the point value (cg_kernel_line_rule's zero-length branch) */
            L = sqrt(L2);
            unit = ez / L;
        }
    }
    /* visit_nodes' stencil: the same nodes in the same order */
    const double end = x[0] + ez;
    double bmin[1], bmax[1];
    bmin[0] = fmin(x[0], end) - R;
    bmax[0] = fmax(x[0], end) + R;
    if (bmax[0] < jb->lo[0] || bmin[0] > jb->hi[0]) return 1;
    cg_index first[3], last[3], stride[3];
    if (!stencil_range(jb, bmin, bmax, first, last, stride)) return 1;
    const double *z = t->coords[0];
    const int nv = jb->n_values, width = jb->out_width;
    const double *val = jb->values + obj * nv;
    double q[PROFILE_BATCH], w[PROFILE_BATCH], v[PROFILE_BATCH];
    cg_index node[PROFILE_BATCH];
    for (cg_index k0 = first[0]; k0 <= last[0]; k0 += PROFILE_BATCH) {
        const int count = (int)(last[0] - k0 + 1 < PROFILE_BATCH ? last[0] - k0 + 1 : PROFILE_BATCH);
        /* values for a whole number of vectors (the padding repeats the last
           node, and is not added): no scalar remainder loop */
        const int padded = (count + PROFILE_PAD - 1) / PROFILE_PAD * PROFILE_PAD;
        for (int i = 0; i < padded; ++i) {
            const cg_index kk = i < count ? k0 + i : k0 + count - 1;
            q[i] = z[kk] - x[0];
            node[i] = kk;
        }
        if (jb->mode == MODE_GRADIENT) {
            /* cg_visit_gradient_points' sums: a node takes the object where the value or the gradient is
               non-zero (out holds n_values * 1 gradients per node) */
            gradient_values(jb->wide, padded, q, R, C, v, w);
            for (int i = 0; i < count; ++i) {
                if (!(v[i] != 0.0 || w[i] != 0.0)) continue;
                double *o = out + node[i] * width;
                for (int c = 0; c < nv; ++c) o[c] += w[i] * val[c];
            }
            continue;
        }
        if (L > 0.0) {
            segment_values(jb->wide, padded, q, ez, L, unit, R, C, lucy, scale, w);
        } else {
            point_values(jb->wide, padded, q, R, C, lucy, w);
            if (jb->is_segment) /* object_weight's psi * scale */
                for (int i = 0; i < count; ++i) w[i] *= scale;
        }
        if (nv == 9 && width == 9) /* a stress: 8 + 1 values, the same sums (w * 1.0 is w) */
            cg_lucy_add9(count, w, node, 1.0, val, out, jb->wide);
        else
            cg_ball_add(count, w, node, width, val, nv, out, jb->wide);
    }
    return 1;
}
