/*
 * cg_fstat.c -- the contacts of a MercuryDPM .fstat frame (cg_fstat.h).
 *
 * One pass over the lines computes each line's force and checks what can be
 * checked line by line; when the pair lines come in turn (both sides of each
 * pair on consecutive pair lines, pairs in increasing order, as cgbound's
 * writer puts them) the kept lines are written in that same pass. Otherwise
 * the pair lines are grouped by their pair (a counting sort on the smaller
 * index, then each bucket sorted by the larger index and the line), which is
 * the order a stable sort of the pairs gives, and the groups are checked and
 * kept from there. Every floating-point expression is written as the NumPy
 * code it replaces evaluates it (the order of sums noted where it matters).
 */
#include "cg_fstat.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Python's max(x, floor): x unless floor > x (so a NaN x stays NaN) */
static double py_max(double x, double floor_value) { return floor_value > x ? floor_value : x; }

/* sum of squares in component order, as np.add.reduce(v * v, axis=1) sums a row */
static double squares(const double *v, int d)
{
    double s = v[0] * v[0] + v[1] * v[1];
    if (d == 3) s += v[2] * v[2];
    return s;
}

/* arm = x_i - c (minimum image), proj = n . arm, force on i = s (fn n + ft t); returns proj */
static double line_force(const cg_fstat_frame *f, int64_t k, double *arm, double *force)
{
    const int d = f->dim;
    const double *r = f->rows + k * f->row_stride;
    const double *x = f->positions + f->partners[2 * k] * d;
    for (int c = 0; c < d; ++c) {
        double a = x[c] - r[3 + c];
        if (f->periodic[c]) {
            const double L = f->period[c];
            if (fabs(a) > 0.5 * L) a -= L * nearbyint(a / L);
        }
        arm[c] = a;
    }
    /* np.einsum("ij,ij->i") sums a 3-vector's products as (p0 + p2) + p1 */
    const double proj = d == 3 ? (r[10] * arm[0] + r[12] * arm[2]) + r[11] * arm[1] : r[10] * arm[0] + r[11] * arm[1];
    const double fn = r[8], ft = r[9];
    for (int c = 0; c < d; ++c) {
        double g = fn * r[10 + c];
        g += ft * r[13 + c];
        force[c] = proj < 0 ? -g : g;
    }
    return proj;
}

/* the flat test: the normal perpendicular to the arm, with a nonzero force (bound: the frame's B) */
static int is_flat(const cg_fstat_frame *f, int64_t k, const double *arm, double proj, double bound)
{
    const double *r = f->rows + k * f->row_stride;
    if (!(r[8] != 0 || r[9] != 0)) return 0;
    const double norm = sqrt(squares(arm, f->dim));
    const double m = norm < 1e-300 ? 1e-300 : norm; /* np.maximum: a NaN norm stays NaN */
    if (!(fabs(proj) <= 1e-12 * m)) return 0;
    return isnan(bound) ? 0 : fabs(proj) <= 1e-12 * py_max(bound, 1e-300);
}

static void write_kept(const cg_fstat_frame *f, cg_fstat_result *out, int64_t k, const double *force)
{
    const int d = f->dim;
    const double *r = f->rows + k * f->row_stride;
    const int64_t i = f->partners[2 * k], j = f->partners[2 * k + 1], n = out->n_kept;
    out->i[n] = i;
    out->j[n] = j < 0 ? -1 : j;
    out->wall[n] = j < 0 ? -1 - j : -1;
    for (int c = 0; c < d; ++c) {
        out->force[n * d + c] = force[c];
        out->point[n * d + c] = r[3 + c];
    }
    out->overlap[n] = r[6];
    out->n_kept = n + 1;
}

static int by_value(const void *a, const void *b)
{
    const int64_t p = *(const int64_t *)a, q = *(const int64_t *)b;
    return (p > q) - (p < q);
}

typedef struct pair_line {
    int64_t hi, line;
} pair_line;

static int by_hi_then_line(const void *a, const void *b)
{
    const pair_line *p = (const pair_line *)a, *q = (const pair_line *)b;
    if (p->hi != q->hi) return p->hi < q->hi ? -1 : 1;
    return (p->line > q->line) - (p->line < q->line);
}

/* |f_p + f_q| and |c_p - c_q| as np.linalg.norm computes them */
static void pair_gaps(const cg_fstat_frame *f, int64_t p, int64_t q, const double *fp, const double *fq, double *df,
                      double *dc)
{
    const int d = f->dim;
    double s[3] = {0, 0, 0}, t[3] = {0, 0, 0};
    const double *cp = f->rows + p * f->row_stride + 3, *cq = f->rows + q * f->row_stride + 3;
    for (int c = 0; c < d; ++c) {
        s[c] = fp[c] + fq[c];
        t[c] = cp[c] - cq[c];
    }
    *df = sqrt(squares(s, d));
    *dc = sqrt(squares(t, d));
}

/* Whether a pair is listed in two places when the pair lines come in turn (each pair's two lines consecutive,
   so the line with i < j names each listing once): a counting sort of those lines on i, then a look for a
   repeated j within each bucket. 1 if one is, 0 if not, -1 if the scratch cannot be allocated. */
static int pairs_repeat(const cg_fstat_frame *f)
{
    const int64_t m = f->n_rows, n = f->n_particles;
    const int64_t *P = f->partners;
    int64_t *start = calloc((size_t)n + 2, sizeof *start), *hi = NULL;
    int64_t n_pairs = 0;
    if (!start) return -1;
    for (int64_t k = 0; k < m; ++k) {
        const int64_t i = P[2 * k], j = P[2 * k + 1];
        if (j >= 0 && i < j) {
            ++start[i + 2];
            ++n_pairs;
        }
    }
    hi = malloc(((size_t)n_pairs + 1) * sizeof *hi);
    if (!hi) {
        free(start);
        return -1;
    }
    for (int64_t a = 0; a < n; ++a) start[a + 2] += start[a + 1];
    for (int64_t k = 0; k < m; ++k) { /* start[a + 1]: the next free place of bucket a */
        const int64_t i = P[2 * k], j = P[2 * k + 1];
        if (j >= 0 && i < j) hi[start[i + 1]++] = j;
    }
    int repeat = 0;
    for (int64_t a = 0; a < n && !repeat; ++a) { /* bucket a: hi[start[a] .. start[a + 1]) */
        const int64_t lo = start[a], len = start[a + 1] - lo;
        if (len > 24) {
            qsort(hi + lo, (size_t)len, sizeof *hi, by_value);
            for (int64_t x = 1; x < len && !repeat; ++x) repeat = hi[lo + x] == hi[lo + x - 1];
        } else {
            for (int64_t x = 1; x < len && !repeat; ++x)
                for (int64_t y = 0; y < x && !repeat; ++y) repeat = hi[lo + x] == hi[lo + y];
        }
    }
    free(start);
    free(hi);
    return repeat;
}

/* The general pairing: groups of lines by pair, checked; the kept lines written in file order. */
static cg_status pair_by_groups(const cg_fstat_frame *f, cg_fstat_result *out, double tol_force, double tol_point)
{
    const int64_t m = f->n_rows, n = f->n_particles;
    const int64_t *P = f->partners;
    int64_t *start = calloc((size_t)n + 1, sizeof *start);
    pair_line *lines = NULL;
    unsigned char *keep = calloc((size_t)m + 1, 1);
    int64_t n_pairs = 0;
    for (int64_t k = 0; k < m; ++k) n_pairs += P[2 * k + 1] >= 0;
    lines = malloc(((size_t)n_pairs + 1) * sizeof *lines);
    if (!start || !keep || !lines) {
        free(start);
        free(keep);
        free(lines);
        return CG_ERR_NOMEM;
    }
    for (int64_t k = 0; k < m; ++k) {
        const int64_t i = P[2 * k], j = P[2 * k + 1];
        if (j >= 0) ++start[(i < j ? i : j) + 1];
    }
    for (int64_t a = 0; a < n; ++a) start[a + 1] += start[a];
    for (int64_t k = 0; k < m; ++k) { /* in file order: each bucket's lines in increasing line order */
        const int64_t i = P[2 * k], j = P[2 * k + 1];
        if (j < 0) continue;
        const int64_t lo = i < j ? i : j;
        lines[start[lo]].hi = i < j ? j : i;
        lines[start[lo]].line = k;
        ++start[lo];
    }
    for (int64_t a = n; a > 0; --a) start[a] = start[a - 1]; /* back to the buckets' starts */
    start[0] = 0;
    /* each bucket by (hi, line); buckets are short (a particle's contacts) */
    for (int64_t a = 0; a < n; ++a) {
        pair_line *b = lines + start[a];
        const int64_t len = start[a + 1] - start[a];
        if (len > 24) {
            qsort(b, (size_t)len, sizeof *b, by_hi_then_line);
            continue;
        }
        for (int64_t x = 1; x < len; ++x) {
            const pair_line v = b[x];
            int64_t y = x;
            while (y > 0 && (b[y - 1].hi > v.hi || (b[y - 1].hi == v.hi && b[y - 1].line > v.line))) {
                b[y] = b[y - 1];
                --y;
            }
            b[y] = v;
        }
    }
    /* the groups: the bad one (repeated or inconsistent) whose first line comes first; else a lonely one */
    int64_t bad_row = -1, lonely_row = -1;
    double arm[3], fa[3] = {0, 0, 0}, fb[3] = {0, 0, 0}; /* (2-D: the third entries stay 0) */
    for (int64_t a = 0; a < n; ++a) {
        for (int64_t g = start[a]; g < start[a + 1];) {
            int64_t h = g + 1;
            while (h < start[a + 1] && lines[h].hi == lines[g].hi) ++h;
            const int64_t count = h - g, k1 = lines[g].line, k2 = count == 2 ? lines[g + 1].line : k1;
            const int repeated = count > 2 || (count == 2 && P[2 * k1] == P[2 * k2]);
            if (repeated) {
                if (bad_row < 0 || k1 < bad_row) {
                    bad_row = k1;
                    out->problem = CG_FSTAT_REPEATED;
                    out->row = k1;
                    out->pair_lo = a;
                    out->pair_hi = lines[g].hi;
                    out->count = count;
                }
            } else if (count == 2) {
                line_force(f, k1, arm, fa);
                line_force(f, k2, arm, fb);
                double df, dc;
                pair_gaps(f, k1, k2, fa, fb, &df, &dc);
                if ((df > tol_force || dc > tol_point) && (bad_row < 0 || k1 < bad_row)) {
                    bad_row = k1;
                    out->problem = CG_FSTAT_INCONSISTENT;
                    out->row = k1;
                    out->other_row = k2;
                    out->pair_lo = a;
                    out->pair_hi = lines[g].hi;
                    out->count = 2;
                    out->df = df;
                    out->dc = dc;
                    memcpy(out->force_row, fa, sizeof fa);
                    memcpy(out->force_other, fb, sizeof fb);
                }
                keep[P[2 * k1] < P[2 * k2] ? k1 : k2] = 1;
            } else {
                if (!f->fixed[P[2 * k1]] && !f->fixed[P[2 * k1 + 1]] && (lonely_row < 0 || k1 < lonely_row))
                    lonely_row = k1;
                keep[k1] = 1;
            }
            g = h;
        }
    }
    free(start);
    free(lines);
    if (bad_row >= 0 || lonely_row >= 0) {
        if (bad_row < 0) {
            out->problem = CG_FSTAT_ONCE;
            out->row = lonely_row;
        }
        free(keep);
        return CG_ERR_FSTAT_LINES;
    }
    out->n_kept = 0;
    for (int64_t k = 0; k < m; ++k) {
        if (P[2 * k + 1] >= 0 && !keep[k]) continue;
        line_force(f, k, arm, fa);
        write_kept(f, out, k, fa);
    }
    free(keep);
    return CG_OK;
}

cg_status cg_fstat_contacts(const cg_fstat_frame *f, cg_fstat_result *out)
{
    if (!f || !out) return CG_ERR_ARGUMENT;
    out->n_kept = 0;
    out->problem = CG_FSTAT_NONE;
    out->row = out->other_row = out->pair_lo = out->pair_hi = -1;
    out->count = 0;
    out->df = out->dc = 0.0;
    if (f->dim != 2 && f->dim != 3) return CG_ERR_ARGUMENT;
    if (f->n_rows < 0 || f->n_particles < 0 || f->row_stride < CG_FSTAT_COLUMNS) return CG_ERR_ARGUMENT;
    if (f->n_rows > 0 && (!f->rows || !f->partners || !f->positions || !f->radii || !f->fixed || !f->periodic ||
                          !f->period || !out->i || !out->j || !out->wall || !out->force || !out->point ||
                          !out->overlap))
        return CG_ERR_ARGUMENT;
    const int64_t m = f->n_rows, n = f->n_particles;
    const int64_t *P = f->partners;
    const int d = f->dim;
    /* the first line of each line-by-line problem */
    int64_t first[CG_FSTAT_FLAT + 1];
    for (int p = 0; p <= CG_FSTAT_FLAT; ++p) first[p] = -1;
    int broken = 0;               /* a problem before FLAT: the rest only looks for those */
    double max_arm = 0.0;         /* the largest |arm component| (NaN if one is NaN) */
    int arm_nan = 0;
    double max_square = -INFINITY; /* the largest |force|^2 (np.max: NaN if one is NaN) */
    int square_nan = 0, any_pair = 0;
    /* in turn: pending = the first line of a pair waiting for its other side */
    int in_turn = 1;
    int64_t pending = -1, last_lo = -1, last_hi = -1;
    int increasing = 1; /* the pairs in increasing order (then none can repeat) */
    double pending_force[3] = {0, 0, 0}, df_max = -INFINITY, dc_max = -INFINITY;
    for (int64_t k = 0; k < m; ++k) {
        const double *r = f->rows + k * f->row_stride;
        if (fabs(r[0] - f->time) > f->time_tolerance && first[CG_FSTAT_TIME] < 0) first[CG_FSTAT_TIME] = k;
        const int64_t i = P[2 * k], j = P[2 * k + 1];
        if (i < 0 || i >= n) {
            if (first[CG_FSTAT_PARTICLE] < 0) first[CG_FSTAT_PARTICLE] = k;
            broken = 1;
            continue;
        }
        if (j >= n && first[CG_FSTAT_GHOST] < 0) first[CG_FSTAT_GHOST] = k;
        if (j == i && first[CG_FSTAT_SELF] < 0) first[CG_FSTAT_SELF] = k;
        broken = broken || first[CG_FSTAT_TIME] >= 0 || first[CG_FSTAT_GHOST] >= 0 || first[CG_FSTAT_SELF] >= 0;
        if (broken) continue;
        double arm[3], force[3];
        const double proj = line_force(f, k, arm, force);
        for (int c = 0; c < d; ++c) {
            const double a = fabs(arm[c]);
            if (isnan(a)) arm_nan = 1;
            else if (a > max_arm) max_arm = a;
        }
        if (first[CG_FSTAT_FLAT] < 0 && is_flat(f, k, arm, proj, INFINITY)) first[CG_FSTAT_FLAT] = k;
        const double sq = squares(force, d);
        if (isnan(sq)) square_nan = 1;
        else if (sq > max_square) max_square = sq;
        if (j < 0) {
            write_kept(f, out, k, force);
            continue;
        }
        any_pair = 1;
        if (!in_turn) continue;
        if (pending < 0) {
            pending = k;
            memcpy(pending_force, force, sizeof force);
        } else {
            const int64_t pi = P[2 * pending], pj = P[2 * pending + 1];
            const int64_t lo = i < j ? i : j, hi = i < j ? j : i;
            if (i != pj || j != pi) {
                in_turn = 0;
                continue;
            }
            if (lo < last_lo || (lo == last_lo && hi <= last_hi)) increasing = 0;
            last_lo = lo;
            last_hi = hi;
            double s[3] = {0, 0, 0}, t[3] = {0, 0, 0};
            const double *cp = f->rows + pending * f->row_stride + 3;
            for (int c = 0; c < d; ++c) {
                s[c] = pending_force[c] + force[c];
                t[c] = cp[c] - r[3 + c];
            }
            const double df = squares(s, d), dc = squares(t, d); /* np.fmax.reduce: NaN skipped */
            if (df > df_max) df_max = df;
            if (dc > dc_max) dc_max = dc;
            pending = -1;
        }
        if (i < j) write_kept(f, out, k, force);
    }
    for (int p = CG_FSTAT_TIME; p <= CG_FSTAT_SELF; ++p) {
        if (first[p] >= 0) {
            out->problem = (cg_fstat_problem)p;
            out->row = first[p];
            return CG_ERR_FSTAT_LINES;
        }
    }
    if (first[CG_FSTAT_FLAT] >= 0) { /* a candidate: the first line flat also against the frame's bound */
        const double bound = arm_nan ? NAN : 2.0 * sqrt((double)d) * max_arm;
        for (int64_t k = first[CG_FSTAT_FLAT]; k < m; ++k) {
            double arm[3], force[3];
            const double proj = line_force(f, k, arm, force);
            if (is_flat(f, k, arm, proj, bound)) {
                out->problem = CG_FSTAT_FLAT;
                out->row = k;
                return CG_ERR_FSTAT_LINES;
            }
        }
    }
    if (!any_pair) return CG_OK;
    const double scale = square_nan ? NAN : sqrt(max_square);
    double lscale = 1.0;
    if (n > 0) {
        double largest = f->radii[0]; /* np.max: NaN if one is NaN */
        for (int64_t a = 1; a < n && !isnan(largest); ++a)
            if (isnan(f->radii[a]) || f->radii[a] > largest) largest = f->radii[a];
        lscale = 2.0 * largest;
    }
    const double tol_force = f->rtol * py_max(scale, 1e-300), tol_point = f->rtol * lscale;
    if (in_turn && pending < 0 && !(sqrt(df_max) > tol_force) && !(sqrt(dc_max) > tol_point)) {
        const int repeat = increasing ? 0 : pairs_repeat(f);
        if (repeat < 0) return CG_ERR_NOMEM;
        if (!repeat) return CG_OK;
    }
    out->n_kept = 0;
    return pair_by_groups(f, out, tol_force, tol_point);
}
