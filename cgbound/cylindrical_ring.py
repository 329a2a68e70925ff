"""Exact θ-averages over rings of kernel sums of point sources (particles, contact points).

A source q at cylindrical (ρ, φ, ζ) is seen from the ring (r, z) at the distance
d(t)² = (r - ρ)² + (z - ζ)² + 4 r ρ sin²(t/2), t = θ - φ, and only on the arc ``|t|`` < Δ where d < c
(sin²(Δ/2) = (c² - d₀²) / 4 r ρ, d₀ the closest approach). d(t) is even in t, so the θ-average of
the kernel times the rotation into (e_r, e_θ, e_z) needs only three moments per (ring, source):

    M_m = (1/2π) ∫_{-Δ}^{Δ} W(d(t)) cos(m t) dt,   m = 0, 1, 2,

and a vector v' (in the source's own basis at θ = φ) averages to (M₁ v'_r, M₁ v'_θ, M₀ v'_z); a tensor
T' to the rules of :func:`rotate_averaged`. The moments are exact to round-off (csrc/cg_ring.c, which
documents its rules: Heaviside in closed form; the Gaussian, entire in t, by Gauss-Legendre panels
that keep the exponent's change per panel small; Lucy, whose odd power d³ has branch points at
t = ±i ε next to t = 0 when the ring passes close to the source, by panels graded towards t = 0).
``tests/test_cylindrical_ring.py`` checks them against 32-digit adaptive quadrature at 1e-12, and
``tests/test_ring_core.py`` the C entry points against their NumPy twins.

On θ-RESOLVED z-averaged grids there is no ring: :func:`axial_line_average` takes the z-average of the point sums
as the kernel's exact line integral along each node's z-line (the core's segment integrals;
``tests/test_cylindrical_zline.py``).
"""
import math

import numpy as np

from . import _engine
from .kernels import Gaussian, Lucy

def ring_moments(kernel, r, h, rho, gradient=False):
    """(M₀, M₁, M₂) of pairs (ring radius r, axial offset h = z - ζ, source radius ρ), arrays of one shape
    (broadcast), shape (3,) + that shape; 0 for pairs whose closest approach is outside the support. With
    ``gradient`` the moments (N₀, N₁, N₂) of G = W'(d)/d instead (∇W(x - q) = G (x - q))."""
    r, h, rho = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (r, h, rho)))
    out = np.zeros((3,) + r.shape)
    flat_r, flat_h, flat_rho, flat_out = r.ravel(), h.ravel(), rho.ravel(), out.reshape(3, -1)
    radii, ring = np.unique(flat_r, return_inverse=True)
    for k, radius in enumerate(radii):
        pick = np.flatnonzero(ring == k) if len(radii) > 1 else slice(None)
        flat_out[:, pick] = _engine.ring_moments(kernel, float(radius), np.ascontiguousarray(flat_h[pick]),
                                                 np.ascontiguousarray(flat_rho[pick]), gradient=gradient)
    return out


def rotate_averaged(values, rank, M):
    """The θ-average of the local components of sources with components ``values`` (pairs, 3, ...) in their
    own basis at θ = φ, weighted by the moments M (3, pairs): with E[cos t] = M₁, E[sin t] = E[sin t cos t] = 0,
    E[cos² t] = (M₀ + M₂)/2, E[sin² t] = (M₀ - M₂)/2."""
    M0, M1, M2 = M
    if rank == 0:
        return M0 * values
    if rank == 1:
        out = values * M1[:, None]
        out[:, 2] = values[:, 2] * M0
        return out
    cc, ss = 0.5 * (M0 + M2), 0.5 * (M0 - M2)
    T = values
    out = np.empty_like(T)
    out[:, 0, 0] = cc * T[:, 0, 0] + ss * T[:, 1, 1]
    out[:, 1, 1] = ss * T[:, 0, 0] + cc * T[:, 1, 1]
    out[:, 0, 1] = cc * T[:, 0, 1] - ss * T[:, 1, 0]
    out[:, 1, 0] = cc * T[:, 1, 0] - ss * T[:, 0, 1]
    for a, b in ((0, 2), (1, 2), (2, 0), (2, 1)):
        out[:, a, b] = M1 * T[:, a, b]
    out[:, 2, 2] = M0 * T[:, 2, 2]
    return out


def reach_box(grid, r_top, z_lo, z_hi):
    """The Cartesian box (lower, upper corners) around the cylinder of radius ``r_top`` about the grid's axis
    between axial coordinates z_lo and z_hi: where sources may reach the rings (for their periodic images)."""
    disc = r_top * np.sqrt(np.clip(1.0 - grid.e_z ** 2, 0.0, 1.0))      # a disc's extent along each box axis
    return (grid.axis_point + np.minimum(z_lo * grid.e_z, z_hi * grid.e_z) - disc,
            grid.axis_point + np.maximum(z_lo * grid.e_z, z_hi * grid.e_z) + disc)


def periodic_sources(box, positions, values, reach_lo, reach_hi):
    """The sources and their periodic images whose Cartesian position lies within [reach_lo, reach_hi]
    (per axis; the box's periodic axes only are imaged), with their values."""
    positions = np.asarray(positions, dtype=float)
    shifts = [np.zeros(3)]
    for d in range(3):
        if not box.periodic[d]:
            continue
        L = float(box.upper[d] - box.lower[d])
        k_lo = math.floor((reach_lo[d] - box.upper[d]) / L)
        k_hi = math.ceil((reach_hi[d] - box.lower[d]) / L)
        shifts = [s + k * L * np.eye(3)[d] for s in shifts for k in range(k_lo, k_hi + 1)]
    pos, vals = [], []
    for s in shifts:
        p = positions + s
        keep = np.all((p >= reach_lo) & (p <= reach_hi), axis=1)
        pos.append(p[keep])
        vals.append([v[keep] for v in values])
    return np.concatenate(pos), [np.concatenate([v[k] for v in vals]) for k in range(len(values))]


#: Gauss-Legendre points per piece (per panel) of an axial average (:func:`axial_rule`)
AXIAL_POINTS = 24
_AXIAL_G, _AXIAL_GW = np.polynomial.legendre.leggauss(AXIAL_POINTS)
#: a Gaussian's pieces are cut into panels of at most this many widths (a piece spans up to cutoff / width)
GAUSSIAN_WIDTHS_PER_PANEL = 5.0


def end_clustered(u):
    """x = (3u - u³)/2 and dx/du: [-1, 1] onto itself with dx/du = 0 at both ends, so an end where the integrand
    behaves like √(1 - x) (a ring's arc appearing, or becoming the whole ring) is analytic in u."""
    return 0.5 * (3.0 * u - u ** 3), 1.5 * (1.0 - u * u)


def end_clustered_inverse(x):
    """The u in [-1, 1] with (3u - u³)/2 = x (the root of the cubic u³ - 3u + 2x = 0 in [-1, 1])."""
    return 2.0 * np.cos((np.arccos(-np.clip(x, -1.0, 1.0)) + 4.0 * math.pi) / 3.0)


def axial_panels(kernel):
    """Panels per piece of an axial average: one for compact kernels and a Gaussian cut off within
    GAUSSIAN_WIDTHS_PER_PANEL widths (a piece spans up to cutoff / width widths of the bump)."""
    if not isinstance(kernel, Gaussian):
        return 1
    return max(1, math.ceil(float(kernel.radius) / (GAUSSIAN_WIDTHS_PER_PANEL * float(kernel.width)) - 1e-9))


#: geometric grading of the axial pieces towards a near-singularity: ratio and most levels (0.25^26 ~ 2e-16)
GRADING = 0.25
GRADING_LEVELS = 26
_GRADES = GRADING ** np.arange(1, GRADING_LEVELS + 1)


def axial_cuts(kernel, r, rho):
    """Where the ring moments of sources at radius ρ, seen from rings of radius r, stop being analytic in
    h = z - ζ, as offsets h >= 0 (the cuts are symmetric about h = 0): (S, n) with the support's edge H,
    the whole-ring transition and 0 (Lucy's closest approach), and graded cuts towards the end of a piece
    that has a branch point close by (a panel is then at most 3 times longer than its distance to it).

    The arc is Δ = 2 arcsin √s, s = (H² - h²) / 4 r ρ: square roots at s = 0 (h = ±H) and s = 1 (h = ±w,
    w = √(c² - (r + ρ)²)), the ends of the pieces, where the end-clustered rule absorbs them; but the
    mirror branch point -w lies 2w from the end w when w is small, the pair ±i √((r + ρ)² - c²) next to
    h = 0 when the ring just misses holding the whole support, and Lucy's d³ has ±i ``|r - ρ|`` next to
    h = 0 when the ring passes close to the source."""
    c = float(kernel.radius)
    H = np.sqrt(np.maximum(c * c - (r - rho) ** 2, 0.0))
    whole = np.sqrt(np.maximum(c * c - (r + rho) ** 2, 0.0))
    missed = np.sqrt(np.maximum((r + rho) ** 2 - c * c, 0.0))
    near_zero = np.where(whole > 0.0, np.inf, missed)              # the branch points next to h = 0
    if isinstance(kernel, Lucy):
        near_zero = np.minimum(near_zero, np.abs(r - rho))
    # graded only where the branch points are closer to the end than a quarter of the piece (a cut next to
    # another piece's end would put that end's square root next to this piece)
    inner = np.where(whole > 0.0, whole, H)[:, None]                 # the piece that ends at h = 0
    graded = near_zero[:, None] < GRADING * inner
    towards_zero = np.where(graded, np.maximum(inner * _GRADES, near_zero[:, None]), 0.0)
    # towards w from above, down to 2 w from it (the mirror branch point -w)
    span = (H - whole)[:, None]
    graded = (whole[:, None] > 0.0) & (2.0 * whole[:, None] < GRADING * span)
    towards_whole = np.where(graded, whole[:, None] + np.maximum(span * _GRADES, 2.0 * whole[:, None]), H[:, None])
    return np.concatenate([np.zeros((len(H), 1)), H[:, None], whole[:, None], towards_zero, towards_whole], axis=1)


def axial_rule(kernel, r, rho, zeta, lo, hi):
    """The exact average over z in [lo, hi] of the ring moments of sources at (ρ, ζ) seen from rings of radius r:
    (pair, h, weight), h = z - ζ of the points (P, q) of source ``pair`` (P,), weights including the
    1 / (hi - lo).

    z is cut at ζ ± :func:`axial_cuts`; each piece [a, b] is mapped from u in [-1, 1] by the end-clustered
    map, and Gauss-Legendre in u covers the part of it inside [lo, hi] (the preimage of the clipped piece): an
    end of the box next to a piece's end (a square root just outside [lo, hi]) stays harmless, the integrand
    being analytic in u over the whole piece."""
    cuts = axial_cuts(kernel, r, rho)
    edges = np.sort(np.concatenate([zeta[:, None] - cuts, zeta[:, None] + cuts], axis=1), axis=1)
    a, b = edges[:, :-1], edges[:, 1:]
    keep = (b > a) & (b > lo) & (a < hi)                 # drops repeated cuts and pieces outside [lo, hi]
    pair, piece = np.nonzero(keep)
    a, b = a[pair, piece], b[pair, piece]
    u_lo = end_clustered_inverse(2.0 * (np.maximum(a, lo) - a) / (b - a) - 1.0)
    u_hi = end_clustered_inverse(2.0 * (np.minimum(b, hi) - a) / (b - a) - 1.0)
    u_lo = np.where(a >= lo, -1.0, u_lo)                 # exact ends where not clipped
    u_hi = np.where(b <= hi, 1.0, u_hi)
    panels = axial_panels(kernel)
    g = ((np.arange(panels)[:, None] + 0.5 * (_AXIAL_G + 1.0)) / panels).ravel()        # in [0, 1]
    gw = np.tile(_AXIAL_GW, panels) / panels                                          # sums to 2
    u = u_lo[:, None] + (u_hi - u_lo)[:, None] * g
    x, dx = end_clustered(u)
    z = a[:, None] + (b - a)[:, None] * 0.5 * (x + 1.0)
    weight = (0.25 * (b - a) * (u_hi - u_lo))[:, None] * dx * gw / (hi - lo)
    return pair, z - zeta[pair, None], weight


def rotate_gradient(values, rank, r, rho, M):
    """The θ-average of the local components of ``values`` (pairs, 3, ...) in the sources' own basis at θ = φ
    times the kernel's gradient ∇W = G (x - q), the gradient index last, from the moments of G and their
    first moments in h: M = (N₀, N₁, N₂, ⟨h G⟩₀, ⟨h G⟩₁) (5, pairs). In the node's local basis
    x - q = (r - ρ cos t, ρ sin t, h) and a vector v' turns into (v'_r cos t + v'_θ sin t, v'_θ cos t - v'_r sin t,
    v'_z); terms odd in t average out."""
    N0, N1, N2, H0, H1 = M
    radial = r * N0 - rho * N1                       # ⟨G (r - ρ cos t)⟩
    if rank == 0:
        return np.stack([values * radial, np.zeros_like(radial), values * H0], axis=-1)
    along = r * N1 - 0.5 * rho * (N0 + N2)           # ⟨G cos t (r - ρ cos t)⟩
    across = 0.5 * rho * (N0 - N2)                   # ⟨G ρ sin² t⟩
    v_r, v_t, v_z = values[:, 0], values[:, 1], values[:, 2]
    out = np.zeros(values.shape + (3,))
    out[:, 0, 0], out[:, 0, 1], out[:, 0, 2] = v_r * along, v_t * across, v_r * H1
    out[:, 1, 0], out[:, 1, 1], out[:, 1, 2] = v_t * along, -v_r * across, v_t * H1
    out[:, 2, 0], out[:, 2, 2] = v_z * radial, v_z * H0
    return out


def gradient_moments(kernel, r, h, rho):
    """(N₀, N₁, N₂, h N₀, h N₁) of G = W'(d)/d for pairs (r, h, ρ) (broadcast): (5,) + their shape."""
    N = ring_moments(kernel, r, h, rho, gradient=True)
    return np.concatenate([N, h * N[:2]])


def accumulate(out, columns, own, s, M, nodes, r=None, rho=None):
    """Add the θ-averaged contributions of sources ``s`` with moments M (3, pairs) to ``nodes`` of ``out``;
    with ``rho`` (the sources' radii, seen from rings of radius ``r``) gradients with the moments of
    :func:`gradient_moments` (5, pairs)."""
    for (_, rank), v, acc in zip(columns, own, out):
        if rho is None:
            contrib = rotate_averaged(v[s], rank, M)
        else:
            contrib = rotate_gradient(v[s], rank, r, rho[s], M)
        contrib = contrib.reshape(len(s), -1)
        flat = acc.reshape(acc.shape[0], -1)
        for col in range(contrib.shape[1]):
            flat[:, col] += np.bincount(nodes, weights=contrib[:, col], minlength=flat.shape[0])


def ring_average(grid, kernel, positions, columns, gradient=False):
    """θ-averages at every node of a θ-averaged CylindricalGrid of sum_i values_i W(x - q_i) (with ``gradient``:
    of sum_i values_i ∇W(x - q_i), the derivative's index last).

    positions: (S, 3) Cartesian sources; columns: [(values (S,) + (3,) * rank Cartesian, rank)]. A z-averaged
    grid averages exactly over its extent (:func:`axial_rule`). Returns [(n_r * n_z,) + (3,) * rank] (with
    ``gradient`` rank + 1) in the local basis, nodes in C order.
    """
    c = float(kernel.radius)
    n_r, n_z = len(grid.r), len(grid.z)
    extra = 1 if gradient else 0
    out = [np.zeros((n_r * n_z,) + (3,) * (rank + extra)) for _, rank in columns]
    moments = (lambda r, h, rho: gradient_moments(kernel, r, h, rho)) if gradient else \
        (lambda r, h, rho: ring_moments(kernel, r, h, rho))
    if not len(positions):
        return out
    # the region the rings' supports cover, as a Cartesian box (for the periodic images)
    r_top = float(grid.r.max()) + c
    if grid.z_averaged:
        z_lo, z_hi = grid.z_extent
    else:
        z_lo, z_hi = float(grid.z.min()), float(grid.z.max())
    z_lo, z_hi = z_lo - c, z_hi + c
    reach_lo, reach_hi = reach_box(grid, r_top, z_lo, z_hi)
    pos, vals = periodic_sources(grid.box, positions, [v for v, _ in columns], reach_lo, reach_hi)
    rel = pos - grid.axis_point
    zeta = rel @ grid.e_z
    x1, x2 = rel @ grid.e_1, rel @ grid.e_2
    rho = np.hypot(x1, x2)
    phi = np.arctan2(x2, x1)
    basis = grid.basis(phi)                                          # (S, 3, 3) rows e_r, e_θ, e_z at φ
    own = []
    for v, rank in zip(vals, (rank for _, rank in columns)):
        if rank == 1:
            v = np.einsum("sia,sa->si", basis, v)
        elif rank == 2:
            v = np.einsum("sia,sab,sjb->sij", basis, v, basis)
        own.append(v)
    z_nodes = grid.z[:, None]
    node_z = np.arange(n_z)
    for k, r in enumerate(grid.r):
        near = np.abs(rho - r) < c
        if not near.any():
            continue
        src = np.flatnonzero(near)
        if grid.z_averaged:
            pair, h, w = axial_rule(kernel, r, rho[src], zeta[src], *grid.z_extent)
            if not pair.size:
                continue
            M = moments(r, h, rho[src][pair, None])
            M = M.reshape(len(M), -1) * w.ravel()
            point_source = np.repeat(pair, h.shape[1])
            M = np.stack([np.bincount(point_source, weights=m, minlength=src.size) for m in M])
            accumulate(out, columns, own, src, M, np.full(src.size, k * n_z), *((r, rho) if gradient else ()))
            continue
        h = z_nodes[:, :, None] - zeta[src][None, None, :]             # (n_z, 1, S')
        inside = (r - rho[src]) ** 2 + h * h < c * c
        zi, qi, si = np.nonzero(inside)
        if not zi.size:
            continue
        s = src[si]
        M = moments(r, h[zi, qi, si], rho[s])
        accumulate(out, columns, own, s, M, k * n_z + node_z[zi], *((r, rho) if gradient else ()))
    return out


#: at most this many panels per piece (a piece longer than MAX_PANELS kernel scales gets longer panels)
MAX_PANELS = 256


def segment_quartic(r, h0, x0, a_perp, a_z, c):
    """The coefficients (K, 5), highest power first, of (Q + r² + h² - c²)² - 4 r² Q in s, Q = ρ(s)² and
    h = h0 - s a_z of the points p(s) = start + s a (in-plane start x0 and vector a_perp, axial a_z): zero where
    (r ∓ ρ(s))² + h(s)² = c²."""
    q0 = np.einsum("ki,ki->k", x0, x0)
    q1 = 2.0 * np.einsum("ki,ki->k", x0, a_perp)
    q2 = np.einsum("ki,ki->k", a_perp, a_perp)
    e0 = q0 + r * r + h0 * h0 - c * c
    e1 = q1 - 2.0 * h0 * a_z
    e2 = q2 + a_z * a_z
    four = 4.0 * r * r
    return np.stack([e2 * e2, 2.0 * e1 * e2, e1 * e1 + 2.0 * e0 * e2 - four * q2, 2.0 * e0 * e1 - four * q1,
                     e0 * e0 - four * q0], axis=1)


def quartic_roots(coef):
    """The complex roots (K, 4), in no particular order, of quartics ``coef`` (K, 5) (a nonzero leading
    coefficient): the C core's Aberth-Ehrlich iteration (csrc/cg_quartic.c; the callers sort their cuts)."""
    return _engine.quartic_roots(np.ascontiguousarray(coef))


def support_crossings(r, h0, x0, a_perp, a_z, c):
    """The s in (0, 1) where p(s) = start + s a crosses (r ∓ ρ(s))² + h(s)² = c² (the edge of the torus around
    the ring, and where the whole ring enters the support): the real roots of the quartic
    (Q + r² + h² - c²)² - 4 r² Q, Q = ρ(s)², h = h0 - s a_z; (K, 4), NaN where there is none. Near-double roots
    (grazing) come as a close complex pair: their real part is kept, a harmless extra breakpoint."""
    coef = segment_quartic(r, h0, x0, a_perp, a_z, c)
    return real_roots(coef, quartic_roots(coef))


def real_roots(coef, roots):
    """The real roots in (0, 1) of the quartics ``coef`` (K, 5), from their complex ``roots`` (K, 4), polished; NaN
    where there is none (:func:`support_crossings`)."""
    real = np.where(np.abs(roots.imag) < 1e-4, roots.real, np.nan)
    for _ in range(3):                                               # polish: Newton on the quartic
        p = ((((coef[:, :1] * real + coef[:, 1:2]) * real + coef[:, 2:3]) * real + coef[:, 3:4]) * real
             + coef[:, 4:5])
        dp = (((4.0 * coef[:, :1] * real + 3.0 * coef[:, 1:2]) * real + 2.0 * coef[:, 2:3]) * real + coef[:, 3:4])
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(dp != 0.0, p / dp, 0.0)
        real = np.where(np.abs(step) < 1e-3, real - step, real)
    return np.where((real > 0.0) & (real < 1.0), real, np.nan)


#: levels of the grading towards a near-singularity along a segment (0.25^12 ~ 6e-8 of the segment: the singular
#: parts, at worst σ² log σ, then contribute ~1e-22 over the innermost panel)
APPROACH_LEVELS = 12
_APPROACH_GRADES = GRADING ** np.arange(1, APPROACH_LEVELS + 1)


def graded_cuts(roots, panel, at_real):
    """Cuts in s (K, 4 (2 APPROACH_LEVELS + 1)), NaN where there is none, grading the rule along each segment
    towards the branch points ``roots`` (K, 4) closer than ``panel`` (K,; the length in s of the panels the pieces
    get anyway, one kernel scale): at s* and s* ± 1/4, 1/16, ... down to their distance ε from s*, s* their real
    part clipped into [0, 1] (as the θ panels of csrc/cg_ring.c towards t = 0: a piece then stays about its
    length away from them; the cut at s* keeps them off the middle of a piece, where the end-clustered map
    s(u) brings them closest to the points). ``at_real``: also for branch points on [0, 1] itself (ε = 0:
    graded to the last level); without it those are left to the caller's cuts (the end-clustered rule handles a
    square root at a piece's end)."""
    centre = np.clip(roots.real, 0.0, 1.0)
    eps = np.abs(roots - centre)
    near = eps < panel[:, None]
    if not at_real:
        near &= eps > 0.0
    steps = np.maximum(_APPROACH_GRADES[None, None, :], eps[..., None])          # (K, 4, levels)
    cuts = np.concatenate([centre[..., None], centre[..., None] - steps, centre[..., None] + steps], axis=2)
    cuts = np.where(near[..., None] & (cuts > 0.0) & (cuts < 1.0), cuts, np.nan)
    return cuts.reshape(len(roots), -1)


def lucy_cuts(r, h0, x0, a_perp, a_z, c, panel):
    """The cuts (K, 16 APPROACH_LEVELS + 12) of Lucy's rule along the segments (``panel``: as :func:`graded_cuts`).

    Lucy's odd powers of d make the θ-averages non-analytic where the ring's distance from the point p(s),
    δ² = (r - ρ(s))² + h(s)², vanishes (δ⁴ log δ in the kernel, δ² log δ in its gradient): at the roots of the
    quartic of :func:`segment_quartic` with c = 0, next to the real axis at the segment's closest approach to the
    ring when it passes close, on it when it passes through. Where a segment just misses the edge of the
    ring's support, or just misses holding the whole ring, the support's square roots form a close complex pair
    that :func:`support_crossings` does not cut at (a pair 0.008 from the real axis, on a segment 3.6 long, left
    2e-6 in a gradient). Both are graded towards; plus the support crossings themselves."""
    approach = graded_cuts(quartic_roots(segment_quartic(r, h0, x0, a_perp, a_z, 0.0)), panel, True)
    return np.concatenate([support_cuts(r, h0, x0, a_perp, a_z, c, panel), approach], axis=1)


def support_cuts(r, h0, x0, a_perp, a_z, c, panel):
    """The cuts (K, 8 APPROACH_LEVELS + 8) of every kernel's rule along the segments: the support crossings
    (:func:`support_crossings`) and graded cuts towards the close complex pairs of the same quartic, a segment just
    missing the edge of the ring's support or just missing holding the whole ring (``panel``: as
    :func:`graded_cuts`; a Heaviside ray 0.066 from the axis, a pair 0.002 from the real axis: 1.8e-12 of the
    field's scale without them), those clear of the crossings (:func:`clear_of`)."""
    coef = segment_quartic(r, h0, x0, a_perp, a_z, c)
    roots = quartic_roots(coef)
    crossings = real_roots(coef, roots)
    near = graded_cuts(roots, panel, False)
    step = np.abs(near - np.repeat(np.clip(roots.real, 0.0, 1.0), near.shape[1] // roots.shape[1], axis=1))
    return np.concatenate([crossings, clear_of(near, step, crossings)], axis=1)


def axis_cuts(x0, a_perp, panel):
    """Cuts in s (K, 2 (2 APPROACH_LEVELS + 1)), NaN where there is none, and their distances from the point they
    grade towards (for :func:`clear_of`), grading the rule along each segment towards its closest approach to the
    axis (:func:`graded_cuts` at the roots s_c ± i ε of ρ(s)² = 0; ε = 0 through the axis).

    Where the ring holds part of the point's support (an arc: :func:`partial_arc`), the ring moments are not
    analytic at the axis (cos Δ = (r² + ρ² + h² - c²) / 2 r ρ, ρ = √ρ(s)²); near the axis that happens only
    within a thin shell, so a piece of arcs may end a hair's breadth from the axis (a Heaviside branch through
    the axis, 0.007 of its length from it: 7e-11 of the field's scale on one panel). The caller keeps the cuts
    that fall on arcs: elsewhere the moments are analytic there (the whole ring or none of it)."""
    q0 = np.einsum("ki,ki->k", x0, x0)
    q2 = np.einsum("ki,ki->k", a_perp, a_perp)
    with np.errstate(invalid="ignore", divide="ignore"):
        centre = np.where(q2 > 0.0, -np.einsum("ki,ki->k", x0, a_perp) / q2, np.nan)
        eps = np.sqrt(np.maximum(q0 / q2 - centre * centre, 0.0))
    roots = np.stack([centre + 1j * eps, centre - 1j * eps], axis=1)
    cuts = graded_cuts(roots, panel, True)
    return cuts, np.abs(cuts - np.clip(centre, 0.0, 1.0)[:, None])


def clear_of(cuts, step, others):
    """``cuts`` (K, n) NaN where a cut lies closer to one of ``others`` (K, m; the pieces' own ends, NaN for none)
    than GRADING times its ``step`` (K, n; its distance from the point it grades towards): such a cut would leave
    the square root at that end just beyond the next piece's end (an axis cut 3.6e-4 from a support crossing,
    on a Heaviside ray: 1.2e-10 of the field's scale)."""
    gap = np.abs(cuts[:, :, None] - others[:, None, :])
    gap = np.where(np.isnan(gap), np.inf, gap).min(axis=2, initial=np.inf)
    return np.where(gap < GRADING * step, np.nan, cuts)


def edge_jump(kernel):
    """W(c) / W(0): the kernel's jump at its support's edge relative to its peak (Heaviside 1, Lucy 0, a Gaussian
    exp(-c² / 2 w²)). The edges' singular points are graded towards only where it exceeds round-off (a Gaussian cut
    within 8.5 widths): beyond, the cuts would only move the last bits (a silo's balance residual at 9 widths,
    7.2e-15 of its largest term, moved to 1.1e-14)."""
    if isinstance(kernel, Gaussian):
        return math.exp(-0.5 * (float(kernel.radius) / float(kernel.width)) ** 2)
    return 0.0 if isinstance(kernel, Lucy) else 1.0


def partial_arc(r, c, rho, h):
    """Whether the ring (r, h = z - ζ) holds part of, not all of, the support of a source at radius ρ: (r - ρ)² + h²
    < c² < (r + ρ)² + h² (False for NaN)."""
    return ((r - rho) ** 2 + h * h < c * c) & (c * c < (r + rho) ** 2 + h * h)


def segments_in_frame(grid, kernel, starts, vectors, values, z_lo, z_hi):
    """The segments (and their periodic images) that may reach rings of ``grid`` between z_lo and z_hi, in the
    ring frame: in-plane starts x0 (K, 2) and vectors a_perp (K, 2), axial starts ζ₀ and steps a_z (K,), the
    values in the frame (e_1, e_2, e_z) (K, 3, 3), and the lengths (K,). Zero-length segments are dropped."""
    c = float(kernel.radius)
    keep = np.einsum("ki,ki->k", vectors, vectors) > 0.0
    starts, vectors, values = starts[keep], vectors[keep], values[keep]
    if not len(starts):
        return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros(0), np.zeros((0, 3, 3)), np.zeros(0)
    longest = float(np.sqrt(np.einsum("ki,ki->k", vectors, vectors).max()))
    r_top = float(grid.r.max()) + c + longest
    lo, hi = z_lo - c - longest, z_hi + c + longest
    reach_lo, reach_hi = reach_box(grid, r_top, lo, hi)
    starts, (vectors, values) = periodic_sources(grid.box, starts, [vectors, values], reach_lo, reach_hi)
    rel = starts - grid.axis_point
    plane = np.stack([grid.e_1, grid.e_2])
    frame = np.stack([grid.e_1, grid.e_2, grid.e_z])
    tensors = np.einsum("ia,kab,jb->kij", frame, values, frame)
    length = np.sqrt(np.einsum("ki,ki->k", vectors, vectors))
    return rel @ plane.T, vectors @ plane.T, rel @ grid.e_z, vectors @ grid.e_z, tensors, length


def segment_ranges(x0, a_perp, zeta0, a_z):
    """Each segment's in-plane distance range from the axis (its closest point to the axis, its farther end) and
    its axial range: rho_min, rho_max, zeta_lo, zeta_hi (K,) each (the rings and z-points it may reach)."""
    x1 = x0 + a_perp
    with np.errstate(invalid="ignore", divide="ignore"):
        s_close = np.clip(-np.einsum("ki,ki->k", x0, a_perp) / np.einsum("ki,ki->k", a_perp, a_perp), 0.0, 1.0)
    s_close = np.nan_to_num(s_close)
    rho_min = np.hypot(*(x0 + s_close[:, None] * a_perp).T)
    rho_max = np.maximum(np.hypot(*x0.T), np.hypot(*x1.T))
    return rho_min, rho_max, np.minimum(zeta0, zeta0 + a_z), np.maximum(zeta0, zeta0 + a_z)


def ring_average_segments(grid, kernel, starts, vectors, values, z_nodes, z_weights, gradient=False):
    """θ-averages at every node of a θ-averaged CylindricalGrid of sum_k values_k ∫_0^1 W(x - starts_k - s vectors_k) ds
    (values (K, 3, 3) Cartesian), in the local basis: (n_r * n_z, 3, 3). With ``gradient`` (Gaussian and Lucy) the
    θ-averages of their gradients, (n_r * n_z, 3, 3, 3) with [a, b, c] = ∂σ_ab/∂x_c in the local basis (the same
    pieces and s-points; the C core's ring_segment_gradient_sum).

    Along each segment the θ-average is analytic in s between the s where the point enters or leaves the torus
    of the ring's support and where the whole ring enters it (:func:`support_crossings`), with a square-root
    behaviour at those ends: each piece gets 20-point Gauss-Legendre in u on panels no longer than the kernel's
    scale, s = a + (b - a) sin²(π u / 2), which makes it analytic; each s-point the exact ring moments (the
    pieces are found here, their sums are taken by the C core's ring_segment_sum). Lucy's pieces are also
    graded towards the branch points next to the segment (:func:`lucy_cuts`: its closest approach to the ring;
    every kernel's near misses of the support's edges, :func:`support_cuts`, and pieces of arcs towards the axis,
    :func:`axis_cuts`)."""
    c = float(kernel.radius)
    n_r, n_z = len(grid.r), z_nodes.shape[0]
    out = np.zeros((n_r * n_z, 3, 3) + ((3,) if gradient else ()))
    x0, a_perp, zeta0, a_z, tensors, length = segments_in_frame(grid, kernel, starts, vectors, values,
                                                                float(z_nodes.min()), float(z_nodes.max()))
    if not len(x0):
        return out
    tensors = np.ascontiguousarray(tensors.reshape(-1, 9))
    geometry = np.ascontiguousarray(np.column_stack([x0, zeta0, a_perp, a_z]))     # the C core's segment rows
    rho_min, rho_max, zeta_lo, zeta_hi = segment_ranges(x0, a_perp, zeta0, a_z)
    scale = kernel.scale
    # the columns of one ring: its (node, z-point) pairs in the order the node's sum adds them
    n_q = z_nodes.shape[1]
    column_z, column_w = z_nodes.ravel(), np.broadcast_to(z_weights, z_nodes.shape).ravel()
    column_node = np.repeat(np.arange(n_z), n_q)
    for k, r in enumerate(grid.r):
        near = np.flatnonzero((rho_min < r + c) & (rho_max > r - c))
        if not near.size:
            continue
        for cols, seg in ring_column_pairs(column_z, c, near, zeta_lo, zeta_hi):
            h0 = column_z[cols] - zeta0[seg]
            if isinstance(kernel, Lucy):
                cuts = lucy_cuts(r, h0, x0[seg], a_perp[seg], a_z[seg], c, scale / length[seg])
            elif edge_jump(kernel) > np.finfo(float).eps:
                cuts = support_cuts(r, h0, x0[seg], a_perp[seg], a_z[seg], c, scale / length[seg])
            else:
                cuts = support_crossings(r, h0, x0[seg], a_perp[seg], a_z[seg], c)
            near_axis, step = axis_cuts(x0[seg], a_perp[seg], scale / length[seg])
            near_axis = clear_of(near_axis, step, cuts[:, :4])           # the crossings (support_cuts' first)
            rho_cut = np.hypot(*(x0[seg, None, :] + near_axis[..., None] * a_perp[seg, None, :]).transpose(2, 0, 1))
            near_axis = np.where(partial_arc(r, c, rho_cut, h0[:, None] - near_axis * a_z[seg, None]), near_axis,
                                 np.nan)
            edges = np.sort(np.concatenate([np.zeros((seg.size, 1)), np.nan_to_num(cuts, nan=1.0),
                                            np.nan_to_num(near_axis, nan=1.0), np.ones((seg.size, 1))], axis=1),
                            axis=1)
            lo, hi = edges[:, :-1], edges[:, 1:]                   # (pairs, pieces)
            mid = 0.5 * (lo + hi)
            px = x0[seg, None, :] + mid[..., None] * a_perp[seg, None, :]
            rho_mid = np.hypot(px[..., 0], px[..., 1])
            h_mid = h0[:, None] - mid * a_z[seg, None]
            inside = (hi > lo) & ((r - rho_mid) ** 2 + h_mid ** 2 < c * c)
            pair, piece = np.nonzero(inside)
            if not pair.size:
                continue
            a, b = lo[pair, piece], hi[pair, piece]
            # panels in u no longer than the kernel's scale along the segment: the integrand varies on it
            panels = np.clip(np.ceil((b - a) * length[seg[pair]] / scale), 1, MAX_PANELS).astype(int)
            used, counts = np.unique(cols[pair], return_counts=True)
            first = np.concatenate([[0], np.cumsum(counts)])
            rings = np.column_stack([np.full(used.size, r), column_z[used], column_w[used]])
            sums = _engine.ring_segment_columns(kernel, rings, first, seg[pair], a, b, panels, geometry, tensors,
                                                gradient=gradient)
            # in column order: a node's z-points add in turn (ufunc.at is unbuffered and in order)
            np.add.at(out, k * n_z + column_node[used], sums.reshape((used.size,) + out.shape[1:]))
    return out


#: (column, segment) pairs whose pieces are found at once (memory: ~200 cuts each for Lucy)
PAIRS_PER_BLOCK = 16384
#: (column, segment) candidates tested at once
CANDIDATES_PER_MASK = 1 << 22


def ring_column_pairs(column_z, c, near, zeta_lo, zeta_hi):
    """The (column, segment) pairs of one ring, in blocks of whole columns of about PAIRS_PER_BLOCK pairs: arrays
    (column index, segment index) in column order, segments in increasing order within a column, of the segments
    ``near`` (the ring's candidates by radius) whose axial range reaches within c of the column's z."""
    step = max(1, CANDIDATES_PER_MASK // near.size)
    for c0 in range(0, column_z.size, step):
        zq = column_z[c0:c0 + step, None]
        col, which = np.nonzero((zeta_lo[near] < zq + c) & (zeta_hi[near] > zq - c))
        if not col.size:
            continue
        col = col + c0
        ends = np.searchsorted(col, np.unique(col), side="right")       # each column's end in the pairs
        start = 0
        while start < col.size:
            stop = ends[np.searchsorted(ends, start + PAIRS_PER_BLOCK, side="right") - 1]
            stop = stop if stop > start else ends[np.searchsorted(ends, start, side="right")]
            yield col[start:stop], near[which[start:stop]]
            start = stop


def axial_line_average(grid, kernel, positions, columns, gradient=False, n_threads=0):
    """z-averages at every node of a θ-RESOLVED z-averaged CylindricalGrid of sum_i values_i W(x - q_i), exact.

    The average of W(x(r, θ, z) - q) over z in [lo, hi] is the kernel's line integral
    ∫₀¹ W(x(r, θ, lo) - q + s (hi - lo) e_z) ds: the segment from q to q - (hi - lo) e_z seen from x(r, θ, lo),
    which the core integrates exactly (its contact-stress line integrals). Periodic images along the box's
    periodic axes are explicit sources. positions: (S, 3) Cartesian; columns: [(values (S,) + (3,) * rank, rank)].
    Returns [(n_nodes,) + (3,) * rank] in the local basis (e_r, e_θ, e_z), nodes in C order (n_r, n_θ, 1). With
    ``gradient`` the z-average of sum_i values_i ∇W(x - q_i) (the line integral's gradient with respect to the
    node), the derivative's index last: rank + 1.
    """
    c = float(kernel.radius)
    lo, hi = grid.z_extent
    R, T = np.meshgrid(grid.r, grid.theta, indexing="ij")
    R, T = R.ravel(), T.ravel()
    extra = 1 if gradient else 0
    out = [np.zeros((R.size,) + (3,) * (rank + extra)) for _, rank in columns]
    if not len(positions):
        return out
    r_top = float(grid.r.max()) + c
    reach_lo, reach_hi = reach_box(grid, r_top, lo - c, hi + c)
    pos, vals = periodic_sources(grid.box, positions, [v for v, _ in columns], reach_lo, reach_hi)
    if not len(pos):
        return out
    nodes = np.ascontiguousarray(grid.cartesian(R, T, np.full(R.shape, lo)))
    vectors = np.ascontiguousarray(np.broadcast_to(-(hi - lo) * grid.e_z, pos.shape))
    flat = np.ascontiguousarray(np.concatenate([v.reshape(len(pos), -1) for v in vals], axis=1))
    target = _engine.point_target(nodes)         # the nodes in unbounded space (images are explicit sources)
    sums = _engine.scatter_segments(target, _engine.ring_kernel(kernel), np.ascontiguousarray(pos), vectors, flat,
                                    gradient=gradient, n_threads=n_threads)
    sums = np.asarray(sums).reshape(R.size, -1)          # (nodes, width[, 3]) flat: each value's 3 derivatives
    basis = grid.basis(T)
    k = 0
    for o, (_, rank) in zip(out, columns):
        rank = rank + extra
        size = 3 ** rank
        v = sums[:, k:k + size].reshape((R.size,) + (3,) * rank)
        k += size
        if rank == 0:
            o[...] = v
        elif rank == 1:
            o[...] = np.einsum("nia,na->ni", basis, v)
        else:
            o[...] = np.einsum("nia,nab,njb->nij", basis, v, basis)
    return out
