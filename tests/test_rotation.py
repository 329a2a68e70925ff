"""Rotation: spin density, spin flux, couple stress, the torque densities and the angular momentum balance
(docs/theory.md, "Rotation and couple stress").

The fields against their oracle twin (oracle_rotation); the balance residual at random points on random,
unbalanced data (round-off small, and clearly not when a term is dropped); invariance under listing a
contact as (j, i, -f); the volume integral of the couple stress and spin density over a periodic box
against the discrete sums; input checks before any work.
"""
import os
import shutil
import subprocess

import numpy as np
import pytest

import cgbound
import cgbound as cg
from cgbound.rotation import ROTATION_FIELDS, contact_torques
from helpers import ForbiddenCore, assert_fields_close, random_snapshot
from oracle import oracle_rotation

KERNELS = {"lucy": cg.Lucy(1.3), "gaussian": cg.Gaussian(0.45, cutoff=1.6), "heaviside": cg.Heaviside(1.1)}
# a Gaussian whose cut-off jump (8 widths: exp(-32) = 1e-14) is below round-off: its gradient is the field's
SMOOTH_GAUSSIAN = cg.Gaussian(0.4, cutoff=8 * 0.4)
BALANCE_KERNELS = {"lucy": cg.Lucy(1.3), "gaussian-8w": SMOOTH_GAUSSIAN}


def spinning(snap, seed, inertia=False):
    """``snap`` with random angular velocities (and moments of inertia when asked)."""
    rng = np.random.default_rng(seed + 1000)
    n, dim = snap.n_particles, snap.dim
    omega = rng.normal(size=(n, 3)) if dim == 3 else rng.normal(size=n)
    return cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box, contacts=snap.contacts,
                       fixed=snap.fixed, body_force=None if snap.body_force is None else snap.body_force[0],
                       radii=snap.radii, angular_velocities=omega,
                       moments_of_inertia=rng.uniform(0.1, 0.3, n) if inertia else None)


def small_snapshot(seed, dim, periodic=None, **kw):
    return spinning(random_snapshot(seed, dim=dim, n=10, n_fixed=3, n_bulk=6, n_fixed_contacts=3, n_wall=2,
                                    periodic=periodic, outside=True, **kw), seed)


def flat(value, expected):
    return np.reshape(value, expected.shape)


# ---------------------------------------------------------------------------------------------------------
# fields against the oracle

TARGETS = [(2, "points"), (2, ()), (2, ("x",)), (3, "points"), (3, ()), (3, ("y",)), (3, ("x", "y"))]


def target_for(snap, layout, seed):
    if layout == "points":
        rng = np.random.default_rng(seed)
        return cg.Points(snap.box.lower + rng.uniform(-0.1, 1.1, (9, snap.dim)) * snap.box.lengths)
    shape = list((4, 5, 3) if snap.dim == 3 else (4, 5))
    names = snap.box.axis_names
    for axis in layout:
        shape[names.index(axis)] = 1
    return cg.Grid(snap.box, tuple(shape), average=layout)


@pytest.mark.parametrize("kname", sorted(KERNELS))
@pytest.mark.parametrize("dim, layout", TARGETS)
def test_fields_match_the_oracle(kname, dim, layout):
    kernel = KERNELS[kname]
    snap = small_snapshot(3 + dim, dim)
    where = target_for(snap, layout, 7)
    got = cg.rotation_fields(snap, where, kernel)
    want = oracle_rotation(snap, where, kernel, ROTATION_FIELDS)
    for name in ROTATION_FIELDS:
        assert got[name].shape[:len(where.field_shape)] == where.field_shape
        assert_fields_close(flat(got[name], want[name]), want[name], 1e-11, f"{name} {kname} {dim}D {layout}")
        assert np.any(want[name] != 0), f"{name}: the comparison must not be of zeros"


@pytest.mark.parametrize("dim", [2, 3])
def test_given_moments_of_inertia_and_shapes(dim):
    snap = spinning(random_snapshot(5, dim=dim, n=10, n_fixed=3, n_bulk=6, n_fixed_contacts=3, n_wall=2), 5,
                    inertia=True)
    where = cg.Points(snap.box.lower + 0.5 * snap.box.lengths + np.zeros((3, dim)))
    got = cg.rotation_fields(snap, where, cg.Lucy(2.0), ("spin_density", "spin_flux", "couple_stress"))
    want = oracle_rotation(snap, where, cg.Lucy(2.0), ("spin_density", "spin_flux", "couple_stress"),
                           inertia=snap.moments_of_inertia)
    T = (3,) if dim == 3 else ()
    assert got["spin_density"].shape == (3,) + T
    assert got["spin_flux"].shape == (3,) + T + (dim,)
    assert got["couple_stress"].shape == (3,) + T + (dim,)
    for name in got:
        assert_fields_close(flat(got[name], want[name]), want[name], 1e-12, name)


def test_two_d_pseudo_vectors_accept_a_column():
    snap = small_snapshot(8, 2)
    column = cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box, contacts=snap.contacts,
                         fixed=snap.fixed, radii=snap.radii, angular_velocities=snap.angular_velocities[:, None],
                         torques=snap.angular_velocities[:, None])
    assert column.angular_velocities.shape == (snap.n_particles,)
    assert column.torques.shape == (snap.n_particles,)
    where = cg.Points(snap.positions[:4])
    a = cg.rotation_fields(snap, where, cg.Lucy(1.3), "spin_density")["spin_density"]
    b = cg.rotation_fields(column, where, cg.Lucy(1.3), "spin_density")["spin_density"]
    assert np.array_equal(a, b)


# ---------------------------------------------------------------------------------------------------------
# the angular momentum balance

def random_points(snap, seed, n=60):
    rng = np.random.default_rng(seed)
    return snap.box.lower + rng.uniform(0, 1, (n, snap.dim)) * snap.box.lengths


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("kname", sorted(BALANCE_KERNELS))
@pytest.mark.parametrize("dim", [2, 3])
def test_balance_residual_is_round_off(dim, kname, seed):
    snap = spinning(random_snapshot(seed, dim=dim), seed)
    bal = cg.angular_momentum_balance_residual(snap, random_points(snap, seed), BALANCE_KERNELS[kname])
    assert bal.relative.max() <= 1e-10, bal
    # unbalanced data: every term is there, and the particles' torques do not sum to zero
    for name in bal.TERMS[:4]:
        assert np.abs(getattr(bal, name)).max() > 1e-3 * bal.scale, name
    assert np.abs(contact_torques(snap)[snap.flowing].sum(axis=0)).max() > 1e-3


@pytest.mark.parametrize("kname", sorted(BALANCE_KERNELS))
@pytest.mark.parametrize("dim", [2, 3])
def test_dropping_a_term_breaks_the_balance(dim, kname):
    snap = spinning(random_snapshot(11, dim=dim), 11)
    bal = cg.angular_momentum_balance_residual(snap, random_points(snap, 11), BALANCE_KERNELS[kname])
    for name in ("div_couple_stress", "stress_torque_density", "boundary_couple_density"):
        without = bal.residual + getattr(bal, name)
        assert (np.linalg.norm(without, axis=1) / bal.scale).max() > 1e-3, name


@pytest.mark.parametrize("dim", [2, 3])
def test_external_and_dumped_torques(dim):
    snap = spinning(random_snapshot(21, dim=dim), 21)
    pts = random_points(snap, 21)
    rng = np.random.default_rng(2)
    ext = rng.normal(size=(snap.n_particles, 3)) if dim == 3 else rng.normal(size=snap.n_particles)
    total = contact_torques(snap) + ext
    kernel = cg.Lucy(1.3)
    # the external torque density is a term of the balance
    assert cg.angular_momentum_balance_residual(snap, pts, kernel, external_torques=ext).relative.max() <= 1e-10
    assert cg.angular_momentum_balance_residual(snap, pts, kernel, torques=total,
                                                external_torques=ext).relative.max() <= 1e-10
    # dumped torques that include a torque the balance is not told about: clearly not balanced
    assert cg.angular_momentum_balance_residual(snap, pts, kernel, torques=total).relative.max() > 1e-3
    dumped = cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box, contacts=snap.contacts,
                         fixed=snap.fixed, torques=contact_torques(snap))
    assert cg.angular_momentum_balance_residual(dumped, pts, kernel,
                                                torques=dumped.torques).relative.max() <= 1e-10


# ---------------------------------------------------------------------------------------------------------
# identities

def flipped(snap, seed):
    """The same snapshot with about half the contacts listed as (j, i, -f) (wall contacts stay)."""
    c = snap.contacts
    rng = np.random.default_rng(seed)
    flip = (rng.random(len(c)) < 0.5) & (c.j >= 0)
    flip[np.flatnonzero(c.j >= 0)[0]] = True
    i = np.where(flip, c.j, c.i)
    j = np.where(flip, c.i, c.j)
    f = np.where(flip[:, None], -c.force, c.force)
    return cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box,
                       contacts=cg.Contacts(i, j, f, c.point), fixed=snap.fixed, radii=snap.radii,
                       angular_velocities=snap.angular_velocities)


@pytest.mark.parametrize("dim", [2, 3])
def test_listing_a_contact_as_j_i_minus_f_changes_nothing(dim):
    snap = spinning(random_snapshot(31, dim=dim), 31)
    other = flipped(snap, 31)
    where = cg.Points(random_points(snap, 31, 25))
    a = cg.rotation_fields(snap, where, cg.Lucy(1.3))
    b = cg.rotation_fields(other, where, cg.Lucy(1.3))
    for name in ROTATION_FIELDS:
        assert_fields_close(b[name], a[name], 1e-13, name)
    assert np.allclose(contact_torques(other), contact_torques(snap), rtol=0, atol=1e-14)
    assert cg.angular_momentum_balance_residual(other, where, cg.Lucy(1.3)).relative.max() <= 1e-10


@pytest.mark.parametrize("dim", [2, 3])
def test_volume_integrals_over_a_periodic_box_are_the_discrete_sums(dim):
    """int m dV = -sum over contact halves of tau (x) a, int s dV = sum_i I_i w_i: the Gaussian is smooth and
    periodic, so the midpoint rule on a grid is exact to round-off."""
    lengths = np.array([4.0, 3.5, 5.0][:dim]) if dim == 3 else np.array([4.0, 5.0])
    snap = spinning(random_snapshot(41, dim=dim, periodic=(True,) * dim, lengths=lengths), 41)
    kernel = cg.Gaussian(0.45, cutoff=8 * 0.45)
    shape = tuple(int(round(x / 0.1)) for x in lengths)
    grid = cg.Grid(snap.box, shape)
    got = cg.rotation_fields(snap, grid, kernel, ("couple_stress", "spin_density", "stress_torque_density",
                                                  "boundary_couple_density"))
    cell = float(np.prod(lengths)) / np.prod(shape)
    axes = tuple(range(dim))
    # the discrete sums, contact by contact
    T = 3 if dim == 3 else 1
    m_sum, pair_sum, wall_sum = np.zeros((T, dim)), np.zeros(T), np.zeros(T)
    X, c, L = snap.positions, snap.contacts, np.asarray(snap.box.lengths)

    def cross(a, b):
        return np.cross(a, b) if dim == 3 else np.array([a[0] * b[1] - a[1] * b[0]])

    def image(v):
        return v - L * np.round(v / L)

    for k in range(len(c)):
        i, j, f, p = int(c.i[k]), int(c.j[k]), c.force[k], c.point[k]
        fi, fj = snap.fixed[i], (j < 0 or snap.fixed[j])
        if fi and fj:
            continue
        if fi:
            i, f = j, -f
        a_i = image(X[i] - p)
        halves = [(f, a_i)]
        if not fi and not fj:
            halves.append((-f, image(X[j] - (X[i] - a_i))))
            pair_sum += cross(f, image(X[i] - X[j]))
        else:
            wall_sum += cross(-a_i, f)
        for fh, a in halves:
            m_sum -= np.outer(cross(-a, fh), a)
    spin_sum = ((0.4 if dim == 3 else 0.5) * snap.masses * snap.radii ** 2)[snap.flowing, None] \
        * np.reshape(snap.angular_velocities, (snap.n_particles, T))[snap.flowing]
    for name, want in (("couple_stress", m_sum), ("spin_density", spin_sum.sum(axis=0)),
                       ("stress_torque_density", pair_sum), ("boundary_couple_density", wall_sum)):
        integral = got[name].sum(axis=axes) * cell
        assert_fields_close(np.reshape(integral, want.shape), want, 1e-10, name)


# ---------------------------------------------------------------------------------------------------------
# bad input, refused by name before any work

@pytest.fixture
def no_work(monkeypatch):
    monkeypatch.setattr(cgbound._engine, "_core", ForbiddenCore(cgbound._engine._core))


def test_snapshot_refuses_bad_rotational_data():
    snap = random_snapshot(1, dim=3, n=6, n_fixed=2, n_bulk=2, n_fixed_contacts=1, n_wall=1)
    args = (snap.positions, snap.velocities, snap.masses)
    with pytest.raises(ValueError, match="angular_velocities"):
        cg.Snapshot(*args, angular_velocities=np.zeros((6, 2)))
    with pytest.raises(ValueError, match="angular_velocities"):
        cg.Snapshot(*args, angular_velocities=np.full((6, 3), np.nan))
    with pytest.raises(ValueError, match="torques"):
        cg.Snapshot(*args, torques=np.zeros(6))
    with pytest.raises(ValueError, match="moments_of_inertia"):
        cg.Snapshot(*args, moments_of_inertia=-np.ones(6))
    with pytest.raises(ValueError, match="moments_of_inertia"):
        cg.Snapshot(*args, moments_of_inertia=np.ones(5))
    with pytest.raises(ValueError, match="angular_velocities"):
        cg.Snapshot(snap.positions[:, :2], None, snap.masses, angular_velocities=np.zeros((6, 3)))


def test_rotation_fields_refuse_missing_data_before_work(no_work):
    snap = random_snapshot(2, dim=3, n=8, n_fixed=2, n_bulk=3, n_fixed_contacts=1, n_wall=1, radii=False)
    where = cg.Points(snap.positions[:2])
    with pytest.raises(ValueError, match="snapshot.angular_velocities"):
        cg.rotation_fields(snap, where, cg.Lucy(1.0), "spin_density")
    spin = cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box,
                       angular_velocities=np.ones((8, 3)))
    with pytest.raises(ValueError, match="moments_of_inertia: expected moments of inertia, or radii"):
        cg.rotation_fields(spin, where, cg.Lucy(1.0), "angular_momentum_density")
    with pytest.raises(ValueError, match="fields: expected some of"):
        cg.rotation_fields(spin, where, cg.Lucy(1.0), "stress")
    with pytest.raises(ValueError, match="kernel: expected a differentiable kernel"):
        cg.angular_momentum_balance_residual(spin, where, cg.Heaviside(1.0))
    with pytest.raises(TypeError, match="points: expected cg.Points"):
        cg.angular_momentum_balance_residual(spin, cg.Grid(spin.box, (2, 2, 2)), cg.Lucy(1.0))
    with pytest.raises(ValueError, match="torques"):
        cg.angular_momentum_balance_residual(spin, where, cg.Lucy(1.0), torques=np.ones((8, 2)))
    with pytest.raises(ValueError, match="external_torques"):
        cg.angular_momentum_balance_residual(spin, where, cg.Lucy(1.0), external_torques=np.ones(8))


# ---------------------------------------------------------------------------------------------------------
# readers

def test_mercury_data_angular_velocities(tmp_path):
    """MercuryDPM's .data columns wx wy wz (3D) and omega (2D) become Snapshot.angular_velocities."""
    from cgbound.readers.mercury import MercuryReader
    from test_mercury_reader import DATA3, FSTAT3, RESTART3, write
    f = write(tmp_path, **{"a.data": DATA3, "a.fstat": FSTAT3, "a.restart": RESTART3})
    snap = MercuryReader(f["a.data"], f["a.fstat"], restart_path=f["a.restart"])[1]
    np.testing.assert_array_equal(snap.angular_velocities, [[0, 0, 0], [1, 2, 3], [0, 0, 0]])
    data2 = "2 0.5 -1 0 2 2\n0 0.45 1 -1 0.5 0.3 -2.5 0\n0.9 0.45 0 0 0.5 0 4 1\n"
    g = write(tmp_path, **{"c.data": data2})
    snap2 = MercuryReader(g["c.data"], density=1.0)[0]
    np.testing.assert_array_equal(snap2.angular_velocities, [-2.5, 4.0])
    spin = cg.rotation_fields(snap2, cg.Points(snap2.positions), cg.Lucy(2.0), "spin_density")["spin_density"]
    assert spin.shape == (2,) and np.all(np.isfinite(spin))


@pytest.mark.parametrize("dim", [2, 3])
def test_fields_scale_with_the_units_as_their_dimension_says(dim):
    """The same data in units 2, 4 and 1/2 times smaller (length, mass, time) multiplies each rotational
    field by 2^L 4^M (1/2)^T, the exponents of cgbound.units.DIMENSIONS."""
    from cgbound import units as cu
    snap = spinning(random_snapshot(51, dim=dim), 51)
    a, b, c = 2.0, 4.0, 0.5
    con = snap.contacts
    big = cg.Snapshot(snap.positions * a, snap.velocities * a / c, snap.masses * b,
                      box=cg.Box(snap.box.lower * a, snap.box.upper * a, periodic=snap.box.periodic),
                      contacts=cg.Contacts(con.i, con.j, con.force * b * a / c ** 2, con.point * a),
                      fixed=snap.fixed, radii=snap.radii * a, angular_velocities=snap.angular_velocities / c)
    pts = random_points(snap, 51, 20)
    out = cg.rotation_fields(snap, cg.Points(pts), cg.Lucy(1.3))
    out_big = cg.rotation_fields(big, cg.Points(pts * a), cg.Lucy(1.3 * a))
    for name in ROTATION_FIELDS:
        m, length, t = cu.dimension(name, dim)
        expected = out[name] * b ** m * a ** length * c ** t
        np.testing.assert_allclose(out_big[name], expected, rtol=1e-10, atol=1e-12 * np.abs(expected).max(),
                                   err_msg=name)


SPIN3D = os.path.join(os.path.dirname(__file__), "data", "lammps")


@pytest.fixture(scope="module")
def spin3d_dir(tmp_path_factory):
    """tests/data/lammps/in.spin3d run afresh when ``lmp`` is on PATH, else its committed dumps."""
    lmp = shutil.which("lmp")
    if lmp is None:
        return os.path.join(SPIN3D, "spin3d")
    work = tmp_path_factory.mktemp("spin3d")
    proc = subprocess.run([lmp, "-in", os.path.join(SPIN3D, "in.spin3d"), "-log", "none", "-screen", "none"],
                          cwd=work, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0 and (work / "atoms.dump").exists(), proc.stdout[-2000:] + proc.stderr[-2000:]
    return str(work)


def test_lammps_pair_torques_are_the_contact_torques(spin3d_dir):
    """Genuine LAMMPS (pair granular, Mindlin tangential): the dumped omega and tq columns reach the snapshot, and
    for every particle without a wall contact the dumped torque is sum_j (c_ij - r_i) x f_ij with the reader's
    contact points, to round-off. (fix wall/gran puts its lever arm at the radius R, the reader's wall contact
    point is on the wall surface at R - delta: there the two differ by design.)"""
    from cgbound.readers import LammpsReader
    values = ("dist", "fx", "fy", "fz") + tuple(f"p{k}" for k in range(1, 13))
    reader = LammpsReader(os.path.join(spin3d_dir, "atoms.dump"), os.path.join(spin3d_dir, "pairs.dump"),
                          pair_style="granular", pair_values=values, body_force=(0.0, 0.0, -1.0), walls=["w"],
                          fixed_types=[2])
    checked = 0
    for snap in reader:
        assert snap.angular_velocities.shape == (snap.n_particles, 3) and snap.torques.shape == (snap.n_particles, 3)
        assert np.abs(snap.angular_velocities[snap.flowing]).max() > 0
        c = snap.contacts
        on_wall = np.zeros(snap.n_particles, bool)
        on_wall[c.i[c.j < 0]] = True
        pair_only = snap.flowing & ~on_wall
        got = contact_torques(snap)
        scale = np.abs(snap.torques[snap.flowing]).max()
        assert np.abs(got[pair_only] - snap.torques[pair_only]).max() <= 1e-9 * scale
        assert np.abs(snap.torques[pair_only]).max() > 1e-3 * scale
        checked += int(pair_only.sum())
        pts = snap.box.lower + np.random.default_rng(0).uniform(0, 1, (30, 3)) * snap.box.lengths
        pts[:, 2] = np.linspace(0.2, 3.0, 30)
        assert cg.angular_momentum_balance_residual(snap, pts, cg.Lucy(1.5)).relative.max() <= 1e-10
    assert checked > 100


def test_a_couple_stress_that_would_overflow_is_refused(no_work):
    """force x branch within range, torque x branch (force x branch^2) not: refused by name, not inf."""
    pos = np.array([[0.0, 0.0, 0.0], [1e110, 0.0, 0.0]])
    snap = cg.Snapshot(pos, None, [1.0, 1.0], contacts=cg.Contacts([0], [1], [[0.0, 1e90, 0.0]], [[5e109, 0, 0]]))
    fine = cg.Snapshot(pos, None, [1.0, 1.0], contacts=cg.Contacts([0], [1], [[0.0, 1e60, 0.0]], [[5e109, 0, 0]]))
    with pytest.raises(ValueError, match="snapshot"):
        cg.rotation_fields(snap, cg.Points(pos), cg.Lucy(1.0), "couple_stress")
    with pytest.raises(AssertionError, match="ran before"):        # the same request on fine data does work
        cg.rotation_fields(fine, cg.Points(pos), cg.Lucy(1.0), "couple_stress")
    with pytest.raises(ValueError, match="snapshot"):
        cg.angular_momentum_balance_residual(snap, cg.Points(pos), cg.Lucy(1.0))


def test_lammps_2d_takes_the_z_columns(tmp_path):
    """A 2D (x-y) LAMMPS dump: omegaz and tqz become the out-of-plane angular velocity and torque; a dump with
    only some of the 3D columns is refused by name."""
    from cgbound.readers import LammpsReader
    src = os.path.join(SPIN3D, "hooke2d")
    lines = open(os.path.join(src, "atoms.dump")).read().splitlines()
    out, in_atoms = [], False
    for line in lines:
        if line.startswith("ITEM: ATOMS"):
            out.append(line + " omegax omegaz tqz")
            in_atoms = True
            continue
        if line.startswith("ITEM:"):
            in_atoms = False
        elif in_atoms:
            atom = int(line.split()[0])
            line += f" 9 {0.5 * atom} {-atom}"
        out.append(line)
    path = tmp_path / "atoms.dump"
    path.write_text("\n".join(out) + "\n")
    values = ("dist", "fx", "fy", "fz") + tuple(f"p{k}" for k in range(1, 13))
    reader = LammpsReader(str(path), os.path.join(src, "pairs.dump"), pair_style="granular", pair_values=values,
                          body_force=(0.0, -1.0), dimension=2, walls=["w"], fixed_types=[2])
    frame = reader.frame(0)
    snap, ids = frame.snapshot, frame.ids
    np.testing.assert_array_equal(snap.angular_velocities, 0.5 * ids)
    np.testing.assert_array_equal(snap.torques, -ids.astype(float))
    # in 2D only the z columns count: tqx alone is no torque
    only_x = tmp_path / "only_x.dump"
    only_x.write_text(path.read_text().replace(" omegax omegaz tqz", " omegax omegaz tqx"))
    assert LammpsReader(str(only_x), os.path.join(src, "pairs.dump"), pair_style="granular", pair_values=values,
                        body_force=(0.0, -1.0), dimension=2, walls=["w"], fixed_types=[2])[0].torques is None
    # in 3D a partial set of columns is refused by name
    dump3 = open(os.path.join(SPIN3D, "spin3d", "atoms.dump")).read().replace(" omegay ", " omegaq ")
    broken = tmp_path / "partial3d.dump"
    broken.write_text(dump3)
    with pytest.raises(ValueError, match=r"angular velocities need columns \['omegay'\]"):
        LammpsReader(str(broken), os.path.join(SPIN3D, "spin3d", "pairs.dump"), pair_style="granular",
                     pair_values=values, body_force=(0.0, 0.0, -1.0), walls=["w"], fixed_types=[2])[0]
