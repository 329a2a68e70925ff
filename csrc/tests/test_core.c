/*
 * test_core.c -- tests of cgbound's C core (cg.h) without Python.
 *
 * Links cg_kernels.c, cg_scatter.c and cg_status.c only. Builds with
 * -std=c11 -Wall -Wextra -Werror, with or without -fopenmp, and is meant to
 * run clean under valgrind --leak-check=full. Prints "N passed, M failed" and
 * exits non-zero on any failure.
 *
 *   make -C csrc/tests check valgrind
 */
#define _POSIX_C_SOURCE 200809L /* sigaction, alarm, clock_gettime for the interrupt test */

#include "cg.h"

#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static int n_passed = 0, n_failed = 0;

#define CHECK(cond, ...)                                                    \
    do {                                                                    \
        if (cond) {                                                         \
            ++n_passed;                                                     \
        } else {                                                            \
            ++n_failed;                                                     \
            fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond); \
            fprintf(stderr, __VA_ARGS__);                                   \
            fputc('\n', stderr);                                            \
        }                                                                   \
    } while (0)

/* |a - b| <= tol * max(|b|, floor) */
static int close_to(double a, double b, double tol, double floor_)
{
    const double scale = fabs(b) > floor_ ? fabs(b) : floor_;
    return isfinite(a) && fabs(a - b) <= tol * scale;
}

#define CHECK_CLOSE(a, b, tol)                                                                        \
    do {                                                                                              \
        const double a_ = (a), b_ = (b);                                                              \
        CHECK(close_to(a_, b_, (tol), 1e-300), "%s = %.17g, expected %.17g (rel tol %g)", #a, a_, b_, \
              (double)(tol));                                                                         \
    } while (0)

#define CHECK_STATUS(call, expected)                                                                  \
    do {                                                                                              \
        const cg_status st_ = (call);                                                                 \
        CHECK(st_ == (expected), "status %d (%s), expected %d", (int)st_, cg_strerror(st_), (int)(expected)); \
    } while (0)

/* max |a - b| relative to max |b| */
static double max_rel_diff(const double *a, const double *b, size_t n)
{
    double err = 0.0, scale = 0.0;
    for (size_t i = 0; i < n; ++i) {
        if (!isfinite(a[i])) return INFINITY;
        const double d = fabs(a[i] - b[i]);
        if (d > err) err = d;
        if (fabs(b[i]) > scale) scale = fabs(b[i]);
    }
    return scale > 0.0 ? err / scale : err;
}

static int all_zero(const double *a, size_t n)
{
    for (size_t i = 0; i < n; ++i)
        if (a[i] != 0.0) return 0;
    return 1;
}

static cg_kernel make_kernel(int type, int dim, int n_resolved, double width, double radius)
{
    cg_kernel k;
    memset(&k, 0, sizeof k);
    k.type = type;
    k.dim = dim;
    k.n_resolved = n_resolved;
    k.width = width;
    k.radius = radius;
    k.avg_extent = 1.0;
    return k;
}

/* ------------------------------------------------------------------ */
/* targets and brute-force references                                   */

#define MAXN 64

typedef struct grid_store {
    double coords[3][MAXN];
} grid_store;

/* grid over the first nr data axes: shape[a] nodes from lo[a] with spacing h[a] */
static cg_target make_grid(grid_store *g, int dim, int nr, const cg_index *shape, const double *lo,
                           const double *h, const int *periodic)
{
    cg_target t;
    memset(&t, 0, sizeof t);
    t.dim = dim;
    t.n_resolved = nr;
    t.is_grid = 1;
    for (int a = 0; a < nr; ++a) {
        t.axes[a] = a;
        t.shape[a] = shape[a];
        for (cg_index i = 0; i < shape[a]; ++i) g->coords[a][i] = lo[a] + h[a] * (double)i;
        t.coords[a] = g->coords[a];
        t.periodic[a] = periodic ? periodic[a] : 0;
        t.period[a] = h[a] * (double)shape[a];
    }
    return t;
}

/* resolved coordinates of node p */
static void node_position(const cg_target *t, cg_index p, double *y)
{
    if (!t->is_grid) {
        for (int a = 0; a < t->n_resolved; ++a) y[a] = t->points[p * t->n_resolved + a];
        return;
    }
    for (int a = t->n_resolved - 1; a >= 0; --a) {
        y[a] = t->coords[a][p % t->shape[a]];
        p /= t->shape[a];
    }
}

typedef enum { REF_POINT, REF_SEGMENT } ref_kind;

/* out[p, k] (or out[p, k, d] with gradient) by a direct sum over objects and
   over images -3..3 along periodic axes (enough for R < 2 periods) */
static void reference_scatter(const cg_target *t, const cg_kernel *k, ref_kind kind, cg_index n,
                              const double *pos, const double *vec, int nv, const double *val, int gradient,
                              double *out)
{
    const int nr = t->n_resolved, D = t->dim;
    const cg_index P = cg_target_size(t);
    const int width = gradient ? nv * nr : nv;
    memset(out, 0, sizeof(double) * (size_t)P * (size_t)width);
    for (cg_index p = 0; p < P; ++p) {
        double y[3];
        node_position(t, p, y);
        for (cg_index o = 0; o < n; ++o) {
            int kk[3] = {0, 0, 0}, kmin[3] = {0, 0, 0}, kmax[3] = {0, 0, 0};
            for (int a = 0; a < nr; ++a)
                if (t->periodic[a]) { kmin[a] = -3; kmax[a] = 3; kk[a] = -3; }
            for (;;) {
                double q[3], e[3], grad[3] = {0.0, 0.0, 0.0}, w;
                for (int a = 0; a < nr; ++a) {
                    q[a] = y[a] - pos[o * D + t->axes[a]] - (t->periodic[a] ? kk[a] * t->period[a] : 0.0);
                    e[a] = vec ? vec[o * D + t->axes[a]] : 0.0;
                }
                if (kind == REF_SEGMENT)
                    w = cg_kernel_line(k, q, e, gradient ? grad : NULL);
                else if (gradient)
                    w = cg_kernel_gradient(k, q, grad);
                else {
                    double rho2 = 0.0;
                    for (int a = 0; a < nr; ++a) rho2 += q[a] * q[a];
                    w = cg_kernel_value(k, rho2);
                }
                for (int c = 0; c < nv; ++c) {
                    if (gradient)
                        for (int a = 0; a < nr; ++a) out[(p * nv + c) * nr + a] += grad[a] * val[o * nv + c];
                    else
                        out[p * nv + c] += w * val[o * nv + c];
                }
                int a = nr - 1;
                while (a >= 0) {
                    if (++kk[a] <= kmax[a]) break;
                    kk[a] = kmin[a];
                    --a;
                }
                if (a < 0) break;
            }
        }
    }
}

/* ------------------------------------------------------------------ */

static void test_strerror(void)
{
    const cg_status codes[] = {CG_OK, CG_ERR_ARGUMENT, CG_ERR_NOMEM, CG_ERR_DIVERGENT, CG_ERR_UNSUPPORTED,
                               CG_ERR_INTERRUPTED};
    const int n = (int)(sizeof codes / sizeof codes[0]);
    for (int i = 0; i < n; ++i) {
        const char *m = cg_strerror(codes[i]);
        CHECK(m != NULL && m[0] != '\0', "code %d has no message", (int)codes[i]);
        CHECK(m && strcmp(m, "unknown error") != 0, "code %d reported as unknown", (int)codes[i]);
        for (int j = 0; j < i; ++j)
            CHECK(m && strcmp(m, cg_strerror(codes[j])) != 0, "codes %d and %d share a message", i, j);
    }
    CHECK(strcmp(cg_strerror(CG_OK), "success") == 0, "%s", cg_strerror(CG_OK));
    CHECK(strstr(cg_strerror(CG_ERR_DIVERGENT), "ray") != NULL, "%s", cg_strerror(CG_ERR_DIVERGENT));
    CHECK(strcmp(cg_strerror((cg_status)99), "unknown error") == 0, "%s", cg_strerror((cg_status)99));
    CHECK(strcmp(cg_strerror((cg_status)-1), "unknown error") == 0, "%s", cg_strerror((cg_status)-1));
#ifdef _OPENMP
    CHECK(cg_have_openmp() == 1, "built with -fopenmp");
#else
    CHECK(cg_have_openmp() == 0, "built without -fopenmp");
#endif
}

static void test_kernel_init(void)
{
    /* good kernels and their prefactors */
    for (int D = 2; D <= 3; ++D) {
        const double w = 0.7;
        cg_kernel g = make_kernel(CG_KERNEL_GAUSSIAN, D, D, w, 5.0 * w);
        CHECK_STATUS(cg_kernel_init(&g), CG_OK);
        CHECK_CLOSE(g.prefactor, pow(2.0 * M_PI * w * w, -0.5 * D), 1e-14);
        cg_kernel l = make_kernel(CG_KERNEL_LUCY, D, D, 0.0, 1.3);
        CHECK_STATUS(cg_kernel_init(&l), CG_OK);
        const double C = D == 2 ? 5.0 / (M_PI * 1.3 * 1.3) : 105.0 / (16.0 * M_PI * pow(1.3, 3));
        CHECK_CLOSE(l.prefactor, C, 1e-14);
        cg_kernel h = make_kernel(CG_KERNEL_HEAVISIDE, D, D, 0.0, 0.8);
        CHECK_STATUS(cg_kernel_init(&h), CG_OK);
        const double V = D == 2 ? M_PI * 0.64 : 4.0 / 3.0 * M_PI * pow(0.8, 3);
        CHECK_CLOSE(h.prefactor, 1.0 / V, 1e-14);
        for (int nr = 0; nr <= D; ++nr) {
            for (int type = 0; type <= 2; ++type) {
                cg_kernel k = make_kernel(type, D, nr, 0.5, 1.5);
                k.avg_extent = 2.5;
                CHECK_STATUS(cg_kernel_init(&k), CG_OK);
                CHECK(k.prefactor > 0.0 && isfinite(k.prefactor), "prefactor %g", k.prefactor);
                if (nr == 0) CHECK_CLOSE(k.prefactor, 1.0 / 2.5, 1e-15);
            }
        }
    }
    /* truncated normalisation: the cut-off 2-D Gaussian integrates to 1 */
    cg_kernel t = make_kernel(CG_KERNEL_GAUSSIAN, 2, 2, 1.0, 2.0);
    t.truncated_norm = 1;
    CHECK_STATUS(cg_kernel_init(&t), CG_OK);
    CHECK_CLOSE(t.prefactor, 1.0 / (2.0 * M_PI * (1.0 - exp(-2.0))), 1e-14);

    /* bad kernels */
    struct { int type, dim, nr; double w, R, ext; } bad[] = {
        {CG_KERNEL_GAUSSIAN, 1, 1, 1.0, 1.0, 1.0},   /* dim 1 */
        {CG_KERNEL_GAUSSIAN, 4, 3, 1.0, 1.0, 1.0},   /* dim 4 */
        {CG_KERNEL_LUCY, 3, -1, 1.0, 1.0, 1.0},      /* negative n_resolved */
        {CG_KERNEL_LUCY, 2, 3, 1.0, 1.0, 1.0},       /* n_resolved > dim */
        {CG_KERNEL_LUCY, 3, 3, 1.0, 0.0, 1.0},       /* zero radius */
        {CG_KERNEL_LUCY, 3, 3, 1.0, -1.0, 1.0},      /* negative radius */
        {CG_KERNEL_LUCY, 3, 3, 1.0, NAN, 1.0},       /* NaN radius */
        {CG_KERNEL_HEAVISIDE, 3, 3, 1.0, INFINITY, 1.0},
        {CG_KERNEL_HEAVISIDE, 3, 2, 1.0, 1.0, 0.0},  /* zero averaged extent */
        {CG_KERNEL_HEAVISIDE, 3, 2, 1.0, 1.0, NAN},
        {CG_KERNEL_HEAVISIDE, 3, 2, 1.0, 1.0, INFINITY},
        {CG_KERNEL_GAUSSIAN, 3, 3, 0.0, 1.0, 1.0},   /* zero width */
        {CG_KERNEL_GAUSSIAN, 3, 3, NAN, 1.0, 1.0},
        {CG_KERNEL_GAUSSIAN, 2, 2, INFINITY, 1.0, 1.0},
        {CG_KERNEL_GAUSSIAN, 3, 0, -1.0, 1.0, 1.0},  /* bad width even when everything is averaged */
        {3, 3, 3, 1.0, 1.0, 1.0},                    /* unknown type */
        {-1, 2, 2, 1.0, 1.0, 1.0},
        {7, 3, 0, 1.0, 1.0, 1.0},                    /* unknown type, everything averaged */
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        cg_kernel k = make_kernel(bad[i].type, bad[i].dim, bad[i].nr, bad[i].w, bad[i].R);
        k.avg_extent = bad[i].ext;
        const cg_status st = cg_kernel_init(&k);
        CHECK(st == CG_ERR_ARGUMENT, "bad kernel #%zu accepted (status %d)", i, (int)st);
    }
}

/* 2-D midpoint sum of M over the resolved plane / 1-D over the resolved line */
static double integrate_marginal(const cg_kernel *k)
{
    const double R = k->radius;
    const int m = k->n_resolved == 1 ? 20000 : 1000;
    const double h = 2.0 * R / m;
    double sum = 0.0;
    if (k->n_resolved == 1) {
        for (int i = 0; i < m; ++i) {
            const double x = -R + (i + 0.5) * h;
            sum += cg_kernel_value(k, x * x) * h;
        }
    } else {
        for (int i = 0; i < m; ++i)
            for (int j = 0; j < m; ++j) {
                const double x = -R + (i + 0.5) * h, y = -R + (j + 0.5) * h;
                sum += cg_kernel_value(k, x * x + y * y) * h * h;
            }
    }
    return sum;
}

static void test_kernel_value(void)
{
    for (int D = 2; D <= 3; ++D) {
        const double w = 0.6;
        cg_kernel g = make_kernel(CG_KERNEL_GAUSSIAN, D, D, w, 4.0 * w);
        cg_kernel_init(&g);
        CHECK_CLOSE(cg_kernel_value(&g, 0.0), pow(2.0 * M_PI * w * w, -0.5 * D), 1e-14);
        CHECK_CLOSE(cg_kernel_value(&g, w * w), pow(2.0 * M_PI * w * w, -0.5 * D) * exp(-0.5), 1e-14);
        CHECK(cg_kernel_value(&g, 16.0 * w * w * 1.0001) == 0.0, "beyond the cutoff");
        CHECK(cg_kernel_value(&g, INFINITY) == 0.0, "at infinity");
        cg_kernel l = make_kernel(CG_KERNEL_LUCY, D, D, 0.0, 2.0);
        cg_kernel_init(&l);
        CHECK_CLOSE(cg_kernel_value(&l, 0.0), l.prefactor, 1e-15);
        CHECK_CLOSE(cg_kernel_value(&l, 1.0), l.prefactor * 2.5 * 0.125, 1e-14); /* x = 1/2 */
        CHECK(cg_kernel_value(&l, 4.0) == 0.0, "Lucy vanishes at the support edge");
        cg_kernel h = make_kernel(CG_KERNEL_HEAVISIDE, D, D, 0.0, 1.0);
        cg_kernel_init(&h);
        CHECK(cg_kernel_value(&h, 0.99) == h.prefactor && cg_kernel_value(&h, 1.01) == 0.0, "Heaviside ball");
    }
    /* Lucy's one-axis marginal at 0: 2 C R int_0^1 (1+3x)(1-x)^3 dx = 0.8 C R */
    cg_kernel lm = make_kernel(CG_KERNEL_LUCY, 3, 2, 0.0, 1.5);
    cg_kernel_init(&lm);
    CHECK_CLOSE(cg_kernel_value(&lm, 0.0), 0.8 * 105.0 / (16.0 * M_PI * pow(1.5, 3)) * 1.5, 1e-14);
    /* a marginal's value near the edge is continuous across the x = 1/2 switch */
    const double below = cg_kernel_value(&lm, pow(0.75 * (1.0 - 1e-12), 2)),
                 above = cg_kernel_value(&lm, pow(0.75 * (1.0 + 1e-12), 2));
    CHECK_CLOSE(below, above, 1e-9);
    /* every marginal integrates to 1 over the resolved subspace (avg_extent 1) */
    for (int D = 2; D <= 3; ++D)
        for (int nr = 1; nr <= 2 && nr <= D - 1; ++nr)
            for (int type = 0; type <= 2; ++type) {
                cg_kernel k = make_kernel(type, D, nr, 0.4, type == CG_KERNEL_GAUSSIAN ? 4.0 : 1.2);
                cg_kernel_init(&k);
                const double tol = type == CG_KERNEL_HEAVISIDE ? 1e-4 : 1e-6; /* edge singularity of sqrt */
                CHECK(close_to(integrate_marginal(&k), 1.0, tol, 1.0), "type %d D %d nr %d: integral %.12g", type,
                      D, nr, integrate_marginal(&k));
            }
    /* fully averaged: the value is the prefactor anywhere */
    cg_kernel avg = make_kernel(CG_KERNEL_LUCY, 3, 0, 0.0, 1.0);
    avg.avg_extent = 8.0;
    cg_kernel_init(&avg);
    CHECK(cg_kernel_value(&avg, 100.0) == 0.125, "%g", cg_kernel_value(&avg, 100.0));
}

static void test_kernel_gradient(void)
{
    const double x[3] = {0.31, -0.22, 0.17};
    for (int type = 0; type <= 2; ++type) {
        cg_kernel k = make_kernel(type, 3, 3, 0.5, 1.0);
        cg_kernel_init(&k);
        double grad[3], rho2 = 0.0;
        for (int d = 0; d < 3; ++d) rho2 += x[d] * x[d];
        const double v = cg_kernel_gradient(&k, x, grad);
        CHECK(v == cg_kernel_value(&k, rho2), "gradient returns the value");
        for (int d = 0; d < 3; ++d) {
            double xp[3] = {x[0], x[1], x[2]}, xm[3] = {x[0], x[1], x[2]}, g2[3];
            const double step = 1e-6;
            xp[d] += step;
            xm[d] -= step;
            const double fd = (cg_kernel_gradient(&k, xp, g2) - cg_kernel_gradient(&k, xm, g2)) / (2.0 * step);
            if (type == CG_KERNEL_HEAVISIDE)
                CHECK(grad[d] == 0.0, "Heaviside gradient is 0");
            else
                CHECK(close_to(grad[d], fd, 1e-7, k.prefactor), "type %d d %d: %.12g vs fd %.12g", type, d,
                      grad[d], fd);
        }
    }
    /* outside the support the gradient is zero */
    cg_kernel l = make_kernel(CG_KERNEL_LUCY, 2, 2, 0.0, 0.1);
    cg_kernel_init(&l);
    double g[2] = {1.0, 1.0};
    CHECK(cg_kernel_gradient(&l, x, g) == 0.0 && g[0] == 0.0 && g[1] == 0.0, "zero outside");
}

/* midpoint rule with m points for int_0^1 M(|q - s e|^2) ds */
static double brute_line(const cg_kernel *k, const double *q, const double *e, int m)
{
    double sum = 0.0;
    for (int i = 0; i < m; ++i) {
        const double s = (i + 0.5) / m;
        double rho2 = 0.0;
        for (int d = 0; d < k->n_resolved; ++d) {
            const double r = q[d] - s * e[d];
            rho2 += r * r;
        }
        sum += cg_kernel_value(k, rho2);
    }
    return sum / m;
}

static void test_kernel_line(void)
{
    const double q[3] = {0.2, -0.1, 0.15}, zero[3] = {0.0, 0.0, 0.0};
    /* a zero-length segment is the point value (and its gradient), exactly */
    for (int type = 0; type <= 2; ++type)
        for (int D = 2; D <= 3; ++D)
            for (int nr = 1; nr <= D; ++nr) {
                cg_kernel k = make_kernel(type, D, nr, 0.3, 0.9);
                cg_kernel_init(&k);
                double rho2 = 0.0;
                for (int d = 0; d < nr; ++d) rho2 += q[d] * q[d];
                CHECK(cg_kernel_line(&k, q, zero, NULL) == cg_kernel_value(&k, rho2), "type %d D %d nr %d", type,
                      D, nr);
                if (nr == D) {
                    double g1[3], g2[3];
                    cg_kernel_line(&k, q, zero, g1);
                    cg_kernel_gradient(&k, q, g2);
                    CHECK(memcmp(g1, g2, sizeof(double) * (size_t)nr) == 0, "zero-length gradient");
                }
            }
    /* Gaussian point value at 0 via a zero-length segment */
    cg_kernel g3 = make_kernel(CG_KERNEL_GAUSSIAN, 3, 3, 0.5, 2.5);
    cg_kernel_init(&g3);
    CHECK_CLOSE(cg_kernel_line(&g3, zero, zero, NULL), pow(2.0 * M_PI * 0.25, -1.5), 1e-14);

    /* Heaviside segment fully inside the ball: psi = prefactor */
    cg_kernel h = make_kernel(CG_KERNEL_HEAVISIDE, 3, 3, 0.0, 1.0);
    cg_kernel_init(&h);
    const double e_in[3] = {0.3, 0.2, -0.1};
    CHECK_CLOSE(cg_kernel_line(&h, q, e_in, NULL), h.prefactor, 1e-14);
    /* half of it inside: start at the centre, end 2R away along x */
    const double e_out[3] = {2.0, 0.0, 0.0};
    CHECK_CLOSE(cg_kernel_line(&h, zero, e_out, NULL), 0.5 * h.prefactor, 1e-14);
    /* entirely outside */
    const double far[3] = {5.0, 0.0, 0.0};
    CHECK(cg_kernel_line(&h, far, e_in, NULL) == 0.0, "outside");

    /* a long segment through the centre: L psi = the 1-D marginal at the
       perpendicular distance (2-D kernel, marginal over one axis) */
    for (int type = 0; type <= 2; ++type) {
        const double w = 0.4, R = type == CG_KERNEL_GAUSSIAN ? 12.0 * w : 1.1;
        cg_kernel k2 = make_kernel(type, 2, 2, w, R);
        cg_kernel k1 = make_kernel(type, 2, 1, w, R);
        cg_kernel_init(&k2);
        cg_kernel_init(&k1);
        const double perp = 0.3, L = 40.0;
        const double qq[2] = {L / 2.0, perp}, ee[2] = {L, 0.0}; /* node at (0, perp) from the middle */
        const double lhs = L * cg_kernel_line(&k2, qq, ee, NULL);
        /* the untruncated 1-D marginal for the Gaussian; exact for the compact kernels */
        const double rhs = type == CG_KERNEL_GAUSSIAN ? exp(-0.5 * perp * perp / (w * w)) / (sqrt(2.0 * M_PI) * w)
                                                      : cg_kernel_value(&k1, perp * perp);
        CHECK(close_to(lhs, rhs, type == CG_KERNEL_GAUSSIAN ? 1e-12 : 1e-11, 0.0), "type %d: %.15g vs %.15g", type,
              lhs, rhs);
    }

    /* against brute-force quadrature, random-ish geometry, every kernel and marginal */
    const double qs[4][3] = {{0.1, 0.2, -0.3}, {0.5, -0.4, 0.2}, {-0.05, 0.01, 0.02}, {1.2, 0.3, 0.1}};
    const double es[4][3] = {{0.8, -0.3, 0.5}, {-1.5, 0.9, 0.1}, {0.001, 0.002, -0.001}, {0.4, 0.0, 0.0}};
    for (int type = 0; type <= 2; ++type)
        for (int D = 2; D <= 3; ++D)
            for (int nr = 1; nr <= D; ++nr)
                for (int c = 0; c < 4; ++c) {
                    /* Gaussian: large cutoff so that the brute force has no jump */
                    const double R = type == CG_KERNEL_GAUSSIAN ? 20.0 * 0.35 : 0.9;
                    cg_kernel k = make_kernel(type, D, nr, 0.35, R);
                    cg_kernel_init(&k);
                    const double psi = cg_kernel_line(&k, qs[c], es[c], NULL);
                    double ref;
                    if (type == CG_KERNEL_GAUSSIAN) /* smooth: Richardson-extrapolated midpoint rule */
                        ref = (4.0 * brute_line(&k, qs[c], es[c], 20000) - brute_line(&k, qs[c], es[c], 10000)) / 3.0;
                    else if (type == CG_KERNEL_HEAVISIDE && nr == D) {
                        /* exact: prefactor x the fraction of [0, 1] with |q - s e| < R */
                        double ee = 0.0, qe = 0.0, qq = 0.0;
                        for (int d = 0; d < D; ++d) {
                            ee += es[c][d] * es[c][d];
                            qe += qs[c][d] * es[c][d];
                            qq += qs[c][d] * qs[c][d];
                        }
                        const double disc = qe * qe - ee * (qq - R * R);
                        double inside = 0.0;
                        if (disc > 0.0) {
                            const double s0 = fmax(0.0, (qe - sqrt(disc)) / ee), s1 = fmin(1.0, (qe + sqrt(disc)) / ee);
                            inside = fmax(0.0, s1 - s0);
                        }
                        ref = k.prefactor * inside;
                    } else
                        ref = brute_line(&k, qs[c], es[c], 40000);
                    /* midpoint error on kinks / sqrt edges of the compact marginals */
                    const double tol = type == CG_KERNEL_GAUSSIAN ? 1e-10 : type == CG_KERNEL_LUCY ? 1e-6 : 1e-5;
                    CHECK(close_to(psi, ref, tol, 1e-3 * k.prefactor), "type %d D %d nr %d case %d: %.15g vs %.15g",
                          type, D, nr, c, psi, ref);
                }

    /* line gradients against finite differences (full-dimensional kernels) */
    for (int type = 0; type <= 1; ++type)
        for (int c = 0; c < 4; ++c) {
            /* Gaussian: no clipping, whose jump the interior derivative leaves out */
            cg_kernel k = make_kernel(type, 3, 3, 0.35, type == CG_KERNEL_GAUSSIAN ? 20.0 * 0.35 : 0.9);
            cg_kernel_init(&k);
            double grad[3], gtmp[3];
            const double psi = cg_kernel_line(&k, qs[c], es[c], grad);
            CHECK(psi == cg_kernel_line(&k, qs[c], es[c], NULL), "value with and without gradient");
            for (int d = 0; d < 3; ++d) {
                double qp[3] = {qs[c][0], qs[c][1], qs[c][2]}, qm[3] = {qs[c][0], qs[c][1], qs[c][2]};
                const double step = 1e-6;
                qp[d] += step;
                qm[d] -= step;
                const double fd = (cg_kernel_line(&k, qp, es[c], gtmp) - cg_kernel_line(&k, qm, es[c], gtmp)) /
                                  (2.0 * step);
                CHECK(close_to(grad[d], fd, 1e-6, 1e-2 * k.prefactor), "type %d case %d d %d: %.12g vs %.12g", type,
                      c, d, grad[d], fd);
            }
        }
    /* fully averaged kernel: psi is the prefactor */
    cg_kernel avg = make_kernel(CG_KERNEL_GAUSSIAN, 2, 0, 1.0, 3.0);
    avg.avg_extent = 4.0;
    cg_kernel_init(&avg);
    CHECK(cg_kernel_line(&avg, q, e_in, NULL) == 0.25, "averaged line");
}

/* ------------------------------------------------------------------ */
/* scatters                                                             */

static void test_target_size_and_minimum_image(void)
{
    grid_store gs;
    const cg_index shape[3] = {3, 4, 5};
    const double lo[3] = {0.0, 0.0, 0.0}, h[3] = {1.0, 1.0, 1.0};
    cg_target t = make_grid(&gs, 3, 3, shape, lo, h, NULL);
    CHECK(cg_target_size(&t) == 60, "%lld", (long long)cg_target_size(&t));
    t.n_resolved = 0;
    CHECK(cg_target_size(&t) == 1, "no resolved axis: one node");
    cg_target p;
    memset(&p, 0, sizeof p);
    p.n_points = 7;
    CHECK(cg_target_size(&p) == 7, "points");

    double v[3 * 3] = {0.6, -0.6, 2.4, 0.4, 1.6, -3.1, 10.2, 0.0, 0.49};
    const int periodic[3] = {1, 0, 1};
    const double period[3] = {1.0, 1.0, 2.0};
    cg_minimum_image(3, 3, v, periodic, period);
    const double expect[9] = {-0.4, -0.6, 0.4, 0.4, 1.6, 0.9, 0.2, 0.0, 0.49};
    CHECK(max_rel_diff(v, expect, 9) < 1e-14, "minimum image %g %g %g / %g %g %g / %g %g %g", v[0], v[1], v[2], v[3],
          v[4], v[5], v[6], v[7], v[8]);
    cg_minimum_image(0, 3, v, periodic, period); /* n = 0: nothing to do */
}

/* one comparison: core result against the brute-force reference */
static void compare_scatter(const char *what, const cg_target *t, const cg_kernel *k, ref_kind kind, cg_index n,
                            const double *pos, const double *vec, int nv, const double *val, int gradient)
{
    const cg_index P = cg_target_size(t);
    const size_t size = (size_t)P * (size_t)(gradient ? nv * t->n_resolved : nv);
    double *out = calloc(size, sizeof(double)), *ref = calloc(size, sizeof(double));
    if (!out || !ref) {
        CHECK(0, "allocation");
        free(out);
        free(ref);
        return;
    }
    cg_status st = kind == REF_SEGMENT ? cg_scatter_segments(t, k, n, pos, vec, 0, nv, val, gradient, out)
                                       : cg_scatter_points(t, k, n, pos, nv, val, gradient, out);
    CHECK(st == CG_OK, "%s: status %d", what, (int)st);
    reference_scatter(t, k, kind, n, pos, vec, nv, val, gradient, ref);
    const double err = max_rel_diff(out, ref, size);
    CHECK(err < 1e-12, "%s: max relative difference %g", what, err);
    CHECK(!all_zero(ref, size), "%s: the reference is not trivially zero", what);
    /* accumulation: a second call adds the same amount again */
    st = kind == REF_SEGMENT ? cg_scatter_segments(t, k, n, pos, vec, 0, nv, val, gradient, out)
                             : cg_scatter_points(t, k, n, pos, nv, val, gradient, out);
    for (size_t i = 0; i < size; ++i) ref[i] *= 2.0;
    CHECK(st == CG_OK && max_rel_diff(out, ref, size) < 1e-12, "%s: out is accumulated into", what);
    free(out);
    free(ref);
}

/* objects scattered around a box [0, 4) x [0, 3) x [0, 5) (some outside it) */
static const double OBJ_POS[6 * 3] = {0.5, 0.4, 1.0,  3.9, 2.9, 4.8, 2.0, 1.5, 2.5,
                                      -0.3, 1.0, 0.2, 4.2, 3.2, 5.3, 1.1, 0.05, 4.9};
static const double OBJ_VEC[6 * 3] = {0.7, 0.2, -0.4, -1.0, 0.5, 0.3, 0.0, 0.0, 0.0,
                                      0.3, -0.6, 1.2, 0.05, 0.02, 0.01, -2.5, 1.0, 0.5};
static const double OBJ_VAL[6 * 2] = {1.0, -0.5, 2.0, 0.3, 0.7, 1.1, -1.2, 0.4, 0.9, 2.2, 1.5, -0.8};

static void test_scatter_grids(void)
{
    const cg_index shape[3] = {8, 6, 10};
    const double lo[3] = {0.25, 0.25, 0.25}, h[3] = {0.5, 0.5, 0.5};
    char what[128];
    for (int D = 2; D <= 3; ++D)
        for (int per = 0; per <= 1; ++per)
            for (int type = 0; type <= 2; ++type)
                for (int kind = 0; kind <= 1; ++kind)
                    for (int gradient = 0; gradient <= 1; ++gradient) {
                        if (gradient && type == CG_KERNEL_HEAVISIDE) continue; /* zero by definition */
                        /* D = 2 uses the x and z extents of the box */
                        const cg_index sh[3] = {shape[0], D == 2 ? shape[2] : shape[1], shape[2]};
                        const int periodic[3] = {per, 0, per};
                        grid_store gs;
                        cg_target t = make_grid(&gs, D, D, sh, lo, h, periodic);
                        cg_kernel k = make_kernel(type, D, D, 0.45, type == CG_KERNEL_GAUSSIAN ? 1.6 : 1.2);
                        cg_kernel_init(&k);
                        double pos[6 * 3], vec[6 * 3];
                        for (int o = 0; o < 6; ++o)
                            for (int d = 0; d < D; ++d) {
                                const int src = D == 2 && d == 1 ? 2 : d;
                                pos[o * D + d] = OBJ_POS[o * 3 + src];
                                vec[o * D + d] = OBJ_VEC[o * 3 + src];
                            }
                        snprintf(what, sizeof what, "grid D=%d periodic=%d kernel=%d %s gradient=%d", D, per, type,
                                 kind ? "segments" : "points", gradient);
                        compare_scatter(what, &t, &k, kind ? REF_SEGMENT : REF_POINT, 6, pos, vec, 2, OBJ_VAL,
                                        gradient);
                    }
    /* averaged axes: a 3-D kernel resolved along z only, and along x, z */
    for (int nr = 1; nr <= 2; ++nr)
        for (int type = 0; type <= 2; ++type)
            for (int kind = 0; kind <= 1; ++kind) {
                grid_store gs;
                cg_index sh[3] = {10, 10, 10};
                cg_target t = make_grid(&gs, 3, nr, sh, lo, h, NULL);
                t.axes[0] = nr == 1 ? 2 : 0;
                t.axes[1] = 2;
                cg_kernel k = make_kernel(type, 3, nr, 0.45, 1.2);
                k.avg_extent = nr == 1 ? 12.0 : 3.0;
                cg_kernel_init(&k);
                snprintf(what, sizeof what, "averaged nr=%d kernel=%d %s", nr, type, kind ? "segments" : "points");
                compare_scatter(what, &t, &k, kind ? REF_SEGMENT : REF_POINT, 6, OBJ_POS, OBJ_VEC, 2, OBJ_VAL, 0);
            }
}

static void test_scatter_points_target(void)
{
    const double pts[5 * 3] = {0.0, 0.0, 0.0, 1.0, 1.2, 2.0, 3.9, 2.9, 4.9, 2.0, 1.5, 2.6, 0.2, 2.8, 4.7};
    char what[128];
    for (int per = 0; per <= 1; ++per)
        for (int type = 0; type <= 2; ++type)
            for (int kind = 0; kind <= 1; ++kind) {
                cg_target t;
                memset(&t, 0, sizeof t);
                t.dim = 3;
                t.n_resolved = 3;
                t.axes[0] = 0;
                t.axes[1] = 1;
                t.axes[2] = 2;
                t.n_points = 5;
                t.points = pts;
                t.periodic[0] = per;
                t.period[0] = 4.0;
                t.periodic[1] = per;
                t.period[1] = 3.0;
                cg_kernel k = make_kernel(type, 3, 3, 0.5, 1.4);
                cg_kernel_init(&k);
                snprintf(what, sizeof what, "points periodic=%d kernel=%d %s", per, type,
                         kind ? "segments" : "points");
                compare_scatter(what, &t, &k, kind ? REF_SEGMENT : REF_POINT, 6, OBJ_POS, OBJ_VEC, 2, OBJ_VAL, 0);
                if (type != CG_KERNEL_HEAVISIDE) {
                    snprintf(what, sizeof what, "points periodic=%d kernel=%d %s gradient", per, type,
                             kind ? "segments" : "points");
                    compare_scatter(what, &t, &k, kind ? REF_SEGMENT : REF_POINT, 6, OBJ_POS, OBJ_VEC, 2, OBJ_VAL, 1);
                }
            }
}

/* mass conservation on a periodic grid (spectrally accurate trapezoid) */
static void test_mass_on_periodic_grid(void)
{
    grid_store gs;
    const cg_index sh[2] = {40, 40};
    const double lo[2] = {0.05, 0.05}, h[2] = {0.1, 0.1};
    const int periodic[2] = {1, 1};
    cg_target t = make_grid(&gs, 2, 2, sh, lo, h, periodic);
    /* a cutoff larger than the period: images on both sides */
    cg_kernel k = make_kernel(CG_KERNEL_GAUSSIAN, 2, 2, 0.5, 6.0);
    cg_kernel_init(&k);
    const double pos[3 * 2] = {0.3, 3.9, 2.2, 1.1, -7.5, 12.25}, mass[3] = {1.0, 2.0, 0.5};
    double *out = calloc(1600, sizeof(double));
    if (!out) { CHECK(0, "allocation"); return; }
    CHECK_STATUS(cg_scatter_points(&t, &k, 3, pos, 1, mass, 0, out), CG_OK);
    double total = 0.0;
    for (int i = 0; i < 1600; ++i) total += out[i] * 0.01;
    CHECK_CLOSE(total, 3.5, 1e-10);
    free(out);
}

static void test_fluctuation(void)
{
    grid_store gs;
    const cg_index sh[3] = {5, 4, 6};
    const double lo[3] = {0.4, 0.375, 0.4167}, h[3] = {0.8, 0.75, 0.8333};
    for (int per = 0; per <= 1; ++per) {
        const int periodic[3] = {per, per, 0};
        cg_target t = make_grid(&gs, 3, 3, sh, lo, h, periodic);
        cg_kernel k = make_kernel(CG_KERNEL_LUCY, 3, 3, 0.0, 1.3);
        cg_kernel_init(&k);
        const cg_index P = cg_target_size(&t);
        const double masses[6] = {1.0, 2.0, 0.5, 1.5, 0.7, 1.1};
        const double vel[6 * 3] = {0.1, 0.2, -0.3, 1.0, -1.0, 0.5, 0.0, 0.0, 0.0,
                                   -0.4, 0.3, 0.8, 2.0, 0.1, -0.2, 0.3, 0.3, 0.3};
        double *nodev = malloc(sizeof(double) * (size_t)P * 3), *out = calloc((size_t)P * 9, sizeof(double)),
               *ref = calloc((size_t)P * 9, sizeof(double));
        if (!nodev || !out || !ref) {
            CHECK(0, "allocation");
            free(nodev); free(out); free(ref);
            return;
        }
        for (cg_index p = 0; p < P; ++p)
            for (int d = 0; d < 3; ++d) nodev[p * 3 + d] = 0.1 * (double)((p + d) % 7) - 0.3;
        CHECK_STATUS(cg_scatter_fluctuation(&t, &k, 6, OBJ_POS, masses, vel, nodev, out), CG_OK);
        /* reference: weights from a one-column point scatter of each object */
        double *w = calloc((size_t)P, sizeof(double));
        if (!w) { CHECK(0, "allocation"); free(nodev); free(out); free(ref); return; }
        for (int o = 0; o < 6; ++o) {
            const double one = 1.0;
            memset(w, 0, sizeof(double) * (size_t)P);
            reference_scatter(&t, &k, REF_POINT, 1, OBJ_POS + 3 * o, NULL, 1, &one, 0, w);
            for (cg_index p = 0; p < P; ++p)
                for (int a = 0; a < 3; ++a)
                    for (int b = 0; b < 3; ++b)
                        ref[p * 9 + a * 3 + b] -= masses[o] * (vel[o * 3 + a] - nodev[p * 3 + a]) *
                                                  (vel[o * 3 + b] - nodev[p * 3 + b]) * w[p];
        }
        const double err = max_rel_diff(out, ref, (size_t)P * 9);
        CHECK(err < 1e-12, "fluctuation periodic=%d: %g", per, err);
        CHECK(!all_zero(ref, (size_t)P * 9), "non-trivial");
        /* symmetric and negative semi-definite diagonal */
        int ok = 1;
        for (cg_index p = 0; p < P; ++p)
            for (int a = 0; a < 3; ++a) {
                ok &= out[p * 9 + a * 4] <= 0.0;
                for (int b = 0; b < 3; ++b)
                    ok &= close_to(out[p * 9 + a * 3 + b], out[p * 9 + b * 3 + a], 1e-14, 1e-300);
            }
        CHECK(ok, "fluctuation stress symmetric with a non-positive diagonal");
        free(w);
        free(nodev);
        free(out);
        free(ref);
    }
}

static void test_rays(void)
{
    grid_store gs;
    const cg_index sh[2] = {12, 10};
    const double lo[2] = {0.25, 0.25}, h[2] = {0.5, 0.5};
    const int periodic[2] = {1, 0}; /* x periodic, z walls */
    cg_target t = make_grid(&gs, 2, 2, sh, lo, h, periodic);
    const cg_index P = cg_target_size(&t);
    for (int type = 0; type <= 2; ++type) {
        cg_kernel k = make_kernel(type, 2, 2, 0.4, type == CG_KERNEL_GAUSSIAN ? 1.6 : 1.0);
        cg_kernel_init(&k);
        /* a ray from inside pointing down and sideways: equals a long segment scaled by its length */
        const double start[2] = {2.1, 3.3}, dir[2] = {0.3, -0.8}, one = 1.0;
        const double S = 20.0; /* start + S dir is far below the target (z < -R) */
        const double longvec[2] = {S * dir[0], S * dir[1]};
        double *ray = calloc((size_t)P, sizeof(double)), *seg = calloc((size_t)P, sizeof(double));
        if (!ray || !seg) { CHECK(0, "allocation"); free(ray); free(seg); return; }
        CHECK_STATUS(cg_scatter_segments(&t, &k, 1, start, dir, 1, 1, &one, 0, ray), CG_OK);
        CHECK_STATUS(cg_scatter_segments(&t, &k, 1, start, longvec, 0, 1, &S, 0, seg), CG_OK);
        CHECK(max_rel_diff(ray, seg, (size_t)P) < 1e-11, "kernel %d: ray = S x long segment (%g)", type,
              max_rel_diff(ray, seg, (size_t)P));
        CHECK(!all_zero(ray, (size_t)P), "ray contributes");
        /* a ray from below pointing away from the target: no contribution */
        const double below[2] = {1.0, -5.0}, away[2] = {0.2, -1.0};
        memset(ray, 0, sizeof(double) * (size_t)P);
        CHECK_STATUS(cg_scatter_segments(&t, &k, 1, below, away, 1, 1, &one, 0, ray), CG_OK);
        CHECK(all_zero(ray, (size_t)P), "ray pointing away");
        /* a ray along the periodic axis never leaves: divergent, out untouched */
        const double along[2] = {1.0, 0.0};
        const double starts2[4] = {2.1, 3.3, 1.0, 1.0}, vecs2[4] = {0.0, -1.0, 1.0, 0.0}, vals2[2] = {1.0, 1.0};
        memset(ray, 0, sizeof(double) * (size_t)P);
        CHECK_STATUS(cg_scatter_segments(&t, &k, 1, start, along, 1, 1, &one, 0, ray), CG_ERR_DIVERGENT);
        CHECK_STATUS(cg_scatter_segments(&t, &k, 2, starts2, vecs2, 1, 1, vals2, 0, ray), CG_ERR_DIVERGENT);
        const double nothing[2] = {0.0, 0.0};
        CHECK_STATUS(cg_scatter_segments(&t, &k, 1, start, nothing, 1, 1, &one, 0, ray), CG_ERR_DIVERGENT);
        CHECK(all_zero(ray, (size_t)P), "divergent rays leave out untouched");
        /* the same direction as a finite segment is fine */
        CHECK_STATUS(cg_scatter_segments(&t, &k, 1, start, along, 0, 1, &one, 0, ray), CG_OK);
        free(ray);
        free(seg);
    }
    /* nearly parallel to a periodic axis: too many images, divergent rather than endless */
    {
        cg_kernel k = make_kernel(CG_KERNEL_LUCY, 2, 2, 0.0, 1.0);
        cg_kernel_init(&k);
        const double start[2] = {1.0, 2.0}, dir[2] = {1.0, -1e-12}, one = 1.0;
        double *out = calloc((size_t)P, sizeof(double));
        if (!out) { CHECK(0, "allocation"); return; }
        CHECK_STATUS(cg_scatter_segments(&t, &k, 1, start, dir, 1, 1, &one, 0, out), CG_ERR_DIVERGENT);
        free(out);
    }
    /* everything averaged: any ray is divergent, but no rays at all is fine */
    {
        cg_target t0 = t;
        t0.n_resolved = 0;
        cg_kernel k = make_kernel(CG_KERNEL_LUCY, 2, 0, 0.0, 1.0);
        cg_kernel_init(&k);
        const double start[2] = {1.0, 2.0}, dir[2] = {0.0, -1.0}, one = 1.0;
        double out = 0.0;
        CHECK_STATUS(cg_scatter_segments(&t0, &k, 1, start, dir, 1, 1, &one, 0, &out), CG_ERR_DIVERGENT);
        CHECK_STATUS(cg_scatter_segments(&t0, &k, 0, NULL, NULL, 1, 1, NULL, 0, &out), CG_OK);
        CHECK(out == 0.0, "untouched");
    }
    /* gradients of rays against a long segment */
    {
        cg_kernel k = make_kernel(CG_KERNEL_GAUSSIAN, 2, 2, 0.4, 1.6);
        cg_kernel_init(&k);
        const double start[2] = {2.1, 3.3}, dir[2] = {0.3, -0.8}, one = 1.0, S = 20.0;
        const double longvec[2] = {S * dir[0], S * dir[1]};
        double *a = calloc((size_t)P * 2, sizeof(double)), *b = calloc((size_t)P * 2, sizeof(double));
        if (!a || !b) { CHECK(0, "allocation"); free(a); free(b); return; }
        CHECK_STATUS(cg_scatter_segments(&t, &k, 1, start, dir, 1, 1, &one, 1, a), CG_OK);
        CHECK_STATUS(cg_scatter_segments(&t, &k, 1, start, longvec, 0, 1, &S, 1, b), CG_OK);
        CHECK(max_rel_diff(a, b, (size_t)P * 2) < 1e-11, "ray gradient %g", max_rel_diff(a, b, (size_t)P * 2));
        free(a);
        free(b);
    }
}

static void test_errors_and_empty(void)
{
    grid_store gs;
    const cg_index sh[3] = {4, 4, 4};
    const double lo[3] = {0.5, 0.5, 0.5}, h[3] = {1.0, 1.0, 1.0};
    cg_target t = make_grid(&gs, 3, 3, sh, lo, h, NULL);
    cg_kernel k = make_kernel(CG_KERNEL_LUCY, 3, 3, 0.0, 1.5);
    cg_kernel_init(&k);
    double out[64 * 9];
    memset(out, 0, sizeof out);
    const double masses[6] = {1, 1, 1, 1, 1, 1}, nodev[64 * 3] = {0};

    /* n = 0: OK, nothing written; NULL arrays are never read */
    CHECK_STATUS(cg_scatter_points(&t, &k, 0, NULL, 1, NULL, 0, out), CG_OK);
    CHECK_STATUS(cg_scatter_points(&t, &k, 0, NULL, 2, NULL, 1, out), CG_OK);
    CHECK_STATUS(cg_scatter_segments(&t, &k, 0, NULL, NULL, 0, 1, NULL, 0, out), CG_OK);
    CHECK_STATUS(cg_scatter_segments(&t, &k, 0, NULL, NULL, 1, 1, NULL, 0, out), CG_OK);
    CHECK_STATUS(cg_scatter_fluctuation(&t, &k, 0, NULL, NULL, NULL, nodev, out), CG_OK);
    CHECK(all_zero(out, 64 * 9), "n = 0 writes nothing");

    /* zero evaluation points */
    cg_target none;
    memset(&none, 0, sizeof none);
    none.dim = 3;
    none.n_resolved = 3;
    none.axes[1] = 1;
    none.axes[2] = 2;
    none.n_points = 0;
    CHECK_STATUS(cg_scatter_points(&none, &k, 6, OBJ_POS, 1, masses, 0, NULL), CG_OK);
    CHECK_STATUS(cg_scatter_segments(&none, &k, 6, OBJ_POS, OBJ_VEC, 0, 1, masses, 0, NULL), CG_OK);

    /* no resolved axis: one node, each object adds prefactor * value */
    {
        cg_target t0 = t;
        t0.n_resolved = 0;
        cg_kernel k0 = make_kernel(CG_KERNEL_GAUSSIAN, 3, 0, 1.0, 3.0);
        k0.avg_extent = 64.0;
        cg_kernel_init(&k0);
        double one_node[2] = {0.0, 0.0};
        CHECK_STATUS(cg_scatter_points(&t0, &k0, 6, OBJ_POS, 2, OBJ_VAL, 0, one_node), CG_OK);
        double sum0 = 0.0, sum1 = 0.0;
        for (int o = 0; o < 6; ++o) { sum0 += OBJ_VAL[2 * o]; sum1 += OBJ_VAL[2 * o + 1]; }
        CHECK_CLOSE(one_node[0], sum0 / 64.0, 1e-14);
        CHECK_CLOSE(one_node[1], sum1 / 64.0, 1e-14);
        double seg_node = 0.0;
        CHECK_STATUS(cg_scatter_segments(&t0, &k0, 6, OBJ_POS, OBJ_VEC, 0, 1, masses, 0, &seg_node), CG_OK);
        CHECK_CLOSE(seg_node, 6.0 / 64.0, 1e-14);
        /* a point set with no resolved axis: every point gets the same value */
        cg_target p0;
        memset(&p0, 0, sizeof p0);
        p0.dim = 3;
        p0.n_points = 4;
        double four[4 * 2];
        memset(four, 0, sizeof four);
        CHECK_STATUS(cg_scatter_points(&p0, &k0, 6, OBJ_POS, 2, OBJ_VAL, 0, four), CG_OK);
        for (int p = 0; p < 4; ++p) {
            CHECK_CLOSE(four[2 * p], sum0 / 64.0, 1e-14);
            CHECK_CLOSE(four[2 * p + 1], sum1 / 64.0, 1e-14);
        }
    }

    /* bad arguments */
    CHECK_STATUS(cg_scatter_points(&t, &k, -1, OBJ_POS, 1, masses, 0, out), CG_ERR_ARGUMENT);
    CHECK_STATUS(cg_scatter_points(&t, &k, 6, OBJ_POS, 0, masses, 0, out), CG_ERR_ARGUMENT);
    CHECK_STATUS(cg_scatter_segments(&t, &k, -3, OBJ_POS, OBJ_VEC, 0, 1, masses, 0, out), CG_ERR_ARGUMENT);
    CHECK_STATUS(cg_scatter_segments(&t, &k, 6, OBJ_POS, OBJ_VEC, 0, 0, masses, 0, out), CG_ERR_ARGUMENT);
    CHECK_STATUS(cg_scatter_fluctuation(&t, &k, -1, OBJ_POS, masses, OBJ_POS, nodev, out), CG_ERR_ARGUMENT);
    cg_kernel k2 = make_kernel(CG_KERNEL_LUCY, 2, 2, 0.0, 1.5);
    cg_kernel_init(&k2);
    CHECK_STATUS(cg_scatter_points(&t, &k2, 6, OBJ_POS, 1, masses, 0, out), CG_ERR_ARGUMENT); /* dim mismatch */
    cg_kernel k32 = make_kernel(CG_KERNEL_LUCY, 3, 2, 0.0, 1.5);
    cg_kernel_init(&k32);
    CHECK_STATUS(cg_scatter_points(&t, &k32, 6, OBJ_POS, 1, masses, 0, out), CG_ERR_ARGUMENT); /* n_resolved */
    {
        cg_target bad = t;
        bad.shape[1] = 0;
        CHECK_STATUS(cg_scatter_points(&bad, &k, 6, OBJ_POS, 1, masses, 0, out), CG_ERR_ARGUMENT);
        bad = t;
        bad.periodic[0] = 1;
        bad.period[0] = 0.0;
        CHECK_STATUS(cg_scatter_points(&bad, &k, 6, OBJ_POS, 1, masses, 0, out), CG_ERR_ARGUMENT);
        bad.period[0] = NAN;
        CHECK_STATUS(cg_scatter_segments(&bad, &k, 6, OBJ_POS, OBJ_VEC, 0, 1, masses, 0, out), CG_ERR_ARGUMENT);
    }
    CHECK(all_zero(out, 64 * 9), "errors write nothing");

    /* gradients over averaged axes: Heaviside's and Lucy's segments are unsupported; Lucy's points
       (cg_gradient.c) and the Gaussian's are fine */
    {
        grid_store g2;
        const cg_index s2[2] = {4, 4};
        cg_target ta = make_grid(&g2, 3, 2, s2, lo, h, NULL);
        cg_kernel lucy = make_kernel(CG_KERNEL_LUCY, 3, 2, 0.0, 1.5);
        cg_kernel heav = make_kernel(CG_KERNEL_HEAVISIDE, 3, 2, 0.0, 1.5);
        cg_kernel gau = make_kernel(CG_KERNEL_GAUSSIAN, 3, 2, 0.5, 1.5);
        cg_kernel_init(&lucy);
        cg_kernel_init(&heav);
        cg_kernel_init(&gau);
        CHECK_STATUS(cg_scatter_segments(&ta, &lucy, 6, OBJ_POS, OBJ_VEC, 0, 1, masses, 1, out),
                     CG_ERR_UNSUPPORTED);
        CHECK_STATUS(cg_scatter_points(&ta, &heav, 6, OBJ_POS, 1, masses, 1, out), CG_ERR_UNSUPPORTED);
        CHECK_STATUS(cg_scatter_segments(&ta, &heav, 6, OBJ_POS, OBJ_VEC, 0, 1, masses, 1, out),
                     CG_ERR_UNSUPPORTED);
        CHECK(all_zero(out, 64 * 9), "unsupported writes nothing");
        CHECK_STATUS(cg_scatter_points(&ta, &lucy, 6, OBJ_POS, 1, masses, 1, out), CG_OK);
        CHECK(!all_zero(out, 16 * 2), "Lucy marginal gradient");
        CHECK_STATUS(cg_scatter_points(&ta, &gau, 6, OBJ_POS, 1, masses, 1, out), CG_OK);
        CHECK(!all_zero(out, 16 * 2), "Gaussian marginal gradient");
        /* Lucy's marginal gradients (one and two averaged axes) against central differences of the value,
           on both sides of x = 0.5 where G switches from its closed form to quadrature */
        for (int n_res = 1; n_res <= 2; ++n_res) {
            cg_kernel lm = make_kernel(CG_KERNEL_LUCY, 3, n_res, 0.0, 1.5);
            cg_kernel_init(&lm);
            const double pts[4][2] = {{0.1, 0.2}, {0.5, -0.3}, {-0.9, 0.6}, {1.2, 0.3}};
            for (int p = 0; p < 4; ++p) {
                double g[2], x[2] = {pts[p][0], pts[p][1]};
                cg_kernel_gradient(&lm, x, g);
                for (int d = 0; d < n_res; ++d) {
                    const double hh = 1e-5;
                    double xp[2] = {x[0], x[1]}, xm[2] = {x[0], x[1]};
                    xp[d] += hh;
                    xm[d] -= hh;
                    double rp = 0.0, rm = 0.0;
                    for (int e = 0; e < n_res; ++e) { rp += xp[e] * xp[e]; rm += xm[e] * xm[e]; }
                    const double fd = (cg_kernel_value(&lm, rp) - cg_kernel_value(&lm, rm)) / (2 * hh);
                    CHECK(fabs(fd - g[d]) <= 1e-8 * (fabs(g[d]) + 1e-3), "Lucy marginal gradient vs differences");
                }
            }
        }
    }
}

static volatile sig_atomic_t alarm_flag = 0;
_Static_assert(sizeof(sig_atomic_t) == sizeof(int), "the core polls an int");

static void on_alarm(int signum)
{
    (void)signum;
    alarm_flag = 1;
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void test_interrupt(void)
{
    grid_store gs;
    const cg_index sh[3] = {30, 30, 30};
    const double lo[3] = {0.05, 0.05, 0.05}, h[3] = {0.1, 0.1, 0.1};
    cg_target t = make_grid(&gs, 3, 3, sh, lo, h, NULL);
    volatile int flag = 1;
    t.interrupt = &flag;
    /* a flag already set: every entry point stops before any object */
    cg_kernel k = make_kernel(CG_KERNEL_GAUSSIAN, 3, 3, 1.0, 100.0);
    cg_kernel_init(&k);
    double *out = calloc(27000 * 3, sizeof(double)), *nodev = calloc(27000 * 3, sizeof(double)),
           *out9 = calloc(27000 * 9, sizeof(double));
    if (!out || !nodev || !out9) { CHECK(0, "allocation"); free(out); free(nodev); free(out9); return; }
    const double pos[3] = {1.5, 1.5, 1.5}, vec[3] = {0.5, 0.1, 0.0}, one = 1.0, vel[3] = {0.0, 0.0, 0.0};
    CHECK_STATUS(cg_scatter_points(&t, &k, 1, pos, 1, &one, 0, out), CG_ERR_INTERRUPTED);
    CHECK_STATUS(cg_scatter_points(&t, &k, 1, pos, 1, &one, 1, out), CG_ERR_INTERRUPTED);
    CHECK_STATUS(cg_scatter_segments(&t, &k, 1, pos, vec, 0, 1, &one, 0, out), CG_ERR_INTERRUPTED);
    CHECK_STATUS(cg_scatter_segments(&t, &k, 1, pos, vec, 1, 1, &one, 0, out), CG_ERR_INTERRUPTED);
    CHECK_STATUS(cg_scatter_fluctuation(&t, &k, 1, pos, &one, vel, nodev, out9), CG_ERR_INTERRUPTED);
    double many[300], vals[100];
    for (int i = 0; i < 300; ++i) many[i] = 0.01 * i;
    for (int i = 0; i < 100; ++i) vals[i] = 1.0;
    CHECK_STATUS(cg_scatter_points(&t, &k, 100, many, 1, vals, 0, out), CG_ERR_INTERRUPTED);
    /* a flag that stays zero changes nothing */
    flag = 0;
    memset(out, 0, sizeof(double) * 27000);
    cg_kernel small = make_kernel(CG_KERNEL_LUCY, 3, 3, 0.0, 0.3);
    cg_kernel_init(&small);
    CHECK_STATUS(cg_scatter_points(&t, &small, 1, pos, 1, &one, 0, out), CG_OK);
    CHECK(!all_zero(out, 27000), "not interrupted");
    free(out);
    free(nodev);
    free(out9);

    /* the flag set by a signal 1 s into two objects that would each take many
       seconds (a support of thousands of periods: millions of images of 100
       nodes each): the poll inside the image and node loops stops them, on
       every thread */
    grid_store gp;
    const cg_index shp[2] = {10, 10};
    const double lop[2] = {0.05, 0.05}, hp[2] = {0.1, 0.1};
    const int periodic[2] = {1, 1};
    cg_target tp = make_grid(&gp, 2, 2, shp, lop, hp, periodic);
    tp.interrupt = (const volatile int *)&alarm_flag;
    cg_kernel huge = make_kernel(CG_KERNEL_LUCY, 2, 2, 0.0, 2000.0);
    cg_kernel_init(&huge);
    struct sigaction sa, old;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_alarm;
    sigemptyset(&sa.sa_mask);
    CHECK(sigaction(SIGALRM, &sa, &old) == 0, "sigaction");
    double grid_out[100] = {0.0};
    const double two_pos[4] = {0.5, 0.5, 0.2, 0.7}, two_val[2] = {1.0, 1.0};
    alarm_flag = 0;
    alarm(1);
    const double start = now();
    const cg_status st = cg_scatter_points(&tp, &huge, 2, two_pos, 1, two_val, 0, grid_out);
    const double elapsed = now() - start;
    alarm(0);
    sigaction(SIGALRM, &old, NULL);
    CHECK(st == CG_ERR_INTERRUPTED, "status %d after %.2f s", (int)st, elapsed);
    CHECK(elapsed < 2.5, "stopped %.2f s after the start (the alarm rang at 1 s)", elapsed);
    CHECK(alarm_flag == 1, "the alarm rang");
}

int main(void)
{
    test_strerror();
    test_kernel_init();
    test_kernel_value();
    test_kernel_gradient();
    test_kernel_line();
    test_target_size_and_minimum_image();
    test_scatter_grids();
    test_scatter_points_target();
    test_mass_on_periodic_grid();
    test_fluctuation();
    test_rays();
    test_errors_and_empty();
    test_interrupt();
    printf("%d passed, %d failed\n", n_passed, n_failed);
    return n_failed == 0 ? 0 : 1;
}
