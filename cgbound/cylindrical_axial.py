"""Exact z-averages of the contact and boundary stresses' line integrals and of the extended stress's rays on
θ-RESOLVED z-averaged CylindricalGrids.

The z-average over [lo, hi] at the node column (r, θ) of a segment's line integral ∫₀¹ W(x - a - s b) ds is
the kernel's integral over the parallelogram {a + s b + t e_z} seen from x(r, θ, lo), divided by H = hi - lo.
It is taken with the segment outside and the column inside:

    ∫₀¹ I(a + s b) ds,   I(p) = (1/H) ∫₀^H W(x_lo + τ e_z - p) dτ,

I the kernel's exact line integral along the column (the core's segment integral with node and source swapped,
as :func:`~cgbound.cylindrical_ring.axial_line_average` does for points). I(p) is zero outside the capsule of
radius c (the kernel's support radius) around the column [x_lo, x_hi], and analytic in s between the s where
p(s) crosses the cylinder ρ = c about the column (square-root ends: the chord √(c² - ρ²)) or the spheres of
radius c about x_lo and x_hi (where the chord starts to be clipped by the column's end): the roots of three
quadratics in s. Each piece gets Gauss-Legendre points in u on panels no longer than the kernel's scale along the
segment, s = s₀ + (s₁ - s₀) sin²(π u / 2) (analytic at square-root ends); the pieces are found here, their
sums taken by the C core (csrc/cg_axial.c, ``cg_axial_segment_sum``). Near-singularities get geometric cuts
towards them (ratio 1/4, a piece at most 3 times longer than its distance to one): a segment grazing the
cylinder (a complex pair of roots), a cylinder root next to another breakpoint (its mirror in the next piece),
and for Lucy, whose d³ term makes I non-analytic where p meets the column (ρ = 0) or its ends, the closest
approaches to the column's line and to x_lo and x_hi. Rays (the extended stress, ∫₀^∞) are clipped where they
leave the grid's reach along the box's walled axes first; periodic images are explicit sources.

``tests/test_cylindrical_axial.py`` checks the sums against nested adaptive quadrature (scipy) at 1e-12.
"""
import numpy as np

from . import _engine
from ._threads import get_num_threads
from .cylindrical_ring import periodic_sources, reach_box
from .kernels import Lucy
from .primaries import segment_sources

#: at most this many panels per piece (the C core's limit; a piece needs one per kernel scale)
MAX_PANELS = 1 << 20
#: geometric grading towards a near-singularity: ratio and levels (0.25^26 ~ 2e-16)
GRADING = 0.25
GRADING_LEVELS = 26
_GRADES = GRADING ** np.arange(1, GRADING_LEVELS + 1)


def quadratic_roots(A, B, C):
    """The real roots (two columns, NaN where none) of A s² + 2 B s + C = 0, stable for small A (then one root
    is C / q and the other far away or absent), and the closest approach of the complex pair where the roots
    are complex: (roots (K, 2), real part (K,), imaginary part (K,) (0 where real))."""
    disc = B * B - A * C
    with np.errstate(divide="ignore", invalid="ignore"):
        q = -(B + np.copysign(np.sqrt(np.maximum(disc, 0.0)), B))
        r1 = np.where(A != 0.0, q / A, np.nan)
        r2 = np.where(q != 0.0, C / q, np.nan)
        real_part = np.where(A != 0.0, -B / A, np.nan)
        imag = np.where(A != 0.0, np.sqrt(np.maximum(-disc, 0.0)) / np.abs(A), np.inf)
    roots = np.where((disc >= 0.0)[:, None], np.stack([r1, r2], axis=1), np.nan)
    return roots, real_part, imag


def graded_cuts(centre, distance, span):
    """Cuts at centre ± max(span 4^-k, distance), k = 1..26 ((K, 52)), NaN where the grading is not needed
    (distance at least a quarter of the span, or no centre)."""
    with np.errstate(invalid="ignore"):
        need = np.flatnonzero(np.isfinite(centre) & (distance < GRADING * span))
    cuts = np.full((len(centre), 2 * GRADING_LEVELS), np.nan)
    if need.size:
        offsets = np.maximum(span[need, None] * _GRADES, distance[need, None])
        cuts[need] = np.concatenate([centre[need, None] - offsets, centre[need, None] + offsets], axis=1)
    return cuts


def column_pieces(kernel, d0, b, e_z, H, S):
    """The pieces [s₀, s₁] of s in [0, S] along the segments d0 + s b (d0: start relative to x_lo, (K, 3))
    where I is nonzero and analytic: (segment (P,), s₀ (P,), s₁ (P,))."""
    c = float(kernel.radius)
    K = len(d0)
    zeta0, beta = d0 @ e_z, b @ e_z
    u0, bp = d0 - zeta0[:, None] * e_z, b - beta[:, None] * e_z
    A_c, B_c, C_c = np.einsum("ki,ki->k", bp, bp), np.einsum("ki,ki->k", u0, bp), np.einsum("ki,ki->k", u0, u0)
    A_s = np.einsum("ki,ki->k", b, b)
    B_lo, C_lo = np.einsum("ki,ki->k", d0, b), np.einsum("ki,ki->k", d0, d0)
    B_hi, C_hi = B_lo - H * beta, C_lo - 2.0 * H * zeta0 + H * H
    cyl, cyl_centre, cyl_imag = quadratic_roots(A_c, B_c, C_c - c * c)
    lo_roots, lo_centre, _ = quadratic_roots(A_s, B_lo, C_lo - c * c)
    hi_roots, hi_centre, _ = quadratic_roots(A_s, B_hi, C_hi - c * c)
    S = np.broadcast_to(np.asarray(S, dtype=float), (K,))
    breaks = np.concatenate([np.zeros((K, 1)), S[:, None], cyl, lo_roots, hi_roots], axis=1)
    breaks = np.where((breaks >= 0.0) & (breaks <= S[:, None]), breaks, np.nan)
    grazing = np.where(cyl_imag > 0.0, cyl_centre, np.nan)          # grazing the cylinder: a complex pair
    cuts = [breaks, graded_cuts(grazing, cyl_imag, S)]
    # a cylinder root with another breakpoint close by (not the segment's ends): the root's square root sits
    # just outside the piece between them
    for j in range(2):
        root = cyl[:, j]
        others = np.delete(breaks[:, 2:], j, axis=1)
        gap = np.nanmin(np.where(np.abs(others - root[:, None]) > 0.0, np.abs(others - root[:, None]), np.inf), axis=1)
        cuts.append(graded_cuts(np.where(np.isfinite(root) & (root >= 0) & (root <= S), root, np.nan), gap, S))
    if isinstance(kernel, Lucy):         # d³: I is not analytic where p(s) meets the column's line or its ends
        with np.errstate(divide="ignore", invalid="ignore"):
            near_line = np.sqrt(np.maximum(C_c - np.where(A_c > 0, B_c * B_c / A_c, 0.0), 0.0) / A_c)
            near_lo = np.sqrt(np.maximum(C_lo - np.where(A_s > 0, B_lo * B_lo / A_s, 0.0), 0.0) / A_s)
            near_hi = np.sqrt(np.maximum(C_hi - np.where(A_s > 0, B_hi * B_hi / A_s, 0.0), 0.0) / A_s)
        cuts += [graded_cuts(cyl_centre, near_line, S), graded_cuts(lo_centre, near_lo, S),
                 graded_cuts(hi_centre, near_hi, S)]
    graded = np.concatenate(cuts[1:], axis=1)
    graded = np.where((graded >= 0.0) & (graded <= S[:, None]), graded, np.nan)
    # the rows with graded cuts (few) sorted apart from the others: most rows need only their breakpoints
    fine = np.isfinite(graded).any(axis=1)
    found = []
    for rows, edges in ((np.flatnonzero(~fine), breaks[~fine]),
                        (np.flatnonzero(fine), np.concatenate([breaks[fine], graded[fine]], axis=1))):
        if not rows.size:
            continue
        edges = np.sort(edges, axis=1)                               # NaN last
        s0, s1 = edges[:, :-1], edges[:, 1:]
        mid = 0.5 * (s0 + s1)
        # inside the capsule at the piece's middle (the capsule's surface is made of breakpoints)
        k = rows[:, None]
        zeta = zeta0[k] + mid * beta[k]
        rho2 = C_c[k] + mid * (2.0 * B_c[k] + mid * A_c[k])
        d_lo = C_lo[k] + mid * (2.0 * B_lo[k] + mid * A_s[k])
        d_hi = C_hi[k] + mid * (2.0 * B_hi[k] + mid * A_s[k])
        with np.errstate(invalid="ignore"):
            inside = (s1 > s0) & (rho2 < c * c) & (((zeta >= 0.0) & (zeta <= H)) | (d_lo < c * c) | (d_hi < c * c))
        seg, piece = np.nonzero(inside)
        found.append((rows[seg], s0[seg, piece], s1[seg, piece]))
    seg, s0, s1 = (np.concatenate(a) for a in zip(*found))
    order = np.argsort(seg, kind="stable")                           # pieces in segment order
    return seg[order], s0[order], s1[order]


def clip_rays(box, starts, vectors, reach_lo, reach_hi):
    """Rays start + s vector, s >= 0, as the segments of them inside [reach_lo, reach_hi] along the box's walled
    axes (the periodic ones are imaged later): (starts, vectors, factor = the s-length kept, the segment's
    line integral times it is the ray's). Raises if a ray never leaves that region (along periodic axes only)."""
    K = len(starts)
    s_lo, s_hi = np.zeros(K), np.full(K, np.inf)
    for d in range(3):
        if box.periodic[d]:
            continue
        v, x = vectors[:, d], starts[:, d]
        with np.errstate(divide="ignore", invalid="ignore"):
            t0, t1 = (reach_lo[d] - x) / v, (reach_hi[d] - x) / v
        inside = (x >= reach_lo[d]) & (x <= reach_hi[d])
        lo = np.where(v != 0.0, np.minimum(t0, t1), np.where(inside, -np.inf, np.inf))
        hi = np.where(v != 0.0, np.maximum(t0, t1), np.where(inside, np.inf, -np.inf))
        s_lo, s_hi = np.maximum(s_lo, lo), np.minimum(s_hi, hi)
    keep = s_hi > s_lo
    if np.any(keep & ~np.isfinite(s_hi)):
        raise ValueError("fields: a boundary contact's ray (extended_stress, eq. 24) runs along the box's periodic "
                         "axes only and never leaves the grid's reach: its line integral is infinite")
    s_lo, s_hi = s_lo[keep], s_hi[keep]
    return starts[keep] + s_lo[:, None] * vectors[keep], (s_hi - s_lo)[:, None] * vectors[keep], keep, s_hi - s_lo


def axial_segment_average(grid, kernel, starts, vectors, values, ray=False, n_threads=None):
    """z-averages at every node of a θ-RESOLVED z-averaged CylindricalGrid of sum_k values_k ∫₀^S W(x - starts_k
    - s vectors_k) ds (S = 1, or ∞ with ``ray``), exact to round-off.

    starts, vectors: (K, 3) Cartesian; values: (K, 3, 3) Cartesian. Returns (n_nodes, 3, 3) in the local basis
    (e_r, e_θ, e_z), nodes in C order (n_r, n_θ, 1). See the module's docstring for the rule. ``n_threads``:
    the C core's threads (None: :func:`cgbound.get_num_threads`; the sums do not depend on it).
    """
    c = float(kernel.radius)
    lo, hi = grid.z_extent
    H = hi - lo
    R, T = np.meshgrid(grid.r, grid.theta, indexing="ij")
    R, T = R.ravel(), T.ravel()
    out = np.zeros((R.size, 3, 3))
    starts = np.asarray(starts, dtype=float).reshape(-1, 3)
    vectors = np.asarray(vectors, dtype=float).reshape(-1, 3)
    values = np.asarray(values, dtype=float).reshape(-1, 9)
    if not len(starts):
        return out
    r_top = float(grid.r.max()) + c
    reach_lo, reach_hi = reach_box(grid, r_top, lo - c, hi + c)
    if ray:
        starts, vectors, keep, factor = clip_rays(grid.box, starts, vectors, reach_lo, reach_hi)
        values = values[keep] * factor[:, None]
        if not len(starts):
            return out
    longest = float(np.sqrt(np.einsum("ki,ki->k", vectors, vectors).max()))
    starts, (vectors, values) = periodic_sources(grid.box, starts, [vectors, values], reach_lo - longest,
                                                 reach_hi + longest)
    if not len(starts):
        return out
    length = np.sqrt(np.einsum("ki,ki->k", vectors, vectors))
    scale = kernel.scale
    e_z = grid.e_z
    bottoms = np.ascontiguousarray(grid.cartesian(R, T, np.full(R.shape, lo)))
    # a quick candidate test per column: the segment's bounding box against the column's capsule's
    seg_lo, seg_hi = np.minimum(starts, starts + vectors), np.maximum(starts, starts + vectors)
    segments, s0s, s1s, counts = [], [], [], np.zeros(R.size, dtype=np.int64)
    for n, x_lo in enumerate(bottoms):
        x_hi = x_lo + H * e_z
        cap_lo, cap_hi = np.minimum(x_lo, x_hi) - c, np.maximum(x_lo, x_hi) + c
        cand = np.flatnonzero(np.all((seg_hi > cap_lo) & (seg_lo < cap_hi), axis=1))
        if not cand.size:
            continue
        seg, s0, s1 = column_pieces(kernel, starts[cand] - x_lo, vectors[cand], e_z, H, 1.0)
        segments.append(cand[seg])
        s0s.append(s0)
        s1s.append(s1)
        counts[n] = seg.size
    if not counts.any():
        return out
    segment, s0, s1 = (np.concatenate(a) for a in (segments, s0s, s1s))
    # panels in u no longer than the kernel's scale along the segment: I varies on it
    panels = np.clip(np.ceil((s1 - s0) * length[segment] / scale), 1, MAX_PANELS).astype(np.int64)
    first = np.concatenate([[0], np.cumsum(counts)])
    sums = _engine.axial_segment_sum(kernel, bottoms, np.ascontiguousarray(-H * e_z), first, segment, s0, s1,
                                     panels, np.ascontiguousarray(starts), np.ascontiguousarray(vectors),
                                     np.ascontiguousarray(values),
                                     n_threads=get_num_threads() if n_threads is None else n_threads)
    basis = grid.basis(T)
    return np.einsum("nia,nab,njb->nij", basis, np.asarray(sums).reshape(-1, 3, 3), basis)


def axial_line_integrals(job, grid, needed):
    """The line-integral primaries among ``needed`` ("sb", "sw": the contact and boundary stresses' segments;
    "sx": the extended stress's rays) z-averaged exactly on the θ-resolved z-averaged ``grid``, in the local basis:
    {name: (n_nodes, 3, 3)}. ``job``: from :func:`~cgbound.pipeline.prepare` (its snapshot, kernel, split)."""
    if not job.split:
        return {}
    bulk, boundary = job.split
    out = {}
    for name, part, ray in (("sb", bulk, False), ("sw", boundary, False), ("sx", boundary, True)):
        if name in needed:
            starts, vectors, values = segment_sources(job.snapshot, part)
            out[name] = axial_segment_average(grid, job.kernel, starts, vectors, values.reshape(-1, 3, 3), ray=ray)
    return out
