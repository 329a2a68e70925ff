"""The virial identity in cylindrical form: the contact (and boundary) stress of a CylindricalGrid, integrated
with the measure r dr dθ dz and rotated back to Cartesian components, is -Σ f ⊗ branch over the contacts (the
tension convention: σᶜ = -Σ f_ij ⊗ (r_i - r_j) ∫ W, σʷ = -Σ f_ik ⊗ (r_i - c_ik) ∫ W)."""
import numpy as np
import pytest

import cgbound as cg

W = 0.5
KERNEL = cg.Gaussian(W, cutoff=9 * W)       # the tail beyond the cutoff is below round-off


def blob():
    """Particles near the axis (x = y = 0), with bulk contacts and boundary contacts of random forces."""
    rng = np.random.default_rng(18)
    n = 20
    pos = np.c_[rng.uniform(-1.0, 1.0, (n, 2)), rng.uniform(-0.8, 0.8, n)]
    pairs = {tuple(sorted(rng.choice(n, 2, replace=False))) for _ in range(40)}
    i, j = np.array(sorted(pairs)).T
    bulk_force = rng.normal(size=(len(i), 3))
    bulk_point = 0.5 * (pos[i] + pos[j])
    k = rng.choice(n, 6, replace=False)
    wall_point = pos[k] + 0.4 * rng.normal(size=(6, 3))
    wall_force = rng.normal(size=(6, 3))
    contacts = cg.Contacts(np.r_[i, k], np.r_[j, np.full(6, -1)], np.r_[bulk_force, wall_force],
                           np.r_[bulk_point, wall_point])
    box = cg.Box([-8, -8, -8], [8, 8, 8], periodic=[False, False, False])
    snap = cg.Snapshot(pos, rng.normal(size=(n, 3)), rng.uniform(0.5, 2, n), box=box, contacts=contacts)
    virial = {"contact_stress": -np.einsum("ca,cb->ab", bulk_force, pos[i] - pos[j]),
              "boundary_stress": -np.einsum("ca,cb->ab", wall_force, pos[k] - wall_point)}
    return snap, virial


def integrate(snap, theta, r_max=7.5, n_r=48, z=(-7.5, 7.5, 60)):
    """∫ σ dV from the cylindrical fields: Gauss-Legendre in r (one grid per radius) with the measure r dr dθ dz,
    θ and z by the midpoint rule (spectral here: periodic in θ; in z the fields vanish to round-off at both
    ends). theta=None: the θ-averaged fields times 2π, which keep only the rotation-invariant parts."""
    x, w = np.polynomial.legendre.leggauss(n_r)
    radii, r_weights = 0.5 * r_max * (x + 1), 0.5 * r_max * w
    dz = (z[1] - z[0]) / z[2]
    total = {"contact_stress": np.zeros((3, 3)), "boundary_stress": np.zeros((3, 3))}
    for r, wr in zip(radii, r_weights):
        grid = cg.CylindricalGrid(snap.box, (0.0, 0.0, 0.0), "z", r=(r - 1e-3, r + 1e-3, 1), theta=theta, z=z)
        out = cg.coarse_grain(snap, grid, KERNEL, fields=tuple(total))
        B = grid.basis(grid.theta)                                        # rows e_r, e_θ, e_z per θ node
        for name in total:
            local = getattr(out, name)[0]                                 # (n_θ or 1, n_z, 3, 3)
            if theta is None:
                # ∫ dθ of the rotation-invariant parts: 2π times the averaged local components
                total[name] += wr * grid.r[0] * dz * 2 * np.pi * local.sum(axis=1)[0]
            else:
                cart = np.einsum("tia,tzij,tjb->ab", B, local, B)             # Σ over θ and z nodes
                total[name] += wr * grid.r[0] * dz * (2 * np.pi / theta) * cart
    return total


def test_virial_identity_theta_resolved():
    """Measured 4.3e-15 of the largest component (1.9e-15 with 96 θ, 64 r and 75 z nodes)."""
    snap, virial = blob()
    total = integrate(snap, theta=64)
    for name, want in virial.items():
        scale = np.abs(want).max()
        assert scale > 0.5
        np.testing.assert_allclose(total[name], want, rtol=0, atol=1e-13 * scale, err_msg=name)


def test_virial_identity_ring_averaged_invariants():
    """On θ-averaged fields: σ_zz, σ_rr + σ_θθ (the in-plane trace) and σ_rθ - σ_θr (the in-plane antisymmetric
    part) are invariant under rotation about the axis, so their integrals are those of σ_zz, σ_xx + σ_yy,
    σ_xy - σ_yx. Measured 3.9e-15 of the largest component."""
    snap, virial = blob()
    total = integrate(snap, theta=None)
    for name, want in virial.items():
        got = total[name]
        scale = np.abs(want).max()
        for g, v in ((got[2, 2], want[2, 2]), (got[0, 0] + got[1, 1], want[0, 0] + want[1, 1]),
                     (got[0, 1] - got[1, 0], want[0, 1] - want[1, 0])):
            assert abs(g - v) < 1e-13 * scale, (name, g, v)
        # a component that is not invariant does not integrate to its Cartesian value (the test above can fail)
        assert abs(got[0, 0] - want[0, 0]) > 1e-3 * scale
