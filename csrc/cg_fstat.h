/*
 * cg_fstat.h -- the per-contact work of a MercuryDPM .fstat frame in one C
 * pass: the table of its interaction lines (parsed by cg_text.h) and the
 * .data frame's particles in, the contacts (one per pair, walls as j = -1)
 * out. The layouts and the rules are those of cgbound/readers/mercury.py's
 * module docstring; this file does what that reader did in NumPy, with the
 * same values bit for bit (its NumPy twin: oracle_fstat_contacts in
 * tests/oracle.py).
 *
 * Plain C11, no Python; returns a cg_status (cg.h). Thread-safe, no state;
 * call it with the GIL released. Allocates only internal scratch (freed).
 *
 * Per line k of the table (row_stride doubles per row, the first 16 the
 * columns 'time i j cx cy cz delta deltat fn ft nx ny nz tx ty tz'; i and j
 * as exact int64 in partners[2k], partners[2k + 1]):
 *   arm    = x_i - c          (minimum image along the periodic axes, the
 *                              rule of cg_minimum_image)
 *   proj   = n . arm           (summed as NumPy's einsum sums it: in 3-D
 *                              (n0 a0 + n2 a2) + n1 a1)
 *   force  = s (fn n + ft t)   s = -1 if proj < 0, else +1 (the force on i)
 * and the first d components of c, n, t are used (d = dim, 2 or 3).
 *
 * Pairing (lines with j >= 0): lines are grouped by the pair (min(i, j),
 * max(i, j)); a pair listed once is kept (an error if both particles flow),
 * a pair listed twice from both sides whose forces are opposite and contact
 * points equal within the tolerances is kept once, from the line with the
 * smaller i; anything else is an error. Tolerances: rtol x max(F, 1e-300)
 * for |f1 + f2| (F the largest |force| of all lines, NaN if one is NaN) and
 * rtol x 2 max(radius) for |c1 - c2| (norms summed in component order). Wall
 * lines (j < 0) are kept as they are. Kept lines are written in file order.
 *
 * Problems, in the order they are looked for (the first kind found is
 * reported, and of that kind the line that comes first; for pairs, the pair
 * whose first line comes first):
 *   CG_FSTAT_TIME          |time_k - time| > time_tolerance      row
 *   CG_FSTAT_PARTICLE      i outside [0, n_particles)            row
 *   CG_FSTAT_GHOST         j >= n_particles (a periodic ghost)   row
 *   CG_FSTAT_SELF          j == i                                row
 *   CG_FSTAT_FLAT          |proj| <= 1e-12 max(|arm|, 1e-300) with fn or ft
 *                          nonzero (and |proj| <= 1e-12 max(B, 1e-300),
 *                          B = 2 sqrt(d) max |arm component| of the frame) row
 *   CG_FSTAT_REPEATED      a pair listed more than twice, or twice from one
 *                          side: row (its first line), pair_lo/hi, count
 *   CG_FSTAT_INCONSISTENT  two lines of a pair disagree: row, other_row,
 *                          pair_lo/hi, df = |f1 + f2|, dc = |c1 - c2|,
 *                          force_row, force_other
 *   CG_FSTAT_ONCE          a pair of two flowing particles listed once: row
 * (REPEATED and INCONSISTENT compete by the pair's first line; ONCE only
 * when neither is found.) The status is then CG_ERR_FSTAT_LINES and the
 * outputs are unspecified.
 */
#ifndef CGBOUND_CG_FSTAT_H
#define CGBOUND_CG_FSTAT_H

#include <stddef.h>
#include <stdint.h>

#include "cg.h"

#ifdef __cplusplus
extern "C" {
#endif

#define CG_FSTAT_COLUMNS 16

typedef enum cg_fstat_problem {
    CG_FSTAT_NONE = 0,
    CG_FSTAT_TIME = 1,
    CG_FSTAT_PARTICLE = 2,
    CG_FSTAT_GHOST = 3,
    CG_FSTAT_SELF = 4,
    CG_FSTAT_FLAT = 5,
    CG_FSTAT_REPEATED = 6,
    CG_FSTAT_INCONSISTENT = 7,
    CG_FSTAT_ONCE = 8
} cg_fstat_problem;

typedef struct cg_fstat_frame {
    const double *rows;       /* n_rows x row_stride, row-major */
    int64_t n_rows;
    int64_t row_stride;       /* >= CG_FSTAT_COLUMNS */
    const int64_t *partners;  /* n_rows x 2: i, j of each line */
    double time;              /* the frame's time */
    double time_tolerance;    /* a line's time may differ from it by this much */
    const double *positions;  /* n_particles x dim */
    int64_t n_particles;
    int dim;                  /* 2 or 3 */
    const double *radii;      /* n_particles */
    const unsigned char *fixed; /* n_particles, nonzero = fixed */
    const int *periodic;      /* dim flags */
    const double *period;     /* dim lengths (used where periodic) */
    double rtol;              /* >= 0 */
} cg_fstat_frame;

typedef struct cg_fstat_result {
    /* outputs, each with room for n_rows contacts (force, point: n_rows x dim) */
    int64_t *i, *j, *wall;    /* j = -1 and wall = -1 - j_line for walls; wall = -1 for pairs */
    double *force, *point, *overlap;
    int64_t n_kept;
    /* the problem found (CG_ERR_FSTAT_LINES), see above */
    cg_fstat_problem problem;
    int64_t row, other_row, pair_lo, pair_hi, count;
    double df, dc;
    double force_row[3], force_other[3];
} cg_fstat_result;

/* The contacts of one .fstat frame (see above). CG_ERR_ARGUMENT for NULL
   pointers, dim not 2 or 3, row_stride < CG_FSTAT_COLUMNS or negative
   counts; CG_ERR_NOMEM if the pairing's scratch cannot be allocated. */
cg_status cg_fstat_contacts(const cg_fstat_frame *frame, cg_fstat_result *out);

#ifdef __cplusplus
}
#endif

#endif /* CGBOUND_CG_FSTAT_H */
