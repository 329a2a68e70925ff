"""Gradient fields on a CylindricalGrid: the ring average of the rotated Cartesian gradient is the cylindrical
gradient of the θ-averaged field (∂/∂r, ∂/∂z of the averaged components; hoop terms in the θ column)."""
import numpy as np
import pytest

import cgbound as cg
from helpers import random_snapshot
from oracle import oracle_kernel_of

GRADIENTS = ("density_gradient", "momentum_gradient")
KERNEL = cg.Gaussian(0.3, cutoff=3.0)          # cutoff 10 w: the θ rule is exact to round-off


def snapshot():
    return random_snapshot(3, n=40, n_bulk=30, lengths=[6.0, 6.0, 5.0], periodic=(False, False, False))


def axis_point(snap):
    return 0.5 * (snap.box.lower + snap.box.upper)


def test_ring_average_of_rotated_cartesian_gradients():
    """Brute force: the Cartesian gradients at 720 ring points rotated on every index and averaged."""
    snap = snapshot()
    a = axis_point(snap)
    grid = cg.CylindricalGrid(snap.box, a, "z", r=(0.0, 2.0, 4), z=(-0.5, 0.5, 2))
    out = cg.coarse_grain(snap, grid, KERNEL, fields=GRADIENTS)
    n = 720
    theta = (np.arange(n) + 0.5) * 2 * np.pi / n
    B = grid.basis(theta)
    for i, r in enumerate(grid.r):
        for k, z in enumerate(grid.z):
            pts = grid.cartesian(r, theta, np.full(n, z))
            cart = cg.coarse_grain(snap, cg.Points(pts), KERNEL, fields=GRADIENTS)
            want_rho = np.einsum("qia,qa->qi", B, cart.density_gradient).mean(axis=0)
            want_p = np.einsum("qia,qab,qjb->qij", B, cart.momentum_gradient, B).mean(axis=0)
            for got, want in ((out.density_gradient[i, 0, k], want_rho), (out.momentum_gradient[i, 0, k], want_p)):
                np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())


def fourth_order(f, h):
    """Central difference of values at -2h, -h, 0, h, 2h (leading axis) at 0."""
    return (f[0] - 8 * f[1] + 8 * f[3] - f[4]) / (12 * h)


@pytest.mark.parametrize("theta", [None, 4])
def test_radial_and_axial_derivatives_and_hoop_terms(theta):
    snap = snapshot()
    a = axis_point(snap)
    h, r0, z0 = 0.01, 1.1, 0.3
    stencil = dict(r=(r0 - 2.5 * h, r0 + 2.5 * h, 5), z=(z0 - 2.5 * h, z0 + 2.5 * h, 5), theta=theta)
    fields = ("density", "momentum", "velocity") + GRADIENTS + ("velocity_gradient",)
    out = cg.coarse_grain(snap, cg.CylindricalGrid(snap.box, a, "z", **stencil), KERNEL, fields=fields)
    r = out.grid.r[:, None, None]
    c = (2, slice(None), 2)                         # the stencil's centre (r0, every θ, z0)
    scale_rho = np.abs(out.density_gradient).max()
    scale_p = np.abs(out.momentum_gradient).max()
    scale_v = np.abs(out.velocity_gradient[c]).max()
    # ∂/∂r and ∂/∂z against 4th-order differences ((h / w)^4 ~ 1e-6)
    np.testing.assert_allclose(out.density_gradient[c][..., 0], fourth_order(out.density[:, :, 2], h),
                               rtol=0, atol=1e-6 * scale_rho)
    np.testing.assert_allclose(out.density_gradient[c][..., 2], fourth_order(out.density[2, :, :].T, h),
                               rtol=0, atol=1e-6 * scale_rho)
    np.testing.assert_allclose(out.momentum_gradient[c][..., 0], fourth_order(out.momentum[:, :, 2], h),
                               rtol=0, atol=1e-6 * scale_p)
    np.testing.assert_allclose(out.momentum_gradient[c][..., 2], fourth_order(np.moveaxis(out.momentum[2], 1, 0), h),
                               rtol=0, atol=1e-6 * scale_p)
    np.testing.assert_allclose(out.velocity_gradient[c][..., 0], fourth_order(out.velocity[:, :, 2], h),
                               rtol=0, atol=1e-6 * scale_v)
    if theta is None:
        # the θ column of the averaged fields: only the hoop terms, at round-off
        p, V = out.momentum, out.velocity
        G, L = out.momentum_gradient, out.velocity_gradient
        assert np.abs(out.density_gradient[..., 1]).max() < 1e-13 * scale_rho
        np.testing.assert_allclose(G[..., 0, 1], -p[..., 1] / r, rtol=0, atol=1e-13 * scale_p)
        np.testing.assert_allclose(G[..., 1, 1], p[..., 0] / r, rtol=0, atol=1e-13 * scale_p)
        assert np.abs(G[..., 2, 1]).max() < 1e-13 * scale_p
        np.testing.assert_allclose(L[..., 0, 1], -V[..., 1] / r, rtol=0, atol=1e-12 * np.abs(L).max())
        np.testing.assert_allclose(L[..., 1, 1], V[..., 0] / r, rtol=0, atol=1e-12 * np.abs(L).max())
        # and they are not small here (the checks above could fail)
        assert np.abs(p[..., 1] / r).max() > 1e-2 * scale_p and np.abs(p[..., 0] / r).max() > 1e-2 * scale_p


def test_z_averaged_grid_has_no_z_derivative():
    snap = snapshot()
    grid = cg.CylindricalGrid(snap.box, axis_point(snap), "z", r=(0.0, 2.0, 4))
    out = cg.coarse_grain(snap, grid, KERNEL, fields=GRADIENTS + ("density",))
    assert np.all(out.density_gradient[..., 2] == 0) and np.all(out.momentum_gradient[..., 2] == 0)
    assert np.abs(out.density_gradient[..., 0]).max() > 0
    # the r column is still the ring average (z-averaged): the same as the z-average of z-resolved nodes
    lo, hi = grid.z_extent
    x, w = np.polynomial.legendre.leggauss(80)
    zs = 0.5 * (hi + lo) + 0.5 * (hi - lo) * x
    acc = 0.0
    for zq, wq in zip(zs, w):
        one = cg.CylindricalGrid(snap.box, axis_point(snap), "z", r=(0.0, 2.0, 4), z=(zq - 1e-3, zq + 1e-3, 1))
        acc = acc + 0.5 * wq * cg.coarse_grain(snap, one, KERNEL, fields=("density_gradient",)).density_gradient
    np.testing.assert_allclose(out.density_gradient[..., 0], acc[..., 0], rtol=0,
                               atol=1e-12 * np.abs(acc).max())


def test_heaviside_gradient_refused():
    snap = snapshot()
    grid = cg.CylindricalGrid(snap.box, axis_point(snap), "z", r=(0.0, 2.0, 4))
    with pytest.raises(ValueError, match="kernel: expected a differentiable kernel"):
        cg.coarse_grain(snap, grid, cg.Heaviside(0.5), fields=("density_gradient",))


def adaptive_ring_gradients(snap, grid, kernel, r, z):
    """The θ-average at the ring (r, z) of sum_i m_i ∇W and sum_i m_i v_i ⊗ ∇W rotated into (e_r, e_θ, e_z),
    by adaptive quadrature (QUADPACK's quad_vec) with every particle's arc ends as breakpoints, and the
    kernel's gradient from its textbook derivative (tests/oracle.py)."""
    from scipy.integrate import quad_vec
    twin = oracle_kernel_of(kernel, 3)
    flowing = ~snap.fixed
    q, m, v = snap.positions[flowing], snap.masses[flowing], snap.velocities[flowing]
    rel = q - grid.axis_point
    rho, phi, zeta = np.hypot(rel[:, 0], rel[:, 1]), np.arctan2(rel[:, 1], rel[:, 0]), rel[:, 2]
    c = float(kernel.radius)
    d0sq = (r - rho) ** 2 + (z - zeta) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        s2 = np.clip((c * c - d0sq) / (4 * r * rho), 0.0, 1.0)
    half = 2 * np.arcsin(np.sqrt(s2))
    inside = d0sq < c * c
    ends = np.concatenate([phi[inside] - half[inside], phi[inside] + half[inside]])
    breaks = np.sort(np.mod(ends, 2 * np.pi))

    def f(theta):
        x = grid.cartesian(r, np.array([theta]), np.array([z]))[0]
        B = grid.basis(np.array([theta]))[0]
        grad = twin.gradient(x - q) @ B.T                      # (S, 3) in the local basis
        vl = v @ B.T
        return np.concatenate([m @ grad, np.einsum("s,sa,sb->ab", m, vl, grad).ravel()])

    total, _ = quad_vec(f, 0.0, 2 * np.pi, epsabs=1e-15, epsrel=1e-14, points=breaks, limit=4000)
    total /= 2 * np.pi
    return total[:3], total[3:].reshape(3, 3)


@pytest.mark.parametrize("kernel", [cg.Lucy(1.3), cg.Gaussian(0.3), cg.Gaussian(0.3, cutoff=1.0)],
                         ids=["lucy", "gauss5w", "gauss3.3w"])
def test_exact_ring_gradients_against_adaptive_quadrature(kernel):
    """The θ-averaged gradients are exact ring integrals of W'(d)/d (csrc/cg_ring.c), not a θ rule: at the
    default 5 w cutoff and for Lucy (where the θ rule stopped near 1e-6) within 1e-12 of QUADPACK."""
    snap = snapshot()
    a = axis_point(snap)
    grid = cg.CylindricalGrid(snap.box, a, "z", r=(0.0, 2.0, 5), z=(-0.5, 0.5, 2))
    out = cg.coarse_grain(snap, grid, kernel, fields=GRADIENTS)
    for i, r in enumerate(grid.r[1:], start=1):
        for k, z in enumerate(grid.z):
            want_rho, want_p = adaptive_ring_gradients(snap, grid, kernel, r, z)
            assert np.abs(want_rho).max() > 0
            np.testing.assert_allclose(out.density_gradient[i, 0, k], want_rho, rtol=0,
                                       atol=1e-12 * np.abs(want_rho).max())
            np.testing.assert_allclose(out.momentum_gradient[i, 0, k], want_p, rtol=0,
                                       atol=1e-12 * np.abs(want_p).max())


@pytest.mark.parametrize("kernel", [cg.Lucy(1.3), cg.Gaussian(0.3)], ids=["lucy", "gauss5w"])
@pytest.mark.parametrize("periodic", [False, True], ids=["walls", "periodic-z"])
def test_theta_resolved_z_averaged_point_sums_are_exact(kernel, periodic):
    """On a θ-resolved grid averaged over z, the point sums and gradients are the kernel's exact line integrals
    along each node's z-line: within 1e-12 of QUADPACK over z (every particle's support edges as breakpoints)
    of the Cartesian fields at points, rotated into the local basis; the Gauss-Legendre rule in z they replace
    is limited by the support's edge."""
    from scipy.integrate import quad_vec
    snap = random_snapshot(3, n=40, n_bulk=30, lengths=[6.0, 6.0, 5.0], periodic=(False, False, periodic))
    a = axis_point(snap)
    grid = cg.CylindricalGrid(snap.box, a, "z", r=(0.2, 2.0, 3), theta=4)
    fields = ("density", "momentum", "density_gradient", "momentum_gradient")
    out = cg.coarse_grain(snap, grid, kernel, fields=fields)
    lo, hi = grid.z_extent
    c = float(kernel.radius)
    for i, r in enumerate(grid.r):
        for j, theta in enumerate(grid.theta):
            B = grid.basis(np.array([theta]))[0]
            foot = grid.cartesian(r, np.array([theta]), np.array([0.0]))[0]
            perp2 = ((snap.positions[:, :2] - foot[:2]) ** 2).sum(axis=1)
            edge = np.sqrt(np.clip(c * c - perp2, 0.0, None))[perp2 < c * c]
            zeta = (snap.positions[:, 2] - a[2])[perp2 < c * c]
            zeta = np.concatenate([zeta + k * snap.box.lengths[2] for k in ((-1, 0, 1) if periodic else (0,))])
            edge = np.tile(edge, len(zeta) // max(len(edge), 1))
            breaks = np.sort(np.concatenate([zeta - edge, zeta + edge]))
            breaks = breaks[(breaks > lo) & (breaks < hi)]

            def f(z):
                point = grid.cartesian(r, np.array([theta]), np.array([z]))
                res = cg.coarse_grain(snap, cg.Points(point), kernel, fields=fields)
                return np.concatenate([res.density.ravel(), B @ res.momentum[0], B @ res.density_gradient[0],
                                       (B @ res.momentum_gradient[0] @ B.T).ravel()])

            want, _ = quad_vec(f, lo, hi, epsabs=1e-14, epsrel=1e-13, points=breaks, limit=2000)
            want /= hi - lo
            got = np.concatenate([[out.density[i, j, 0]], out.momentum[i, j, 0], out.density_gradient[i, j, 0],
                                  out.momentum_gradient[i, j, 0].ravel()])
            want[[6, 9, 12, 15]] = 0.0               # averaged over z: the z column is zero
            assert np.abs(want).max() > 0
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())


def test_kernels_too_narrow_for_the_quadrature_are_refused_by_name():
    """A kernel far narrower than the grid: every field's exact path (point sums, gradients, the stresses' line
    integrals and rays; θ-averaged or resolved, z-averaged or resolved) still works; the balance residual on a
    z-averaged grid, which still takes its terms on Gauss-Legendre points in z, is refused by the kernel
    argument's name, not by an overflow deep in NumPy."""
    snap = snapshot()
    tiny = cg.Lucy(1e-59)
    kinds = (dict(), dict(z=(-0.5, 0.5, 2)), dict(theta=4), dict(theta=4, z=(-0.5, 0.5, 2)))
    for kind in kinds:
        g = cg.CylindricalGrid(snap.box, axis_point(snap), "z", r=(0.2, 2.0, 3), **kind)
        for name in ("density", "density_gradient", "contact_stress", "extended_stress"):
            assert np.all(np.isfinite(getattr(cg.coarse_grain(snap, g, tiny, fields=(name,)), name))), (kind, name)
    grid = cg.CylindricalGrid(snap.box, axis_point(snap), "z", r=(0.2, 2.0, 3))
    with pytest.raises(ValueError, match="^kernel: a kernel scale of .* needs .* points in z"):
        cg.cylindrical_momentum_balance_residual(snap, grid, tiny)
