/*
 * cg_gradient_rows.c -- kernel gradients of point objects on grids, visiting
 * only the rows of nodes the support ball reaches.
 *
 * The node-by-node path visits every node of an object's stencil box, (2R/h)^D
 * of them, and evaluates the gradient at each; the ball holds about half of
 * them in 3D (pi/6), fewer with the slack of whole nodes. Here each row of the
 * box along the last resolved axis is narrowed to the nodes within the ball
 * (rho^2 < R^2 with a margin, widened by a node each way, as cg_lucy.c does
 * for point values), and each node's gradient is cg_kernel_gradient's, at the
 * same offsets, accumulated the same way: bit for bit the node-by-node sums.
 * The full-dimensional Lucy and Gaussian kernels have their gradient factor
 * (grad = factor q) computed for a batch of nodes (several rows: a small
 * ball's rows have a few nodes each) in a loop the compiler vectorises, with
 * cg_kernel_gradient's arithmetic, and in 3-D four values' 12 terms added as
 * three vectors; marginals call cg_kernel_gradient node by node.
 */
#include "cg.h"
#include "cg_internal.h"

#include <math.h>
#include <string.h>

typedef double v4 __attribute__((vector_size(32)));

/* nodes per batch (of several rows) */
#define GRADIENT_BATCH 64

/* cg_visit_gradient_points for AVX2 too (as cg_lucy.c's visit): ball_row's floor and ceil are one instruction
   there (SSE2 has none: about a tenth of the call on W1) and the factors' roots and divisions 4 wide; scalar
   arithmetic without FMA contraction (ISO C), so the same bits on both */
#if defined(__GNUC__) && !defined(__clang__) && defined(__has_attribute)
#if __has_attribute(target_clones) && defined(__x86_64__) && !defined(CGBOUND_NO_CLONES)
#define GRADIENT_CLONES __attribute__((target_clones("avx2", "default")))
#define GRADIENT_INLINE static inline __attribute__((always_inline))
#endif
#endif
#ifndef GRADIENT_CLONES
#define GRADIENT_CLONES
#define GRADIENT_INLINE static
#endif

/* grad W = factor(rho^2) q for the full-dimensional kernels, as cg_kernel_gradient
   computes it; 0 outside the support, where that adds nothing either */
GRADIENT_INLINE void batch_factors(const cg_kernel *k, int count, const double *rho2, double *factor)
{
    const double R = k->radius, R2 = R * R, C = k->prefactor;
    if (k->type == CG_KERNEL_LUCY) {
        for (int i = 0; i < count; ++i) {
            const double om = 1.0 - sqrt(rho2[i]) / R;
            factor[i] = rho2[i] < R2 ? -12.0 * C * om * om / R2 : 0.0;
        }
    } else {
        const double w2 = k->width * k->width;
        for (int i = 0; i < count; ++i) factor[i] = rho2[i] < R2 ? -(C * exp(-0.5 * rho2[i] / w2)) / w2 : 0.0;
    }
}

/* a batch of nodes (their offsets q per resolved axis, rho^2 and node index): out[node] += grad (x) values of
   obj, grad = factor q */
GRADIENT_INLINE void batch_add(const job *jb, double *out, cg_index obj, int count, double (*q)[GRADIENT_BATCH],
                               const double *rho2, const cg_index *node)
{
    const int nv = jb->n_values, nr = jb->target->n_resolved;
    const double *v = jb->values + obj * nv;
    double factor[GRADIENT_BATCH];
    batch_factors(jb->kernel, count, rho2, factor);
    for (int i = 0; i < count; ++i) {
        if (factor[i] == 0.0) continue;
        double grad[3];
        for (int a = 0; a < nr; ++a) grad[a] = factor[i] * q[a][i];
        double *o = out + node[i] * jb->out_width;
        int kv = 0;
        if (nr == 3) {
            /* four values' 12 terms as three vectors of 4 (element by element: the same products and sums) */
            const v4 g = {grad[0], grad[1], grad[2], 0.0};
            const v4 ga = __builtin_shufflevector(g, g, 0, 1, 2, 0), gb = __builtin_shufflevector(g, g, 1, 2, 0, 1),
                     gc = __builtin_shufflevector(g, g, 2, 0, 1, 2);
            for (; kv + 4 <= nv; kv += 4) {
                const double *w = v + kv;
                const v4 va = {w[0], w[0], w[0], w[1]}, vb = {w[1], w[1], w[2], w[2]}, vc = {w[2], w[3], w[3], w[3]};
                v4 oa, ob, oc;
                double *p = o + 3 * kv;
                memcpy(&oa, p, sizeof oa);
                memcpy(&ob, p + 4, sizeof ob);
                memcpy(&oc, p + 8, sizeof oc);
                oa += ga * va;
                ob += gb * vb;
                oc += gc * vc;
                memcpy(p, &oa, sizeof oa);
                memcpy(p + 4, &ob, sizeof ob);
                memcpy(p + 8, &oc, sizeof oc);
            }
        }
        for (; kv < nv; ++kv) /* (the values left) */
            for (int d = 0; d < nr; ++d) o[kv * nr + d] += grad[d] * v[kv];
    }
}

GRADIENT_CLONES int cg_visit_gradient_points(const job *jb, double *out, cg_index obj, const double *x)
{
    const cg_target *t = jb->target;
    const int nr = t->n_resolved;
    const double R = jb->kernel->radius;
    cg_index first[3], last[3], stride[3];
    if (!ball_stencil(jb, x, R, first, last, stride)) return 1;
    const int row = nr - 1;
    const double *zc = t->coords[row];
    const double xr = x[row];
    const double bound = R * R * (1.0 + 1e-6);
    double q[3] = {0.0, 0.0, 0.0}, grad[3] = {0.0, 0.0, 0.0};
    /* the batch: the nodes of several rows (a small ball's rows have a few nodes each) */
    double bq[3][GRADIENT_BATCH], rho2[GRADIENT_BATCH];
    cg_index node[GRADIENT_BATCH];
    int count = 0;
    const cg_kernel *kern = jb->kernel;
    const int batched = cg_kernel_marginal_axes(kern) == 0 &&
                        (kern->type == CG_KERNEL_LUCY || kern->type == CG_KERNEL_GAUSSIAN);
    cg_index idx[3] = {first[0], first[1], first[2]};
    for (;;) {
        cg_index base = 0;
        double p2 = 0.0;
        for (int a = 0; a < row; ++a) {
            q[a] = t->coords[a][idx[a]] - x[a];
            p2 += q[a] * q[a];
            base += idx[a] * stride[a];
        }
        cg_index k0, k1;
        ball_row(jb, row, xr, bound, p2, first[row], last[row], &k0, &k1);
        if (batched) {
            for (cg_index k = k0; k <= k1; ++k) {
                if (count == GRADIENT_BATCH) {
                    batch_add(jb, out, obj, count, bq, rho2, node);
                    count = 0;
                }
                /* the node-by-node sum over the axes in order: (q0^2 + q1^2) + q2^2 */
                const double qr = zc[k] - xr;
                for (int a = 0; a < row; ++a) bq[a][count] = q[a];
                bq[row][count] = qr;
                rho2[count] = p2 + qr * qr;
                node[count++] = base + k;
            }
        } else {
            for (cg_index k = k0; k <= k1; ++k) {
                q[row] = zc[k] - xr;
                const double w = cg_kernel_gradient(jb->kernel, q, grad);
                /* as node by node: a node takes the object where the value or the gradient is non-zero */
                int nz = w != 0.0;
                for (int a = 0; a < nr; ++a) nz |= grad[a] != 0.0;
                if (nz) cg_accumulate(jb, out, obj, base + k, w, grad);
            }
        }
        if (!stencil_next(idx, first, last, row)) break;
    }
    if (count) batch_add(jb, out, obj, count, bq, rho2, node);
    return 1;
}
