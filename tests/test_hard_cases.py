"""Hard cases of docs/theory.md ("Hard cases and bad input"), each against a 50-digit mpmath reference or an exact value.

Each test asserts 1e-12 relative agreement (relative to the value itself, or to the
field's scale where the value is near zero) and the absence of NaN/Inf, and records
the error it reached; the table is printed at the end of the pytest run.
"""
import math
import warnings

import mpmath as mp
import numpy as np
import pytest

import cgbound as cg
from cgbound.fields import PER_PARTICLE_FIELDS
from cgbound.fields import NAN_WITHOUT_MATTER, PRESSURE_RATIO_FIELDS
from cgbound.rotation import SPIN_FIELDS
from stability_log import record

mp.mp.dps = 50
RTOL = 1e-12


# --- 50-digit references for the Gaussian ------------------------------------------

def mp_gauss(r2, w, R, n):
    """Gaussian marginal in n resolved dimensions at squared distance r2 (mpf), cut at R."""
    if r2 >= mp.mpf(R) ** 2:
        return mp.mpf(0)
    w = mp.mpf(w)
    return mp.exp(-r2 / (2 * w * w)) / (2 * mp.pi * w * w) ** (mp.mpf(n) / 2)


def mp_psi(q, e, w, R, ray=False):
    """int_0^1 (or ^inf) W(q - s e) ds for the cut Gaussian, exact erf form in 50 digits.
    q, e are sequences of floats (taken exactly)."""
    q = [mp.mpf(float(x)) for x in q]
    e = [mp.mpf(float(x)) for x in e]
    n = len(q)
    w, R = mp.mpf(w), mp.mpf(R)
    L = mp.sqrt(sum(x * x for x in e))
    if L == 0:
        return mp_gauss(sum(x * x for x in q), w, R, n)
    u = sum(a * b for a, b in zip(q, e)) / L
    a2 = sum((qa - u * ea / L) ** 2 for qa, ea in zip(q, e))
    if a2 >= R * R:
        return mp.mpf(0)
    b = mp.sqrt(R * R - a2)
    t_hi = min(u, b)
    t_lo = -b if ray else max(u - L, -b)
    if t_lo >= t_hi:
        return mp.mpf(0)
    s2w = mp.sqrt(2) * w
    x_hi, x_lo = t_hi / s2w, t_lo / s2w
    if x_lo >= 0:      # erfc keeps every digit of tiny brackets (mpmath too has finite precision)
        bracket = mp.erfc(x_lo) - mp.erfc(x_hi)
    elif x_hi <= 0:
        bracket = mp.erfc(-x_hi) - mp.erfc(-x_lo)
    else:
        bracket = mp.erf(x_hi) - mp.erf(x_lo)
    return (mp.exp(-a2 / (2 * w * w)) / (2 * mp.pi * w * w) ** (mp.mpf(n) / 2)
            * (w / L) * mp.sqrt(mp.pi / 2) * bracket)


def rel_error(actual, expected, scale=None):
    """max |a - e| / scale, scale = max |e| unless given; NaN/Inf fail."""
    actual = np.asarray(actual, float)
    expected = np.asarray(expected, float)
    assert np.all(np.isfinite(actual)), "NaN or Inf in the result"
    if scale is None:
        scale = np.max(np.abs(expected))
    err = np.max(np.abs(actual - expected)) if actual.size else 0.0
    return float(err / scale) if scale > 0 else float(err)


def boundary_snapshot(particle, point, force, box, mass=1.0):
    """One flowing particle touching a wall at `point`."""
    dim = len(particle)
    return cg.Snapshot(np.array([particle], float), np.zeros((1, dim)), [mass], box=box,
                       contacts=cg.Contacts([0], [-1], [force], [point]))


def psi_of_boundary_stress(out, force, branch):
    """Recover psi from sigma^w = -f (x) a psi via the largest component."""
    tensor = -np.outer(force, branch)
    a, b = np.unravel_index(np.argmax(np.abs(tensor)), tensor.shape)
    return out.boundary_stress[..., a, b] / tensor[a, b]


# --- zero-length and nearly zero-length branches --------------------------------------

@pytest.mark.parametrize("ratio", [0.0, 1e-16, 1e-13, 1e-10, 1e-7, 1e-5, 1e-3])
def test_nearly_zero_length_branch(ratio):
    w = 0.3
    R = 8 * w
    box = cg.Box([-2, -2, -2], [2, 2, 2])
    particle = np.array([0.11, -0.07, 0.05])
    direction = np.array([0.6, -0.64, 0.48])
    point = particle + ratio * w * direction     # contact point at (or next to) the centre
    force = np.array([0.3, -0.2, 1.0])
    snap = boundary_snapshot(particle, point, force, box)
    rng = np.random.default_rng(1)
    pts = particle + rng.normal(scale=w, size=(12, 3))
    out = cg.coarse_grain(snap, cg.Points(pts), cg.Gaussian(w, cutoff=R),
                          fields=("boundary_stress", "interaction_force_density"))
    branch = snap.positions[0] - point          # a = r_i - c
    # IFD: f W(r - c), exact
    t_ref = np.array([[float(mp_gauss(sum((mp.mpf(float(p[d])) - mp.mpf(float(point[d]))) ** 2 for d in range(3)), w, R, 3)) * f
                       for f in force] for p in pts])
    err_t = rel_error(out.interaction_force_density, t_ref)
    assert err_t <= RTOL
    if ratio == 0.0:
        assert np.all(out.boundary_stress == 0.0)
        record("zero-length branch (c = r_i)", err_t)
        return
    psi = psi_of_boundary_stress(out, force, branch)
    psi_ref = np.array([float(mp_psi(p - particle, -branch, w, R)) for p in pts])
    err = rel_error(psi, psi_ref)
    assert err <= RTOL
    record(f"nearly zero-length branch, L/w = {ratio:g}", max(err, err_t))


# --- segments almost perpendicular to the resolved axis of a profile --------------------

@pytest.mark.parametrize("tilt", [0.0, 1e-15, 1e-12, 1e-9, 1e-6])
def test_segment_almost_perpendicular_to_a_profile(tilt):
    """A Z profile of a branch lying (almost) in the x,y plane: its z extent is tilt * L."""
    w = 0.2
    R = 8 * w
    box = cg.Box([0, 0, 0], [4, 4, 4], periodic=(True, True, False))
    particle = np.array([1.0, 2.0, 2.013])
    e = np.array([0.45, -0.3, tilt])
    point = particle + e
    force = np.array([0.2, 0.1, -1.0])
    snap = boundary_snapshot(particle, point, force, box)
    grid = cg.Grid(box, (1, 1, 80), average=("x", "y"))
    out = cg.coarse_grain(snap, grid, cg.Gaussian(w, cutoff=R), fields=("boundary_stress",))
    branch = particle - point
    psi = psi_of_boundary_stress(out, force, branch).ravel()
    z = grid.axis_coordinates[2]
    psi_ref = np.array([float(mp_psi([zz - particle[2]], [e[2]], w, R) / 16) for zz in z])
    err = rel_error(psi, psi_ref)
    assert err <= RTOL
    record(f"segment perpendicular to a Z profile, tilt {tilt:g}", err)


# --- far along the line: erf(a) - erf(b) cancels; exactly on the line -------------------

@pytest.mark.parametrize("distance", [3.0, 6.0, 10.0, 20.0])
def test_points_far_along_the_segment_line(distance):
    """Nodes beyond the segment's end along its line: relative accuracy of the tiny value itself."""
    w = 0.25
    R = 40 * w
    box = cg.Box([-20, -20, -20], [20, 20, 20])
    particle = np.array([0.3, -0.2, 0.1])
    e = np.array([0.3, 0.4, 0.0])       # L = 0.5 = 2 w
    point = particle + e
    force = np.array([1.0, 0.0, 0.0])
    snap = boundary_snapshot(particle, point, force, box)
    unit = e / np.linalg.norm(e)
    along = np.array([np.linalg.norm(e) + distance * w, -distance * w])   # beyond either end
    perp = np.array([0.0, 0.0, 0.7 * w])
    pts = np.concatenate([particle + along[:, None] * unit, particle + along[:, None] * unit + perp])
    out = cg.coarse_grain(snap, cg.Points(pts), cg.Gaussian(w, cutoff=R), fields=("boundary_stress",))
    psi = psi_of_boundary_stress(out, force, particle - point)
    for value, p in zip(psi, pts):
        ref = float(mp_psi(p - particle, e, w, R))
        assert ref > 0
        err = abs(value - ref) / ref
        assert np.isfinite(value) and err <= RTOL, (value, ref)
    record(f"node {distance:g} w beyond a segment end (value-relative)", float(
        max(abs(v - float(mp_psi(p - particle, e, w, R))) / float(mp_psi(p - particle, e, w, R)) for v, p in zip(psi, pts))))


def test_points_exactly_on_the_segment_line():
    w = 0.25
    R = 8 * w
    box = cg.Box([-3, -3, -3], [3, 3, 3])
    particle = np.array([0.1, 0.2, 0.3])
    e = np.array([0.5, -0.25, 0.125])
    point = particle + e
    force = np.array([0.0, 1.0, 0.0])
    snap = boundary_snapshot(particle, point, force, box)
    s = np.array([-3.0, -0.5, 0.0, 0.25, 0.5, 1.0, 1.7, 4.0])
    pts = particle + s[:, None] * e
    out = cg.coarse_grain(snap, cg.Points(pts), cg.Gaussian(w, cutoff=R), fields=("boundary_stress",))
    psi = psi_of_boundary_stress(out, force, particle - point)
    ref = np.array([float(mp_psi(p - particle, e, w, R)) for p in pts])
    err = rel_error(psi, ref)
    assert err <= RTOL
    record("nodes exactly on the segment line", err)


# --- w much smaller than the grid spacing, w much larger than the box ------------------

def test_width_much_smaller_than_grid_spacing():
    w = 1e-3
    R = 8 * w
    box = cg.Box([0, 0], [1, 1])
    grid = cg.Grid(box, (10, 10))
    node = grid.coordinates[3, 4]
    particle = node + np.array([2.1e-3, -1.3e-3])       # within the cutoff of exactly one node
    snap = cg.Snapshot(particle[None], np.zeros((1, 2)), [2.0], box=box)
    out = cg.coarse_grain(snap, grid, cg.Gaussian(w, cutoff=R), fields=("density",))
    ref = np.zeros((10, 10))
    ref[3, 4] = 2.0 * float(mp_gauss(sum((mp.mpf(float(node[d])) - mp.mpf(float(particle[d]))) ** 2 for d in range(2)), w, R, 2))
    err = rel_error(out.density, ref)
    assert err <= RTOL and np.count_nonzero(out.density) == 1
    record("w = 1e-3 x grid spacing", err)


def test_width_much_larger_than_a_periodic_box():
    """w = 20 L on a periodic box: images out to the cutoff, against a 50-digit image sum."""
    L = 1.0
    w = 20.0
    R = 2.5 * w
    box = cg.Box([0, 0], [L, L], periodic=(True, True))
    snap = cg.Snapshot(np.array([[0.3, 0.6]]), np.zeros((1, 2)), [1.0], box=box)
    pts = np.array([[0.1, 0.2], [0.9, 0.95], [0.3, 0.6]])
    out = cg.coarse_grain(snap, cg.Points(pts), cg.Gaussian(w, cutoff=R), fields=("density",))
    K = int(math.ceil(R / L)) + 1
    ref = []
    for p in pts:
        dx = [mp.mpf(float(p[0])) - mp.mpf(0.3) + k * L for k in range(-K, K + 1)]
        dz = [mp.mpf(float(p[1])) - mp.mpf(float(0.6)) + k * L for k in range(-K, K + 1)]
        gx = [mp.exp(-x * x / (2 * w * w)) for x in dx]
        total = mp.mpf(0)
        for a, x in zip(gx, dx):
            for b, z in zip(gx if False else [mp.exp(-zz * zz / (2 * w * w)) for zz in dz], dz):
                if x * x + z * z < R * R:
                    total += a * b
        ref.append(float(total / (2 * mp.pi * w * w)))
    err = rel_error(out.density, ref)
    assert err <= RTOL
    record("w = 20 x periodic box (cutoff 50 box lengths)", err)


def test_cutoff_larger_than_half_a_periodic_box_contact_stress():
    L = 2.0
    w = 0.6
    R = 3.0        # 1.5 box lengths
    box = cg.Box([0, 0, 0], [L, 10, 10], periodic=(True, False, False))
    particle = np.array([0.2, 5.0, 5.0])
    e = np.array([-0.4, 0.2, -0.3])
    force = np.array([0.5, -1.0, 0.25])
    snap = boundary_snapshot(particle, particle + e, force, box)
    pts = np.array([[1.9, 5.1, 4.9], [1.0, 5.0, 5.0], [0.05, 4.5, 5.5]])
    out = cg.coarse_grain(snap, cg.Points(pts), cg.Gaussian(w, cutoff=R), fields=("boundary_stress",))
    psi = psi_of_boundary_stress(out, force, -e)
    ref = [float(sum(mp_psi(p - particle - np.array([k * L, 0, 0]), e, w, R) for k in range(-4, 5))) for p in pts]
    err = rel_error(psi, ref)
    assert err <= RTOL
    record("cutoff = 1.5 x periodic box length", err)


# --- outside the box, unwrapped across periodic boundaries ------------------------------

def test_particles_and_contact_points_outside_the_box_or_unwrapped():
    from helpers import random_snapshot
    snap = random_snapshot(5, dim=3)
    L = snap.box.lengths
    rng = np.random.default_rng(2)
    shift = np.zeros_like(snap.positions)
    shift[:, :2] = rng.integers(-3, 4, (snap.n_particles, 2)) * L[:2]
    pshift = np.zeros_like(snap.contacts.point)
    pshift[:, :2] = rng.integers(-3, 4, (len(snap.contacts), 2)) * L[:2]
    c = snap.contacts
    moved = cg.Snapshot(snap.positions + shift, snap.velocities, snap.masses, box=snap.box,
                        contacts=cg.Contacts(c.i, c.j, c.force, c.point + pshift), fixed=snap.fixed,
                        body_force=snap.body_force)
    grid = cg.Grid(snap.box, (5, 4, 6))
    fields = ("density", "stress", "interaction_force_density", "extended_stress")
    a = cg.coarse_grain(snap, grid, cg.Gaussian(0.5, cutoff=2.5), fields=fields)
    b = cg.coarse_grain(moved, grid, cg.Gaussian(0.5, cutoff=2.5), fields=fields)
    err = max(rel_error(b[f], a[f]) for f in fields)
    assert err <= RTOL
    record("particles/contact points up to 3 periods outside the box", err)


# --- far from the origin ------------------------------------------------------------------

def test_positions_near_1e6_with_small_width():
    w = 1e-3
    R = 8 * w
    origin = np.array([1.0e6 + 0.123456, -2.0e6 + 0.654321, 1.0e6 - 0.5])
    box = cg.Box(origin - 1, origin + 1)
    particle = origin + np.array([1.1e-4, -3.2e-4, 2.0e-4])
    point = particle + np.array([4e-4, 2e-4, -3e-4])
    force = np.array([0.1, -0.3, 1.0])
    snap = boundary_snapshot(particle, point, force, box, mass=1.5)
    rng = np.random.default_rng(4)
    pts = particle + rng.normal(scale=w, size=(10, 3))
    out = cg.coarse_grain(snap, cg.Points(pts), cg.Gaussian(w, cutoff=R),
                          fields=("density", "boundary_stress", "interaction_force_density"))
    rho_ref = [1.5 * float(mp_gauss(sum((mp.mpf(float(p[d])) - mp.mpf(float(particle[d]))) ** 2 for d in range(3)), w, R, 3))
               for p in pts]
    psi_ref = [float(mp_psi([mp.mpf(float(p[d])) - mp.mpf(float(particle[d])) for d in range(3)],
                            [mp.mpf(float(point[d])) - mp.mpf(float(particle[d])) for d in range(3)], w, R)) for p in pts]
    branch = particle - point
    err = max(rel_error(out.density, rho_ref), rel_error(psi_of_boundary_stress(out, force, branch), psi_ref))
    assert err <= RTOL
    record("positions near 1e6, w = 1e-3", err)


# --- Galilean: huge uniform flow ------------------------------------------------------------

def test_uniform_flow_1e8_times_the_fluctuation():
    from helpers import random_snapshot
    snap = random_snapshot(6, dim=3)
    rng = np.random.default_rng(5)
    v = np.round(rng.normal(size=snap.velocities.shape) * 2**16) / 2**16
    U = np.array([2.0**27, -(2.0**26), 2.0**25])
    grid = cg.Grid(snap.box, (4, 4, 5))
    k = cg.Gaussian(0.5)
    c = snap.contacts
    make = lambda vel: cg.Snapshot(snap.positions, vel, snap.masses, box=snap.box, contacts=c, fixed=snap.fixed)
    a = cg.coarse_grain(make(v), grid, k, fields=("kinetic_stress",))
    b = cg.coarse_grain(make(v + U), grid, k, fields=("kinetic_stress",))
    err = rel_error(b.kinetic_stress, a.kinetic_stress)
    assert err <= 1e-9
    record("uniform flow 1e8 x fluctuation (kinetic stress; target 1e-9)", err)


# --- empty regions and degenerate counts -----------------------------------------------------

def test_zero_density_regions():
    box = cg.Box([0, 0], [10, 10])
    snap = cg.Snapshot([[2.0, 2.0]], [[1.0, -1.0]], [1.0], box=box, contacts=cg.Contacts([0], [-1], [[0.0, 1.0]], [[2.0, 1.5]]))
    grid = cg.Grid(box, (20, 20))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = cg.coarse_grain(snap, grid, cg.Lucy(1.0), fields=("density", "velocity", "temperature", "stress",
                                                                "interaction_force_density"))
    empty = out.density == 0
    far = np.linalg.norm(grid.coordinates - [2.0, 2.0], axis=-1) > 1.6
    assert np.all(empty[far])
    assert np.all(np.isnan(out.velocity[empty])) and np.all(np.isnan(out.temperature[empty]))
    assert np.all(out.stress[far] == 0) and np.all(out.interaction_force_density[far] == 0)
    np.testing.assert_allclose(out.velocity[~empty], np.broadcast_to([1.0, -1.0], out.velocity[~empty].shape), rtol=1e-15)
    record("rho = 0 regions (velocity NaN, others exactly 0)", 0.0)


def test_single_particle():
    w = 0.4
    R = 8 * w
    box = cg.Box([0, 0, 0], [3, 3, 3])
    x = np.array([1.3, 1.1, 1.7])
    snap = cg.Snapshot(x[None], [[0.5, 0.0, 0.0]], [2.5], box=box)
    grid = cg.Grid(box, (6, 6, 6))
    out = cg.coarse_grain(snap, grid, cg.Gaussian(w, cutoff=R), fields=("density", "velocity", "kinetic_stress"))
    nodes = grid.coordinates.reshape(-1, 3)
    ref = np.array([2.5 * float(mp_gauss(sum((mp.mpf(float(n[d])) - mp.mpf(float(x[d]))) ** 2 for d in range(3)), w, R, 3))
                    for n in nodes]).reshape(6, 6, 6)
    err = rel_error(out.density, ref)
    assert err <= RTOL
    assert np.all(out.kinetic_stress == 0)            # one particle has no fluctuation
    np.testing.assert_array_equal(out.velocity[out.density > 0], np.broadcast_to([0.5, 0, 0], (int((out.density > 0).sum()), 3)))
    record("single particle", err)


# every field that needs no angular velocities (these snapshots do not spin)
ALL = tuple(f for f in cg.FIELD_NAMES if f not in SPIN_FIELDS)


def assert_empty_fields(out):
    """No flowing matter: velocity, temperature and the fields that divide by the density or the pressure
    NaN, every other field exactly zero."""
    for name in ALL:
        value = out[name]
        if name in ("velocity", "temperature") + PER_PARTICLE_FIELDS + NAN_WITHOUT_MATTER + PRESSURE_RATIO_FIELDS:
            assert np.all(np.isnan(value)), name
        else:
            assert np.all(value == 0), name


def test_no_particles():
    box = cg.Box([0, 0, 0], [2, 2, 2])
    snap = cg.Snapshot(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), box=box, radii=np.zeros(0))
    out = cg.coarse_grain(snap, cg.Grid(box, (3, 3, 3)), cg.Gaussian(0.5), fields=ALL)
    assert_empty_fields(out)
    record("N = 0", 0.0)


def test_no_contacts():
    from helpers import random_snapshot
    snap = random_snapshot(7, dim=2)
    bare = cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box, fixed=snap.fixed)
    out = cg.coarse_grain(bare, cg.Grid(snap.box, (5, 5)), cg.Lucy(1.2),
                          fields=("contact_stress", "boundary_stress", "interaction_force_density", "extended_stress",
                                  "density"))
    for name in ("contact_stress", "boundary_stress", "interaction_force_density"):
        assert np.all(out[name] == 0)
    assert np.all(np.isfinite(out.extended_stress)) and np.any(out.density > 0)
    record("M = 0", 0.0)


def test_all_particles_fixed():
    from helpers import random_snapshot
    snap = random_snapshot(8, dim=3)
    c = snap.contacts
    frozen = cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box, contacts=c,
                         fixed=np.ones(snap.n_particles, bool), body_force=snap.body_force, radii=snap.radii)
    out = cg.coarse_grain(frozen, cg.Grid(snap.box, (3, 3, 4)), cg.Gaussian(0.5), fields=ALL)
    assert_empty_fields(out)
    record("all particles fixed", 0.0)


@pytest.mark.parametrize("line_quadrature", ["exact", 3])
def test_zero_length_branch_with_a_node_on_the_cutoff_sphere(line_quadrature):
    """Two particles at one place in contact (a branch of length 0) and grid nodes exactly at the cutoff
    distance: finite, and the same as node by node (the branch is a point there)."""
    box = cg.Box([-3.5, -3.5, -3.5], [3.5, 3.5, 3.5])                  # nodes at the integers -3..3
    pos = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    contacts = cg.Contacts([0, 0], [1, 2], [[1.0, 0.5, 0.2], [0.3, 0.1, 0.2]],
                           [[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]])
    snap = cg.Snapshot(pos, np.zeros((3, 3)), np.ones(3), box=box, contacts=contacts)
    grid = cg.Grid(box, (7, 7, 7))
    kernel = cg.Gaussian(2.0 / 3.0, cutoff=2.0, line_quadrature=line_quadrature)   # node (2, 0, 0) on the sphere
    fast = cg.coarse_grain(snap, grid, kernel, fields=("contact_stress",)).contact_stress
    kernel._per_node = True
    slow = cg.coarse_grain(snap, grid, kernel, fields=("contact_stress",)).contact_stress
    assert np.isfinite(fast).all()
    np.testing.assert_allclose(fast, slow, rtol=1e-12, atol=1e-12 * np.abs(slow).max())
