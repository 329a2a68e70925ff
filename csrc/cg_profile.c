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
 * cg_lucy_marginal_gradient). Non-periodic profiles without rays take their
 * objects in blocks (cg_visit_profile_objects, below): one list of (object,
 * node) pairs per block, one vectorised pass over it, the sums in the same
 * order; cg_visit_profile then serves the others, object by object. The
 * Gaussian's points and exact segment integrals on such profiles
 * (job.profile_gauss) take the same blocks with cg_visit_separable's numbers
 * (see "The Gaussian's segments" below).
 */
#include "cg_internal.h"
#include "cg_vmath.h"

#include <math.h>
#include <string.h>

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

/* segment_values_body with the segment's e, L and unit per node (lane i of a
   block's nodes, from several objects): the same operations lane by lane, scale 1 */
INLINE void segment_lanes_body(int count, const double *restrict q, const double *restrict e,
                               const double *restrict L, const double *restrict unit, double R, double C, int lucy,
                               double *restrict w)
{
    const double RR = R * R;
    for (int i = 0; i < count; ++i) {
        const double u = 0.0 + q[i] * unit[i];
        const double t_far = 0.0 + (q[i] - e[i]) * unit[i];
        const double qperp = q[i] - u * unit[i];
        const double a2 = 0.0 + qperp * qperp;
        const double b2 = RR - a2;
        const double b = sqrt(b2 > 0.0 ? b2 : 0.0);
        const double s0 = u > b ? (u - b) / L[i] : 0.0;
        const double s1 = t_far < -b ? (u + b) / L[i] : 1.0;
        const int inside = b2 > 0.0 && !(s0 > 1.0 || s1 < 0.0 || !(s0 < s1));
        const double t0 = s0 == 0.0 ? u : (s0 == 1.0 ? t_far : u - s0 * L[i]);
        const double t1 = s1 == 0.0 ? u : (s1 == 1.0 ? t_far : u - s1 * L[i]);
        const double span = (s1 - s0) * L[i];
        const int one_side_t1 = t1 >= 0.0, one_side_t0 = !one_side_t1 && t0 <= 0.0;
        const int one_side = one_side_t1 || one_side_t0;
        const double lo0 = one_side_t1 ? t1 : (one_side_t0 ? -t0 : 0.0);
        double sum = piece_terms(lucy, C, R, RR, lo0, one_side ? span : t0, 0.0);
        sum = piece_terms(lucy, C, R, RR, 0.0, one_side ? 0.0 : -t1, sum);
        w[i] = inside ? sum / L[i] * 1.0 : 0.0;
    }
}

PROFILE_CLONES static void segment_lanes_narrow(int count, const double *restrict q, const double *restrict e,
                                                const double *restrict L, const double *restrict unit, double R,
                                                double C, int lucy, double *restrict w)
{
    if (lucy) segment_lanes_body(count, q, e, L, unit, R, C, 1, w);
    else segment_lanes_body(count, q, e, L, unit, R, C, 0, w);
}

#ifdef CG_HAVE_WIDE_SEPARABLE
__attribute__((target("avx512f"))) static void segment_lanes_wide(int count, const double *restrict q,
                                                                  const double *restrict e, const double *restrict L,
                                                                  const double *restrict unit, double R, double C,
                                                                  int lucy, double *restrict w)
{
    if (lucy) segment_lanes_body(count, q, e, L, unit, R, C, 1, w);
    else segment_lanes_body(count, q, e, L, unit, R, C, 0, w);
}
#endif

static void segment_lanes(int wide, int count, const double *q, const double *e, const double *L, const double *unit,
                          double R, double C, int lucy, double *w)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (wide) {
        segment_lanes_wide(count, q, e, L, unit, R, C, lucy, w);
        return;
    }
#endif
    (void)wide;
    segment_lanes_narrow(count, q, e, L, unit, R, C, lucy, w);
}

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

/* The Gaussian's point weights at the node offsets q[i] as cg_visit_separable
   forms them on one resolved axis: the two missing slots' tables are exp(0) =
   1 exactly, so a node's weight is (prefactor 1) 1 times exp(-(q^2) / 2w^2)
   (cg_exp_in_place, lane by lane: the same bits in any width), taken where
   0 + q^2 < R^2 (rows_of_one_point's test); in[i] = 1 there, else 0 (a node
   inside takes the object even where its weight underflows to 0, as there) */
INLINE void gauss_values_body(int count, const double *restrict q, double R2, double inv2w2, double C,
                              double *restrict in, double *restrict w)
{
    for (int i = 0; i < count; ++i) w[i] = -(q[i] * q[i]) * inv2w2;
    cg_exp_in_place(w, count);
    for (int i = 0; i < count; ++i) {
        const int inside = 0.0 + q[i] * q[i] < R2;
        in[i] = inside ? 1.0 : 0.0;
        w[i] = inside ? C * w[i] : 0.0;
    }
}

PROFILE_CLONES static void gauss_values_narrow(int count, const double *restrict q, double R2, double inv2w2,
                                               double C, double *restrict in, double *restrict w)
{
    gauss_values_body(count, q, R2, inv2w2, C, in, w);
}

#ifdef CG_HAVE_WIDE_SEPARABLE
__attribute__((target("avx512f"))) static void gauss_values_wide(int count, const double *restrict q, double R2,
                                                                 double inv2w2, double C, double *restrict in,
                                                                 double *restrict w)
{
    gauss_values_body(count, q, R2, inv2w2, C, in, w);
}
#endif

static void gauss_values(int wide, int count, const double *q, double R2, double inv2w2, double C, double *in,
                         double *w)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (wide) {
        gauss_values_wide(count, q, R2, inv2w2, C, in, w);
        return;
    }
#endif
    (void)wide;
    gauss_values_narrow(count, q, R2, inv2w2, C, in, w);
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

/* ------------------------------------------------------------------ */
/* Blocks of objects (cg_visit_profile_objects): the nodes of up to
   CG_PROFILE_OBJECTS objects gathered into one list of (object, node) pairs, the
   kernel evaluated over the whole list in vectors (segments with their own
   length and direction per lane, zero-length segments and points as point
   values), then the pairs added in list order, which is object order and,
   within an object, node order: every node receives the same terms in the
   same order as object by object, so the same bits. The per-object work left
   is the stencil's bounds and the list's entries. */

/* pairs of one block at most (plus the padding of the last vector) */
#define PROFILE_PAIRS 512

/* o[c] += wi * v[c], c < nv: 4 at a time in vectors (element-wise products and
   sums, no FMA in ISO C mode: the scalar loop's bits; the compiler leaves that
   loop scalar, its 10 values per pair the larger part of a Gaussian's pair) */
INLINE void add_row(double *restrict o, double wi, const double *restrict v, int nv)
{
    int c = 0;
#if defined(__GNUC__)
    typedef double v4 __attribute__((vector_size(32)));
    const v4 w4 = {wi, wi, wi, wi};
    for (; c + 4 <= nv; c += 4) {
        v4 a, b;
        memcpy(&a, o + c, sizeof a);
        memcpy(&b, v + c, sizeof b);
        a += w4 * b;
        memcpy(o + c, &a, sizeof a);
    }
#endif
    for (; c < nv; ++c) o[c] += wi * v[c];
}

/* out[node[i] * width + c] += w[i] * val[i][c], c < nv, for every non-zero
   w[i] (cg_ball_add's and cg_lucy_add9's sums: their vector forms are these
   element-wise products and sums) */
INLINE void pairs_add_body(int count, const double *restrict w, const cg_index *restrict node,
                           const double *const *restrict val, int width, int nv, double *restrict out)
{
    for (int i = 0; i < count; ++i) {
        const double wi = w[i];
        if (wi == 0.0) continue;
        add_row(out + node[i] * width, wi, val[i], nv);
    }
}

/* the gradients g of cg_profile's gradient batches: a node takes the object where v or g is non-zero */
INLINE void pairs_add_gradient_body(int count, const double *restrict v, const double *restrict g,
                                    const cg_index *restrict node, const double *const *restrict val, int width,
                                    int nv, double *restrict out)
{
    for (int i = 0; i < count; ++i) {
        if (!(v[i] != 0.0 || g[i] != 0.0)) continue;
        add_row(out + node[i] * width, g[i], val[i], nv);
    }
}

INLINE void pairs_add_any(int count, const double *v, const double *w, const cg_index *node,
                          const double *const *val, int width, int nv, double *out)
{
    /* fixed widths: the rows' loops unrolled (the Gaussian's points: 10 values, its contacts' stress: 9,
       with v) */
    if (v && nv == 10 && width == 10) pairs_add_gradient_body(count, v, w, node, val, 10, 10, out);
    else if (v && nv == 9 && width == 9) pairs_add_gradient_body(count, v, w, node, val, 9, 9, out); /* stress */
    else if (v) pairs_add_gradient_body(count, v, w, node, val, width, nv, out);
    else if (nv == 9 && width == 9) pairs_add_body(count, w, node, val, 9, 9, out); /* a stress */
    else if (nv == 10 && width == 10) pairs_add_body(count, w, node, val, 10, 10, out); /* density to flux */
    else pairs_add_body(count, w, node, val, width, nv, out);
}

PROFILE_CLONES static void pairs_add_narrow(int count, const double *v, const double *w, const cg_index *node,
                                            const double *const *val, int width, int nv, double *out)
{
    pairs_add_any(count, v, w, node, val, width, nv, out);
}

#ifdef CG_HAVE_WIDE_SEPARABLE
__attribute__((target("avx512f"))) static void pairs_add_wide(int count, const double *v, const double *w,
                                                              const cg_index *node, const double *const *val,
                                                              int width, int nv, double *out)
{
    pairs_add_any(count, v, w, node, val, width, nv, out);
}
#endif

/* v: the values of a gradient batch (NULL for values) */
static void pairs_add(int wide, int count, const double *v, const double *w, const cg_index *node,
                      const double *const *val, int width, int nv, double *out)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (wide) {
        pairs_add_wide(count, v, w, node, val, width, nv, out);
        return;
    }
#endif
    (void)wide;
    pairs_add_narrow(count, v, w, node, val, width, nv, out);
}

/* one block's pairs: segment lanes (sq, se, sL, su; their pair sp) and point
   lanes (pq; their pair pp) */
typedef struct profile_block {
    int n, ns, np;
    double q_seg[PROFILE_PAIRS + PROFILE_PAD], e[PROFILE_PAIRS + PROFILE_PAD], L[PROFILE_PAIRS + PROFILE_PAD],
        unit[PROFILE_PAIRS + PROFILE_PAD], q_pt[PROFILE_PAIRS + PROFILE_PAD];
    /* the Gaussian's segments (job.profile_gauss): q_seg, e (the segment along the axis) and
       the points of the segment's rule, 0 where it has none (cg_gaussian_roundoff_points) */
    double rule_points[PROFILE_PAIRS + PROFILE_PAD];
    int seg_pair[PROFILE_PAIRS], pt_pair[PROFILE_PAIRS];
    double w_seg[PROFILE_PAIRS + PROFILE_PAD], w_pt[PROFILE_PAIRS + PROFILE_PAD], v_pt[PROFILE_PAIRS + PROFILE_PAD];
    double w[PROFILE_PAIRS + PROFILE_PAD], v[PROFILE_PAIRS + PROFILE_PAD]; /* (lanes' padding: points alone) */
    cg_index node[PROFILE_PAIRS];
    const double *val[PROFILE_PAIRS];
} profile_block;

/* the lanes up to a whole number of vectors, repeating the last (computed, not added) */
static int pad_lanes(int n, double *a, double *b, double *c, double *d)
{
    const int padded = (n + PROFILE_PAD - 1) / PROFILE_PAD * PROFILE_PAD;
    for (int i = n; i < padded; ++i) {
        a[i] = a[n - 1];
        if (b) {
            b[i] = b[n - 1];
            c[i] = c[n - 1];
            d[i] = d[n - 1];
        }
    }
    return padded;
}

/* ------------------------------------------------------------------ */
/* The Gaussian's segments on a profile (job.profile_gauss, exact line
   integrals): cg_visit_separable's numbers for one resolved axis, lane by
   lane over a block's pairs. There the two averaged axes are slots with one
   node at 0 and a segment of length 0 along them, so that every sum over the
   slots reduces to the resolved one's terms (0 * 0 = +0 and +0 + x = x, as
   written out below where it is not exact for every x), and each node takes
   one term of each object: the segment's Gauss-Legendre rule
   (cg_gaussian_roundoff_points: the tables' exp(-(q - x_g e)^2 / 2w^2)
   summed with the weights times the prefactor, the slots' factor exp(-0) = 1)
   at the nodes whose ball holds both ends, near enough to them (CG_GAUSS_FAR_BEYOND_END);
   the closed form in tails (erfcx, cut_batch_flush's lanes, a short
   Gauss-Legendre rule where it would cancel) at the other nodes of the capsule;
   nothing at a segment of length 0 along the axis there (those of length +-0
   are the points' lanes: the slots' sum of the weights times exp(-q^2 / 2w^2)).
   Segments too long for a rule (cg_visit_separable leaves them to the
   node-by-node erf form) take the closed form at all their nodes: the same
   integral, to round-off relative to each value. */

/* lanes of the rule and of the closed form evaluated at a time (whole vectors) */
#define GAUSS_RULE_CHUNK 64
#define GAUSS_CUT_CHUNK 128
/* the closed form's fallback: Gauss-Legendre points on a short interval (as cut_batch_flush's) */
#define GAUSS_CUT_FALLBACK 8

/* each lane's route: rule[i] = 1 where the segment's rule takes node i, cut[i] = 1
   where the closed form does (cg_visit_separable's tests, in_bits and cand_bits,
   node by node: its walks' intervals are these nodes, the tests being monotone
   along the axis) */
INLINE void gauss_routes_body(int count, const double *restrict q, const double *restrict ez,
                              const double *restrict points, double R, double w, double *restrict rule,
                              double *restrict cut)
{
    const double R2 = R * R, R2_margin = R2 * (1.0 + 1e-12);
    for (int i = 0; i < count; ++i) {
        const double L2 = 0.0 + ez[i] * ez[i], L = sqrt(L2);
        const double inv_L2 = L2 > 0.0 ? 1.0 / L2 : 0.0, R2_cyl = R2_margin + 1e-14 * L2;
        const double qb = q[i] - ez[i];
        const double sa = 0.0 + q[i] * q[i], sb = 0.0 + qb * qb, p = 0.0 + q[i] * ez[i];
        const int cyl = (sa - (p * p) * inv_L2 < R2_cyl) & (p >= 0.0) & (p <= L2);
        const int cand = (sa < R2_margin) | (sb < R2_margin) | cyl;
        const int far_check = R - L > CG_GAUSS_FAR_BEYOND_END * w;
        const double far_lo = -CG_GAUSS_FAR_BEYOND_END * w * L, far_hi = L2 + CG_GAUSS_FAR_BEYOND_END * w * L;
        const int near = (far_check == 0) | ((p >= far_lo) & (p <= far_hi));
        const int in = (points[i] > 0.0) & (sa < R2) & (sb < R2) & near;
        rule[i] = in ? 1.0 : 0.0;
        /* a segment of length 0 (ez below sqrt of the smallest double): its cut nodes carry 0 */
        cut[i] = cand & (in == 0) & (L2 > 0.0) ? 1.0 : 0.0;
    }
}

/* the rule's weights at n nodes (q, ez per lane), G points x_g, weights gw_g
   (times the prefactor): sum_g gw_g exp(-(q - x_g ez)^2 / 2w^2), in g order
   from +0 (args: G n doubles) */
INLINE void gauss_rule_body(int n, int G, const double *restrict q, const double *restrict ez,
                            const double *restrict gx, const double *restrict gw, double inv2w2,
                            double *restrict args, double *restrict w)
{
    for (int g = 0; g < G; ++g)
        for (int i = 0; i < n; ++i) {
            const double qg = q[i] - gx[g] * ez[i];
            args[g * n + i] = -(qg * qg) * inv2w2;
        }
    cg_exp_in_place(args, (cg_index)G * n);
    for (int i = 0; i < n; ++i) w[i] = 0.0;
    for (int g = 0; g < G; ++g)
        for (int i = 0; i < n; ++i) w[i] += gw[g] * args[g * n + i];
}

/* cut_lanes with the node (0, 0, q) and the segment (0, 0, ez) per lane: the
   exponents e0, e1, ea (halved), erfcx's arguments c0, c1, and the factor
   sqrt(pi/2) w C / L */
INLINE void gauss_cut_lanes_body(int n, const double *restrict q, const double *restrict ez, double R2, double w,
                                 double C, double *restrict a2s, double *restrict t0s, double *restrict spans,
                                 double *restrict e0, double *restrict e1, double *restrict ea,
                                 double *restrict c0, double *restrict c1, double *restrict factor,
                                 double *restrict near)
{
    const double inv4w2 = 0.25 / (w * w), inv_sqrt2w = 1.0 / (1.4142135623730951 * w);
    const double amp_w = C * 1.2533141373155003 * w;
    for (int i = 0; i < n; ++i) {
        const double L2 = 0.0 + ez[i] * ez[i], inv_L2 = 1.0 / L2, L = sqrt(L2);
        const double near_b2 = -0x1p-40 * R2, near_s = 0x1p-40 * sqrt(R2 * inv_L2);
        const double u = (0.0 + q[i] * ez[i]) * inv_L2;
        const double d0 = 0.0 - u * 0.0, d2 = q[i] - u * ez[i];
        const double a2 = (d0 * d0 + d0 * d0) + d2 * d2;
        double b2 = R2 - a2;
        const int meets_line = b2 > near_b2;
        b2 = b2 > 0.0 ? b2 : 0.0;
        const double half = sqrt(b2 * inv_L2);
        double s0 = u - half, s1 = u + half;
        near[i] = meets_line & (s1 > -near_s) & (s0 < 1.0 + near_s) ? 1.0 : 0.0;
        s0 = s0 > 0.0 ? s0 : 0.0;
        s1 = s1 < 1.0 ? s1 : 1.0;
        double span = s1 - s0;
        span = span > 0.0 ? span : 0.0;
        const double t0 = (s0 - u) * L, t1 = t0 + span * L;
        a2s[i] = a2;
        t0s[i] = s0 - u;
        spans[i] = span;
        e0[i] = -(a2 + t0 * t0) * inv4w2;
        e1[i] = -(a2 + t1 * t1) * inv4w2;
        ea[i] = -a2 * inv4w2;
        c0[i] = (t0 < 0.0 ? -t0 : t0) * inv_sqrt2w;
        c1[i] = (t1 < 0.0 ? -t1 : t1) * inv_sqrt2w;
        factor[i] = amp_w / L;
    }
}

/* cut_values with a factor per lane */
INLINE int gauss_cut_values_body(int n, const double *restrict t0s, const double *restrict spans,
                                 const double *restrict e0, const double *restrict e1, const double *restrict ea,
                                 const double *restrict c0, const double *restrict c1, const double *restrict factor,
                                 double *restrict value, double *restrict is_short)
{
    int64_t any_short = 0;
    for (int i = 0; i < n; ++i) {
        const double T0 = (e0[i] * c0[i]) * e0[i], T1 = (e1[i] * c1[i]) * e1[i], twoA = 2.0 * ea[i] * ea[i];
        const double t0 = t0s[i], t1 = t0s[i] + spans[i];
        const int straddle = (t0 < 0.0) & (t1 > 0.0);
        const double diff = T0 > T1 ? T0 - T1 : T1 - T0, larger = T0 > T1 ? T0 : T1;
        const double v = straddle ? (twoA - T0) - T1 : diff;
        const double largest = straddle ? twoA : larger;
        value[i] = v * factor[i];
        const int64_t short_i = ((spans[i] > 0.0) | (is_short[i] != 0.0)) & !(16.0 * v >= largest);
        is_short[i] = short_i ? 1.0 : 0.0;
        any_short |= short_i;
    }
    return any_short != 0;
}

/* The weights of a block's segment lanes into B->w, B->v at their pairs (v = 1:
   the rule's nodes, added whatever their weight, as block_add adds a row; 0: the
   closed form's, added where not 0, as cut_batch_flush) */
INLINE void gauss_segments_body(const job *jb, profile_block *B)
{
    const cg_kernel *k = jb->kernel;
    const double R = k->radius, R2 = R * R, w = k->width, C = k->prefactor, inv2w2 = 0.5 / (w * w);
    const int ns = B->ns;
    const int padded = (ns + PROFILE_PAD - 1) / PROFILE_PAD * PROFILE_PAD;
    for (int i = ns; i < padded; ++i) {
        B->q_seg[i] = B->q_seg[ns - 1];
        B->e[i] = B->e[ns - 1];
        B->rule_points[i] = B->rule_points[ns - 1];
    }
    double *const rule = B->w_seg, *const cut = B->L; /* (Lucy's lanes: free here) */
    gauss_routes_body(padded, B->q_seg, B->e, B->rule_points, R, w, rule, cut);
    /* the lanes of each route, the rule's by its number of points */
    int rule_lane[PROFILE_PAIRS], cut_lane[PROFILE_PAIRS], n_rule = 0, n_cut = 0;
    int per_points[CG_MAX_LINE_POINTS + 2] = {0};
    double points_lo = CG_MAX_LINE_POINTS, points_hi = 0.0; /* of the rule's lanes */
    for (int i = 0; i < ns; ++i) {
        const int p = B->seg_pair[i];
        B->w[p] = 0.0;
        B->v[p] = rule[i];
        const double G = rule[i] != 0.0 ? B->rule_points[i] : points_lo;
        points_lo = G < points_lo ? G : points_lo;
        points_hi = rule[i] != 0.0 && G > points_hi ? G : points_hi;
        rule_lane[n_rule] = i;
        n_rule += rule[i] != 0.0;
        cut_lane[n_cut] = i;
        n_cut += cut[i] != 0.0;
    }
    if (n_rule > 0) {
        int by_points_sorted[PROFILE_PAIRS];
        const int *by_points = rule_lane;
        if (points_lo == points_hi) {
            /* one rule for all (most blocks) */
            per_points[(int)points_lo] = n_rule;
            for (int G = (int)points_lo + 1; G <= CG_MAX_LINE_POINTS; ++G) per_points[G] = n_rule;
        } else {
            for (int m = 0; m < n_rule; ++m) ++per_points[(int)B->rule_points[rule_lane[m]] + 1];
            for (int G = 0; G <= CG_MAX_LINE_POINTS; ++G) per_points[G + 1] += per_points[G];
            for (int m = 0; m < n_rule; ++m)
                by_points_sorted[per_points[(int)B->rule_points[rule_lane[m]]]++] = rule_lane[m];
            by_points = by_points_sorted;
        }
        /* per_points[G] is now the end of G's lanes */
        double q[GAUSS_RULE_CHUNK], ez[GAUSS_RULE_CHUNK], wt[GAUSS_RULE_CHUNK];
        double args[CG_MAX_LINE_POINTS * GAUSS_RULE_CHUNK];
        int begin = 0;
        for (int G = 1; G <= CG_MAX_LINE_POINTS; ++G) {
            const int end = per_points[G];
            if (end == begin) continue;
            double gx[CG_MAX_LINE_POINTS], gw[CG_MAX_LINE_POINTS];
            cg_gauss_legendre01(G, gx, gw);
            for (int g = 0; g < G; ++g) gw[g] *= 1.0 * C; /* scale (1) times the prefactor */
            for (int m0 = begin; m0 < end; m0 += GAUSS_RULE_CHUNK) {
                const int n = end - m0 < GAUSS_RULE_CHUNK ? end - m0 : GAUSS_RULE_CHUNK;
                const int n_padded = (n + PROFILE_PAD - 1) / PROFILE_PAD * PROFILE_PAD;
                for (int m = 0; m < n_padded; ++m) {
                    const int i = by_points[m < n ? m0 + m : m0 + n - 1];
                    q[m] = B->q_seg[i];
                    ez[m] = B->e[i];
                }
                gauss_rule_body(n_padded, G, q, ez, gx, gw, inv2w2, args, wt);
                for (int m = 0; m < n; ++m) {
                    const int p = B->seg_pair[by_points[m0 + m]];
                    B->w[p] = 1.0 * wt[m]; /* the slots' factor exp(-0) exp(-0) */
                }
            }
            begin = end;
        }
    }
    if (n_cut > 0) {
        double q[GAUSS_CUT_CHUNK], ez[GAUSS_CUT_CHUNK], a2s[GAUSS_CUT_CHUNK], t0s[GAUSS_CUT_CHUNK];
        double spans[GAUSS_CUT_CHUNK], factor[GAUSS_CUT_CHUNK], value[GAUSS_CUT_CHUNK], is_short[GAUSS_CUT_CHUNK];
        double ex[3 * GAUSS_CUT_CHUNK], c[2 * GAUSS_CUT_CHUNK]; /* e0, e1, ea; c0, c1 */
        double arg[GAUSS_CUT_FALLBACK * GAUSS_CUT_CHUNK];
        int short_lane[GAUSS_CUT_CHUNK];
        for (int m0 = 0; m0 < n_cut; m0 += GAUSS_CUT_CHUNK) {
            const int n = n_cut - m0 < GAUSS_CUT_CHUNK ? n_cut - m0 : GAUSS_CUT_CHUNK;
            const int n_padded = (n + PROFILE_PAD - 1) / PROFILE_PAD * PROFILE_PAD;
            for (int m = 0; m < n_padded; ++m) {
                const int i = cut_lane[m < n ? m0 + m : m0 + n - 1];
                q[m] = B->q_seg[i];
                ez[m] = B->e[i];
            }
            double *const e0 = ex, *const e1 = ex + n_padded, *const ea = ex + 2 * n_padded;
            double *const c0 = c, *const c1 = c + n_padded;
            gauss_cut_lanes_body(n_padded, q, ez, R2, w, C, a2s, t0s, spans, e0, e1, ea, c0, c1, factor, is_short);
            cg_exp_in_place(ex, 3 * n_padded);
            cg_erfcx_in_place2(c0, c1, n_padded, R2 > 31.9 * (w * w));
            const int any_short = gauss_cut_values_body(n_padded, t0s, spans, e0, e1, ea, c0, c1, factor, value,
                                                        is_short);
            int n_short = 0;
            if (any_short)
                for (int m = 0; m < n; ++m)
                    if (is_short[m] != 0.0) short_lane[n_short++] = m;
            if (n_short) {
                /* the short intervals: Gauss-Legendre on [s0, s0 + span] (cut_batch_flush's, its span from
                   exact differences) */
                for (int s = 0; s < n_short; ++s) {
                    const int m = short_lane[s];
                    const double e3[3] = {0.0, 0.0, ez[m]};
                    cg_cut_span_frame f;
                    cg_cut_span_frame_of(e3, R, &f);
                    spans[m] = cg_cut_span_lane(0.0, 0.0, q[m], &f);
                }
                double gx[GAUSS_CUT_FALLBACK], gw[GAUSS_CUT_FALLBACK];
                cg_gauss_legendre01(GAUSS_CUT_FALLBACK, gx, gw);
                for (int g = 0; g < GAUSS_CUT_FALLBACK; ++g)
                    for (int s = 0; s < n_short; ++s) {
                        const int m = short_lane[s];
                        const double t = t0s[m] + gx[g] * spans[m], L2 = 0.0 + ez[m] * ez[m];
                        arg[g * n_short + s] = -(a2s[m] + t * t * L2) * (0.5 * inv2w2);
                    }
                cg_exp_in_place(arg, (cg_index)GAUSS_CUT_FALLBACK * n_short);
                for (int s = 0; s < n_short; ++s) {
                    const int m = short_lane[s];
                    double sum = 0.0;
                    for (int g = 0; g < GAUSS_CUT_FALLBACK; ++g)
                        sum += (gw[g] * arg[g * n_short + s]) * arg[g * n_short + s];
                    value[m] = (1.0 * C * sum) * spans[m];
                }
            }
            for (int m = 0; m < n; ++m) B->w[B->seg_pair[cut_lane[m0 + m]]] = value[m];
        }
    }
}

PROFILE_CLONES static void gauss_segments_narrow(const job *jb, profile_block *B) { gauss_segments_body(jb, B); }

#ifdef CG_HAVE_WIDE_SEPARABLE
__attribute__((target("avx512f"))) static void gauss_segments_wide(const job *jb, profile_block *B)
{
    gauss_segments_body(jb, B);
}
#endif

static void gauss_segments(const job *jb, profile_block *B)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (jb->wide) {
        gauss_segments_wide(jb, B);
        return;
    }
#endif
    gauss_segments_narrow(jb, B);
}

/* the constant of the points' lanes (gauss_values): the prefactor for points; for
   segments of length +-0 along the axis, cg_visit_separable's weight of their
   rows, the sum of their rule's weights times the prefactor (times exp(-0) = 1) */
static double gauss_point_constant(const job *jb)
{
    const cg_kernel *k = jb->kernel;
    if (!jb->is_segment) return k->prefactor;
    double gx[CG_MAX_LINE_POINTS], gw[CG_MAX_LINE_POINTS], sum = 0.0;
    const int G = cg_gaussian_roundoff_points(0.0, k->width);
    cg_gauss_legendre01(G, gx, gw);
    for (int g = 0; g < G; ++g) sum += gw[g] * (1.0 * k->prefactor) * 1.0;
    return sum * 1.0;
}

/* the kernel over the block's lanes, then its pairs added in order */
static void flush_block(const job *jb, profile_block *B, double *out)
{
    if (B->n == 0) return;
    const cg_kernel *k = jb->kernel;
    const double R = k->radius, C = k->prefactor;
    const int lucy = k->type == CG_KERNEL_LUCY, gradient = jb->mode == MODE_GRADIENT;
    if (B->ns > 0 && jb->profile_gauss) {
        gauss_segments(jb, B);
    } else if (B->ns > 0) {
        const int padded = pad_lanes(B->ns, B->q_seg, B->e, B->L, B->unit);
        segment_lanes(jb->wide, padded, B->q_seg, B->e, B->L, B->unit, R, C, lucy, B->w_seg);
        for (int i = 0; i < B->ns; ++i) B->w[B->seg_pair[i]] = B->w_seg[i];
    }
    if (B->np > 0) {
        const int padded = pad_lanes(B->np, B->q_pt, NULL, NULL, NULL);
        /* only points' lanes: lane i is pair i, the values straight into the pairs' */
        const int direct = B->ns == 0;
        double *const v = direct ? B->v : B->v_pt, *const w = direct ? B->w : B->w_pt;
        if (jb->profile_gauss) {
            /* v: the nodes inside the cutoff (pairs_add's gradient form adds w where v != 0) */
            const double width = k->width;
            gauss_values(jb->wide, padded, B->q_pt, R * R, 0.5 / (width * width), gauss_point_constant(jb), v, w);
        } else if (gradient) {
            gradient_values(jb->wide, padded, B->q_pt, R, C, v, w);
        } else {
            /* a zero-length segment's psi * scale: scale is 1 here, and w * 1.0 is w */
            point_values(jb->wide, padded, B->q_pt, R, C, lucy, w);
        }
        if (!direct) {
            if (gradient || jb->profile_gauss) {
                for (int i = 0; i < B->np; ++i) {
                    const int p = B->pt_pair[i];
                    B->v[p] = v[i];
                    B->w[p] = w[i];
                }
            } else {
                for (int i = 0; i < B->np; ++i) B->w[B->pt_pair[i]] = w[i];
            }
        }
    }
    pairs_add(jb->wide, B->n, gradient || jb->profile_gauss ? B->v : NULL, B->w, B->node, B->val, jb->out_width, jb->n_values, out);
    B->n = B->ns = B->np = 0;
}

int cg_profile_blocks(const job *jb)
{
    return (jb->profile_rows && !(jb->is_segment && jb->ray) && !jb->target->periodic[0]) ||
           (jb->profile_gauss && !jb->target->periodic[0]);
}

/* (cloned: floor and ceil are single instructions from SSE 4.1 on) */
PROFILE_CLONES void cg_visit_profile_objects(const job *jb, double *out, const cg_index *order, cg_index begin,
                                             cg_index end)
{
    const cg_target *t = jb->target;
    const int D = t->dim, a0 = t->axes[0], nv = jb->n_values;
    const double R = jb->kernel->radius, lo = jb->lo[0], hi = jb->hi[0];
    const double *z = t->coords[0];
    const cg_index n0 = t->shape[0];
    const double c0 = z[0], h = jb->spacing[0];
    const int whole = n0 == 1 || h == 0.0; /* stencil_range takes every node */
    /* values formed per object (cg_forms_values): formed here, a row per object of the block */
    double rows[CG_PROFILE_OBJECTS * CG_MAX_OUTER_VALUES];
    job own;
    const job *jv = jb;
    const int formed = cg_forms_values(jb);
    if (formed) {
        own = *jb;
        own.values = rows;
        jv = &own;
    }
    profile_block B;
    B.n = B.ns = B.np = 0;
    for (cg_index o = begin; o < end; ++o) {
        const cg_index obj = order ? order[o] : o;
        const int b = (int)(o - begin);
        const double x = jb->positions[obj * D + a0];
        double ez = 0.0, L = 0.0, unit = 0.0;
        if (jb->is_segment) {
            ez = cg_vec_of(jb, obj, a0);
            const double L2 = 0.0 + ez * ez;
            if (L2 != 0.0) {
                L = sqrt(L2);
                unit = ez / L;
            }
        }
        /* cg_visit_profile's stencil (fmin and fmax as comparisons: end is x + ez, NaN where x is) */
        const double end_ = x + ez;
        const double bmin = (end_ < x ? end_ : x) - R, bmax = (end_ > x ? end_ : x) + R;
        if (bmax < lo || bmin > hi) continue;
        cg_index first = 0, last = n0 - 1;
        if (!whole) {
            double f = floor((bmin - c0) / h), l = ceil((bmax - c0) / h);
            if (f < 0.0) f = 0.0;
            if (l > (double)(n0 - 1)) l = (double)(n0 - 1);
            if (f > l) continue;
            first = (cg_index)f;
            last = (cg_index)l;
        }
        const double *val;
        if (formed) {
            double *r = rows + b * nv;
            cg_form_values(jb, obj, r);
            val = r;
        } else {
            val = jb->values + obj * nv;
        }
        const cg_index count = last - first + 1;
        if (jb->profile_gauss) {
            /* the object's nodes in order, across as many blocks as they fill: points and segments
               of length +-0 along the axis as points, other segments with their rule's points */
            const int segment = jb->is_segment && ez != 0.0;
            const double points = segment ? (double)cg_gaussian_roundoff_points(sqrt(0.0 + ez * ez), jb->kernel->width)
                                          : 0.0;
            if (segment) {
                for (cg_index kk = first; kk <= last; ++kk) {
                    if (B.n == PROFILE_PAIRS) flush_block(jb, &B, out);
                    B.q_seg[B.ns] = z[kk] - x;
                    B.e[B.ns] = ez;
                    B.rule_points[B.ns] = points;
                    B.seg_pair[B.ns++] = B.n;
                    B.node[B.n] = kk;
                    B.val[B.n++] = val;
                }
            } else {
                for (cg_index kk = first; kk <= last; ++kk) {
                    if (B.n == PROFILE_PAIRS) flush_block(jb, &B, out);
                    B.q_pt[B.np] = z[kk] - x;
                    B.pt_pair[B.np++] = B.n;
                    B.node[B.n] = kk;
                    B.val[B.n++] = val;
                }
            }
            continue;
        }
        if (B.n + count > PROFILE_PAIRS) {
            flush_block(jb, &B, out);
            if (count > PROFILE_PAIRS) { /* a long stencil alone, in batches */
                double xs[3] = {x, 0.0, 0.0}, es[3] = {ez, 0.0, 0.0};
                cg_visit_profile(jv, out, formed ? b : obj, xs, es, 1.0);
                continue;
            }
        }
        const int segment = L > 0.0 && jb->mode != MODE_GRADIENT;
        for (cg_index kk = first; kk <= last; ++kk) {
            const double q = z[kk] - x;
            if (segment) {
                B.q_seg[B.ns] = q;
                B.e[B.ns] = ez;
                B.L[B.ns] = L;
                B.unit[B.ns] = unit;
                B.seg_pair[B.ns++] = B.n;
            } else {
                B.q_pt[B.np] = q;
                B.pt_pair[B.np++] = B.n;
            }
            B.node[B.n] = kk;
            B.val[B.n++] = val;
        }
    }
    flush_block(jb, &B, out);
}
