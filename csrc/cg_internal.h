/*
 * cg_internal.h -- what cg_scatter.c (loops over objects, images, threads)
 * shares with cg_separable.c (the Gaussian on grids as outer products),
 * cg_lucy.c and cg_lucy_line.c (Lucy's closed-form line integrals, rows of Lucy's and
 * Heaviside's stencils) and cg_kernels.c. Not part of the public interface
 * (cg.h).
 */
#ifndef CGBOUND_CG_INTERNAL_H
#define CGBOUND_CG_INTERNAL_H

#include "cg.h"

#include <math.h>
#include <stddef.h>

/* How many axes the kernel integrates out (its marginal over them): D - D_res,
   or 0 when the kernel is the D_res-dimensional one (lower_dimensional). */
/* values[r * D + c] = 0.0 + f[r] * v[c], r < nf, c < D (einsum's "ni,nj->nij":
   a zero is +0): an object's values from its factors and vector (the contact
   stress's form); three by three written out, the common case */
static inline void cg_outer_values(int nf, int D, const double *f, const double *v, double *values)
{
    if (nf == 3 && D == 3) {
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) values[r * 3 + c] = 0.0 + f[r] * v[c];
        return;
    }
    for (int r = 0; r < nf; ++r)
        for (int c = 0; c < D; ++c) values[r * D + c] = 0.0 + f[r] * v[c];
}

/* a particle's values for cg_scatter_points_kinetic (parts: CG_KINETIC_* bits): m; m (v_r - u_r); m (v_r v_c) for
   r <= c, the products in the order NumPy's columns take them (cgbound.primaries: the same bits) */
static inline void cg_kinetic_values(int parts, int D, double m, const double *v, const double *u, double *values)
{
    int k = 0;
    if (parts & CG_KINETIC_MASS) values[k++] = m;
    if (parts & CG_KINETIC_MOMENTUM)
        for (int r = 0; r < D; ++r) values[k++] = m * (v[r] - u[r]);
    if (parts & CG_KINETIC_FLUX)
        for (int r = 0; r < D; ++r)
            for (int c = r; c < D; ++c) values[k++] = m * (v[r] * v[c]);
}

/* Lucy's profile (1 + 3x)(1 - x)^3, x = r/R (cg_kernel_value and the batched
   point values of cg_lucy_line.c: one formula, the same bits) */
static inline double cg_lucy_profile(double x)
{
    const double om = 1.0 - x;
    return (1.0 + 3.0 * x) * om * om * om;
}

/* the 8-point Gauss-Legendre rule on [-1, 1], its non-negative half (cg_kernels.c, cg_profile.c) */
static const double CG_GL8_X[4] = {0.18343464249564978, 0.525532409916329,
                                   0.7966664774136267, 0.9602898564975362};
static const double CG_GL8_W[4] = {0.36268378337836166, 0.3137066458778869,
                                   0.22238103445337443, 0.10122853629037706};

/* g2(z) = int_z^1 lucy_profile(r) r dr = (1-z)^4 (0.1 + 0.4 z + 0.5 z^2): Lucy's marginal over two axes */
static inline double cg_lucy_marginal2(double z)
{
    if (z >= 1.0) return 0.0;
    const double om = 1.0 - z, om2 = om * om;
    return om2 * om2 * (0.1 + z * (0.4 + 0.5 * z));
}

/* cg_kernel_value of Lucy's (lucy != 0) or Heaviside's kernel averaged over
   two axes, of prefactor C and radius R: its one place, inlined where the
   kernel's type and constants are taken once for many values (cg_kernels.c,
   cg_profile.c) */
static inline double cg_marginal2_value(int lucy, double C, double R, double rho2)
{
    if (!(rho2 < R * R)) return 0.0;
    if (lucy) return C * cg_lucy_marginal2(sqrt(rho2) / R);
    return C * 3.14159265358979323846 * (R * R - rho2);
}

static inline int cg_kernel_marginal_axes(const cg_kernel *k)
{
    return k->lower_dimensional ? 0 : k->dim - k->n_resolved;
}

/* a segment rule (job.line_points, cg_kernel_line_rule's n_points): MercuryCG's
   approximate Gauss line integral along one resolved axis (cg_lowdim.c) */
#define CG_LINE_MERCURYCG (-2)

/* MercuryCG's line integral of its Gauss kernel over the segment from the
   node offset -q to e - q along the one resolved axis (cg_lowdim.c) */
double cg_mercurycg_gauss_line(const cg_kernel *kernel, double q, double e);

/* the n-point Gauss-Legendre rule on [0, 1]: nodes x (increasing), weights w (tabulated for
   n <= CG_MAX_LINE_POINTS, else by Newton on the Legendre recurrence) */
void cg_gauss_legendre01(int n, double *x, double *w);

/* cg_kernel_line with an explicit rule: n_points = 0 evaluates the integral
   to round-off, n_points > 0 applies the n-point Gauss-Legendre rule,
   CG_LINE_MERCURYCG MercuryCG's approximation (Gaussian only; other kernels
   are always evaluated to round-off) */
double cg_kernel_line_rule(const cg_kernel *kernel, const double *q, const double *e, double *grad,
                           int n_points);

/* cg_kernel_line_moment with the same rule as cg_kernel_line_rule (cg_moment.c) */
double cg_kernel_line_moment_rule(const cg_kernel *kernel, const double *q, const double *e, double *grad,
                                  int n_points);

/* ------------------------------------------------------------------ */
/* A segment seen from a node (cg_kernels.c, cg_lucy.c). With L = |e|, unit
   vector n = e/L, u = q.n and q_perp = q - u n (component-wise, which keeps
   |q_perp| accurate when q is nearly parallel to e), the point of the segment
   at parameter s is at signed distance t(s) = u - s L along n from the node's
   foot. */

typedef struct segment_axis {
    double L;        /* |e| */
    double unit[3];  /* n = e / L */
} segment_axis;

typedef struct segment_frame {
    int n;
    double L;        /* |e| */
    double u;        /* q . n */
    double t_far;    /* (q - e) . n, = u - L but without its cancellation */
    double a2;       /* |q_perp|^2 */
    double qperp[3];
    double unit[3];  /* n */
} segment_frame;

/* L and n of a segment e (n components) of non-zero length */
static inline void segment_axis_of(int n, const double *e, segment_axis *ax)
{
    double L2 = 0.0;
    for (int d = 0; d < n; ++d) L2 += e[d] * e[d];
    ax->L = sqrt(L2);
    for (int d = 0; d < n; ++d) ax->unit[d] = e[d] / ax->L;
}

/* the frame of node offset q (node minus segment start) */
static inline void node_frame(int n, const segment_axis *ax, const double *q, const double *e, segment_frame *f)
{
    f->n = n;
    f->L = ax->L;
    double u = 0.0, t_far = 0.0;
    for (int d = 0; d < n; ++d) {
        f->unit[d] = ax->unit[d];
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

static inline void make_frame(int n, const double *q, const double *e, segment_frame *f)
{
    segment_axis ax;
    segment_axis_of(n, e, &ax);
    node_frame(n, &ax, q, e, f);
}

/* t at parameter s, taking the accurate end values at s = 0 and s = 1 */
static inline double t_at(const segment_frame *f, double s)
{
    if (s == 0.0) return f->u;
    if (s == 1.0) return f->t_far;
    return f->u - s * f->L;
}

/* Clip [0, 1] to the support |t(s)| <= b, b = sqrt(R^2 - a^2). Returns 0 if empty. */
static inline int clip_to_support(const segment_frame *f, double R, double *s0, double *s1, double *b)
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

/* Lucy's line integral psi = int_0^1 W(|q - s e|) ds of the full-dimensional
   kernel (D_avg = 0) at one node, in closed form (cg_lucy.c); the segment has
   non-zero length. With grad != NULL also its gradient. */
double cg_lucy_segment(const cg_kernel *kernel, const segment_axis *ax, const double *q, const double *e,
                       double *grad);

/* Lucy's line integral in closed form (cg_lucy.c), in units of R: over the
   part t1 <= t <= t0 of a line at distance sqrt(a2) from the node (span =
   t0 - t1, given accurately), acc[0] = int P(x) dt/R with P = (1 + 3x)(1 - x)^3,
   x = sqrt(a2 + t^2)/R; with want_grad also acc[1] = int (1 - x)^2 dt/R and
   acc[2] = int (t/R)(1 - x)^2 dt/R (else 0). Needs |t0|, |t1| and a2 inside
   the support (the caller clips). */
void cg_lucy_line(double a2, double t0, double t1, double span, double R, int want_grad, double *acc);

/* Lucy's line integral, value only (cg_lucy_line.c): int P(x) dt/R as
   cg_lucy_line's acc[0], from the node offset q, the segment e of length L
   and direction n (3 components each, the unused ones 0); 0 outside the
   support. cg_lucy_values does so for count nodes (offsets q0[i], q1[i],
   q2[i]) into w[i] = factor * value, vectorised (wide: the AVX-512 build, if
   compiled); the same bits as cg_lucy_value at every node. */
double cg_lucy_value(const double *q, const double *n, const double *e, double L, double R);
void cg_lucy_values(int count, const double *q0, const double *q1, const double *q2, const double *n,
                    const double *e, double L, double R, double factor, double *w, int wide);

/* Nodes' frames (cg_lucy_line.c): cg_lucy_frames computes each node's frame
   (u = q.n, t_far = (q - e).n, a2 = |q - u n|^2, as cg_lucy_value does) and
   keep[i] = 0 where the value is surely 0 (Lucy's: a test without square
   roots, loose by a relative 1e-9; cylinder: only a2 < R^2, for Heaviside).
   cg_heaviside_values_frame: Heaviside's line integral from the frames,
   prefactor times the clipped part of [0, 1] (the node-by-node path's
   numbers, cg_kernel_line_rule). */
void cg_lucy_frames(int count, const double *q0, const double *q1, const double *q2, const double *n,
                    const double *e, double R, double *u, double *t_far, double *a2, int *keep, int cylinder,
                    int wide);
void cg_heaviside_values_frame(int count, const double *u, const double *t_far, const double *a2, double L,
                               double R, double prefactor, double *w, int wide);

/* Point values of Lucy's (heaviside 0) or Heaviside's (1) full-dimensional
   kernel at squared distances rho2: w[i] = cg_kernel_value(kernel, rho2[i])
   bit for bit, vectorised (cg_lucy_line.c) */
void cg_ball_values(int count, const double *rho2, double R, double prefactor, int heaviside, double *w, int wide);

/* out[node[i] * width + c] += w[i] * val[c], c < nv, for each i with a
   non-zero w[i], in order (cg_lucy_line.c; vectorised over c, the bits of
   cg_accumulate's MODE_VALUE) */
void cg_ball_add(int count, const double *w, const cg_index *node, int width, const double *val, int nv, double *out,
                 int wide);

/* out[node[i] * 9 + k] += (w[i] * scale) * val[k], k < 9, for each i with a
   non-zero w[i] * scale, in order (cg_lucy_line.c; vectorised, the bits of
   cg_accumulate's) */
void cg_lucy_add9(int count, const double *w, const cg_index *node, double scale, const double *val, double *out,
                  int wide);

/* Lucy's values for the nodes of several segments at once (cg_lucy_line.c):
   segment s (< nseg) has nodes start[s]..start[s + 1] - 1 (offsets q0[i],
   q1[i], q2[i] from its start, grid indices node[i]), direction
   geom[7s..7s+2], end offset geom[7s+3..7s+5] and L/R (as L * (1/R))
   geom[7s + 6]. Out: the nodes of segment s at cstart[s]..cstart[s + 1] - 1,
   their indices in node_c and w = the value cg_lucy_value gives (bit for
   bit, unscaled); nodes whose value is surely 0 may be left out (the
   AVX-512 build does). u, t_far, a2, Ld: scratch. Every array is read or
   written up to a whole number of 8-lane vectors past each segment's last
   node (at least 8 elements of slack, initialised, past start[nseg]).
   cg_lucy_batch_add9: cg_lucy_add9 per segment (start: cstart, node: node_c)
   with weights factor[s] * w[i], scale[s] and values val[9s..9s+8], in order. */
void cg_lucy_batch_values(int nseg, const int *start, const double *geom, const double *q0, const double *q1,
                          const double *q2, const cg_index *node, double R, double *u, double *t_far, double *a2,
                          double *Ld, double *w, cg_index *node_c, int *cstart, int wide);
void cg_lucy_batch_add9(int nseg, const int *start, const double *factor, const double *scale, const double *val,
                        const double *w, const cg_index *node, double *out, int wide);

/* A segment seen from the rows of a grid (cg_lucy_line.c, cg_lucy_rows):
   n, e along the (up to two) axes before the row axis (0 where absent), nz,
   ez along the row axis; the squared radius with margins bound, the margin
   mu of u; the row's nodes z0 + k h, x_row the segment start's coordinate
   along it, slack the rounding of the node positions in nodes. */
typedef struct lucy_row_params {
    double n[2], e[2], nz, ez, L, bound, mu, z0, h, x_row, slack;
} lucy_row_params;

/* For count rows (offsets f0[i], f1[i] of the row from the segment's start
   along the axes before the row axis): the indices klo[i]..khi[i] (doubles;
   empty if klo > khi) of the row's nodes that can be inside the capsule */
void cg_lucy_rows(int count, const double *f0, const double *f1, const lucy_row_params *P, double *klo,
                  double *khi, int wide);

/* Gradient of Lucy's marginal over one or two averaged axes (D_avg > 0,
   D_res > 0) at resolved offset x into grad; returns M(x) (cg_gradient.c). */
double cg_lucy_marginal_gradient(const cg_kernel *kernel, const double *x, double *grad);

/* Order of a Gauss-Legendre rule that integrates the Gaussian (width w) over a
   segment of length L exactly to round-off, or 0 if the segment is too long. */
int cg_gaussian_roundoff_points(double L, double w);

typedef enum { MODE_VALUE, MODE_GRADIENT, MODE_FLUCTUATION } scatter_mode;

typedef struct job {
    const cg_target *target;
    const cg_kernel *kernel;
    scatter_mode mode;
    int is_segment;
    int ray;
    cg_index n;
    const double *positions;   /* n x D: point or segment start */
    const double *vecs;        /* n x D or NULL */
    int negate_vecs;           /* the segments' vectors are -vecs (cg_vec_of; cg_scatter_segments_outer's negate) */
    int n_values;
    const double *values;      /* n x n_values */
    const double *factors;     /* or NULL; else values are factors (x) vecs, formed per object
                                  (cg_scatter_segments_outer): n x n_factors */
    int n_factors;
    int kinetic;               /* or 0; else (cg_scatter_points_kinetic) values formed per object from masses,
                                  velocities and u_ref: the parts CG_KINETIC_* of this mask, in that order */
    double u_ref[3];
    const double *masses;      /* fluctuation, kinetic */
    const double *velocities;  /* fluctuation, kinetic: n x D */
    const double *node_velocity; /* fluctuation, P x D */
    int out_width;             /* doubles per node in out */
    double lo[3], hi[3];       /* extent of the nodes along each resolved axis */
    double spacing[3];
    int separable;             /* use cg_visit_separable (Gaussian on a grid) */
    int lucy_rows;             /* use cg_visit_lucy (Lucy's and Heaviside's segments on a grid) */
    int ball_rows;             /* use cg_visit_ball_points (Lucy's, Heaviside's points on a grid) */
    int gradient_rows;         /* use cg_visit_gradient_points (gradients of points on a grid) */
    int profile_rows;          /* use cg_visit_profile (Lucy's, Heaviside's values, Lucy's point gradients on one
                                  resolved axis, two averaged) */
    int profile_gauss;         /* the Gaussian's point values and exact segment integrals on such a profile:
                                  cg_visit_profile_objects (the separable path's numbers; segments too long
                                  for its rule: the closed form) */
    int wide;                  /* ... its AVX-512 build (and cg_visit_lucy's) */
    int lucy_box;              /* cg_visit_lucy may evaluate whole boxes: a grid of >= 2 resolved axes, all spaced */
    double inv_spacing[3];     /* grids: 1 / spacing (0 where the spacing is 0) */
    double coord_extent[3];    /* grids: |first node| + |last node| along each resolved axis */
    double inv_cell;           /* grids: 1 / the product of the spacings (0 if one is 0) */
    cg_index grid_stride[3];   /* grids: row-major strides of the resolved axes */
    int line_points;           /* the kernel's rule for finite segments (0: round-off) */
    const cg_index *point_order; /* point targets: the points by their first resolved coordinate (or NULL) */
    const double *point_first;   /* ... and that coordinate, in that order */
    const cg_index *point_cell;  /* ... and where to start looking for a coordinate c: point_cell[j], j =
                                    floor((c - point_cell_lo) * point_cell_inv) in 0..n_points (or NULL) */
    double point_cell_lo, point_cell_inv;
    int moment;                /* segments weighted by the kernel's first moment (cg_moment.c) */
    int any_periodic;          /* a resolved axis is periodic (else no images to look for) */
} job;

/* an object's values formed just before it is visited (factors (x) vecs, or a particle's kinetic values): the
   visits then read them from a row of the caller's, not from jb->values */
static inline int cg_forms_values(const job *jb)
{
    return jb->factors != NULL || jb->kinetic != 0;
}

/* component axis of segment obj's vector, negated where negate_vecs (unary minus: exact, zeros' signs too, as
   np.negative) */
static inline double cg_vec_of(const job *jb, cg_index obj, int axis)
{
    const double e = jb->vecs[obj * jb->target->dim + axis];
    return jb->negate_vecs ? -e : e;
}

/* object obj's values into values (n_values of them), where cg_forms_values */
static inline void cg_form_values(const job *jb, cg_index obj, double *values)
{
    const int D = jb->target->dim;
    if (jb->factors) {
        double vec[3];
        for (int d = 0; d < D; ++d) vec[d] = cg_vec_of(jb, obj, d);
        cg_outer_values(jb->n_factors, D, jb->factors + obj * jb->n_factors, vec, values);
    } else
        cg_kinetic_values(jb->kinetic, D, jb->masses[obj], jb->velocities + obj * D, jb->u_ref, values);
}

struct lucy_batch;
struct axis_sums;

/* per-thread scratch memory of the separable path, grown on demand */
typedef struct scratch {
    double *buf;
    size_t cap;
    struct lucy_batch *lucy; /* cg_visit_lucy's segments waiting for their values (cg_lucy_batch_flush) */
    struct axis_sums *sums;  /* out's values of one kind held apart by the separable path (cg_separable_flush) */
} scratch;

/* out[node] += the contribution of object obj with the given weight (or
   gradient, MODE_GRADIENT) */
static inline void cg_accumulate(const job *jb, double *out, cg_index obj, cg_index node, double weight,
                                 const double *grad)
{
    const int nv = jb->n_values;
    double *o = out + node * jb->out_width;
    switch (jb->mode) {
    case MODE_VALUE: {
        const double *v = jb->values + obj * nv;
        for (int k = 0; k < nv; ++k) o[k] += weight * v[k];
        break;
    }
    case MODE_GRADIENT: {
        const int nr = jb->target->n_resolved;
        const double *v = jb->values + obj * nv;
        for (int k = 0; k < nv; ++k)
            for (int d = 0; d < nr; ++d) o[k * nr + d] += grad[d] * v[k];
        break;
    }
    case MODE_FLUCTUATION: {
        const int D = jb->target->dim;
        const double *v = jb->velocities + obj * D;
        const double *V = jb->node_velocity + node * D;
        double dv[3];
        for (int a = 0; a < D; ++a) dv[a] = v[a] - V[a];
        const double mw = jb->masses[obj] * weight;
        for (int a = 0; a < D; ++a)
            for (int b = 0; b < D; ++b) o[a * D + b] -= mw * dv[a] * dv[b];
        break;
    }
    }
}

/* The grid nodes of an object's box [bmin, bmax] (resolved coordinates):
   index range first..last along each resolved axis and the row-major
   strides. Returns 0 when no node is in the box. */
static inline int stencil_range(const job *jb, const double *bmin, const double *bmax, cg_index *first,
                                cg_index *last, cg_index *stride)
{
    const cg_target *t = jb->target;
    const int nr = t->n_resolved;
    for (int a = 0; a < 3; ++a) {
        first[a] = last[a] = 0;
        stride[a] = 1;
    }
    for (int a = 0; a < nr; ++a) {
        const double c0 = t->coords[a][0], h = jb->spacing[a];
        const cg_index n = t->shape[a];
        if (n == 1 || h == 0.0) { first[a] = 0; last[a] = n - 1; continue; }
        double f = floor((bmin[a] - c0) / h), l = ceil((bmax[a] - c0) / h);
        if (f < 0.0) f = 0.0;
        if (l > (double)(n - 1)) l = (double)(n - 1);
        if (f > l) return 0;
        first[a] = (cg_index)f;
        last[a] = (cg_index)l;
    }
    for (int a = nr - 2; a >= 0; --a) stride[a] = stride[a + 1] * t->shape[a + 1];
    return 1;
}

/* Advance the multi-index idx over the stencil box first..last along axes 0..n-1 (the last fastest);
   returns 0 once every index has been visited. */
/* The stencil box of a ball of radius R around a point x (resolved
   coordinates) on a grid: stencil_range of [x - R, x + R]; 0 when the box
   misses the nodes. */
static inline int ball_stencil(const job *jb, const double *x, double R, cg_index *first, cg_index *last,
                               cg_index *stride)
{
    double bmin[3], bmax[3];
    for (int a = 0; a < jb->target->n_resolved; ++a) {
        bmin[a] = x[a] - R;
        bmax[a] = x[a] + R;
        if (bmax[a] < jb->lo[a] || bmin[a] > jb->hi[a]) return 0;
    }
    return stencil_range(jb, bmin, bmax, first, last, stride);
}

/* The nodes k0..k1 of a grid row along axis `row` (within first..last) that
   the ball of squared radius `bound` around coordinate xr reaches, for a row
   at squared distance p2 from the centre along the other axes: none (k1 < k0)
   when p2 >= bound; all of first..last when the row's spacing is 0. A node
   of slack each way covers the rounding of 1 / spacing. */
static inline void ball_row(const job *jb, int row, double xr, double bound, double p2, cg_index first,
                            cg_index last, cg_index *k0, cg_index *k1)
{
    *k0 = first;
    *k1 = last;
    if (!(jb->spacing[row] > 0.0)) return;
    if (!(p2 < bound)) {
        *k1 = first - 1;
        return;
    }
    const double half = sqrt(bound - p2), c0 = jb->target->coords[row][0], inv_h = jb->inv_spacing[row];
    const double klo = floor((xr - half - c0) * inv_h) - 1.0;
    const double khi = ceil((xr + half - c0) * inv_h) + 1.0;
    if (klo > (double)*k0) *k0 = (cg_index)klo;
    if (khi < (double)*k1) *k1 = (cg_index)khi;
}

static inline int stencil_next(cg_index *idx, const cg_index *first, const cg_index *last, int n)
{
    for (int a = n - 1; a >= 0; --a) {
        if (++idx[a] <= last[a]) return 1;
        idx[a] = first[a];
    }
    return 0;
}

/* Whether the separable path can take this object: returns 0 when the caller
   should use the node-by-node path instead. Otherwise visits every node of
   the object's stencil (one image at resolved position x, segment vector e,
   line integral multiplied by scale; ray: the segment is a cut ray and stays
   exact) and returns 1, or -1 if scratch memory could not be had. */
int cg_visit_separable(const job *jb, double *out, scratch *sc, cg_index obj, const double *x, const double *e,
                       double scale);

/* out's values of one kind held apart by the separable path (segments along a
   grid axis, their rows added as vectors): copied back into out. Before a
   range of objects counts as done; cg_separable_release (with sc's thread)
   copies them back and frees them. */
void cg_separable_flush(scratch *sc);
void cg_separable_release(scratch *sc);

/* Lucy's segments on grids (full-dimensional kernel, values): the nodes of
   each row of the stencil with the segment's axis computed once; the same
   numbers as the node-by-node path, bit for bit. Returns 1 when it visited the
   object, 0 when the caller should use the node-by-node path (zero length).
   Lucy's segments whose box is evaluated whole may wait in sc->lucy (their
   terms not yet in out) until cg_lucy_batch_flush, called before anything
   else writes to out and at the end of a thread's objects: the terms reach
   every node in object order all the same. cg_lucy_batch_flush also frees
   sc->lucy. */
int cg_visit_lucy(const job *jb, double *out, scratch *sc, cg_index obj, const double *x, const double *e,
                  double scale);
void cg_lucy_batch_flush(scratch *sc);

/* Points of Lucy and Heaviside on grids (values and fluctuations): each row
   of the stencil narrowed to the support ball, the node-by-node numbers bit
   for bit. Returns 1 (it visited the object). */
int cg_visit_ball_points(const job *jb, double *out, cg_index obj, const double *x);
/* cg_gradient_rows.c: kernel gradients of points on a grid, the support ball's rows only */
int cg_visit_gradient_points(const job *jb, double *out, cg_index obj, const double *x);

/* cg_profile.c: values of Lucy's and Heaviside's marginals over two averaged
   axes on a grid of one resolved axis, points and segments (zero-length ones
   too), and the gradients of Lucy's for points, each object's nodes in vectorised batches; the node-by-node numbers
   bit for bit. Returns 1 (it visited the object). */
int cg_visit_profile(const job *jb, double *out, cg_index obj, const double *x, const double *e, double scale);
/* Whether cg_visit_profile_objects takes this job's objects (a profile, not
   periodic along its axis, no rays), and the objects order[begin..end) (or
   begin..end) of such a job, at most CG_PROFILE_OBJECTS of them, in blocks of (object, node)
   pairs: the same bits as cg_visit_profile object by object (the Gaussian's points and
   segments, job.profile_gauss: as cg_visit_separable's, object by object). */
#define CG_PROFILE_OBJECTS 32
int cg_profile_blocks(const job *jb);
void cg_visit_profile_objects(const job *jb, double *out, const cg_index *order, cg_index begin, cg_index end);

/* An AVX-512 build of the separable path (cg_separable_wide.c) exists on
   x86-64 with GCC; cg_separable_wide_available() says whether this CPU runs it
   (job.wide then selects it). */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(CGBOUND_NO_CLONES)
#define CG_HAVE_WIDE_SEPARABLE 1
int cg_visit_separable_wide(const job *jb, double *out, scratch *sc, cg_index obj, const double *x, const double *e,
                            double scale);
#endif
int cg_separable_wide_available(void);
/* The exact Gaussian's segment rule (cg_gaussian_roundoff_points) is exact to
   round-off relative to the kernel's peak; relative to a node's own value it
   keeps 1e-14 up to 4.25 w beyond an end (every rule, all its lengths;
   measured against mpmath). Nodes farther than this many w beyond an end go
   to the closed form (cg_separable.c, cg_profile.c). */
#define CG_GAUSS_FAR_BEYOND_END 4.0
/* cg_separable.c's erfcx for the closed form's lanes, x[i] and z[i] in place
   (n a multiple of 4; may_exceed: some argument may exceed 4), for
   cg_profile.c's blocks: the cut nodes' bits */
void cg_erfcx_in_place2(double *x, double *z, cg_index n, int may_exceed);

/* Double-double steps (Dekker's product, no FMA: the same bits in every build; Knuth's sum) for
   cg_cut_span_lane. */
static inline void cg_dd_split(double a, double *hi, double *lo)
{
    const double c = 134217729.0 * a; /* 2^27 + 1: Veltkamp's split */
    *hi = c - (c - a);
    *lo = a - *hi;
}
/* a b = hi + lo exactly, a = ah + al and b = bh + bl split */
static inline void cg_dd_prod(double a, double ah, double al, double b, double bh, double bl, double *hi, double *lo)
{
    *hi = a * b;
    *lo = ((ah * bh - *hi) + ah * bl + al * bh) + al * bl;
}
static inline void cg_dd_add(double ah, double al, double bh, double bl, double *hi, double *lo)
{
    const double s = ah + bh, bb = s - ah, err = (ah - (s - bb)) + (bh - bb) + (al + bl);
    *hi = s + err;
    *lo = err - (*hi - s);
}
static inline void cg_dd_mul(double ah, double al, double bh, double bl, double *hi, double *lo)
{
    double sh, sl, th, tl, p, e;
    cg_dd_split(ah, &sh, &sl);
    cg_dd_split(bh, &th, &tl);
    cg_dd_prod(ah, sh, sl, bh, th, tl, &p, &e);
    e += ah * bl + al * bh;
    *hi = p + e;
    *lo = e - (*hi - p);
}

/* a segment's constants for cg_cut_span_lane: e (3 slots, |e| > 0) split, |e|^2 and R^2 in double-double */
typedef struct cg_cut_span_frame {
    double e[3], eh[3], el[3], E, El, R2, R2l;
} cg_cut_span_frame;

static inline void cg_cut_span_frame_of(const double *e, double R, cg_cut_span_frame *f)
{
    double h, l, Rh, Rl;
    f->E = f->El = 0.0;
    for (int s = 0; s < 3; ++s) {
        f->e[s] = e[s];
        cg_dd_split(e[s], &f->eh[s], &f->el[s]);
        cg_dd_prod(e[s], f->eh[s], f->el[s], e[s], f->eh[s], f->el[s], &h, &l);
        cg_dd_add(f->E, f->El, h, l, &f->E, &f->El);
    }
    cg_dd_split(R, &Rh, &Rl);
    cg_dd_prod(R, Rh, Rl, R, Rh, Rl, &f->R2, &f->R2l);
}

/* The length, in units of the segment (q the node minus the start, 3 slots), of the part of the segment
   inside the node's ball of radius R, from exact differences: the closed form's short intervals
   (cg_separable.c's cut_batch_flush, cg_profile.c's twin: the same bits; branch-free, so that a loop of it
   is vectorised). The lanes build it from s = u -+ h / L at the scale of R / L, which keeps only eps R / span
   of a sliver (the sphere crossing within a few ulp of an end, or barely clipping the segment's side).
   Here, with D = R^2 - |q|^2, P = q.e, E = |e|^2 and H = h^2 E = D E + P^2 in double-double, the
   crossings' cancelling sums are quotients: u + h = D E / (hL - P) / L where P < 0 (the start inside),
   h - (u - L) = (D + 2P - E) E / (hL + P - E) / L where P > E (the end inside), 2h otherwise; a few eps
   of the part's own length for the inputs q, e, R as given. */
static inline double cg_cut_span_lane(double q0, double q1, double q2, const cg_cut_span_frame *f)
{
    const double q[3] = {q0, q1, q2};
    double Q = 0.0, Ql = 0.0, P = 0.0, Pl = 0.0, h, l, qh, ql;
    for (int s = 0; s < 3; ++s) {
        cg_dd_split(q[s], &qh, &ql);
        cg_dd_prod(q[s], qh, ql, q[s], qh, ql, &h, &l);
        cg_dd_add(Q, Ql, h, l, &Q, &Ql);
        cg_dd_prod(q[s], qh, ql, f->e[s], f->eh[s], f->el[s], &h, &l);
        cg_dd_add(P, Pl, h, l, &P, &Pl);
    }
    double D, Dl, H, Hl, Pp, Ppl, de, del, pp, ppl, Dend, Dendl;
    cg_dd_add(f->R2, f->R2l, -Q, -Ql, &D, &Dl);     /* R^2 - |q|^2: > 0 where the start is inside */
    cg_dd_add(P, Pl, -f->E, -f->El, &Pp, &Ppl);     /* (q - e).e */
    cg_dd_mul(D, Dl, f->E, f->El, &de, &del);
    cg_dd_mul(P, Pl, P, Pl, &pp, &ppl);
    cg_dd_add(de, del, pp, ppl, &H, &Hl);
    cg_dd_add(D, Dl, Pp, Ppl, &h, &l);
    cg_dd_add(h, l, P, Pl, &Dend, &Dendl);          /* R^2 - |q - e|^2 = D + (P - E) + P: > 0, the end inside */
    const double hL = sqrt(H > 0.0 ? H : 0.0), inv_E = 1.0 / f->E;
    const int start_in = D > 0.0, end_in = Dend > 0.0;
    const double at_start = P < 0.0 ? D / (hL - P) : (P + hL) * inv_E;
    const double at_end = Pp > 0.0 ? Dend / (hL + Pp) : (hL - Pp) * inv_E;
    const double middle = P > 0.0 && Pp < 0.0 ? 2.0 * hL * inv_E : 0.0;
    double span = start_in ? (end_in ? 1.0 : at_start) : (end_in ? at_end : middle);
    span = H > 0.0 ? span : 0.0; /* the ball misses the line or touches it */
    return span < 1.0 ? span : 1.0;
}

#endif /* CGBOUND_CG_INTERNAL_H */
