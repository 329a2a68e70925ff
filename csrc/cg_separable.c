/*
 * cg_separable.c -- the Gaussian on regular grids, as outer products of 1-D
 * weights.
 *
 * exp(-|r - x|^2 / 2w^2) = prod_a exp(-(r_a - x_a)^2 / 2w^2), so for one
 * object the weights of its whole stencil need only one table of exponentials
 * per axis; a row of nodes along the last resolved axis (contiguous in the
 * output) then costs one multiply-add per node and value. The cutoff ball is
 * applied node by node with the same squared distance, summed in the same
 * order, as the node-by-node path (cg_scatter.c), so both agree to rounding.
 *
 * Segments with an n-point Gauss-Legendre rule are n points with weights
 * w_g: the same outer products, one table set per point. Segments asked for
 * to round-off ("exact") use a Gauss-Legendre rule that is exact to round-off
 * (cg_gaussian_roundoff_points) at the nodes whose whole segment lies inside
 * the cutoff ball (both ends inside: the integrand is a smooth Gaussian on
 * [0, 1]), and the exact erf form (cg_kernel_line_rule) at the nodes the
 * cutoff sphere cuts the segment for; segments too long for such a rule go
 * to the node-by-node path.
 *
 * Resolved axes are placed in three "slots", right-aligned: the last
 * resolved axis (stride 1 in the output) is always slot 2; missing slots
 * have one node, coordinate 0 and weight 1.
 */
#include "cg_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* helpers of the hot loop are inlined into it, so that its AVX2 clone (below) covers them too */
#if defined(__GNUC__)
#define INLINE static inline __attribute__((always_inline))
#else
#define INLINE static inline
#endif

static double *scratch_get(scratch *sc, size_t need)
{
    if (need > sc->cap) {
        double *b = realloc(sc->buf, need * sizeof(double));
        if (!b) return NULL;
        sc->buf = b;
        sc->cap = need;
    }
    return sc->buf;
}

/* out row (nk nodes, nv values each, contiguous) += w[k] * v; fixed widths
   let the compiler unroll and vectorise */
#define ROW_ADD_FIXED(NV)                                                  \
    for (cg_index k = 0; k < nk; ++k) {                                    \
        const double wk = w[k];                                            \
        double *ok = o + k * (NV);                                         \
        for (int c = 0; c < (NV); ++c) ok[c] += wk * v[c];                 \
    }

INLINE void row_add(double *restrict o, const double *restrict w, cg_index nk, const double *restrict v, int nv)
{
    switch (nv) {
    case 1: {
        const double v0 = v[0];
        for (cg_index k = 0; k < nk; ++k) o[k] += w[k] * v0;
        return;
    }
    case 2: ROW_ADD_FIXED(2) return;
    case 3: ROW_ADD_FIXED(3) return;
    case 4: ROW_ADD_FIXED(4) return;
    case 7: ROW_ADD_FIXED(7) return;   /* 2D density, momentum and momentum flux in one scatter */
    case 9: ROW_ADD_FIXED(9) return;
    case 13: ROW_ADD_FIXED(13) return; /* the same in 3D */
    default:
        for (cg_index k = 0; k < nk; ++k)
            for (int c = 0; c < nv; ++c) o[k * nv + c] += w[k] * v[c];
    }
}

/* ex[k] = exp(-d2[k] / 2w^2) for the squared distances d2[k] = (q0 + k h)^2
   of equally spaced nodes. exp(-(q0 + (k+1) h)^2 c) = exp(-(q0 + k h)^2 c) r_k
   with r_k = exp(-(2 (q0 + k h) h + h^2) c) and r_{k+1} = r_k exp(-2 h^2 c):
   three exponentials per table instead of one per node; the products lose
   about one rounding per step, far below the tolerances (stencils are short).
   Direct where the first value could underflow. */
INLINE void gaussian_table(const double *d2, cg_index n, double q0, double h, double inv2w2, double *ex)
{
    if (n < 4 || !(h > 0.0) || d2[0] * inv2w2 > 600.0 || d2[n - 1] * inv2w2 > 600.0) {
        for (cg_index k = 0; k < n; ++k) ex[k] = exp(-d2[k] * inv2w2);
        return;
    }
    double value = exp(-d2[0] * inv2w2), ratio = exp(-(2.0 * q0 * h + h * h) * inv2w2);
    const double step = exp(-2.0 * h * h * inv2w2);
    ex[0] = value;
    for (cg_index k = 1; k < n; ++k) {
        value *= ratio;
        ratio *= step;
        ex[k] = value;
    }
}

/* The exact line integral (to round-off) at a node whose ball the segment
   leaves: q = node - start and e in slots, |e|^2 = L2. The integrand
   exp(-|q - s e|^2 / 2w^2) = exp(-(a^2 + (s - u)^2 L2) / 2w^2) is smooth on
   the part [s0, s1] of [0, 1] inside the ball, so a Gauss-Legendre rule that is
   exact to round-off for that length (no longer than the segment) integrates it. */
INLINE double cut_segment_value(const double *q, const double *e, double L2, double inv_L2, double R2, double w,
                                double inv2w2)
{
    const double u = (q[0] * e[0] + q[1] * e[1] + q[2] * e[2]) * inv_L2;
    double a2 = 0.0;
    for (int s = 0; s < 3; ++s) {
        const double d = q[s] - u * e[s];
        a2 += d * d;
    }
    const double b2 = R2 - a2;
    if (!(b2 > 0.0)) return 0.0;
    const double half = sqrt(b2 * inv_L2);
    const double s0 = u - half > 0.0 ? u - half : 0.0, s1 = u + half < 1.0 ? u + half : 1.0;
    if (!(s1 > s0)) return 0.0;
    const double span = s1 - s0;
    double xs[CG_MAX_LINE_POINTS], ws[CG_MAX_LINE_POINTS];
    int m = cg_gaussian_roundoff_points(span * sqrt(L2), w);
    if (m == 0) m = CG_MAX_LINE_POINTS; /* not reached: the segment itself passed this test */
    cg_gauss_legendre01(m, xs, ws);
    double sum = 0.0;
    for (int g = 0; g < m; ++g) {
        const double t = s0 + xs[g] * span - u;
        sum += ws[g] * exp(-(a2 + t * t * L2) * inv2w2);
    }
    return sum * span;
}

/* squared distance from point p to the segment [0, e] (3 slots), q = p */
INLINE double segment_distance2(const double *q, const double *e, double inv_L2)
{
    double t = 0.0;
    if (inv_L2 > 0.0) {
        t = (q[0] * e[0] + q[1] * e[1] + q[2] * e[2]) * inv_L2;
        t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
    }
    double d2 = 0.0;
    for (int s = 0; s < 3; ++s) {
        const double d = q[s] - t * e[s];
        d2 += d * d;
    }
    return d2;
}

/* On x86-64 with GCC, also build an AVX2 version of the hot loops, chosen at
   load time on CPUs that have it (4 doubles per instruction instead of 2).
   Results are identical: ISO C mode (-std=c11) forbids contracting a*b+c
   into an FMA, and no sum is reordered. */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(CGBOUND_NO_CLONES) && \
    defined(__has_attribute)
#if __has_attribute(target_clones)
#define HOT_CLONES __attribute__((target_clones("avx2", "default")))
#endif
#endif
#ifndef HOT_CLONES
#define HOT_CLONES
#endif

HOT_CLONES
int cg_visit_separable(const job *jb, double *out, scratch *sc, cg_index obj, const double *x, const double *e,
                       double scale)
{
    const cg_target *t = jb->target;
    const cg_kernel *kn = jb->kernel;
    const int nr = t->n_resolved, pad = 3 - nr;
    const double R = kn->radius, R2 = R * R, w = kn->width, inv2w2 = 0.5 / (w * w);

    /* the rule: G points on the object with weights (times the prefactor) */
    double gx[CG_MAX_LINE_POINTS], gw[CG_MAX_LINE_POINTS];
    int G = 1, hybrid = 0;
    double L2 = 0.0;
    if (jb->is_segment) {
        for (int a = 0; a < nr; ++a) L2 += e[a] * e[a];
        G = jb->ray ? 0 : jb->line_points;
        if (G == 0) {
            G = cg_gaussian_roundoff_points(sqrt(L2), w);
            if (G == 0) return 0; /* too long: the node-by-node erf form */
            hybrid = 1;
        }
        cg_gauss_legendre01(G, gx, gw);
        for (int g = 0; g < G; ++g) gw[g] *= scale * kn->prefactor;
    } else {
        gx[0] = 0.0;
        gw[0] = kn->prefactor;
    }

    /* stencil: node index range along each slot (as in visit_nodes) */
    cg_index first[3] = {0, 0, 0}, count[3] = {1, 1, 1}, stride[3] = {0, 0, 0};
    double xs[3] = {0.0, 0.0, 0.0}, es[3] = {0.0, 0.0, 0.0};
    cg_index st = 1;
    for (int a = nr - 1; a >= 0; --a) {
        const int s = a + pad;
        const double c0 = t->coords[a][0], h = jb->spacing[a];
        const cg_index n = t->shape[a];
        stride[s] = st;
        st *= n;
        xs[s] = x[a];
        es[s] = e ? e[a] : 0.0;
        const double lo = fmin(x[a], x[a] + es[s]) - R, hi = fmax(x[a], x[a] + es[s]) + R;
        if (hi < jb->lo[a] || lo > jb->hi[a]) return 1;
        if (n == 1 || h == 0.0) { first[s] = 0; count[s] = n; continue; }
        double f = floor((lo - c0) / h), l = ceil((hi - c0) / h);
        if (f < 0.0) f = 0.0;
        if (l > (double)(n - 1)) l = (double)(n - 1);
        if (f > l) return 1;
        first[s] = (cg_index)f;
        count[s] = (cg_index)l - (cg_index)f + 1;
    }
    const cg_index n0 = count[0], n1 = count[1], n2 = count[2];
    const size_t per_point = 2 * (size_t)(n0 + n1 + n2);
    /* tables d2, g per rule point; end-point tables (hybrid); node coordinates; a row */
    const size_t need = (size_t)G * per_point + (hybrid ? per_point : 0) + (size_t)(n0 + n1 + n2) + 2 * (size_t)n2;
    double *buf = scratch_get(sc, need);
    if (!buf) return -1;
    double *coord = buf + (size_t)G * per_point + (hybrid ? per_point : 0); /* node coordinate - x, per slot */
    double *row = coord + (n0 + n1 + n2);
    double *inside = row + n2; /* hybrid: 1 where the rule is exact, else 0 */
    double *cslot[3] = {coord, coord + n0, coord + n0 + n1};
    for (int s = 0; s < 3; ++s) {
        const int a = s - pad;
        for (cg_index k = 0; k < count[s]; ++k) cslot[s][k] = a >= 0 ? t->coords[a][first[s] + k] - xs[s] : 0.0;
    }
    /* per rule point g and slot s: d2[g][s][k] = (node - point)^2, ex = exp(-d2 / 2w^2) */
    double *d2[CG_MAX_LINE_POINTS][3], *ex[CG_MAX_LINE_POINTS][3];
    for (int g = 0; g < G; ++g) {
        double *p = buf + (size_t)g * per_point;
        for (int s = 0; s < 3; ++s) {
            d2[g][s] = p;
            ex[g][s] = p + count[s];
            p += 2 * count[s];
            const int a = s - pad;
            double q0 = 0.0;
            for (cg_index k = 0; k < count[s]; ++k) {
                double q = 0.0;
                if (a >= 0) q = jb->is_segment ? t->coords[a][first[s] + k] - (xs[s] + gx[g] * es[s]) : cslot[s][k];
                d2[g][s][k] = q * q;
                if (k == 0) q0 = q;
            }
            gaussian_table(d2[g][s], count[s], q0, a >= 0 ? jb->spacing[a] : 0.0, inv2w2, ex[g][s]);
        }
    }
    /* hybrid: squared distances of the nodes to the two ends, per slot */
    double *endA[3] = {NULL, NULL, NULL}, *endB[3] = {NULL, NULL, NULL};
    if (hybrid) {
        double *p = buf + (size_t)G * per_point;
        for (int s = 0; s < 3; ++s) {
            endA[s] = p;
            endB[s] = p + count[s];
            p += 2 * count[s];
            for (cg_index k = 0; k < count[s]; ++k) {
                const double qa = cslot[s][k], qb = cslot[s][k] - es[s];
                endA[s][k] = qa * qa;
                endB[s][k] = qb * qb;
            }
        }
    }
    const double R2_margin = R2 * (1.0 + 1e-12); /* the erf form decides near the sphere itself */
    const int nv = jb->n_values;
    const double *values = jb->mode == MODE_VALUE ? jb->values + obj * nv : NULL;
    const double e2d[3] = {es[0], es[1], 0.0};
    const double L2_2d = es[0] * es[0] + es[1] * es[1];
    const double inv_L2_2d = L2_2d > 0.0 ? 1.0 / L2_2d : 0.0, inv_L2 = L2 > 0.0 ? 1.0 / L2 : 0.0;
    for (cg_index i = 0; i < n0; ++i) {
        for (cg_index j = 0; j < n1; ++j) {
            if (hybrid) {
                /* rows whose line misses the capsule carry nothing */
                const double q2d[3] = {cslot[0][i], cslot[1][j], 0.0};
                if (!(segment_distance2(q2d, e2d, inv_L2_2d) < R2_margin)) continue;
            }
            cg_index k0 = n2, k1 = 0; /* the range of the row that receives anything */
            for (cg_index k = 0; k < n2; ++k) row[k] = 0.0;
            if (!hybrid) {
                for (int g = 0; g < G; ++g) {
                    const double s01 = d2[g][0][i] + d2[g][1][j];
                    if (!(s01 < R2)) continue;
                    /* the same cutoff test as the node-by-node path, as a mask the
                       compiler vectorises (cheaper than finding the range) */
                    const double *dz = d2[g][2], *gz = ex[g][2];
                    const double c = gw[g] * ex[g][0][i] * ex[g][1][j];
                    for (cg_index k = 0; k < n2; ++k) row[k] += (s01 + dz[k] < R2) ? c * gz[k] : 0.0;
                    k0 = 0;
                    k1 = n2;
                }
            } else {
                /* the rule is exact where both ends, hence the whole segment, lie
                   inside the ball; elsewhere the part inside the ball is integrated */
                const double a01 = endA[0][i] + endA[1][j], b01 = endB[0][i] + endB[1][j];
                int any_inside = 0;
                for (cg_index k = 0; k < n2; ++k) {
                    inside[k] = (a01 + endA[2][k] < R2 && b01 + endB[2][k] < R2) ? 1.0 : 0.0;
                    any_inside |= inside[k] != 0.0;
                }
                if (any_inside) {
                    for (int g = 0; g < G; ++g) {
                        const double c = gw[g] * ex[g][0][i] * ex[g][1][j];
                        const double *gz = ex[g][2];
                        for (cg_index k = 0; k < n2; ++k) row[k] += inside[k] * (c * gz[k]);
                    }
                }
                for (cg_index k = 0; k < n2; ++k) {
                    if (inside[k] != 0.0) continue; /* the rule is exact here */
                    const double q3[3] = {cslot[0][i], cslot[1][j], cslot[2][k]};
                    row[k] = scale * kn->prefactor * cut_segment_value(q3, es, L2, inv_L2, R2, w, inv2w2);
                }
                k0 = 0;
                k1 = n2;
            }
            while (k0 < k1 && row[k0] == 0.0) ++k0;
            while (k1 > k0 && row[k1 - 1] == 0.0) --k1;
            if (k0 >= k1) continue;
            const cg_index base = (first[0] + i) * stride[0] + (first[1] + j) * stride[1] + (first[2] + k0) * stride[2];
            if (jb->mode == MODE_VALUE) {
                row_add(out + base * jb->out_width, row + k0, k1 - k0, values, nv);
            } else {
                for (cg_index k = k0; k < k1; ++k)
                    if (row[k] != 0.0) cg_accumulate(jb, out, obj, base + (k - k0), row[k], NULL);
            }
        }
    }
    return 1;
}
