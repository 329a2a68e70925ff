"""θ-resolved z-averaged CylindricalGrids: the z-averages of the contact and boundary stresses' line integrals and
of the extended stress's rays (cgbound.cylindrical_axial) against nested adaptive quadrature (scipy's quad over
the node's z and along the segment, split where the kernel's support begins and ends and at closest approaches);
never values from the code under test."""
import math

import numpy as np
import pytest
import warnings
from scipy.integrate import IntegrationWarning, quad

import cgbound as cg

from test_cylindrical_ring import float_kernel

KERNELS = [cg.Gaussian(0.4), cg.Gaussian(0.4, cutoff=1.2), cg.Lucy(1.2), cg.Heaviside(1.0)]
IDS = ["gauss5w", "gauss3w", "lucy", "heaviside"]
TOL = 1e-12


def quadratic_points(A, B, C, lo, hi):
    """Roots of A t² + 2 B t + C = 0 and the vertex, inside (lo, hi)."""
    pts = []
    if A > 0:
        pts.append(-B / A)
        disc = B * B - A * C
        if disc >= 0:
            pts += [(-B - math.sqrt(disc)) / A, (-B + math.sqrt(disc)) / A]
    return [p for p in pts if lo < p < hi]


def oracle_column_average(kernel, x_lo, H, a, b, S=1.0, e=(0.0, 0.0, 1.0)):
    """(1/H) ∫₀^H dτ ∫₀^S ds W(|x_lo + τ e - a - s b|) (e the unit axis) by nested QUADPACK: s split where the
    point's support sphere meets the segment's line and at the closest approach; τ where that sphere passes the
    segment's ends, becomes tangent to its line, and at the closest approaches."""
    W = float_kernel(kernel)
    c = float(kernel.radius)
    x_lo, a, b = (np.asarray(v, dtype=float) for v in (x_lo, a, b))
    e = np.asarray(e, dtype=float)
    bb = b @ b

    def inner(tau):
        q = x_lo + tau * e - a
        if bb == 0.0:
            return S * W(math.sqrt(q @ q))
        pts = [0.0, S] + quadratic_points(bb, -(q @ b), q @ q - c * c, 0.0, S)
        pts = sorted(set(pts))
        return sum(quad(lambda s: W(math.sqrt(max((q - s * b) @ (q - s * b), 0.0))), u, v, epsabs=1e-16,
                        epsrel=1e-14, limit=200)[0] for u, v in zip(pts[:-1], pts[1:]))

    q0 = x_lo - a
    pts = [0.0, H]
    for end in (np.zeros(3), S * b if np.isfinite(S) else None):
        if end is not None:
            p = q0 - end
            pts += quadratic_points(1.0, p @ e, p @ p - c * c, 0.0, H)
    if bb > 0:
        bh = b / math.sqrt(bb)
        q_perp, e_perp = q0 - (q0 @ bh) * bh, e - (e @ bh) * bh
        pts += quadratic_points(e_perp @ e_perp, q_perp @ e_perp, q_perp @ q_perp - c * c, 0.0, H)
    pts = sorted(set(pts))
    with warnings.catch_warnings():          # (round-off at these tolerances is expected)
        warnings.simplefilter("ignore", IntegrationWarning)
        return sum(quad(inner, u, v, epsabs=1e-16, epsrel=1e-14, limit=200)[0]
                   for u, v in zip(pts[:-1], pts[1:])) / H


def basis(theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def oracle_sums(kernel, grid, starts, vectors, values, S=1.0, period=None):
    """Σ_k values_k (1/H) ∫ dz ∫₀^S ds W(|x(r, θ, z) - a_k - s b_k|) per node, in (e_r, e_θ, e_z), by
    :func:`oracle_column_average` (images along z when ``period``): (n_nodes, 3, 3). S = ∞ (rays): cut where the
    ray is farther from the axis than every column's support (the rays have an in-plane component)."""
    lo, hi = grid.z_extent
    c = float(kernel.radius)
    e = grid.e_z
    shifts = [0.0] if period is None else [k * period for k in range(-2, 3)]
    out = []

    def across(v):                       # the component across the axis
        return np.linalg.norm(v - (v @ e) * e)
    for r in grid.r:
        for t in grid.theta:
            x = grid.cartesian(r, t, lo)
            total = np.zeros((3, 3))
            for a, b, v in zip(starts, vectors, values):
                for shift in shifts:
                    a_k = a + shift * e
                    S_k = S if np.isfinite(S) else (across(a_k - grid.axis_point) + grid.r.max() + c) / across(b)
                    if across(a_k - x) - across(b) * S_k >= c:
                        continue
                    z_ends = (a_k - x) @ e, (a_k + S_k * b - x) @ e
                    if min(z_ends) >= hi - lo + c or max(z_ends) <= -c:
                        continue
                    total += oracle_column_average(kernel, x, hi - lo, a_k, b, S_k, e) * v
            B = grid.basis(t)
            out.append(B @ total @ B.T)
    return np.array(out)


def contact_snapshot(periodic):
    """Particles with bulk contacts that cross the grid's z ends (or the periodic boundary), lie in a plane
    through a node column (y = 0 holds the nodes at θ = π), are axial and nearly axial, and wall contacts."""
    pos = np.array([[-0.9, 0.0, 0.1],      # 0 - 1: in the plane y = 0 (holds the column at r = 0.9, θ = π)
                    [-0.3, 0.0, 0.6],
                    [0.4, 0.5, 1.7],       # 2 - 3: crosses the top z = 2 (walls: ends outside; periodic: wraps)
                    [0.6, 0.2, -1.8],
                    [-0.2, -0.8, -0.5],    # 4 - 5: axial
                    [-0.2, -0.8, 0.3],
                    [0.45, -0.77, -1.2],   # 6 - 7: nearly axial, close to the column at r = 0.9, θ = 5π/3
                    [0.45 + 1e-7, -0.77, -0.4],
                    [1.2, 0.9, -1.9]])     # 8: wall contact through the bottom
    if not periodic:
        pos[3, 2] = 2.15                   # outside the z extent [-2, 2]: the segment 2 - 3 leaves it
    n = len(pos)
    rng = np.random.default_rng(7)
    force = rng.normal(size=(6, 3))
    i, j = [0, 2, 4, 6, 8, 1], [1, 3, 5, 7, -1, -1]
    point = np.array([0.5 * (pos[0] + pos[1]), 0.5 * (pos[2] + pos[3]), pos[4], pos[6],
                      [1.0, 0.7, -2.0], [-0.4, 0.3, 0.9]])
    if periodic:
        point[1] = [0.5, 0.35, 1.95]
    box = cg.Box([-3, -3, -2], [3, 3, 2], periodic=[False, False, periodic])
    return cg.Snapshot(pos, np.zeros((n, 3)), np.ones(n), box=box, contacts=cg.Contacts(i, j, force, point))


def segments(snap, boundary):
    """The stress's segments from the snapshot's own split: (starts, vectors, values -f a)."""
    bulk, walls = snap.split_contacts()
    part = walls if boundary else bulk
    starts = snap.positions[part["i"]]
    return starts, -part["branch"], -np.einsum("ka,kb->kab", part["force"], part["branch"])


@pytest.mark.parametrize("periodic", [False, True], ids=["walls", "periodic"])
@pytest.mark.parametrize("kernel", KERNELS, ids=IDS)
def test_contact_and_boundary_stress_equal_nested_quadrature(kernel, periodic):
    from cgbound.cylindrical_fields import ring_primaries
    snap = contact_snapshot(periodic)
    grid = cg.CylindricalGrid(snap.box, (0, 0, 0), "z", r=(0.3, 1.5, 2), theta=3)
    _, sums = ring_primaries(snap, grid, kernel, ["contact_stress", "boundary_stress", "extended_stress"])
    period = 4.0 if periodic else None
    for name, boundary, S in (("sb", False, 1.0), ("sw", True, 1.0), ("sx", True, np.inf)):
        starts, vectors, values = segments(snap, boundary)
        want = oracle_sums(kernel, grid, starts, vectors, values, S, period)
        got = np.asarray(sums[name]).reshape(want.shape)
        scale = np.abs(want).max()
        assert scale > 0
        assert np.abs(got - want).max() <= TOL * scale, (name, np.abs(got - want).max() / scale)


@pytest.mark.parametrize("kernel", KERNELS, ids=IDS)
def test_degenerate_segments_equal_nested_quadrature(kernel):
    """Zero-length, exactly and nearly axial segments, segments in a plane through a node column (crossing the
    column's line) and segments ending just outside the z extent, one at a time."""
    from cgbound.cylindrical_axial import axial_segment_average
    box = cg.Box([-3, -3, -2], [3, 3, 2])
    grid = cg.CylindricalGrid(box, (0, 0, 0), "z", r=(0.3, 1.5, 2), theta=3)     # r 0.6, 1.2; θ π/3, π, 5π/3
    x = grid.cartesian(0.6, math.pi, 0.0)
    cases = {"zero-length": ([-0.5, 0.1, 0.4], [0.0, 0.0, 0.0]),
             "axial": ([-0.7, 0.2, -1.5], [0.0, 0.0, 0.8]),
             "nearly-axial": ([-0.7, 0.2, -1.5], [1e-9, -2e-9, 0.8]),
             "in-plane": ([x[0] - 0.4, 0.0, 0.3], [0.9, 0.0, -0.5]),
             "through-node-end": ([x[0] - 0.3, 0.0, -2.3], [0.6, 0.0, 0.6]),
             "past-the-top": ([-0.2, 0.6, 1.6], [0.3, -0.2, 0.7])}
    value = np.arange(9.0).reshape(3, 3) - 3.0
    for name, (a, b) in cases.items():
        a, b = np.array([a]), np.array([b])
        got = axial_segment_average(grid, kernel, a, b, value[None])
        want = oracle_sums(kernel, grid, a, b, value[None])
        scale = np.abs(want).max()
        assert scale > 0
        assert np.abs(got - want).max() <= TOL * scale, (name, np.abs(got - want).max() / scale)


def test_ray_along_the_periodic_axis_is_refused():
    from cgbound.cylindrical_axial import axial_segment_average
    box = cg.Box([-3, -3, -2], [3, 3, 2], periodic=[False, False, True])
    grid = cg.CylindricalGrid(box, (0, 0, 0), "z", r=(0.3, 1.5, 2), theta=3)
    with pytest.raises(ValueError, match="periodic"):
        axial_segment_average(grid, cg.Lucy(1.0), np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]), np.ones((1, 3, 3)),
                              ray=True)
    out = axial_segment_average(grid, cg.Lucy(1.0), np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]),
                                np.ones((1, 3, 3)))            # a segment is fine
    assert np.abs(out).max() > 0


@pytest.mark.parametrize("kernel", [cg.Gaussian(0.4, cutoff=1.2), cg.Lucy(1.2)], ids=["gauss3w", "lucy"])
def test_axis_along_x_with_a_periodic_axis(kernel):
    """The axis along x (periodic), walls across it: contact and boundary stress and rays against the oracle."""
    snap = contact_snapshot(True)
    perm = [2, 0, 1]                                   # (x, y, z) -> the old (z, x, y)
    pos = snap.positions[:, perm]
    c = snap.contacts
    box = cg.Box([-2, -3, -3], [2, 3, 3], periodic=[True, False, False])
    snap = cg.Snapshot(pos, np.zeros_like(pos), snap.masses, box=box,
                       contacts=cg.Contacts(c.i, c.j, c.force[:, perm], c.point[:, perm]))
    from cgbound.cylindrical_fields import ring_primaries
    grid = cg.CylindricalGrid(snap.box, (0, 0.1, -0.2), "x", r=(0.3, 1.5, 2), theta=3)
    _, sums = ring_primaries(snap, grid, kernel, ["contact_stress", "boundary_stress", "extended_stress"])
    for name, boundary, S in (("sb", False, 1.0), ("sw", True, 1.0), ("sx", True, np.inf)):
        starts, vectors, values = segments(snap, boundary)
        want = oracle_sums(kernel, grid, starts, vectors, values, S, 4.0)
        got = np.asarray(sums[name]).reshape(want.shape)
        scale = np.abs(want).max()
        assert scale > 0
        assert np.abs(got - want).max() <= TOL * scale, (name, np.abs(got - want).max() / scale)
