/*
 * cg_lucy.c -- Lucy's line integral in closed form.
 *
 * W = C (1 + 3x)(1 - x)^3 = C (1 - 6x^2 + 8x^3 - 3x^4), x = r/R, is a
 * polynomial in r = sqrt(a^2 + t^2) along a segment (a: distance of the node
 * from the segment's line, t: signed position along it). The even powers
 * integrate to polynomials in t; r^3 and r (the gradient's) to
 *   int r^3 dt = t r^3/4 + 3a^2 t r/8 + 3a^4 asinh(t/a)/8,
 *   int r dt   = t r/2 + a^2 asinh(t/a)/2.
 * Written naively as F(t0) - F(t1) these cancel for short pieces (all digits
 * for a segment 1e-10 R long). So the interval is cut at t = 0 and each
 * piece reflected onto 0 <= p <= q; every difference is then taken in a
 * divided form whose terms have one sign:
 *   q^k - p^k         = (q - p) (q^(k-1) + ... + p^(k-1)),
 *   r_q - r_p         = (q - p)(q + p) / (r_q + r_p),
 *   asinh(q/a) - asinh(p/a) = log1p((q - p + r_q - r_p) / (p + r_p)),
 * the last free of 1/a (so a -> 0 needs no case).
 * What cancellation remains is that of W itself near the support's edge,
 * an absolute error of order eps C (the field's scale), never relative to 1/L.
 */
#include "cg_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* one piece [p, q] (units of R, 0 <= p <= q, d = q - p given accurately),
   added into acc: [0] += int P, [1] += int (1 - x)^2, [2] += sign int t (1 - x)^2 */
static void lucy_piece(double a2, double p, double q, double d, double sign, int want_grad, double *acc)
{
    if (!(d > 0.0)) return;
    const double p2 = p * p, q2 = q * q, qp = q * p, sum = q + p;
    const double rp = sqrt(a2 + p2), rq = sqrt(a2 + q2);
    const double J2 = d * (q2 + qp + p2) * (1.0 / 3.0);            /* int t^2 */
    const double J4 = d * (q2 * q2 + qp * (q2 + p2) + qp * qp + p2 * p2) * 0.2; /* int t^4 */
    const double Jr2 = a2 * d + J2;                                 /* int r^2 */
    const double Jr4 = a2 * a2 * d + 2.0 * a2 * J2 + J4;            /* int r^4 */
    const double dr = d * sum / (rq + rp);                          /* r_q - r_p */
    const double rr = rq * rq + rq * rp + rp * rp;
    const double D2 = d * rq + p * dr;                              /* q r_q - p r_p */
    const double D1 = d * rq * rq * rq + p * dr * rr;               /* q r_q^3 - p r_p^3 */
    /* asinh(q/a) - asinh(p/a) = log((q + r_q)/(p + r_p)); its factor a^2 (a^4)
       makes it vanish with a (and p + r_p = 0 only when a = p = 0) */
    const double D3 = a2 > 0.0 ? log1p((d + dr) / (p + rp)) : 0.0;
    const double Jr3 = 0.25 * D1 + 0.375 * a2 * D2 + 0.375 * a2 * a2 * D3; /* int r^3 */
    acc[0] += d - 6.0 * Jr2 + 8.0 * Jr3 - 3.0 * Jr4;
    if (want_grad) {
        const double Jr1 = 0.5 * D2 + 0.5 * a2 * D3;               /* int r */
        acc[1] += d - 2.0 * Jr1 + Jr2;
        const double T1 = 0.5 * d * sum;                            /* int t */
        const double Tr1 = dr * rr * (1.0 / 3.0);                           /* int t r = (r_q^3 - r_p^3)/3 */
        const double Tr2 = a2 * T1 + 0.25 * d * sum * (q2 + p2);    /* int t r^2 */
        acc[2] += sign * (T1 - 2.0 * Tr1 + Tr2);
    }
}

void cg_lucy_line(double a2, double t0, double t1, double span, double R, int want_grad, double *acc)
{
    const double inv = 1.0 / R, s2 = a2 * inv * inv;
    acc[0] = acc[1] = acc[2] = 0.0;
    if (t1 >= 0.0) {
        lucy_piece(s2, t1 * inv, t0 * inv, span * inv, 1.0, want_grad, acc);
    } else if (t0 <= 0.0) {
        lucy_piece(s2, -t0 * inv, -t1 * inv, span * inv, -1.0, want_grad, acc);
    } else {
        lucy_piece(s2, 0.0, t0 * inv, t0 * inv, 1.0, want_grad, acc);
        lucy_piece(s2, 0.0, -t1 * inv, -t1 * inv, -1.0, want_grad, acc);
    }
}

double cg_lucy_segment(const cg_kernel *k, const segment_axis *ax, const double *q, const double *e, double *grad)
{
    const int n = k->n_resolved;
    const double R = k->radius;
    double q3[3] = {0.0, 0.0, 0.0}, n3[3] = {0.0, 0.0, 0.0}, e3[3] = {0.0, 0.0, 0.0};
    for (int d = 0; d < n; ++d) {
        q3[d] = q[d];
        n3[d] = ax->unit[d];
        e3[d] = e[d];
    }
    /* the value as the row path (cg_visit_lucy) computes it (cg_lucy_line.c) */
    const double psi = k->prefactor * (R / ax->L) * cg_lucy_value(q3, n3, e3, ax->L, R);
    if (!grad) return psi;
    for (int d = 0; d < n; ++d) grad[d] = 0.0;
    segment_frame f;
    node_frame(n, ax, q, e, &f);
    double s0, s1, b;
    if (!clip_to_support(&f, R, &s0, &s1, &b)) return psi;
    double acc[3];
    cg_lucy_line(f.a2, t_at(&f, s0), t_at(&f, s1), (s1 - s0) * f.L, R, 1, acc);
    /* grad W = -12 C (1 - x)^2 (r_vec) / R^2, r_vec = q_perp + t n */
    const double factor = -12.0 * k->prefactor / (R * R);
    const double g_perp = R / f.L * acc[1], g_along = R * R / f.L * acc[2];
    for (int d = 0; d < n; ++d) grad[d] = factor * (f.qperp[d] * g_perp + f.unit[d] * g_along);
    return psi;
}

/* a box of at most this many times the capsule's volume (plus 8 nodes) is
   evaluated whole rather than narrowed */
#define LUCY_BOX_RATIO 2.0

/* nodes and rows per batch of cg_visit_lucy */
#define LUCY_BATCH 256
#define LUCY_ROWS 64

/* batches are evaluated in whole vectors of this many nodes (AVX-512's 8
   doubles; a multiple of AVX2's 4); LUCY_BATCH is a multiple of it */
#define LUCY_LANES 8

/* cg_visit_lucy's state for one object: the rows gathered (offsets along the
   axes before the row axis, unused ones 0) and the candidate nodes gathered
   (offsets along every axis, unused ones 0), each evaluated a batch at a time */
typedef struct lucy_visit {
    const job *jb;
    double *out;
    cg_index obj;
    int nr, row, narrow, wide;
    cg_index k_first, k_last;   /* the stencil box along the row axis */
    const double *zc;           /* the row axis' coordinates */
    double x_row, L, R, factor, scale;
    double n3[3], e3[3];
    lucy_row_params P;
    int nrows, count;
    int heaviside;              /* Heaviside's kernel (else Lucy's) */
    double f[2][LUCY_ROWS], klo[LUCY_ROWS], khi[LUCY_ROWS];
    cg_index rbase[LUCY_ROWS];
    double qb[3][LUCY_BATCH], w[LUCY_BATCH];
    double fu[LUCY_BATCH], ft[LUCY_BATCH], fa[LUCY_BATCH]; /* the nodes' frames (cg_lucy_frames) */
    int keep[LUCY_BATCH];
    cg_index node[LUCY_BATCH];
} lucy_visit;

static void lucy_values_add(lucy_visit *v, int m);

/* the gathered nodes' weights (cg_lucy_line.c): their frames, those that may
   reach the segment kept (compacted in place), their values, then each
   non-zero one into out */
static void lucy_values_flush(lucy_visit *v)
{
    if (v->count == 0) return;
    /* whole vectors (no scalar remainder loops): the lanes past count get
       node 0's offsets and past m a frame outside the support; their
       results are not used */
    const int count = v->count, padded = (count + LUCY_LANES - 1) & -LUCY_LANES;
    for (int i = count; i < padded; ++i)
        for (int a = 0; a < 3; ++a) v->qb[a][i] = v->qb[a][0];
    if (!v->heaviside) {
        /* Lucy: frames and values in one pass over every gathered node (a
           node beyond the support gets 0, as lucy_may_reach would have
           dropped it): cheaper than compacting the few far nodes away */
        cg_lucy_values(padded, v->qb[0], v->qb[1], v->qb[2], v->n3, v->e3, v->L, v->R, v->factor, v->w, v->wide);
        v->count = 0;
        lucy_values_add(v, count);
        return;
    }
    cg_lucy_frames(padded, v->qb[0], v->qb[1], v->qb[2], v->n3, v->e3, v->R, v->fu, v->ft, v->fa, v->keep,
                   v->heaviside, v->wide);
    int m = 0;
    for (int i = 0; i < count; ++i) {
        v->fu[m] = v->fu[i];
        v->ft[m] = v->ft[i];
        v->fa[m] = v->fa[i];
        v->node[m] = v->node[i];
        m += v->keep[i];
    }
    v->count = 0;
    if (m == 0) return;
    const int m_padded = (m + LUCY_LANES - 1) & -LUCY_LANES;
    for (int i = m; i < m_padded; ++i) {
        v->fu[i] = v->ft[i] = 0.0;
        v->fa[i] = 4.0 * v->R * v->R;
    }
    cg_heaviside_values_frame(m_padded, v->fu, v->ft, v->fa, v->L, v->R, v->factor, v->w, v->wide);
    lucy_values_add(v, m);
}

/* the first m weights (of nodes v->node) into out */
static void lucy_values_add(lucy_visit *v, int m)
{
    const job *jb = v->jb;
    const double scale = v->scale;
    if (jb->n_values == 9 && jb->out_width == 9) {
        /* a 3-D tensor (the contact stress): cg_accumulate's MODE_VALUE sums, vectorised */
        cg_lucy_add9(m, v->w, v->node, scale, jb->values + v->obj * 9, v->out, v->wide);
    } else {
        for (int i = 0; i < m; ++i) {
            const double wi = v->w[i] * scale;
            if (wi != 0.0) cg_accumulate(jb, v->out, v->obj, v->node[i], wi, NULL);
        }
    }
}

/* the gathered rows' candidate nodes, gathered in turn */
static void lucy_rows_flush(lucy_visit *v)
{
    if (v->nrows == 0) return;
    if (v->narrow) cg_lucy_rows(v->nrows, v->f[0], v->f[1], &v->P, v->klo, v->khi, v->wide);
    const int row = v->row;
    for (int r = 0; r < v->nrows; ++r) {
        cg_index k0 = v->k_first, k1 = v->k_last;
        if (v->narrow) {
            const double lo = v->klo[r], hi = v->khi[r];
            if (!(lo <= hi && lo <= (double)k1 && hi >= (double)k0)) continue;
            if (lo > (double)k0) k0 = (cg_index)lo;
            if (hi < (double)k1) k1 = (cg_index)hi;
        }
        for (cg_index k = k0; k <= k1; ++k) {
            if (v->count == LUCY_BATCH) lucy_values_flush(v);
            const int c = v->count++;
            for (int a = 0; a < row; ++a) v->qb[a][c] = v->f[a][r];
            v->qb[row][c] = v->zc[k] - v->x_row;
            v->node[c] = v->rbase[r] + k;
        }
    }
    v->nrows = 0;
}

static void lucy_add_row(lucy_visit *v, double f0, double f1, cg_index base)
{
    if (v->nrows == LUCY_ROWS) lucy_rows_flush(v);
    v->f[0][v->nrows] = f0;
    v->f[1][v->nrows] = f1;
    v->rbase[v->nrows++] = base;
}

/* every node of the box first..last (2-D or 3-D), no narrowing: rows of
   nodes gathered a run at a time (runs of a few nodes: scalar code beats
   the vectoriser's set-up); a box that fits in the batch (the common case)
   without checking the batch's room, its row offsets formed once */
#if defined(__GNUC__) && !defined(__clang__)
__attribute__((optimize("no-tree-vectorize")))
#endif
static void lucy_add_box(lucy_visit *v, const cg_target *t, const double *x, const cg_index *first,
                         const cg_index *last, const cg_index *stride)
{
    const int row = v->row;
    const cg_index n0 = row == 2 ? last[0] - first[0] + 1 : 1;
    const cg_index k0 = first[row], k1 = last[row], nk = k1 - k0 + 1;
    const cg_index ja = first[row - 1], jb_ = last[row - 1], sj = stride[row - 1];
    const double *zc = v->zc, xr = v->x_row, *yc = t->coords[row - 1], xj = x[row - 1];
    /* 3-D: (f0, fj, z) into (q0, q1, q2); 2-D: (fj, z, 0) */
    double *qa = v->qb[0], *qj = v->qb[row - 1], *qz = v->qb[row], *q2 = v->qb[2];
    cg_index *node = v->node;
    int c = v->count;
    const int fits = n0 * (jb_ - ja + 1) * nk <= LUCY_BATCH - c;
    double zq[LUCY_BATCH];
    if (fits)
        for (cg_index m = 0; m < nk; ++m) zq[m] = zc[k0 + m] - xr;
    for (cg_index i = 0; i < n0; ++i) {
        const cg_index ii = row == 2 ? first[0] + i : 0;
        const double f0 = row == 2 ? t->coords[0][ii] - x[0] : 0.0;
        cg_index base = (row == 2 ? ii * stride[0] : 0) + ja * sj + k0;
        for (cg_index j = ja; j <= jb_; ++j, base += sj) {
            const double fj = yc[j] - xj;
            if (fits) {
                double *pa = qa + c, *pj = qj + c, *pz = qz + c, *p2 = q2 + c;
                cg_index *pn = node + c;
                for (cg_index m = 0; m < nk; ++m) {
                    if (row == 2) pa[m] = f0; else p2[m] = 0.0;
                    pj[m] = fj;
                    pz[m] = zq[m];
                    pn[m] = base + m;
                }
                c += (int)nk;
                continue;
            }
            for (cg_index k = 0; k < nk;) {
                if (c == LUCY_BATCH) {
                    v->count = c;
                    lucy_values_flush(v);
                    c = 0;
                }
                const cg_index room = LUCY_BATCH - c, left = nk - k;
                const int run = (int)(left < room ? left : room);
                for (int m = 0; m < run; ++m) {
                    if (row == 2) qa[c + m] = f0; else q2[c + m] = 0.0;
                    qj[c + m] = fj;
                    qz[c + m] = zc[k0 + k + m] - xr;
                    node[c + m] = base + k + m;
                }
                c += run;
                k += run;
            }
        }
    }
    v->count = c;
}

/* the state of one object (lucy_visit) up to its rows */
static void lucy_visit_init(lucy_visit *v, const job *jb, double *out, cg_index obj, const double *x,
                            const double *e, const segment_axis *ax, double scale)
{
    const int nr = jb->target->n_resolved;
    const double R = jb->kernel->radius;
    v->jb = jb;
    v->out = out;
    v->obj = obj;
    v->nr = nr;
    v->row = nr - 1; /* the last resolved axis: contiguous in the output */
    v->zc = jb->target->coords[nr - 1];
    v->x_row = x[nr - 1];
    v->L = ax->L;
    v->R = R;
    v->heaviside = jb->kernel->type == CG_KERNEL_HEAVISIDE;
    v->factor = v->heaviside ? jb->kernel->prefactor : jb->kernel->prefactor * (R / ax->L);
    v->scale = scale;
    v->wide = jb->wide;
    v->nrows = v->count = 0;
    for (int a = 0; a < 3; ++a) v->n3[a] = v->e3[a] = 0.0;
    for (int a = 0; a < nr; ++a) {
        v->n3[a] = ax->unit[a];
        v->e3[a] = e[a];
    }
}

/* nodes and segments per batch of lucy_batch (several segments' boxes
   evaluated at once), and its arrays' slack past the last node (for
   whole vectors: cg_lucy_batch_values, lucy_box_rows) */
#define LUCY_BATCH_NODES 256
#define LUCY_BATCH_SEGS 32
#define LUCY_SLACK 16

/* Lucy's boxes waiting for their values: the nodes of segments
   0..nseg - 1 (start[s]..start[s + 1] - 1) with each segment's geometry
   (cg_lucy_batch_values' geom), weight factor, scale and 9 values (copied:
   with factors the job's values are rewritten for each object) */
struct lucy_batch {
    double *out;
    double R;
    int wide, count, nseg;
    int start[LUCY_BATCH_SEGS + 1], cstart[LUCY_BATCH_SEGS + 1];
    double geom[7 * LUCY_BATCH_SEGS], factor[LUCY_BATCH_SEGS], scale[LUCY_BATCH_SEGS], val[9 * LUCY_BATCH_SEGS];
    double qb[3][LUCY_BATCH_NODES + LUCY_SLACK];
    cg_index node[LUCY_BATCH_NODES + LUCY_SLACK], node_c[LUCY_BATCH_NODES + LUCY_SLACK];
    double u[LUCY_BATCH_NODES + LUCY_SLACK], t_far[LUCY_BATCH_NODES + LUCY_SLACK];
    double a2[LUCY_BATCH_NODES + LUCY_SLACK], Ld[LUCY_BATCH_NODES + LUCY_SLACK], w[LUCY_BATCH_NODES + LUCY_SLACK];
};

/* the waiting segments' values, then their terms into out, segment after segment */
static void lucy_batch_run(struct lucy_batch *b)
{
    if (b->nseg == 0) return;
    cg_lucy_batch_values(b->nseg, b->start, b->geom, b->qb[0], b->qb[1], b->qb[2], b->node, b->R, b->u, b->t_far,
                         b->a2, b->Ld, b->w, b->node_c, b->cstart, b->wide);
    cg_lucy_batch_add9(b->nseg, b->cstart, b->factor, b->scale, b->val, b->w, b->node_c, b->out, b->wide);
    b->nseg = b->count = 0;
}

void cg_lucy_batch_flush(scratch *sc)
{
    if (!sc->lucy) return;
    lucy_batch_run(sc->lucy);
    free(sc->lucy);
    sc->lucy = NULL;
}

typedef double lucy_v4d __attribute__((vector_size(32)));
typedef cg_index lucy_v4i __attribute__((vector_size(32)));

/* every node of the box first..last (2-D or 3-D) into the batch after its
   nodes (they fit), as lucy_add_box gathers them; a row of at most 8 nodes
   (a box a little longer than a short segment) stored as whole vectors, the
   lanes past its end rewritten by the next row or left in the slack */
static inline __attribute__((always_inline)) void lucy_box_rows(struct lucy_batch *b, int row, const cg_target *t,
                                                                const double *x, const cg_index *first,
                                                                const cg_index *last, const cg_index *stride)
{
    const cg_index n0 = row == 2 ? last[0] - first[0] + 1 : 1;
    const cg_index k0 = first[row], nk = last[row] - k0 + 1;
    const cg_index ja = first[row - 1], jb_ = last[row - 1], sj = stride[row - 1];
    const double *zc = t->coords[row], xr = x[row], *yc = t->coords[row - 1], xj = x[row - 1];
    /* 3-D: (f0, fj, z) into (q0, q1, q2); 2-D: (fj, z, 0) */
    double *qa = row == 2 ? b->qb[0] : b->qb[2], *qj = b->qb[row - 1], *qz = b->qb[row];
    cg_index *node = b->node;
    int c = b->count;
    if (nk <= 8) {
        /* 4 lanes, or 8 as two vectors of 4 (AVX2's width; a 64-byte vector
           type would go through memory there) */
        const lucy_v4i iota = {0, 1, 2, 3}, four = {4, 4, 4, 4};
        double zq[8];
        for (int m = 0; m < 8; ++m) zq[m] = m < nk ? zc[k0 + m] - xr : 0.0;
        lucy_v4d z0, z1;
        memcpy(&z0, zq, sizeof z0);
        memcpy(&z1, zq + 4, sizeof z1);
        const int two = nk > 4;
        for (cg_index i = 0; i < n0; ++i) {
            const cg_index ii = row == 2 ? first[0] + i : 0;
            const double f0 = row == 2 ? t->coords[0][ii] - x[0] : 0.0;
            const lucy_v4d f0v = {f0, f0, f0, f0};
            cg_index base = (row == 2 ? ii * stride[0] : 0) + ja * sj + k0;
            for (cg_index j = ja; j <= jb_; ++j, base += sj) {
                const double fj = yc[j] - xj;
                const lucy_v4d fjv = {fj, fj, fj, fj};
                const lucy_v4i n0v = iota + base;
                memcpy(qa + c, &f0v, sizeof f0v);
                memcpy(qj + c, &fjv, sizeof fjv);
                memcpy(qz + c, &z0, sizeof z0);
                memcpy(node + c, &n0v, sizeof n0v);
                if (two) {
                    const lucy_v4i n1v = n0v + four;
                    memcpy(qa + c + 4, &f0v, sizeof f0v);
                    memcpy(qj + c + 4, &fjv, sizeof fjv);
                    memcpy(qz + c + 4, &z1, sizeof z1);
                    memcpy(node + c + 4, &n1v, sizeof n1v);
                }
                c += (int)nk;
            }
        }
        b->count = c;
        return;
    }
    for (cg_index i = 0; i < n0; ++i) {
        const cg_index ii = row == 2 ? first[0] + i : 0;
        const double f0 = row == 2 ? t->coords[0][ii] - x[0] : 0.0;
        cg_index base = (row == 2 ? ii * stride[0] : 0) + ja * sj + k0;
        for (cg_index j = ja; j <= jb_; ++j, base += sj) {
            const double fj = yc[j] - xj;
            for (cg_index m = 0; m < nk; ++m) {
                qa[c + m] = f0;
                qj[c + m] = fj;
                qz[c + m] = zc[k0 + m] - xr;
                node[c + m] = base + m;
            }
            c += (int)nk;
        }
    }
    b->count = c;
}

/* Lucy's box first..last of a segment (axis ax, end e) into sc->lucy, its
   waiting segments evaluated first if it would not fit; 0 if not batched
   (not a 9-value sum, a box bigger than a batch, or no memory) */
static inline __attribute__((always_inline)) int lucy_batch_box(const job *jb, double *out, scratch *sc, cg_index obj, const double *x, const double *e,
                          const segment_axis *ax, double scale, const cg_index *first, const cg_index *last,
                          double box)
{
    if (jb->kernel->type != CG_KERNEL_LUCY || jb->n_values != 9 || jb->out_width != 9 || box > LUCY_BATCH_NODES)
        return 0;
    struct lucy_batch *b = sc->lucy;
    if (!b) {
        /* zeroed: the slack lanes hold finite numbers */
        b = sc->lucy = calloc(1, sizeof *b);
        if (!b) return 0;
    }
    if (b->count + (int)box > LUCY_BATCH_NODES || b->nseg == LUCY_BATCH_SEGS) lucy_batch_run(b);
    const int nr = jb->target->n_resolved, s = b->nseg;
    const double R = jb->kernel->radius;
    b->out = out;
    b->R = R;
    b->wide = jb->wide;
    double *g = b->geom + 7 * s;
    for (int a = 0; a < 3; ++a) g[a] = g[3 + a] = 0.0;
    for (int a = 0; a < nr; ++a) {
        g[a] = ax->unit[a];
        g[3 + a] = e[a];
    }
    g[6] = ax->L * (1.0 / R);
    b->factor[s] = jb->kernel->prefactor * (R / ax->L);
    b->scale[s] = scale;
    for (int k = 0; k < 9; ++k) b->val[9 * s + k] = jb->values[obj * 9 + k];
    b->start[s] = b->count;
    lucy_box_rows(b, nr - 1, jb->target, x, first, last, jb->grid_stride);
    b->start[s + 1] = b->count;
    b->nseg = s + 1;
    return 1;
}

/* cg_visit_lucy for AVX2 too (as cg_lucy_line.c's loops): its box's bounds
   round with one instruction (SSE2 has none) and the gathering stores whole
   vectors; scalar arithmetic without FMA contraction (ISO C), so the same
   bits on both */
#if defined(__GNUC__) && !defined(__clang__) && defined(__has_attribute)
#if __has_attribute(target_clones) && defined(__x86_64__) && !defined(CGBOUND_NO_CLONES)
#define VISIT_CLONES __attribute__((target_clones("avx2", "default")))
#endif
#endif
#ifndef VISIT_CLONES
#define VISIT_CLONES
#endif

/* The node-by-node path (cg_scatter.c, visit_nodes) over the same stencil box,
   with the segment's axis computed once per object instead of once per node:
   in 3-D the planes of the first axis narrowed to the rows the capsule's
   shadow on the first two axes (the 2-D capsule of the projected segment)
   covers, each row narrowed to the nodes the capsule can reach (both by
   cg_lucy_rows), their values computed in batches (vectorised,
   cg_lucy_line.c) as the node-by-node path computes each one. Every node gets
   one term per object, so the order of the nodes within an object does not
   change the sums. */
VISIT_CLONES int cg_visit_lucy(const job *jb, double *out, scratch *sc, cg_index obj, const double *x, const double *e,
                               double scale)
{
    const cg_target *t = jb->target;
    const int nr = t->n_resolved;
    const double R = jb->kernel->radius;
    double L2 = 0.0;
    for (int a = 0; a < nr; ++a) L2 += e[a] * e[a];
    if (L2 == 0.0) {
        if (sc->lucy) lucy_batch_run(sc->lucy); /* the node-by-node path writes to out next */
        return 0;
    }
    segment_axis ax;
    segment_axis_of(nr, e, &ax);
    double bmin[3], bmax[3];
    for (int a = 0; a < nr; ++a) {
        const double end = x[a] + e[a];
        bmin[a] = fmin(x[a], end) - R;
        bmax[a] = fmax(x[a], end) + R;
        if (bmax[a] < jb->lo[a] || bmin[a] > jb->hi[a]) return 1;
    }
    /* the narrowing's margins: for the rounding of a^2 (>> at any node of the
       box), of u, and of the node positions; none where they would not be small */
    double reach = R + ax.L; /* the stencil box's nodes are within reach (plus a spacing) of the start */
    for (int a = 0; a < nr; ++a) reach += jb->spacing[a];
    const double rounding = 1e-12 * reach * reach, bound = R * R * (1.0 + 1e-6) + rounding;
    const double mu = 1e-6 * R + 1e-12 * reach;
    const int small_rounding = rounding < 1e-8 * R * R;
    lucy_visit vs;
    lucy_visit *v = &vs;
    if (nr >= 2 && jb->lucy_box && small_rounding) {
        /* A box hardly bigger than the capsule (short segments along an axis,
           as in a lattice) costs less to evaluate whole than to narrow row by
           row (the narrowing only drops nodes of weight 0, so the sums are
           the same). The box: the nodes within the capsule's bounding box
           (stencil_range takes a node more each way), widened by the
           narrowing's margins, so that every node of non-zero weight is in. */
        const double margin = 1e-6 * (R + reach) + mu;
        cg_index tf[3] = {0, 0, 0}, tl[3] = {0, 0, 0};
        double box = 1.0;
        for (int a = 0; a < nr; ++a) {
            const double inv_h = jb->inv_spacing[a], c0 = t->coords[a][0];
            const double sl = 1e-9 + 1e-12 * (jb->coord_extent[a] + fabs(x[a]) + reach) * inv_h;
            double klo = ceil((bmin[a] - margin - c0) * inv_h - sl), khi = floor((bmax[a] + margin - c0) * inv_h + sl);
            klo = klo > 0.0 ? klo : 0.0;
            khi = khi < (double)(t->shape[a] - 1) ? khi : (double)(t->shape[a] - 1);
            if (!(klo <= khi)) return 1;
            tf[a] = (cg_index)klo;
            tl[a] = (cg_index)khi;
            box *= khi - klo + 1.0;
        }
        const double pi = 3.14159265358979323846;
        const double capsule = nr == 3 ? pi * R * R * (ax.L + 4.0 / 3.0 * R) : R * (2.0 * ax.L + pi * R);
        if (box <= LUCY_BOX_RATIO * capsule * jb->inv_cell + 8.0) {
            if (lucy_batch_box(jb, out, sc, obj, x, e, &ax, scale, tf, tl, box)) return 1;
            if (sc->lucy) lucy_batch_run(sc->lucy);
            lucy_visit_init(v, jb, out, obj, x, e, &ax, scale);
            lucy_add_box(v, t, x, tf, tl, jb->grid_stride);
            lucy_values_flush(v);
            return 1;
        }
    }
    cg_index first[3], last[3], stride[3];
    if (!stencil_range(jb, bmin, bmax, first, last, stride)) return 1;
    if (sc->lucy) lucy_batch_run(sc->lucy);
    lucy_visit_init(v, jb, out, obj, x, e, &ax, scale);
    const int row = nr - 1;
    v->k_first = first[row];
    v->k_last = last[row];
    for (int a = row; a < 2; ++a)
        for (int i = 0; i < LUCY_ROWS; ++i) v->f[a][i] = 0.0;
    for (int a = nr; a < 3; ++a)
        for (int i = 0; i < LUCY_BATCH; ++i) v->qb[a][i] = 0.0;
    const double h = jb->spacing[row];
    v->narrow = h > 0.0 && small_rounding;
    const lucy_row_params P = {{0.0, 0.0}, {0.0, 0.0}, ax.unit[row], e[row], ax.L, bound, mu, v->zc[0], h, x[row],
                               1e-9 + 1e-12 * (fabs(v->zc[0]) + fabs(v->zc[t->shape[row] - 1]) + fabs(x[row]) + reach) / h};
    v->P = P;
    for (int a = 0; a < row; ++a) {
        v->P.n[a] = ax.unit[a];
        v->P.e[a] = e[a];
    }
    const double h1 = nr == 3 ? jb->spacing[1] : 0.0;
    if (nr == 3 && h1 > 0.0 && small_rounding) {
        /* planes i: the rows j inside the shadow, a 2-D capsule around the
           projected segment (unit m, length Lp; a disk when Lp = 0) */
        const double Lp = sqrt(e[0] * e[0] + e[1] * e[1]);
        const double m0 = Lp > 0.0 ? e[0] / Lp : 0.0, m1 = Lp > 0.0 ? e[1] / Lp : 0.0;
        const double *yc = t->coords[1];
        const lucy_row_params S = {{m0, 0.0}, {e[0], 0.0}, m1, e[1], Lp, bound, mu, yc[0], h1, x[1],
                                   1e-9 + 1e-12 * (fabs(yc[0]) + fabs(yc[t->shape[1] - 1]) + fabs(x[1]) + reach) / h1};
        double g0[LUCY_ROWS], zero[LUCY_ROWS], jlo[LUCY_ROWS], jhi[LUCY_ROWS];
        for (int i = 0; i < LUCY_ROWS; ++i) zero[i] = 0.0;
        for (cg_index i0 = first[0]; i0 <= last[0]; i0 += LUCY_ROWS) {
            const int ni = (int)(last[0] - i0 + 1 < LUCY_ROWS ? last[0] - i0 + 1 : LUCY_ROWS);
            for (int ii = 0; ii < ni; ++ii) g0[ii] = t->coords[0][i0 + ii] - x[0];
            cg_lucy_rows(ni, g0, zero, &S, jlo, jhi, v->wide);
            for (int ii = 0; ii < ni; ++ii) {
                const double lo = jlo[ii], hi = jhi[ii];
                if (!(lo <= hi && lo <= (double)last[1] && hi >= (double)first[1])) continue;
                const cg_index j0 = lo > (double)first[1] ? (cg_index)lo : first[1];
                const cg_index j1 = hi < (double)last[1] ? (cg_index)hi : last[1];
                for (cg_index j = j0; j <= j1; ++j)
                    lucy_add_row(v, g0[ii], yc[j] - x[1], (i0 + ii) * stride[0] + j * stride[1]);
            }
        }
    } else {
        cg_index idx[3] = {first[0], first[1], first[2]};
        for (int more = 1; more;) {
            double fa[2] = {0.0, 0.0};
            cg_index base = 0;
            for (int a = 0; a < row; ++a) {
                fa[a] = t->coords[a][idx[a]] - x[a];
                base += idx[a] * stride[a];
            }
            lucy_add_row(v, fa[0], fa[1], base);
            more = stencil_next(idx, first, last, row);
        }
    }
    lucy_rows_flush(v);
    lucy_values_flush(v);
    return 1;
}

/* nodes per batch of cg_visit_ball_points */
#define BALL_BATCH 256

/* the gathered nodes' weights (cg_ball_values, or cg_kernel_value for
   marginal kernels), each non-zero one into out */
static void ball_flush(const job *jb, double *out, cg_index obj, int count, const double *rho2, const cg_index *node,
                       double *w)
{
    const cg_kernel *k = jb->kernel;
    if (cg_kernel_marginal_axes(k) == 0)
        cg_ball_values(count, rho2, k->radius, k->prefactor, k->type == CG_KERNEL_HEAVISIDE, w, jb->wide);
    else
        for (int i = 0; i < count; ++i) w[i] = cg_kernel_value(k, rho2[i]);
    if (jb->mode == MODE_VALUE) {
        cg_ball_add(count, w, node, jb->out_width, jb->values + obj * jb->n_values, jb->n_values, out, jb->wide);
        return;
    }
    for (int i = 0; i < count; ++i)
        if (w[i] != 0.0) cg_accumulate(jb, out, obj, node[i], w[i], NULL);
}

/* Points of Lucy and Heaviside on grids: the node-by-node path's stencil box,
   each row narrowed to the nodes the support ball can reach (rho^2 < R^2 with
   a margin, widened by a node each way); each node's value is computed as
   the node-by-node path computes it (the same rho^2, cg_kernel_value's
   arithmetic), a batch of nodes at a time. */
int cg_visit_ball_points(const job *jb, double *out, cg_index obj, const double *x)
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
    double rho2[BALL_BATCH], w[BALL_BATCH];
    cg_index node[BALL_BATCH];
    int count = 0;
    cg_index idx[3] = {first[0], first[1], first[2]};
    for (;;) {
        cg_index base = 0;
        double p2 = 0.0;
        for (int a = 0; a < row; ++a) {
            const double q = t->coords[a][idx[a]] - x[a];
            p2 += q * q;
            base += idx[a] * stride[a];
        }
        cg_index k0, k1;
        ball_row(jb, row, xr, bound, p2, first[row], last[row], &k0, &k1);
        for (cg_index k = k0; k <= k1; ++k) {
            if (count == BALL_BATCH) {
                ball_flush(jb, out, obj, count, rho2, node, w);
                count = 0;
            }
            /* the node-by-node sum over the axes in order: (q0^2 + q1^2) + q2^2 */
            const double q = zc[k] - xr;
            rho2[count] = p2 + q * q;
            node[count++] = base + k;
        }
        if (!stencil_next(idx, first, last, row)) break;
    }
    if (count) ball_flush(jb, out, obj, count, rho2, node, w);
    return 1;
}
