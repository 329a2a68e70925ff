/*
 * cg_lucy_line.c -- Lucy's line integral (value only) for a batch of nodes,
 * written without branches so that the compiler vectorises it over the nodes.
 *
 * psi = int_0^1 W(|q - s e|) ds with W = C (1 - 6x^2 + 8x^3 - 3x^4), x = r/R,
 * r^2 = a^2 + t^2 along the segment's line (a: the node's distance from the
 * line, t = u - s L). The part inside the support ball, t1 <= t <= t0
 * (|t| <= b = sqrt(R^2 - a^2)), is reflected so that t0 >= |t1| (W is even in
 * t); then either 0 <= t1 (one side of the closest approach) or t1 < 0 < t0
 * (across it). In units of R, with d = t0 - t1 given accurately (L itself
 * when the segment is not clipped), every difference F(t0) - F(t1) of an
 * antiderivative is taken in a divided form:
 *   int t^2 = d (t0^2 + t0 t1 + t1^2)/3,  int t^4 = d (t0^4 + ... + t1^4)/5,
 *   t0 r0 - t1 r1       = d r0 + t1 (r0 - r1),
 *   t0 r0^3 - t1 r1^3   = d r0^3 + t1 (r0 - r1)(r0^2 + r0 r1 + r1^2),
 *   r0 - r1             = d (t0 + t1) / (r0 + r1).
 * Across the closest approach these sums have terms of both signs, but their
 * cancelled part is at most the size of the result (t1 < 0 makes
 * t0 r0 - t1 r1 a sum of two positives), so nothing is lost but a few
 * roundings. asinh(t0/a) - asinh(t1/a) = log((t0 + r0)/(t1 + r1)) = log1p(X),
 *   X = (d + r0 - r1) / (t1 + r1),
 * a ratio of positives (r0 >= r1 after the reflection), with t1 + r1 taken
 * as a^2 / (r1 - t1) when t1 < 0. Its factor a^4 makes the term vanish with
 * a, so for a^2 < 1e-200 R^2 (where a^4 underflows) it is left out.
 * The log is fdlibm's (musl's) polynomial in branch-free form, taken from
 * the ratio X = N/D without forming it (lucy_log_ratio): the same bits as a
 * scalar evaluation on every instruction set (ISO C: no FMA contraction).
 * What cancellation remains is that of W itself near the support's edge: an
 * absolute error of order eps C (the field's scale).
 *
 * cg_lucy.c computes the gradient terms (the residual's segment term) and
 * visits grid rows; both it and the node-by-node path (cg_kernels.c) take the
 * value from here, so the two agree bit for bit.
 */
#include "cg_internal.h"

#include <math.h>
#include <stdint.h>
#include <string.h>
#ifdef CG_HAVE_WIDE_SEPARABLE
#include <immintrin.h> /* the AVX-512 build's compaction (lucy_batch_frames_wide) */
#endif

/* eight doubles as one value (GCC's vector arithmetic: element by element,
   rounded as scalar code) */
typedef double lucy_v8 __attribute__((vector_size(64)));

#if defined(__GNUC__)
#define INLINE static inline __attribute__((always_inline))
#else
#define INLINE static inline
#endif

static inline uint64_t bits_of(double x)
{
    uint64_t u;
    memcpy(&u, &x, sizeof u);
    return u;
}

static inline double double_of(uint64_t u)
{
    double x;
    memcpy(&x, &u, sizeof x);
    return x;
}

/* log(1 + N/D) (D > 1e-290, N >= 0; other inputs give garbage, which
   callers mask) and c/D' in one division, where D' is D scaled by a power
   of two into [1, 2): with M = 2^-e D' and N' the same scaling of N,
   1 + N/D = 2^k m/D' for m the mantissa of D' + N' in [1, 2) taken to within
   a factor sqrt(2) of D' (k from the exponents), and
   log(m/D') = 2 atanh(s), s = (m - D') / (m + D') (m - D' exact, |s| <= 0.172),
   by fdlibm's (musl's) polynomial: log = 2s + s R(s^2). For N' < (sqrt(2) - 1) D'
   (k = 0) s = N' / (2D' + N') instead, free of the rounding of D' + N' (X
   small: a short segment). The one division 1/(c (m + D')) also gives
   *c_over = 1/c times what it is asked for (the caller's r0 - r1). Error
   about 2 ulp. */
INLINE double lucy_log_ratio(double N, double D, double c, double c_num, double *c_over)
{
    const double ln2_hi = 6.93147180369123816490e-01, ln2_lo = 1.90821492927058770002e-10;
    const double Lg1 = 6.666666666666735130e-01, Lg2 = 3.999999999940941908e-01, Lg3 = 2.857142874366239149e-01,
                 Lg4 = 2.222219843214978396e-01, Lg5 = 1.818357216161805012e-01, Lg6 = 1.531383769920937332e-01,
                 Lg7 = 1.479819860511658591e-01;
    const double sqrt2 = 1.41421356237309504880;
    const uint64_t mant = UINT64_C(0x000fffffffffffff), one = UINT64_C(0x3ff0000000000000);
    const int ok = D > 1e-290;
    const uint64_t db = bits_of(D);
    /* D' = D 2^-e in [1, 2), N' = N 2^-e (exact: 2^-e = 2^(1023 - (e + 1023)) is a normal double) */
    const double Ds = ok ? double_of((db & mant) | one) : 1.0;
    const double Ns = ok ? N * double_of((UINT64_C(2046) - (db >> 52)) << 52) : 0.0;
    const int small = Ns < (sqrt2 - 1.0) * Ds;
    const double U = Ds + Ns;
    const uint64_t ub = bits_of(U);
    /* the exponent k of U as a double, exactly: 2^52 + (k + 1023) - (2^52 + 1023) */
    const double dk0 = double_of(UINT64_C(0x4330000000000000) | (ub >> 52)) - 4503599627371519.0;
    const double m0 = double_of((ub & mant) | one);
    const double m = m0 > sqrt2 * Ds ? 0.5 * m0 : (m0 * sqrt2 < Ds ? 2.0 * m0 : m0);
    const double dk = m0 > sqrt2 * Ds ? dk0 + 1.0 : (m0 * sqrt2 < Ds ? dk0 - 1.0 : dk0);
    const double num = small ? Ns : m - Ds, den = small ? 2.0 * Ds + Ns : m + Ds;
    const double k = small ? 0.0 : dk;
    const double rec = ok ? 1.0 / (c * den) : 0.0;
    *c_over = c_num * den * rec;
    const double sv = num * c * rec;
    const double z = sv * sv, w = z * z;
    const double t1 = w * (Lg2 + w * (Lg4 + w * Lg6));
    const double t2 = z * (Lg1 + w * (Lg3 + w * (Lg5 + w * Lg7)));
    return k * ln2_hi + (k * ln2_lo + (2.0 * sv + sv * (t1 + t2)));
}

/* The frame of a node at offset q (3 components, the unused ones 0) from the
   start of a segment e of direction n: u = q.n, t_far = (q - e).n and a2 =
   |q - u n|^2, as node_frame (cg_internal.h) computes them. */
INLINE void lucy_frame(double q0, double q1, double q2, const double *n, const double *e, double *u_out,
                       double *t_far_out, double *a2_out)
{
    const double u = q0 * n[0] + q1 * n[1] + q2 * n[2];
    const double t_far = (q0 - e[0]) * n[0] + (q1 - e[1]) * n[1] + (q2 - e[2]) * n[2];
    const double p0 = q0 - u * n[0], p1 = q1 - u * n[1], p2 = q2 - u * n[2];
    *u_out = u;
    *t_far_out = t_far;
    *a2_out = p0 * p0 + p1 * p1 + p2 * p2;
}

/* int P(x) dt / R over the part of the line inside the support (units of R),
   P = (1 + 3x)(1 - x)^3, for a node of frame (u, t_far, a2) (lucy_frame) and
   a segment of length L; 0 outside the support. Two square roots (one per
   end: its r if the end is inside the ball, else b, r being 1 there), both
   from the frame, so neither waits for the other, and one division:
   r0 - r1 and the log of 1 + X share it (lucy_log_ratio), X = N/(rsum h)
   with h the denominator of X (see the top of the file). Where rsum h is
   below 1e-290 (a node within 1e-145 R of a segment as short) the
   reciprocal is taken as 0: r0 - r1 then only enters multiplied by t1 (as
   small) and X only with a factor a^4 that underflows. */
/* lucy_value_frame in three stages, each a loop of its own in the batched
   path (lucy_values_body): one vector of nodes' chain of dependent
   operations (square root, then division, then the log's polynomial; some
   200 cycles, about as many instructions) is too long for the processor's
   window to overlap with the next vector's; a stage is short enough that
   several vectors run at once (about 11 % less time for the values on W1).
   The same operations on the same values in the same order as in one
   piece: the same bits.
   Stage 1: the ends clipped to the support and reflected (t0 >= |t1|),
   their r, the span d, s^2 = a^2/R^2 and whether the node is reached (1 or 0);
   Ld = L/R as L * inv */
INLINE void lucy_stage_ends(double u, double t_far, double a2, double Ld, double R, double inv, double *t0_out,
                            double *t1_out, double *r0_out, double *r1_out, double *d_out, double *s2_out,
                            double *ok_out)
{
    /* (the flags are written as comparisons of doubles where used: int
       flags mixed with them keep GCC 12 from vectorising the loop) */
    const double R2 = R * R, b2 = R2 - a2;
    const double s2 = a2 * inv * inv;
    /* the ends, clipped to the support (u > b, t_far < -b: the end outside
       the ball), reflected below so that t0 >= |t1|. One square root per
       end, independent of each other: r at an end inside the ball, b at a
       clipped one (where r = 1) */
    const double ru2 = a2 + u * u, rt2 = a2 + t_far * t_far;
    const int clip_hi = u > 0.0 && ru2 > R2, clip_lo = t_far < 0.0 && rt2 > R2;
    const double b2_ = b2 > 0.0 ? b2 : 0.0;
    const double root_hi = sqrt(clip_hi ? b2_ : ru2), root_lo = sqrt(clip_lo ? b2_ : rt2);
    const double hi_p = clip_hi ? root_hi : u, lo_p = clip_lo ? -root_lo : t_far;
    const double hi = hi_p * inv, lo = lo_p * inv;
    const double r_hi = clip_hi ? 1.0 : root_hi * inv, r_lo = clip_lo ? 1.0 : root_lo * inv;
    const double d = clip_hi || clip_lo ? (hi_p - lo_p) * inv : Ld;
    const int flip = hi <= 0.0;
    *t0_out = flip ? -lo : hi;
    *t1_out = flip ? -hi : lo;
    *r0_out = flip ? r_lo : r_hi;
    *r1_out = flip ? r_hi : r_lo;
    *d_out = d;
    *s2_out = s2;
    *ok_out = b2 > 0.0 && hi > lo && d > 0.0 ? 1.0 : 0.0;
}

/* Stage 2: asinh(t0/a) - asinh(t1/a) = log1p(X) (0 where a^4 underflows)
   and r0 - r1 (dr), from one division:
   X = (d + dr) / (t1 + r1), t1 + r1 = a^2 / (r1 - t1) when t1 < 0;
   X = N / (rsum h); r0 - r1 = d (t0 + t1) / rsum */
INLINE void lucy_stage_log(double t0, double t1, double r0, double r1, double d, double s2, double *log_out,
                           double *dr_out)
{
    const double sum = t0 + t1, rsum = r0 + r1;
    const int with_log = s2 > 1e-200;
    const int across = t1 < 0.0;
    const double h = across ? (with_log ? s2 : 1.0) : t1 + r1, g = across ? r1 - t1 : 1.0;
    double dr;
    const double log_x = lucy_log_ratio(d * (rsum + sum) * g, rsum * h, rsum, d * sum, &dr);
    *log_out = with_log ? log_x : 0.0;
    *dr_out = dr;
}

/* Stage 3: int P dt / R from the pieces (0 where the node is not reached) */
INLINE double lucy_stage_sum(double t0, double t1, double r0, double r1, double d, double s2, double ok, double D3,
                             double dr)
{
    const double q2_ = t0 * t0, p2_ = t1 * t1, qp = t0 * t1;
    const double J2 = d * (q2_ + qp + p2_) * (1.0 / 3.0);
    const double J4 = d * (q2_ * q2_ + qp * (q2_ + p2_) + qp * qp + p2_ * p2_) * 0.2;
    const double Jr2 = s2 * d + J2;
    const double Jr4 = s2 * s2 * d + 2.0 * s2 * J2 + J4;
    const double rr = r0 * r0 + r0 * r1 + r1 * r1;
    const double D2 = d * r0 + t1 * dr;
    const double D1 = d * r0 * r0 * r0 + t1 * dr * rr;
    const double Jr3 = 0.25 * D1 + 0.375 * s2 * D2 + 0.375 * s2 * s2 * D3;
    const double acc = d - 6.0 * Jr2 + 8.0 * Jr3 - 3.0 * Jr4;
    return ok != 0.0 ? acc : 0.0;
}

INLINE double lucy_value_frame(double u, double t_far, double a2, double L, double R, double inv)
{
    double t0, t1, r0, r1, d, s2, ok, D3, dr;
    lucy_stage_ends(u, t_far, a2, L * inv, R, inv, &t0, &t1, &r0, &r1, &d, &s2, &ok);
    lucy_stage_log(t0, t1, r0, r1, d, s2, &D3, &dr);
    return lucy_stage_sum(t0, t1, r0, r1, d, s2, ok, D3, dr);
}

/* the same from the node's offset q */
INLINE double lucy_value_units(double q0, double q1, double q2, const double *n, const double *e, double L,
                               double R, double inv)
{
    double u, t_far, a2;
    lucy_frame(q0, q1, q2, n, e, &u, &t_far, &a2);
    return lucy_value_frame(u, t_far, a2, L, R, inv);
}

/* Whether a node of frame (u, t_far, a2) can have a non-zero value: a test
   without the square root that lucy_value_frame's b = sqrt(R^2 - a2) needs,
   loose by a relative 1e-9 (its rounding is 1e-16), so that it never drops a
   node lucy_value_frame accepts (u > -b and t_far < b there). */
INLINE int lucy_may_reach(double u, double t_far, double a2, double R2)
{
    const double b2 = R2 - a2, loose = b2 * (1.0 + 1e-9);
    /* bitwise, not short-circuit: no branches, so that lucy_frames_body vectorises */
    return (b2 > 0.0) & ((u >= 0.0) | (u * u < loose)) & ((t_far <= 0.0) | (t_far * t_far < loose));
}

/* nodes per chunk of lucy_values_body's stages */
#define LUCY_STAGE_CHUNK 64

/* nodes per vector of the batched frames (AVX-512's 8 doubles; a multiple of AVX2's 4) */
#define LUCY_LANES 8

INLINE void lucy_values_body(int count, const double *restrict q0, const double *restrict q1,
                             const double *restrict q2, const double *n, const double *e, double L, double R,
                             double factor, double *restrict w)
{
    const double inv = 1.0 / R, Ld = L * inv;
    const double nn[3] = {n[0], n[1], n[2]}, ee[3] = {e[0], e[1], e[2]};
    double t0[LUCY_STAGE_CHUNK], t1[LUCY_STAGE_CHUNK], r0[LUCY_STAGE_CHUNK], r1[LUCY_STAGE_CHUNK];
    double d[LUCY_STAGE_CHUNK], s2[LUCY_STAGE_CHUNK], ok[LUCY_STAGE_CHUNK], lg[LUCY_STAGE_CHUNK], dr[LUCY_STAGE_CHUNK];
    for (int i0 = 0; i0 < count; i0 += LUCY_STAGE_CHUNK) {
        const int m = count - i0 < LUCY_STAGE_CHUNK ? count - i0 : LUCY_STAGE_CHUNK;
        const double *restrict a0 = q0 + i0, *restrict a1 = q1 + i0, *restrict a2 = q2 + i0;
        double *restrict wo = w + i0;
        for (int i = 0; i < m; ++i) {
            double u, t_far, aa;
            lucy_frame(a0[i], a1[i], a2[i], nn, ee, &u, &t_far, &aa);
            lucy_stage_ends(u, t_far, aa, Ld, R, inv, &t0[i], &t1[i], &r0[i], &r1[i], &d[i], &s2[i], &ok[i]);
        }
        for (int i = 0; i < m; ++i) lucy_stage_log(t0[i], t1[i], r0[i], r1[i], d[i], s2[i], &lg[i], &dr[i]);
        for (int i = 0; i < m; ++i)
            wo[i] = factor * lucy_stage_sum(t0[i], t1[i], r0[i], r1[i], d[i], s2[i], ok[i], lg[i], dr[i]);
    }
}

/* Several segments' nodes at once (cg_lucy_batch_values): segment s has nodes
   start[s]..start[s + 1] - 1, direction geom[7s..7s+2], end geom[7s+3..7s+5]
   and L/R geom[7s + 6]. First each segment's frames, in loops with its
   direction broadcast, then the stage loops of lucy_values_body over all the
   nodes, so that they run full whatever a segment's count (W1: 35 nodes in a
   box, which took 5 vectors of stage loops per call, the chains of too few
   vectors to keep the processor busy, and the call's set-up per segment).
   The same operations on the same values per node: the bits of
   lucy_values_body (without its factor: lucy_batch_add9 applies it, as
   factor * value). The frames go to cstart[s]..cstart[s + 1] - 1 with their
   node indices (node_c): in the AVX-512 build only the nodes that may reach
   the segment (lucy_may_reach, compacted; the others' values are 0 and add
   nothing), elsewhere all of them in place. */

/* the nodes' frames, all of them in place (a loop per segment over a whole
   number of vectors: the lanes past its last node are the next segment's,
   rewritten by its own loop, or slack) */
INLINE void lucy_batch_frames_body(int nseg, const int *restrict start, const double *restrict geom,
                                   const double *restrict q0, const double *restrict q1, const double *restrict q2,
                                   const cg_index *restrict node, double *restrict u, double *restrict t_far,
                                   double *restrict a2, double *restrict Ld, cg_index *restrict node_c,
                                   int *restrict cstart)
{
    for (int s = 0; s < nseg; ++s) {
        const double *g = geom + 7 * s;
        const double nn[3] = {g[0], g[1], g[2]}, ee[3] = {g[3], g[4], g[5]}, ld = g[6];
        const int b = start[s], m = (start[s + 1] - b + LUCY_LANES - 1) & -LUCY_LANES;
        const double *restrict a0 = q0 + b, *restrict a1 = q1 + b, *restrict a2_ = q2 + b;
        double *restrict uo = u + b, *restrict to = t_far + b, *restrict ao = a2 + b, *restrict lo = Ld + b;
        const cg_index *restrict ni = node + b;
        cg_index *restrict no = node_c + b;
        for (int i = 0; i < m; ++i) {
            double ui, ti, ai;
            lucy_frame(a0[i], a1[i], a2_[i], nn, ee, &ui, &ti, &ai);
            uo[i] = ui;
            to[i] = ti;
            ao[i] = ai;
            lo[i] = ld;
            no[i] = ni[i];
        }
        cstart[s] = b;
    }
    cstart[nseg] = start[nseg];
}

/* the stages over count nodes' frames (lucy_values_body's), unscaled values into w */
INLINE void lucy_batch_stages_body(int count, const double *restrict u, const double *restrict t_far,
                                   const double *restrict a2, const double *restrict Ld, double R,
                                   double *restrict w)
{
    const double inv = 1.0 / R;
    count = (count + LUCY_LANES - 1) & -LUCY_LANES;
    double t0[LUCY_STAGE_CHUNK], t1[LUCY_STAGE_CHUNK], r0[LUCY_STAGE_CHUNK], r1[LUCY_STAGE_CHUNK];
    double d[LUCY_STAGE_CHUNK], s2[LUCY_STAGE_CHUNK], ok[LUCY_STAGE_CHUNK], lg[LUCY_STAGE_CHUNK], dr[LUCY_STAGE_CHUNK];
    for (int i0 = 0; i0 < count; i0 += LUCY_STAGE_CHUNK) {
        const int m = count - i0 < LUCY_STAGE_CHUNK ? count - i0 : LUCY_STAGE_CHUNK;
        const double *restrict uu = u + i0, *restrict tt = t_far + i0, *restrict aa = a2 + i0, *restrict ll = Ld + i0;
        double *restrict wo = w + i0;
        for (int i = 0; i < m; ++i)
            lucy_stage_ends(uu[i], tt[i], aa[i], ll[i], R, inv, &t0[i], &t1[i], &r0[i], &r1[i], &d[i], &s2[i], &ok[i]);
        for (int i = 0; i < m; ++i) lucy_stage_log(t0[i], t1[i], r0[i], r1[i], d[i], s2[i], &lg[i], &dr[i]);
        for (int i = 0; i < m; ++i) wo[i] = lucy_stage_sum(t0[i], t1[i], r0[i], r1[i], d[i], s2[i], ok[i], lg[i], dr[i]);
    }
}

/* the frames of count nodes into u, t_far, a2 and whether each may reach
   (lucy_may_reach) into keep */
INLINE void lucy_frames_body(int count, const double *restrict q0, const double *restrict q1,
                             const double *restrict q2, const double *n, const double *e, double R,
                             double *restrict u, double *restrict t_far, double *restrict a2, int *restrict keep,
                             int cylinder)
{
    const double nn[3] = {n[0], n[1], n[2]}, ee[3] = {e[0], e[1], e[2]}, R2 = R * R;
    for (int i = 0; i < count; ++i) {
        double ui, ti, ai;
        lucy_frame(q0[i], q1[i], q2[i], nn, ee, &ui, &ti, &ai);
        u[i] = ui;
        t_far[i] = ti;
        a2[i] = ai;
        keep[i] = cylinder ? R2 - ai > 0.0 : lucy_may_reach(ui, ti, ai, R2);
    }
}

/* Heaviside's line integral (the full-dimensional kernel): prefactor times
   the part of [0, 1] inside the ball, clipped as clip_to_support
   (cg_internal.h) clips it, from the frame; 0 outside */
INLINE void heaviside_values_frame_body(int count, const double *restrict u, const double *restrict t_far,
                                        const double *restrict a2, double L, double R, double prefactor,
                                        double *restrict w)
{
    for (int i = 0; i < count; ++i) {
        const double b2 = R * R - a2[i];
        const int inside = b2 > 0.0;
        const double b = sqrt(inside ? b2 : 0.0);
        const double lo = u[i] > b ? (u[i] - b) / L : 0.0;
        const double hi = t_far[i] < -b ? (u[i] + b) / L : 1.0;
        const int valid = inside && !(lo > 1.0 || hi < 0.0 || !(lo < hi));
        w[i] = valid ? prefactor * (hi - lo) : 0.0;
    }
}

/* The candidate nodes of a row: the row (fixed offsets f0, f1 from the
   segment's start along the axes before the row axis, z along it) meets the
   capsule (convex) in one interval, the hull of its meets with the ball at
   the start (|q|^2 <= bound), the ball at the end (|q - e|^2 <= bound) and
   the cylinder piece (a^2(z) <= bound, a quadratic in z, and
   -mu <= u(z) = c + z nz <= L + mu). bound = R^2 (1 + 1e-6) plus the rounding
   of a^2 and mu a margin for that of u (lucy_row_params): every node the
   exact test of lucy_value_units can accept is inside. Where the quadratic is
   too flat (the segment nearly along the row) its roots are ill-conditioned
   and the cylinder piece is taken as the whole slab. Out: the node indices
   klo..khi (as doubles; klo > khi: none) on the row's coordinates
   z0 + k h, widened by slack nodes for their rounding. */
INLINE void lucy_rows_body(int count, const double *restrict f0, const double *restrict f1,
                           const lucy_row_params *restrict P, double *restrict klo, double *restrict khi)
{
    const double n0 = P->n[0], n1 = P->n[1], nz = P->nz, e0 = P->e[0], e1 = P->e[1], ez = P->ez;
    const double A = 1.0 - nz * nz, bound = P->bound, mu = P->mu, L = P->L;
    const int flat = !(A > 1e-3);
    const double inv_a = 1.0 / (flat ? 1.0 : A), inv_nz = 1.0 / (nz != 0.0 ? nz : 1.0);
    const double inv_h = 1.0 / P->h, shift = P->x_row - P->z0, slack = P->slack;
    for (int i = 0; i < count; ++i) {
        const double c = f0[i] * n0 + f1[i] * n1;
        const double p2 = f0[i] * f0[i] + f1[i] * f1[i];
        const double g0 = f0[i] - e0, g1 = f1[i] - e1;
        const double pe2 = g0 * g0 + g1 * g1;
        const double hs = sqrt(p2 < bound ? bound - p2 : 0.0), he = sqrt(pe2 < bound ? bound - pe2 : 0.0);
        double lo = p2 < bound ? -hs : INFINITY, hi = p2 < bound ? hs : -INFINITY;
        const double elo = pe2 < bound ? ez - he : INFINITY, ehi = pe2 < bound ? ez + he : -INFINITY;
        lo = elo < lo ? elo : lo;
        hi = ehi > hi ? ehi : hi;
        /* the slab -mu <= c + z nz <= L + mu */
        const double za = (-mu - c) * inv_nz, zb = (L + mu - c) * inv_nz;
        const int c_in = c >= -mu && c <= L + mu;
        double slo = nz > 0.0 ? za : zb, shi = nz > 0.0 ? zb : za;
        slo = nz != 0.0 ? slo : (c_in ? -INFINITY : INFINITY);
        shi = nz != 0.0 ? shi : (c_in ? INFINITY : -INFINITY);
        /* A z^2 - 2 B z + C <= 0 */
        const double B = c * nz, C = p2 - c * c - bound;
        const double disc = B * B - A * C;
        const double root = sqrt(disc > 0.0 ? disc : 0.0);
        double clo = flat ? slo : (disc > 0.0 ? (B - root) * inv_a : INFINITY);
        double chi = flat ? shi : (disc > 0.0 ? (B + root) * inv_a : -INFINITY);
        clo = slo > clo ? slo : clo;
        chi = shi < chi ? shi : chi;
        const int cyl = clo <= chi;
        lo = cyl && clo < lo ? clo : lo;
        hi = cyl && chi > hi ? chi : hi;
        klo[i] = ceil((shift + lo) * inv_h - slack);
        khi[i] = floor((shift + hi) * inv_h + slack);
    }
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__has_attribute)
#if __has_attribute(target_clones) && defined(__x86_64__) && !defined(CGBOUND_NO_CLONES)
#define LUCY_CLONES __attribute__((target_clones("avx2", "default")))
#endif
#endif
#ifndef LUCY_CLONES
#define LUCY_CLONES
#endif

/* The value loops without jump threading: threading the selects on the
   clip flags duplicates lucy_value_frame's square roots and divisions into
   both arms (3 and 3 per node instead of 2 and 2: the divider bounds the
   loop) */
#if defined(__GNUC__) && !defined(__clang__)
#define LUCY_NO_THREADING __attribute__((optimize("no-thread-jumps")))
#else
#define LUCY_NO_THREADING
#endif

LUCY_NO_THREADING LUCY_CLONES static void lucy_values_narrow(int count, const double *q0, const double *q1, const double *q2,
                                           const double *n, const double *e, double L, double R, double factor,
                                           double *w)
{
    lucy_values_body(count, q0, q1, q2, n, e, L, R, factor, w);
}

#ifdef CG_HAVE_WIDE_SEPARABLE
LUCY_NO_THREADING __attribute__((target("avx512f"))) static void lucy_values_wide(int count, const double *q0, const double *q1,
                                                                  const double *q2, const double *n, const double *e,
                                                                  double L, double R, double factor, double *w)
{
    lucy_values_body(count, q0, q1, q2, n, e, L, R, factor, w);
}
#endif

LUCY_NO_THREADING LUCY_CLONES static void lucy_batch_values_narrow(int nseg, const int *start, const double *geom,
                                                                 const double *q0, const double *q1,
                                                                 const double *q2, const cg_index *node, double R,
                                                                 double *u, double *t_far, double *a2, double *Ld,
                                                                 double *w, cg_index *node_c, int *cstart)
{
    lucy_batch_frames_body(nseg, start, geom, q0, q1, q2, node, u, t_far, a2, Ld, node_c, cstart);
    lucy_batch_stages_body(cstart[nseg], u, t_far, a2, Ld, R, w);
}

#ifdef CG_HAVE_WIDE_SEPARABLE
/* lucy_batch_frames_body with the nodes that cannot reach the segment
   (lucy_may_reach) left out: each vector's kept lanes compressed to the
   front and stored whole (the lanes past them rewritten next or slack);
   W1 keeps 27 of a box's 35 nodes. The frame's operations as lucy_frame's,
   element by element (GCC's vector arithmetic). */
__attribute__((target("avx512f"))) static inline __attribute__((always_inline)) void
lucy_batch_frames_wide(int nseg, const int *restrict start, const double *restrict geom, const double *restrict q0,
                       const double *restrict q1, const double *restrict q2, const cg_index *restrict node, double R,
                       double *restrict u, double *restrict t_far, double *restrict a2, double *restrict Ld,
                       cg_index *restrict node_c, int *restrict cstart)
{
    const double R2 = R * R;
    int p = 0;
    for (int s = 0; s < nseg; ++s) {
        const double *g = geom + 7 * s;
        const lucy_v8 n0 = {g[0], g[0], g[0], g[0], g[0], g[0], g[0], g[0]};
        const lucy_v8 n1 = {g[1], g[1], g[1], g[1], g[1], g[1], g[1], g[1]};
        const lucy_v8 n2 = {g[2], g[2], g[2], g[2], g[2], g[2], g[2], g[2]};
        const lucy_v8 e0 = {g[3], g[3], g[3], g[3], g[3], g[3], g[3], g[3]};
        const lucy_v8 e1 = {g[4], g[4], g[4], g[4], g[4], g[4], g[4], g[4]};
        const lucy_v8 e2 = {g[5], g[5], g[5], g[5], g[5], g[5], g[5], g[5]};
        const __m512d ld = _mm512_set1_pd(g[6]);
        const int end = start[s + 1];
        cstart[s] = p;
        for (int i = start[s]; i < end; i += LUCY_LANES) {
            lucy_v8 a0, a1, a2v;
            memcpy(&a0, q0 + i, sizeof a0);
            memcpy(&a1, q1 + i, sizeof a1);
            memcpy(&a2v, q2 + i, sizeof a2v);
            const lucy_v8 uv = a0 * n0 + a1 * n1 + a2v * n2;
            const lucy_v8 tv = (a0 - e0) * n0 + (a1 - e1) * n1 + (a2v - e2) * n2;
            const lucy_v8 p0 = a0 - uv * n0, p1 = a1 - uv * n1, p2 = a2v - uv * n2;
            const lucy_v8 av = p0 * p0 + p1 * p1 + p2 * p2;
            /* lucy_may_reach, lane by lane */
            const __m512d U = (__m512d)uv, T = (__m512d)tv, b2 = _mm512_sub_pd(_mm512_set1_pd(R2), (__m512d)av);
            const __m512d loose = _mm512_mul_pd(b2, _mm512_set1_pd(1.0 + 1e-9)), zero = _mm512_setzero_pd();
            const __mmask8 lanes = end - i >= LUCY_LANES ? (__mmask8)0xff : (__mmask8)((1u << (end - i)) - 1u);
            const __mmask8 keep = lanes & _mm512_cmp_pd_mask(b2, zero, _CMP_GT_OQ) &
                                  (_mm512_cmp_pd_mask(U, zero, _CMP_GE_OQ) |
                                   _mm512_cmp_pd_mask(_mm512_mul_pd(U, U), loose, _CMP_LT_OQ)) &
                                  (_mm512_cmp_pd_mask(T, zero, _CMP_LE_OQ) |
                                   _mm512_cmp_pd_mask(_mm512_mul_pd(T, T), loose, _CMP_LT_OQ));
            _mm512_storeu_pd(u + p, _mm512_maskz_compress_pd(keep, U));
            _mm512_storeu_pd(t_far + p, _mm512_maskz_compress_pd(keep, T));
            _mm512_storeu_pd(a2 + p, _mm512_maskz_compress_pd(keep, (__m512d)av));
            _mm512_storeu_pd(Ld + p, ld);
            _mm512_storeu_si512(node_c + p, _mm512_maskz_compress_epi64(keep, _mm512_loadu_si512(node + i)));
            p += __builtin_popcount(keep);
        }
    }
    cstart[nseg] = p;
}

LUCY_NO_THREADING __attribute__((target("avx512f"))) static void
lucy_batch_values_wide(int nseg, const int *start, const double *geom, const double *q0, const double *q1,
                       const double *q2, const cg_index *node, double R, double *u, double *t_far, double *a2,
                       double *Ld, double *w, cg_index *node_c, int *cstart)
{
    lucy_batch_frames_wide(nseg, start, geom, q0, q1, q2, node, R, u, t_far, a2, Ld, node_c, cstart);
    lucy_batch_stages_body(cstart[nseg], u, t_far, a2, Ld, R, w);
}
#endif

void cg_lucy_batch_values(int nseg, const int *start, const double *geom, const double *q0, const double *q1,
                          const double *q2, const cg_index *node, double R, double *u, double *t_far, double *a2,
                          double *Ld, double *w, cg_index *node_c, int *cstart, int wide)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (wide) {
        lucy_batch_values_wide(nseg, start, geom, q0, q1, q2, node, R, u, t_far, a2, Ld, w, node_c, cstart);
        return;
    }
#endif
    (void)wide;
    lucy_batch_values_narrow(nseg, start, geom, q0, q1, q2, node, R, u, t_far, a2, Ld, w, node_c, cstart);
}

LUCY_CLONES static void lucy_frames_narrow(int count, const double *q0, const double *q1, const double *q2,
                                           const double *n, const double *e, double R, double *u, double *t_far,
                                           double *a2, int *keep, int cylinder)
{
    lucy_frames_body(count, q0, q1, q2, n, e, R, u, t_far, a2, keep, cylinder);
}

LUCY_CLONES static void heaviside_values_frame_narrow(int count, const double *u, const double *t_far,
                                                      const double *a2, double L, double R, double prefactor,
                                                      double *w)
{
    heaviside_values_frame_body(count, u, t_far, a2, L, R, prefactor, w);
}

#ifdef CG_HAVE_WIDE_SEPARABLE
__attribute__((target("avx512f"))) static void lucy_frames_wide(int count, const double *q0, const double *q1,
                                                                  const double *q2, const double *n, const double *e,
                                                                  double R, double *u, double *t_far, double *a2,
                                                                  int *keep, int cylinder)
{
    lucy_frames_body(count, q0, q1, q2, n, e, R, u, t_far, a2, keep, cylinder);
}

__attribute__((target("avx512f"))) static void heaviside_values_frame_wide(int count, const double *u,
                                                                             const double *t_far, const double *a2,
                                                                             double L, double R, double prefactor,
                                                                             double *w)
{
    heaviside_values_frame_body(count, u, t_far, a2, L, R, prefactor, w);
}

#endif

/* cg_kernel_value's full-dimensional Lucy and Heaviside branches */
INLINE void ball_values_body(int count, const double *restrict rho2, double R, double prefactor, int heaviside,
                             double *restrict w)
{
    const double R2 = R * R;
    for (int i = 0; i < count; ++i) {
        const double lucy = prefactor * cg_lucy_profile(sqrt(rho2[i]) / R);
        w[i] = rho2[i] < R2 ? (heaviside ? prefactor : lucy) : 0.0;
    }
}

LUCY_CLONES static void ball_values_narrow(int count, const double *rho2, double R, double prefactor, int heaviside,
                                           double *w)
{
    ball_values_body(count, rho2, R, prefactor, heaviside, w);
}

#ifdef CG_HAVE_WIDE_SEPARABLE
__attribute__((target("avx512f"))) static void ball_values_wide(int count, const double *rho2, double R,
                                                                  double prefactor, int heaviside, double *w)
{
    ball_values_body(count, rho2, R, prefactor, heaviside, w);
}
#endif

void cg_ball_values(int count, const double *rho2, double R, double prefactor, int heaviside, double *w, int wide)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (wide) {
        ball_values_wide(count, rho2, R, prefactor, heaviside, w);
        return;
    }
#endif
    (void)wide;
    ball_values_narrow(count, rho2, R, prefactor, heaviside, w);
}

/* out[node[i] * width + c] += w[i] * val[c], c < nv, for every non-zero w[i]
   (cg_accumulate's MODE_VALUE sums), the value loop vectorised */
INLINE void ball_add_body(int count, const double *restrict w, const cg_index *restrict node, int width,
                          const double *restrict val, int nv, double *restrict out)
{
    for (int i = 0; i < count; ++i) {
        const double wi = w[i];
        if (wi == 0.0) continue;
        double *restrict o = out + node[i] * width;
        for (int c = 0; c < nv; ++c) o[c] += wi * val[c];
    }
}

LUCY_CLONES static void ball_add_narrow(int count, const double *w, const cg_index *node, int width,
                                        const double *val, int nv, double *out)
{
    ball_add_body(count, w, node, width, val, nv, out);
}

#ifdef CG_HAVE_WIDE_SEPARABLE
__attribute__((target("avx512f"))) static void ball_add_wide(int count, const double *w, const cg_index *node,
                                                               int width, const double *val, int nv, double *out)
{
    ball_add_body(count, w, node, width, val, nv, out);
}
#endif

void cg_ball_add(int count, const double *w, const cg_index *node, int width, const double *val, int nv, double *out,
                 int wide)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (wide) {
        ball_add_wide(count, w, node, width, val, nv, out);
        return;
    }
#endif
    (void)wide;
    ball_add_narrow(count, w, node, width, val, nv, out);
}

/* out[node[i] * 9 + k] += (w[i] * scale) * val[k] for every non-zero
   w[i] * scale (cg_accumulate's MODE_VALUE sums of a 9-component value): the
   first 8 components as one vector of the same element-wise products and
   sums, so the same bits on every instruction set */
INLINE void lucy_add9_body(int count, const double *restrict w, const cg_index *restrict node, double scale,
                           const double *restrict val, double *restrict out)
{
    lucy_v8 v;
    memcpy(&v, val, sizeof v);
    const double v8 = val[8];
    for (int i = 0; i < count; ++i) {
        const double wi = w[i] * scale;
        if (wi == 0.0) continue;
        double *o = out + node[i] * 9;
        lucy_v8 ov;
        memcpy(&ov, o, sizeof ov);
        ov += wi * v;
        memcpy(o, &ov, sizeof ov);
        o[8] += wi * v8;
    }
}

LUCY_CLONES static void lucy_add9_narrow(int count, const double *w, const cg_index *node, double scale,
                                         const double *val, double *out)
{
    lucy_add9_body(count, w, node, scale, val, out);
}

#ifdef CG_HAVE_WIDE_SEPARABLE
__attribute__((target("avx512f"))) static void lucy_add9_wide(int count, const double *w, const cg_index *node,
                                                                double scale, const double *val, double *out)
{
    lucy_add9_body(count, w, node, scale, val, out);
}
#endif

void cg_lucy_add9(int count, const double *w, const cg_index *node, double scale, const double *val, double *out,
                  int wide)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (wide) {
        lucy_add9_wide(count, w, node, scale, val, out);
        return;
    }
#endif
    (void)wide;
    lucy_add9_narrow(count, w, node, scale, val, out);
}

/* cg_lucy_add9 for the segments of a batch (cg_lucy_batch_values' start):
   segment s's nodes with the weights (factor[s] * w[i]) * scale[s] and the
   values val[9s..9s+8], segment after segment: the bits of cg_lucy_add9
   called per segment on w[i] = factor[s] * value */
INLINE void lucy_batch_add9_body(int nseg, const int *restrict start, const double *restrict factor,
                                 const double *restrict scale, const double *restrict val, const double *restrict w,
                                 const cg_index *restrict node, double *restrict out)
{
    for (int s = 0; s < nseg; ++s) {
        lucy_v8 v;
        memcpy(&v, val + 9 * s, sizeof v);
        const double v8 = val[9 * s + 8], f = factor[s], sc = scale[s];
        for (int i = start[s]; i < start[s + 1]; ++i) {
            const double wi = (f * w[i]) * sc;
            if (wi == 0.0) continue;
            double *o = out + node[i] * 9;
            lucy_v8 ov;
            memcpy(&ov, o, sizeof ov);
            ov += wi * v;
            memcpy(o, &ov, sizeof ov);
            o[8] += wi * v8;
        }
    }
}

LUCY_CLONES static void lucy_batch_add9_narrow(int nseg, const int *start, const double *factor, const double *scale,
                                               const double *val, const double *w, const cg_index *node, double *out)
{
    lucy_batch_add9_body(nseg, start, factor, scale, val, w, node, out);
}

#ifdef CG_HAVE_WIDE_SEPARABLE
__attribute__((target("avx512f"))) static void lucy_batch_add9_wide(int nseg, const int *start, const double *factor,
                                                                      const double *scale, const double *val,
                                                                      const double *w, const cg_index *node,
                                                                      double *out)
{
    lucy_batch_add9_body(nseg, start, factor, scale, val, w, node, out);
}
#endif

void cg_lucy_batch_add9(int nseg, const int *start, const double *factor, const double *scale, const double *val,
                        const double *w, const cg_index *node, double *out, int wide)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (wide) {
        lucy_batch_add9_wide(nseg, start, factor, scale, val, w, node, out);
        return;
    }
#endif
    (void)wide;
    lucy_batch_add9_narrow(nseg, start, factor, scale, val, w, node, out);
}

void cg_lucy_frames(int count, const double *q0, const double *q1, const double *q2, const double *n,
                    const double *e, double R, double *u, double *t_far, double *a2, int *keep, int cylinder,
                    int wide)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (wide) {
        lucy_frames_wide(count, q0, q1, q2, n, e, R, u, t_far, a2, keep, cylinder);
        return;
    }
#endif
    (void)wide;
    lucy_frames_narrow(count, q0, q1, q2, n, e, R, u, t_far, a2, keep, cylinder);
}

void cg_heaviside_values_frame(int count, const double *u, const double *t_far, const double *a2, double L,
                               double R, double prefactor, double *w, int wide)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (wide) {
        heaviside_values_frame_wide(count, u, t_far, a2, L, R, prefactor, w);
        return;
    }
#endif
    (void)wide;
    heaviside_values_frame_narrow(count, u, t_far, a2, L, R, prefactor, w);
}

LUCY_CLONES static void lucy_rows_narrow(int count, const double *f0, const double *f1, const lucy_row_params *P,
                                         double *klo, double *khi)
{
    lucy_rows_body(count, f0, f1, P, klo, khi);
}

#ifdef CG_HAVE_WIDE_SEPARABLE
__attribute__((target("avx512f"))) static void lucy_rows_wide(int count, const double *f0, const double *f1,
                                                                const lucy_row_params *P, double *klo, double *khi)
{
    lucy_rows_body(count, f0, f1, P, klo, khi);
}
#endif

void cg_lucy_rows(int count, const double *f0, const double *f1, const lucy_row_params *P, double *klo,
                  double *khi, int wide)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (wide) {
        lucy_rows_wide(count, f0, f1, P, klo, khi);
        return;
    }
#endif
    (void)wide;
    lucy_rows_narrow(count, f0, f1, P, klo, khi);
}

void cg_lucy_values(int count, const double *q0, const double *q1, const double *q2, const double *n,
                    const double *e, double L, double R, double factor, double *w, int wide)
{
#ifdef CG_HAVE_WIDE_SEPARABLE
    if (wide) {
        lucy_values_wide(count, q0, q1, q2, n, e, L, R, factor, w);
        return;
    }
#endif
    (void)wide;
    lucy_values_narrow(count, q0, q1, q2, n, e, L, R, factor, w);
}

double cg_lucy_value(const double *q, const double *n, const double *e, double L, double R)
{
    const double inv = 1.0 / R;
    return lucy_value_units(q[0], q[1], q[2], n, e, L, R, inv);
}
