"""Physical identities of docs/theory.md ("Identities the tests check"), each able to catch a sign or factor error."""
import math

import numpy as np
import pytest
from scipy.special import erfc

import cgbound as cg
from helpers import assert_fields_close, random_snapshot
from oracle import OracleKernel

CONTACT_STRESSES = ("contact_stress", "boundary_stress")


def periodic_snapshot(seed, dim=3, **kw):
    return random_snapshot(seed, dim=dim, periodic=(True,) * dim, **kw)


def cell_volume(grid):
    return float(np.prod(grid.box.lengths / np.array(grid.shape)))


# --- 1. mass ------------------------------------------------------------------

@pytest.mark.parametrize("dim", [2, 3])
def test_mass_is_conserved_on_a_resolved_periodic_grid(dim):
    snap = periodic_snapshot(1, dim=dim)
    w = 0.45
    grid = cg.Grid(snap.box, tuple(int(math.ceil(L / (w / 3))) for L in snap.box.lengths))
    out = cg.coarse_grain(snap, grid, cg.Gaussian(w, cutoff=10 * w), fields=("density",))
    total = out.density.sum() * cell_volume(grid)
    assert total == pytest.approx(snap.masses[snap.flowing].sum(), rel=1e-12)


@pytest.mark.parametrize("kernel", [cg.Gaussian(0.5, cutoff=1.5), cg.Lucy(1.2), cg.Heaviside(0.8)])
def test_mass_on_a_fully_averaged_grid_is_exact(kernel):
    snap = random_snapshot(2, dim=3)
    grid = cg.Grid(snap.box, (1, 1, 1), average=("x", "y", "z"))
    out = cg.coarse_grain(snap, grid, kernel, fields=("density",))
    volume = float(np.prod(snap.box.lengths))
    assert out.density.item() * volume == pytest.approx(snap.masses[snap.flowing].sum(), rel=1e-14)


def test_mass_of_a_profile_counts_every_particle_once():
    snap = random_snapshot(3, dim=3, lengths=(4.0, 3.5, 12.0))
    w = 0.05   # every kernel (cutoff 10 w) lies inside the box along z
    grid = cg.Grid(snap.box, (1, 1, 800), average=("x", "y"))
    out = cg.coarse_grain(snap, grid, cg.Gaussian(w, cutoff=10 * w), fields=("density",))
    total = out.density.sum() * cell_volume(grid)
    assert total == pytest.approx(snap.masses[snap.flowing].sum(), rel=1e-12)


# --- 2. virial -------------------------------------------------------------------

def virial_sums(snap):
    """-sum f_ij r_ij - sum f_ik a_ik, from the raw contact list (minimum image by hand)."""
    D = snap.dim
    total = np.zeros((D, D))
    L = snap.box.lengths
    for i, j, f, c in zip(snap.contacts.i, snap.contacts.j, snap.contacts.force, snap.contacts.point):
        fi = snap.fixed[i]
        fj = True if j < 0 else snap.fixed[j]
        if fi and fj:
            continue
        if not fi and not fj:
            r = snap.positions[i] - snap.positions[j]
        elif not fi:
            r = snap.positions[i] - c
        else:
            r, f = snap.positions[j] - c, -f
        r = np.array([x - l * round(x / l) if p else x for x, l, p in zip(r, L, snap.box.periodic)])
        total -= np.outer(f, r)
    return total


@pytest.mark.parametrize("dim", [2, 3])
def test_virial_of_the_contact_stress(dim):
    snap = periodic_snapshot(4, dim=dim)
    w = 0.45
    grid = cg.Grid(snap.box, tuple(int(math.ceil(L / (w / 3))) for L in snap.box.lengths))
    out = cg.coarse_grain(snap, grid, cg.Gaussian(w, cutoff=10 * w), fields=CONTACT_STRESSES)
    integral = (out.contact_stress + out.boundary_stress).reshape(-1, dim, dim).sum(axis=0) * cell_volume(grid)
    expected = virial_sums(snap)
    np.testing.assert_allclose(integral, expected, rtol=0, atol=1e-12 * np.abs(expected).max())


@pytest.mark.parametrize("kernel", [cg.Gaussian(0.5, cutoff=1.5), cg.Lucy(1.2), cg.Heaviside(0.8)])
def test_virial_including_kinetic_part_on_an_averaged_grid(kernel):
    snap = random_snapshot(5, dim=3)
    grid = cg.Grid(snap.box, (1, 1, 1), average=("x", "y", "z"))
    out = cg.coarse_grain(snap, grid, kernel, fields=("stress",))
    flow = snap.flowing
    m, v = snap.masses[flow], snap.velocities[flow]
    vmean = (m[:, None] * v).sum(0) / m.sum()
    kinetic = -np.einsum("i,ia,ib->ab", m, v - vmean, v - vmean)
    volume = float(np.prod(snap.box.lengths))
    expected = kinetic + virial_sums(snap)
    np.testing.assert_allclose(out.stress[0, 0, 0] * volume, expected, rtol=0, atol=1e-13 * np.abs(expected).max())


# --- 3. momentum balance ------------------------------------------------------------

def random_points(snap, n, seed):
    rng = np.random.default_rng(seed)
    return snap.box.lower + rng.uniform(0.0, 1.0, (n, snap.dim)) * snap.box.lengths


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("kernel", [cg.Lucy(1.3), cg.Gaussian(0.5, cutoff=6.0)])
def test_momentum_balance_residual_vanishes_on_random_data(dim, kernel):
    snap = random_snapshot(6 + dim, dim=dim, n_bulk=12, n_fixed_contacts=6, n_wall=4)
    res = cg.momentum_balance_residual(snap, random_points(snap, 60, 1), kernel)
    assert res.scale > 0
    assert res.relative.max() <= 1e-10


def test_momentum_balance_detects_a_truncated_kernel():
    """The check is sharp: a Gaussian cut at 1.5 w leaves a visible residual."""
    snap = random_snapshot(8, dim=3, n_bulk=12)
    res = cg.momentum_balance_residual(snap, random_points(snap, 60, 2), cg.Gaussian(0.5, cutoff=0.75))
    assert res.relative.max() > 1e-3


def test_momentum_balance_with_inconsistent_forces_is_visible():
    snap = random_snapshot(9, dim=3)
    forces = snap.particle_forces()
    forces[~snap.fixed] *= 1.01
    res = cg.momentum_balance_residual(snap, random_points(snap, 40, 3), cg.Lucy(1.3), forces=forces)
    assert res.relative.max() > 1e-4


@pytest.mark.parametrize("kind", ["gaussian", "lucy"])
def test_gradients_match_the_oracle(kind):
    """The gradient entry points of the core against quadrature of the textbook kernel gradient."""
    dim = 3
    snap = random_snapshot(10, dim=dim, periodic=(False, False, False))
    kernel = cg.Gaussian(0.6, cutoff=3.0) if kind == "gaussian" else cg.Lucy(1.4)
    ref = OracleKernel(kind, dim, getattr(kernel, "width", None) or kernel.radius, kernel.radius)
    pts = random_points(snap, 30, 4)
    res = cg.momentum_balance_residual(snap, pts, kernel)
    bulk, boundary = snap.split_contacts()
    expected = np.zeros((pts.shape[0], dim))
    for i, f, r in zip(bulk["i"], bulk["force"], bulk["branch"]):
        g = ref.line_gradient(pts - snap.positions[i], -r)          # (P, D): d psi / d r_beta
        expected += -np.einsum("a,b,pb->pa", f, r, g)
    assert_fields_close(res.div_contact_stress, expected, 1e-10, "div contact stress")
    expected = np.zeros((pts.shape[0], dim))
    for i, f, a in zip(boundary["i"], boundary["force"], boundary["branch"]):
        expected += -np.einsum("a,b,pb->pa", f, a, ref.line_gradient(pts - snap.positions[i], -a))
    assert_fields_close(res.div_boundary_stress, expected, 1e-10, "div boundary stress")


# --- 4. relation (27) on a Z profile ------------------------------------------------

@pytest.mark.parametrize("dim", [2, 3])
def test_extended_stress_equals_stress_minus_integrated_ifd(dim):
    """sigma'_az(z) = sigma_az(z) - int_z^inf t_a dz' (eq. 27), with the integral done analytically."""
    snap = random_snapshot(12, dim=dim)
    w = 0.4
    avg = ("x", "y") if dim == 3 else ("x",)
    shape = (1, 1, 120) if dim == 3 else (1, 120)
    grid = cg.Grid(snap.box, shape, average=avg)
    out = cg.coarse_grain(snap, grid, cg.Gaussian(w, cutoff=12 * w),
                          fields=("stress", "extended_stress", "interaction_force_density"))
    z = grid.axis_coordinates[-1]
    area = float(np.prod(snap.box.lengths[:-1]))
    _, boundary = snap.split_contacts()
    integral = np.zeros((z.size, dim))
    for f, c in zip(boundary["force"], boundary["point"]):
        integral += 0.5 * erfc((z - c[-1]) / (math.sqrt(2) * w))[:, None] * f / area
    lhs = out.extended_stress.reshape(-1, dim, dim)[:, :, -1]
    rhs = out.stress.reshape(-1, dim, dim)[:, :, -1] - integral
    assert np.abs(integral).max() > 0.1 * np.abs(rhs).max()  # the correction matters here
    assert_fields_close(lhs, rhs, 1e-12, "eq. 27")


# --- 6. invariances ----------------------------------------------------------------

FIELDS = ("density", "momentum", "momentum_flux", "kinetic_stress", "contact_stress", "boundary_stress",
          "interaction_force_density", "body_force_density", "extended_stress", "volume_fraction")


def fields_of(snap, grid, kernel=cg.Gaussian(0.5, cutoff=2.0), fields=FIELDS):
    return cg.coarse_grain(snap, grid, kernel, fields=fields)


def rebuild(snap, **changes):
    c = snap.contacts
    args = dict(positions=snap.positions, velocities=snap.velocities, masses=snap.masses, box=snap.box,
                contacts=cg.Contacts(c.i, c.j, c.force, c.point), fixed=snap.fixed, species=snap.species,
                body_force=snap.body_force, radii=snap.radii, time=snap.time)
    args.update(changes)
    return cg.Snapshot(**args)


def assert_same_fields(a, b, fields=FIELDS, rtol=1e-12):
    for name in fields:
        assert_fields_close(a[name], b[name], rtol, name)


def test_relabelling_particles_changes_nothing():
    snap = random_snapshot(13, dim=3)
    grid = cg.Grid(snap.box, (5, 4, 6))
    perm = np.random.default_rng(0).permutation(snap.n_particles)
    inverse = np.argsort(perm)
    c = snap.contacts
    j = np.where(c.j >= 0, inverse[np.maximum(c.j, 0)], -1)
    relabelled = rebuild(snap, positions=snap.positions[perm], velocities=snap.velocities[perm],
                         masses=snap.masses[perm], fixed=snap.fixed[perm], radii=snap.radii[perm],
                         body_force=snap.body_force[perm],
                         contacts=cg.Contacts(inverse[c.i], j, c.force, c.point))
    assert_same_fields(fields_of(snap, grid), fields_of(relabelled, grid))


def test_listing_contacts_as_j_i_minus_f_changes_nothing():
    snap = random_snapshot(14, dim=3)
    grid = cg.Grid(snap.box, (5, 4, 6))
    c = snap.contacts
    flip = c.j >= 0
    flipped = cg.Contacts(np.where(flip, c.j, c.i), np.where(flip, c.i, c.j), np.where(flip[:, None], -c.force, c.force),
                          c.point)
    assert_same_fields(fields_of(snap, grid), fields_of(rebuild(snap, contacts=flipped), grid))


def test_translation_changes_nothing():
    snap = random_snapshot(15, dim=3)
    shift = np.array([0.37, -1.25, 2.5])
    box = cg.Box(snap.box.lower + shift, snap.box.upper + shift, periodic=snap.box.periodic)
    c = snap.contacts
    moved = rebuild(snap, positions=snap.positions + shift, box=box,
                    contacts=cg.Contacts(c.i, c.j, c.force, c.point + shift))
    assert_same_fields(fields_of(snap, cg.Grid(snap.box, (5, 4, 6))), fields_of(moved, cg.Grid(box, (5, 4, 6))))


def rotation(seed):
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def test_rotation_rotates_vectors_and_tensors():
    snap = random_snapshot(16, dim=3, periodic=(False, False, False))
    Q = rotation(1)
    centre = 0.5 * (snap.box.lower + snap.box.upper)
    rot = lambda x: (x - centre) @ Q.T + centre
    c = snap.contacts
    big = cg.Box(centre - 20, centre + 20)
    rotated = rebuild(snap, positions=rot(snap.positions), velocities=snap.velocities @ Q.T, box=big,
                      body_force=snap.body_force @ Q.T, contacts=cg.Contacts(c.i, c.j, c.force @ Q.T, rot(c.point)))
    original = rebuild(snap, box=big)
    pts = random_points(snap, 40, 7)
    a = fields_of(original, cg.Points(pts))
    b = fields_of(rotated, cg.Points(rot(pts)))
    for name in FIELDS:
        rank = cg.FIELDS[name][0]
        expected = a[name]
        if rank == 1:
            expected = expected @ Q.T
        elif rank == 2:
            expected = np.einsum("ab,pbc,dc->pad", Q, expected, Q)
        assert_fields_close(b[name], expected, 1e-12, name)


@pytest.mark.parametrize("dim", [2, 3])
def test_galilean_invariance_with_huge_mean_velocity(dim):
    """Adding U = 1e8 |v'| leaves the kinetic stress unchanged to 1e-9 (inputs chosen exactly representable)."""
    snap = random_snapshot(17, dim=dim)
    rng = np.random.default_rng(3)
    v = np.round(rng.normal(size=snap.velocities.shape) * 2**16) / 2**16   # 16 fractional bits
    U = np.zeros(dim)
    U[0] = 2.0**27   # ~1.3e8; U + v is exact in float64
    U[-1] = -(2.0**26)
    grid = cg.Grid(snap.box, (5, 4, 6)[:dim] if dim == 3 else (7, 9))
    kernel = cg.Lucy(1.5)
    slow = cg.coarse_grain(rebuild(snap, velocities=v), grid, kernel, fields=("kinetic_stress", "temperature"))
    fast = cg.coarse_grain(rebuild(snap, velocities=v + U), grid, kernel, fields=("kinetic_stress", "temperature"))
    assert np.all(v + U - U == v)
    assert_fields_close(fast.kinetic_stress, slow.kinetic_stress, 1e-9, "kinetic stress")
    assert_fields_close(fast.temperature, slow.temperature, 1e-9, "temperature")


# --- 7. averaging commutes ----------------------------------------------------------

LINEAR = ("density", "momentum", "momentum_flux", "contact_stress", "boundary_stress",
          "interaction_force_density", "body_force_density")


@pytest.mark.parametrize("dim", [2, 3])
def test_profile_equals_mean_of_the_full_field(dim):
    snap = random_snapshot(18, dim=dim)
    w = 0.45
    kernel = cg.Gaussian(w, cutoff=10 * w)
    n = [int(math.ceil(L / (w / 3))) for L in snap.box.lengths]
    full = cg.coarse_grain(snap, cg.Grid(snap.box, tuple(n)), kernel, fields=LINEAR)
    avg = ("x", "y") if dim == 3 else ("x",)
    profile = cg.coarse_grain(snap, cg.Grid(snap.box, tuple([1] * (dim - 1) + [n[-1]]), average=avg), kernel,
                              fields=LINEAR)
    for name in LINEAR:
        mean = full[name].mean(axis=tuple(range(dim - 1)), keepdims=True)
        assert_fields_close(profile[name], mean, 1e-12, name)


def test_lucy_profile_equals_exact_plane_average():
    """For Lucy the profile uses the exact marginal (not the 1-D Lucy kernel): compare
    with the x,y average computed by dense Gauss-Legendre quadrature of the 3D field."""
    snap = random_snapshot(19, dim=3, n_bulk=3, n_fixed_contacts=2, n_wall=1)
    kernel = cg.Lucy(1.1)
    box = snap.box
    grid = cg.Grid(box, (1, 1, 40), average=("x", "y"))
    profile = cg.coarse_grain(snap, grid, kernel, fields=("density", "contact_stress"))
    zc = grid.axis_coordinates[2][[5, 12, 20, 27]]
    # plane average by a tensor Gauss-Legendre rule on a fine panel partition of the periodic cell
    x, wx = np.polynomial.legendre.leggauss(8)
    nx = 40
    def rule(lo, L):
        edges = lo + np.linspace(0, L, nx + 1)
        pts = (0.5 * (edges[1:] + edges[:-1])[:, None] + 0.5 * np.diff(edges)[:, None] * x).ravel()
        wts = (0.5 * np.diff(edges)[:, None] * wx).ravel()
        return pts, wts
    px, wxs = rule(box.lower[0], box.lengths[0])
    py, wys = rule(box.lower[1], box.lengths[1])
    X, Y = np.meshgrid(px, py, indexing="ij")
    W = np.outer(wxs, wys).ravel()
    for k, zz in zip([5, 12, 20, 27], zc):
        pts = np.stack([X.ravel(), Y.ravel(), np.full(X.size, zz)], axis=1)
        field = cg.coarse_grain(snap, cg.Points(pts), kernel, fields=("density",))
        mean = (field.density * W).sum() / W.sum()
        assert mean == pytest.approx(profile.density[0, 0, k], rel=2e-6)


# --- periodic shift ---------------------------------------------------------------

@pytest.mark.parametrize("axis", [0, 1])
def test_half_box_shift_along_a_periodic_axis_moves_the_fields(axis):
    snap = random_snapshot(20, dim=3)
    shape = (6, 4, 5)
    L = snap.box.lengths[axis]
    shift = np.zeros(3)
    shift[axis] = 0.5 * L
    c = snap.contacts
    moved = rebuild(snap, positions=snap.positions + shift, contacts=cg.Contacts(c.i, c.j, c.force, c.point + shift))
    grid = cg.Grid(snap.box, shape)
    a, b = fields_of(snap, grid), fields_of(moved, grid)
    for name in FIELDS:
        assert_fields_close(b[name], np.roll(a[name], shape[axis] // 2, axis=axis), 1e-12, name)
    profile = cg.Grid(snap.box, (1, 1, 8), average=("x", "y"))
    assert_same_fields(fields_of(snap, profile), fields_of(moved, profile))
