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
"""
import math

import numpy as np

from . import _engine
from .kernels import Gaussian

def ring_moments(kernel, r, h, rho):
    """(M₀, M₁, M₂) of pairs (ring radius r, axial offset h = z - ζ, source radius ρ), arrays of one shape
    (broadcast), shape (3,) + that shape; 0 for pairs whose closest approach is outside the support."""
    r, h, rho = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (r, h, rho)))
    out = np.zeros((3,) + r.shape)
    flat_r, flat_h, flat_rho, flat_out = r.ravel(), h.ravel(), rho.ravel(), out.reshape(3, -1)
    radii, ring = np.unique(flat_r, return_inverse=True)
    for k, radius in enumerate(radii):
        pick = np.flatnonzero(ring == k) if len(radii) > 1 else slice(None)
        flat_out[:, pick] = _engine.ring_moments(kernel, float(radius), np.ascontiguousarray(flat_h[pick]),
                                                 np.ascontiguousarray(flat_rho[pick]))
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


def ring_average(grid, kernel, positions, columns, z_nodes, z_weights):
    """θ-averages at every node of a θ-averaged CylindricalGrid of sum_i values_i W(x - q_i).

    positions: (S, 3) Cartesian sources; columns: [(values (S,) + (3,) * rank Cartesian, rank)];
    z_nodes (n_z, m) and z_weights (n_z, m): the axial points of each node row and their weights (one point,
    weight 1, when z is resolved). Returns [(n_r * n_z,) + (3,) * rank] in the local basis, nodes in C order.
    """
    c = float(kernel.radius)
    n_r, n_z = len(grid.r), z_nodes.shape[0]
    out = [np.zeros((n_r * n_z,) + (3,) * rank) for _, rank in columns]
    if not len(positions):
        return out
    # the region the rings' supports cover, as a Cartesian box (for the periodic images)
    r_top = float(grid.r.max()) + c
    z_lo, z_hi = float(z_nodes.min()) - c, float(z_nodes.max()) + c
    disc = r_top * np.sqrt(np.clip(1.0 - grid.e_z ** 2, 0.0, 1.0))      # a disc's extent along each box axis
    reach_lo = grid.axis_point + np.minimum(z_lo * grid.e_z, z_hi * grid.e_z) - disc
    reach_hi = grid.axis_point + np.maximum(z_lo * grid.e_z, z_hi * grid.e_z) + disc
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
    node_z = np.arange(n_z)
    for k, r in enumerate(grid.r):
        near = np.abs(rho - r) < c
        if not near.any():
            continue
        src = np.flatnonzero(near)
        h = z_nodes[:, :, None] - zeta[src][None, None, :]             # (n_z, m, S')
        inside = (r - rho[src]) ** 2 + h * h < c * c
        zi, qi, si = np.nonzero(inside)
        if not zi.size:
            continue
        s = src[si]
        M = ring_moments(kernel, r, h[zi, qi, si], rho[s]) * z_weights[zi, qi]
        nodes = k * n_z + node_z[zi]
        for (_, rank), v, acc in zip(columns, own, out):
            contrib = rotate_averaged(v[s], rank, M).reshape(len(s), -1)
            flat = acc.reshape(acc.shape[0], -1)
            for col in range(contrib.shape[1]):
                flat[:, col] += np.bincount(nodes, weights=contrib[:, col], minlength=flat.shape[0])
    return out


#: at most this many panels per piece (a piece longer than MAX_PANELS kernel scales gets longer panels)
MAX_PANELS = 256


def support_crossings(r, h0, x0, a_perp, a_z, c):
    """The s in (0, 1) where p(s) = start + s a crosses (r ∓ ρ(s))² + h(s)² = c² (the edge of the torus around
    the ring, and where the whole ring enters the support): the real roots of the quartic
    (Q + r² + h² - c²)² - 4 r² Q, Q = ρ(s)², h = h0 - s a_z; (K, 4), NaN where there is none. Near-double roots
    (grazing) come as a close complex pair: their real part is kept, a harmless extra breakpoint."""
    q0 = np.einsum("ki,ki->k", x0, x0)
    q1 = 2.0 * np.einsum("ki,ki->k", x0, a_perp)
    q2 = np.einsum("ki,ki->k", a_perp, a_perp)
    e0 = q0 + r * r + h0 * h0 - c * c
    e1 = q1 - 2.0 * h0 * a_z
    e2 = q2 + a_z * a_z
    four = 4.0 * r * r
    coef = np.stack([e2 * e2, 2.0 * e1 * e2, e1 * e1 + 2.0 * e0 * e2 - four * q2, 2.0 * e0 * e1 - four * q1,
                     e0 * e0 - four * q0], axis=1)
    comp = np.zeros((len(e0), 4, 4))
    comp[:, 0, :] = -coef[:, 1:] / coef[:, :1]
    comp[:, 1, 0] = comp[:, 2, 1] = comp[:, 3, 2] = 1.0
    roots = np.linalg.eigvals(comp)
    real = np.where(np.abs(roots.imag) < 1e-4, roots.real, np.nan)
    for _ in range(3):                                               # polish: Newton on the quartic
        p = ((((coef[:, :1] * real + coef[:, 1:2]) * real + coef[:, 2:3]) * real + coef[:, 3:4]) * real
             + coef[:, 4:5])
        dp = (((4.0 * coef[:, :1] * real + 3.0 * coef[:, 1:2]) * real + 2.0 * coef[:, 2:3]) * real + coef[:, 3:4])
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(dp != 0.0, p / dp, 0.0)
        real = np.where(np.abs(step) < 1e-3, real - step, real)
    return np.where((real > 0.0) & (real < 1.0), real, np.nan)


def ring_average_segments(grid, kernel, starts, vectors, values, z_nodes, z_weights):
    """θ-averages at every node of a θ-averaged CylindricalGrid of sum_k values_k ∫_0^1 W(x - starts_k - s vectors_k) ds
    (values (K, 3, 3) Cartesian), in the local basis: (n_r * n_z, 3, 3).

    Along each segment the θ-average is analytic in s between the s where the point enters or leaves the torus
    of the ring's support and where the whole ring enters it (:func:`support_crossings`), with a square-root
    behaviour at those ends: each piece gets 20-point Gauss-Legendre in u on panels no longer than the kernel's
    scale, s = a + (b - a) sin²(π u / 2), which makes it analytic; each s-point the exact ring moments (the
    pieces are found here, their sums are taken by the C core's ring_segment_sum)."""
    c = float(kernel.radius)
    n_r, n_z = len(grid.r), z_nodes.shape[0]
    out = np.zeros((n_r * n_z, 3, 3))
    keep = np.einsum("ki,ki->k", vectors, vectors) > 0.0
    starts, vectors, values = starts[keep], vectors[keep], values[keep]
    if not len(starts):
        return out
    longest = float(np.sqrt(np.einsum("ki,ki->k", vectors, vectors).max()))
    r_top = float(grid.r.max()) + c + longest
    z_lo, z_hi = float(z_nodes.min()) - c - longest, float(z_nodes.max()) + c + longest
    disc = r_top * np.sqrt(np.clip(1.0 - grid.e_z ** 2, 0.0, 1.0))
    reach_lo = grid.axis_point + np.minimum(z_lo * grid.e_z, z_hi * grid.e_z) - disc
    reach_hi = grid.axis_point + np.maximum(z_lo * grid.e_z, z_hi * grid.e_z) + disc
    starts, (vectors, values) = periodic_sources(grid.box, starts, [vectors, values], reach_lo, reach_hi)
    rel = starts - grid.axis_point
    plane = np.stack([grid.e_1, grid.e_2])
    frame = np.stack([grid.e_1, grid.e_2, grid.e_z])
    tensors = np.ascontiguousarray(np.einsum("ia,kab,jb->kij", frame, values, frame).reshape(-1, 9))
    x0, a_perp = rel @ plane.T, vectors @ plane.T                   # in-plane (e_1, e_2) components
    zeta0, a_z = rel @ grid.e_z, vectors @ grid.e_z
    geometry = np.ascontiguousarray(np.column_stack([x0, zeta0, a_perp, a_z]))     # the C core's segment rows
    x1 = x0 + a_perp
    # the in-plane distance range of each segment (closest point to the axis) and its axial range
    with np.errstate(invalid="ignore", divide="ignore"):
        s_close = np.clip(-np.einsum("ki,ki->k", x0, a_perp) / np.einsum("ki,ki->k", a_perp, a_perp), 0.0, 1.0)
    s_close = np.nan_to_num(s_close)
    rho_min = np.hypot(*(x0 + s_close[:, None] * a_perp).T)
    rho_max = np.maximum(np.hypot(*x0.T), np.hypot(*x1.T))
    zeta_lo, zeta_hi = np.minimum(zeta0, zeta0 + a_z), np.maximum(zeta0, zeta0 + a_z)
    length = np.sqrt(np.einsum("ki,ki->k", vectors, vectors))
    scale = float(kernel.width) if isinstance(kernel, Gaussian) else c / 3.0
    for k, r in enumerate(grid.r):
        for j in range(n_z):
            for zq, wq in zip(z_nodes[j], z_weights[j]):
                cand = np.flatnonzero((rho_min < r + c) & (rho_max > r - c) & (zeta_lo < zq + c) & (zeta_hi > zq - c))
                if not cand.size:
                    continue
                h0 = zq - zeta0[cand]
                roots = support_crossings(r, h0, x0[cand], a_perp[cand], a_z[cand], c)
                edges = np.sort(np.concatenate([np.zeros((cand.size, 1)), np.nan_to_num(roots, nan=1.0),
                                                np.ones((cand.size, 1))], axis=1), axis=1)
                lo, hi = edges[:, :-1], edges[:, 1:]                   # (K, 5) pieces
                mid = 0.5 * (lo + hi)
                px = x0[cand, None, :] + mid[..., None] * a_perp[cand, None, :]
                rho_mid = np.hypot(px[..., 0], px[..., 1])
                h_mid = h0[:, None] - mid * a_z[cand, None]
                inside = (hi > lo) & ((r - rho_mid) ** 2 + h_mid ** 2 < c * c)
                seg, piece = np.nonzero(inside)
                if not seg.size:
                    continue
                a, b = lo[seg, piece], hi[seg, piece]
                # panels in u no longer than the kernel's scale along the segment: the integrand varies on it
                panels = np.clip(np.ceil((b - a) * length[cand[seg]] / scale), 1, MAX_PANELS).astype(int)
                out[k * n_z + j] += _engine.ring_segment_sum(kernel, float(r), float(zq), cand[seg], a, b, panels,
                                                             geometry, tensors, float(wq))
    return out
