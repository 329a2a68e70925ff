/*
 * cg_internal.h -- what cg_scatter.c (loops over objects, images, threads)
 * shares with cg_separable.c (the Gaussian on grids as outer products) and
 * cg_kernels.c. Not part of the public interface (cg.h).
 */
#ifndef CGBOUND_CG_INTERNAL_H
#define CGBOUND_CG_INTERNAL_H

#include "cg.h"

#include <stddef.h>

/* the n-point Gauss-Legendre rule on [0, 1]: nodes x (increasing), weights w */
void cg_gauss_legendre01(int n, double *x, double *w);

/* cg_kernel_line with an explicit rule: n_points = 0 evaluates the integral
   to round-off, n_points > 0 applies the n-point Gauss-Legendre rule
   (Gaussian only; other kernels are always evaluated to round-off) */
double cg_kernel_line_rule(const cg_kernel *kernel, const double *q, const double *e, double *grad,
                           int n_points);

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
    int n_values;
    const double *values;      /* n x n_values */
    const double *masses;      /* fluctuation */
    const double *velocities;  /* fluctuation, n x D */
    const double *node_velocity; /* fluctuation, P x D */
    int out_width;             /* doubles per node in out */
    double lo[3], hi[3];       /* extent of the nodes along each resolved axis */
    double spacing[3];
    int separable;             /* use cg_visit_separable (Gaussian on a grid) */
    int wide;                  /* ... its AVX-512 build */
    int line_points;           /* the kernel's rule for finite segments (0: round-off) */
} job;

/* per-thread scratch memory of the separable path, grown on demand */
typedef struct scratch {
    double *buf;
    size_t cap;
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

/* Whether the separable path can take this object: returns 0 when the caller
   should use the node-by-node path instead. Otherwise visits every node of
   the object's stencil (one image at resolved position x, segment vector e,
   line integral multiplied by scale; ray: the segment is a cut ray and stays
   exact) and returns 1, or -1 if scratch memory could not be had. */
int cg_visit_separable(const job *jb, double *out, scratch *sc, cg_index obj, const double *x, const double *e,
                       double scale);

/* An AVX-512 build of the separable path (cg_separable_wide.c) exists on
   x86-64 with GCC; cg_separable_wide_available() says whether this CPU runs it
   (job.wide then selects it). */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(CGBOUND_NO_CLONES)
#define CG_HAVE_WIDE_SEPARABLE 1
int cg_visit_separable_wide(const job *jb, double *out, scratch *sc, cg_index obj, const double *x, const double *e,
                            double scale);
#endif
int cg_separable_wide_available(void);

#endif /* CGBOUND_CG_INTERNAL_H */
