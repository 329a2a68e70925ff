/*
 * cg.h -- the public C interface of cgbound's coarse-graining core.
 *
 * Plain C11, no Python. Every function that can fail returns a cg_status;
 * cg_strerror() turns it into a message. The core never allocates memory
 * that the caller must free: callers own every array they pass in, and the
 * output arrays are accumulated into (+=), so the caller zeroes them first
 * (with +0: terms that are +-0, such as those of a value that is +-0, may be
 * skipped, which leaves an output of -0 at -0 where adding +0 would not).
 *
 * Vocabulary
 *   D        spatial dimension of the data (2 or 3).
 *   resolved axes   the data axes the evaluation nodes vary along (D_res of
 *            them, 0..D). The other D_avg = D - D_res axes are averaged: the
 *            kernel used is the marginal of the D-dimensional kernel over them,
 *            divided by avg_extent (the product of the averaged extents);
 *            or, with lower_dimensional, the D_res-dimensional kernel itself
 *            (MercuryCG's convention), divided by avg_extent.
 *   target   where fields are evaluated: a regular grid (tensor product of
 *            1-D node coordinates with uniform spacing) or a list of points.
 *   object   what is smeared by the kernel: a point (particle, contact point)
 *            or a segment/ray (contact branch) for the line integral
 *            psi(r) = int_0^S W(r - x0 - s e) ds, S = 1 (segment) or infinity (ray).
 *
 * Kernels (all radial, integral 1 in D dimensions)
 *   Gaussian   W = (2 pi w^2)^(-D/2) exp(-r^2 / 2 w^2), cut off at radius R.
 *              Over averaged axes the exact marginal of the untruncated
 *              Gaussian is used, truncated at R in the resolved subspace.
 *              truncated_norm != 0 renormalises over the truncated support
 *              (MercuryCG's convention). Line integrals: exact (erf forms,
 *              or Gauss-Legendre where it is exact to round-off), or an
 *              n-point Gauss-Legendre rule (line_points = n), or with one
 *              resolved axis MercuryCG's approximation (mercurycg_line,
 *              cg_lowdim.c). On grids the kernel is evaluated as outer
 *              products of 1-D weights.
 *   Lucy       W = C (1 + 3x)(1 - x)^3, x = r/R < 1. Exact marginals over
 *              averaged axes. Line integrals of the full kernel in closed
 *              form (cg_lucy.c); of the marginal over two axes by an exact
 *              Gauss-Legendre rule; of the marginal over one axis by graded
 *              Gauss-Legendre quadrature converged to round-off.
 *   Heaviside  uniform ball of radius R. Exact marginals and line integrals.
 *
 * Periodic resolved axes: every object is summed over all kernel images that
 * reach the target, so the result is right for any R / period.
 */
#ifndef CGBOUND_CG_H
#define CGBOUND_CG_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef int64_t cg_index;

typedef enum cg_status {
    CG_OK = 0,
    CG_ERR_ARGUMENT = 1,     /* an argument is out of its documented range */
    CG_ERR_NOMEM = 2,        /* an internal allocation failed */
    CG_ERR_DIVERGENT = 3,    /* a ray never leaves the target: its integral is infinite */
    CG_ERR_UNSUPPORTED = 4,  /* e.g. a gradient of a kernel/marginal that has none */
    CG_ERR_INTERRUPTED = 5,  /* *interrupt became non-zero during the work */
    /* text parsing (cg_text.h); the position is in cg_text_result */
    CG_ERR_TEXT_NUMBER = 6,     /* a token is not a number */
    CG_ERR_TEXT_INTEGER = 7,    /* a number in an integer column is not an integer */
    CG_ERR_TEXT_OVERFLOW = 8,   /* an integer outside the int64 range */
    CG_ERR_TEXT_ROW_LENGTH = 9, /* a line with more or fewer values than the table's columns */
    CG_ERR_TEXT_ROWS = 10,      /* more rows than the caller expected */
    /* MercuryDPM .fstat contacts (cg_fstat.h); the problem is in cg_fstat_result */
    CG_ERR_FSTAT_LINES = 11     /* a .fstat frame's lines contradict each other or the .data frame */
} cg_status;

/* A static message for a status code (never NULL). */
const char *cg_strerror(cg_status status);

/* Whether the core was built with OpenMP, and how many threads it may use. */
int cg_have_openmp(void);

/* Threads a call with target.n_threads = 0 may use (1 without OpenMP). */
int cg_default_threads(void);

/* Whether the Gaussian on grids runs its AVX-512 build (x86-64 CPUs that have
   it, GCC builds). allow = 0 makes later calls use the AVX2/baseline build
   instead (results are identical; for tests and benchmarks), allow = 1
   restores the default. Returns the previous setting. Set it between calls,
   not during one. */
int cg_set_wide_vectors(int allow);
int cg_wide_vectors(void);

/* out[i] = erfcx(x[i]) = exp(x^2) erfc(x) for x[i] >= 0, as the exact
   Gaussian line integrals evaluate it (the AVX2/baseline build; the AVX-512
   one gives the same bits); for tests. out may be x. */
void cg_gaussian_erfcx(const double *x, double *out, cg_index n);

/* out[i] = exp(x[i]) for x[i] <= 0, as every Gaussian path evaluates its
   weights (cg_vmath.h's cg_exp_in_place: 0 below -708); for tests. out may
   be x. */
void cg_gaussian_exp(const double *x, double *out, cg_index n);

typedef enum cg_kernel_type {
    CG_KERNEL_GAUSSIAN = 0,
    CG_KERNEL_LUCY = 1,
    CG_KERNEL_HEAVISIDE = 2
} cg_kernel_type;

/* the largest n of an n-point Gauss-Legendre line rule */
#define CG_MAX_LINE_POINTS 16

typedef struct cg_kernel {
    /* set by the caller */
    int type;             /* cg_kernel_type */
    int dim;              /* D, 2 or 3 */
    int n_resolved;       /* D_res, 0..D */
    double width;         /* Gaussian standard deviation w (> 0); ignored otherwise */
    double radius;        /* support radius R (> 0): cutoff for the Gaussian */
    int truncated_norm;   /* Gaussian only: renormalise over the cut-off ball */
    double avg_extent;    /* product of the averaged extents (1 when none), > 0 */
    int line_points;      /* Gaussian only: 0 = line integrals to round-off (erf form,
                             or Gauss-Legendre where that is exact to round-off);
                             n = 1..CG_MAX_LINE_POINTS: n-point Gauss-Legendre rule
                             along each finite segment (rays stay exact) */
    int per_node;         /* internal, for benchmarks: 1 = skip the separable fast
                             path and evaluate the kernel node by node */
    int mercurycg_line;   /* Gaussian with D_res = 1 only: 1 = finite segments use
                             MercuryCG's approximate line integral (cg_lowdim.c) instead
                             of the exact one, to reproduce its X/Y/Z ContactStress;
                             rays stay exact; no gradient (CG_ERR_UNSUPPORTED) */
    int lower_dimensional; /* over averaged axes: 0 = the marginal of the D-dimensional
                             kernel; 1 = MercuryCG's convention, the D_res-dimensional
                             kernel itself (e.g. the 1-D Lucy for one resolved axis),
                             divided by avg_extent. The Gaussian is the same either way
                             (its marginal is the lower-dimensional Gaussian). */
    /* filled by cg_kernel_init */
    double prefactor;
} cg_kernel;

/* Validate the kernel and compute its prefactor. */
cg_status cg_kernel_init(cg_kernel *kernel);

/* Marginal kernel M at squared distance rho2 in the resolved subspace. */
double cg_kernel_value(const cg_kernel *kernel, double rho2);

/* Gradient of the marginal at x (D_res components) into grad; returns M(x).
   Any D_avg for the Gaussian and Lucy (Lucy's marginals: cg_gradient.c);
   Heaviside's gradient is given as 0 (D_avg = 0 only). */
double cg_kernel_gradient(const cg_kernel *kernel, const double *x, double *grad);

/* psi = int_0^1 M(|q - s e|^2) ds for the resolved vectors q (node minus
   segment start) and e (segment vector). If grad != NULL it receives the
   gradient of psi with respect to the node position (interior derivative,
   D_avg = 0 only). */
double cg_kernel_line(const cg_kernel *kernel, const double *q, const double *e, double *grad);

/* chi = int_0^1 s M(|q - s e|^2) ds, the first moment of the kernel along the
   segment (the branch-line couple stress, docs/theory.md), with q and e as for
   cg_kernel_line; if grad != NULL it receives the gradient of chi with respect
   to the node position. Exact (closed forms, or Gauss-Legendre panels where
   they are exact to round-off) for the Gaussian (any D_avg; an n-point rule
   when line_points = n, as for psi), and for Lucy and Heaviside (their
   marginals over averaged axes by Gauss-Legendre panels, cg_moment.c); Heaviside
   has no gradient, nor have Lucy's marginals (grad is then filled with NaN). */
double cg_kernel_line_moment(const cg_kernel *kernel, const double *q, const double *e, double *grad);

/* Where fields are evaluated. */
typedef struct cg_target {
    int dim;              /* D */
    int n_resolved;       /* D_res */
    int axes[3];          /* data axis of each resolved axis, increasing */
    int is_grid;          /* 1: grid, 0: points */
    /* grid: node k of resolved axis a is at coords[a][k]; the spacing must be uniform */
    cg_index shape[3];
    const double *coords[3];
    /* points: n_points x n_resolved, row-major */
    cg_index n_points;
    const double *points;
    /* periodicity of each resolved axis */
    int periodic[3];
    double period[3];
    /* Optional: polled during the work; when it reads non-zero the call
       returns CG_ERR_INTERRUPTED (outputs are then partial). May be NULL. */
    const volatile int *interrupt;
    /* Threads to use: 0 = the OpenMP default (omp_get_max_threads()); the
       core uses fewer for small inputs. Ignored without OpenMP. */
    int n_threads;
} cg_target;

/* Number of evaluation nodes of a target (product of the grid shape, 1 for a
   grid with no resolved axis, or n_points). */
cg_index cg_target_size(const cg_target *target);

/* out[0..n) = +0.0 on up to n_threads threads (0: OpenMP's default), each zeroing a contiguous part: a new
   output array's pages are then first touched, and mapped, by several threads at once */
void cg_fill_zero(double *out, cg_index n, int n_threads);

/*
 * Point objects:  out[p, k] += sum_o values[o, k] * M(node_p - x_o)
 * positions: n x D, values: n x n_values.
 * gradient = 0: out is P x n_values.
 * gradient = 1: out is P x n_values x D_res and receives grad M instead
 *   (Gaussian and Lucy for any D_avg; Heaviside only for D_avg = 0).
 */
cg_status cg_scatter_points(const cg_target *target, const cg_kernel *kernel,
                            cg_index n, const double *positions,
                            int n_values, const double *values,
                            int gradient, double *out);

/*
 * Point objects whose values are a particle's mass, momentum and momentum
 * flux, formed per particle as the sums need them (no n x n_values array):
 * cg_scatter_points (gradient = 0) with values[o] the parts of mask parts,
 * in this order: CG_KINETIC_MASS m_o; CG_KINETIC_MOMENTUM m_o (v_or - u_r),
 * r < D; CG_KINETIC_FLUX m_o (v_or v_oc), r <= c < D (the upper triangle,
 * row by row: the flux is symmetric, v_r v_c = v_c v_r exactly). masses: n,
 * velocities: n x D, u_ref: D (a reference velocity). out is P x n_values,
 * n_values = cg_kinetic_values_count(parts, D). parts: a nonzero mask of
 * these bits (CG_ERR_ARGUMENT otherwise).
 */
#define CG_KINETIC_MASS 1
#define CG_KINETIC_MOMENTUM 2
#define CG_KINETIC_FLUX 4
/* [1] + [dim] + [dim (dim + 1) / 2] for the parts present; 0 for a mask that is not a nonzero mask of CG_KINETIC_* bits or a
   dim outside 1..3 */
int cg_kinetic_values_count(int parts, int dim);
cg_status cg_scatter_points_kinetic(const cg_target *target, const cg_kernel *kernel,
                                    cg_index n, const double *positions,
                                    const double *masses, const double *velocities,
                                    const double *u_ref, int parts, double *out);

/*
 * Segment objects: out[p, k] += sum_o values[o, k] * psi_o(node_p) with
 * psi_o(r) = int_0^S M(r - start_o - s vec_o) ds; S = 1, or infinity if ray.
 * starts, vecs: n x D; values: n x n_values; gradient as for points, but
 * Lucy's segments only for D_avg = 0 (CG_ERR_UNSUPPORTED otherwise).
 * A ray whose resolved projection never leaves the target (zero projection,
 * or only along periodic axes) gives CG_ERR_DIVERGENT before any work.
 */
cg_status cg_scatter_segments(const cg_target *target, const cg_kernel *kernel,
                              cg_index n, const double *starts, const double *vecs,
                              int ray, int n_values, const double *values,
                              int gradient, double *out);

/*
 * Segment objects whose values are an outer product with their own vector:
 * as cg_scatter_segments with values[o, r * D + c] = 0.0 + factors[o, r] *
 * vecs[o, c] (r < n_factors, c < D; the 0.0 + makes a zero +0, as NumPy's
 * einsum "ni,nj->nij" does), formed per object as the sums need them: no
 * n x (n_factors D) array. negate != 0: every vector is -vecs[o] instead
 * (exactly, as if negated beforehand: no n x D array of them). The contact
 * stress -f (x) b along -b is factors = f, vecs = b, negate = 1 ((-f) b =
 * f (-b) exactly). n_factors D <= CG_MAX_OUTER_VALUES (CG_ERR_ARGUMENT
 * otherwise); out as for cg_scatter_segments with n_values = n_factors D.
 */
#define CG_MAX_OUTER_VALUES 27
cg_status cg_scatter_segments_outer(const cg_target *target, const cg_kernel *kernel,
                                    cg_index n, const double *starts, const double *vecs, int negate,
                                    int ray, int n_factors, const double *factors,
                                    int gradient, double *out);

/*
 * Segment objects weighted by the kernel's first moment along them:
 * out[p, k] += sum_o values[o, k] * chi_o(node_p), chi_o(r) = int_0^1 s M(r -
 * start_o - s vec_o) ds (cg_kernel_line_moment); gradient as for segments.
 * CG_ERR_UNSUPPORTED for Lucy and Heaviside over averaged axes (D_avg > 0
 * without lower_dimensional), for Heaviside's gradient and for mercurycg_line.
 */
cg_status cg_scatter_segment_moments(const cg_target *target, const cg_kernel *kernel,
                                     cg_index n, const double *starts, const double *vecs,
                                     int n_values, const double *values,
                                     int gradient, double *out);

/*
 * Kinetic stress in fluctuation form (eq. 17a):
 *   out[p, a, b] -= sum_o m_o (v_o - V_p)_a (v_o - V_p)_b M(node_p - x_o)
 * positions, velocities: n x D; masses: n; node_velocity: P x D; out: P x D x D.
 */
cg_status cg_scatter_fluctuation(const cg_target *target, const cg_kernel *kernel,
                                 cg_index n, const double *positions,
                                 const double *masses, const double *velocities,
                                 const double *node_velocity, double *out);

/*
 * Rings (theta-averaged cylindrical grids; cg_ring.c). A source at cylindrical
 * (rho, phi, zeta) is seen from the ring of radius r at the axial offset
 * h = z - zeta at d(t)^2 = (r - rho)^2 + h^2 + 4 r rho sin^2(t/2), t = theta - phi.
 * The kernel must be the full 3-D kernel (dim 3, n_resolved 3, avg_extent 1).
 *
 * cg_ring_moments: for n pairs (h[i], rho[i]) the moments over the half arc
 * where d < R, M_m = (1/pi) int_0^Delta W(d(t)) cos(m t) dt, m = 0 .. n_moments - 1
 * (n_moments 1 to 4), to round-off, written to moments[m * n + i] (0 for pairs
 * whose closest approach is outside the support). With gradient != 0 the same
 * moments of G(d) = W'(d) / d instead of W (grad W(x - q) = G (x - q)); the
 * Heaviside kernel has none (CG_ERR_UNSUPPORTED).
 *
 * cg_ring_segment_sum: out[9] += weight * sum over pieces q of
 * int_lo^hi (theta-average of tensors[segment[q]] carried by the point
 * x0 + s a of that segment) ds, in the local basis, for the ring (r, z): the
 * piece [lo, hi] of s in [0, 1] on panels[q] equal panels in u, s = lo +
 * (hi - lo) sin^2(pi u / 2) (which removes square-root ends), 20-point
 * Gauss-Legendre in u. geometry: per segment (x0_1, x0_2, zeta0, a_1, a_2,
 * a_z), the start and the vector in the ring's frame (e_1, e_2, e_z) relative
 * to the axis point. Pieces in blocks summed in order (thread-count free).
 *
 * cg_ring_segment_gradient_sum: as cg_ring_segment_sum (the same pieces and
 * s-points), out[27] += the theta-average of the gradient, out[9 a + 3 b + c] =
 * d T_ab / d x_c, a, b, c in the local basis (e_r, e_theta, e_z): at each
 * s-point the moments of G, m = 0..3, and an 8-angle rule exact for the
 * degree-3 trigonometric polynomial they weight. Gaussian and Lucy (the
 * Heaviside kernel: CG_ERR_UNSUPPORTED); the truncated Gaussian's jump at
 * the cutoff is not included, as in the Cartesian gradient.
 */
cg_status cg_ring_moments(const cg_kernel *kernel, double r, cg_index n, const double *h, const double *rho,
                          int gradient, int n_moments, double *moments, int n_threads);
cg_status cg_ring_segment_sum(const cg_kernel *kernel, double r, double z, cg_index n_pieces, const cg_index *segment,
                              const double *lo, const double *hi, const cg_index *panels, cg_index n_segments,
                              const double *geometry, const double *tensors, double weight, double *out,
                              int n_threads);
cg_status cg_ring_segment_gradient_sum(const cg_kernel *kernel, double r, double z, cg_index n_pieces,
                                       const cg_index *segment, const double *lo, const double *hi,
                                       const cg_index *panels, cg_index n_segments, const double *geometry,
                                       const double *tensors, double weight, double *out, int n_threads);

/*
 * cg_ring_segment_columns: cg_ring_segment_sum (gradient == 0, width 9) or
 * cg_ring_segment_gradient_sum (gradient != 0, width 27) for n_columns rings at
 * once: column c is the ring (r, z) = (rings[3 c], rings[3 c + 1]) with the
 * weight rings[3 c + 2] and the pieces first[c] .. first[c + 1] - 1 (first[0]
 * = 0, nondecreasing; n_columns + 1 entries); out[width c + k] += its sum,
 * which has the bits of cg_ring_segment_sum's over the same pieces (the same
 * blocks, added in order). Columns are independent (thread-count free).
 * CG_ERR_ARGUMENT for a bad ring, first or piece (as cg_ring_segment_sum),
 * CG_ERR_UNSUPPORTED for the Heaviside kernel's gradient.
 */
cg_status cg_ring_segment_columns(const cg_kernel *kernel, cg_index n_columns, const double *rings,
                                  const cg_index *first, const cg_index *segment, const double *lo, const double *hi,
                                  const cg_index *panels, cg_index n_segments, const double *geometry,
                                  const double *tensors, int gradient, double *out, int n_threads);

/*
 * cg_ring_axial_point_sum: out[9] += sum over the n point sources j (in-plane
 * xy[2 j], xy[2 j + 1] and axial zeta[j] in the ring frame e_1, e_2, e_z
 * relative to the axis point) of weights[j] times the theta-average over the
 * ring of radius r, averaged over z in [lo, hi] (lo < hi), of tensors[9 j ..]
 * (ring frame) W, in the local basis (e_r, e_theta, e_z): the exact axial
 * average of the ring moments (cut where they stop being analytic in z, graded
 * towards branch points just off the cuts, 24-point Gauss-Legendre through the
 * end-clustered map per piece; cgbound/cylindrical_ring.py's axial_rule).
 * Sources in blocks summed in order (thread-count free). CG_ERR_ARGUMENT for
 * a bad kernel, r < 0 or a non-finite or empty [lo, hi].
 */
cg_status cg_ring_axial_point_sum(const cg_kernel *kernel, double r, double lo, double hi, cg_index n,
                                  const double *xy, const double *zeta, const double *tensors, const double *weights,
                                  double *out, int n_threads);

/*
 * cg_quartic_roots (cg_quartic.c): the four complex roots of each of n quartics
 * coef[5 i] x^4 + coef[5 i + 1] x^3 + ... + coef[5 i + 4] (highest power
 * first, a nonzero leading coefficient, finite), written as roots[8 i + 2 k]
 * (real part) and roots[8 i + 2 k + 1] (imaginary part), k = 0..3, in no
 * particular order: Aberth-Ehrlich iteration on the monic quartic, to the
 * last bit at simple roots (a double root comes as a close pair). Rows are
 * independent (thread-count free). CG_ERR_ARGUMENT for a zero leading or a
 * non-finite coefficient.
 */
cg_status cg_quartic_roots(cg_index n, const double *coef, double *roots, int n_threads);

/*
 * Columns of theta-resolved, z-averaged cylindrical grids (cg_axial.c): for
 * each column c, out[9 c + k] += sum over its pieces q = first[c] ..
 * first[c + 1] - 1 of values[9 segment[q] + k] int_lo^hi I_c(starts + s
 * vectors) ds (of segment[q]'s rows), I_c(p) = int_0^1 W(bottoms_c - p -
 * t column) dt the kernel's exact line integral along the column (the z-average
 * at its nodes when column = -(hi - lo) e_z and bottoms_c the node at lo). Each
 * piece [lo, hi] (0 <= lo <= hi <= 1) on panels[q] equal panels in u,
 * s = lo + (hi - lo) sin^2(pi u / 2), 20-point Gauss-Legendre in u. The kernel
 * must be the full 3-D kernel (dim 3, n_resolved 3, avg_extent 1, exact line
 * integrals). first[0] = 0, nondecreasing; bottoms n_columns x 3; starts,
 * vectors n_segments x 3; values n_segments x 9; out n_columns x 9. Columns
 * summed independently (thread-count free). CG_ERR_ARGUMENT otherwise.
 */
cg_status cg_axial_segment_sum(const cg_kernel *kernel, cg_index n_columns, const double *bottoms,
                               const double *column, const cg_index *first, const cg_index *segment,
                               const double *lo, const double *hi, const cg_index *panels, cg_index n_segments,
                               const double *starts, const double *vectors, const double *values, double *out,
                               int n_threads);

/* Replace each row of vecs (n x D) by its minimum image along the periodic
   data axes (periodic[d] != 0, period[d] > 0). */
void cg_minimum_image(cg_index n, int dim, double *vecs,
                      const int *periodic, const double *period);

/* Wrap each row of positions (n x D) into the box [lower, upper) along the
   periodic data axes (periodic[d] != 0): a coordinate already inside is left
   unchanged, any other becomes lower + mod(x - lower, L), L = upper - lower,
   with NumPy's mod (the remainder of fmod moved into [0, L]); a result that
   rounds to upper is lower. CG_ERR_ARGUMENT when a periodic axis has no
   positive finite length or x - lower is not finite (positions are then
   partly wrapped). */
cg_status cg_wrap(cg_index n, int dim, double *positions, const int *periodic,
                  const double *lower, const double *upper);

#ifdef __cplusplus
}
#endif
#endif /* CGBOUND_CG_H */
