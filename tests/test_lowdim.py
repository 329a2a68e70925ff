"""MercuryCG's lower-dimensional kernel over averaged axes (``averaged_axes="lower-dimensional"``).

Over the axes a Grid averages, cgbound's default kernel is the exact marginal of the D-dimensional kernel;
MercuryCG uses the kernel of the resolved dimension itself (for a Z profile with Lucy the 1-D Lucy
C_1 (1 + 3x)(1 - x)^3, C_1 = 5 / (4 R), x = |z - z_i| / R), divided by the averaged extent. Tested here:
values against the formulas written out in the tests, every core entry point against its slow twin
(tests/oracle.py, ``OracleKernel(..., lower_dimensional=True)``), the whole pipeline against the twin, the
mass identity and the line-integral identity under the option, and MercuryCG's own .stat files.
"""
import math
import os

import numpy as np
import pytest

import cgbound as cg
from cgbound import _core
from cgbound.mercurycg import read_stat, stat_kernel
from cgbound.readers.mercury import MercuryReader
from helpers import assert_fields_close
from oracle import (OracleKernel, oracle_coarse_grain, oracle_scatter_fluctuation, oracle_scatter_points,
                    oracle_scatter_segments)
from test_core_sweep import (LENGTHS, ORACLE_KIND, PERIODICITY, RTOL, case_id, diverges, layouts, make_target,
                             objects, periodic_flags, seed_of, steer_rays)

GAUSSIAN, LUCY, HEAVISIDE = 0, 1, 2
DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "mercurycg")
CHUTE = os.path.join(DATA, "ChutePeriodicDemo_t15")
#: the whole run (frames t = 0, 2.5, ..., 20) with its .restart and MercuryCG's files (tests/data/mercurydpm/README.md)
RUN = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "mercurydpm", "ChutePeriodicDemo",
                   "ChutePeriodicDemo")

#: name: (core type, width, cutoff radius) of kernels tried with lower_dimensional = 1
KERNELS = {"lucy": (LUCY, 1.1, 1.1), "lucy-wide": (LUCY, 2.2, 2.2), "heaviside": (HEAVISIDE, 0.9, 0.9)}


def lucy_1d(z, R):
    """The 1-D Lucy: 5 / (4R) (1 + 3x)(1 - x)^3, x = |z| / R < 1."""
    x = np.abs(z) / R
    return np.where(x < 1, 5 / (4 * R) * (1 + 3 * x) * (1 - x) ** 3, 0.0)


def lucy_2d(rho, R):
    """The 2-D Lucy: 5 / (pi R^2) (1 + 3x)(1 - x)^3, x = rho / R < 1."""
    x = rho / R
    return np.where(x < 1, 5 / (math.pi * R * R) * (1 + 3 * x) * (1 - x) ** 3, 0.0)


def lucy_1d_antiderivative(z, R):
    """int_0^z of the 1-D Lucy (odd in z): with x = z / R, P(x) = 1 - 6x^2 + 8|x|^3 - 3x^4 integrates to
    x - 2x^3 + 2x^3|x| - 3x^5/5, times 5/4 (the 1/R of C_1 cancels the dz = R dx); constant beyond |x| = 1."""
    x = np.clip(z / R, -1.0, 1.0)
    return 5 / 4 * (x - 2 * x ** 3 + 2 * x ** 3 * np.abs(x) - 0.6 * x ** 5)


def one_particle(position, box, mass=2.0):
    snap = cg.Snapshot(positions=[position], masses=[mass], radii=[0.1], box=box)
    return snap


# ----------------------------------------------------------------------
# the option


def test_option_is_checked_and_shown():
    assert cg.Lucy(1.0).averaged_axes == "marginal" and not cg.Lucy(1.0).lower_dimensional
    k = cg.Lucy(1.0, averaged_axes="lower-dimensional")
    assert k.lower_dimensional and "lower-dimensional" in repr(k)
    assert "averaged_axes" not in repr(cg.Lucy(1.0))
    assert cg.Heaviside(0.5, averaged_axes="lower-dimensional").lower_dimensional
    assert cg.Gaussian(0.5, averaged_axes="lower-dimensional").lower_dimensional
    with pytest.raises(ValueError, match="averaged_axes: expected 'marginal'.*got 'lowdim'"):
        cg.Lucy(1.0, averaged_axes="lowdim")
    with pytest.raises(TypeError, match="averaged_axes"):
        cg.Heaviside(1.0, averaged_axes=True)


# ----------------------------------------------------------------------
# values from the formulas


@pytest.mark.parametrize("mode", ["marginal", "lower-dimensional"])
def test_z_profile_of_one_particle_is_the_1d_lucy(mode):
    """A Z profile of one particle: the 1-D Lucy (lower-dimensional) or the marginal of the 3-D one,
    both divided by the area Lx Ly."""
    R, z0, m = 0.8, 1.37, 2.0
    box = cg.Box([0, 0, 0], [3.0, 2.0, 4.0])
    grid = cg.Grid(box, (1, 1, 40), average=("x", "y"))
    rho = cg.coarse_grain(one_particle([1.1, 0.7, z0], box, m), grid, cg.Lucy(R, averaged_axes=mode),
                          fields=["density"])["density"].ravel()
    z = grid.axis_coordinates[2]
    if mode == "lower-dimensional":
        expected = m * lucy_1d(z - z0, R) / (3.0 * 2.0)
    else:
        # the marginal of the 3-D Lucy over a plane: 2 pi int_|z|^R W3(r) r dr = 2 pi C3 R^2 g(|z|/R),
        # g(u) = (1 - u)^4 (1 + 4u + 5u^2) / 10 (integrated by hand from (1 + 3r)(1 - r)^3 r)
        u = np.minimum(np.abs(z - z0) / R, 1.0)
        c3 = 105 / (16 * math.pi * R ** 3)
        expected = m * 2 * math.pi * c3 * R ** 2 * (1 - u) ** 4 * (1 + 4 * u + 5 * u * u) / 10 / (3.0 * 2.0)
    np.testing.assert_allclose(rho, expected, rtol=1e-13, atol=1e-15 * expected.max())
    # the two differ: at the particle the 1-D Lucy peaks at 5/(4R), the marginal at 21/(16R)
    if mode == "lower-dimensional":
        assert lucy_1d(0.0, R) == pytest.approx(5 / (4 * R))


def test_xz_map_of_one_particle_is_the_2d_lucy():
    R, m = 0.9, 1.5
    box = cg.Box([0, 0, 0], [3.0, 2.5, 4.0])
    x0 = np.array([1.23, 0.4, 2.05])
    grid = cg.Grid(box, (12, 1, 16), average="y")
    rho = cg.coarse_grain(one_particle(x0, box, m), grid, cg.Lucy(R, averaged_axes="lower-dimensional"),
                          fields=["density"])["density"][:, 0, :]
    X, Z = np.meshgrid(grid.axis_coordinates[0], grid.axis_coordinates[2], indexing="ij")
    expected = m * lucy_2d(np.hypot(X - x0[0], Z - x0[2]), R) / 2.5
    np.testing.assert_allclose(rho, expected, rtol=1e-13, atol=1e-15 * expected.max())


@pytest.mark.parametrize("average, norm", [(("x", "y"), lambda R: 2 * R), ("y", lambda R: math.pi * R * R)])
def test_heaviside_lower_dimensional_is_the_uniform_ball_of_the_resolved_dimension(average, norm):
    R, m = 0.7, 3.0
    box = cg.Box([0, 0, 0], [2.0, 2.5, 4.0])
    x0 = np.array([1.0, 1.2, 2.0])
    grid = cg.Grid(box, (1 if "x" in average else 9, 1, 13), average=average)
    rho = cg.coarse_grain(one_particle(x0, box, m), grid, cg.Heaviside(R, averaged_axes="lower-dimensional"),
                          fields=["density"])["density"]
    X, Z = np.meshgrid(grid.axis_coordinates[0], grid.axis_coordinates[2], indexing="ij")
    dist = np.abs(Z - x0[2]) if "x" in average else np.hypot(X - x0[0], Z - x0[2])
    extent = np.prod([box.lengths[d] for d in grid.averaged])
    expected = np.where(dist < R, m / (norm(R) * extent), 0.0)
    assert np.allclose(rho[:, 0, :], expected, rtol=1e-14, atol=0)


def test_gaussian_is_the_same_either_way():
    """The marginal of a Gaussian is the lower-dimensional Gaussian: the option changes nothing, bit for bit."""
    rng = np.random.default_rng(3)
    box = cg.Box([0, 0, 0], [3.0, 2.0, 4.0], periodic=(True, True, False))
    snap = cg.Snapshot(positions=rng.uniform([0, 0, 0], [3, 2, 4], (30, 3)), masses=rng.uniform(1, 2, 30),
                       radii=np.full(30, 0.2), velocities=rng.normal(size=(30, 3)), box=box)
    grid = cg.Grid(box, (1, 1, 25), average=("x", "y"))
    for k in ({}, {"cutoff": 1.0, "normalize": "truncated"}):
        a = cg.coarse_grain(snap, grid, cg.Gaussian(0.4, **k), fields=["density", "kinetic_stress"])
        b = cg.coarse_grain(snap, grid, cg.Gaussian(0.4, averaged_axes="lower-dimensional", **k),
                            fields=["density", "kinetic_stress"])
        assert np.array_equal(a["density"], b["density"])
        assert np.array_equal(a["kinetic_stress"], b["kinetic_stress"])


def test_contact_stress_line_integral_in_1d():
    """One bulk contact between two flowing particles, a Z profile: sigma_zz(z) = -f_z l_z psi(z) / A with
    psi(z) = (1 / l_z) int W_1 over the branch's z-extent (MercuryCG's evaluateCGIntegral1D), from the
    antiderivative of the 1-D Lucy written out above."""
    R = 1.0
    box = cg.Box([0, 0, 0], [3.0, 2.0, 5.0])
    xi, xj = np.array([1.0, 1.0, 2.1]), np.array([1.4, 0.8, 2.95])
    force = np.array([0.3, -0.2, 1.7])                     # on i from j
    contacts = cg.Contacts(i=[0], j=[1], force=[force], point=[0.5 * (xi + xj)])
    snap = cg.Snapshot(positions=[xi, xj], masses=[1.0, 1.0], radii=[0.5, 0.5], box=box, contacts=contacts)
    grid = cg.Grid(box, (1, 1, 50), average=("x", "y"))
    sigma = cg.coarse_grain(snap, grid, cg.Lucy(R, averaged_axes="lower-dimensional"),
                            fields=["contact_stress"])["contact_stress"].reshape(50, 3, 3)
    z = grid.axis_coordinates[2]
    lz = xi[2] - xj[2]
    # psi(z) = int_0^1 W_1(z - z_i + s l_z) ds = [F(z - z_j) - F(z - z_i)] / l_z (l = x_i - x_j, F the antiderivative)
    psi = (lucy_1d_antiderivative(z - xj[2], R) - lucy_1d_antiderivative(z - xi[2], R)) / lz
    expected = -np.einsum("a,b,p->pab", force, xi - xj, psi) / (3.0 * 2.0)   # tension-positive
    np.testing.assert_allclose(sigma, expected, rtol=1e-12, atol=1e-14 * np.abs(expected).max())


# ----------------------------------------------------------------------
# every core entry point against its twin


def kernel_pair(name, dim, avg_extent):
    ktype, width, radius = KERNELS[name]
    core = (ktype, width, radius, 0, avg_extent, 0, 0, 1)
    return core, OracleKernel(ORACLE_KIND[ktype], dim, width, radius, lower_dimensional=True)


def averaged_cases():
    """Grid layouts with at least one averaged axis (the option changes nothing elsewhere) x periodicity."""
    return [(dim, layout, p) for dim in (2, 3) for layout in layouts(dim)
            if layout[0] == "grid" and layout[1] for p in PERIODICITY]


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("case", averaged_cases(), ids=case_id)
def test_points_and_fluctuation_match_oracle(case, kernel):
    dim, layout, which = case
    periodic = periodic_flags(dim, which)
    target, tgt = make_target(dim, layout, periodic, seed_of(case))
    core_kernel, ref_kernel = kernel_pair(kernel, dim, tgt[4])
    x, velocities, values = objects(dim, 5, seed_of(case, kernel, "lowdim"), periodic)
    out = _core.scatter_points(target, core_kernel, x, values)
    assert_fields_close(out, oracle_scatter_points(ref_kernel, tgt, x, values), RTOL, "scatter_points")
    masses = 1.0 + np.abs(values[:, 0])
    node_velocity = np.random.default_rng(seed_of(kernel, case)).normal(size=(tgt[0].shape[0], dim))
    out = _core.scatter_fluctuation(target, core_kernel, x, masses, velocities, node_velocity)
    ref = oracle_scatter_fluctuation(ref_kernel, tgt, x, masses, velocities, node_velocity)
    assert_fields_close(out, ref, RTOL, "scatter_fluctuation")
    # the lower-dimensional kernel is a full kernel in the resolved axes: it has a gradient
    out = _core.scatter_points(target, core_kernel, x, values, gradient=True)
    ref = oracle_scatter_points(ref_kernel, tgt, x, values, gradient=True)
    if tgt[1]:
        assert_fields_close(out, ref, RTOL, "scatter_points gradient")


@pytest.mark.parametrize("ray", [False, True], ids=["segment", "ray"])
@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("case", [c for c in averaged_cases() if c[2] != "all"], ids=case_id)
def test_segments_match_oracle(case, kernel, ray):
    dim, layout, which = case
    periodic = periodic_flags(dim, which)
    target, tgt = make_target(dim, layout, periodic, seed_of(case))
    core_kernel, ref_kernel = kernel_pair(kernel, dim, tgt[4])
    starts, vectors, values = objects(dim, 2, seed_of(case, ray, kernel), periodic)
    if ray and (not tgt[1] or diverges(periodic, tgt[1])):
        with pytest.raises(ValueError):
            _core.scatter_segments(target, core_kernel, starts, vectors, values, ray=True)
        return
    if ray:
        steer_rays(vectors, periodic, tgt[1])
    else:
        vectors[0] = 0.0   # a segment of zero length is a point
    out = _core.scatter_segments(target, core_kernel, starts, vectors, values, ray=ray)
    ref = oracle_scatter_segments(ref_kernel, tgt, starts, vectors, values, ray=ray)
    assert_fields_close(out, ref, RTOL, "scatter_segments")
    # the node-by-node path gives the same numbers as the row path Lucy's segments take on grids
    per_node = core_kernel[:6] + (1, 1)
    assert_fields_close(_core.scatter_segments(target, per_node, starts, vectors, values, ray=ray), out, 1e-14,
                        "per node")
    if tgt[1] and ORACLE_KIND[core_kernel[0]] == "lucy" and not ray:
        grad = _core.scatter_segments(target, core_kernel, starts, vectors, values, gradient=True)
        ref = oracle_scatter_segments(ref_kernel, tgt, starts, vectors, values, gradient=True)
        assert_fields_close(grad, ref, RTOL, "scatter_segments gradient")


@pytest.mark.parametrize("dim, average", [(3, ("x", "y")), (3, ("y",)), (2, ("x",))])
@pytest.mark.parametrize("kernel", [cg.Lucy(0.9, averaged_axes="lower-dimensional"),
                                    cg.Heaviside(0.7, averaged_axes="lower-dimensional")], ids=repr)
def test_pipeline_matches_oracle(dim, average, kernel):
    """Every field, contacts in the bulk and with the boundary (contact, boundary and extended stress, IFD)."""
    pipeline_against_oracle(dim, average, kernel)


@pytest.mark.parametrize("dim, average", [(3, ("x", "y")), (2, ("x",))])
def test_pipeline_with_mercurycg_gauss_line_matches_oracle(dim, average):
    pipeline_against_oracle(dim, average, cg.Gaussian(0.3, cutoff=0.9, normalize="truncated",
                                                      line_quadrature="mercurycg", averaged_axes="lower-dimensional"))


def pipeline_against_oracle(dim, average, kernel):
    rng = np.random.default_rng(dim + len(average))
    lengths = np.array([2.5, 2.0, 3.0])[:dim] if dim == 3 else np.array([2.5, 3.0])
    box = cg.Box(np.zeros(dim), lengths, periodic=[True] * (dim - 1) + [False])
    n = 9
    pos = rng.uniform(0.2, 0.8, (n, dim)) * lengths
    fixed = np.zeros(n, bool)
    fixed[:2] = True
    pairs = [(2, 3), (3, 4), (4, 5), (5, 6), (0, 2), (7, 1), (6, 8), (8, -1)]
    i = np.array([p[0] for p in pairs])
    j = np.array([p[1] for p in pairs])
    below = pos[i].copy()
    below[:, -1] -= 0.4                                   # a wall below particle 8
    point = 0.5 * (pos[i] + np.where(j[:, None] >= 0, pos[np.maximum(j, 0)], below))
    contacts = cg.Contacts(i=i, j=j, force=rng.normal(size=(len(pairs), dim)), point=point)
    snap = cg.Snapshot(positions=pos, masses=rng.uniform(1, 2, n), radii=np.full(n, 0.2), box=box,
                       velocities=rng.normal(size=(n, dim)), fixed=fixed, contacts=contacts,
                       body_force=np.r_[np.zeros(dim - 1), -1.0])
    grid = cg.Grid(box, tuple(1 if box.axis_names[d] in average else 7 for d in range(dim)), average=average)
    fields = ["density", "momentum", "momentum_flux", "kinetic_stress", "contact_stress", "boundary_stress",
              "extended_stress", "interaction_force_density", "body_force_density", "volume_fraction"]
    res = cg.coarse_grain(snap, grid, kernel, fields=fields)
    ref = oracle_coarse_grain(snap, grid, kernel, fields)
    for name in fields:
        assert_fields_close(res[name].reshape(ref[name].shape), ref[name], 1e-11, name)


def test_tiles_and_saved_metadata(tmp_path):
    """The option travels with the kernel: tiles give the untiled numbers, and a saved result says which kernel."""
    pytest.importorskip("h5py")
    import h5py
    rng = np.random.default_rng(11)
    box = cg.Box([0, 0, 0], [4.0, 2.0, 3.0], periodic=(True, True, False))
    n = 40
    pos = rng.uniform([0, 0, 0.5], [4, 2, 2.5], (n, 3))
    i, j = np.arange(n - 1), np.arange(1, n)
    contacts = cg.Contacts(i=i, j=j, force=rng.normal(size=(n - 1, 3)), point=0.5 * (pos[i] + pos[j]))
    snap = cg.Snapshot(positions=pos, masses=np.ones(n), radii=np.full(n, 0.2), velocities=rng.normal(size=(n, 3)),
                       box=box, contacts=contacts)
    grid = cg.Grid(box, (8, 1, 12), average="y")
    kernel = cg.Lucy(0.7, averaged_axes="lower-dimensional")
    fields = ("density", "stress")
    whole = cg.coarse_grain(snap, grid, kernel, fields=fields)
    tiled = cg.coarse_grain_tiled(snap, grid, kernel, fields=fields, tiles=(2, 1, 3), backend="serial")
    for name in fields:
        assert_fields_close(tiled[name], whole[name], 1e-13, name)
    assert tiled.kernel.lower_dimensional
    whole.to_hdf5(tmp_path / "r.h5")
    with h5py.File(tmp_path / "r.h5") as f:
        assert f.attrs["averaged_axes"] == "lower-dimensional"


# ----------------------------------------------------------------------
# identities under the option


@pytest.mark.parametrize("kernel", [cg.Lucy(0.8, averaged_axes="lower-dimensional"),
                                    cg.Heaviside(0.8, averaged_axes="lower-dimensional")], ids=repr)
def test_mass_identity(kernel):
    """sum over nodes of density x cell length x averaged extent = the flowing mass. The nodes sample the kernel
    with 80 per cutoff R; every particle sits on a cell face and R is a whole number of cells, so the midpoint
    sum of the uniform Heaviside segment is exact, and that of Lucy is off by the Euler-Maclaurin term of the
    jumps of its third derivative: 7/5760 h^4 x (96 + 2 x 24) C_1 / R^3 = 0.21875 (h/R)^4 (5.3e-9 here)."""
    h, R = 0.01, kernel.radius
    box = cg.Box([0, 0, 0], [2.0, 1.5, 4.0], periodic=(True, True, False))
    rng = np.random.default_rng(5)
    z = 1.0 + h * rng.integers(0, 200, 12)
    pos = np.c_[rng.uniform(0, 2, 12), rng.uniform(0, 1.5, 12), z]
    m = rng.uniform(1, 3, 12)
    snap = cg.Snapshot(positions=pos, masses=m, radii=np.full(12, 0.1), box=box)
    grid = cg.Grid(box, (1, 1, 400), average=("x", "y"))
    rho = cg.coarse_grain(snap, grid, kernel, fields=["density"])["density"]
    total = rho.sum() * h * 2.0 * 1.5
    if isinstance(kernel, cg.Lucy):
        assert abs(total / m.sum() - 1) <= 0.22 * (h / R) ** 4
        # a 2-D map (y averaged, x periodic): the 2-D midpoint sum, within (h/R)^4 for h = R / 40
        grid = cg.Grid(box, (100, 1, 200), average="y")
        rho = cg.coarse_grain(snap, grid, kernel, fields=["density"])["density"]
        assert abs(rho.sum() * 0.02 * 0.02 * 1.5 / m.sum() - 1) <= (0.02 / R) ** 4
    else:
        assert total == pytest.approx(m.sum(), rel=1e-13)


def test_line_integral_identity():
    """e . grad psi = W(r - x_start) - W(r - x_end) for the lower-dimensional Lucy (the divergence of the
    contact stress is the force pair, the momentum balance of the 1-D kernel), to round-off."""
    dim, avg_extent = 3, 6.0
    coords = [np.linspace(-1.0, 4.0, 101)]
    target = (dim, (2,), coords, None, [False], [5.0])
    kernel = (LUCY, 1.0, 1.0, 0, avg_extent, 0, 0, 1)
    starts = np.array([[0.3, 0.1, 1.2], [0.0, 0.0, 2.0]])
    vecs = np.array([[0.5, -0.2, 0.7], [0.1, 0.3, -0.45]])
    ones = np.ones((2, 1))
    for k in range(2):
        g = _core.scatter_segments(target, kernel, starts[k:k + 1], vecs[k:k + 1], ones[:1], gradient=True)[:, 0, 0]
        w0 = _core.scatter_points(target, kernel, starts[k:k + 1], ones[:1])[:, 0]
        w1 = _core.scatter_points(target, kernel, starts[k:k + 1] + vecs[k:k + 1], ones[:1])[:, 0]
        np.testing.assert_allclose(vecs[k, 2] * g, w0 - w1, rtol=0, atol=1e-12 * np.abs(w0).max())


# ----------------------------------------------------------------------
# MercuryCG's own numbers


@pytest.fixture(scope="module")
def chute():
    """The genuine MercuryDPM chute frame at t = 15 (fixed base: particles 0..209)."""
    theta = np.radians(24)
    reader = MercuryReader(CHUTE + ".data", CHUTE + ".fstat", fixed=np.arange(210), density=6 / np.pi,
                           periodic=(True, True, False), body_force=(np.sin(theta), 0, -np.cos(theta)))
    return reader[0]


COLUMNS = [("density", "Density"), ("momentum", "Momentum"), ("momentum_flux", "MomentumFlux"),
           ("interaction_force_density", "InteractionForce"), ("volume_fraction", "VolumeFraction")]


def agree_to_printed_digits(ours, theirs):
    """|ours - theirs| within the rounding of 6 printed digits (plus round-off of sums that cancel to ~0)."""
    bound = 5.0e-6 * np.abs(theirs) + 1e-12 * max(float(np.abs(theirs).max()), 1e-300)
    return np.abs(ours - theirs) <= bound


def relative_difference(ours, theirs):
    return float(np.max(np.abs(ours - theirs)) / np.max(np.abs(theirs)))


STAT_FILES = {"Z_Lucy_w1": RUN + ".Z_Lucy_w1.stat", "Z_Heaviside_w1": CHUTE + ".Z_Heaviside_w1.stat",
              "XZ_Lucy_w1_interior": CHUTE + ".XZ_Lucy_w1_interior.stat", "Z_Gauss_w0.5": CHUTE + ".Z_Gauss_w0.5.stat"}


@pytest.mark.parametrize("name", sorted(STAT_FILES))
def test_reproduces_mercurycg_profiles(chute, name):
    """With the kernel MercuryCG's header names (StatFile.kernel(): lower-dimensional over averaged axes, and
    for the Gauss Z profile MercuryCG's approximate line integral), every column agrees to MercuryCG's 6
    printed digits, ContactStress included. With the marginal, Lucy differs by 1.5-4.5 % and Heaviside by
    11-45 %."""
    stat = read_stat(STAT_FILES[name])
    assert stat.times[0] == chute.time
    grid = stat.grid(periodic=chute.box.periodic)
    fields = [c[0] for c in COLUMNS] + ["contact_stress", "boundary_stress"]
    res = cg.coarse_grain(chute, grid, stat.kernel(), fields=fields, convention="compression")
    shape = stat.columns["Density"][0].shape
    for ours, theirs in COLUMNS:
        assert np.all(agree_to_printed_digits(res[ours].reshape(shape + res[ours].shape[3:]),
                                              stat.columns[theirs][0])), ours
    contact = (res["contact_stress"] + res["boundary_stress"]).reshape(shape + (3, 3))
    assert np.all(agree_to_printed_digits(contact, stat.columns["ContactStress"][0]))
    marginal = cg.coarse_grain(chute, grid, stat.kernel(averaged_axes="marginal"), fields=["density"])
    diff = relative_difference(marginal["density"].reshape(shape), stat.columns["Density"][0])
    if stat.function == "Gauss":
        assert diff < 5e-6
        # the exact line integral of the cut-off Gaussian is 1.5e-3 from MercuryCG's approximation
        exact = cg.coarse_grain(chute, grid, stat.kernel(line_quadrature="exact"),
                                fields=["contact_stress", "boundary_stress"], convention="compression")
        contact = (exact["contact_stress"] + exact["boundary_stress"]).reshape(shape + (3, 3))
        assert relative_difference(contact, stat.columns["ContactStress"][0]) > 1e-4
    else:
        assert diff > 1e-2


def test_mercurycg_gauss_line_of_one_contact():
    """MercuryCG's Gauss "line integral" on a Z profile (Gauss::evaluateCGIntegral1D), written out here:
    psi = P(d) [erf(hi/s) - erf(lo/s)], P(d) = 1 / (2 [G(c + d) - G(-c)]), G(x) = x erf(x/s) + s/sqrt(pi)
    exp(-x^2/s^2), s = sqrt(2) w, c = 3 w, lo <= hi the branch ends' offsets from the node, d = hi - lo."""
    w = 0.4
    c, s = 3 * w, math.sqrt(2) * w
    box = cg.Box([0, 0, 0], [3.0, 2.0, 5.0])
    xi, xj = np.array([1.0, 1.0, 2.1]), np.array([1.4, 0.8, 2.95])
    force = np.array([0.3, -0.2, 1.7])
    contacts = cg.Contacts(i=[0], j=[1], force=[force], point=[0.5 * (xi + xj)])
    snap = cg.Snapshot(positions=[xi, xj], masses=[1.0, 1.0], radii=[0.5, 0.5], box=box, contacts=contacts)
    grid = cg.Grid(box, (1, 1, 50), average=("x", "y"))
    kernel = cg.Gaussian(w, cutoff=c, normalize="truncated", line_quadrature="mercurycg")
    assert kernel.mercurycg_line and "mercurycg" in repr(kernel)
    sigma = cg.coarse_grain(snap, grid, kernel, fields=["contact_stress"])["contact_stress"].reshape(50, 3, 3)

    def G(x):
        return x * math.erf(x / s) + s / math.sqrt(math.pi) * math.exp(-(x / s) ** 2)

    d = xj[2] - xi[2]
    psi = []
    for z in grid.axis_coordinates[2]:
        lo, hi = xi[2] - z, xj[2] - z
        psi.append(0.0 if hi < -c or lo > c else (math.erf(hi / s) - math.erf(lo / s)) / (2 * (G(c + d) - G(-c))))
    expected = -np.einsum("a,b,p->pab", force, xi - xj, np.array(psi)) / (3.0 * 2.0)
    np.testing.assert_allclose(sigma, expected, rtol=1e-12, atol=1e-14 * np.abs(expected).max())
    # it is not the exact integral of the cut-off kernel (1e-3..1e-2 apart near the cutoff)
    exact = cg.coarse_grain(snap, grid, cg.Gaussian(w, cutoff=c, normalize="truncated"),
                            fields=["contact_stress"])["contact_stress"].reshape(50, 3, 3)
    assert 1e-3 < relative_difference(exact, expected) < 1e-1


MERCURYCG_GAUSS = (GAUSSIAN, 0.45, 1.35, 1, 1.0, 0, 0, 1, 1)


@pytest.mark.parametrize("ray", [False, True], ids=["segment", "ray"])
@pytest.mark.parametrize("case", [c for c in averaged_cases() if len(c[1][1]) == c[0] - 1], ids=case_id)
def test_mercurycg_gauss_line_matches_oracle(case, ray):
    dim, layout, which = case
    periodic = periodic_flags(dim, which)
    target, tgt = make_target(dim, layout, periodic, seed_of(case))
    core_kernel = MERCURYCG_GAUSS[:4] + (tgt[4],) + MERCURYCG_GAUSS[5:]
    ref_kernel = OracleKernel("gaussian", dim, 0.45, 1.35, truncated=True, line_points="mercurycg")
    starts, vectors, values = objects(dim, 3, seed_of(case, ray, "mercurycg"), periodic)
    if ray and diverges(periodic, tgt[1]):
        with pytest.raises(ValueError):
            _core.scatter_segments(target, core_kernel, starts, vectors, values, ray=True)
        return
    if ray:
        steer_rays(vectors, periodic, tgt[1])   # rays stay exact
    else:
        vectors[0] = 0.0   # no extent: the point value
    out = _core.scatter_segments(target, core_kernel, starts, vectors, values, ray=ray)
    ref = oracle_scatter_segments(ref_kernel, tgt, starts, vectors, values, ray=ray)
    assert_fields_close(out, ref, RTOL, "scatter_segments")
    with pytest.raises(NotImplementedError):
        _core.scatter_segments(target, core_kernel, starts, vectors, values, gradient=True)


def test_mercurycg_gauss_line_refused_where_it_is_not_mercurycg():
    rng = np.random.default_rng(2)
    box = cg.Box([0, 0, 0], [3.0, 2.0, 4.0])
    snap = cg.Snapshot(positions=rng.uniform(0.5, 1.5, (3, 3)), masses=np.ones(3), radii=np.full(3, 0.2), box=box,
                       contacts=cg.Contacts(i=[0], j=[1], force=[[0, 0, 1.0]], point=[[1, 1, 1.0]]))
    kernel = cg.Gaussian(0.3, cutoff=0.9, normalize="truncated", line_quadrature="mercurycg")
    for where in (cg.Grid(box, (2, 2, 2)), cg.Grid(box, (2, 1, 3), average="y"), np.ones((2, 3))):
        with pytest.raises(ValueError, match="line_quadrature: 'mercurycg' is MercuryCG's line integral along one"):
            cg.coarse_grain(snap, where, kernel, fields=["contact_stress"])
    with pytest.raises(ValueError, match="line_quadrature: 'mercurycg'"):
        cg.momentum_balance_residual(snap, np.ones((2, 3)), kernel)
    with pytest.raises(ValueError, match="line_quadrature: expected 'exact', 'auto', 'mercurycg'"):
        cg.Gaussian(0.3, line_quadrature="MercuryCG")
    # the core refuses it too (a Lucy kernel, two resolved axes)
    target = (3, (0, 2), [np.array([0.5, 1.5]), np.array([1.0, 2.0])], None, [False, False], [3.0, 4.0])
    for bad in ((LUCY, 1.0, 1.0, 0, 2.0, 0, 0, 0, 1), (GAUSSIAN, 0.3, 0.9, 1, 2.0, 0, 0, 0, 1)):
        with pytest.raises(ValueError, match="mercurycg_line"):
            _core.scatter_points(target, bad, np.ones((1, 3)), np.ones((1, 1)))


def test_stat_kernel_is_lower_dimensional():
    assert stat_kernel("Lucy", 1.0).lower_dimensional
    assert stat_kernel("Heaviside", 1.0).lower_dimensional
    assert not stat_kernel("Lucy", 1.0, averaged_axes="marginal").lower_dimensional
    z = read_stat(STAT_FILES["Z_Gauss_w0.5"])
    assert z.kernel().line_quadrature == "mercurycg" and z.kernel(line_quadrature="exact").line_quadrature == "exact"
    assert read_stat(STAT_FILES["XZ_Lucy_w1_interior"]).kernel().lower_dimensional
    with pytest.raises(ValueError, match="averaged_axes"):
        stat_kernel("Lucy", 1.0, averaged_axes="1d")


def test_cli_reproduces_mercurycg_z_profile(tmp_path, capsys):
    """cgbound run on the MercuryDPM files with --averaged-kernel lower-dimensional writes MercuryCG's Z profile
    (both files printed to 6 digits: within twice the rounding); without the flag a Lucy .stat is refused."""
    from cgbound.cli import main
    out = tmp_path / "z.stat"
    fields = "density,momentum,momentum_flux,contact_stress,boundary_stress,interaction_force_density,volume_fraction"
    theta = np.radians(24)
    gravity = f"{float(np.sin(theta))!r},0,{float(-np.cos(theta))!r}"
    args = ["run", RUN + ".data", "--gravity", gravity, "--kernel", "lucy", "--cutoff", "1", "--grid", "1,1,140", "--average", "x,y", "--lower", ",,-2", "--upper", ",,12",
            "--fields", fields, "--start", "6", "--stop", "7", "-o", str(out), "-q"]
    assert main(args) == 2
    assert "--averaged-kernel lower-dimensional" in capsys.readouterr().err and not out.exists()
    assert main(args + ["--averaged-kernel", "lower-dimensional"]) == 0
    ours, theirs = read_stat(out), read_stat(RUN + ".Z_Lucy_w1.stat")
    assert ours.times[0] == theirs.times[0] == 15
    for col in ("VolumeFraction", "Density", "Momentum", "MomentumFlux", "ContactStress", "InteractionForce"):
        a, b = ours.columns[col][0], theirs.columns[col][0]
        assert np.all(np.abs(a - b) <= 1e-5 * np.abs(b) + 1e-12 * np.abs(b).max()), col
