/*
 * cg_scatter.c -- accumulate kernel-weighted quantities of points and
 * segments onto evaluation nodes. One loop serves every field: for each
 * object, each periodic image that reaches the target, each node of its
 * stencil, a weight (or gradient) is computed and handed to accumulate().
 *
 * Threads: on grids long enough along the first resolved axis (and not
 * periodic along it), the objects are cut into slabs whose writes do not
 * overlap those of the slabs three further on; the slabs of one colour
 * (s mod 3) run in parallel straight into the output, so the result is the
 * same bit for bit for any thread count. Otherwise objects are split into
 * contiguous blocks, one per thread; each thread accumulates into its own
 * buffer and the buffers are added in thread order, so a run is
 * deterministic for a given thread count.
 */
#include "cg.h"
#include "cg_internal.h"

#include <math.h>
#if defined(__unix__)
#include <sched.h>
#endif
#include <stdlib.h>
#include <string.h>

#ifdef _OPENMP
#include <omp.h>
#endif

cg_index cg_target_size(const cg_target *t)
{
    if (!t->is_grid) return t->n_points;
    cg_index size = 1;
    for (int a = 0; a < t->n_resolved; ++a) size *= t->shape[a];
    return size;
}

void cg_fill_zero(double *out, cg_index n, int n_threads)
{
#ifdef _OPENMP
    /* below 1 MB one thread (the region costs more than it saves) */
    int nt = n_threads > 0 ? n_threads : omp_get_max_threads();
    if (n < (cg_index)1 << 17) nt = 1;
#pragma omp parallel num_threads(nt) if (nt > 1)
    {
        const cg_index t = omp_get_thread_num(), T = omp_get_num_threads();
        const cg_index lo = n * t / T, hi = n * (t + 1) / T;
        memset(out + lo, 0, (size_t)(hi - lo) * sizeof *out);
    }
#else
    (void)n_threads;
    memset(out, 0, (size_t)n * sizeof *out);
#endif
}

void cg_minimum_image(cg_index n, int dim, double *vecs, const int *periodic, const double *period)
{
    for (int d = 0; d < dim; ++d) {
        if (!periodic[d]) continue;
        const double L = period[d];
        for (cg_index i = 0; i < n; ++i) {
            double *x = vecs + i * dim + d;
            if (fabs(*x) > 0.5 * L) *x -= L * nearbyint(*x / L);
        }
    }
}

cg_status cg_wrap(cg_index n, int dim, double *positions, const int *periodic, const double *lower,
                  const double *upper)
{
    for (int d = 0; d < dim; ++d) {
        if (!periodic[d]) continue;
        const double lo = lower[d], hi = upper[d], L = hi - lo;
        if (!(L > 0.0 && isfinite(L))) return CG_ERR_ARGUMENT;
        for (cg_index i = 0; i < n; ++i) {
            double *x = positions + i * dim + d;
            if (*x >= lo && *x < hi) continue; /* inside: left exactly as it is */
            /* NumPy's mod: fmod is exact; a negative remainder moves up by L
               (and may round to L itself); a zero remainder is +0 */
            double m = fmod(*x - lo, L);
            if (m < 0.0) m += L;
            else if (m == 0.0) m = 0.0;
            const double w = lo + m;
            if (isinf(m) || isnan(m)) return CG_ERR_ARGUMENT; /* x - lo overflowed (or x was not finite) */
            *x = w >= hi ? lo : w; /* lo + m rounded up to hi: that is lo again */
        }
    }
    return CG_OK;
}

/* ------------------------------------------------------------------ */

/* how often (in visited nodes or images) the interrupt flag is polled
   inside one object: a single object with a huge support can take seconds */
#define POLL_EVERY 4096

/* more images than this along one axis means a ray (nearly) parallel to a
   periodic axis: treated as divergent rather than looping for ever */
#define MAX_IMAGES 1e6

static int interrupted(const job *jb)
{
    return jb->target->interrupt != NULL && *jb->target->interrupt != 0;
}

/* weight of one object (already shifted to an image) at a node offset q;
   scale multiplies a segment's line integral (rays cut to finite length) */
static double object_weight(const job *jb, const double *q, const double *e, double scale, double *grad)
{
    const int want = jb->mode == MODE_GRADIENT;
    if (jb->moment) return cg_kernel_line_moment_rule(jb->kernel, q, e, want ? grad : NULL, jb->line_points);
    if (jb->is_segment) {
        const double psi = cg_kernel_line_rule(jb->kernel, q, e, want ? grad : NULL, jb->ray ? 0 : jb->line_points);
        if (want && scale != 1.0)
            for (int d = 0; d < jb->target->n_resolved; ++d) grad[d] *= scale;
        return psi * scale;
    }
    if (want) return cg_kernel_gradient(jb->kernel, q, grad);
    double rho2 = 0.0;
    for (int d = 0; d < jb->target->n_resolved; ++d) rho2 += q[d] * q[d];
    return cg_kernel_value(jb->kernel, rho2);
}

#if defined(__GNUC__)
#define ALWAYS_INLINE static inline __attribute__((always_inline))
#else
#define ALWAYS_INLINE static inline
#endif

/* The box [bmin, bmax] of the object's support along the resolved axes; 0
   when it misses the target's nodes. fmin and fmax as comparisons (not
   calls): they differ only where one side is NaN, and end is NaN where x is. */
ALWAYS_INLINE int object_box(const job *jb, const double *x, const double *e, int nr, double *bmin, double *bmax)
{
    const double R = jb->kernel->radius;
    for (int a = 0; a < nr; ++a) {
        const double end = x[a] + e[a];
        bmin[a] = (end < x[a] ? end : x[a]) - R;
        bmax[a] = (end > x[a] ? end : x[a]) + R;
        if (bmax[a] < jb->lo[a] || bmin[a] > jb->hi[a]) return 0;
    }
    return 1;
}

/* visit_nodes for a point target (nr resolved axes, a constant where inlined
   with one): with the points sorted by their first coordinate, only those
   with it inside [bmin, bmax] (the first found from a table of cells, else
   by bisection); each point still receives its terms in object order, so
   the sums are the same */
ALWAYS_INLINE cg_status visit_points(const job *jb, double *out, cg_index obj, const double *x, const double *e,
                                     double scale, cg_index *count, int nr)
{
    const cg_target *t = jb->target;
    double q[3], grad[3] = {0.0, 0.0, 0.0};
    double bmin[3], bmax[3];
    if (!object_box(jb, x, e, nr, bmin, bmax)) return CG_OK;
    cg_index k = 0, k_end = t->n_points;
    if (jb->point_cell) {
        /* the first point with !(c < bmin[0]): from its cell's first point,
           a step or two up. Never down: c >= bmin gives (c - lo) * inv >=
           (bmin - lo) * inv (rounding is monotonic), so a point at or above
           bmin is at or above its cell's start; a NaN bmin starts at cell 0,
           point 0, as bisection ends */
        const double *c = jb->point_first, j = (bmin[0] - jb->point_cell_lo) * jb->point_cell_inv;
        k = jb->point_cell[j > 0.0 ? (j < (double)k_end ? (cg_index)j : k_end) : 0];
        while (k < k_end && c[k] < bmin[0]) ++k;
    } else if (jb->point_order) {
        /* the first point with !(c < bmin[0]), without branches */
        const double *c = jb->point_first;
        cg_index base = 0, left = t->n_points;
        while (left > 1) {
            const cg_index half = left / 2;
            base = c[base + half] < bmin[0] ? base + half : base;
            left -= half;
        }
        k = base + (c[base] < bmin[0]);
    }
    for (; k < k_end; ++k) {
        if (jb->point_order && jb->point_first[k] > bmax[0]) break;
        const cg_index p = jb->point_order ? jb->point_order[k] : k;
        if (++*count % POLL_EVERY == 0 && interrupted(jb)) return CG_ERR_INTERRUPTED;
        const double *pt = t->points + p * nr;
        int inside = 1;
        for (int a = 0; a < nr; ++a) {
            if (pt[a] < bmin[a] || pt[a] > bmax[a]) { inside = 0; break; }
            q[a] = pt[a] - x[a];
        }
        if (!inside) continue;
        const double w = object_weight(jb, q, e, scale, grad);
        if (w != 0.0 || jb->mode == MODE_GRADIENT) cg_accumulate(jb, out, obj, p, w, grad);
    }
    return CG_OK;
}

/* Visit every node within the support of the object [x, x + e] (resolved
   coordinates, one image). *count counts visited nodes for polling the
   interrupt flag; returns CG_ERR_INTERRUPTED (out then partial) or CG_OK. */
static cg_status visit_nodes(const job *jb, double *out, scratch *sc, cg_index obj, const double *x,
                             const double *e, double scale, cg_index *count)
{
    if (jb->separable) {
        /* the outer-product path; 0: not for this object, -1: no scratch memory */
        const int done = cg_visit_separable(jb, out, sc, obj, x, e, scale);
        if (done < 0) return CG_ERR_NOMEM;
        if (done > 0) return (++*count % POLL_EVERY == 0 && interrupted(jb)) ? CG_ERR_INTERRUPTED : CG_OK;
    }
    if (jb->profile_rows && cg_visit_profile(jb, out, obj, x, e, scale))
        return (++*count % POLL_EVERY == 0 && interrupted(jb)) ? CG_ERR_INTERRUPTED : CG_OK;
    if (jb->ball_rows && cg_visit_ball_points(jb, out, obj, x))
        return (++*count % POLL_EVERY == 0 && interrupted(jb)) ? CG_ERR_INTERRUPTED : CG_OK;
    if (jb->gradient_rows && cg_visit_gradient_points(jb, out, obj, x))
        return (++*count % POLL_EVERY == 0 && interrupted(jb)) ? CG_ERR_INTERRUPTED : CG_OK;
    if (jb->lucy_rows && cg_visit_lucy(jb, out, sc, obj, x, e, scale))
        return (++*count % POLL_EVERY == 0 && interrupted(jb)) ? CG_ERR_INTERRUPTED : CG_OK;
    const cg_target *t = jb->target;
    const int nr = t->n_resolved;
    /* point targets: written out for three resolved axes, the common case */
    if (!t->is_grid) return nr == 3 ? visit_points(jb, out, obj, x, e, scale, count, 3)
                                    : visit_points(jb, out, obj, x, e, scale, count, nr);
    double q[3], grad[3] = {0.0, 0.0, 0.0};
    double bmin[3], bmax[3];
    if (!object_box(jb, x, e, nr, bmin, bmax)) return CG_OK;
    /* grid: index range of the stencil along each resolved axis */
    cg_index first[3], last[3], stride[3];
    if (!stencil_range(jb, bmin, bmax, first, last, stride)) return CG_OK;
    cg_index idx[3] = {first[0], first[1], first[2]};
    for (;;) {
        if (++*count % POLL_EVERY == 0 && interrupted(jb)) return CG_ERR_INTERRUPTED;
        cg_index node = 0;
        for (int a = 0; a < nr; ++a) {
            q[a] = t->coords[a][idx[a]] - x[a];
            node += idx[a] * stride[a];
        }
        const double w = object_weight(jb, q, e, scale, grad);
        if (w != 0.0) cg_accumulate(jb, out, obj, node, w, grad);
        else if (jb->mode == MODE_GRADIENT) {
            int nz = 0;
            for (int a = 0; a < nr; ++a) nz |= grad[a] != 0.0;
            if (nz) cg_accumulate(jb, out, obj, node, w, grad);
        }
        if (!stencil_next(idx, first, last, nr)) break;
    }
    return CG_OK;
}

/* For a ray, the parameter beyond which it cannot reach any node: the first
   exit from [lo - R, hi + R] along a non-periodic resolved axis. Returns 0 for
   an object that never contributes, -1 if the ray never leaves. */
static int ray_length(const job *jb, const double *x, const double *e, double *s_max)
{
    const cg_target *t = jb->target;
    const double R = jb->kernel->radius;
    double smax = INFINITY;
    for (int a = 0; a < t->n_resolved; ++a) {
        if (t->periodic[a] || e[a] == 0.0) continue;
        const double bound = e[a] > 0.0 ? jb->hi[a] + R : jb->lo[a] - R;
        const double s = (bound - x[a]) / e[a];
        if (s < smax) smax = s;
    }
    if (!isfinite(smax)) return -1;
    if (!(smax > 0.0)) return 0;
    *s_max = smax;
    return 1;
}

/* One object: resolve its coordinates, turn a ray into a finite segment, and
   visit all periodic images that can reach the target. With values formed
   per object, they are the thread's row 0 (visit_range formed them). */
static cg_status scatter_object(const job *jb, double *out, scratch *sc, cg_index obj)
{
    const cg_index row = cg_forms_values(jb) ? 0 : obj;
    const cg_target *t = jb->target;
    const int nr = t->n_resolved, D = t->dim;
    const double R = jb->kernel->radius;
    double x[3] = {0.0, 0.0, 0.0}, e[3] = {0.0, 0.0, 0.0}, scale = 1.0;
    for (int a = 0; a < nr; ++a) {
        x[a] = jb->positions[obj * D + t->axes[a]];
        if (jb->is_segment) e[a] = cg_vec_of(jb, obj, t->axes[a]);
    }
    if (nr == 0) {
        /* the kernel is constant: every node (one for a grid, all of a
           point set) receives the same weight */
        const double dummy[3] = {0.0, 0.0, 0.0};
        const cg_index P = cg_target_size(t);
        for (cg_index p = 0; p < P; ++p) cg_accumulate(jb, out, row, p, jb->kernel->prefactor, dummy);
        return CG_OK;
    }
    if (jb->is_segment && jb->ray) {
        double s_max;
        const int r = ray_length(jb, x, e, &s_max);
        if (r < 0) return CG_ERR_DIVERGENT;
        if (r == 0) return CG_OK;
        /* int_0^smax M(q - s e) ds = smax * int_0^1 M(q - s' (smax e)) ds' */
        for (int a = 0; a < nr; ++a) e[a] *= s_max;
        scale = s_max;
    }
    if (!jb->any_periodic) { /* one image: the object itself */
        cg_index count = 0;
        if (!t->is_grid) return nr == 3 ? visit_points(jb, out, row, x, e, scale, &count, 3)
                                        : visit_points(jb, out, row, x, e, scale, &count, nr);
        return visit_nodes(jb, out, sc, row, x, e, scale, &count);
    }
    /* periodic images: first bring the start next to the target, so that
       image indices stay small whatever the input coordinates */
    cg_index kmin[3] = {0, 0, 0}, kmax[3] = {0, 0, 0};
    for (int a = 0; a < nr; ++a) {
        if (!t->periodic[a]) continue;
        const double L = t->period[a];
        x[a] -= L * floor((x[a] - jb->lo[a]) / L);
        const double omin = fmin(x[a], x[a] + e[a]), omax = fmax(x[a], x[a] + e[a]);
        const double first = ceil((jb->lo[a] - omax - R) / L), last = floor((jb->hi[a] - omin + R) / L);
        if (last - first > MAX_IMAGES) return CG_ERR_DIVERGENT; /* a ray almost parallel to a periodic axis */
        kmin[a] = (cg_index)first;
        kmax[a] = (cg_index)last;
        if (kmin[a] > kmax[a]) return CG_OK;
    }
    cg_index count = 0;
    cg_index k[3] = {kmin[0], kmin[1], kmin[2]};
    for (;;) {
        double xs[3];
        for (int a = 0; a < nr; ++a) xs[a] = t->periodic[a] ? x[a] + (double)k[a] * t->period[a] : x[a];
        /* an image counts as a visit: up to MAX_IMAGES of them may miss the target */
        if (++count % POLL_EVERY == 0 && interrupted(jb)) return CG_ERR_INTERRUPTED;
        const cg_status st = visit_nodes(jb, out, sc, row, xs, e, scale, &count);
        if (st != CG_OK) return st;
        int a = nr - 1;
        while (a >= 0) {
            if (t->periodic[a] && ++k[a] <= kmax[a]) break;
            k[a] = kmin[a];
            --a;
        }
        if (a < 0) break;
    }
    return CG_OK;
}

/* the longest stencil (nodes) for which a profile's Gaussian points go by blocks, and its segments */
#define PROFILE_GAUSS_MAX_NODES 16.0
#define PROFILE_GAUSS_SEGMENT_MAX_NODES 40.0

static cg_status prepare(job *jb)
{
    const cg_target *t = jb->target;
    if (t->dim != jb->kernel->dim || t->n_resolved != jb->kernel->n_resolved) return CG_ERR_ARGUMENT;
    if (t->n_resolved < 0 || t->n_resolved > t->dim) return CG_ERR_ARGUMENT;
    for (int a = 0; a < t->n_resolved; ++a) {
        if (t->periodic[a] && !(t->period[a] > 0.0)) return CG_ERR_ARGUMENT;
        if (t->is_grid) {
            const cg_index n = t->shape[a];
            if (n < 1) return CG_ERR_ARGUMENT;
            jb->lo[a] = t->coords[a][0];
            jb->hi[a] = t->coords[a][n - 1];
            jb->spacing[a] = n > 1 ? (jb->hi[a] - jb->lo[a]) / (double)(n - 1) : 0.0;
        } else {
            double lo = INFINITY, hi = -INFINITY;
            for (cg_index p = 0; p < t->n_points; ++p) {
                const double v = t->points[p * t->n_resolved + a];
                if (v < lo) lo = v;
                if (v > hi) hi = v;
            }
            jb->lo[a] = lo;
            jb->hi[a] = hi;
        }
    }
    for (int a = 0; a < t->n_resolved; ++a) jb->any_periodic |= t->periodic[a] != 0;
    const cg_kernel *k = jb->kernel;
    if (jb->mode == MODE_GRADIENT) {
        /* averaged axes: the Gaussian's marginals, and Lucy's for points (cg_gradient.c) */
        if (k->type != CG_KERNEL_GAUSSIAN && cg_kernel_marginal_axes(k) != 0 &&
            !(k->type == CG_KERNEL_LUCY && !jb->is_segment)) return CG_ERR_UNSUPPORTED;
        if (k->mercurycg_line && jb->is_segment) return CG_ERR_UNSUPPORTED;
    }
    if (k->line_points < 0 || k->line_points > CG_MAX_LINE_POINTS) return CG_ERR_ARGUMENT;
    jb->line_points = k->type != CG_KERNEL_GAUSSIAN ? 0 : k->mercurycg_line ? CG_LINE_MERCURYCG : k->line_points;
    jb->separable = k->type == CG_KERNEL_GAUSSIAN && !k->per_node && t->is_grid && t->n_resolved > 0 &&
                    jb->mode != MODE_GRADIENT && !(k->mercurycg_line && jb->is_segment);
    jb->lucy_rows = (k->type == CG_KERNEL_LUCY || k->type == CG_KERNEL_HEAVISIDE) && !k->per_node && t->is_grid &&
                    t->n_resolved > 0 &&
                    cg_kernel_marginal_axes(k) == 0 && jb->is_segment && jb->mode == MODE_VALUE;
    jb->wide = (jb->separable || jb->lucy_rows) && cg_separable_wide_available();
    if (t->is_grid) {
        double cell = 1.0;
        jb->lucy_box = t->n_resolved >= 2;
        for (int a = t->n_resolved - 1; a >= 0; --a) {
            const double h = jb->spacing[a];
            jb->inv_spacing[a] = h > 0.0 ? 1.0 / h : 0.0;
            jb->coord_extent[a] = fabs(t->coords[a][0]) + fabs(t->coords[a][t->shape[a] - 1]);
            jb->grid_stride[a] = a == t->n_resolved - 1 ? 1 : jb->grid_stride[a + 1] * t->shape[a + 1];
            jb->lucy_box &= h > 0.0;
            cell *= h;
        }
        jb->inv_cell = cell > 0.0 ? 1.0 / cell : 0.0;
    }
    jb->ball_rows = (k->type == CG_KERNEL_LUCY || k->type == CG_KERNEL_HEAVISIDE) && !k->per_node && t->is_grid &&
                    t->n_resolved > 0 && !jb->is_segment && jb->mode != MODE_GRADIENT;
    if (jb->ball_rows) jb->wide = cg_separable_wide_available();
    jb->gradient_rows = !k->per_node && t->is_grid && t->n_resolved > 0 && !jb->is_segment &&
                        jb->mode == MODE_GRADIENT;
    /* a profile: one resolved axis, the polynomial marginal over the two others (cg_profile.c) */
    jb->profile_rows = (k->type == CG_KERNEL_LUCY || k->type == CG_KERNEL_HEAVISIDE) && !k->per_node && t->is_grid &&
                       t->n_resolved == 1 && cg_kernel_marginal_axes(k) == 2 &&
                       (jb->mode == MODE_VALUE ||
                        (jb->mode == MODE_GRADIENT && k->type == CG_KERNEL_LUCY && !jb->is_segment));
    if (jb->profile_rows) jb->wide = cg_separable_wide_available();
    /* the Gaussian's points on a profile: blocks of objects (cg_profile.c), not the separable
       path's per-object tables, where stencils are short: the blocks save ~65 ns per object but
       add ~4 ns per node against the separable path's contiguous rows (AVX-512, W2); segments
       likewise with the exact line integral (not rays: their length is cut per object), up to
       longer stencils: the blocks save ~2100 instructions per segment and add ~14 per node
       (AVX2); W2's contact stress on a Z profile of 200 nodes (27 a stencil) 1.3 times as fast,
       of 400 (54) as fast (AVX-512) */
    jb->profile_gauss = jb->separable && t->n_resolved == 1 && jb->mode == MODE_VALUE &&
                        (!jb->is_segment || (!jb->ray && jb->line_points == 0)) &&
                        2.0 * k->radius * jb->inv_spacing[0] + 1.0 <=
                            (jb->is_segment ? PROFILE_GAUSS_SEGMENT_MAX_NODES : PROFILE_GAUSS_MAX_NODES);
    if (jb->moment) {
        /* the first moment (cg_moment.c): node by node */
        if (k->type != CG_KERNEL_GAUSSIAN && cg_kernel_marginal_axes(k) != 0 && jb->mode == MODE_GRADIENT)
            return CG_ERR_UNSUPPORTED;   /* Lucy's and Heaviside's marginals: values only */
        if (k->mercurycg_line || (k->type == CG_KERNEL_HEAVISIDE && jb->mode == MODE_GRADIENT))
            return CG_ERR_UNSUPPORTED;
        jb->separable = jb->wide = jb->lucy_rows = jb->ball_rows = jb->gradient_rows = jb->profile_rows =
            jb->profile_gauss = 0;
    }
    return CG_OK;
}

/* Rays of a block are checked before any work so that an error leaves out untouched. */
static cg_status check_rays(const job *jb)
{
    if (!(jb->is_segment && jb->ray)) return CG_OK;
    const cg_target *t = jb->target;
    const int nr = t->n_resolved, D = t->dim;
    if (nr == 0) return jb->n > 0 ? CG_ERR_DIVERGENT : CG_OK;
    for (cg_index o = 0; o < jb->n; ++o) {
        double x[3], e[3], s;
        for (int a = 0; a < nr; ++a) {
            x[a] = jb->positions[o * D + t->axes[a]];
            e[a] = cg_vec_of(jb, o, t->axes[a]);
        }
        if (ray_length(jb, x, e, &s) < 0) return CG_ERR_DIVERGENT;
    }
    return CG_OK;
}

/* the first error of any thread; read and written atomically so that every
   thread sees it and stops at its next object */
static int load_status(const int *status)
{
    int v;
#ifdef _OPENMP
#pragma omp atomic read
#endif
    v = *status;
    return v;
}

static void store_status(int *status, int v)
{
#ifdef _OPENMP
#pragma omp atomic write
#endif
    *status = v;
    (void)v; /* gcc 12 warns "set but not used" for a parameter only used under omp atomic */
}

#ifdef _OPENMP
/* below this many estimated node visits in all, one thread does the work */
#define MIN_WORK_PER_THREAD 2e5

/* nodes in one object's stencil, roughly (for choosing the thread count) */
static double stencil_estimate(const job *jb)
{
    const cg_target *t = jb->target;
    double nodes = 1.0;
    for (int a = 0; a < t->n_resolved; ++a) {
        double n = t->is_grid ? (double)t->shape[a] : (double)t->n_points;
        if (t->is_grid && jb->spacing[a] > 0.0) n = fmin(n, 2.0 * jb->kernel->radius / jb->spacing[a] + 1.0);
        nodes *= n;
        if (!t->is_grid) break; /* a point target is scanned once per object */
    }
    return jb->is_segment ? 2.0 * nodes : nodes;
}
#endif

/* how many objects ahead the input of sorted objects is prefetched */
#define PREFETCH_AHEAD 8

/* objects fewer than this are visited in input order */
#define MIN_OBJECTS_TO_SORT 4096

/* object o's bucket of spatial_order: its nearest node (row-major index) among P, in `buckets` */
static cg_index bucket_of(const job *jb, cg_index o, cg_index buckets, cg_index P)
{
    const cg_target *t = jb->target;
    const int D = t->dim;
    cg_index node = 0;
    for (int a = 0; a < t->n_resolved; ++a) {
        const double x = jb->positions[o * D + t->axes[a]];
        const cg_index m = t->shape[a];
        double k = jb->spacing[a] > 0.0 ? (x - jb->lo[a]) / jb->spacing[a] + 0.5 : 0.0;
        k = k < 0.0 ? 0.0 : (k > (double)(m - 1) ? (double)(m - 1) : k); /* also maps NaN-free far images */
        node = node * m + (cg_index)k;
    }
    const cg_index b = (cg_index)((double)node * (double)buckets / (double)P);
    return b >= buckets ? buckets - 1 : b;
}

/* objects at least this many per thread for spatial_order to count and place them on several threads */
#define ORDER_PER_THREAD 32768

/* An order of the objects by the grid node nearest to their start (row-major
   node index, in at most n buckets; a stable counting sort, so the order
   depends only on the input): consecutive objects then write to the same
   rows of the output, which stays in cache. Input order in unsorted data can
   make every object a cache miss (4x slower at 1e6 particles). Returns NULL
   when not worth it or when memory is short (the input order is as right).
   *ends (if not NULL on return; the caller frees it): where each bucket's
   objects end in the order, min(P, n) of them. On T threads each counts and
   places a T-th of the objects (in input order), its bucket's objects after
   those of the threads before it: the same order as on one thread (it ran
   serially before the scatter: 6.6 ms of W1's contacts). */
static cg_index *spatial_order(const job *jb, cg_index **ends, int n_threads)
{
    *ends = NULL;
    const cg_target *t = jb->target;
    const cg_index n = jb->n;
    if (!t->is_grid || t->n_resolved == 0 || n < MIN_OBJECTS_TO_SORT) return NULL;
    const cg_index P = cg_target_size(t);
    const cg_index buckets = P < n ? P : n;
    int T = 1;
#ifdef _OPENMP
    T = n_threads > 0 ? n_threads : omp_get_max_threads();
    if (T > n / ORDER_PER_THREAD) T = (int)(n / ORDER_PER_THREAD);
    if (T < 1) T = 1;
#else
    (void)n_threads;
#endif
    cg_index *order = malloc((size_t)n * sizeof *order);
    /* start: per thread a row of buckets + 1: its count in each bucket (thread 0's at b + 1), then its next place
       there; zeroed by each thread by writing (calloc's fresh pages, read first by the counts, would be the shared
       zero page: each page faulting twice, the second time with a TLB flush on every core) */
    const size_t stride = (size_t)buckets + 1;
    cg_index *start = malloc(stride * (size_t)T * sizeof *start);
    if (!order || !start) {
        free(order);
        free(start);
        return NULL;
    }
    /* the buckets counted, then computed again as the objects are placed (an n-array of them would be new memory
       each call: a page fault per 4 kB, ~3 us each on a virtual machine, more than the arithmetic) */
    int team = 1;
#ifdef _OPENMP
#pragma omp parallel num_threads(T) if (T > 1)
#endif
    {
        int k = 0;
#ifdef _OPENMP
        k = omp_get_thread_num();
#pragma omp single
        team = omp_get_num_threads(); /* (the team may be smaller than asked for) */
#endif
        const cg_index lo = n * k / team, hi = n * (k + 1) / team;
        cg_index *mine = start + (size_t)k * stride;
        const cg_index shift = k == 0 ? 1 : 0;
        memset(mine, 0, stride * sizeof *mine);
        for (cg_index o = lo; o < hi; ++o) ++mine[bucket_of(jb, o, buckets, P) + shift];
#ifdef _OPENMP
#pragma omp barrier
#pragma omp single
#endif
        {
            /* bucket b's places: those of thread 0's objects, then thread 1's, ...; start[b] (thread 0's row)
               becomes b's first place, thread k's row its objects' first place */
            cg_index at = 0;
            for (cg_index b = 0; b < buckets; ++b) {
                const cg_index here = start[b + 1]; /* thread 0's count in b */
                start[b] = at;
                at += here;
                for (int m = 1; m < team; ++m) {
                    cg_index *row = start + (size_t)m * stride;
                    const cg_index count = row[b];
                    row[b] = at;
                    at += count;
                }
            }
            start[buckets] = at;
        }
        /* (single's barrier: every place known) */
        for (cg_index o = lo; o < hi; ++o) order[mine[bucket_of(jb, o, buckets, P)]++] = o;
    }
    /* bucket b's end: where the last thread's place in b has moved to (on one thread, start[b] itself) */
    const cg_index *last = start + (size_t)(team - 1) * stride;
    for (cg_index b = 0; b < buckets; ++b) start[b] = last[b];
    *ends = start;
    return order;
}

/* Objects order[begin..end) (or begin..end) into out, one thread; stops at the
   first error of any thread (recorded in *failed). With values formed per
   object (cg_forms_values), each object's are formed in this thread's row of
   values (a copy of the job pointing at it) just before the object is
   visited. Leaves sc->lucy empty (freed). */
static void visit_range(const job *shared, double *out, scratch *sc, const cg_index *order, cg_index begin,
                        cg_index end, int *failed)
{
    job own;
    double values[CG_MAX_OUTER_VALUES];
    const job *jb = shared;
    if (cg_forms_values(shared)) {
        own = *shared;
        own.values = values;
        jb = &own;
    }
    if (cg_profile_blocks(shared)) {
        /* profiles: blocks of objects (cg_profile.c), their values formed there */
        for (cg_index o = begin; o < end; o += CG_PROFILE_OBJECTS) {
            if (load_status(failed) != CG_OK) return;
            if (interrupted(shared)) { store_status(failed, CG_ERR_INTERRUPTED); return; }
            cg_visit_profile_objects(shared, out, order, o, end - o > CG_PROFILE_OBJECTS ? o + CG_PROFILE_OBJECTS : end);
        }
        return;
    }
    for (cg_index o = begin; o < end; ++o) {
        if (load_status(failed) != CG_OK) break;
        if (interrupted(jb)) { store_status(failed, CG_ERR_INTERRUPTED); break; }
#if defined(__GNUC__)
        if (order && o + PREFETCH_AHEAD < end) {
            /* sorted objects are read out of input order: fetch ahead */
            const cg_index next = order[o + PREFETCH_AHEAD];
            __builtin_prefetch(jb->positions + next * jb->target->dim);
            if (jb->factors) {
                __builtin_prefetch(jb->factors + next * jb->n_factors);
            } else if (jb->kinetic) {
                __builtin_prefetch(jb->masses + next);
                __builtin_prefetch(jb->velocities + next * jb->target->dim);
            } else if (jb->values) {
                __builtin_prefetch(jb->values + next * jb->n_values);
                __builtin_prefetch(jb->values + next * jb->n_values + jb->n_values - 1); /* may span two lines */
            }
            if (jb->vecs) __builtin_prefetch(jb->vecs + next * jb->target->dim);
        }
#endif
        const cg_index obj = order ? order[o] : o;
        if (cg_forms_values(jb)) cg_form_values(jb, obj, values);
        const cg_status s = scatter_object(jb, out, sc, obj);
        if (s != CG_OK) { store_status(failed, s); break; }
    }
    /* the sums kept apart and Lucy's segments still waiting for their values (cg_visit_separable,
       cg_visit_lucy): into out before this range counts as done */
    cg_separable_flush(sc);
    cg_lucy_batch_flush(sc);
}

/* Slabs: the objects cut along the first resolved axis into slabs of W
   nodes, W at least the reach of an object's writes (cutoff plus the longest
   projected segment, plus two nodes for the stencil's rounding). Slabs s and
   s + 3 then write to disjoint nodes, so the slabs of one colour (s mod 3)
   run in parallel straight into the output, colour after colour: no
   per-thread copies of the output, and every node sums its terms in the same
   order whatever the number of threads. Not for periodic first axes, rays
   (unbounded reach) or fewer than SLAB_MIN slabs. */
#define SLAB_COLOURS 3
#define SLAB_MIN 6

/* Each slab's objects are run as this many tasks, one after the other (part
   k + 1 starts when part k is done: they overlap), so that the last tasks of a
   run are short: with whole slabs, 2 threads and an odd count of equal slabs
   one thread ran the last slab alone (a tenth of W1's contact stress). The
   per-node order of the terms is that of whole slabs. */
#define SLAB_PARTS 4

typedef struct slab_plan {
    cg_index n_slabs;
    cg_index *start;   /* n_slabs + 1: slab s holds objects[start[s]..start[s + 1]) */
    cg_index *objects; /* n: in spatial order within each slab */
} slab_plan;

static void free_slabs(slab_plan *plan)
{
    free(plan->start);
    free(plan->objects);
    plan->start = plan->objects = NULL;
    plan->n_slabs = 0;
}

/* with at least one object per node the buckets of spatial_order are the
   nodes (while node * P is exact in a double), row-major: its order is then
   already by slab (the nearest node along the first axis, as plan_slabs
   finds it), and the slabs' starts are bucket ends */
#define NODE_BUCKETS_MAX 90000000

/* 1 with a plan, 0 when slabs do not apply (or memory is short: the
   per-thread copies are as right). *order (spatial_order's, or NULL) is
   taken over (set to NULL) when it is the plan's order itself. */
static int plan_slabs(const job *jb, cg_index **order_owned, const cg_index *ends, slab_plan *plan)
{
    const cg_index *order = *order_owned;
    const cg_target *t = jb->target;
    plan->n_slabs = 0;
    plan->start = plan->objects = NULL;
    if (!t->is_grid || t->n_resolved == 0 || t->periodic[0] || (jb->is_segment && jb->ray)) return 0;
    const cg_index n0 = t->shape[0], n = jb->n;
    const double h = jb->spacing[0], c0 = t->coords[0][0];
    const int D = t->dim, a0 = t->axes[0];
    if (!(h > 0.0)) return 0;
    double reach = jb->kernel->radius;
    if (jb->is_segment) {
        double longest = 0.0;
        for (cg_index o = 0; o < n; ++o) longest = fmax(longest, fabs(jb->vecs[o * D + a0]));
        reach += longest;
    }
    const double width = ceil(reach / h) + 2.0;
    if (!(width * SLAB_MIN <= (double)n0)) return 0;
    const cg_index W = (cg_index)width, n_slabs = (n0 + W - 1) / W;
    const cg_index P = cg_target_size(t);
    if (order && ends && n >= P && P <= NODE_BUCKETS_MAX) {
        plan->start = malloc(((size_t)n_slabs + 1) * sizeof *plan->start);
        if (!plan->start) return 0;
        const cg_index per_plane = P / n0; /* nodes with one index along the first axis */
        for (cg_index s = 0; s < n_slabs; ++s) plan->start[s] = s == 0 ? 0 : ends[s * W * per_plane - 1];
        plan->start[n_slabs] = n;
        plan->objects = *order_owned;
        *order_owned = NULL;
        plan->n_slabs = n_slabs;
        return 1;
    }
    plan->start = calloc((size_t)n_slabs + 1, sizeof *plan->start);
    plan->objects = malloc((size_t)n * sizeof *plan->objects);
    cg_index *slab_of = malloc((size_t)n * sizeof *slab_of);
    if (!plan->start || !plan->objects || !slab_of) {
        free(slab_of);
        free_slabs(plan);
        return 0;
    }
    for (cg_index k = 0; k < n; ++k) {
        const cg_index o = order ? order[k] : k;
        double ix = floor((jb->positions[o * D + a0] - c0) / h + 0.5); /* the nearest node */
        ix = ix < 0.0 ? 0.0 : (ix > (double)(n0 - 1) ? (double)(n0 - 1) : ix);
        slab_of[k] = (cg_index)ix / W;
        ++plan->start[slab_of[k] + 1];
    }
    for (cg_index s = 0; s < n_slabs; ++s) plan->start[s + 1] += plan->start[s];
    for (cg_index k = 0; k < n; ++k) plan->objects[plan->start[slab_of[k]]++] = order ? order[k] : k;
    for (cg_index s = n_slabs; s > 0; --s) plan->start[s] = plan->start[s - 1]; /* back to the starts */
    plan->start[0] = 0;
    free(slab_of);
    plan->n_slabs = n_slabs;
    return 1;
}

/* The per-thread copies' memory (run_objects), kept from one call to the next while at most SPARE_MAX bytes: a loop
   over frames then reuses its pages instead of faulting in fresh ones (~3 us per 4 kB page on a virtual machine,
   1,700 pages a copy of W1's stress) and unmapping them (a TLB flush on every core). One call at a time holds it
   (the bindings release the GIL); another allocates its own. */
#define SPARE_MAX ((size_t)64 << 20) /* (a W1 copy: 7 MB; larger grids take seconds a frame, where faults matter less) */
static double *spare_memory;
static size_t spare_bytes;
static int spare_held;

static double *copies_alloc(size_t bytes, int *held)
{
    *held = 0;
#if defined(__GNUC__)
    if (bytes <= SPARE_MAX && !__atomic_exchange_n(&spare_held, 1, __ATOMIC_ACQUIRE)) {
        if (spare_bytes < bytes) {
            free(spare_memory);
            spare_memory = malloc(bytes);
            spare_bytes = spare_memory ? bytes : 0;
        }
        if (spare_memory) {
            *held = 1;
            return spare_memory;
        }
        __atomic_store_n(&spare_held, 0, __ATOMIC_RELEASE);
    }
#endif
    return malloc(bytes);
}

static void copies_free(double *memory, int held)
{
#if defined(__GNUC__)
    if (held) {
        __atomic_store_n(&spare_held, 0, __ATOMIC_RELEASE);
        return;
    }
#endif
    (void)held;
    free(memory);
}

/* a pause while another thread finishes a slab this one needs */
static void slab_wait(void)
{
#if defined(_OPENMP) && defined(__unix__)
    sched_yield();
#endif
}

/* point targets with at least this many points are sorted by their first
   resolved coordinate (visit_nodes then bisects instead of scanning all) */
#define MIN_POINTS_TO_SORT 16

typedef struct keyed_point {
    double key;
    cg_index index;
} keyed_point;

static int by_key(const void *a, const void *b)
{
    const keyed_point *x = a, *y = b;
    if (x->key < y->key) return -1;
    if (x->key > y->key) return 1;
    return x->index < y->index ? -1 : x->index > y->index;
}

/* the points' order by first coordinate (NULL: not sorted); 0 when memory is short */
static int sort_points(const job *jb, cg_index **order, double **first, cg_index **cell, double *cell_lo,
                       double *cell_inv)
{
    const cg_target *t = jb->target;
    *order = NULL;
    *first = NULL;
    *cell = NULL;
    if (t->is_grid || t->n_resolved == 0 || t->n_points < MIN_POINTS_TO_SORT) return 1;
    const cg_index P = t->n_points;
    const int nr = t->n_resolved;
    for (cg_index p = 0; p < P; ++p)
        if (isnan(t->points[p * nr])) return 1; /* no order: scanned as before */
    keyed_point *keyed = malloc((size_t)P * sizeof *keyed);
    *order = malloc((size_t)P * sizeof **order);
    *first = malloc((size_t)P * sizeof **first);
    if (!keyed || !*order || !*first) {
        free(keyed);
        free(*order);
        free(*first);
        *order = NULL;
        *first = NULL;
        return 0;
    }
    for (cg_index p = 0; p < P; ++p) {
        keyed[p].key = t->points[p * nr];
        keyed[p].index = p;
    }
    qsort(keyed, (size_t)P, sizeof *keyed, by_key);
    for (cg_index p = 0; p < P; ++p) {
        (*order)[p] = keyed[p].index;
        (*first)[p] = keyed[p].key;
    }
    free(keyed);
    /* cells of equal width between the first and last coordinates, P of
       them: cell[j] is the first point at or above the cell's lower edge
       (approximately: visit_points steps from there to the exact first) */
    const double lo = (*first)[0], span = (*first)[P - 1] - lo;
    const double inv = (double)P / span;
    if (span > 0.0 && isfinite(span) && isfinite(inv)) {
        *cell = malloc(((size_t)P + 1) * sizeof **cell);
        if (*cell) {
            cg_index k = 0;
            for (cg_index j = 0; j <= P; ++j) {
                while (k < P && ((*first)[k] - lo) * inv < (double)j) ++k;
                (*cell)[j] = k;
            }
            *cell_lo = lo;
            *cell_inv = inv;
        }
    }
    return 1;
}

static cg_status run_objects(job *jb, double *out, cg_index P, size_t width, int n_threads);

static cg_status run(job *jb, double *out)
{
    cg_status st = prepare(jb);
    if (st != CG_OK) return st;
    st = check_rays(jb);
    if (st != CG_OK) return st;
    const cg_index P = cg_target_size(jb->target);
    const size_t width = (size_t)jb->out_width;
    if (jb->n == 0 || P == 0) return CG_OK;

    int n_threads = 1;
#ifdef _OPENMP
    n_threads = jb->target->n_threads > 0 ? jb->target->n_threads : omp_get_max_threads();
    if ((cg_index)n_threads > jb->n) n_threads = (int)jb->n;
    if (n_threads < 1) n_threads = 1;
    /* small inputs: starting a team and adding per-thread buffers costs more
       than the work (the choice depends only on the input, so a run stays
       deterministic) */
    const double work = (double)jb->n * stencil_estimate(jb);
    if (work < MIN_WORK_PER_THREAD || work < 2.0 * (double)P * (double)width) n_threads = 1;
#endif
    cg_index *point_order = NULL, *point_cell = NULL;
    double *point_first = NULL;
    if (!sort_points(jb, &point_order, &point_first, &point_cell, &jb->point_cell_lo, &jb->point_cell_inv))
        return CG_ERR_NOMEM;
    jb->point_order = point_order;
    jb->point_first = point_first;
    jb->point_cell = point_cell;
    const cg_status done = run_objects(jb, out, P, width, n_threads);
    free(point_order);
    free(point_first);
    free(point_cell);
    return done;
}

static cg_status run_objects(job *jb, double *out, cg_index P, size_t width, int n_threads)
{
    cg_index *ends;
    cg_index *order = spatial_order(jb, &ends, n_threads);
    int failed = CG_OK;
    slab_plan plan;
    const int slabs = plan_slabs(jb, &order, ends, &plan);
    free(ends);
    if (slabs) {
        free(order);
        /* The slabs in colour order, each started as soon as the slabs it
           overlaps (|s' - s| <= 2) of an earlier colour are done, instead of
           a barrier after each colour (which leaves a thread idle when a
           colour's slab count is odd): every node still receives its terms
           slab by slab in colour order, so the sums are those of the
           colour-by-colour order whatever the number of threads. A slab is
           run as SLAB_PARTS tasks (its objects cut in order), part k after
           part k - 1; the list holds a colour's parts k of every slab, then
           its parts k + 1, so that tasks taken together seldom wait for each
           other. Tasks are taken in list order, so a task only waits for
           tasks already taken. done[s] counts the parts of slab s done. */
        const cg_index S = plan.n_slabs, n_all = S * SLAB_PARTS;
        cg_index *task = malloc((size_t)n_all * sizeof *task);
        int *done = calloc((size_t)S, sizeof *done);
        if (!task || !done) {
            free(task);
            free(done);
            free_slabs(&plan);
            return CG_ERR_NOMEM;
        }
        cg_index n_tasks = 0;
        for (int colour = 0; colour < SLAB_COLOURS; ++colour)
            for (int part = 0; part < SLAB_PARTS; ++part)
                for (cg_index s = colour; s < S; s += SLAB_COLOURS) task[n_tasks++] = s * SLAB_PARTS + part;
        cg_index next_task = 0;
#ifdef _OPENMP
#pragma omp parallel num_threads(n_threads) if (n_threads > 1)
#endif
        {
            scratch sc = {NULL, 0, NULL, NULL};
            for (;;) {
                cg_index i;
#ifdef _OPENMP
#pragma omp atomic capture
#endif
                i = next_task++;
                if (i >= n_all) break;
                const cg_index s = task[i] / SLAB_PARTS;
                const int part = (int)(task[i] % SLAB_PARTS);
                const cg_index colour = s % SLAB_COLOURS;
                for (cg_index d = -2; d <= 2; ++d) {
                    const cg_index p = s + d;
                    if (d == 0 || p < 0 || p >= S || p % SLAB_COLOURS >= colour) continue;
                    for (long spins = 0; load_status(done + p) < SLAB_PARTS; ++spins) {
                        if (spins > 64) slab_wait();
                    }
                }
                for (long spins = 0; load_status(done + s) < part; ++spins) {
                    if (spins > 64) slab_wait();
                }
#ifdef _OPENMP
#pragma omp flush
#endif
                const cg_index first = plan.start[s], count = plan.start[s + 1] - first;
                visit_range(jb, out, &sc, plan.objects, first + count * part / SLAB_PARTS,
                            first + count * (part + 1) / SLAB_PARTS, &failed);
#ifdef _OPENMP
#pragma omp flush
#endif
                store_status(done + s, part + 1);
            }
            free(sc.buf);
            cg_separable_release(&sc);
        }
        free(task);
        free(done);
        free_slabs(&plan);
        return (cg_status)failed;
    }
    /* Per-thread copies of the output: thread 0 sums into out, thread t > 0 into copy t - 1, then each thread adds
       the copies' share of a slice of the nodes to out (every node in copy order: the sums are the same whatever
       the slicing). A copy is zeroed by its own thread by writing (calloc's fresh pages, read first by the adds,
       were the shared zero page: each page then faulted twice, the second time with a TLB flush on both cores). */
    const size_t total = (size_t)P * width;
    double *buffers = NULL;
    int held = 0;
    if (n_threads > 1) {
        buffers = total <= SIZE_MAX / sizeof(double) / (size_t)(n_threads - 1)
                      ? copies_alloc((size_t)(n_threads - 1) * total * sizeof(double), &held)
                      : NULL;
        if (!buffers) n_threads = 1; /* fall back to one thread rather than fail */
    }
#ifdef _OPENMP
#pragma omp parallel num_threads(n_threads) if (n_threads > 1)
#endif
    {
        int tid = 0, team = 1;
#ifdef _OPENMP
        tid = omp_get_thread_num();
        team = omp_get_num_threads(); /* (the team may be smaller than asked for) */
#endif
        double *mine = tid == 0 ? out : buffers + (size_t)(tid - 1) * total;
        if (tid > 0) memset(mine, 0, total * sizeof *mine);
        const cg_index begin = jb->n * tid / team, end = jb->n * (tid + 1) / team;
        scratch sc = {NULL, 0, NULL, NULL};
        visit_range(jb, mine, &sc, order, begin, end, &failed);
        free(sc.buf);
        cg_separable_release(&sc);
        if (team > 1) {
#ifdef _OPENMP
#pragma omp barrier
#endif
            const size_t lo = total * (size_t)tid / (size_t)team, hi = total * (size_t)(tid + 1) / (size_t)team;
            for (int c = 1; c < team; ++c) {
                const double *restrict b = buffers + (size_t)(c - 1) * total;
                double *restrict o = out;
                for (size_t i = lo; i < hi; ++i) o[i] += b[i];
            }
        }
    }
    copies_free(buffers, held);
    free(order);
    return (cg_status)failed;
}

/* a job of n objects at positions, everything else zero (NULL, none) */
static job new_job(const cg_target *target, const cg_kernel *kernel, scatter_mode mode, cg_index n,
                   const double *positions, int n_values, int out_width)
{
    job jb;
    memset(&jb, 0, sizeof jb);
    jb.target = target;
    jb.kernel = kernel;
    jb.mode = mode;
    jb.n = n;
    jb.positions = positions;
    jb.n_values = n_values;
    jb.out_width = out_width;
    return jb;
}

/* points and segments share one job layout; with factors (n_factors per
   object) the values are formed per segment as factors (x) vecs */
static cg_status scatter_values(const cg_target *target, const cg_kernel *kernel, cg_index n,
                                const double *positions, int is_segment, const double *vecs, int ray,
                                int n_values, const double *values, const double *factors, int n_factors,
                                int gradient, double *out, int moment, int negate_vecs)
{
    if (factors) {
        if (n_factors < 1 || n_factors * target->dim > CG_MAX_OUTER_VALUES) return CG_ERR_ARGUMENT;
        n_values = n_factors * target->dim;
    }
    if (n < 0 || n_values < 1) return CG_ERR_ARGUMENT;
    job jb = new_job(target, kernel, gradient ? MODE_GRADIENT : MODE_VALUE, n, positions, n_values,
                     gradient ? n_values * target->n_resolved : n_values);
    jb.is_segment = is_segment;
    jb.ray = ray;
    jb.vecs = vecs;
    jb.negate_vecs = negate_vecs;
    jb.values = values;
    jb.factors = factors;
    jb.n_factors = factors ? n_factors : 0;
    jb.moment = moment;
    return run(&jb, out);
}

cg_status cg_scatter_points(const cg_target *target, const cg_kernel *kernel,
                            cg_index n, const double *positions,
                            int n_values, const double *values,
                            int gradient, double *out)
{
    return scatter_values(target, kernel, n, positions, 0, NULL, 0, n_values, values, NULL, 0, gradient, out, 0, 0);
}

int cg_kinetic_values_count(int parts, int dim)
{
    const int all = CG_KINETIC_MASS | CG_KINETIC_MOMENTUM | CG_KINETIC_FLUX;
    if (parts <= 0 || parts > all || dim < 1 || dim > 3) return 0;
    return (parts & CG_KINETIC_MASS ? 1 : 0) + (parts & CG_KINETIC_MOMENTUM ? dim : 0) +
           (parts & CG_KINETIC_FLUX ? dim * (dim + 1) / 2 : 0);
}

cg_status cg_scatter_points_kinetic(const cg_target *target, const cg_kernel *kernel,
                                    cg_index n, const double *positions,
                                    const double *masses, const double *velocities,
                                    const double *u_ref, int parts, double *out)
{
    const int n_values = cg_kinetic_values_count(parts, target->dim);
    if (n < 0 || n_values == 0) return CG_ERR_ARGUMENT;
    job jb = new_job(target, kernel, MODE_VALUE, n, positions, n_values, n_values);
    jb.kinetic = parts;
    for (int d = 0; d < target->dim; ++d) jb.u_ref[d] = u_ref[d];
    jb.masses = masses;
    jb.velocities = velocities;
    return run(&jb, out);
}

cg_status cg_scatter_segments(const cg_target *target, const cg_kernel *kernel,
                              cg_index n, const double *starts, const double *vecs,
                              int ray, int n_values, const double *values,
                              int gradient, double *out)
{
    return scatter_values(target, kernel, n, starts, 1, vecs, ray, n_values, values, NULL, 0, gradient, out, 0, 0);
}

cg_status cg_scatter_segments_outer(const cg_target *target, const cg_kernel *kernel,
                                    cg_index n, const double *starts, const double *vecs, int negate,
                                    int ray, int n_factors, const double *factors,
                                    int gradient, double *out)
{
    if (!factors) return CG_ERR_ARGUMENT;
    return scatter_values(target, kernel, n, starts, 1, vecs, ray, 0, NULL, factors, n_factors, gradient, out, 0,
                          negate != 0);
}

cg_status cg_scatter_segment_moments(const cg_target *target, const cg_kernel *kernel,
                                     cg_index n, const double *starts, const double *vecs,
                                     int n_values, const double *values,
                                     int gradient, double *out)
{
    return scatter_values(target, kernel, n, starts, 1, vecs, 0, n_values, values, NULL, 0, gradient, out, 1, 0);
}

cg_status cg_scatter_fluctuation(const cg_target *target, const cg_kernel *kernel,
                                 cg_index n, const double *positions,
                                 const double *masses, const double *velocities,
                                 const double *node_velocity, double *out)
{
    if (n < 0) return CG_ERR_ARGUMENT;
    job jb = new_job(target, kernel, MODE_FLUCTUATION, n, positions, 1, target->dim * target->dim);
    jb.masses = masses;
    jb.velocities = velocities;
    jb.node_velocity = node_velocity;
    return run(&jb, out);
}
