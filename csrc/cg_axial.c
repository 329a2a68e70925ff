/*
 * cg_axial.c -- z-averages of segment line integrals at the node columns of
 * theta-resolved, z-averaged cylindrical grids (cgbound/cylindrical_axial.py).
 *
 * The z-average over a column [x_lo, x_lo - column] of a segment's line
 * integral int_0^1 W(x - a - s b) ds is int_0^1 I(a + s b) ds, I(p) the
 * kernel's line integral along the column seen from the point p
 * (cg_kernel_line with q = x_lo - p, e = column: exact). The caller cuts s
 * into pieces on which I is analytic; each piece [lo, hi] gets panels equal
 * panels in u of 20-point Gauss-Legendre, s = lo + (hi - lo) sin^2(pi u / 2)
 * (which removes square-root ends). Columns are independent and each is summed
 * in piece order, so the result does not depend on the thread count.
 */
#include "cg.h"
#include "cg_internal.h"

#include <math.h>
#include <stddef.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define AXIAL_POINTS 20

static int axial_kernel_ok(const cg_kernel *k)
{
    return k && k->dim == 3 && k->n_resolved == 3 && k->prefactor > 0.0 && k->avg_extent == 1.0 &&
           k->line_points == 0 && !k->mercurycg_line && !k->lower_dimensional &&
           (k->type == CG_KERNEL_GAUSSIAN || k->type == CG_KERNEL_LUCY || k->type == CG_KERNEL_HEAVISIDE);
}

cg_status cg_axial_segment_sum(const cg_kernel *kernel, cg_index n_columns, const double *bottoms,
                               const double *column, const cg_index *first, const cg_index *segment,
                               const double *lo, const double *hi, const cg_index *panels, cg_index n_segments,
                               const double *starts, const double *vectors, const double *values, double *out,
                               int n_threads)
{
    if (!axial_kernel_ok(kernel) || n_columns < 0 || n_segments < 0 || first[0] != 0)
        return CG_ERR_ARGUMENT;
    for (int d = 0; d < 3; ++d)
        if (!isfinite(column[d])) return CG_ERR_ARGUMENT;
    for (cg_index c = 0; c < n_columns; ++c)
        if (first[c + 1] < first[c]) return CG_ERR_ARGUMENT;
    const cg_index n_pieces = first[n_columns];
    for (cg_index q = 0; q < n_pieces; ++q)
        if (segment[q] < 0 || segment[q] >= n_segments || panels[q] < 1 || panels[q] > 1 << 20 ||
            !(lo[q] >= 0.0 && lo[q] <= hi[q] && hi[q] <= 1.0))
            return CG_ERR_ARGUMENT;
    double x[AXIAL_POINTS], w[AXIAL_POINTS];
    cg_gauss_legendre01(AXIAL_POINTS, x, w);
    int threads = 1;
#ifdef _OPENMP
    threads = n_threads > 0 ? n_threads : omp_get_max_threads();
    if (n_pieces < 16 || threads < 1) threads = 1;
#else
    (void)n_threads;
#endif
    (void)threads;
#ifdef _OPENMP
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
#endif
    for (cg_index c = 0; c < n_columns; ++c) {
        double acc[9] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
        const double *node = bottoms + 3 * c;
        for (cg_index q = first[c]; q < first[c + 1]; ++q) {
            const double *a = starts + 3 * segment[q], *b = vectors + 3 * segment[q];
            const double *T = values + 9 * segment[q];
            const double s0 = lo[q], span = hi[q] - lo[q];
            const cg_index P = panels[q];
            double piece = 0.0;         /* int I ds over the piece (the tensor is constant on it) */
            for (cg_index jp = 0; jp < P; ++jp)
                for (int i = 0; i < AXIAL_POINTS; ++i) {
                    const double u = ((double)jp + x[i]) / (double)P;
                    const double sn = sin(0.5 * M_PI * u);
                    const double s = s0 + span * sn * sn;
                    const double weight = span * 0.5 * M_PI * sin(M_PI * u) * w[i] / (double)P;
                    double rel[3];
                    for (int d = 0; d < 3; ++d) rel[d] = node[d] - (a[d] + s * b[d]);
                    piece += weight * cg_kernel_line(kernel, rel, column, NULL);
                }
            for (int k = 0; k < 9; ++k) acc[k] += piece * T[k];
        }
        for (int k = 0; k < 9; ++k) out[9 * c + k] += acc[k];
    }
    return CG_OK;
}
