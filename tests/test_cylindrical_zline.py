"""θ-resolved z-averaged CylindricalGrids: the point sums' z-averages are exact line integrals of the kernel
(cgbound.cylindrical_ring.axial_line_average), checked against adaptive quadrature over z with breakpoints
where the source's support begins and ends and at its closest approach."""
import math

import numpy as np
import pytest
from scipy.integrate import quad

import cgbound as cg
from cgbound.cylindrical_ring import axial_line_average

from test_cylindrical_ring import float_kernel

KERNELS = [cg.Gaussian(0.4), cg.Gaussian(0.4, cutoff=1.2), cg.Gaussian(0.4, normalize="truncated"), cg.Lucy(1.2),
           cg.Heaviside(1.0)]
IDS = ["gauss5w", "gauss3w", "gauss5w-truncated", "lucy", "heaviside"]


def basis(theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def oracle_line_average(kernel, positions, masses, velocities, r, theta, lo, hi, period=None):
    """(1/(hi - lo)) ∫_lo^hi Σ_i (m_i, m_i v_i in (e_r, e_θ, e_z)) W(|x(r, θ, z) - q_i|) dz by QUADPACK, per source,
    split where the support begins and ends and at the closest approach (images along z when ``period``)."""
    W = float_kernel(kernel)
    c = float(kernel.radius)
    x = np.array([r * math.cos(theta), r * math.sin(theta), 0.0])
    shifts = [0.0] if period is None else [k * period for k in range(-3, 4)]
    mass, mom = 0.0, np.zeros(3)
    for q, m, v in zip(positions, masses, velocities):
        for shift in shifts:
            zq = q[2] + shift
            perp2 = (x[0] - q[0]) ** 2 + (x[1] - q[1]) ** 2

            def f(z):
                return W(math.sqrt(perp2 + (z - zq) ** 2))
            pts = [lo, hi, min(max(zq, lo), hi)]
            if perp2 < c * c:
                half = math.sqrt(c * c - perp2)
                pts += [min(max(zq - half, lo), hi), min(max(zq + half, lo), hi)]
            pts = sorted(set(pts))
            total = sum(quad(f, a, b, epsabs=1e-15, epsrel=1e-13, limit=200)[0] for a, b in zip(pts[:-1], pts[1:]) if b > a)
            total /= hi - lo
            mass += m * total
            mom += m * total * (basis(theta) @ v)
    return mass, mom


def snapshot(periodic=False, seed=4, n=9):
    rng = np.random.default_rng(seed)
    pos = np.c_[rng.uniform(-1.5, 1.5, (n, 2)), rng.uniform(-1.9, 1.9, n)]
    pos[0] = [0.0, 0.0, 0.1]                  # on the axis
    pos[1] = [1.0 * math.cos(0.3), 1.0 * math.sin(0.3), 1.95]    # on a node's z-line, near the extent's end
    box = cg.Box([-3, -3, -2], [3, 3, 2], periodic=[False, False, periodic])
    return cg.Snapshot(pos, rng.normal(size=(n, 3)), rng.uniform(0.5, 2, n), box=box)


@pytest.mark.parametrize("periodic", [False, True], ids=["walls", "periodic"])
@pytest.mark.parametrize("kernel", KERNELS, ids=IDS)
def test_point_sums_z_average_equals_adaptive_quadrature(kernel, periodic):
    snap = snapshot(periodic)
    grid = cg.CylindricalGrid(snap.box, (0, 0, 0), "z", r=(0.0, 2.0, 4), theta=6)
    masses, velocities = snap.masses, snap.velocities
    sums = axial_line_average(grid, kernel, snap.positions,
                              [(masses, 0), (masses[:, None] * velocities, 1)])
    lo, hi = grid.z_extent
    n = 0
    for r in grid.r:
        for t in grid.theta:
            rho, p = oracle_line_average(kernel, snap.positions, masses, velocities, r, t, lo, hi,
                                         period=4.0 if periodic else None)
            assert abs(sums[0][n] - rho) <= 1e-12 * max(1.0, abs(rho))
            assert np.max(np.abs(sums[1][n] - p)) <= 1e-12 * max(1.0, np.max(np.abs(p)))
            n += 1


@pytest.mark.parametrize("kernel", KERNELS, ids=IDS)
def test_density_field_on_theta_resolved_z_averaged_grid(kernel):
    snap = snapshot(True)
    grid = cg.CylindricalGrid(snap.box, (0, 0, 0), "z", r=(0.2, 1.8, 3), theta=4)
    res = cg.coarse_grain(snap, grid, kernel, ["density"])
    lo, hi = grid.z_extent
    rho = np.asarray(res["density"]).reshape(-1)
    n = 0
    for r in grid.r:
        for t in grid.theta:
            want, _ = oracle_line_average(kernel, snap.positions, snap.masses, snap.velocities, r, t, lo, hi, 4.0)
            assert abs(rho[n] - want) <= 1e-12 * max(1.0, want)
            n += 1


def test_zero_sources_and_outside():
    snap = snapshot()
    grid = cg.CylindricalGrid(snap.box, (0, 0, 0), "z", r=(0.0, 1.0, 2), theta=3)
    out = axial_line_average(grid, cg.Lucy(1.0), np.zeros((0, 3)), [(np.zeros(0), 0)])
    assert out[0].shape == (6,) and not out[0].any()
    far = axial_line_average(grid, cg.Lucy(0.5), np.array([[0.0, 0.0, 10.0]]), [(np.ones(1), 0)])
    assert not far[0].any()


def test_thread_counts_agree_bit_for_bit():
    snap = snapshot(True, n=40)
    grid = cg.CylindricalGrid(snap.box, (0, 0, 0), "z", r=(0.0, 2.0, 5), theta=7)
    columns = [(snap.masses, 0), (snap.masses[:, None] * snap.velocities, 1)]
    one = axial_line_average(grid, cg.Lucy(1.2), snap.positions, columns, n_threads=1)
    two = axial_line_average(grid, cg.Lucy(1.2), snap.positions, columns, n_threads=2)
    for a, b in zip(one, two):
        assert np.array_equal(a, b)
