"""Exact z-averages of the contact and boundary stresses' line integrals on θ-averaged, z-averaged
CylindricalGrids, and the extended stress's rays on θ-averaged grids as finite segments.

The average over z in [lo, hi] of the ring average of ∫₀¹ W(x - p(s)) ds is taken in the order s outside,
z inside: at each point p(s) of a segment the z-average of the ring moments is the exact axial average of a
point source (:func:`~cgbound.cylindrical_ring.axial_rule`, the rule of the particle sums, written in C for these
s-points: ``cg_ring_axial_point_sum`` in csrc/cg_ring.c). As a function of s
that average is analytic except where the structure of the point's support changes, all of them roots of
low-degree polynomials in s (ρ(s)² = q₀ + q₁ s + q₂ s², ζ(s) = ζ₀ + s a_z):

- ρ(s) = r + c, ``|r - c|`` (the support's torus in the plane: the point's z-window appears; at ``|r - c|``
  also the whole ring starts to fit in it) and ρ(s) = r (Lucy's d³ at the closest approach);
- (r ∓ ρ(s))² + (lo - ζ(s))² = c², the same at hi (the z-window's ends and the whole-ring window's ends
  cross the box's ends: :func:`~cgbound.cylindrical_ring.support_crossings` at h₀ = lo - ζ₀, hi - ζ₀);
- ζ(s) = lo, hi (the point crosses an end), and the closest approach to the axis (a harmless extra cut that
  keeps a grazing pair of roots at a piece's end).

Between cuts each piece gets 20-point Gauss-Legendre panels in u, s = a + (b - a) sin²(π u / 2) (square-root
ends made analytic), no longer than the kernel's scale along the segment. Two singularities are worse than square
roots and are graded towards (:func:`graded_cuts_along`): x log x where the whole ring enters the support of a
kernel with a jump at its edge, and the axis where a box end cuts the arcs of the point's support.
"""
import math

import numpy as np

from . import _engine
from .cylindrical_ring import (axis_cuts, clear_of, edge_jump, partial_arc, reach_box, segment_ranges,
                               segments_in_frame, support_crossings, GRADING, MAX_PANELS)

#: Gauss-Legendre points per panel along a segment (as the C core's ring_segment_sum)
SEGMENT_POINTS = 20
_SEG_G, _SEG_GW = np.polynomial.legendre.leggauss(SEGMENT_POINTS)
#: a panel along a segment spans at most this many kernel scales
PANEL_SCALES = 1.0
#: s-points whose axial averages are taken at once (memory: their points and tensors)
POINTS_PER_BLOCK = 1 << 16


def quadratic_roots(a, b, c):
    """The real roots of a s² + b s + c (rows), (K, 2), NaN where there is none (a = 0: the linear root)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        disc = b * b - 4.0 * a * c
        sq = np.sqrt(disc)
        q = -0.5 * (b + np.copysign(sq, b))            # no cancellation
        r1 = np.where(a != 0.0, q / a, -c / b)
        r2 = np.where(q != 0.0, c / q, np.nan)
        r2 = np.where(a != 0.0, r2, np.nan)
        ok = disc >= 0.0
    return np.where(ok[:, None], np.stack([r1, r2], axis=1), np.nan)


def axial_cuts_along(r, c, lo, hi, x0, a_perp, zeta0, a_z):
    """The s in (0, 1) where the z-averaged ring moments of the point p(s) stop being analytic (module
    docstring), with 0 and 1, sorted: (K, n), repeated cuts are pieces of zero length."""
    q0 = np.einsum("ki,ki->k", x0, x0)
    q1 = 2.0 * np.einsum("ki,ki->k", x0, a_perp)
    q2 = np.einsum("ki,ki->k", a_perp, a_perp)
    cuts = []
    for radius in (r + c, abs(r - c), r):
        cuts.append(quadratic_roots(q2, q1, q0 - radius * radius))
    with np.errstate(invalid="ignore", divide="ignore"):
        cuts.append(np.where(q2 > 0.0, -q1 / (2.0 * np.where(q2 > 0.0, q2, 1.0)), np.nan)[:, None])
        for end in (lo, hi):
            cuts.append(support_crossings(r, end - zeta0, x0, a_perp, a_z, c))
            cuts.append(np.where(a_z != 0.0, (end - zeta0) / np.where(a_z != 0.0, a_z, 1.0), np.nan)[:, None])
    s = np.concatenate(cuts, axis=1)
    s = np.where((s > 0.0) & (s < 1.0), s, 1.0)        # outside (0, 1) or none: a repeated end
    return np.sort(np.concatenate([np.zeros((len(q0), 1)), s, np.ones((len(q0), 1))], axis=1), axis=1)


#: levels of the grading towards a whole ring entering the support (:func:`graded_cuts_along`)
WHOLE_RING_LEVELS = 6


def graded_cuts_along(kernel, r, lo, hi, x0, a_perp, zeta0, a_z, panel, others):
    """Cuts in s (K, n), NaN where there is none, grading the rule towards two points along each segment where the
    z-averaged ring moments are singular next to a piece's end, beyond the square roots the pieces' rule absorbs:

    - where the whole ring enters the point's support, ρ(s) = c - r (r < c; or where the segment passes closest to
      that cylinder, graded down to its distance ε from the pair of complex roots), for kernels with a jump at their edge
      above round-off (:func:`~cgbound.cylindrical_ring.edge_jump`: Heaviside, a Gaussian cut within 8.5 widths;
      Lucy vanishes there with two derivatives): the z-window's two whole-ring
      ends h = ±√(c² - (r + ρ)²) (square roots of the moments in h) pinch at h = 0, which leaves x log x in s.
      Cuts at s* ± max(``panel`` 4⁻ᵏ, ε), k = 0 .. WHOLE_RING_LEVELS - 1 (``panel`` the length in s of one kernel
      scale; none when ε > ``panel``),
      measured on ``random_snapshot(5)``, ring r = 0.375: a Heaviside's field moved by 2.3e-11 of its scale
      under 8 times finer panels, 5e-15 with 4 or more levels;
    - the closest approach to the axis (:func:`~cgbound.cylindrical_ring.axis_cuts`), kept where a box end cuts
      the arcs of the point's support (elsewhere the z-window holds every arc whole or none: analytic there).

    ``others``: the pieces' ends (:func:`axial_cuts_along`); cuts too close to them are dropped
    (:func:`~cgbound.cylindrical_ring.clear_of`)."""
    c = float(kernel.radius)
    cuts, distances = [], []
    if c > r and edge_jump(kernel) > np.finfo(float).eps:
        # the roots s_c ± √(((c - r)² - ρ_c²) / q₂) of ρ(s)² = (c - r)², ρ_c the closest approach to the axis at s_c:
        # real, or a pair ε from the real axis when the segment just misses the cylinder ρ = c - r
        q2 = np.einsum("ki,ki->k", a_perp, a_perp)
        with np.errstate(invalid="ignore", divide="ignore"):
            centre = np.where(q2 > 0.0, -np.einsum("ki,ki->k", x0, a_perp) / q2, np.nan)
            gap = ((c - r) ** 2 - np.einsum("ki,ki->k", x0, x0)) / q2 + centre * centre
        half = np.sqrt(np.abs(gap))
        eps = np.where(gap >= 0.0, 0.0, half)
        roots = np.where(gap >= 0.0, np.stack([centre - half, centre + half]), centre).T                # (K, 2)
        steps = np.maximum(panel[:, None, None] * GRADING ** np.arange(WHOLE_RING_LEVELS), eps[:, None, None])
        steps = np.broadcast_to(np.where(eps[:, None, None] < panel[:, None, None], steps, np.nan),
                                roots.shape + (WHOLE_RING_LEVELS,))
        cuts.append(np.concatenate([roots[..., None] - steps, roots[..., None] + steps], axis=2).reshape(len(x0), -1))
        distances.append(np.concatenate([steps, steps], axis=2).reshape(len(x0), -1))
    near_axis, step = axis_cuts(x0, a_perp, panel)
    distances.append(step)
    rho = np.hypot(*(x0[:, None, :] + near_axis[..., None] * a_perp[:, None, :]).transpose(2, 0, 1))
    zeta = zeta0[:, None] + near_axis * a_z[:, None]
    cuts.append(np.where(partial_arc(r, c, rho, lo - zeta) | partial_arc(r, c, rho, hi - zeta), near_axis, np.nan))
    s = clear_of(np.concatenate(cuts, axis=1), np.concatenate(distances, axis=1), others)
    return np.where((s > 0.0) & (s < 1.0), s, np.nan)


def z_averaged_ring_segments(grid, kernel, starts, vectors, values):
    """θ- and z-averages at every ring of a θ-averaged, z-averaged CylindricalGrid of
    sum_k values_k ∫₀¹ W(x - starts_k - s vectors_k) ds (values (K, 3, 3) Cartesian), exact: (n_r, 3, 3) in the
    local basis."""
    c = float(kernel.radius)
    lo, hi = grid.z_extent
    out = np.zeros((len(grid.r), 3, 3))
    x0, a_perp, zeta0, a_z, tensors, _ = segments_in_frame(grid, kernel, starts, vectors, values, lo, hi)
    if not len(x0):
        return out
    rho_min, rho_max, zeta_lo, zeta_hi = segment_ranges(x0, a_perp, zeta0, a_z)
    length = np.sqrt(np.einsum("ki,ki->k", a_perp, a_perp) + a_z * a_z)     # in the ring frame
    flat_tensors = tensors.reshape(-1, 9)
    scale = kernel.scale
    for k, r in enumerate(grid.r):
        cand = np.flatnonzero((rho_min < r + c) & (rho_max > r - c) & (zeta_lo < hi + c) & (zeta_hi > lo - c))
        if not cand.size:
            continue
        edges = axial_cuts_along(float(r), c, lo, hi, x0[cand], a_perp[cand], zeta0[cand], a_z[cand])
        graded = graded_cuts_along(kernel, float(r), lo, hi, x0[cand], a_perp[cand], zeta0[cand], a_z[cand],
                                   PANEL_SCALES * scale / length[cand], edges)
        edges = np.sort(np.concatenate([edges, np.nan_to_num(graded, nan=1.0)], axis=1), axis=1)
        a, b = edges[:, :-1], edges[:, 1:]
        mid = 0.5 * (a + b)
        rho_mid = np.hypot(*(x0[cand, None, :] + mid[..., None] * a_perp[cand, None, :]).transpose(2, 0, 1))
        zeta_mid = zeta0[cand, None] + mid * a_z[cand, None]
        window = np.sqrt(np.maximum(c * c - (r - rho_mid) ** 2, 0.0))
        active = (b > a) & (window > 0.0) & (zeta_mid - window < hi) & (zeta_mid + window > lo)
        seg, piece = np.nonzero(active)
        if not seg.size:
            continue
        seg_a, seg_b = a[seg, piece], b[seg, piece]
        owner = cand[seg]
        panels = np.clip(np.ceil((seg_b - seg_a) * length[owner] / (PANEL_SCALES * scale)), 1, MAX_PANELS).astype(int)
        # the s-points: per piece P panels of SEGMENT_POINTS, s = a + (b - a) sin²(π u / 2)
        piece_of = np.repeat(np.arange(seg.size), panels * SEGMENT_POINTS)
        first = np.repeat(np.cumsum(panels) - panels, panels * SEGMENT_POINTS)
        index = np.arange(piece_of.size) - first * SEGMENT_POINTS
        panel, node = index // SEGMENT_POINTS, index % SEGMENT_POINTS
        P = panels[piece_of]
        u = (panel + 0.5 * (_SEG_G[node] + 1.0)) / P
        span = seg_b[piece_of] - seg_a[piece_of]
        s = seg_a[piece_of] + span * np.sin(0.5 * math.pi * u) ** 2
        ds = span * 0.5 * _SEG_GW[node] / P * 0.5 * math.pi * np.sin(math.pi * u)
        who = owner[piece_of]
        for start in range(0, s.size, POINTS_PER_BLOCK):
            part = slice(start, start + POINTS_PER_BLOCK)
            # each s-point's exact axial average of a point source, summed by the C core
            out[k] += _engine.ring_axial_point_sum(kernel, float(r), lo, hi,
                                                   x0[who[part]] + s[part, None] * a_perp[who[part]],
                                                   zeta0[who[part]] + s[part] * a_z[who[part]],
                                                   flat_tensors[who[part]], ds[part])
    return out


def ray_lengths(grid, kernel, starts, vectors):
    """For rays start + s vector, s >= 0, the s beyond which no point of the ray (nor of its periodic images) is
    within the kernel's reach of a node of ``grid``: (K,), 0 for a ray that never comes within reach.

    Cuts, each valid where the box's periodic images leave it in place: the exit from the Cartesian box around
    the rings' supports along a non-periodic box axis (always; as the Cartesian engine cuts rays), from the
    cylinder ρ <= r_max + c (when the box is periodic only along the axis) and from the slab of z within c of
    the nodes (when no periodic box axis has a component along the axis). Raises ValueError for a ray that no
    cut ends (it runs along a periodic axis: its line integral is infinite)."""
    c = float(kernel.radius)
    starts, vectors = np.asarray(starts, float), np.asarray(vectors, float)
    r_top = float(grid.r.max()) + c
    z_lo, z_hi = grid.z_extent if grid.z_averaged else (float(grid.z.min()), float(grid.z.max()))
    z_lo, z_hi = z_lo - c, z_hi + c
    reach_lo, reach_hi = reach_box(grid, r_top, z_lo, z_hi)
    periodic = np.asarray(grid.box.periodic, bool)
    length = np.full(len(starts), np.inf)
    with np.errstate(invalid="ignore", divide="ignore"):
        for d in np.flatnonzero(~periodic):
            bound = np.where(vectors[:, d] > 0.0, reach_hi[d], reach_lo[d])
            exit_d = np.where(vectors[:, d] != 0.0, (bound - starts[:, d]) / vectors[:, d], np.inf)
            length = np.minimum(length, exit_d)
        rel = starts - grid.axis_point
        zeta0, a_z = rel @ grid.e_z, vectors @ grid.e_z
        if np.all(np.abs(grid.e_z[periodic]) == 1.0):           # images only along the axis: the cylinder stays
            x0 = rel - zeta0[:, None] * grid.e_z
            a_perp = vectors - a_z[:, None] * grid.e_z
            roots = quadratic_roots(np.einsum("ki,ki->k", a_perp, a_perp), 2.0 * np.einsum("ki,ki->k", x0, a_perp),
                                    np.einsum("ki,ki->k", x0, x0) - r_top * r_top)
            moving = np.einsum("ki,ki->k", a_perp, a_perp) > 0.0
            exit_r = np.where(moving, np.nan_to_num(np.nanmax(np.where(np.isnan(roots), -np.inf, roots), axis=1),
                                                    neginf=0.0), np.inf)
            exit_r = np.where(moving & np.all(np.isnan(roots), axis=1), 0.0, exit_r)   # misses the cylinder
            length = np.minimum(length, exit_r)
        if not np.any(grid.e_z[periodic] != 0.0):               # images only across the axis: the slab stays
            bound = np.where(a_z > 0.0, z_hi, z_lo)
            length = np.minimum(length, np.where(a_z != 0.0, (bound - zeta0) / a_z, np.inf))
    if not np.all(np.isfinite(length)):
        k = int(np.flatnonzero(~np.isfinite(length))[0])
        raise ValueError(f"contacts: expected the extended stress's rays to leave the reach of the grid's rings, got "
                         f"the ray of the boundary contacts' row {k} (direction {vectors[k].tolist()}) running along a "
                         "periodic axis forever: its line integral is infinite")
    return np.maximum(length, 0.0)
