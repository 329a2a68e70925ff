"""Structure fields (docs/theory.md, "Structure"): fabric, coordination number, number density, size moments.

Against the slow twin (tests/oracle.py, oracle_structure) and against identities: the fabric's domain
integral is the sum of n n over the contacts (its trace the number of contacts), listing a contact either way
round changes nothing, and a simple cubic lattice has coordination number 6.
"""
import itertools

import numpy as np
import pytest

import cgbound as cg
from cgbound.fields import STRUCTURE_FIELDS

from helpers import random_snapshot
from oracle import oracle_structure


def kernels():
    return [cg.Gaussian(0.7), cg.Lucy(1.6), cg.Gaussian(0.6, normalize="truncated")]


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("kernel", kernels(), ids=repr)
def test_structure_fields_match_the_oracle_on_a_grid(seed, kernel):
    snap = random_snapshot(seed)
    grid = cg.Grid(snap.box, (3, 3, 4))
    got = cg.coarse_grain(snap, grid, kernel, fields=STRUCTURE_FIELDS)
    want = oracle_structure(snap, grid, kernel, STRUCTURE_FIELDS)
    compare(got, want)


def compare(got, want):
    for name in STRUCTURE_FIELDS:
        a, b = got[name].reshape(want[name].shape), want[name]
        if name == "radius_skewness":
            # the skewness is (M3 - 3 M1 var - M1^3) / spread^3 from raw moments: where the local sizes hardly
            # spread (a node that sees essentially one particle) rounding of the moments is amplified without bound,
            # so it is compared where the spread is at least 1 % of the mean radius
            spread = want["radius_spread"] > 0.01 * want["mean_radius"]
            a, b = a[spread], b[spread]
        if name == "radius_spread":
            # sqrt(M2/M0 - mean^2): the variance carries the moments' rounding (~1e-16 mean^2) and the square root
            # turns it into ~1e-8 mean where the sizes do not spread; compare the variance, on the mean's scale
            scale = np.nan_to_num(want["mean_radius"]) ** 2
            assert np.all((np.abs(a ** 2 - b ** 2) <= 1e-10 * np.abs(b ** 2) + 1e-14 * scale)
                          | (np.isnan(a) & np.isnan(b))), name
            continue
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12, err_msg=name)


@pytest.mark.parametrize("seed", range(3))
def test_structure_fields_match_the_oracle_at_points_and_with_averaged_axes(seed):
    snap = random_snapshot(seed, dim=2, periodic=(True, False))
    kernel = cg.Gaussian(0.8)
    points = cg.Points(np.asarray(snap.positions)[:5] + 0.1)
    profile = cg.Grid(snap.box, (1, 6), average="x")
    for where in (points, profile):
        got = cg.coarse_grain(snap, where, kernel, fields=STRUCTURE_FIELDS)
        compare(got, oracle_structure(snap, where, kernel, STRUCTURE_FIELDS))


def oriented_normals(snap):
    """Unit contact normals of the bulk and boundary contacts (each once), from the contact list directly."""
    box = snap.box
    X = np.asarray(snap.positions)
    c = snap.contacts
    out = []
    for k in range(len(c)):
        i, j = int(c.i[k]), int(c.j[k])
        wall_j = j < 0 or snap.fixed[j]
        if snap.fixed[i] and wall_j:
            continue
        d = X[i] - X[j] if not wall_j and not snap.fixed[i] else X[j if snap.fixed[i] else i] - c.point[k]
        for a in range(box.dim):
            if box.periodic[a]:
                L = box.upper[a] - box.lower[a]
                d[a] -= L * np.round(d[a] / L)
        out.append(d / np.linalg.norm(d))
    return np.array(out)


@pytest.mark.parametrize("seed", range(4))
def test_fabric_domain_integral_is_the_sum_of_nn_over_contacts(seed):
    # a fully periodic box and a grid averaged over every axis: the field is the domain integral / volume, exactly
    snap = random_snapshot(seed, periodic=(True, True, True))
    box = snap.box
    volume = float(np.prod(np.asarray(box.upper) - np.asarray(box.lower)))
    whole = cg.Grid(box, (1, 1, 1), average=("x", "y", "z"))
    r = cg.coarse_grain(snap, whole, cg.Gaussian(0.5), fields=("fabric", "coordination_number", "number_density"))
    n = oriented_normals(snap)
    assert len(n) > 0
    want = np.einsum("ka,kb->ab", n, n)
    np.testing.assert_allclose(r.fabric.reshape(3, 3) * volume, want, rtol=1e-12, atol=1e-12)
    assert np.trace(r.fabric.reshape(3, 3)) * volume == pytest.approx(len(n), rel=1e-12)
    # the mean coordination number: every bulk contact counts for both its particles
    split = snap.split_contacts()
    n_flowing = int((~np.asarray(snap.fixed)).sum())
    assert float(r.number_density.ravel()[0]) * volume == pytest.approx(n_flowing, rel=1e-12)
    assert float(r.coordination_number.ravel()[0]) == pytest.approx(
        (2 * split[0]["i"].size + split[1]["i"].size) / n_flowing, rel=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_fabric_does_not_depend_on_which_way_round_a_contact_is_listed(seed):
    snap = random_snapshot(seed)
    c = snap.contacts
    pair = c.j >= 0
    flip = pair & (np.arange(len(c)) % 2 == 0)    # bulk and fixed-particle contacts as (j, i, -f)
    i = np.where(flip, c.j, c.i)
    j = np.where(flip, c.i, c.j)
    flipped = cg.Snapshot(snap.positions, snap.velocities, snap.masses, snap.box,
                          cg.Contacts(i, j, np.where(flip[:, None], -c.force, c.force), c.point),
                          fixed=snap.fixed, radii=snap.radii)
    assert flip.any()
    grid = cg.Grid(snap.box, (3, 3, 4))
    fields = ("fabric", "coordination_number")
    a = cg.coarse_grain(snap, grid, cg.Lucy(1.5), fields=fields)
    b = cg.coarse_grain(flipped, grid, cg.Lucy(1.5), fields=fields)
    for name in fields:
        np.testing.assert_allclose(b[name], a[name], rtol=1e-13, atol=1e-15)


def simple_cubic(n, spacing=1.0):
    """An n^3 simple cubic lattice in a periodic box, each nearest-neighbour pair a contact once (at the midpoint)."""
    L = n * spacing
    box = cg.Box([0.0] * 3, [L] * 3, periodic=(True, True, True))
    index = {}
    pos = []
    for k, (a, b, c) in enumerate(itertools.product(range(n), repeat=3)):
        index[(a, b, c)] = k
        pos.append(((a + 0.5) * spacing, (b + 0.5) * spacing, (c + 0.5) * spacing))
    pos = np.array(pos)
    I, J, P = [], [], []
    for (a, b, c), k in index.items():
        for axis in range(3):
            step = [a, b, c]
            step[axis] = (step[axis] + 1) % n
            I.append(k)
            J.append(index[tuple(step)])
            mid = pos[k].copy()
            mid[axis] += 0.5 * spacing
            P.append(mid % L)
    contacts = cg.Contacts(I, J, np.ones((len(I), 3)), P)
    return cg.Snapshot(pos, masses=np.ones(len(pos)), box=box, contacts=contacts,
                       radii=np.full(len(pos), 0.5 * spacing))


def test_simple_cubic_lattice_has_coordination_number_six():
    snap = simple_cubic(6)
    # a Gaussian wider than the spacing a: the lattice sums are uniform up to ~exp(-2 pi^2 w^2 / a^2) (Poisson
    # summation; 1e-19 at w = 1.5 a) and the truncation at 8 widths leaves ~1e-12
    r = cg.coarse_grain(snap, cg.Grid(snap.box, (3, 4, 5)), cg.Gaussian(1.5, cutoff=12.0),
                        fields=("coordination_number", "fabric", "number_density", "mean_radius", "radius_spread"))
    np.testing.assert_allclose(r.coordination_number, 6.0, rtol=1e-9)
    # isotropic: F = (N_contacts / V) / 3 * identity, with 3 contacts per particle and density 1
    np.testing.assert_allclose(r.fabric, np.broadcast_to(np.eye(3), r.fabric.shape), atol=1e-9)
    np.testing.assert_allclose(r.number_density, 1.0, rtol=1e-9)
    np.testing.assert_allclose(r.mean_radius, 0.5, rtol=1e-12)
    np.testing.assert_allclose(r.radius_spread, 0.0, atol=1e-7)


def test_radius_statistics_of_a_wide_kernel_are_the_sample_statistics():
    rng = np.random.default_rng(7)
    n = 400
    box = cg.Box([0, 0, 0], [4, 4, 4], periodic=(True, True, True))
    radii = rng.gamma(3.0, 0.1, n)
    snap = cg.Snapshot(rng.uniform(0, 4, (n, 3)), masses=np.ones(n), box=box, radii=radii)
    whole = cg.Grid(box, (1, 1, 1), average=("x", "y", "z"))
    r = cg.coarse_grain(snap, whole, cg.Gaussian(0.3),
                        fields=("mean_radius", "radius_spread", "radius_skewness", "size_moment_4"))
    mean, sd = radii.mean(), radii.std()
    assert float(r.mean_radius.ravel()[0]) == pytest.approx(mean, rel=1e-12)
    assert float(r.radius_spread.ravel()[0]) == pytest.approx(sd, rel=1e-10)
    assert float(r.radius_skewness.ravel()[0]) == pytest.approx(np.mean((radii - mean) ** 3) / sd ** 3, rel=1e-9)
    assert float(r.size_moment_4.ravel()[0]) * 64 == pytest.approx(np.sum(radii ** 4), rel=1e-12)


def test_size_moments_without_radii_are_refused_naming_the_radii():
    snap = random_snapshot(0, radii=False)
    with pytest.raises(ValueError, match="snapshot.radii"):
        cg.coarse_grain(snap, cg.Grid(snap.box, 3), cg.Gaussian(0.7), fields=("mean_radius",))
    # the number density needs no radii
    cg.coarse_grain(snap, cg.Grid(snap.box, 3), cg.Gaussian(0.7), fields=("number_density", "size_moment_0"))


def test_a_contact_without_a_normal_is_refused():
    box = cg.Box([0, 0], [4, 4], periodic=(True, True))
    pos = np.array([[1.0, 1.0], [2.0, 1.0]])
    wall = cg.Contacts([0], [-1], [[0.0, 1.0]], [[1.0, 1.0]])   # at the particle's centre
    snap = cg.Snapshot(pos, masses=[1.0, 1.0], box=box, contacts=wall)
    with pytest.raises(ValueError, match="contacts"):
        cg.coarse_grain(snap, cg.Grid(box, 2), cg.Gaussian(0.5), fields=("fabric",))
