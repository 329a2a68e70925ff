"""The momentum balance on θ-averaged fields with its hoop terms (cg.cylindrical_momentum_balance_residual):
round-off on random unbalanced data and on the genuine silo frames, and clearly not without the hoop terms."""
import os

import numpy as np
import pytest

import cgbound as cg
from cgbound.cylindrical_balance import TERMS, hoop_terms
from helpers import random_snapshot

EXACT = cg.Gaussian(0.4, cutoff=4.0)       # cutoff 10 w: the θ rule is exact to round-off
DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "lammps", "silo")


def snapshot(periodic=(False, False, False)):
    return random_snapshot(3, n=40, n_bulk=30, lengths=[6.0, 6.0, 5.0], periodic=periodic)


def axis_point(snap):
    return 0.5 * (snap.box.lower + snap.box.upper)


def largest_term(balance):
    return max(np.abs(getattr(balance, name)).max() for name in TERMS)


def without_hoop(balance, component=slice(None)):
    """The residual with the hoop terms of ``component`` dropped from both divergences."""
    out = balance.residual.copy()
    out[..., component] += balance.hoop_contact_stress[..., component] + balance.hoop_boundary_stress[..., component]
    return out


@pytest.mark.parametrize("z, periodic", [((-1.0, 1.5, 4), (False, False, False)), (None, (False, False, False)),
                                         ((-1.0, 1.5, 4), (True, True, False))])
def test_random_data_balance_is_round_off_and_needs_the_hoop_terms(z, periodic):
    """Any data (random contact forces: no balance of the particles themselves); periodic images across the
    box's x and y sides break the axial symmetry, not the identity."""
    snap = snapshot(periodic)
    grid = cg.CylindricalGrid(snap.box, axis_point(snap), "z", r=(0.0, 2.5, 6), z=z)
    b = cg.cylindrical_momentum_balance_residual(snap, grid, EXACT)
    assert b.residual.shape == grid.shape + (3,) and b.contact_stress.shape == grid.shape + (3, 3)
    scale = largest_term(b)
    assert np.abs(b.residual).max() < 1e-14 * scale       # measured 7.6e-16 (RZ), 1e-16 (R)
    assert b.relative.max() < 1e-14 and b.scale >= scale
    # every component's hoop term is needed: dropping it leaves a residual of percents
    for a in range(3):
        assert np.abs(without_hoop(b, a)[..., a]).max() > 1e-3 * scale, a


def test_averaged_stress_is_the_fields_and_its_derivatives_are_radial_and_axial():
    snap = snapshot()
    a = axis_point(snap)
    h, r0, z0 = 0.01, 1.3, 0.4
    grid = cg.CylindricalGrid(snap.box, a, "z", r=(r0 - 2.5 * h, r0 + 2.5 * h, 5), z=(z0 - 2.5 * h, z0 + 2.5 * h, 5))
    b = cg.cylindrical_momentum_balance_residual(snap, grid, EXACT)
    fields = cg.coarse_grain(snap, grid, EXACT, fields=("contact_stress", "boundary_stress"))
    for name in ("contact_stress", "boundary_stress"):
        value = getattr(fields, name)
        scale = np.abs(value).max()
        np.testing.assert_allclose(getattr(b, name), value, rtol=0, atol=1e-14 * scale)
        d = lambda f: (f[0] - 8 * f[1] + 8 * f[3] - f[4]) / (12 * h)        # 4th-order central difference
        dr, dz = getattr(b, name + "_dr")[2, 0, 2], getattr(b, name + "_dz")[2, 0, 2]
        np.testing.assert_allclose(dr, d(value[:, 0, 2]), rtol=0, atol=1e-6 * np.abs(dr).max())
        np.testing.assert_allclose(dz, d(value[2, 0, :]), rtol=0, atol=1e-6 * np.abs(dz).max())
    # the hoop terms are those of the averaged stresses
    r = grid.r[:, None, None]
    np.testing.assert_array_equal(b.hoop_contact_stress, hoop_terms(b.contact_stress, r))
    np.testing.assert_allclose(b.hoop_contact_stress[..., 0],
                               (b.contact_stress[..., 0, 0] - b.contact_stress[..., 1, 1]) / r, rtol=1e-15)


@pytest.mark.parametrize("z, periodic", [((-1.0, 1.5, 4), (False, False, False)), (None, (False, False, False)),
                                         ((-1.0, 1.5, 4), (True, True, False)), (None, (True, True, False))])
def test_lucy_balance_is_round_off(z, periodic):
    """Lucy's θ-averages are exact ring integrals and its rule along the segments is graded towards their closest
    approach to the ring (tests/test_cylindrical_segment_gradients.py): measured 0.9e-15 to 2.0e-15 of the
    largest term (2.9e-6 with the trapezoid in θ, 3e-8 with an ungraded rule along the segments)."""
    snap = snapshot(periodic)
    grid = cg.CylindricalGrid(snap.box, axis_point(snap), "z", r=(0.0, 2.5, 6), z=z)
    b = cg.cylindrical_momentum_balance_residual(snap, grid, cg.Lucy(1.2))
    scale = largest_term(b)
    assert np.abs(b.residual).max() < 1e-14 * scale
    assert np.abs(without_hoop(b)).max() > 1e-2 * scale


@pytest.fixture(scope="module")
def silo_reader():
    from cgbound.paper.scenes import SILO_TIMESTEP
    from cgbound.paper.scenes.lammps import PAIR_VALUES
    from cgbound.readers.lammps import LammpsReader
    return LammpsReader(os.path.join(DATA, "frames.atoms.dump.gz"), os.path.join(DATA, "frames.pairs.dump.gz"),
                        pair_values=PAIR_VALUES, walls=["wall0", "wall1"], body_force=(0.0, 0.0, -1.0),
                        dt=SILO_TIMESTEP)


@pytest.mark.parametrize("frame", [0, 1])
def test_genuine_silo_balance(silo_reader, frame):
    """The static column in its cylinder (axis z through the origin, radius 4, bottom at z = -0.2): the balance
    with the dumped forces and with the forces built from the contacts; measured 1.4e-15 of the largest term,
    0.24 without the hoop terms."""
    snap = silo_reader[frame]
    grid = cg.CylindricalGrid(snap.box, (0.0, 0.0, 0.0), "z", r=(0.0, 4.5, 9), z=(-0.5, 10.0, 4))
    for forces in (None, silo_reader.dumped_forces(frame)):
        b = cg.cylindrical_momentum_balance_residual(snap, grid, cg.Gaussian(0.5, cutoff=4.5), forces=forces)
        scale = largest_term(b)
        assert np.abs(b.residual).max() < 1e-14 * scale
        assert np.abs(without_hoop(b)).max() > 0.1 * scale
        # the wall's interaction force density is there (the outer rings) and the column is at rest: the
        # forcing (∂p/∂t + div k) is a small fraction of the weight density
        assert np.abs(b.interaction_force_density[-1]).max() > 0.1 * scale
        assert np.abs(b.forcing).max() < 1e-2 * np.abs(b.body_force_density).max()


def test_genuine_silo_balance_lucy(silo_reader):
    """The same frame with Lucy: measured 6.9e-15 of the largest term (2.9e-8 before the grading along the
    segments, 2.9e-6 with the trapezoid in θ)."""
    snap = silo_reader[0]
    grid = cg.CylindricalGrid(snap.box, (0.0, 0.0, 0.0), "z", r=(0.0, 4.5, 9), z=(-0.5, 10.0, 4))
    b = cg.cylindrical_momentum_balance_residual(snap, grid, cg.Lucy(1.5))
    scale = largest_term(b)
    assert np.abs(b.residual).max() < 2e-14 * scale
    assert np.abs(without_hoop(b)).max() > 0.1 * scale


def test_bad_arguments_are_named():
    snap = snapshot()
    a = axis_point(snap)
    ring = cg.CylindricalGrid(snap.box, a, "z", r=(0.0, 2.0, 2), z=(-1.0, 1.0, 2))
    with pytest.raises(ValueError, match="grid: expected a θ-averaged"):
        cg.cylindrical_momentum_balance_residual(snap, cg.CylindricalGrid(snap.box, a, "z", r=(0.0, 2.0, 2), theta=4,
                                                                         z=(-1.0, 1.0, 2)), EXACT)
    with pytest.raises(TypeError, match="grid: expected a cg.CylindricalGrid"):
        cg.cylindrical_momentum_balance_residual(snap, cg.Grid(snap.box, (2, 2, 2)), EXACT)
    with pytest.raises(ValueError, match="kernel: expected a differentiable"):
        cg.cylindrical_momentum_balance_residual(snap, ring, cg.Heaviside(0.5))
    with pytest.raises(ValueError, match="forces"):
        cg.cylindrical_momentum_balance_residual(snap, ring, EXACT, forces=np.zeros((3, 3)))
    with pytest.raises(TypeError, match="snapshot"):
        cg.cylindrical_momentum_balance_residual(None, ring, EXACT)
