"""CylindricalGrid: ring averages against a brute-force θ oracle, mass, rigid rotation, the axis, errors."""
import numpy as np
import pytest

import cgbound as cg
from helpers import random_snapshot

FIELDS = ("density", "momentum", "velocity", "momentum_flux", "kinetic_stress", "contact_stress", "boundary_stress",
          "interaction_force_density", "stress")


def snapshot(periodic=None):
    return random_snapshot(3, n=40, n_bulk=30, lengths=[6.0, 6.0, 5.0], periodic=periodic)


def centre(snap):
    return 0.5 * (snap.box.lower + snap.box.upper)


def basis_rows(theta, e1, e2, ez):
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    return np.stack([c * e1 + s * e2, -s * e1 + c * e2, np.broadcast_to(ez, (len(theta), 3))], axis=1)


def oracle(snap, kernel, axis_point, r_nodes, z_nodes, z_weights, n_theta=720):
    """θ (and z) averages by brute force: Cartesian fields at n_theta ring points rotated into (e_r, e_θ, e_z);
    velocity as the ratio of the averaged momentum and density. Angle origin e_1 = x̂ for the z axis."""
    e1, e2, ez = np.eye(3)
    theta = (np.arange(n_theta) + 0.5) * 2 * np.pi / n_theta
    R = basis_rows(theta, e1, e2, ez)
    out = {f: [] for f in FIELDS}
    for r in r_nodes:
        acc = {f: 0.0 for f in FIELDS}
        for zq, wq in zip(z_nodes, z_weights):
            pts = axis_point + r * (np.cos(theta)[:, None] * e1 + np.sin(theta)[:, None] * e2) + zq * ez
            res = cg.coarse_grain(snap, cg.Points(pts), kernel, fields=FIELDS)
            for f in FIELDS:
                v = getattr(res, f)
                if v.ndim == 2:
                    v = np.einsum("qia,qa->qi", R, v)
                elif v.ndim == 3:
                    v = np.einsum("qia,qab,qjb->qij", R, v, R)
                acc[f] = acc[f] + wq * v.mean(axis=0)
        # averaged primaries, then fields: velocity and the velocity spread about the ring's mean velocity
        acc["velocity"] = acc["momentum"] / acc["density"]
        acc["kinetic_stress"] = np.outer(acc["momentum"], acc["momentum"]) / acc["density"] - acc["momentum_flux"]
        acc["stress"] = acc["kinetic_stress"] + acc["contact_stress"] + acc["boundary_stress"]
        for f in FIELDS:
            out[f].append(acc[f])
    return {f: np.array(v) for f, v in out.items()}


@pytest.mark.parametrize("z_resolved", [True, False])
def test_ring_average_equals_brute_force_oracle(z_resolved):
    snap = snapshot()
    kernel = cg.Gaussian(0.3, cutoff=3.0)          # the cutoff jump exp(-50) is below round-off
    c = centre(snap)
    if z_resolved:
        zc = snap.box.upper[2] - 1.2 - c[2]
        grid = cg.CylindricalGrid(snap.box, c, "z", r=(0.0, 2.0, 4), z=(zc - 0.05, zc + 0.05, 1))
        zs, wz = grid.z, np.ones(1)
    else:
        grid = cg.CylindricalGrid(snap.box, c, "z", r=(0.0, 2.0, 4))
        lo, hi = snap.box.lower[2] - c[2], snap.box.upper[2] - c[2]
        x, w = np.polynomial.legendre.leggauss(120)
        zs, wz = 0.5 * (hi + lo) + 0.5 * (hi - lo) * x, 0.5 * w
    out = cg.coarse_grain(snap, grid, kernel, fields=FIELDS)
    want = oracle(snap, kernel, c, grid.r, zs, wz)
    for f in FIELDS:
        got = getattr(out, f)[:, 0, 0]
        scale = np.abs(want[f]).max()
        assert scale > 0, f
        np.testing.assert_allclose(got, want[f], rtol=0, atol=1e-12 * scale, err_msg=f)


def test_lucy_ring_average_accuracy():
    """The density is the exact ring integral (to round-off, tests/test_cylindrical_ring.py): it matches a
    4000-point rule to that rule's own error. The contact stress's line integrals still come from the
    trapezoidal rule, only finitely smooth for Lucy (a jump in its third derivative at the support's edge, so it
    converges like N^-4): measured 1.1e-6 of the largest stress against 4000 points."""
    snap = snapshot()
    kernel = cg.Lucy(1.0)
    c = centre(snap)
    zc = snap.box.upper[2] - 1.2 - c[2]
    grid = cg.CylindricalGrid(snap.box, c, "z", r=(0.0, 2.0, 4), z=(zc - 0.05, zc + 0.05, 1))
    out = cg.coarse_grain(snap, grid, kernel, fields=("density", "stress"))
    want = oracle(snap, kernel, c, grid.r, grid.z, np.ones(1), n_theta=4000)
    for f, bound in (("density", 1e-9), ("stress", 2e-6)):
        scale = np.abs(want[f]).max()
        assert np.abs(getattr(out, f)[:, 0, 0] - want[f]).max() < bound * scale, f


def test_mass_integral():
    rng = np.random.default_rng(5)
    box = cg.Box([-6, -6, 0], [6, 6, 8], periodic=[False, False, False])
    n = 30
    pos = np.c_[rng.uniform(-1.5, 1.5, (n, 2)), rng.uniform(3, 5, n)]
    m = rng.uniform(0.5, 2, n)
    snap = cg.Snapshot(pos, np.zeros((n, 3)), m, box=box)
    grid = cg.CylindricalGrid(box, (0, 0, 0), "z", r=(0.0, 4.5, 900))
    rho = cg.coarse_grain(snap, grid, cg.Gaussian(0.3, cutoff=3.0), fields=("density",)).density[:, 0, 0]
    h = 4.5 / 900
    mass = np.sum(rho * 2 * np.pi * grid.r * h) * 8.0
    # midpoint rule in r: O(h^2) with h/w = 1/60
    assert abs(mass / m.sum() - 1) < 1e-4


def test_rigid_rotation():
    """v = ω e_z × (x - a): p = ω e_z × m with m the in-plane first moment (the momentum of velocities x - a),
    so p_r = -ω m_θ, p_θ = ω m_r, p_z = 0 at every node; on the θ-average m_θ = 0 and p_r = 0."""
    snap0 = snapshot(periodic=(False, False, False))   # a periodic image carries the velocity of its original
    a = centre(snap0)
    omega = 0.7
    d = snap0.positions - a
    rot = np.c_[-omega * d[:, 1], omega * d[:, 0], np.zeros(len(d))]
    mk = lambda v: cg.Snapshot(snap0.positions, v, snap0.masses, box=snap0.box)
    grid = cg.CylindricalGrid(snap0.box, a, "z", r=(0.0, 2.0, 5), theta=3, z=(-0.5, 0.5, 2))
    kernel = cg.Gaussian(0.4, cutoff=4.0)
    p = cg.coarse_grain(mk(rot), grid, kernel, fields=("momentum", "density", "velocity"))
    moment = cg.coarse_grain(mk(np.c_[d[:, :2], np.zeros(len(d))]), grid, kernel, fields=("momentum",)).momentum
    scale = np.abs(p.momentum).max()
    np.testing.assert_allclose(p.momentum[..., 0], -omega * moment[..., 1], rtol=0, atol=1e-13 * scale)
    assert np.abs(p.momentum[..., 2]).max() == 0
    np.testing.assert_allclose(p.momentum[..., 1], omega * moment[..., 0], rtol=0, atol=1e-13 * scale)
    np.testing.assert_allclose(p.velocity[..., 1], p.momentum[..., 1] / p.density, rtol=1e-14)
    ring = cg.CylindricalGrid(snap0.box, a, "z", r=(0.0, 2.0, 5), z=(-0.5, 0.5, 2))
    pr = cg.coarse_grain(mk(rot), ring, kernel, fields=("momentum",)).momentum
    assert np.abs(pr[..., 0]).max() < 1e-13 * np.abs(pr).max()


def test_particle_on_axis():
    """A particle on the axis: the ring average sees it at every angle; no node has r = 0 (cell centres),
    its in-plane velocity averages to zero over θ and its axial velocity is kept."""
    box = cg.Box([-3, -3, -3], [3, 3, 3], periodic=[False, False, False])
    snap = cg.Snapshot([[0.0, 0.0, 0.0]], [[1.0, 0.5, 2.0]], [1.0], box=box)
    grid = cg.CylindricalGrid(box, (0, 0, 0), "z", r=(0.0, 1.0, 4), z=(-0.1, 0.1, 1))
    assert grid.r.min() > 0
    out = cg.coarse_grain(snap, grid, cg.Gaussian(0.5, cutoff=5.0), fields=("density", "velocity"))
    w = 0.5
    want = (2 * np.pi * w * w) ** -1.5 * np.exp(-grid.r ** 2 / (2 * w * w))
    np.testing.assert_allclose(out.density[:, 0, 0], want, rtol=1e-13)
    assert np.abs(out.velocity[..., :2]).max() < 1e-14
    np.testing.assert_allclose(out.velocity[..., 2], 2.0, rtol=1e-14)


def test_shapes_and_axis_vector():
    snap = snapshot()
    c = centre(snap)
    g = cg.CylindricalGrid(snap.box, c, "z", r=(0.5, 2.0, 3), theta=4, z=(-1, 1, 2))
    out = cg.coarse_grain(snap, g, cg.Gaussian(0.4), fields=("density", "velocity", "stress"))
    assert out.density.shape == (3, 4, 2) and out.velocity.shape == (3, 4, 2, 3) and out.stress.shape == (3, 4, 2, 3, 3)
    g2 = cg.CylindricalGrid(snap.box, c, (0, 0, 2.0), r=(0.5, 2.0, 3), theta=4, z=(-1, 1, 2))
    out2 = cg.coarse_grain(snap, g2, cg.Gaussian(0.4), fields=("density", "velocity", "stress"))
    for f in ("density", "velocity", "stress"):
        np.testing.assert_array_equal(getattr(out, f), getattr(out2, f))
    np.testing.assert_allclose(g.theta, (np.arange(4) + 0.5) * np.pi / 2)


@pytest.mark.parametrize("theta", [None, 4])
def test_every_field_has_its_shape_and_the_derived_ones_follow_from_the_averaged(theta):
    # the derived fields (pressure, temperature, extended stress, volume fraction ...) from the averaged
    # primaries: shapes like the grid's, pressure = -tr(stress)/3 and velocity = momentum/density node by node
    snap = snapshot()
    g = cg.CylindricalGrid(snap.box, centre(snap), "z", r=(0.5, 2.0, 3), theta=theta, z=(-1, 1, 2))
    names = tuple(f for f in cg.FIELD_NAMES if f not in cg.fields.GRADIENT_FIELDS and f not in
                  ("shear_stress", "friction") and not f.startswith(("fabric", "coordination", "size_moment",
                                                                       "mean_radius", "radius_", "number_density"))
                  and f not in cg.ROTATION_FIELDS)
    out = cg.coarse_grain(snap, g, cg.Gaussian(0.4, cutoff=3.6), fields=names)
    nodes = g.shape
    for name in names:
        rank = cg.fields.field_rank(name)
        assert out[name].shape == nodes + (3,) * rank, name
    np.testing.assert_allclose(out.pressure, -np.trace(out.stress, axis1=-2, axis2=-1) / 3, rtol=1e-12, atol=1e-14)
    has = out.density > 0
    np.testing.assert_allclose(out.velocity[has], out.momentum[has] / out.density[has][:, None], rtol=1e-12)
    np.testing.assert_allclose(out.stress, out.kinetic_stress + out.contact_stress + out.boundary_stress,
                               rtol=1e-12, atol=1e-12 * np.abs(out.stress).max())


@pytest.mark.parametrize("kwargs, name", [
    (dict(box="box"), "box"),
    (dict(axis_point=(0, 0)), "axis_point"),
    (dict(axis="w"), "axis"),
    (dict(axis=(0, 0, 0)), "axis"),
    (dict(r=(-1, 2, 3)), "r"),
    (dict(r=(2, 1, 3)), "r"),
    (dict(r=(0, 1, 0)), "r"),
    (dict(r=None), "r"),
    (dict(theta=0), "theta"),
    (dict(theta="a"), "theta"),
    (dict(z=(1, 0, 2)), "z"),
    (dict(axis=(1, 1, 0)), "z"),
])
def test_bad_arguments_are_named(kwargs, name):
    box = cg.Box([-3, -3, -3], [3, 3, 3])
    args = dict(box=box, axis_point=(0, 0, 0), axis="z", r=(0, 1, 3), theta=None, z=None)
    args.update(kwargs)
    with pytest.raises((TypeError, ValueError), match=f"^{name}:"):
        cg.CylindricalGrid(**args)


def test_2d_refused():
    with pytest.raises(ValueError, match="^box:"):
        cg.CylindricalGrid(cg.Box([0, 0], [1, 1]), r=(0, 1, 2))
    box3 = cg.Box([-3, -3, -3], [3, 3, 3])
    snap2 = cg.Snapshot([[0.0, 0.0]], [[0.0, 0.0]], [1.0], box=cg.Box([-1, -1], [1, 1]))
    with pytest.raises(ValueError, match="^snapshot:"):
        cg.coarse_grain(snap2, cg.CylindricalGrid(box3, r=(0, 1, 2)), cg.Gaussian(0.3), fields=("density",))
