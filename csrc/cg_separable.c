/*
 * cg_separable.c -- the Gaussian on regular grids, as outer products of 1-D
 * weights.
 *
 * exp(-|r - x|^2 / 2w^2) = prod_a exp(-(r_a - x_a)^2 / 2w^2), so for one
 * object the weights of its whole stencil need only one table of exponentials
 * per axis (all tables of an object in one vectorised exp); a row of nodes
 * along the last resolved axis (contiguous in the output) then costs one
 * multiply-add per node and value. The cutoff ball is applied node by node
 * with the same squared distance as the node-by-node path (cg_scatter.c): the
 * nodes inside are an interval of each row (the squared distance is convex
 * along it), found by walking from the previous row's ends. A point's values
 * go through visit_point: the same stencil, tables and sums, without the set-up
 * for rules and capsules; with one value (a density) each row's nodes inside
 * the ball come from one vector compare, no walk (rows_of_point).
 *
 * Segments with an n-point Gauss-Legendre rule are n points with weights
 * w_g: the same outer products, one table set per point (one pass per point
 * for n <= 2; for more, each row's weights are summed over the points first,
 * with the cutoff as a vector mask). Segments asked for to round-off
 * ("exact") use a Gauss-Legendre rule that is exact to round-off relative to
 * the kernel's peak (cg_gaussian_roundoff_points) at the nodes whose whole
 * segment lies inside the cutoff ball (both ends inside: the integrand is a
 * smooth Gaussian on [0, 1]) and at most FAR_BEYOND_END w beyond its ends;
 * at the nodes the cutoff sphere cuts it for, and farther beyond the ends,
 * the closed erf form on the part of the segment inside the ball, in tails
 * (erfcx), exact relative to each value (gathered and evaluated in vectorised
 * batches); segments too long for such a rule go to the node-by-node path.
 * A segment along a grid axis (it moves along one slot; not on profiles) takes
 * visit_axis instead: every node's exact value from per-object 1-D tables
 * along the segment and a packed table of its cross-section (no transcendental
 * per node, no rule), plane by plane across the segment, the few nodes whose
 * tail terms cancel by Gauss-Legendre on their part of the segment
 * (axis_cut_flush). With one value of the object's not 0 (a central contact
 * force) and a cutoff of a few node spacings, that value of the output is
 * held apart, node-major, so that rows of nodes take vectors (axis_sums).
 *
 * Resolved axes are placed in three "slots", right-aligned: the last
 * resolved axis (stride 1 in the output) is always slot 2; missing slots
 * have one node, coordinate 0 and weight 1.
 *
 * This file is compiled twice: as itself (4-wide vectors; AVX2 and baseline
 * clones) and through cg_separable_wide.c (8-wide, AVX-512). Both give the
 * same results bit for bit.
 */
#include "cg_internal.h"
#include "cg_vmath.h"

#include <math.h>
#include <stdint.h>
#if defined(CG_SEPARABLE_WIDE) && defined(__GNUC__) && !defined(__clang__)
#include <immintrin.h> /* the AVX-512 build's mask tests (mask_bits, the rows' and planes' masks) */
#endif
#include <stdlib.h>
#include <string.h>

/* helpers of the hot loop are inlined into it, so that its clones (below) cover them too */
#if defined(__GNUC__)
#define INLINE static inline __attribute__((always_inline))
#else
#define INLINE static inline
#endif

static double *scratch_get(scratch *sc, size_t need)
{
    if (need > sc->cap) {
        double *b = realloc(sc->buf, need * sizeof(double));
        if (!b) return NULL;
        sc->buf = b;
        sc->cap = need;
    }
    return sc->buf;
}

/* Four doubles as one value (GCC and clang): a row of nv values per node is
   added 4 at a time. Loads and stores go through memcpy (any alignment); the
   products are rounded as in scalar code (no FMA contraction in ISO C mode),
   so the results do not depend on the instruction set. */
#if defined(__GNUC__)
typedef double v8d __attribute__((vector_size(64)));
typedef double v4d __attribute__((vector_size(32)));
typedef double v2d __attribute__((vector_size(16)));
#define HAVE_V4D 1
#ifdef CG_SEPARABLE_WIDE
typedef v8d vwd;
#else
typedef v4d vwd;
#endif
#endif
/* the lanes of one machine vector: this file is compiled twice (see the end),
   8 wide for AVX-512 (cg_separable_wide.c) and 4 wide otherwise; wider types
   than the machine's are emulated through memory, which costs more than it saves */
#ifdef CG_SEPARABLE_WIDE
#define VW 8
#else
#define VW 4
#endif

/* x in every lane (an initializer: 0.0 + x, the other spelling, costs an
   addition where x may be -0.0) */
#if VW == 8
#define SPLAT(x) ((vwd){(x), (x), (x), (x), (x), (x), (x), (x)})
#else
#define SPLAT(x) ((vwd){(x), (x), (x), (x)})
#endif

/* the lanes' indices, 0 .. VW - 1 (an initializer of an int64_t vector of VW lanes) */
#if VW == 8
#define LANE_INDEX {0, 1, 2, 3, 4, 5, 6, 7}
#else
#define LANE_INDEX {0, 1, 2, 3}
#endif


/* One output value of the segments along a grid axis (visit_axis with one picked value) held apart from out:
   node-major, so that a row of nodes along slot 2 is contiguous and a plane's values are added to it as vectors (in
   out a node's values are contiguous: a row's value of one kind is a node apart, each add its own cache line; those
   adds were a quarter of W1's contact stress at 5 w). The held values are out's own: a node's is copied from out
   when first asked for and copied back by cg_separable_flush, which runs before any other object's visit writes to
   out and at the end of a range of objects. So every term is added to the same sum in the same order as straight
   into out: the same bits. Each value's window of nodes grows (copied) to take the nodes asked for. */
#define AXIS_SUMS_VALUES 16
/* (W1, 1 thread: a cutoff of 3 spacings, holding cost 4 %; of 5, it saved 16 %) */
#define HOLD_REACH 4.0
typedef struct axis_sum {
    double *sum;                /* nodes [base, base + cap) */
    cg_index base, cap, lo, hi; /* [lo, hi): the nodes held (lo >= hi: none) */
} axis_sum;
struct axis_sums {
    double *out; /* (the range's output) */
    cg_index width, nodes;
    int held; /* some nodes held */
    axis_sum of[AXIS_SUMS_VALUES]; /* per value of a node */
};

#ifndef CG_SEPARABLE_WIDE
void cg_separable_flush(scratch *sc)
{
    struct axis_sums *a = sc->sums;
    if (!a || !a->held) return;
    const cg_index width = a->width;
    for (int c = 0; c < AXIS_SUMS_VALUES; ++c) {
        axis_sum *v = &a->of[c];
        if (v->lo >= v->hi) continue;
        const double *restrict sum = v->sum + (v->lo - v->base);
        double *restrict o = a->out + v->lo * width + c;
        for (cg_index n = 0; n < v->hi - v->lo; ++n) o[n * width] = sum[n];
        v->lo = v->hi = 0;
    }
    a->held = 0;
}

void cg_separable_release(scratch *sc)
{
    struct axis_sums *a = sc->sums;
    if (!a) return;
    cg_separable_flush(sc);
    for (int c = 0; c < AXIS_SUMS_VALUES; ++c) free(a->of[c].sum);
    free(a);
    sc->sums = NULL;
}
#endif

/* out's value c held for nodes [lo, hi) (and those held already): *at such that sums[node - at] is node's; NULL
   where not held (value c beyond AXIS_SUMS_VALUES, no memory: then the terms go straight to out) */
static double *axis_sums_of(scratch *sc, const job *jb, double *out, int c, cg_index lo, cg_index hi, cg_index *at)
{
    if (c >= AXIS_SUMS_VALUES) return NULL;
    struct axis_sums *a = sc->sums;
    if (!a && !(a = sc->sums = calloc(1, sizeof *a))) return NULL;
    if (a->out != out) {
        cg_separable_flush(sc); /* (another output: another job on this scratch) */
        a->out = out;
        a->width = jb->out_width;
        a->nodes = cg_target_size(jb->target);
    }
    axis_sum *v = &a->of[c];
    const int empty = v->lo >= v->hi;
    const cg_index new_lo = empty || lo < v->lo ? lo : v->lo, new_hi = empty || hi > v->hi ? hi : v->hi;
    if (!(v->sum && new_lo >= v->base && new_hi <= v->base + v->cap)) {
        if (empty && v->sum && new_hi - new_lo <= v->cap) {
            /* (nothing held: the window moves) */
            v->base = new_lo + v->cap <= a->nodes ? new_lo : (a->nodes - v->cap > 0 ? a->nodes - v->cap : 0);
        } else {
            /* a window of the nodes held and asked for, and half as many again around them */
            const cg_index margin = (new_hi - new_lo) / 4 + 64;
            const cg_index base = new_lo - margin > 0 ? new_lo - margin : 0;
            const cg_index top = new_hi + margin < a->nodes ? new_hi + margin : a->nodes;
            double *sum = malloc((size_t)(top - base) * sizeof *sum);
            if (!sum) {
                cg_separable_flush(sc); /* (what is held back in out, as if never held) */
                return NULL;
            }
            if (!empty) memcpy(sum + (v->lo - base), v->sum + (v->lo - v->base), (size_t)(v->hi - v->lo) * sizeof *sum);
            free(v->sum);
            v->sum = sum;
            v->base = base;
            v->cap = top - base;
        }
    }
    /* the nodes newly held: out's values */
    const cg_index width = a->width, base = v->base;
    const double *restrict o = out + c;
    double *restrict sum = v->sum;
    if (empty) {
        for (cg_index n = new_lo; n < new_hi; ++n) sum[n - base] = o[n * width];
    } else {
        for (cg_index n = new_lo; n < v->lo; ++n) sum[n - base] = o[n * width];
        for (cg_index n = v->hi; n < new_hi; ++n) sum[n - base] = o[n * width];
    }
    v->lo = new_lo;
    v->hi = new_hi;
    a->held = 1;
    *at = v->base;
    return v->sum;
}

/* out's values held apart back in out before an object's visit may write to it (no object but a segment along one
   axis in MODE_VALUE keeps them held: visit_axis then decides) */
INLINE void axis_sums_release_for(scratch *sc, const job *jb, const double *e)
{
    if (!sc->sums || !sc->sums->held) return;
    int along = 0;
    if (jb->is_segment && jb->mode == MODE_VALUE && e)
        for (int a = 0; a < jb->target->n_resolved; ++a) along += e[a] != 0.0;
    if (along != 1) cg_separable_flush(sc);
}

/* factor 2: f[i] = sum_g gw[g] tab_g[i], the points in order from 0.0 (tab_g = tab + g n, or
   one table `same` for every point); i in blocks of 4 up to n rounded up: f and the tables
   must have room for (and tolerate) 3 more values */
INLINE void factor2_sum(double *restrict f, const double *restrict tab, const double *restrict same,
                        const double *gw, int G, cg_index n)
{
    for (cg_index i = 0; i < n; i += 4) {
#ifdef HAVE_V4D
        v4d acc = {0.0, 0.0, 0.0, 0.0};
        for (int g = 0; g < G; ++g) {
            const double *restrict t = same ? same + i : tab + (size_t)g * (size_t)n + i;
            const v4d c = {gw[g], gw[g], gw[g], gw[g]};
            v4d v;
            memcpy(&v, t, sizeof v);
            acc += c * v;
        }
        memcpy(f + i, &acc, sizeof acc);
#else
        double a0 = 0.0, a1 = 0.0, a2 = 0.0, a3 = 0.0;
        for (int g = 0; g < G; ++g) {
            const double c = gw[g], *restrict t = same ? same + i : tab + (size_t)g * (size_t)n + i;
            a0 += c * t[0];
            a1 += c * t[1];
            a2 += c * t[2];
            a3 += c * t[3];
        }
        f[i] = a0;
        f[i + 1] = a1;
        f[i + 2] = a2;
        f[i + 3] = a3;
#endif
    }
}

/* o[k * nv + c] += (scale * w[k]) * v[c] for k < nk, c < nv (1.0 * w[k] is
   w[k]): a rank-one update of nk contiguous nodes of nv values each */
INLINE void block_add_n(double *restrict o, double scale, const double *restrict w, cg_index nk,
                        const double *restrict v, const int nv)
{
    for (cg_index k = 0; k < nk; ++k) {
        const double wk = scale * w[k];
        double *ok = o + k * nv;
        int c = 0;
#ifdef HAVE_V4D
        /* widest first: 8 (AVX-512), then 4, 2, 1 */
#if VW >= 8
        const v8d w8 = {wk, wk, wk, wk, wk, wk, wk, wk};
        for (; c + 8 <= nv; c += 8) {
            v8d acc, val;
            memcpy(&acc, ok + c, sizeof acc);
            memcpy(&val, v + c, sizeof val);
            acc += w8 * val;
            memcpy(ok + c, &acc, sizeof acc);
        }
#endif
        for (; nv - c >= 4; c += 4) {
            const v4d w4 = {wk, wk, wk, wk};
            v4d acc, val;
            memcpy(&acc, ok + c, sizeof acc);
            memcpy(&val, v + c, sizeof val);
            acc += w4 * val;
            memcpy(ok + c, &acc, sizeof acc);
        }
        if (nv - c >= 2) {
            const v2d w2 = {wk, wk};
            v2d acc, val;
            memcpy(&acc, ok + c, sizeof acc);
            memcpy(&val, v + c, sizeof val);
            acc += w2 * val;
            memcpy(ok + c, &acc, sizeof acc);
            c += 2;
        }
        if (nv - c == 1) ok[c] += wk * v[c];
#else
        for (; c < nv; ++c) ok[c] += wk * v[c];
#endif
    }
}

/* An object's values whose coefficient is not +-0 (MODE_VALUE), where there are at most PICK_MAX
   of them and at most half: its updates add only those (block_add_picked). That changes no output
   bit: a skipped term is w * (+-0) = +-0 for a finite weight w (the caller checks that the weights
   are finite), and x + +-0 == x for every x but -0, which no output holds: outputs start at +0
   (cg.h: a caller's -0 may stay -0 where a term is +-0) and a sum of two doubles is -0 only if both
   are. (The contact stress along a grid axis has 1 value of 9; in a grid plane, 4.) */
#define PICK_MAX 3
/* the kind of the plain update of all nv values: PLAIN + nv (one switch for both kinds) */
#define PLAIN 8
typedef struct picked {
    int kind;           /* values picked (1..PICK_MAX), or PLAIN + nv: all */
    int at[PICK_MAX];   /* their indices */
    double v[PICK_MAX]; /* and coefficients */
} picked;

/* the picked values of v (nv of them; picked if they are finite, else all); returns how many are
   not +-0 (or 1 for nv > 64: some) */
INLINE int pick_values(const double *v, int nv, picked *p)
{
    p->kind = PLAIN + nv;
    if (nv > 64) return 1;
    uint64_t nonzero = 0;
    int n = 0;
    for (int c = 0; c < nv; ++c) {
        const int z = v[c] != 0.0;
        nonzero |= (uint64_t)z << c;
        n += z;
    }
    /* (at most half of them: a vector adds 2 or 4 contiguous values in the time of one picked) */
    if (n == 0 || n > PICK_MAX || 2 * n > nv) return n;
    for (int m = 0; m < n; ++m) {
        const int c = __builtin_ctzll(nonzero);
        nonzero &= nonzero - 1;
        if (!isfinite(v[c])) return n;
        p->at[m] = c;
        p->v[m] = v[c];
    }
    p->kind = n;
    return n;
}

/* o[k * nv + c] += (scale * w[k]) * v[c] for k < nk and the picked values c (kind PLAIN + nv: all):
   the same products and sums per value whichever are picked */
INLINE void block_add_picked(double *restrict o, double scale, const double *restrict w, cg_index nk,
                             const double *restrict v, int nv, const picked *p)
{
    /* fixed widths let the compiler unroll the inner loop */
    switch (p->kind) {
    case 1: {
        const double v0 = p->v[0];
        double *restrict o0 = o + p->at[0];
        for (cg_index k = 0; k < nk; ++k) o0[k * nv] += (scale * w[k]) * v0;
        return;
    }
    case 2: {
        const double v0 = p->v[0], v1 = p->v[1];
        double *restrict o0 = o + p->at[0], *restrict o1 = o + p->at[1];
        for (cg_index k = 0; k < nk; ++k) {
            const double wk = scale * w[k];
            o0[k * nv] += wk * v0;
            o1[k * nv] += wk * v1;
        }
        return;
    }
    case 3: {
        const double v0 = p->v[0], v1 = p->v[1], v2 = p->v[2];
        double *restrict o0 = o + p->at[0], *restrict o1 = o + p->at[1], *restrict o2 = o + p->at[2];
        for (cg_index k = 0; k < nk; ++k) {
            const double wk = scale * w[k];
            o0[k * nv] += wk * v0;
            o1[k * nv] += wk * v1;
            o2[k * nv] += wk * v2;
        }
        return;
    }
    case PLAIN + 1: {
        const double v0 = v[0];
        for (cg_index k = 0; k < nk; ++k) o[k] += (scale * w[k]) * v0;
        return;
    }
    case PLAIN + 2: block_add_n(o, scale, w, nk, v, 2); return;
    case PLAIN + 3: block_add_n(o, scale, w, nk, v, 3); return;
    case PLAIN + 4: block_add_n(o, scale, w, nk, v, 4); return;
    case PLAIN + 6: block_add_n(o, scale, w, nk, v, 6); return; /* 2D density, momentum and momentum flux at once */
    case PLAIN + 9: block_add_n(o, scale, w, nk, v, 9); return;   /* 3D stress tensors */
    case PLAIN + 10: block_add_n(o, scale, w, nk, v, 10); return; /* 3D density, momentum and momentum flux */
    default: block_add_n(o, scale, w, nk, v, nv); return;
    }
}

/* block_add_picked of all nv values */
INLINE void block_add(double *restrict o, double scale, const double *restrict w, cg_index nk,
                      const double *restrict v, int nv)
{
    const picked all = {PLAIN + nv, {0, 0, 0}, {0.0, 0.0, 0.0}};
    block_add_picked(o, scale, w, nk, v, nv, &all);
}

/* cg_exp_in_place is called on whole vectors of this many values where it can */
#define EXP_PAD 8

/* erfcx(x) = exp(x^2) erfc(x) for x >= 0 (in place): (1 + 2x) erfcx(x) is a
   Chebyshev series in y = (x - 4) / (x + 4), which maps [0, inf) to [-1, 1)
   (27 terms, fitted in 50-digit arithmetic; summed by Clenshaw's recurrence).
   Within 2 ulp of the exact value for every x >= 0 (checked against mpmath
   from 0 to 1e8). */
#define ERFCX_TERMS 27
static const double ERFCX_CHEB[ERFCX_TERMS] = {
    1.1774832005374487,      -0.007260796620301901,  -0.081265123236185,      0.06009212804122225,
    -0.02875393558027666,    0.01059566336347286,    -0.003136927294554264,   0.0007456494372536184,
    -0.0001369696503010054,  1.7183861600300937e-05, -7.158364623450346e-07,  -2.4261399442449534e-07,
    5.5765709395703566e-08,  -2.1057869513809494e-09, -1.1717889351884957e-09, 1.9098355172456688e-10,
    1.408871764208813e-11,   -6.901108320480815e-12, 9.167958364111294e-14,   2.1454508286554553e-13,
    -1.4716575027010623e-14, -6.668675118770408e-15, 7.504598509880083e-16,   2.22009300666632e-16,
    -3.1704898956330886e-17, -8.193570309884333e-18, 1.2459819733129574e-18,
};

/* erfcx on [0, ERFCX_SHORT_MAX], where the cut nodes' arguments lie for
   cutoffs up to 4 sqrt(2) w (|t| / (sqrt(2) w) with |t| at most the cutoff):
   a polynomial of degree 18 in v = (3x - 4) / (x + 4), which maps [0, 4] to
   [-1, 1] (the half of the series above's y range that these x reach; one
   division instead of two). It is a Chebyshev series of 19 terms fitted in
   40-digit arithmetic (the next term below 7e-20), converted exactly to
   powers of v and rounded: the coefficients' magnitudes sum to 1.00000 and
   the values are 0.137 to 1, so Horner's rule (2 operations per term, where
   Clenshaw's recurrence takes 3) loses no more than the series did. Within
   2.5 ulp of the exact value on [0, 4] (the Chebyshev form: 3.5; checked
   against mpmath in tests/test_gauss_exact_fast.py). */
#define ERFCX_SHORT_MAX 4.0
#define ERFCX_SHORT_TERMS 19
static const double ERFCX_SHORT_POLY[ERFCX_SHORT_TERMS] = {
    0.3511346940289053,     -0.3413688586994343,     0.18679878538547712,    -0.08179648450710927,
    0.028805854367752032,   -0.008071598027091873,   0.0017402399209039921,  -0.0002648129191416756,
    2.0713280768648866e-05, 1.4566599959765932e-06,  -5.678735758042798e-07, 2.745972842231866e-08,
    9.880146231411115e-09,  -1.1865933048288481e-09, -1.8197454417255487e-10, 3.2926820058151594e-11,
    4.237149035268989e-12,  -7.501044565500683e-13,  -1.0942463637153306e-13,
};

/* p <- the short polynomial at v (p, v: scalars or GCC vectors of doubles, p's type that of the temporaries):
   a0 + v (a1 + v Z) with Z = sum_k a_k v^(k-2) for k = 2..18 in three parts, Z = Zlo + v^6 (Zmid + v^5 Zhi)
   (k = 2..7, 8..12 and 13..18), each in Horner form: three chains of 4 or 5 steps side by side, then 4, instead
   of one chain of 18 (a step waits for the previous one's result, so one long chain left the units idle). The
   last steps are Horner's, and so is the rounding of the value (the coefficients fall to 2e-5 by k = 8):
   within 2.4 ulp of the exact value on [0, 4], as one chain. */
#define ERFCX_SHORT_HORNER(p, v)                                                                    \
    do {                                                                                            \
        const __typeof__(p) v2_ = (v) * (v), v4_ = v2_ * v2_, v5_ = v4_ * (v), v6_ = v4_ * v2_;     \
        __typeof__(p) lo_ = (v) * ERFCX_SHORT_POLY[7] + ERFCX_SHORT_POLY[6];                        \
        __typeof__(p) mid_ = (v) * ERFCX_SHORT_POLY[12] + ERFCX_SHORT_POLY[11];                     \
        __typeof__(p) hi_ = (v) * ERFCX_SHORT_POLY[18] + ERFCX_SHORT_POLY[17];                      \
        lo_ = lo_ * (v) + ERFCX_SHORT_POLY[5];                                                      \
        mid_ = mid_ * (v) + ERFCX_SHORT_POLY[10];                                                   \
        hi_ = hi_ * (v) + ERFCX_SHORT_POLY[16];                                                     \
        lo_ = lo_ * (v) + ERFCX_SHORT_POLY[4];                                                      \
        mid_ = mid_ * (v) + ERFCX_SHORT_POLY[9];                                                    \
        hi_ = hi_ * (v) + ERFCX_SHORT_POLY[15];                                                     \
        lo_ = lo_ * (v) + ERFCX_SHORT_POLY[3];                                                      \
        mid_ = mid_ * (v) + ERFCX_SHORT_POLY[8];                                                    \
        hi_ = hi_ * (v) + ERFCX_SHORT_POLY[14];                                                     \
        lo_ = lo_ * (v) + ERFCX_SHORT_POLY[2];                                                      \
        hi_ = hi_ * (v) + ERFCX_SHORT_POLY[13];                                                     \
        p = lo_ + v6_ * (mid_ + v5_ * hi_);                                                         \
        p = p * (v) + ERFCX_SHORT_POLY[1];                                                          \
        p = p * (v) + ERFCX_SHORT_POLY[0];                                                          \
    } while (0)

INLINE double erfcx_one(double x)
{
    if (!(x > ERFCX_SHORT_MAX)) {
        const double v = (3.0 * x - 4.0) / (x + 4.0);
        double p;
        ERFCX_SHORT_HORNER(p, v);
        return p;
    }
    const double y = (x - 4.0) / (x + 4.0), y2 = y + y;
    double b1 = 0.0, b2 = 0.0;
    for (int j = ERFCX_TERMS - 1; j >= 1; --j) {
        const double bj = (y2 * b1 - b2) + ERFCX_CHEB[j];
        b2 = b1;
        b1 = bj;
    }
    return ((y * b1 - b2) + ERFCX_CHEB[0]) / (1.0 + 2.0 * x);
}

#ifdef HAVE_V4D
typedef int64_t vwl __attribute__((vector_size(8 * VW)));

/* a Chebyshev series sum_j coef[j] T_j(t) by Clenshaw's recurrence, VW lanes (through a pointer: a vector
   return value changes the ABI without AVX, which -Wpsabi reports) */
INLINE void chebyshev_series(vwd t, const double *coef, int terms, vwd *sum)
{
    const vwd t2 = t + t;
    vwd b1 = {0.0}, b2 = {0.0};
#pragma GCC unroll 32
    for (int j = terms - 1; j >= 1; --j) {
        const vwd bj = (t2 * b1 - b2) + coef[j];
        b2 = b1;
        b1 = bj;
    }
    *sum = (t * b1 - b2) + coef[0];
}

/* erfcx_one's short polynomial, VW lanes */
INLINE void erfcx_short(vwd x, vwd *out)
{
    const vwd v = (SPLAT(3.0) * x - SPLAT(4.0)) / (x + SPLAT(4.0));
    vwd p;
    ERFCX_SHORT_HORNER(p, v);
    *out = p;
}

/* erfcx_one's long series, VW lanes */
INLINE void erfcx_long(vwd x, vwd *out)
{
    vwd sum;
    chebyshev_series((x - SPLAT(4.0)) / (x + SPLAT(4.0)), ERFCX_CHEB, ERFCX_TERMS, &sum);
    *out = sum / (SPLAT(1.0) + (x + x));
}
#endif

/* x[i] = erfcx(x[i]) and z[i] = erfcx(z[i]) for n a multiple of VW, as
   erfcx_one: VW lanes of each at a time in vector registers (the two short
   polynomials side by side, their Horner steps interleaved: each step waits
   for the previous one's result); the long series only where some argument of the
   pair of vectors exceeds ERFCX_SHORT_MAX (cutoffs beyond 4 sqrt(2) w), lane
   by lane; looked for only if may_exceed (the caller knows none does: a cut
   node's |x| is at most the cutoff over sqrt(2) w) */
#ifdef HAVE_V4D
INLINE uint64_t mask_bits(vwl m); /* below */
#endif
INLINE void erfcx_in_place2(double *restrict x, double *restrict z, cg_index n, int may_exceed)
{
#ifdef HAVE_V4D
    const vwd limit = SPLAT(ERFCX_SHORT_MAX);
    for (cg_index i = 0; i < n; i += VW) {
        vwd xv, zv;
        memcpy(&xv, x + i, sizeof xv);
        memcpy(&zv, z + i, sizeof zv);
        vwd rx, rz;
        erfcx_short(xv, &rx);
        erfcx_short(zv, &rz);
        const vwl fx = xv > limit, fz = zv > limit;
        if (may_exceed && mask_bits(fx | fz)) {
            vwd lx, lz;
            erfcx_long(xv, &lx);
            erfcx_long(zv, &lz);
            rx = (vwd)(((vwl)lx & fx) | ((vwl)rx & ~fx));
            rz = (vwd)(((vwl)lz & fz) | ((vwl)rz & ~fz));
        }
        memcpy(x + i, &rx, sizeof rx);
        memcpy(z + i, &rz, sizeof rz);
    }
#else
    (void)may_exceed;
    for (cg_index i = 0; i < n; ++i) {
        x[i] = erfcx_one(x[i]);
        z[i] = erfcx_one(z[i]);
    }
#endif
}

/* nodes farther than this many w beyond an end go to the closed form (cg_internal.h) */
#define FAR_BEYOND_END CG_GAUSS_FAR_BEYOND_END

/* Nodes evaluated by the closed form (cut_batch_flush): those whose
   ball the segment leaves ("cut" nodes), and those too far beyond an end for
   the segment's rule to keep their own digits; gathered in batches: q = node
   - start in slots, and the output node. */
#define CUT_BATCH 128

typedef struct cut_batch {
    int n;
    double *q[3];     /* CUT_BATCH each */
    cg_index *node;   /* CUT_BATCH */
    double *a2, *t0, *span, *value; /* CUT_BATCH each */
    double *arg;      /* CUT_BATCH_WORK * CUT_BATCH */
} cut_batch;

/* the fallback's Gauss-Legendre points (intervals short against w, see below) */
#define CUT_FALLBACK_POINTS 8
/* work arrays of a batch: 3 exponentials, 2 erfcx, the short lanes, the fallback's points */
#define CUT_BATCH_WORK (6 + CUT_FALLBACK_POINTS)
/* doubles of scratch a cut_batch takes */
#define CUT_BATCH_DOUBLES ((size_t)CUT_BATCH * (8 + CUT_BATCH_WORK))

static void cut_batch_init(cut_batch *b, double *mem)
{
    b->n = 0;
    for (int s = 0; s < 3; ++s) b->q[s] = mem + (size_t)s * CUT_BATCH;
    b->node = (cg_index *)(void *)(mem + 3 * CUT_BATCH); /* cg_index and double are both 8 bytes */
    b->a2 = mem + 4 * CUT_BATCH;
    b->t0 = mem + 5 * CUT_BATCH;
    b->span = mem + 6 * CUT_BATCH;
    b->value = mem + 7 * CUT_BATCH;
    b->arg = mem + 8 * CUT_BATCH;
}

#ifdef HAVE_V4D
typedef uint64_t vwu __attribute__((vector_size(8 * VW)));

/* lanes of a where m is set, else of b (m: all ones or zero per lane) */
#define SELECT(m, a, b) ((vwd)(((vwl)(a) & (m)) | ((vwl)(b) & ~(m))))

/* sqrt of each lane (a loop the compiler turns into one vector square root) */
INLINE void sqrt_lanes(vwd x, vwd *out)
{
    vwd r;
    for (int l = 0; l < VW; ++l) r[l] = sqrt(x[l]);
    *out = r;
}

/* at most this many vectors of lanes per call of cut_lanes_fused (see there) */
#define CUT_ILP 2

/* exp of ne vectors xe (cg_exp_in_place's operations, the same bits, for x <= 0 or NaN: the
   callers' exponents are minus sums of squares times a positive constant, where its clamp to 0
   from above changes nothing) and erfcx_short of nc vectors xc (ne <= 3 CUT_ILP, nc <= 2 CUT_ILP,
   constants after inlining), the same operations per lane; their chains are independent, in flight
   together */
INLINE void exp_erfcx_lanes(int ne, const vwd *xe, vwd *oe, int nc, const vwd *xc, vwd *oc)
{
    const vwd log2e = SPLAT(1.4426950408889634), shifter = SPLAT(0x1.8p52);
    const vwd ln2_hi = SPLAT(6.93147180369123816490e-01), ln2_lo = SPLAT(1.90821492927058770002e-10);
#pragma GCC unroll 8
    for (int k = 0; k < nc; ++k) {
        const vwd v = (SPLAT(3.0) * xc[k] - SPLAT(4.0)) / (xc[k] + SPLAT(4.0));
        ERFCX_SHORT_HORNER(oc[k], v);
    }
#pragma GCC unroll 8
    for (int k = 0; k < ne; ++k) {
        const vwl below = xe[k] < SPLAT(-708.0);
        const vwd x = SELECT(below, SPLAT(-708.0), xe[k]);
        const vwd shifted = x * log2e + shifter; /* k in the low bits of the mantissa */
        const vwd kd = shifted - shifter;
        const vwd r = (x - kd * ln2_hi) - kd * ln2_lo;
        vwd p;
        CG_EXP_TAYLOR13(p, r);
        const vwu bits = ((vwu)shifted - UINT64_C(0x4338000000000000) + 1023) << 52; /* 2^k */
        oe[k] = (vwd)((vwl)(p * (vwd)bits) & ~below);
    }
}

/* The closed form on nv <= CUT_ILP vectors of lanes of a batch from i (a
   multiple of VW), in registers, side by side (exp_erfcx_lanes):
   the part [t0, t1] of the segment inside each node's ball (s0 - u and span
   in units of the segment, kept with a^2 for the fallback), the exponentials
   at the two ends and the foot (of half the exponents: exp(x / 2)^2 reaches
   the subnormal values down to exp(-1416) where the exponential stops at
   exp(-708): far nodes, cutoffs beyond 37 w), erfcx of the ends' |x|, and
   value = factor * (|T0 - T1| or, where the ends straddle the foot, 2A - T0 -
   T1), T = E erfcx; is_short: the lanes where a term exceeds 16 times the
   value (short intervals, for the fallback; with those whose span is 0 only
   by a rounding margin: near), written to b->arg + 5 CUT_BATCH;
   their OR into *shorts (through a pointer, as chebyshev_series' result) */
INLINE void cut_lanes_fused(const cut_batch *b, cg_index i, int nv, const double *e, double L2, double R2, double w,
                            double factor, int may_exceed, vwl *shorts)
{
    const double inv_L2 = 1.0 / L2, L = sqrt(L2), inv4w2 = 0.25 / (w * w);
    const double inv_sqrt2w = 1.0 / (1.4142135623730951 * w);
    const vwd zero = {0.0}, one = SPLAT(1.0);
    const vwd ilv = SPLAT(inv_L2), Lv = SPLAT(L), i4 = SPLAT(inv4w2), isw = SPLAT(inv_sqrt2w);
    const vwd ex = SPLAT(e[0]), ey = SPLAT(e[1]), ez = SPLAT(e[2]);
    vwd xe[3 * CUT_ILP], E[3 * CUT_ILP], xc[2 * CUT_ILP], C[2 * CUT_ILP], t0s[CUT_ILP], span[CUT_ILP];
    vwd xa[CUT_ILP], EA[CUT_ILP];
    vwl straddle[CUT_ILP], near[CUT_ILP];
    /* lanes whose ball misses the segment (span 0) by less than these margins: the fallback's exact span
       decides (a sliver the lanes' rounding lost) */
    const vwd near_b2 = SPLAT(-0x1p-40 * R2), near_s = SPLAT(0x1p-40 * sqrt(R2 * inv_L2));
#pragma GCC unroll 8
    for (int h = 0; h < nv; ++h) {
        const cg_index at = i + (cg_index)h * VW;
        vwd q0, q1, q2;
        memcpy(&q0, b->q[0] + at, sizeof q0);
        memcpy(&q1, b->q[1] + at, sizeof q1);
        memcpy(&q2, b->q[2] + at, sizeof q2);
        const vwd u = (q0 * ex + q1 * ey + q2 * ez) * ilv;
        const vwd d0 = q0 - u * ex, d1 = q1 - u * ey, d2 = q2 - u * ez;
        const vwd a2 = d0 * d0 + d1 * d1 + d2 * d2;
        vwd b2 = SPLAT(R2) - a2;
        const vwl meets_line = b2 > near_b2;
        b2 = SELECT(b2 > zero, b2, zero);
        vwd half;
        sqrt_lanes(b2 * ilv, &half);
        vwd s0 = u - half, s1 = u + half;
        near[h] = meets_line & (s1 > -near_s) & (s0 < one + near_s);
        s0 = SELECT(s0 > zero, s0, zero);
        s1 = SELECT(s1 < one, s1, one);
        vwd sp = s1 - s0;
        sp = SELECT(sp > zero, sp, zero);
        const vwd t0 = (s0 - u) * Lv, t1 = t0 + sp * Lv;
        t0s[h] = s0 - u;
        span[h] = sp;
        memcpy(b->a2 + at, &a2, sizeof a2);
        memcpy(b->t0 + at, &t0s[h], sizeof t0s[h]);
        memcpy(b->span + at, &sp, sizeof sp);
        xe[2 * h] = -(a2 + t0 * t0) * i4;
        xe[2 * h + 1] = -(a2 + t1 * t1) * i4;
        xa[h] = -a2 * i4;
        xc[2 * h] = SELECT(t0 < zero, -t0, t0) * isw;
        xc[2 * h + 1] = SELECT(t1 < zero, -t1, t1) * isw;
        straddle[h] = (t0s[h] < zero) & (t0s[h] + sp > zero);
    }
    /* the foot's exponential A is used only where the ends straddle the foot (6 % of W1's cut
       nodes at 3 w, in a third of the vectors): none where no lane straddles, and one vector
       for two whose straddling lanes differ (each lane's exponent as its own vector's) */
    if (nv == 2) {
        const uint64_t sa = mask_bits(straddle[0]), sb = mask_bits(straddle[1]);
        if (!(sa | sb)) {
            exp_erfcx_lanes(4, xe, E, 4, xc, C);
            EA[0] = EA[1] = zero;
        } else if (!(sa & sb)) {
            xe[4] = SELECT(straddle[0], xa[0], xa[1]);
            exp_erfcx_lanes(5, xe, E, 4, xc, C);
            EA[0] = EA[1] = E[4];
        } else {
            xe[4] = xa[0];
            xe[5] = xa[1];
            exp_erfcx_lanes(6, xe, E, 4, xc, C);
            EA[0] = E[4];
            EA[1] = E[5];
        }
    } else if (!mask_bits(straddle[0])) {
        exp_erfcx_lanes(2, xe, E, 2, xc, C);
        EA[0] = zero;
    } else {
        xe[2] = xa[0];
        exp_erfcx_lanes(3, xe, E, 2, xc, C);
        EA[0] = E[2];
    }
#pragma GCC unroll 8
    for (int h = 0; h < nv; ++h) {
        const cg_index at = i + (cg_index)h * VW;
        vwd C0 = C[2 * h], C1 = C[2 * h + 1];
        const vwd E0 = E[2 * h], E1 = E[2 * h + 1];
        if (may_exceed) {
            /* the long series where an argument exceeds the short one's range */
            const vwd limit = SPLAT(ERFCX_SHORT_MAX), x0 = xc[2 * h], x1 = xc[2 * h + 1];
            const vwl f0 = x0 > limit, f1 = x1 > limit;
            if (mask_bits(f0 | f1)) {
                vwd l0, l1;
                erfcx_long(x0, &l0);
                erfcx_long(x1, &l1);
                C0 = SELECT(f0, l0, C0);
                C1 = SELECT(f1, l1, C1);
            }
        }
        const vwd T0 = (E0 * C0) * E0, T1 = (E1 * C1) * E1, twoA = SPLAT(2.0) * EA[h] * EA[h];
        const vwl first = T0 > T1;
        const vwd diff = SELECT(first, T0 - T1, T1 - T0), larger = SELECT(first, T0, T1);
        const vwd v = SELECT(straddle[h], (twoA - T0) - T1, diff);
        const vwd largest = SELECT(straddle[h], twoA, larger);
        const vwd value = v * SPLAT(factor);
        memcpy(b->value + at, &value, sizeof value);
        const vwl s = ((span[h] > zero) | near[h]) & ~(SPLAT(16.0) * v >= largest);
        memcpy(b->arg + 5 * CUT_BATCH + at, &s, sizeof s); /* all ones (a NaN) or +0 */
        *shorts |= s;
    }
}
#else
/* (cg_profile.c's gauss_cut_lanes_body and gauss_cut_values_body are this and
   cut_values for one resolved axis, a segment per lane, with the same bits:
   test_profile_rows.py's test_gaussian_segments compares them; change both.)
   the lanes of a batch: the part [t0, t1] of the segment inside each node's
   ball (as s0 - u and span, in units of the segment) and the arguments of the
   closed form: e0, e1, ea the exponents at the two ends and at the foot, c0,
   c1 the ends' |x| (erfcx's arguments); near[i] = 1 where the ball misses the
   segment by less than a rounding margin (cut_values' short test reads it).
   Loops of this shape are vectorised. */
INLINE void cut_lanes(cg_index n, const double *restrict q0, const double *restrict q1, const double *restrict q2,
                      double ex, double ey, double ez, double L2, double R2, double w, double *restrict a2s,
                      double *restrict t0s, double *restrict spans, double *restrict e0, double *restrict e1,
                      double *restrict ea, double *restrict c0, double *restrict c1, double *restrict near)
{
    /* half the exponents: exp(x / 2)^2 reaches the subnormal values down to
       exp(-1416) where cg_exp_in_place stops at exp(-708) (far nodes, cutoffs
       beyond 37 w) */
    const double inv_L2 = 1.0 / L2, L = sqrt(L2), inv4w2 = 0.25 / (w * w);
    const double inv_sqrt2w = 1.0 / (1.4142135623730951 * w);
    const double near_b2 = -0x1p-40 * R2, near_s = 0x1p-40 * sqrt(R2 * inv_L2);
    for (cg_index i = 0; i < n; ++i) {
        const double u = (q0[i] * ex + q1[i] * ey + q2[i] * ez) * inv_L2;
        const double d0 = q0[i] - u * ex, d1 = q1[i] - u * ey, d2 = q2[i] - u * ez;
        const double a2 = d0 * d0 + d1 * d1 + d2 * d2;
        double b2 = R2 - a2;
        const int meets_line = b2 > near_b2;
        b2 = b2 > 0.0 ? b2 : 0.0;
        const double half = sqrt(b2 * inv_L2);
        double s0 = u - half, s1 = u + half;
        near[i] = meets_line & (s1 > -near_s) & (s0 < 1.0 + near_s) ? 1.0 : 0.0;
        s0 = s0 > 0.0 ? s0 : 0.0;
        s1 = s1 < 1.0 ? s1 : 1.0;
        double span = s1 - s0;
        span = span > 0.0 ? span : 0.0;
        const double t0 = (s0 - u) * L, t1 = t0 + span * L;
        a2s[i] = a2;
        t0s[i] = s0 - u;
        spans[i] = span;
        e0[i] = -(a2 + t0 * t0) * inv4w2;
        e1[i] = -(a2 + t1 * t1) * inv4w2;
        ea[i] = -a2 * inv4w2;
        c0[i] = (t0 < 0.0 ? -t0 : t0) * inv_sqrt2w;
        c1[i] = (t1 < 0.0 ? -t1 : t1) * inv_sqrt2w;
    }
}

/* value = factor * (|T0 - T1| or, where the ends straddle the foot, 2A - T0 -
   T1), T = E erfcx; short[i] = 1 where a term exceeds 16 times the value;
   returns whether some lane is short (most batches have none: no scan) */
INLINE int cut_values(cg_index n, const double *restrict t0s, const double *restrict spans,
                       const double *restrict e0, const double *restrict e1, const double *restrict ea,
                       const double *restrict c0, const double *restrict c1, double factor, double *restrict value,
                       double *restrict is_short)
{
    int64_t any_short = 0; /* lanes as wide as the doubles' (the reduction is vectorised) */
    for (cg_index i = 0; i < n; ++i) {
        const double T0 = (e0[i] * c0[i]) * e0[i], T1 = (e1[i] * c1[i]) * e1[i], twoA = 2.0 * ea[i] * ea[i];
        const double t0 = t0s[i], t1 = t0s[i] + spans[i];
        const int straddle = (t0 < 0.0) & (t1 > 0.0);
        const double diff = T0 > T1 ? T0 - T1 : T1 - T0, larger = T0 > T1 ? T0 : T1;
        const double v = straddle ? (twoA - T0) - T1 : diff;
        const double largest = straddle ? twoA : larger;
        value[i] = v * factor;
        const int64_t short_i = ((spans[i] > 0.0) | (is_short[i] != 0.0)) & !(16.0 * v >= largest);
        is_short[i] = short_i ? 1.0 : 0.0;
        any_short |= short_i;
    }
    return any_short != 0;
}

#endif

/* The exact line integral at the gathered nodes, added to out (amp: the
   kernel's prefactor times the object's scale). With a^2 the node's squared
   distance to the segment's line, t the signed distance along it from the
   foot of the node and [t0, t1] the part of the segment inside the node's
   ball (clipped like the node-by-node path),
     int exp(-(a^2 + t^2) / 2w^2) dt = sqrt(pi/2) w [erf(x1) - erf(x0)] A,
   x = t / (sqrt(2) w), A = exp(-a^2 / 2w^2). In tails T = A erfc(|x|) =
   E erfcx(|x|), E = exp(-(a^2 + t^2) / 2w^2) (relative accuracy however far
   out): the bracket times A is |T0 - T1| where both ends lie on one side of
   the foot and 2A - T0 - T1 where they straddle it; no term is larger than
   the value unless the interval is short (x1 - x0 small against 1 and
   against 1 / x). Where a term exceeds 16 times the value (cancellation of
   more than 4 bits), the interval is that short: its integrand varies by
   less than 7 % and an 8-point Gauss-Legendre rule is exact to round-off. */
INLINE void cut_batch_add(const cut_batch *b, int n, const job *jb, double *out, cg_index obj, const picked *pick);

INLINE void cut_batch_flush(cut_batch *b, const job *jb, double *out, cg_index obj, const double *e, double L2,
                            double R2, double w, double amp, const picked *pick)
{
    const int n = b->n;
    b->n = 0;
    /* a segment of zero length is a point: the nodes gathered for it are those
       just outside its ball (within the candidates' margin), whose value is 0 */
    if (n == 0 || !(L2 > 0.0)) return;
    const double inv2w2 = 0.5 / (w * w);
    const double factor = amp * 1.2533141373155003 * w / sqrt(L2); /* sqrt(pi/2) w / L: per unit of s */
    double *restrict value = b->value;
    double *const is_short = b->arg + 5 * CUT_BATCH;
    /* |t| is at most R (to round-off: the clipped part of the segment, or an end inside
       the ball, or the foot of a node within R of the segment), so erfcx's arguments
       exceed ERFCX_SHORT_MAX = 4 only where R > 4 sqrt(2) w; a margin for the rounding */
    const int may_exceed = R2 > 31.9 * (w * w);
#ifdef HAVE_V4D
    /* whole vectors: the lanes past n are not used */
    const cg_index n_padded = (n + VW - 1) / VW * VW;
    for (int k = 0; k < VW - 1; ++k) /* (not a loop to n_padded: that becomes calls of memset) */
        if (n + k < n_padded) b->q[0][n + k] = b->q[1][n + k] = b->q[2][n + k] = 0.0;
    vwl shorts = {0};
    cg_index i = 0;
    for (; i + CUT_ILP * VW <= n_padded; i += CUT_ILP * VW)
        cut_lanes_fused(b, i, CUT_ILP, e, L2, R2, w, factor, may_exceed, &shorts);
    for (; i < n_padded; i += VW) cut_lanes_fused(b, i, 1, e, L2, R2, w, factor, may_exceed, &shorts);
    const int any_short = mask_bits(shorts) != 0;
#else
    double *const e0 = b->arg, *const e1 = e0 + CUT_BATCH, *const ea = e1 + CUT_BATCH;
    double *const c0 = ea + CUT_BATCH, *const c1 = c0 + CUT_BATCH;
    /* whole vectors (EXP_PAD; CUT_BATCH is a multiple of it): the lanes past n are not used */
    const cg_index n_padded = (n + EXP_PAD - 1) / EXP_PAD * EXP_PAD;
    for (cg_index m = n; m < n_padded; ++m) b->q[0][m] = b->q[1][m] = b->q[2][m] = 0.0;
    cut_lanes(n_padded, b->q[0], b->q[1], b->q[2], e[0], e[1], e[2], L2, R2, w, b->a2, b->t0, b->span, e0, e1, ea,
              c0, c1, is_short);
    cg_exp_in_place(e0, n_padded);
    cg_exp_in_place(e1, n_padded);
    cg_exp_in_place(ea, n_padded);
    erfcx_in_place2(c0, c1, n_padded, may_exceed);
    const int any_short = cut_values(n_padded, b->t0, b->span, e0, e1, ea, c0, c1, factor, value, is_short);
#endif
    const double *a2s = b->a2, *t0s = b->t0;
    double *restrict spans = b->span;
    int n_short = 0;
    int short_lane[CUT_BATCH];
    if (any_short)
        for (int i = 0; i < n; ++i)
            if (is_short[i] != 0.0) short_lane[n_short++] = i;
    if (n_short) {
        /* the short intervals: Gauss-Legendre on [s0, s0 + span], the span from exact differences (a
           sliver's digits: cg_cut_span_lane) */
        cg_cut_span_frame f;
        cg_cut_span_frame_of(e, jb->kernel->radius, &f);
        double *restrict qs = is_short + CUT_BATCH; /* the lanes' q, then their spans (arg's room) */
        for (int m = 0; m < n_short; ++m)
            for (int s = 0; s < 3; ++s) qs[s * CUT_BATCH + m] = b->q[s][short_lane[m]];
        for (int m = 0; m < n_short; ++m)
            qs[3 * CUT_BATCH + m] = cg_cut_span_lane(qs[m], qs[CUT_BATCH + m], qs[2 * CUT_BATCH + m], &f);
        for (int m = 0; m < n_short; ++m) spans[short_lane[m]] = qs[3 * CUT_BATCH + m];
        double gx[CUT_FALLBACK_POINTS], gw[CUT_FALLBACK_POINTS];
        cg_gauss_legendre01(CUT_FALLBACK_POINTS, gx, gw);
        double *restrict arg = is_short + CUT_BATCH;
        for (int g = 0; g < CUT_FALLBACK_POINTS; ++g)
            for (int m = 0; m < n_short; ++m) {
                const int i = short_lane[m];
                const double t = t0s[i] + gx[g] * spans[i];
                arg[g * n_short + m] = -(a2s[i] + t * t * L2) * (0.5 * inv2w2); /* halved, as in cut_lanes */
            }
        const cg_index n_args = (cg_index)CUT_FALLBACK_POINTS * n_short;
        cg_exp_in_place(arg, n_args);
        for (int m = 0; m < n_short; ++m) {
            const int i = short_lane[m];
            double sum = 0.0;
            for (int g = 0; g < CUT_FALLBACK_POINTS; ++g) sum += (gw[g] * arg[g * n_short + m]) * arg[g * n_short + m];
            value[i] = (amp * sum) * spans[i];
        }
    }
    /* (value 0: the segment misses this node's ball) */
    cut_batch_add(b, n, jb, out, obj, pick);
}

/* the batch's n values (b->value) times the object's values, added to its nodes */
INLINE void cut_batch_add(const cut_batch *b, int n, const job *jb, double *out, cg_index obj, const picked *pick)
{
    const double *restrict value = b->value;
    if (jb->mode == MODE_VALUE) {
        const double *restrict vals = jb->values + obj * jb->n_values;
        const cg_index width = jb->out_width;
        if (pick->kind == 1) {
            /* every node: where value is 0, the term is +-0 (a finite value picked), which changes
               nothing (above); 1.0 * value is value (block_add's product) */
            const double v0 = pick->v[0];
            double *restrict o0 = out + pick->at[0];
            const cg_index *restrict node = b->node;
            for (int i = 0; i < n; ++i) o0[node[i] * width] += value[i] * v0;
        } else if (pick->kind <= PICK_MAX) {
            for (int i = 0; i < n; ++i)
                if (value[i] != 0.0)
                    block_add_picked(out + b->node[i] * width, 1.0, &value[i], 1, vals, jb->n_values, pick);
        } else if (jb->n_values == 9) { /* 3D stress tensors: block_add's case 9, without its switch per node */
            for (int i = 0; i < n; ++i)
                if (value[i] != 0.0) block_add_n(out + b->node[i] * width, 1.0, &value[i], 1, vals, 9);
        } else {
            for (int i = 0; i < n; ++i)
                if (value[i] != 0.0) block_add(out + b->node[i] * width, 1.0, &value[i], 1, vals, jb->n_values);
        }
    } else {
        for (int i = 0; i < n; ++i)
            if (value[i] != 0.0) cg_accumulate(jb, out, obj, b->node[i], value[i], NULL);
    }
}

/* squared distance from point p to the segment [0, e] (3 slots), q = p */
INLINE double segment_distance2(const double *q, const double *e, double inv_L2)
{
    double t = 0.0;
    if (inv_L2 > 0.0) {
        t = (q[0] * e[0] + q[1] * e[1] + q[2] * e[2]) * inv_L2;
        t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
    }
    double d2 = 0.0;
    for (int s = 0; s < 3; ++s) {
        const double d = q[s] - t * e[s];
        d2 += d * d;
    }
    return d2;
}

/* d2[k] = segment_distance2 of the nodes (x, y, z[k]) of a row, k < n (the
   same operations, in a loop that is vectorised) */
INLINE void row_distance2(cg_index n, double x, double y, const double *restrict z, const double *e, double inv_L2,
                          double *restrict d2)
{
    const double ex = e[0], ey = e[1], ez = e[2], pxy = x * ex + y * ey;
    for (cg_index k = 0; k < n; ++k) {
        double t = (pxy + z[k] * ez) * inv_L2;
        t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
        const double d0 = x - t * ex, d1 = y - t * ey, d2k = z[k] - t * ez;
        d2[k] = (d0 * d0 + d1 * d1) + d2k * d2k;
    }
}

/* the index of the least of n >= 1 values (the first of equal ones) */
INLINE cg_index argmin(const double *d, cg_index n)
{
    cg_index m = 0;
    for (cg_index k = 1; k < n; ++k) m = d[k] < d[m] ? k : m;
    return m;
}

/* The rows [j0, j1) of plane i (squared distance si along its axis) with a
   node inside the ball: those whose node of least z distance is inside, an
   interval around the row jm of least y distance. Returns 0 if none. */
INLINE int plane_rows(double si, const double *dy, cg_index n1, cg_index jm, double dz_min, double R2, cg_index *j0,
                      cg_index *j1)
{
    if (!(si + dy[jm] + dz_min < R2)) return 0;
    cg_index lo = jm, hi = jm + 1;
    while (lo > 0 && si + dy[lo - 1] + dz_min < R2) --lo;
    while (hi < n1 && si + dy[hi] + dz_min < R2) ++hi;
    *j0 = lo;
    *j1 = hi;
    return 1;
}

/* The rows of one point's stencil: node (i, j, k) is inside the
   cutoff ball where dx[i] + dy[j] + dz[k] < R2 (the node-by-node path's test)
   and receives (c gx[i] gy[j]) gz[k] times the values (node indices: node0 +
   i stride_i + j stride_j + k; out has nv doubles per node in MODE_VALUE). Along each axis the
   squared distance falls and then rises, so the nodes inside the ball are an
   interval of every row (and the rows, an interval of every plane), around the
   node of least squared distance. */
INLINE void rows_of_one_point(const job *jb, double *out, cg_index obj, cg_index node0, cg_index stride_i,
                              cg_index stride_j, cg_index n0, cg_index n1, cg_index n2, const double *restrict dx,
                              const double *restrict dy, const double *restrict dz, const double *restrict gx,
                              const double *restrict gy, const double *restrict gz, double c, double R2,
                              const double *restrict v, int nv, const picked *pick)
{
    const int add_values = jb->mode == MODE_VALUE; /* else each node's weight goes to cg_accumulate */
    const cg_index jm = argmin(dy, n1), km = argmin(dz, n2); /* the nodes of least squared distance */
    const double dz_min = dz[km];
    for (cg_index i = 0; i < n0; ++i) {
        const double si = dx[i];
        cg_index j0, j1;
        if (!plane_rows(si, dy, n1, jm, dz_min, R2, &j0, &j1)) continue;
        const double ci = c * gx[i];
        /* the row's nodes inside, [a, b), from the previous row's: the ends move
           little from row to row (node km is inside in every row of [j0, j1)) */
        cg_index a = km, b = km + 1;
        for (cg_index j = j0; j < j1; ++j) {
            const double s01 = si + dy[j];
            while (a > 0 && s01 + dz[a - 1] < R2) --a;
            while (!(s01 + dz[a] < R2)) ++a;
            while (b < n2 && s01 + dz[b] < R2) ++b;
            while (!(s01 + dz[b - 1] < R2)) --b;
            const double cij = ci * gy[j];
            const cg_index row0 = node0 + i * stride_i + j * stride_j; /* node k = 0 of the row */
            if (add_values)
                block_add_picked(out + (row0 + a) * nv, cij, gz + a, b - a, v, nv, pick);
            else
                for (cg_index k = a; k < b; ++k) cg_accumulate(jb, out, obj, row0 + k, cij * gz[k], NULL);
        }
    }
}

/* doubles after a row that may be written (and after a table, read) when
   rows are summed 8 at a time */
#define ROW_PAD 8

/* row[k] = sum_g (ci[g] gy_j[g]) gz[g][k] for k in [a, b), summed in rule order
   as a scalar loop would, VW nodes at a time (gy_j: the row's y weights of the
   G points, contiguous): writes up to 7 doubles past b (ROW_PAD) and reads as
   far past the tables (in scratch memory, followed by more tables or the row;
   the values there are not used) */
INLINE void inside_row(double *restrict row, cg_index a, cg_index b, int G, const double *restrict ci,
                       const double *restrict gy_j, const double *const *gz)
{
    double cij[CG_MAX_LINE_POINTS];
    for (int g = 0; g < G; ++g) cij[g] = ci[g] * gy_j[g];
    for (cg_index k = a; k < b; k += VW) {
#ifdef HAVE_V4D
        vwd acc = {0.0};
        for (int g = 0; g < G; ++g) {
            const vwd c = SPLAT(cij[g]);
            vwd gzk;
            memcpy(&gzk, gz[g] + k, sizeof gzk);
            acc += c * gzk;
        }
        memcpy(row + k, &acc, sizeof acc);
#else
        const cg_index end = k + VW < b ? k + VW : b;
        for (cg_index m = k; m < end; ++m) row[m] = 0.0;
        for (int g = 0; g < G; ++g) {
            const double c = cij[g];
            for (cg_index m = k; m < end; ++m) row[m] += c * gz[g][m];
        }
#endif
    }
}

/* The rows of a G-point rule along a segment (MODE_VALUE, n2 <= 64): each
   point's ball by the node-by-node path's test, as a mask on VW nodes at a
   time (its weight where inside, 0 elsewhere: the sum over the points in rule
   order is as a scalar loop would form it); the nodes any ball reaches, from
   the masks' bits; then one update of the output per row. Reads up to 7
   doubles past the z tables and writes as far past the row (ROW_PAD; the
   values there are not used). */
#ifdef HAVE_V4D
/* lane l of a mask (all ones or zero) as bit l: a horizontal OR in halving
   steps (lane extracts one by one cost more than the rest of a row); in the
   AVX-512 build one test into a mask register */
#if VW == 8 && defined(CG_SEPARABLE_WIDE) && defined(__GNUC__) && !defined(__clang__)
#define ROW_MASKS_AVX512 1 /* the exact form's row tests by AVX-512 intrinsics, into mask registers */
INLINE uint64_t mask_bits(vwl m) { return (uint64_t)_mm512_test_epi64_mask((__m512i)m, (__m512i)m); }
#else
INLINE uint64_t mask_bits(vwl m)
{
#if VW == 8
    const vwl bit = {1, 2, 4, 8, 16, 32, 64, 128};
    vwl b = m & bit;
#if defined(__clang__)
    b |= __builtin_shufflevector(b, b, 4, 5, 6, 7, 0, 1, 2, 3);
    b |= __builtin_shufflevector(b, b, 2, 3, 0, 1, 6, 7, 4, 5);
    b |= __builtin_shufflevector(b, b, 1, 0, 3, 2, 5, 4, 7, 6);
#else
    b |= __builtin_shuffle(b, (vwl){4, 5, 6, 7, 0, 1, 2, 3});
    b |= __builtin_shuffle(b, (vwl){2, 3, 0, 1, 6, 7, 4, 5});
    b |= __builtin_shuffle(b, (vwl){1, 0, 3, 2, 5, 4, 7, 6});
#endif
#else
    const vwl bit = {1, 2, 4, 8};
    vwl b = m & bit;
#if defined(__clang__)
    b |= __builtin_shufflevector(b, b, 2, 3, 0, 1);
    b |= __builtin_shufflevector(b, b, 1, 0, 3, 2);
#else
    b |= __builtin_shuffle(b, (vwl){2, 3, 0, 1});
    b |= __builtin_shuffle(b, (vwl){1, 0, 3, 2});
#endif
#endif
    return (uint64_t)b[0];
}
#endif

#ifndef ROW_MASKS_AVX512
#define ROW_MASKS_AVX512 0
#endif

/* three masks' lanes as bits (mask_bits of each): in the 4-wide build one
   horizontal OR for all three (the lanes of each in their own 4 bits) */
INLINE void mask_bits3(vwl a, vwl b, vwl c, uint64_t *ba, uint64_t *bb, uint64_t *bc)
{
#if VW == 4
    const vwl bit_a = {1, 2, 4, 8}, bit_b = {16, 32, 64, 128}, bit_c = {256, 512, 1024, 2048};
    vwl m = (a & bit_a) | (b & bit_b) | (c & bit_c);
#if defined(__clang__)
    m |= __builtin_shufflevector(m, m, 2, 3, 0, 1);
    m |= __builtin_shufflevector(m, m, 1, 0, 3, 2);
#else
    m |= __builtin_shuffle(m, (vwl){2, 3, 0, 1});
    m |= __builtin_shuffle(m, (vwl){1, 0, 3, 2});
#endif
    const uint64_t all = (uint64_t)m[0];
    *ba = all & 15;
    *bb = (all >> 4) & 15;
    *bc = all >> 8;
#else
    *ba = mask_bits(a);
    *bb = mask_bits(b);
    *bc = mask_bits(c);
#endif
}

/* the bits from the lowest to the highest set bit of x (0 for 0), without branches */
INLINE uint64_t bit_span(uint64_t x) { return (x | (0 - x)) & (~UINT64_C(0) >> __builtin_clzll(x | 1)); }

INLINE void rows_of_rule(double *restrict out, cg_index stride_i, cg_index stride_j, cg_index n0, cg_index n1,
                         cg_index n2, int G, double *const (*d2)[3], double *const (*ex)[3], const double *gw,
                         double R2, double *const rows[2], const double *restrict v, int nv, const picked *pick)
{
    cg_index jm[CG_MAX_LINE_POINTS];
    double dz_min[CG_MAX_LINE_POINTS];
    for (int g = 0; g < G; ++g) {
        jm[g] = argmin(d2[g][1], n1);
        dz_min[g] = d2[g][2][argmin(d2[g][2], n2)];
    }
    const uint64_t valid = n2 >= 64 ? ~UINT64_C(0) : (UINT64_C(1) << n2) - 1;
    const vwd R2w = SPLAT(R2);
    for (cg_index i = 0; i < n0; ++i) {
        /* per point: its rows [j0, j1) in this plane (as in rows_of_one_point) */
        cg_index j0[CG_MAX_LINE_POINTS], j1[CG_MAX_LINE_POINTS];
        double si[CG_MAX_LINE_POINTS], ci[CG_MAX_LINE_POINTS];
        cg_index J0 = n1, J1 = 0;
        for (int g = 0; g < G; ++g) {
            si[g] = d2[g][0][i];
            ci[g] = gw[g] * ex[g][0][i];
            j0[g] = j1[g] = 0;
            if (!plane_rows(si[g], d2[g][1], n1, jm[g], dz_min[g], R2, &j0[g], &j1[g])) continue;
            if (j0[g] < J0) J0 = j0[g];
            if (j1[g] > J1) J1 = j1[g];
        }
        /* a row's update of the output waits for the next row's weights: read
           right after its vector store, the row would stall store forwarding */
        double *pending = NULL;
        cg_index pending_k0 = 0, pending_k1 = 0, pending_j = 0;
        for (cg_index j = J0; j < J1; ++j) {
            double *row = rows[j & 1];
            uint64_t bits = 0;
            for (cg_index kw = 0; kw < n2; kw += VW) {
                vwd acc = {0.0};
                vwl any = {0};
                for (int g = 0; g < G; ++g) {
                    if (j < j0[g] || j >= j1[g]) continue;
                    const double s01 = si[g] + d2[g][1][j], c = ci[g] * ex[g][1][j];
                    const vwd sw = SPLAT(s01), cw = SPLAT(c);
                    vwd dz, gz;
                    memcpy(&dz, d2[g][2] + kw, sizeof dz);
                    memcpy(&gz, ex[g][2] + kw, sizeof gz);
                    const vwl inside = sw + dz < R2w;
                    acc += (vwd)((vwl)(cw * gz) & inside);
                    any |= inside;
                }
                memcpy(row + kw, &acc, sizeof acc);
                bits |= mask_bits(any) << kw;
            }
            bits &= valid;
            if (pending)
                block_add_picked(out + i * stride_i + pending_j * stride_j + pending_k0 * nv, 1.0,
                                 pending + pending_k0, pending_k1 - pending_k0, v, nv, pick);
            pending = NULL;
            if (!bits) continue;
            pending = row;
            pending_j = j;
            pending_k0 = __builtin_ctzll(bits);
            pending_k1 = 64 - __builtin_clzll(bits);
        }
        if (pending)
            block_add_picked(out + i * stride_i + pending_j * stride_j + pending_k0 * nv, 1.0, pending + pending_k0,
                             pending_k1 - pending_k0, v, nv, pick);
    }
}

/* a point's stencils longer than this along an axis go to the general visit (visit_point's tables are on the stack) */
#define POINT_ROW_MAX 64

/* rows_of_one_point in MODE_VALUE for one value v0 (not picked), n2 <= POINT_ROW_MAX: the same
   nodes, terms and sums, with no walk and no call or branch per node. A row's nodes inside the
   ball are a mask, VW nodes at a time (lanes past n2 masked off: the z tables are read up to
   VW - 1 past their ends, values not used); they are an interval (dz falls, then rises). The
   AVX-512 build adds them by masked loads and stores (the nodes outside are not touched); the
   4-wide one, the row's interval from the mask's bits. */
INLINE void rows_of_point(double *restrict out, cg_index stride_i, cg_index stride_j, cg_index n0, cg_index n1,
                          cg_index n2, const double *restrict dx, const double *restrict dy,
                          const double *restrict dz, const double *restrict gx, const double *restrict gy,
                          const double *restrict gz, double c, double R2, double v0)
{
    const cg_index jm = argmin(dy, n1), km = argmin(dz, n2); /* the nodes of least squared distance */
    const double dz_min = dz[km];
    const uint64_t valid = n2 >= 64 ? ~UINT64_C(0) : (UINT64_C(1) << n2) - 1;
#if ROW_MASKS_AVX512
    const __m512d R2v = _mm512_set1_pd(R2), vv = _mm512_set1_pd(v0);
#else
    const vwd R2v = SPLAT(R2);
#endif
    for (cg_index i = 0; i < n0; ++i) {
        const double si = dx[i];
        cg_index j0, j1;
        if (!plane_rows(si, dy, n1, jm, dz_min, R2, &j0, &j1)) continue;
        const double ci = c * gx[i];
        for (cg_index j = j0; j < j1; ++j) {
            const double s01 = si + dy[j], cij = ci * gy[j];
            double *restrict orow = out + i * stride_i + j * stride_j; /* node k = 0 of the row */
#if ROW_MASKS_AVX512
            const __m512d sv = _mm512_set1_pd(s01), cv = _mm512_set1_pd(cij);
            for (cg_index kw = 0; kw < n2; kw += VW) {
                const __mmask8 m = _mm512_cmp_pd_mask(_mm512_add_pd(sv, _mm512_loadu_pd(dz + kw)), R2v, _CMP_LT_OQ) &
                                   (__mmask8)(valid >> kw);
                if (!m) continue;
                double *o = orow + kw;
                const __m512d t = _mm512_mul_pd(_mm512_mul_pd(cv, _mm512_loadu_pd(gz + kw)), vv);
                _mm512_mask_storeu_pd(o, m, _mm512_add_pd(_mm512_maskz_loadu_pd(m, o), t));
            }
#else
            const vwd sv = SPLAT(s01);
            uint64_t bits = 0;
            for (cg_index kw = 0; kw < n2; kw += VW) {
                vwd dzk;
                memcpy(&dzk, dz + kw, sizeof dzk);
                bits |= mask_bits((vwl)(sv + dzk < R2v)) << kw;
            }
            bits &= valid;
            if (!bits) continue;
            const cg_index a = __builtin_ctzll(bits), b = 64 - __builtin_clzll(bits);
            for (cg_index k = a; k < b; ++k) orow[k] += (cij * gz[k]) * v0;
#endif
        }
    }
}
#endif

/* Two builds of the visit below: cg_separable_wide.c compiles this file again
   for AVX-512 (VW = 8, CG_SEPARABLE_WIDE); here, on x86-64 with GCC, an AVX2
   and a baseline version are cloned and chosen at load time (VW = 4). The
   dispatcher at the end picks the wide build where the CPU has AVX-512.
   Results are identical in all: ISO C mode (-std=c11) forbids contracting
   a*b+c into an FMA, and no sum is reordered. */
#ifdef CG_SEPARABLE_WIDE
#define VISIT_SEPARABLE cg_visit_separable_wide
#define HOT_CLONES
#else
#define VISIT_SEPARABLE visit_separable_narrow
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(CGBOUND_NO_CLONES) && \
    defined(__has_attribute)
#if __has_attribute(target_clones)
#define HOT_CLONES __attribute__((target_clones("avx2", "default")))
#endif
#endif
#ifndef HOT_CLONES
#define HOT_CLONES
#endif
#endif

/* cut_batch_flush as a call (once per batch of up to CUT_BATCH nodes): inlined into the visit's three
   places it changed the register allocation of the visit's row loops (measured with callgrind on W1
   at 3 w: 20,986 instructions per contact inlined, 20,571 called; a random packing's too, 0.9 % fewer) */
#if defined(__GNUC__)
__attribute__((noinline))
#endif
HOT_CLONES static void cut_batch_flush_out(cut_batch *b, const job *jb, double *out, cg_index obj, const double *e,
                                           double L2, double R2, double w, double amp, const picked *pick)
{
    cut_batch_flush(b, jb, out, obj, e, L2, R2, w, amp, pick);
}

/* The packed exponent table of a segment that does not move along some slot (below, in the
   visit), its exponentials, and with fx (factor 2) the outer product's tables fx, fy, fz from
   it. Not inlined: inside the visit this code changed the register allocation of its row
   loops (measured: more instructions there than saved here). */
#if defined(__GNUC__)
__attribute__((noinline))
#endif
HOT_CLONES static void packed_tables(double *restrict packed, size_t at[3], double *const cslot[3],
                                     const cg_index count[3], const double es[3], const double *gx,
                                     const double *gw, int G, double inv2w2, double *restrict fx,
                                     double *restrict fy, double *restrict fz)
{
    size_t m = 0;
    for (int s = 0; s < 3; ++s) {
        at[s] = m;
        const int points = es[s] == 0.0 ? 1 : G;
        const cg_index n = count[s];
        const double *restrict cs = cslot[s];
        for (int g = 0; g < points; ++g) {
            /* (indexed by k, not m++: the loop vectorises) */
            const double shift = gx[g] * es[s];
            /* whole blocks of 4 (no scalar remainder): the lanes past n read the next slot's
               coordinates or the zeroed row after them, and write over the next table's start
               (written after) or the padding (zeroed below) */
            double *restrict dst = packed + m;
            for (cg_index k = 0; k < n; k += 4)
                for (int l = 0; l < 4; ++l) {
                    const double q = cs[k + l] - shift;
                    dst[k + l] = -(q * q) * inv2w2;
                }
            m += (size_t)n;
        }
    }
    const size_t m_padded = (m + EXP_PAD - 1) / EXP_PAD * EXP_PAD;
    /* a whole EXP_PAD of zeros (a fixed count, not a memset call): the padding, and
       what the factor-2 sums below read past the last table */
    for (int i = 0; i < EXP_PAD; ++i) packed[m + (size_t)i] = 0.0;
    cg_exp_in_place(packed, (cg_index)m_padded);
    if (!fx) return;
    /* the outer product's tables straight from the packed ones (the summed slot: the
       moving one, slot 0 where none moves) */
    const int moves0 = es[0] != 0.0, moves1 = es[1] != 0.0, moves2 = es[2] != 0.0;
    const cg_index n0 = count[0], n1 = count[1], n2 = count[2];
    const int sum0 = moves0 || !(moves1 || moves2);
    const double *restrict px = packed + at[0], *restrict py = packed + at[1], *restrict pz = packed + at[2];
    /* the summed slot first, in whole blocks of 4 (no scalar remainder): its writes
       past the table reach the next table (copied after it) or, for slot 2, the
       ROW_PAD gap before pz; its reads past the last table, the zeros above or the
       next slot's values (unused lanes) */
    if (sum0) factor2_sum(fx, px, moves0 ? NULL : px, gw, G, n0);
    if (moves1) factor2_sum(fy, py, NULL, gw, G, n1);
    if (moves2) factor2_sum(fz, pz, NULL, gw, G, n2);
    if (!sum0) memcpy(fx, px, (size_t)n0 * sizeof(double));
    if (!moves1) memcpy(fy, py, (size_t)n1 * sizeof(double));
    if (!moves2) memcpy(fz, pz, (size_t)n2 * sizeof(double));
}

/* the nodes along resolved axis a (slot s) within [lo, hi]: first[s], count[s]; 0 when none (the object
   carries nothing to the grid), 1 otherwise. An axis of one node (or of zero spacing) takes all its nodes. */
INLINE int slot_range(const job *jb, int a, int s, double lo, double hi, cg_index *first, cg_index *count)
{
    const cg_target *t = jb->target;
    const double c0 = t->coords[a][0], h = jb->spacing[a];
    const cg_index n = t->shape[a];
    if (hi < jb->lo[a] || lo > jb->hi[a]) return 0;
    if (n == 1 || h == 0.0) {
        first[s] = 0;
        count[s] = n;
        return 1;
    }
    double f = floor((lo - c0) / h), l = ceil((hi - c0) / h);
    if (f < 0.0) f = 0.0;
    if (l > (double)(n - 1)) l = (double)(n - 1);
    if (f > l) return 0;
    first[s] = (cg_index)f;
    count[s] = (cg_index)l - (cg_index)f + 1;
    return 1;
}

#ifdef HAVE_V4D
/* A point in MODE_VALUE: the general visit's stencil, tables and sums (below: the same operations, so
   the same bits) without its set-up for rules, capsules and scratch memory (the tables are on the
   stack); one value's rows by rows_of_point, more values' by rows_of_one_point. Returns 1 when done,
   0 to leave the point to the general visit (sparse values, which it picks; stencils longer than
   POINT_ROW_MAX along an axis). A function of its own (not inlined into the visit, whose register
   allocation is tuned for the segments). */
#if defined(__GNUC__)
__attribute__((noinline))
#endif
HOT_CLONES static int visit_point(const job *jb, double *out, cg_index obj, const double *x)
{
    const cg_target *t = jb->target;
    const cg_kernel *kn = jb->kernel;
    const int nr = t->n_resolved, pad = 3 - nr, nv = jb->n_values;
    const double R = kn->radius, R2 = R * R, w = kn->width, inv2w2 = 0.5 / (w * w), c = kn->prefactor;
    const double *values = jb->values + obj * nv;
    picked pick = {PLAIN + nv, {0, 0, 0}, {0.0, 0.0, 0.0}};
    if (isfinite(4.0 * c) && pick_values(values, nv, &pick) == 0) return 1; /* every value is +-0 */
    if (pick.kind <= PICK_MAX) return 0;
    cg_index first[3] = {0, 0, 0}, count[3] = {1, 1, 1}, stride[3] = {0, 0, 0};
    cg_index st = 1;
    for (int a = nr - 1; a >= 0; --a) {
        const int s = a + pad;
        stride[s] = st;
        st *= t->shape[a];
        if (!slot_range(jb, a, s, x[a] - R, x[a] + R, first, count)) return 1;
        if (count[s] > POINT_ROW_MAX) return 0;
    }
    const cg_index n0 = count[0], n1 = count[1], n2 = count[2], n_all = n0 + n1 + n2;
    /* per slot the squared distances (node - x)^2 and their exponentials, one call for all;
       rows_of_point reads up to VW - 1 past the last table */
    double d2[3 * POINT_ROW_MAX + EXP_PAD], ex[3 * POINT_ROW_MAX + EXP_PAD];
    double *ds[3] = {d2, d2 + n0, d2 + n0 + n1};
    for (int s = 0; s < 3; ++s) {
        if (s < pad) {
            ds[s][0] = 0.0;
            continue;
        }
        const double *restrict cs = t->coords[s - pad] + first[s];
        double *restrict dst = ds[s];
        const double xs = x[s - pad];
        for (cg_index k = 0; k < count[s]; ++k) {
            const double q = cs[k] - xs;
            dst[k] = q * q;
        }
    }
    const cg_index n_padded = (n_all + EXP_PAD - 1) / EXP_PAD * EXP_PAD;
    for (cg_index m = 0; m < n_all; ++m) ex[m] = -d2[m] * inv2w2;
    for (int m = 0; m < EXP_PAD; ++m) d2[n_all + m] = ex[n_all + m] = 0.0;
    cg_exp_in_place(ex, n_padded);
    const cg_index node0 = first[0] * stride[0] + first[1] * stride[1] + first[2] * stride[2];
    double *const o = out + node0 * nv;
    const cg_index si = stride[0] * nv, sj = stride[1] * nv;
    const double *gx = ex, *gy = ex + n0, *gz = ex + n0 + n1;
    if (nv == 1)
        rows_of_point(o, si, sj, n0, n1, n2, ds[0], ds[1], ds[2], gx, gy, gz, c, R2, values[0]);
    else /* (the walks of rows_of_one_point: rows_of_point with 13 values took 15 % more on W1) */
        rows_of_one_point(jb, out, obj, node0, stride[0], stride[1], n0, n1, n2, ds[0], ds[1], ds[2], gx, gy, gz, c,
                          R2, values, nv, &pick);
    return 1;
}
#endif

#ifdef HAVE_V4D
/* The exact form for a segment along a grid axis (it moves along one slot m only): every node's value
   separates. With rho^2 the node's squared distance to the segment's line (from its coordinates across
   slot m, a "cross" entry: the same for every node along m) and u its coordinate along the segment
   (from the start, in the segment's direction; an "along" entry, the same for every node across), the
   part of the segment inside the ball is [max(0, u - h), min(L, u + h)], h = sqrt(R^2 - rho^2), and
     value = factor (A erf-bracket),  A = exp(-rho^2 / 2w^2) = g_a g_b (the two cross slots' 1-D tables);
   in tails (as cut_batch_flush) each limit's term is A erfc(|a| / sqrt2 w), a = limit - u: at an end of
   the segment A Es[u] or A Ee[u] (erfc of |u| and |u - L|: along tables, by erfcx and a halved
   exponent), at a crossing of the sphere exp(-R^2 / 2w^2) erfcx(h / sqrt2 w) = Pc (rho^2 + h^2 = R^2:
   a cross table). Where both ends are inside the ball the bracket is A W[u] (an along table: 2 - Es - Ee,
   or |Es - Ee| beyond an end; where those cancel by more than 4 bits, the 8-point Gauss-Legendre rule
   on [0, L], as cut_batch_flush's fallback). Elsewhere the same test of the terms against the value
   (16 times): a node that fails it has a short part of the segment inside its ball, gathered for
   axis_cut_flush (Gauss-Legendre on that part, from u, h and L). So a node needs no transcendental: the
   per-object tables (1-D along m; across, the cross entries whose line meets the ball, packed) and a few
   vector operations. The nodes go plane by plane (one along entry each), a plane's packed cross entries
   in one vector loop whatever m is (beyond the segment's ends only the rows of entries whose h reaches
   it), its values then added at their nodes by their offsets.
   Only where every product of terms stays normal (R^2 / 2w^2 below AXIS_EXPONENT_MAX: each term is at
   least exp(-R^2 / 2w^2) times erfcx), every slot's count <= 64, MODE_VALUE and finite values (a node
   whose value is 0 then adds +-0, which changes no output). */
#define AXIS_EXPONENT_MAX 600.0
/* and A W, ~ (L / w) exp(-R^2 / 2w^2) at least, normal: below exp(-AXIS_VALUE_EXPONENT_MAX) it loses digits
   or is 0 while the node's value is normal (short segments with large cutoffs: the general path; the test's
   L >= 1e-20 w in the dispatch keeps log off every other segment's way: 600 + 46 < 700) */
#define AXIS_VALUE_EXPONENT_MAX 700.0

/* |x| (the sign bit cleared): |P0 - P1| is P1 - P0 where P1 > P0 (a difference rounds symmetrically) */
#define ABS_LANES(x) ((vwd)((vwl)(x) & ((vwl){0} | INT64_MAX)))

/* one VW-lane step of a row: val = the bracket (0 where the ball misses the segment or the terms cancel:
   cancel's lanes), from the along entries u, Es, Ee, W and the cross entries h, A, Pc */
INLINE void axis_lanes(vwd u, vwd h, vwd A, vwd Pc, vwd Es, vwd Ee, vwd W, vwd L, vwd *val, vwl *cancel)
{
    const vwd zero = {0.0};
    const vwd lo = u - h, hi = u + h;
    const vwl at_start = lo <= zero, at_end = hi >= L;
    const vwd t0 = SELECT(at_start, zero, lo), t1 = SELECT(at_end, L, hi);
    const vwl meets = t1 > t0;
    const vwd P0 = SELECT(at_start, A * Es, Pc), P1 = SELECT(at_end, A * Ee, Pc);
    const vwl straddle = (t0 < u) & (t1 > u);
    const vwd twoA = A + A;
    const vwl first = P0 > P1;
    const vwd diff = ABS_LANES(P0 - P1), larger = SELECT(first, P0, P1);
    vwd v = SELECT(straddle, (twoA - P0) - P1, diff);
    const vwd largest = SELECT(straddle, twoA, larger);
    const vwl both = at_start & at_end;
    v = SELECT(both, A * W, v);
    const vwl ok = both | (SPLAT(16.0) * v >= largest);
    *val = (vwd)((vwl)v & (meets & ok));
    *cancel = (meets & ~ok) | (~meets & (h > zero)); /* (and a chord lost to rounding: its exact span) */
}

/* axis_lanes for a node beyond an end of the segment, the same values bit for bit: before its start (u < 0:
   lo <= u < 0, the start is inside the ball; no straddle) ... */
INLINE void axis_lanes_before(vwd u, vwd h, vwd A, vwd Pc, vwd Es, vwd Ee, vwd W, vwd L, vwd near, vwd *val,
                              vwl *cancel)
{
    const vwd zero = {0.0}, hi = u + h;
    const vwl at_end = hi >= L;
    const vwd t1 = SELECT(at_end, L, hi);
    const vwl meets = t1 > zero;
    const vwd P0 = A * Es, P1 = SELECT(at_end, A * Ee, Pc);
    const vwl first = P0 > P1;
    const vwd diff = ABS_LANES(P0 - P1), larger = SELECT(first, P0, P1);
    const vwd v = SELECT(at_end, A * W, diff);
    const vwl ok = at_end | (SPLAT(16.0) * v >= larger);
    *val = (vwd)((vwl)v & (meets & ok));
    /* (and near misses, their exact span: the packed entries', h > 0, not the padding's) */
    *cancel = (t1 > -near) & (h > zero) & ~(meets & ok);
}

/* ... and beyond its end (u > L: hi >= u > L, the end is inside the ball) */
INLINE void axis_lanes_after(vwd u, vwd h, vwd A, vwd Pc, vwd Es, vwd Ee, vwd W, vwd L, vwd near, vwd *val,
                             vwl *cancel)
{
    const vwd zero = {0.0}, lo = u - h;
    const vwl at_start = lo <= zero;
    const vwd t0 = SELECT(at_start, zero, lo);
    const vwl meets = L > t0;
    const vwd P0 = SELECT(at_start, A * Es, Pc), P1 = A * Ee;
    const vwl first = P0 > P1;
    const vwd diff = ABS_LANES(P0 - P1), larger = SELECT(first, P0, P1);
    const vwd v = SELECT(at_start, A * W, diff);
    const vwl ok = at_start | (SPLAT(16.0) * v >= larger);
    *val = (vwd)((vwl)v & (meets & ok));
    *cancel = (L + near > t0) & (h > zero) & ~(meets & ok);
}

/* a plane's lanes: before, within or after the segment (where: -1, 0, 1) */
INLINE void axis_plane_lanes(int where, vwd u, vwd h, vwd A, vwd Pc, vwd Es, vwd Ee, vwd W, vwd L, vwd near,
                             vwd *val, vwl *cancel)
{
    if (where < 0)
        axis_lanes_before(u, h, A, Pc, Es, Ee, W, L, near, val, cancel);
    else if (where > 0)
        axis_lanes_after(u, h, A, Pc, Es, Ee, W, L, near, val, cancel);
    else
        axis_lanes(u, h, A, Pc, Es, Ee, W, L, val, cancel);
}

/* axis_plane_lanes of the packed entries kw .. kw + VW (their h, A and Pc) */
INLINE void axis_packed_lanes(int where, vwd u, const double *PH, const double *PA, const double *PP, cg_index kw,
                              vwd Es, vwd Ee, vwd W, vwd L, vwd near, vwd *val, vwl *cancel)
{
    vwd h, A, Pc;
    memcpy(&h, PH + kw, sizeof h);
    memcpy(&A, PA + kw, sizeof A);
    memcpy(&Pc, PP + kw, sizeof Pc);
    axis_plane_lanes(where, u, h, A, Pc, Es, Ee, W, L, near, val, cancel);
}

/* the AVX-512 build packs lanes by its compress instructions (the 4-wide, lane by lane: the same values) */
#if VW == 8 && defined(CG_SEPARABLE_WIDE) && defined(__GNUC__) && !defined(__clang__)
#define AXIS_COMPRESS 1
#else
#define AXIS_COMPRESS 0
#endif

/* o[at[k]] += w[k] for k < n (the values already times the picked value and the scale, as block_add_picked
   multiplies them) */
INLINE void scatter_add_one(double *restrict o, const double *restrict w, const cg_index *restrict at, cg_index n)
{
    for (cg_index k = 0; k < n; ++k) o[at[k]] += w[k];
}

/* o[at[k] + c] += (scale * w[k]) * v[c] for k < n and the picked values c (kind PLAIN + nv: all): block_add_picked
   node by node, at each node's offset (a term w[k] = 0 is left out beyond one picked value: it adds +-0) */
INLINE void scatter_add_picked(double *restrict o, double scale, const double *restrict w, const cg_index *restrict at,
                               cg_index n, const double *restrict v, int nv, const picked *p)
{
    if (p->kind == 1) {
        const double v0 = p->v[0];
        double *restrict o0 = o + p->at[0];
        for (cg_index k = 0; k < n; ++k) o0[at[k]] += (scale * w[k]) * v0;
        return;
    }
    for (cg_index k = 0; k < n; ++k)
        if (w[k] != 0.0) block_add_picked(o + at[k], scale, w + k, 1, v, nv, p);
}

/* a plane's values w added to the values held apart by rows (sum: the plane's first node): the packed rows
   [r0, r1) (row r: entries [start[r], start[r + 1]), contiguous nodes from sum + node[r]) */
INLINE void add_plane_rows(double *restrict sum, const double *restrict w, const cg_index *restrict start,
                           const cg_index *restrict node, cg_index r0, cg_index r1)
{
    for (cg_index r = r0; r < r1; ++r) {
        const cg_index k0 = start[r], n = start[r + 1] - k0;
        double *restrict d = sum + node[r];
        const double *restrict v = w + k0;
        /* (the compiler's vectors: masked vectors of 8 per row were 3 % slower at 3 w on W1, 2 % at 5 w) */
        for (cg_index j = 0; j < n; ++j) d[j] += v[j];
    }
}

/* a plane's n values w added at their nodes' offsets at (out: the plane's first output; one: a single picked value,
   the values already times it and the scale) */
INLINE void add_plane(double *out, const double *restrict w, const cg_index *restrict at, cg_index n, double scale,
                      int one, const double *restrict values, int nv, const picked *pick)
{
    if (one)
        scatter_add_one(out + pick->at[0], w, at, n);
    else
        scatter_add_picked(out, scale, w, at, n, values, nv, pick);
}

/* visit_axis's cancelling nodes (and those whose sphere misses an end of the segment, or the segment, by less
   than rounding), gathered in a cut batch as q[0] = A, q[1] = d0 and q[2] = span: the part of the segment
   inside the node's ball is [u + d0, u + d0 + span], its span from exact differences (cg_cut_span_lane, as the
   general path's fallback: h = sqrt(R^2 - rho^2) rounded would take a sliver's digits), d0 = -u where it starts
   at the start, L - u - span where it ends at the end, else -span / 2. The terms cancel, so the interval is
   short (as cut_batch_flush's fallback): there the 8-point Gauss-Legendre rule is exact to round-off,
     value = amp / L  A span sum_g gw_g exp(-(d0 + gx_g span)^2 / 2w^2)
   (A times an exponential is normal: rho^2 + d^2 <= R^2 inside the ball, R^2 / 2w^2 < AXIS_EXPONENT_MAX). */
static void axis_cut_flush(cut_batch *b, const job *jb, double *out, cg_index obj, double L, double w, double amp,
                           const picked *pick, double *sums, cg_index sums_at)
{
    const int n = b->n;
    b->n = 0;
    if (n == 0) return;
    double gx[CUT_FALLBACK_POINTS], gw[CUT_FALLBACK_POINTS];
    cg_gauss_legendre01(CUT_FALLBACK_POINTS, gx, gw);
    const double inv2w2 = 0.5 / (w * w), per_length = amp / L;
    double *restrict arg = b->arg; /* CUT_BATCH_WORK CUT_BATCH > CUT_FALLBACK_POINTS CUT_BATCH + EXP_PAD */
    const cg_index n_args = (cg_index)CUT_FALLBACK_POINTS * n;
    for (int g = 0; g < CUT_FALLBACK_POINTS; ++g)
        for (int i = 0; i < n; ++i) {
            const double d = b->q[1][i] + gx[g] * b->q[2][i];
            arg[g * n + i] = -(d * d) * inv2w2;
        }
    for (cg_index k = n_args; k < n_args + EXP_PAD; ++k) arg[k] = 0.0;
    cg_exp_in_place(arg, n_args);
    for (int i = 0; i < n; ++i) {
        double sum = 0.0;
        for (int g = 0; g < CUT_FALLBACK_POINTS; ++g) sum += gw[g] * arg[g * n + i];
        b->value[i] = (b->q[0][i] * sum) * (b->q[2][i] * per_length);
    }
    if (sums) /* (one picked value held apart: cut_batch_add's terms) */
        for (int i = 0; i < n; ++i) sums[b->node[i] - sums_at] += b->value[i] * pick->v[0];
    else
        cut_batch_add(b, n, jb, out, obj, pick);
}

/* (round-up to a multiple of 2 VW) */
#define AXIS_UP(n) (((size_t)(n) + 2 * VW - 1) / (2 * VW) * (2 * VW))

#if defined(__GNUC__)
__attribute__((noinline))
#endif
HOT_CLONES static int visit_axis(const job *jb, double *out, scratch *sc, cg_index obj, const double *x,
                                 const double *es, const cg_index first[3], const cg_index count[3],
                                 const cg_index stride[3], int m, double amp, double L2, const picked *pick)
{
    const cg_target *t = jb->target;
    const int pad = 3 - t->n_resolved, nv = jb->n_values;
    const double R = jb->kernel->radius, R2 = R * R, w = jb->kernel->width, inv2w2 = 0.5 / (w * w);
    const double L = sqrt(L2), sgn = es[m] < 0.0 ? -1.0 : 1.0;
    const double factor = amp * 1.2533141373155003 * w / L; /* as cut_batch_flush's */
    const double inv_sqrt2w = 1.0 / (1.4142135623730951 * w), q4 = 0.25 / (w * w);
    const int c1 = m == 0 ? 1 : 0, c2 = m == 2 ? 1 : 2; /* the cross slots */
    const cg_index n0 = count[0], n1 = count[1], n2 = count[2], nm = count[m], na = count[c1], nb = count[c2];
    const cg_index nbp = (nb + VW - 1) / VW * VW; /* a cross row in whole vectors */
    /* (q: room for a vector read from any entry, ge: for the cross slots' entries in whole EXP_PAD) */
    const size_t nmp = (size_t)(nm + VW - 1) / VW * VW, nsp = AXIS_UP(n0 + n1 + n2 + EXP_PAD);
    const size_t npx = AXIS_UP(na * nb + VW); /* the packed cross entries, at most, and room for a vector */
    /* node - x per slot; the cross slots' exponentials; along: u, Es, Ee, W and two work arrays (2 nmp
       for the exponentials); the cross rows' A, h and erfcx argument; packed: A, h, Pc, offset; two planes'
       values; a cut batch */
    const size_t nrx = (size_t)na * (size_t)nbp; /* the cross rows, whole vectors each */
    const size_t need = nsp + nsp + EXP_PAD + 6 * nmp + 3 * nrx + 7 * npx + CUT_BATCH_DOUBLES;
    double *buf = scratch_get(sc, need);
    if (!buf) return -1;
    double *q[3] = {buf, buf + n0, buf + n0 + n1};
    double *ge = buf + nsp, *g[3] = {ge, ge + n0, ge + n0 + n1}; /* and room for the along exponents */
    double *U = ge + nsp + EXP_PAD + 2 * nmp, *WW = U + nmp;
    double *ES = WW + nmp, *EE = ES + nmp, *PP = EE + nmp;
    double *RA = PP + npx, *RH = RA + nrx, *RP = RH + nrx;
    double *PA = RP + nrx, *PH = PA + npx;
    cg_index *PO = (cg_index *)(void *)(PH + npx); /* (cg_index and double are both 8 bytes) */
    double *const planebufs[2] = {(double *)(void *)(PO + npx), (double *)(void *)(PO + npx) + npx};
    cg_index *PN = (cg_index *)(void *)(planebufs[1] + npx); /* the packed entries' nodes from node0 (below) */
    cut_batch cuts;
    cut_batch_init(&cuts, planebufs[1] + 2 * npx);
    const vwl lane = LANE_INDEX; /* (the loops in whole vectors: which lanes hold entries) */
    for (int s = 0; s < 3; ++s) {
        if (s < pad) {
            q[s][0] = 0.0;
            continue;
        }
        const double *restrict c = t->coords[s - pad] + first[s];
        const double xs_s = x[s - pad];
        for (cg_index k = 0; k < count[s]; ++k) q[s][k] = c[k] - xs_s;
    }
    for (size_t k = (size_t)(n0 + n1 + n2); k < nsp; ++k) buf[k] = 0.0; /* (read, not used: whole vectors) */
    /* The exponentials in one batch (the cross slots' 1-D Gaussians, the along entries' halved exponents),
       and the erfcx (the along entries' ends, the packed cross entries' crossings) in two loops back to
       back, after the packing: a few vectors each, whose chains overlap (a batch per table, each followed by
       the work that needs it, left them to their latency) */
    /* the cross slots' 1-D Gaussians (q's slots are contiguous: those of the cross slots, [g_lo, g_hi), with
       the along slot's between them for m = 1, computed, not used), in whole vectors, then the along
       entries' exponents e0 and e1 */
    const cg_index g_lo = m == 0 ? n0 : 0, g_hi = m == 2 ? n0 + n1 : n0 + n1 + n2;
    const cg_index g_n = (g_hi - g_lo + EXP_PAD - 1) / EXP_PAD * EXP_PAD;
    double *restrict e0 = ge + g_lo + g_n, *restrict e1 = e0 + nmp;
    int erfcx_beyond; /* (some along argument beyond erfcx's short polynomial) */
    {
        /* in whole vectors (short loops of a few: element by element, their set-up and exits cost more than
           their arithmetic), the lanes beyond the entries 0; the same operations per entry */
        const vwd zero = {0.0}, i2 = SPLAT(inv2w2);
        for (cg_index k = g_lo; k < g_lo + g_n; k += VW) {
            vwd qk;
            memcpy(&qk, q[0] + k, sizeof qk);
            const vwd arg = -(qk * qk) * i2;
            const vwd val = SELECT(lane + k < g_hi, arg, zero);
            memcpy(ge + k, &val, sizeof val);
        }
        /* along: u, the ends' erfc as (E erfcx) E with E the halved exponent's exponential. An end's term is
           read only where the end is inside a node's ball (|u| or |u - L| at most h <= R, as the lanes round
           it: sqrt(R^2 - rho^2) within an ulp of R); elsewhere its value does not matter, so its argument is
           clamped at R / sqrt2 w (and a margin): on the short polynomial for cutoffs up to 5.6 w, where the
           far ends of the along entries (|u - L| up to R + L) took the long series */
        const double *qm = q[m];
        const vwd sg = SPLAT(sgn), Lv = SPLAT(L), q4v = SPLAT(q4), isw = SPLAT(inv_sqrt2w);
        const vwd limit = SPLAT(ERFCX_SHORT_MAX), reach = SPLAT(R * inv_sqrt2w * (1.0 + 0x1p-20));
        vwl beyond = {0};
        for (size_t a = 0; a < nmp; a += VW) {
            vwd qa;
            memcpy(&qa, qm + a, sizeof qa);
            const vwl in = lane + (int64_t)a < nm;
            const vwd u = sg * qa, v = u - Lv;
            vwd su = SELECT(u < zero, -u, u) * isw, sv = SELECT(v < zero, -v, v) * isw;
            su = SELECT(su > reach, reach, su);
            sv = SELECT(sv > reach, reach, sv);
            const vwd ua = SELECT(in, u, zero), e0a = SELECT(in, -(u * u) * q4v, zero);
            const vwd e1a = SELECT(in, -(v * v) * q4v, zero), esa = SELECT(in, su, zero), eea = SELECT(in, sv, zero);
            memcpy(U + a, &ua, sizeof ua);
            memcpy(e0 + a, &e0a, sizeof e0a);
            memcpy(e1 + a, &e1a, sizeof e1a);
            memcpy(ES + a, &esa, sizeof esa);
            memcpy(EE + a, &eea, sizeof eea);
            beyond |= (esa > limit) | (eea > limit);
        }
        erfcx_beyond = mask_bits(beyond) != 0;
    }
    cg_exp_in_place(ge + g_lo, g_n + (cg_index)(2 * nmp));
    /* cross: the entries whose line meets the ball (rho^2 < R^2: h > 0), packed (row by row, in order):
       A, h, the crossing's term Pc = exp(-R^2 / 2w^2) erfcx(h / sqrt2 w), and each entry's node (its
       index over the cross slots) and output offset; whole vectors of two (padding: h = 0, which meets
       no segment) */
    const cg_index width = jb->out_width;
    /* the cross slots' strides (sb > 0: slot c2 is resolved; sa = 0 where slot c1 is not, its one entry 0) and the
       node of their first entries */
    const cg_index sa = stride[c1], sb = stride[c2], node0 = first[c1] * sa + first[c2] * sb;
    /* the packed rows (cross entries along slot c2 of one entry along c1): their first entries, and their
       entries' largest h */
    cg_index npk = 0, n_rows = 0, row_start[65], npad;
#if !AXIS_COMPRESS
    cg_index row_a[64];
#endif
    double row_h[64];
    {
        const double *restrict qa = q[c1], *restrict ga = g[c1];
        const vwd R2v = SPLAT(R2), isw = SPLAT(inv_sqrt2w), zero = {0.0};
        double qb[64 + VW], gb[64 + VW];
        for (cg_index b = 0; b < nbp; b += VW) {
            vwd qv, gv;
            memcpy(&qv, q[c2] + b, sizeof qv);
            memcpy(&gv, g[c2] + b, sizeof gv);
            const vwl in = lane + b < nb;
            qv = SELECT(in, qv, zero);
            gv = SELECT(in, gv, zero);
            memcpy(qb + b, &qv, sizeof qv);
            memcpy(gb + b, &gv, sizeof gv);
        }
        const cg_index sbw = sb * width;
#if AXIS_COMPRESS
        cg_index lane_offsets[8];
        for (int l = 0; l < 8; ++l) lane_offsets[l] = l * sbw;
        const __m512i lane_at = _mm512_loadu_si512(lane_offsets);
        for (int l = 0; l < 8; ++l) lane_offsets[l] = l * sb;
        const __m512i lane_node = _mm512_loadu_si512(lane_offsets);
#endif
        for (cg_index a = 0; a < na; ++a) {
            if (!(qa[a] * qa[a] < R2)) continue;
            double *ra = RA + n_rows * nbp, *rh = RH + n_rows * nbp, *rp = RP + n_rows * nbp;
#if AXIS_COMPRESS
            const cg_index row_at = (node0 + a * sa) * width;
            __m512d h_max = _mm512_setzero_pd();
            row_start[n_rows] = npk;
            ++n_rows;
#else
            row_a[n_rows++] = a;
#endif
            const vwd qa2 = SPLAT(qa[a] * qa[a]), gaa = SPLAT(ga[a]);
            for (cg_index bw = 0; bw < nbp; bw += VW) {
                vwd qbv, gbv, h;
                memcpy(&qbv, qb + bw, sizeof qbv);
                memcpy(&gbv, gb + bw, sizeof gbv);
                vwd hh = R2v - (qa2 + qbv * qbv);
                hh = SELECT(hh > zero, hh, zero);
                sqrt_lanes(hh, &h);
                const vwd A = gaa * gbv, arg = h * isw;
#if AXIS_COMPRESS
                /* packed here: the row's entries (b < nb) with h > 0, compressed */
                const __mmask8 in_row = nb - bw >= 8 ? (__mmask8)0xff : (__mmask8)((1u << (nb - bw)) - 1u);
                const __mmask8 keep = in_row & _mm512_cmp_pd_mask((__m512d)h, _mm512_setzero_pd(), _CMP_GT_OQ);
                const __m512i at = _mm512_add_epi64(_mm512_set1_epi64(row_at + bw * sbw), lane_at);
                _mm512_storeu_pd(PA + npk, _mm512_maskz_compress_pd(keep, (__m512d)A));
                _mm512_storeu_pd(PH + npk, _mm512_maskz_compress_pd(keep, (__m512d)h));
                _mm512_storeu_pd(PP + npk, _mm512_maskz_compress_pd(keep, (__m512d)arg));
                _mm512_storeu_si512(PO + npk, _mm512_maskz_compress_epi64(keep, at));
                const __m512i node = _mm512_add_epi64(_mm512_set1_epi64(a * sa + bw * sb), lane_node);
                _mm512_storeu_si512(PN + npk, _mm512_maskz_compress_epi64(keep, node));
                npk += __builtin_popcount(keep);
                h_max = _mm512_max_pd(h_max, _mm512_maskz_mov_pd(keep, (__m512d)h));
#else
                memcpy(ra + bw, &A, sizeof A);
                memcpy(rh + bw, &h, sizeof h);
                memcpy(rp + bw, &arg, sizeof arg);
#endif
            }
#if AXIS_COMPRESS
            row_h[n_rows - 1] = _mm512_reduce_max_pd(h_max);
            (void)ra, (void)rh, (void)rp;
#endif
        }
#if !AXIS_COMPRESS
        /* packed in a second pass (read right after their vector stores, the entries would stall store
           forwarding); branch-free: every entry is written at npk, which moves on past those that meet the
           ball */
        for (cg_index r = 0; r < n_rows; ++r) {
            const double *ra = RA + r * nbp, *rh = RH + r * nbp, *rp = RP + r * nbp;
            const cg_index row_at = (node0 + row_a[r] * sa) * width;
            double h_max = 0.0;
            row_start[r] = npk;
            for (cg_index b = 0; b < nb; ++b) {
                const double h = rh[b];
                PA[npk] = ra[b];
                PH[npk] = h;
                PP[npk] = rp[b];
                PO[npk] = row_at + b * sbw;
                PN[npk] = row_a[r] * sa + b * sb;
                npk += h > 0.0;
                h_max = h > h_max ? h : h_max;
            }
            row_h[r] = h_max;
        }
#endif
        row_start[n_rows] = npk;
        npad = (cg_index)AXIS_UP(npk);
        for (cg_index k = npk; k < npad; ++k) PA[k] = PH[k] = PP[k] = 0.0;
    }
    /* one picked value and a cutoff of HOLD_REACH node spacings or more: its values held apart. Across rows along
       slot 2 (stride 1) they take a plane's rows as vectors (row r from node0 + row_node[r] of the plane); along
       slot 2, a plane's entries at their nodes PN, a plane's node next to the previous plane's (in out, 9 values
       apart: a cache line each) */
    double *sums = NULL;
    cg_index row_node[64], sums_at = 0;
    int hold = pick->kind == 1;
    for (int a = 0; a < t->n_resolved; ++a) /* (the job's rule, not the segment's: no flush between its segments) */
        hold &= !(R < HOLD_REACH * jb->spacing[a]);
    if (!hold) cg_separable_flush(sc); /* (this segment writes to out) */
    if (hold) {
        cg_index lo = 0, hi = 1;
        for (int s = 0; s < 3; ++s) {
            lo += first[s] * stride[s];
            hi += (count[s] - 1) * stride[s];
        }
        sums = axis_sums_of(sc, jb, out, pick->at[0], lo, lo + hi, &sums_at);
        if (sums && m != 2)
            for (cg_index r = 0; r < n_rows; ++r)
                row_node[r] = row_start[r] < row_start[r + 1] ? PN[row_start[r]] : 0;
    }
    {
        /* (two loops, one after the other, the along ends paired: only their vectors may need the long
           series, the crossings' arguments h / sqrt2 w being at most R / sqrt2 w, beyond 4 only where
           R > 5.648 w) */
        erfcx_in_place2(ES, EE, (cg_index)nmp, erfcx_beyond);
        erfcx_in_place2(PP, PP + npad / 2, npad / 2, R2 > 31.9 * (w * w));
        const double ER = exp(-R2 * inv2w2);
        for (cg_index k = 0; k < npk; ++k) PP[k] = ER * PP[k];
    }
    /* along: the ends' terms and the bracket where both ends are inside, W */
    {
        /* (in whole vectors, as the along entries above) */
        const vwd zero = {0.0}, two = SPLAT(2.0), sixteen = SPLAT(16.0), Lv = SPLAT(L);
        vwl cancels = {0};
        for (size_t a = 0; a < nmp; a += VW) {
            vwd e0a, esa, e1a, eea, u;
            memcpy(&e0a, e0 + a, sizeof e0a);
            memcpy(&esa, ES + a, sizeof esa);
            memcpy(&e1a, e1 + a, sizeof e1a);
            memcpy(&eea, EE + a, sizeof eea);
            memcpy(&u, U + a, sizeof u);
            const vwd es_a = (e0a * esa) * e0a, ee_a = (e1a * eea) * e1a;
            memcpy(ES + a, &es_a, sizeof es_a);
            memcpy(EE + a, &ee_a, sizeof ee_a);
            const vwl straddle = (u > zero) & (u < Lv), first = es_a > ee_a;
            const vwd larger = SELECT(first, es_a, ee_a), diff = SELECT(first, es_a - ee_a, ee_a - es_a);
            const vwd v = SELECT(straddle, (two - es_a) - ee_a, diff), largest = SELECT(straddle, two, larger);
            memcpy(WW + a, &v, sizeof v);
            cancels |= ~(sixteen * v >= largest) & (lane + (int64_t)a < nm);
        }
        if (mask_bits(cancels)) {
            double gx[CUT_FALLBACK_POINTS], gw[CUT_FALLBACK_POINTS];
            cg_gauss_legendre01(CUT_FALLBACK_POINTS, gx, gw);
            const double scale_back = L / (1.2533141373155003 * w); /* W is in units of factor */
            for (cg_index a = 0; a < nm; ++a) {
                const double es_a = ES[a], ee_a = EE[a], u = U[a];
                const int straddle = (u > 0.0) & (u < L);
                const double larger = es_a > ee_a ? es_a : ee_a, largest = straddle ? 2.0 : larger;
                if (16.0 * WW[a] >= largest) continue;
                double arg[CUT_FALLBACK_POINTS + EXP_PAD];
                for (int k = 0; k < CUT_FALLBACK_POINTS; ++k) {
                    const double d = u - gx[k] * L;
                    arg[k] = -(d * d) * inv2w2;
                }
                for (int k = CUT_FALLBACK_POINTS; k < CUT_FALLBACK_POINTS + EXP_PAD; ++k) arg[k] = 0.0;
                cg_exp_in_place(arg, CUT_FALLBACK_POINTS);
                double sum = 0.0;
                for (int k = 0; k < CUT_FALLBACK_POINTS; ++k) sum += gw[k] * arg[k];
                WW[a] = sum * scale_back;
            }
        }
    }
    const double *values = jb->values + obj * nv;
    const vwd Lv = SPLAT(L);
    /* the along entries within R of the segment's line range, [u_lo, u_hi) (u is monotone along its slot) */
    cg_index u_lo = nm, u_hi = nm;
    {
        /* (a bit per entry, nm <= 64: the set bits are one run) */
        const vwd lo = SPLAT(-R), hi = SPLAT(L + R);
        uint64_t within = 0;
        for (size_t a = 0; a < nmp; a += VW) {
            vwd u;
            memcpy(&u, U + a, sizeof u);
            within |= mask_bits((u > lo) & (u < hi) & (lane + (int64_t)a < nm)) << a;
        }
        if (within) {
            u_lo = __builtin_ctzll(within);
            u_hi = 64 - __builtin_clzll(within);
        }
    }
    /* Plane by plane (an along entry): every packed entry's value in one vector loop, then added at its node.
       A plane's update of the output waits for the next plane's values (read right after their vector
       stores, the values would stall store forwarding). */
    const double *pending = NULL;
    cg_index pending_at = 0, pending_lo = 0, pending_hi = 0, pending_r0 = 0, pending_r1 = 0;
    int parity = 0;
    const cg_index sm = stride[m];
    /* one picked value: the plane's values times it and the scale in the vector loop, added as they are */
    const int one = pick->kind == 1;
    const vwd factor_v = SPLAT(factor), v0_v = SPLAT(one ? pick->v[0] : 1.0);
    /* a crossing within this of an end (or a chord lost to rounding) goes to axis_cut_flush with the span
       of the part inside the ball from exact differences (cg_cut_span_lane), as the general path's short
       lanes do */
    const double near = 0x1p-40 * R;
    const vwd near_v = SPLAT(near);
    /* the pending plane's values added: held apart (along slot 2 at their nodes, across it by rows), else to out */
#define ADD_PENDING_PLANE()                                                                                            \
    do {                                                                                                               \
        if (!pending)                                                                                                  \
            break;                                                                                                     \
        if (sums && m == 2)                                                                                            \
            scatter_add_one(sums + (pending_at + node0 - sums_at), pending + pending_lo, PN + pending_lo,              \
                            pending_hi - pending_lo);                                                                  \
        else if (sums)                                                                                                 \
            add_plane_rows(sums + (pending_at + node0 - sums_at), pending, row_start, row_node, pending_r0,            \
                           pending_r1);                                                                                \
        else                                                                                                           \
            add_plane(out + pending_at * width, pending + pending_lo, PO + pending_lo, pending_hi - pending_lo,        \
                      factor, one, values, nv, pick);                                                                  \
    } while (0)
    cg_cut_span_frame span_frame;
    int have_frame = 0;
    for (cg_index i = u_lo; i < u_hi; ++i) {
        const double ui = U[i];
        /* beyond an end, the rows whose h is too short to reach the segment, or nearly (u + h <= -near or
           u - h >= L + near for each of their entries, as the lanes round it), meet nothing: a plane's entries
           that may meet it are those of a range of rows [r0, r1) (h is largest in the middle rows),
           [k_lo, k_hi) */
        cg_index r0 = 0, r1 = n_rows;
        if (ui < 0.0) {
            while (r0 < r1 && !(ui + row_h[r0] > -near)) ++r0;
            while (r1 > r0 && !(ui + row_h[r1 - 1] > -near)) --r1;
        } else if (ui > L) {
            while (r0 < r1 && !(ui - row_h[r0] < L + near)) ++r0;
            while (r1 > r0 && !(ui - row_h[r1 - 1] < L + near)) --r1;
        }
        const cg_index k_lo = row_start[r0], k_hi = row_start[r1];
        const int where = ui < 0.0 ? -1 : ui > L;
        const vwd u = SPLAT(ui), Es = SPLAT(ES[i]), Ee = SPLAT(EE[i]), W = SPLAT(WW[i]);
        double *restrict pv = planebufs[parity];
        vwl any_cancel = {0};
        for (cg_index kw = k_lo / VW * VW; kw < k_hi; kw += VW) {
            vwd val;
            vwl cancel;
            axis_packed_lanes(where, u, PH, PA, PP, kw, Es, Ee, W, Lv, near_v, &val, &cancel);
            if (one) val = (factor_v * val) * v0_v; /* (block_add_picked's products) */
            memcpy(pv + kw, &val, sizeof val);
            any_cancel |= cancel;
        }
        /* (the plane's nodes that miss the ball, or cancel, are 0 in pv, and add +-0) */
        ADD_PENDING_PLANE();
        pending = pv;
        pending_lo = k_lo;
        pending_hi = k_hi;
        pending_r0 = r0;
        pending_r1 = r1;
        const cg_index plane_node = (first[m] + i) * sm;
        pending_at = plane_node; /* (its node with cross index 0; the held values' index from node0 on) */
        parity ^= 1;
        if (mask_bits(any_cancel)) {
            /* the cancelling nodes (few: their lanes again, as above), gathered for axis_cut_flush */
            for (cg_index kw = k_lo / VW * VW; kw < k_hi; kw += VW) {
                vwd val;
                vwl cancel;
                axis_packed_lanes(where, u, PH, PA, PP, kw, Es, Ee, W, Lv, near_v, &val, &cancel);
                for (uint64_t bits = mask_bits(cancel); bits; bits &= bits - 1) {
                    const cg_index k = kw + __builtin_ctzll(bits);
                    if (k >= k_hi) break; /* (the padding: h = 0, never flagged; kept out whatever the lanes say) */
                    if (cuts.n == CUT_BATCH) axis_cut_flush(&cuts, jb, out, obj, L, w, amp, pick, sums, sums_at);
                    /* the part inside the ball: its span from exact differences, in the node's coordinates
                       q (the cross entries' indices from the offset); it starts at the start where that is
                       inside (as the lanes round it), ends at the end where that is, else is the chord
                       centred on the node's foot */
                    if (!have_frame) {
                        cg_cut_span_frame_of(es, R, &span_frame);
                        have_frame = 1;
                    }
                    const cg_index cross = PN[k]; /* ia sa + ib sb, ib sb < sa */
                    const cg_index ia = sa ? cross / sa : 0, ib = (cross - ia * sa) / sb;
                    double qn[3];
                    qn[m] = q[m][i];
                    qn[c1] = q[c1][ia];
                    qn[c2] = q[c2][ib];
                    const double span = cg_cut_span_lane(qn[0], qn[1], qn[2], &span_frame) * L;
                    const double uu = U[i], hk = PH[k];
                    const int at_start = uu - hk <= 0.0, at_end = uu + hk >= L;
                    const int n = cuts.n++;
                    cuts.q[0][n] = PA[k];
                    cuts.q[1][n] = at_start ? -uu : (at_end ? (L - uu) - span : -0.5 * span);
                    cuts.q[2][n] = span;
                    cuts.node[n] = plane_node + node0 + PN[k];
                }
            }
        }
    }
    ADD_PENDING_PLANE();
#undef ADD_PENDING_PLANE
    axis_cut_flush(&cuts, jb, out, obj, L, w, amp, pick, sums, sums_at);
    return 1;
}
#endif

#ifndef CG_SEPARABLE_WIDE
static
#endif
HOT_CLONES
int VISIT_SEPARABLE(const job *jb, double *out, scratch *sc, cg_index obj, const double *x, const double *e,
                    double scale)
{
    const cg_target *t = jb->target;
    const cg_kernel *kn = jb->kernel;
    const int nr = t->n_resolved, pad = 3 - nr;
    const double R = kn->radius, R2 = R * R, w = kn->width, inv2w2 = 0.5 / (w * w);
    axis_sums_release_for(sc, jb, e);
#ifdef HAVE_V4D
    if (!jb->is_segment && jb->mode == MODE_VALUE && visit_point(jb, out, obj, x)) return 1;
#endif

    /* the rule: G points on the object with weights (times the prefactor) */
    double gx[CG_MAX_LINE_POINTS], gw[CG_MAX_LINE_POINTS];
    int G = 1, hybrid = 0;
    double L2 = 0.0;
    if (jb->is_segment) {
        for (int a = 0; a < nr; ++a) L2 += e[a] * e[a];
        G = jb->ray ? 0 : jb->line_points;
        if (G == 0) {
            G = cg_gaussian_roundoff_points(sqrt(L2), w);
            if (G == 0) {
                cg_separable_flush(sc); /* (before the node-by-node visit writes to out) */
                return 0;                /* too long: the node-by-node erf form */
            }
            hybrid = 1;
        }
    } else {
        gx[0] = 0.0;
        gw[0] = kn->prefactor;
    }
    /* MODE_VALUE: the values that add anything (picked, where the weights are finite: all are at most
       |scale prefactor|, the closed form's at most 2 factor, cut_batch_flush's) */
    const int nv = jb->n_values;
    picked pick = {PLAIN + nv, {0, 0, 0}, {0.0, 0.0, 0.0}};
    if (jb->mode == MODE_VALUE) {
        const double amp = scale * kn->prefactor;
        if (isfinite(4.0 * amp) &&
            (!hybrid || !(L2 > 0.0) || isfinite(2.0 * (amp * 1.2533141373155003 * w / sqrt(L2)))) &&
            pick_values(jb->values + obj * nv, nv, &pick) == 0)
            return 1; /* every value is +-0: nothing to add */
    }

    /* stencil: node index range along each slot (as in visit_nodes) */
    cg_index first[3] = {0, 0, 0}, count[3] = {1, 1, 1}, stride[3] = {0, 0, 0};
    double xs[3] = {0.0, 0.0, 0.0}, es[3] = {0.0, 0.0, 0.0};
    cg_index st = 1;
    for (int a = nr - 1; a >= 0; --a) {
        const int s = a + pad;
        stride[s] = st;
        st *= t->shape[a];
        xs[s] = x[a];
        es[s] = e ? e[a] : 0.0;
        const double end = x[a] + es[s]; /* (libm's fmin and fmax are calls) */
        const double lo = (end < x[a] ? end : x[a]) - R, hi = (end > x[a] ? end : x[a]) + R;
        if (!slot_range(jb, a, s, lo, hi, first, count)) return 1;
    }
#ifdef HAVE_V4D
    /* a segment along a grid axis: every node's value from 1-D and cross-section tables (visit_axis); not on
       profiles (one resolved axis), whose blocks (cg_profile.c) give this visit's general bits */
    if (hybrid && nr > 1 && jb->mode == MODE_VALUE && L2 > 0.0 && count[0] <= 64 && count[1] <= 64 &&
        count[2] <= 64 && (es[0] != 0.0) + (es[1] != 0.0) + (es[2] != 0.0) == 1 && R2 * inv2w2 < AXIS_EXPONENT_MAX &&
        (L2 >= 1e-40 * (w * w) || R2 * inv2w2 - 0.5 * log(L2 / (w * w)) < AXIS_VALUE_EXPONENT_MAX)) {
        const double amp = scale * kn->prefactor;
        const double *v = jb->values + obj * nv;
        int finite = isfinite(2.0 * (amp * 1.2533141373155003 * w / sqrt(L2)));
        for (int c = 0; c < nv; ++c) finite &= isfinite(v[c]);
        if (finite) return visit_axis(jb, out, sc, obj, x, es, first, count, stride, es[2] != 0.0 ? 2 : es[1] != 0.0,
                                      amp, L2, &pick);
    }
#endif
    cg_separable_flush(sc); /* (the values held apart back in out before this visit writes to it) */
    if (jb->is_segment) { /* (the rule: after visit_axis's dispatch, which needs none) */
        cg_gauss_legendre01(G, gx, gw);
        for (int g = 0; g < G; ++g) gw[g] *= scale * kn->prefactor;
    }
    const cg_index n0 = count[0], n1 = count[1], n2 = count[2];
    const size_t per_table_f = (size_t)(n0 + n1 + n2); /* hybrid: the factorised weights (below) */
    const size_t per_point = 2 * (size_t)(n0 + n1 + n2);
    /* tables d2, g per rule point; end-point tables, a cut batch and a row's
       distances (hybrid); node coordinates; a row */
    /* the row has ROW_PAD more doubles: the exact form's rows are summed 8 at a time */
    const size_t hybrid_need = hybrid ? per_point + CUT_BATCH_DOUBLES + n2 + per_table_f + 2 * ROW_PAD + n2 : 0;
    const size_t need = (size_t)G * per_point + EXP_PAD + hybrid_need + (size_t)(n0 + n1 + n2) +
                        2 * ((size_t)n2 + ROW_PAD);
    double *buf = scratch_get(sc, need);
    if (!buf) return -1;
    double *coord = buf + (size_t)G * per_point + EXP_PAD + (hybrid ? per_point : 0); /* node - x, per slot */
    double *row = coord + (n0 + n1 + n2);
    cut_batch cuts = {0, {NULL, NULL, NULL}, NULL, NULL, NULL, NULL, NULL, NULL};
    /* (from 0: packed_tables reads up to 3 values past the coordinates) */
    if (hybrid || G > 1)
        for (cg_index k = 0; k < 2 * (n2 + ROW_PAD); ++k) row[k] = 0.0;
    if (hybrid) cut_batch_init(&cuts, row + n2 + ROW_PAD);
    double *dk = row + 2 * (n2 + ROW_PAD) + CUT_BATCH_DOUBLES; /* hybrid: a row's squared distances */
    /* node coordinates relative to x (points, and the exact form's ends) */
    double *cslot[3] = {coord, coord + n0, coord + n0 + n1};
    /* hybrid: squared distances of the nodes to the two ends, per slot (in the same pass) */
    double *endA[3] = {NULL, NULL, NULL}, *endB[3] = {NULL, NULL, NULL};
    if (hybrid) {
        double *p = buf + 2 * (size_t)G * (size_t)(n0 + n1 + n2) + EXP_PAD;
        for (int s = 0; s < 3; ++s) {
            endA[s] = p;
            endB[s] = p + count[s];
            p += 2 * count[s];
        }
    }
    if (!jb->is_segment || hybrid) {
        for (int s = 0; s < 3; ++s) {
            if (s < pad) {
                cslot[s][0] = 0.0;
                if (hybrid) {
                    const double qb = 0.0 - es[s];
                    endA[s][0] = 0.0 * 0.0;
                    endB[s][0] = qb * qb;
                }
                continue;
            }
            const double *restrict c = t->coords[s - pad] + first[s];
            double *restrict dst = cslot[s];
            const double xs_s = xs[s];
            if (hybrid) {
                double *restrict a = endA[s], *restrict b = endB[s];
                const double e_s = es[s];
                for (cg_index k = 0; k < count[s]; ++k) {
                    const double qa = c[k] - xs_s, qb = qa - e_s;
                    dst[k] = qa;
                    a[k] = qa * qa;
                    b[k] = qb * qb;
                }
            } else {
                for (cg_index k = 0; k < count[s]; ++k) dst[k] = c[k] - xs_s;
            }
        }
    }
    /* per rule point g and slot s: d2[g][s][k] = (node - point)^2 and
       ex[g][s][k] = exp(-d2 / 2w^2) (the exact form: its own layout, below); all
       exponentials in one vectorised call */
    double *d2[CG_MAX_LINE_POINTS][3], *ex[CG_MAX_LINE_POINTS][3];
    const size_t per_table = (size_t)(n0 + n1 + n2);
    double *d2_all = buf, *ex_all = buf + (size_t)G * per_table;
    for (int g = 0; g < (hybrid ? 0 : G); ++g) { /* the exact form: below, in its own layout */
        double *p = d2_all + (size_t)g * per_table;
        for (int s = 0; s < 3; ++s) {
            d2[g][s] = p;
            ex[g][s] = ex_all + (p - d2_all);
            p += count[s];
            double *restrict dst = d2[g][s];
            const double *restrict node = cslot[s];
            const double shift = jb->is_segment ? gx[g] * es[s] : 0.0; /* the rule point - x */
            const cg_index n = count[s];
            if (s - pad < 0) {
                dst[0] = 0.0;
                continue;
            }
            if (jb->is_segment) {
                /* (node - x) - shift: node - x is exact or nearly (both large and close
                   far from the origin), where x + shift would round at the scale of x */
                const double *restrict c = t->coords[s - pad] + first[s];
                const double x_s = xs[s];
                for (cg_index k = 0; k < n; ++k) {
                    const double q = (c[k] - x_s) - shift;
                    dst[k] = q * q;
                }
            } else {
                for (cg_index k = 0; k < n; ++k) dst[k] = node[k] * node[k];
            }
        }
    }
    /* The rule's weight at node (i, j, k) is sum_g gw[g] X_g[i] Y_g[j] Z_g[k]; along a slot the
       segment does not move (es = 0) the table is the same for every point. Where it moves along
       at most one slot (a segment along a grid axis, or of zero length), the weights are an
       outer product fx[i] fy[j] fz[k], the moving slot's table summed over the points once per
       object (factor 2): a row is then fz times a scalar, with no sum over the points per row.
       Where it moves along slots 0 and 1 only (in a grid plane of constant z), a row is gz times
       a scalar sum over the points (factor 1). Else each row is summed over the points
       (inside_row, factor 0). */
    const int moves0 = es[0] != 0.0, moves1 = es[1] != 0.0, moves2 = es[2] != 0.0;
    const int factor = !hybrid || G < 2 ? 0 : (moves0 + moves1 + moves2 <= 1 ? 2 : (!moves2 ? 1 : 0));
    double *const fx = dk + n2, *const fy = fx + n0, *const fz = fy + n1; /* factor 2 (hybrid's scratch) */
    double *const pz = fz + n2 + ROW_PAD; /* hybrid: the rows' q.e along slot 2, node by node */
    {
        /* whole vectors only (EXP_PAD): a scalar remainder would cost more than the rest */
        const size_t n_all = (size_t)G * per_table, n_padded = (n_all + EXP_PAD - 1) / EXP_PAD * EXP_PAD;
        if (hybrid && G > 1 && (es[0] == 0.0 || es[1] == 0.0 || es[2] == 0.0)) {
            /* a slot along which the segment does not move (es = +-0: a segment in a grid
               plane or along an axis) has the same exponents at every point (q - g 0 = q,
               and (-q)^2 = q^2): its exponentials once, packed with the other slots' in the
               d2 table (the exact form reads none), then copied to every point's place in
               the layout below: the same values with fewer exponentials. The packing's
               padding may reach into ex_all, which is written after it. */
            double *restrict packed = d2_all;
            size_t at[3];
            packed_tables(packed, at, cslot, count, es, gx, gw, G, inv2w2, factor == 2 ? fx : NULL, fy, fz);
            if (factor == 2) goto tables_done;
            for (int s = 0; s < 2; ++s) {
                double *restrict dst = ex_all + (s == 0 ? 0 : (size_t)G * n0);
                const double *restrict src = packed + at[s];
                const cg_index n = count[s];
                if (es[s] == 0.0) {
                    for (cg_index k = 0; k < n; ++k)
                        for (int g = 0; g < G; ++g) dst[k * G + g] = src[k];
                } else {
                    for (cg_index k = 0; k < n; ++k)
                        for (int g = 0; g < G; ++g) dst[k * G + g] = src[(size_t)g * n + k];
                }
            }
            for (int g = 0; g < G; ++g) {
                const double *restrict src = packed + at[2] + (es[2] == 0.0 ? 0 : (size_t)g * n2);
                memcpy(ex_all + (size_t)G * (n0 + n1) + (size_t)g * n2, src, (size_t)n2 * sizeof(double));
            }
            for (size_t i = n_all; i < n_all + EXP_PAD; ++i) ex_all[i] = 0.0; /* as below */
            goto tables_done;
        }
        if (hybrid) {
            /* the exact form reads no d2 table: the exponents straight from the node
               coordinates (node - x), the same operations as above, laid out for the
               rows' loops: slots 0 and 1 point-fastest (a plane's and a row's G weights
               contiguous), slot 2 point by point (a missing slot's one node: 0 - 0 = 0,
               as above) */
            for (int s = 0; s < 2; ++s) {
                double *restrict dst = ex_all + (s == 0 ? 0 : (size_t)G * n0);
                const double e_s = es[s];
                for (cg_index k = 0; k < count[s]; ++k)
                    for (int g = 0; g < G; ++g) {
                        const double q = cslot[s][k] - gx[g] * e_s;
                        dst[k * G + g] = -(q * q) * inv2w2;
                    }
            }
            for (int g = 0; g < G; ++g) {
                const double shift = gx[g] * es[2];
                double *restrict dst = ex_all + (size_t)G * (n0 + n1) + (size_t)g * n2;
                for (cg_index k = 0; k < n2; ++k) {
                    const double q = cslot[2][k] - shift;
                    dst[k] = -(q * q) * inv2w2;
                }
            }
        } else {
            for (size_t m = 0; m < n_all; ++m) ex_all[m] = -d2_all[m] * inv2w2;
        }
        for (size_t m = n_all; m < n_all + EXP_PAD; ++m) ex_all[m] = 0.0; /* read past by rows_of_rule */
        cg_exp_in_place(ex_all, (cg_index)n_padded);
    }
tables_done:;
    /* hybrid: the rows' q.e along slot 2 (the ends' tables: with the coordinates above) */
    if (hybrid) {
        for (cg_index k = 0; k < n2; ++k) pz[k] = cslot[2][k] * es[2];
        for (cg_index k = n2; k < n2 + ROW_PAD; ++k) pz[k] = 0.0;
    }
    const double R2_margin = R2 * (1.0 + 1e-12); /* the exact form decides near the sphere itself */
    /* the capsule's test by the distance to the line, |q|^2 - p^2 / L^2: its round-off, a few ulp of
       |q|^2 <= R^2 + L^2, within this margin */
    const double R2_cyl = R2_margin + 1e-14 * L2;
    const double *values = jb->mode == MODE_VALUE ? jb->values + obj * nv : NULL;
    const double e2d[3] = {es[0], es[1], 0.0};
    const double L2_2d = es[0] * es[0] + es[1] * es[1];
    const double inv_L2_2d = L2_2d > 0.0 ? 1.0 / L2_2d : 0.0, inv_L2 = L2 > 0.0 ? 1.0 / L2 : 0.0;
    if (!hybrid) {
        const cg_index node0 = first[0] * stride[0] + first[1] * stride[1] + first[2] * stride[2];
#ifdef HAVE_V4D
        /* 3 or more points: rows summed over the points first; 2 points: a pass
           each (measured on W1: 2 points 145 ms by passes, 175 by rows; 4 points
           280 ms by passes, 245 by rows) */
        if (G > 2 && n2 <= 64 && jb->mode == MODE_VALUE) {
            double *const rows[2] = {row, row + n2 + ROW_PAD};
            rows_of_rule(out + node0 * jb->out_width, stride[0] * jb->out_width, stride[1] * jb->out_width, n0, n1,
                         n2, G, (double *const(*)[3])d2, (double *const(*)[3])ex, gw, R2, rows, values, nv, &pick);
            return 1;
        }
#endif
        for (int g = 0; g < G; ++g)
            rows_of_one_point(jb, out, obj, node0, stride[0], stride[1], n0, n1, n2, d2[g][0], d2[g][1], d2[g][2],
                              ex[g][0], ex[g][1], ex[g][2], gw[g], R2, values, nv, &pick);
        return 1;
    }
    /* the exact form (hybrid) */
    /* the rule's weights as laid out above: gx_t[i G + g], gy_t[j G + g], gz_of[g][k] */
    const double *gx_t = ex_all, *gy_t = ex_all + (size_t)G * n0, *gz_of[CG_MAX_LINE_POINTS];
    for (int g = 0; g < G; ++g) gz_of[g] = ex_all + (size_t)G * (n0 + n1) + (size_t)g * n2;
    const double amp = scale * kn->prefactor, L = sqrt(L2);
    /* q . e of the nodes the rule keeps: at most FAR_BEYOND_END w beyond either end */
    const double far_lo = -FAR_BEYOND_END * w * L, far_hi = L2 + FAR_BEYOND_END * w * L;
    const int far_check = R - L > FAR_BEYOND_END * w; /* else no node with both ends inside is that far */
    for (cg_index i = 0; i < n0; ++i) {
        double ci[CG_MAX_LINE_POINTS]; /* the rule's weights times the plane's */
        if (factor != 2)
            for (int g = 0; g < G; ++g) ci[g] = gw[g] * gx_t[i * G + g];
        /* the plane's share of every row's constants */
        const double x_i = cslot[0][i], px_i = x_i * es[0], fx_i = factor == 2 ? fx[i] : 0.0;
        const double a0_i = endA[0][i], b0_i = endB[0][i];
        const cg_index base_i = (first[0] + i) * stride[0] + first[1] * stride[1] + first[2] * stride[2];
        /* rows whose line misses the capsule carry nothing: the plane's rows that
           meet it, as bits (n1 <= 64), VW rows at a time */
        uint64_t plane_bits = ~UINT64_C(0);
#ifdef HAVE_V4D
        if (n1 <= 64) {
            /* segment_distance2's operations on (x, y[j], 0) and (ex, ey, 0), less
               the terms that are +0 (they change no sum or product here) */
            const double xq = cslot[0][i], xe = xq * e2d[0];
            plane_bits = 0;
#if ROW_MASKS_AVX512
            /* the same operations, straight into mask registers (t: 0 without a length, then
               clamped to [0, 1] as +0 and 1) */
            const __mmask8 has_length = inv_L2_2d > 0.0 ? 0xFF : 0;
            const __m512d xv = _mm512_set1_pd(xq), xev = _mm512_set1_pd(xe), exv = _mm512_set1_pd(e2d[0]);
            const __m512d eyv = _mm512_set1_pd(e2d[1]), il = _mm512_set1_pd(inv_L2_2d);
            const __m512d Rm = _mm512_set1_pd(R2_margin), zero = _mm512_setzero_pd(), one = _mm512_set1_pd(1.0);
            for (cg_index jw = 0; jw < n1; jw += VW) {
                const __m512d y = _mm512_loadu_pd(cslot[1] + jw); /* (as below: reads past the plane's y) */
                __m512d t = _mm512_mul_pd(_mm512_add_pd(xev, _mm512_mul_pd(y, eyv)), il);
                t = _mm512_maskz_mov_pd(has_length, t);
                t = _mm512_mask_mov_pd(t, _mm512_cmp_pd_mask(t, zero, _CMP_LT_OQ), zero);
                t = _mm512_mask_mov_pd(t, _mm512_cmp_pd_mask(t, one, _CMP_GT_OQ), one);
                const __m512d d0 = _mm512_sub_pd(xv, _mm512_mul_pd(t, exv));
                const __m512d d1 = _mm512_sub_pd(y, _mm512_mul_pd(t, eyv));
                const __m512d dd = _mm512_add_pd(_mm512_mul_pd(d0, d0), _mm512_mul_pd(d1, d1));
                plane_bits |= (uint64_t)_mm512_cmp_pd_mask(dd, Rm, _CMP_LT_OQ) << jw;
            }
#else
            const vwd xv = SPLAT(xq), xev = SPLAT(xe), exv = SPLAT(e2d[0]), eyv = SPLAT(e2d[1]);
            const vwd il = SPLAT(inv_L2_2d), Rm = SPLAT(R2_margin), zero = {0.0}, one = SPLAT(1.0);
            const vwl has_length = SPLAT(inv_L2_2d) > zero;
            for (cg_index jw = 0; jw < n1; jw += VW) {
                vwd y; /* reads up to VW - 1 past the plane's y (into cslot[2]; those bits are dropped) */
                memcpy(&y, cslot[1] + jw, sizeof y);
                vwd t = (xev + y * eyv) * il;
                t = (vwd)((vwl)t & has_length);
                const vwl below = (vwl)(t < zero);
                t = (vwd)((vwl)t & ~below);
                const vwl above = (vwl)(t > one);
                t = (vwd)(((vwl)t & ~above) | ((vwl)one & above));
                const vwd d0 = xv - t * exv, d1 = y - t * eyv;
                plane_bits |= mask_bits((vwl)(d0 * d0 + d1 * d1 < Rm)) << jw;
            }
#endif
            plane_bits &= n1 >= 64 ? ~UINT64_C(0) : (UINT64_C(1) << n1) - 1;
        }
#endif
        for (cg_index j = 0; j < n1; ++j) {
#ifdef HAVE_V4D
            if (n1 <= 64) {
                /* on to the next row that meets the capsule */
                const uint64_t rest = plane_bits >> j;
                if (!rest) break;
                j += (cg_index)__builtin_ctzll(rest);
            }
#endif
            /* the nodes of the row that receive anything: row[k0..k1) */
            cg_index k0 = n2, k1 = 0;
            const cg_index base = base_i + j * stride[1];
            {
#ifdef HAVE_V4D
                if (n1 > 64)
#endif
                {
                    const double q2d[3] = {cslot[0][i], cslot[1][j], 0.0};
                    if (!(segment_distance2(q2d, e2d, inv_L2_2d) < R2_margin)) continue;
                }
                /* the rule is exact where both ends, hence the whole segment, lie inside
                   the ball (an interval: two balls meet the row in intervals) */
                const double a01 = a0_i + endA[1][j], b01 = b0_i + endB[1][j];
                const double *za = endA[2], *zb = endB[2];
#ifdef HAVE_V4D
                if (n2 <= 64) {
                    /* the same tests as the walks and loops below, VW nodes at a time, as bits, in
                       one pass: the rule's nodes (both ends inside), those near enough to the ends
                       (far_check), and the capsule's candidates. A node is in the capsule if it is
                       in either end's ball or, projecting onto the segment (0 <= p = q.e <= L^2),
                       its squared distance to the line, |q|^2 - p^2 / L^2, is below R^2: the
                       nodes row_distance2 puts inside, up to round-off of |q|^2 (R2_cyl's margin;
                       the exact form decides near the sphere itself) */
                    const uint64_t valid = n2 >= 64 ? ~UINT64_C(0) : (UINT64_C(1) << n2) - 1;
                    uint64_t in_bits = 0, cand_bits = 0, near_bits = 0;
                    const double xq = x_i, yq = cslot[1][j];
                    const double pxy = px_i + yq * es[1];
#if ROW_MASKS_AVX512
                    {
                        /* the same tests straight into mask registers */
                        const __m512d a01v = _mm512_set1_pd(a01), b01v = _mm512_set1_pd(b01);
                        const __m512d R2v = _mm512_set1_pd(R2), Rmv = _mm512_set1_pd(R2_margin);
                        const __m512d Rcv = _mm512_set1_pd(R2_cyl), pxyv = _mm512_set1_pd(pxy);
                        const __m512d ilv = _mm512_set1_pd(inv_L2), L2v = _mm512_set1_pd(L2);
                        const __m512d zero = _mm512_setzero_pd(), lov = _mm512_set1_pd(far_lo);
                        const __m512d hiv = _mm512_set1_pd(far_hi);
                        for (cg_index kw = 0; kw < n2; kw += VW) {
                            const __m512d sa = _mm512_add_pd(a01v, _mm512_loadu_pd(za + kw));
                            const __m512d sb = _mm512_add_pd(b01v, _mm512_loadu_pd(zb + kw));
                            const __m512d p = _mm512_add_pd(pxyv, _mm512_loadu_pd(pz + kw));
                            const __m512d d = _mm512_sub_pd(sa, _mm512_mul_pd(_mm512_mul_pd(p, p), ilv));
                            __mmask8 cyl = _mm512_cmp_pd_mask(p, zero, _CMP_GE_OQ);
                            cyl = _mm512_mask_cmp_pd_mask(cyl, p, L2v, _CMP_LE_OQ);
                            cyl = _mm512_mask_cmp_pd_mask(cyl, d, Rcv, _CMP_LT_OQ);
                            const __mmask8 bi = _mm512_mask_cmp_pd_mask(_mm512_cmp_pd_mask(sa, R2v, _CMP_LT_OQ), sb,
                                                                        R2v, _CMP_LT_OQ);
                            const __mmask8 bc = (__mmask8)(_mm512_cmp_pd_mask(sa, Rmv, _CMP_LT_OQ) |
                                                           _mm512_cmp_pd_mask(sb, Rmv, _CMP_LT_OQ) | cyl);
                            in_bits |= (uint64_t)bi << kw;
                            cand_bits |= (uint64_t)bc << kw;
                            if (far_check) /* (per object: predicted) */
                                near_bits |= (uint64_t)_mm512_mask_cmp_pd_mask(
                                                 _mm512_cmp_pd_mask(p, lov, _CMP_GE_OQ), p, hiv, _CMP_LE_OQ)
                                             << kw;
                        }
                    }
#else
                    {
                        const vwd a01v = SPLAT(a01), b01v = SPLAT(b01), R2v = SPLAT(R2), Rmv = SPLAT(R2_margin);
                        const vwd Rcv = SPLAT(R2_cyl), pxyv = SPLAT(pxy), ilv = SPLAT(inv_L2), L2v = SPLAT(L2);
                        const vwd zero = {0.0}, lov = SPLAT(far_lo), hiv = SPLAT(far_hi);
                        for (cg_index kw = 0; kw < n2; kw += VW) {
                            vwd zav, zbv, pzv;
                            memcpy(&zav, za + kw, sizeof zav);
                            memcpy(&zbv, zb + kw, sizeof zbv);
                            memcpy(&pzv, pz + kw, sizeof pzv);
                            const vwd sa = a01v + zav, sb = b01v + zbv, p = pxyv + pzv;
                            const vwl cyl = (vwl)(sa - (p * p) * ilv < Rcv) & (vwl)(p >= zero) & (vwl)(p <= L2v);
                            uint64_t bi, bc, bn;
                            mask_bits3((vwl)(sa < R2v) & (vwl)(sb < R2v), (vwl)(sa < Rmv) | (vwl)(sb < Rmv) | cyl,
                                       (vwl)(p >= lov) & (vwl)(p <= hiv), &bi, &bc, &bn);
                            in_bits |= bi << kw;
                            cand_bits |= bc << kw;
                            near_bits |= bn << kw;
                        }
                    }
#endif
                    /* the rule's interval: [first, last] of its nodes inside, and of those (far_check)
                       [first, last] of the near ones, as the walks below (bit_span: no branches on
                       the bits) */
                    in_bits = bit_span(in_bits & valid);
                    if (far_check) in_bits = bit_span(near_bits & in_bits);
                    if (in_bits) {
                        k0 = __builtin_ctzll(in_bits);
                        k1 = 64 - __builtin_clzll(in_bits);
                        if (!factor) inside_row(row, k0, k1, G, ci, gy_t + j * G, gz_of);
                    }
                    cand_bits &= valid & ~in_bits;
                    if (cand_bits) {
                        /* room for the whole row first, then the row's candidates through local
                           pointers (no flush test, no reload of the batch's fields per node) */
                        if (cuts.n + n2 > CUT_BATCH) cut_batch_flush_out(&cuts, jb, out, obj, es, L2, R2, w, amp, &pick);
                        int m = cuts.n;
                        double *restrict q0 = cuts.q[0], *restrict q1 = cuts.q[1], *restrict q2 = cuts.q[2];
                        cg_index *restrict nodes = cuts.node;
                        const double *restrict zc = cslot[2];
                        const cg_index s2 = stride[2];
                        do {
                            const cg_index k = __builtin_ctzll(cand_bits);
                            cand_bits &= cand_bits - 1;
                            q0[m] = xq;
                            q1[m] = yq;
                            q2[m] = zc[k];
                            nodes[m] = base + k * s2;
                            ++m;
                        } while (cand_bits);
                        cuts.n = m;
                    }
                    goto row_done;
                }
#endif
                cg_index a = 0, b = n2;
                while (a < b && !(a01 + za[a] < R2 && b01 + zb[a] < R2)) ++a;
                while (b > a && !(a01 + za[b - 1] < R2 && b01 + zb[b - 1] < R2)) --b;
                /* the rule keeps each value's own digits only up to a distance beyond
                   the ends (FAR_BEYOND_END w): farther nodes go to the closed form; their
                   projections on the segment's line grow along the row, so the nodes
                   left are an interval [ia, ib) of [a, b) */
                cg_index ia = a, ib = b;
                if (far_check && a < b) {
                    const double pij = cslot[0][i] * es[0] + cslot[1][j] * es[1];
                    const double *zc = cslot[2];
                    while (ia < ib && !(pij + zc[ia] * es[2] >= far_lo && pij + zc[ia] * es[2] <= far_hi)) ++ia;
                    while (ib > ia && !(pij + zc[ib - 1] * es[2] >= far_lo && pij + zc[ib - 1] * es[2] <= far_hi))
                        --ib;
                }
                if (ia < ib) {
                    k0 = ia;
                    k1 = ib;
                    if (!factor) inside_row(row, ia, ib, G, ci, gy_t + j * G, gz_of);
                }
                /* elsewhere, the part inside the ball, at the nodes near enough to the
                   segment (the capsule: the exact form decides near its surface) */
                row_distance2(n2, cslot[0][i], cslot[1][j], cslot[2], es, inv_L2, dk);
                for (cg_index k = 0; k < n2; ++k) {
                    if (k == ia && ia < ib) {
                        k = ib - 1; /* skip the rule's interval */
                        continue;
                    }
                    if (!(dk[k] < R2_margin)) continue;
                    const double q3[3] = {cslot[0][i], cslot[1][j], cslot[2][k]};
                    if (cuts.n == CUT_BATCH) cut_batch_flush_out(&cuts, jb, out, obj, es, L2, R2, w, amp, &pick);
                    const int m = cuts.n++;
                    for (int s = 0; s < 3; ++s) cuts.q[s][m] = q3[s];
                    cuts.node[m] = base + k * stride[2];
                }
            }
#ifdef HAVE_V4D
        row_done:
#endif
            if (k0 >= k1) continue;
            /* the row's weights: rs rw[k] */
            double rs = 1.0;
            const double *rw = row;
            if (factor == 2) {
                rs = fx_i * fy[j];
                rw = fz;
            } else if (factor == 1) {
                const double *gy_j = gy_t + j * G;
                rs = 0.0;
                for (int g = 0; g < G; ++g) rs += ci[g] * gy_j[g];
                rw = gz_of[0];
            }
            if (jb->mode == MODE_VALUE) {
                block_add_picked(out + (base + k0 * stride[2]) * jb->out_width, rs, rw + k0, k1 - k0, values, nv,
                                 &pick);
            } else {
                for (cg_index k = k0; k < k1; ++k) {
                    const double wk = rs * rw[k];
                    if (wk != 0.0) cg_accumulate(jb, out, obj, base + k * stride[2], wk, NULL);
                }
            }
        }
    }
    if (hybrid) cut_batch_flush_out(&cuts, jb, out, obj, es, L2, R2, w, amp, &pick);
    return 1;
}

#ifndef CG_SEPARABLE_WIDE
int cg_visit_separable(const job *jb, double *out, scratch *sc, cg_index obj, const double *x, const double *e,
                       double scale)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (jb->wide) return cg_visit_separable_wide(jb, out, sc, obj, x, e, scale);
#endif
    return visit_separable_narrow(jb, out, sc, obj, x, e, scale);
}

static int allow_wide = 1;

int cg_set_wide_vectors(int allow)
{
    const int previous = allow_wide;
    allow_wide = allow != 0;
    return previous;
}

int cg_separable_wide_available(void)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    return allow_wide && __builtin_cpu_supports("avx512f") != 0;
#else
    return 0;
#endif
}

int cg_wide_vectors(void) { return cg_separable_wide_available(); }

void cg_gaussian_erfcx(const double *x, double *out, cg_index n)
{
    /* through the batches' routine, VW lanes at a time (a padded copy) */
    double a[CUT_BATCH], b[CUT_BATCH];
    for (cg_index i0 = 0; i0 < n; i0 += CUT_BATCH) {
        const cg_index m = n - i0 < CUT_BATCH ? n - i0 : CUT_BATCH;
        const cg_index padded = (m + VW - 1) / VW * VW;
        for (cg_index i = 0; i < padded; ++i) a[i] = b[i] = i < m ? x[i0 + i] : 0.0;
        erfcx_in_place2(a, b, padded, 1);
        for (cg_index i = 0; i < m; ++i) out[i0 + i] = a[i];
    }
}

void cg_gaussian_exp(const double *x, double *out, cg_index n)
{
    /* cg_exp_in_place works in place: on a copy */
    if (out != x)
        for (cg_index i = 0; i < n; ++i) out[i] = x[i];
    cg_exp_in_place(out, n);
}

HOT_CLONES void cg_erfcx_in_place2(double *x, double *z, cg_index n, int may_exceed)
{
    erfcx_in_place2(x, z, n, may_exceed);
}
#endif
