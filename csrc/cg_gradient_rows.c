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
 * (grad = factor q) computed a row at a time in a loop the compiler
 * vectorises, with cg_kernel_gradient's arithmetic; marginals call it.
 */
#include "cg.h"
#include "cg_internal.h"

#include <math.h>

/* nodes per chunk of a row */
#define ROW_CHUNK 64

/* grad W = factor(rho^2) q for the full-dimensional kernels, as cg_kernel_gradient
   computes it; 0 outside the support, where that adds nothing either */
static void row_factors(const cg_kernel *k, int count, const double *rho2, double *factor)
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

/* out[node] += grad (x) values of obj for a chunk of one row (the last axis varies) */
static void row_add(const job *jb, double *out, cg_index obj, int count, const double *q, const double *qrow,
                    const double *factor, cg_index node0)
{
    const int nv = jb->n_values, nr = jb->target->n_resolved, row = nr - 1;
    const double *v = jb->values + obj * nv;
    double grad[3];
    for (int i = 0; i < count; ++i) {
        if (factor[i] == 0.0) continue;
        for (int a = 0; a < row; ++a) grad[a] = factor[i] * q[a];
        grad[row] = factor[i] * qrow[i];
        double *o = out + (node0 + i) * jb->out_width;
        for (int kv = 0; kv < nv; ++kv)
            for (int d = 0; d < nr; ++d) o[kv * nr + d] += grad[d] * v[kv];
    }
}

int cg_visit_gradient_points(const job *jb, double *out, cg_index obj, const double *x)
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
    double qrow[ROW_CHUNK], rho2[ROW_CHUNK], factor[ROW_CHUNK];
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
            for (cg_index k = k0; k <= k1; k += ROW_CHUNK) {
                const int count = (int)(k1 - k + 1 < ROW_CHUNK ? k1 - k + 1 : ROW_CHUNK);
                for (int i = 0; i < count; ++i) {
                    /* the node-by-node sum over the axes in order: (q0^2 + q1^2) + q2^2 */
                    qrow[i] = zc[k + i] - xr;
                    rho2[i] = p2 + qrow[i] * qrow[i];
                }
                row_factors(jb->kernel, count, rho2, factor);
                row_add(jb, out, obj, count, q, qrow, factor, base + k);
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
    return 1;
}
