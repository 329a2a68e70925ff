"""Gradient, kinematics and rheology fields (docs/theory.md, "Gradients, kinematics and rheology").

The kernel gradients of the core against their oracle twin and against Richardson-extrapolated
central differences of the kernel sums; the fields of coarse_grain against oracle_rheology and
against finite differences of the velocity field; the kinematic identities; the shipped chute.
"""
import math

import numpy as np
import pytest

import cgbound as cg
from cgbound import _engine
from cgbound.fields import GRADIENT_FIELDS, RHEOLOGY_FIELDS, derive
from helpers import assert_fields_close, random_snapshot
from oracle import oracle_kernel_of, oracle_rheology, oracle_scatter_points, oracle_target

# a Gaussian whose cut-off jump exp(-c^2/2) (c = 9 widths: 3e-18) is below round-off: the gradient of the
# smooth part the core sums is then the derivative of the field itself
SMOOTH_GAUSSIAN = cg.Gaussian(0.45, cutoff=9 * 0.45)
KERNELS = {"gaussian": cg.Gaussian(0.45, cutoff=1.6), "gaussian-smooth": SMOOTH_GAUSSIAN,
           "gaussian-truncated": cg.Gaussian(0.45, cutoff=1.6, normalize="truncated"), "lucy": cg.Lucy(1.3)}
# (dim, averaged axes)
LAYOUTS = [(2, ()), (2, ("x",)), (2, ("z",)), (3, ()), (3, ("x",)), (3, ("y", "z")), (3, ("x", "y"))]
ALL_FIELDS = RHEOLOGY_FIELDS


def small_box(dim, periodic):
    lengths = np.array([3.0, 2.6, 3.4][:dim]) if dim == 3 else np.array([3.0, 3.4])
    return cg.Box(-0.3 * lengths, 0.7 * lengths, periodic=periodic)


def random_objects(box, n, seed, width=2):
    rng = np.random.default_rng(seed)
    pos = box.lower + rng.uniform(-0.2, 1.2, (n, box.dim)) * box.lengths   # some outside: periodic images
    return pos, rng.normal(size=(n, width))


def shifted_target(target, axis, shift):
    """The core target with every node moved by ``shift`` along resolved axis number ``axis``."""
    if target.points is not None:
        pts = np.array(target.points, float)
        pts[:, axis] += shift
        return target._replace(points=pts)
    coords = [np.array(c, float) for c in target.coordinates]
    coords[axis] = coords[axis] + shift
    return target._replace(coordinates=coords)


def difference_step(kernel):
    """The step of the central differences: 1 % of the Gaussian's width (Richardson's O(h^4) error ~1e-8);
    0.01 % of Lucy's cutoff (W = C (1 - 6x^2 + 8x^3 - 3x^4) has a |r|^3 term at r = 0 and a (R - r)^3 edge, whose
    jumps in the third derivative leave an O(h^2) error, ~1e-8 of the gradient's scale, at nodes within h of
    them; more where a velocity divides by a small density)."""
    return kernel.width / 100 if isinstance(kernel, cg.Gaussian) else kernel.radius / 10000


def richardson_gradient(value_at, n_resolved, h):
    """d/dx_a of value_at(axis, shift) at shift 0 for every resolved axis: central differences with steps h
    and h/2 combined by Richardson extrapolation (error O(h^4) for a smooth field); shape (..., n_resolved)."""
    out = []
    for a in range(n_resolved):
        central = [(value_at(a, s) - value_at(a, -s)) / (2 * s) for s in (h, h / 2)]
        out.append((4 * central[1] - central[0]) / 3)
    return np.stack(out, axis=-1)


# --- 1. the core's gradients ---------------------------------------------------------------------

@pytest.mark.parametrize("dim,average", LAYOUTS)
@pytest.mark.parametrize("name", ["gaussian", "gaussian-truncated", "lucy"])
@pytest.mark.parametrize("periodic", [False, True])
def test_core_gradient_matches_the_oracle_on_grids(dim, average, name, periodic):
    """scatter_points(gradient=True) on grids with and without averaged axes against oracle_scatter_points."""
    box = small_box(dim, [periodic] * (dim - 1) + [False])
    grid = cg.Grid(box, 5, average=average)
    kernel = KERNELS[name]
    pos, vals = random_objects(box, 9, 7 + dim)
    got = _engine.scatter_points(_engine.core_target(grid, box), _engine.core_kernel(kernel, grid.avg_extent),
                                 pos, vals, gradient=True)
    expected = oracle_scatter_points(oracle_kernel_of(kernel, dim), oracle_target(grid, box), pos, vals,
                                     gradient=True)
    assert got.shape == (grid.size, 2, dim - len(average))
    assert_fields_close(got, expected, 1e-12, f"{name} {average}")


@pytest.mark.parametrize("dim,average", LAYOUTS)
@pytest.mark.parametrize("name", ["gaussian", "gaussian-smooth", "lucy"])
@pytest.mark.parametrize("periodic", [False, True])
def test_gradient_rows_equal_node_by_node_bit_for_bit(dim, average, name, periodic):
    """Gradients of points on grids visit only the support ball's rows (cg_gradient_rows.c, the full kernels'
    factors a row at a time): the same sums as every node of the stencil box evaluated on its own, bit for bit,
    on fine and coarse grids (a support of many and of few nodes: batches of nodes full within an object) and
    nodes exactly on particles; 1 to 9 values (in 3-D, groups of four values are added as vectors, the rest one
    by one)."""
    box = small_box(dim, [periodic] * (dim - 1) + [False])
    kernel = KERNELS[name]
    for n, width in ((4, 3), (23, 3), (4, 9), (23, 4), (11, 1), (11, 5)):
        grid = cg.Grid(box, n, average=average)
        pos, vals = random_objects(box, 40, 11 + dim + n + width, width=width)
        nodes = np.stack(np.meshgrid(*grid.axis_coordinates, indexing="ij"), -1).reshape(-1, dim)
        pos[:3] = nodes[[0, len(nodes) // 2, -1]]
        target = _engine.core_target(grid, box)
        results = []
        for per_node in (False, True):
            kernel._per_node = per_node
            try:
                results.append(_engine.scatter_points(target, _engine.core_kernel(kernel, grid.avg_extent), pos,
                                                      vals, gradient=True))
            finally:
                kernel._per_node = False
        assert np.count_nonzero(results[1]) > 0
        assert np.array_equal(results[0], results[1]), (name, average, n, width)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("name", ["gaussian", "lucy"])
def test_core_gradient_matches_the_oracle_at_points(dim, name):
    box = small_box(dim, [True] * (dim - 1) + [False])
    kernel = KERNELS[name]
    pos, vals = random_objects(box, 9, 3)
    points = cg.Points(random_objects(box, 15, 4)[0])
    got = _engine.scatter_points(_engine.core_target(points, box), _engine.core_kernel(kernel, 1.0), pos, vals,
                                 gradient=True)
    expected = oracle_scatter_points(oracle_kernel_of(kernel, dim), oracle_target(points, box), pos, vals,
                                     gradient=True)
    assert_fields_close(got, expected, 1e-12, name)


def test_everything_averaged_gives_no_gradient_components():
    box = small_box(3, [True, True, False])
    grid = cg.Grid(box, 1, average=("x", "y", "z"))
    pos, vals = random_objects(box, 5, 1)
    got = _engine.scatter_points(_engine.core_target(grid, box), _engine.core_kernel(cg.Lucy(1.0), grid.avg_extent),
                                 pos, vals, gradient=True)
    assert got.shape == (1, 2, 0)


@pytest.mark.parametrize("dim,average", LAYOUTS)
@pytest.mark.parametrize("name", ["gaussian-smooth", "lucy"])
@pytest.mark.parametrize("periodic", [False, True])
def test_core_gradient_is_the_derivative_of_the_kernel_sum(dim, average, name, periodic):
    """The analytic gradient against Richardson-extrapolated central differences of the value sums, on grids
    (averaged axes: the derivative of the marginal along the resolved axes) and at points."""
    box = small_box(dim, [periodic] * (dim - 1) + [False])
    kernel = KERNELS[name]
    pos, vals = random_objects(box, 9, 11 + dim)
    for where in (cg.Grid(box, 5, average=average), cg.Points(random_objects(box, 12, 5)[0]) if not average else None):
        if where is None:
            continue
        target = _engine.core_target(where, box)
        core_kernel = _engine.core_kernel(kernel, where.avg_extent)
        n_res = len(where.resolved)
        got = _engine.scatter_points(target, core_kernel, pos, vals, gradient=True)

        def value_at(axis, shift):
            return _engine.scatter_points(shifted_target(target, axis, shift), core_kernel, pos, vals)

        expected = richardson_gradient(value_at, n_res, difference_step(kernel))
        assert_fields_close(got, expected, 1e-7, f"{name} {where!r}")


def test_lucy_segments_with_averaged_axes_still_have_no_gradient():
    """Only point gradients were extended to averaged axes: Lucy's segment gradients there are refused."""
    box = small_box(3, [True, True, False])
    grid = cg.Grid(box, 4, average=("x",))
    pos, vals = random_objects(box, 3, 2)
    with pytest.raises(NotImplementedError):
        _engine.scatter_segments(_engine.core_target(grid, box), _engine.core_kernel(cg.Lucy(1.0), grid.avg_extent),
                                 pos, np.ones_like(pos), vals, gradient=True)


# --- 2. the fields against their twin ----------------------------------------------------------

@pytest.mark.parametrize("dim,average", [(2, ()), (2, ("x",)), (3, ()), (3, ("x", "y")), (3, ("y",))])
@pytest.mark.parametrize("name", ["gaussian", "lucy"])
def test_fields_match_the_oracle(dim, average, name):
    snap = random_snapshot(21 + dim, dim=dim, n=12)
    kernel = KERNELS[name]
    for where in (cg.Grid(snap.box, 4, average=average), None if average else cg.Points(snap.positions[:5] + 0.1)):
        if where is None:
            continue
        result = cg.coarse_grain(snap, where, kernel, fields=ALL_FIELDS)
        expected = oracle_rheology(snap, where, kernel, ALL_FIELDS)
        for field in ALL_FIELDS:
            got = result[field].reshape(expected[field].shape)
            assert_fields_close(got, expected[field], 1e-10, f"{field} {where!r}")


def test_fields_match_the_oracle_over_frames():
    """Time averages: the gradients are averaged as primaries, L from the averaged sums (the twin: one snapshot
    holding every frame's particles, with masses divided by the number of frames)."""
    frames = [random_snapshot(30 + k, dim=3, n=10) for k in range(3)]
    frames = [cg.Snapshot(f.positions, f.velocities, f.masses, box=frames[0].box, radii=f.radii, time=float(k))
              for k, f in enumerate(frames)]
    grid = cg.Grid(frames[0].box, 5, average=("x", "y"))
    fields = ("density_gradient", "momentum_gradient", "velocity_gradient", "shear_rate")
    result = cg.CoarseGrain(frames, grid, KERNELS["lucy"], fields=fields).run().results
    merged = cg.Snapshot(np.concatenate([f.positions for f in frames]), np.concatenate([f.velocities for f in frames]),
                         np.concatenate([f.masses for f in frames]) / len(frames), box=frames[0].box)
    expected = oracle_rheology(merged, grid, KERNELS["lucy"], fields)
    for field in fields:
        assert_fields_close(result[field].reshape(expected[field].shape), expected[field], 1e-10, field)


@pytest.mark.parametrize("dim,average", [(2, ()), (2, ("x",)), (3, ()), (3, ("x", "y"))])
@pytest.mark.parametrize("name", ["gaussian-smooth", "lucy"])
def test_velocity_gradient_is_the_derivative_of_the_velocity(dim, average, name):
    """L from coarse_grain against Richardson differences of coarse_grain's velocity (grids moved by a shift
    of their box along each resolved axis, or points moved)."""
    snap = random_snapshot(41 + dim, dim=dim, n=14)
    kernel = KERNELS[name]
    grid = cg.Grid(snap.box, 4, average=average)
    flow = snap.positions[snap.flowing]
    points = cg.Points(flow[:4] + 0.05)
    for where in ((grid,) if average else (grid, points)):
        res = cg.coarse_grain(snap, where, kernel, fields=("velocity", "velocity_gradient", "density",
                                                         "density_gradient"))
        resolved = where.resolved

        def moved(axis, shift):
            d = resolved[axis]
            if isinstance(where, cg.Points):
                pts = where.positions.copy()
                pts[:, d] += shift
                return cg.Points(pts)
            offset = np.zeros(dim)
            offset[d] = shift
            box = cg.Box(snap.box.lower + offset, snap.box.upper + offset, periodic=snap.box.periodic)
            return cg.Grid(box, where.shape, average=average)

        def value_at(axis, shift):
            r = cg.coarse_grain(snap, moved(axis, shift), kernel, fields=("velocity", "density"))
            return np.concatenate([r.velocity.reshape(where.size, dim), r.density.reshape(where.size, 1)], axis=1)

        fd = richardson_gradient(value_at, len(resolved), difference_step(kernel))   # (P, D + 1, n_res)
        L = res.velocity_gradient.reshape(where.size, dim, dim)
        grad_rho = res.density_gradient.reshape(where.size, dim)
        dense = res.density.reshape(-1) > 1e-3 * res.density.max()
        assert_fields_close(L[dense][:, :, resolved], fd[dense][:, :dim], 1e-7, f"L {where!r}")
        assert_fields_close(grad_rho[:, resolved], fd[:, dim], 1e-7, f"grad rho {where!r}")
        averaged = [d for d in range(dim) if d not in resolved]
        assert np.all(L[:, :, averaged][dense] == 0.0) and np.all(grad_rho[:, averaged] == 0.0)


def test_heaviside_is_refused_before_any_work():
    snap = random_snapshot(1)
    for field in GRADIENT_FIELDS:
        with pytest.raises(ValueError, match=f"kernel: expected a differentiable kernel.*'{field}'"):
            cg.coarse_grain(snap, cg.Grid(snap.box, 3), cg.Heaviside(1.0), fields=[field])
        with pytest.raises(ValueError, match="kernel: expected a differentiable kernel"):
            cg.CoarseGrain([snap], cg.Grid(snap.box, 3), cg.Heaviside(1.0), fields=[field])
    # fields without a gradient still work with it
    cg.coarse_grain(snap, cg.Grid(snap.box, 3), cg.Heaviside(1.0), fields=["shear_stress", "friction"])


def test_inertial_number_needs_radii():
    snap = random_snapshot(2, radii=False)
    with pytest.raises(ValueError, match="snapshot.radii.*inertial_number"):
        cg.coarse_grain(snap, cg.Grid(snap.box, 3), cg.Lucy(1.0), fields=["inertial_number"])


# --- 3. kinematic identities -------------------------------------------------------------------

def test_kinematic_identities_on_random_data():
    """tr spin = 0, spin antisymmetric, strain rate symmetric, D + Omega = L, gamma_dot >= 0, exactly."""
    snap = random_snapshot(5, n=14)
    r = cg.coarse_grain(snap, cg.Grid(snap.box, 5), cg.Lucy(1.4),
                        fields=("velocity_gradient", "strain_rate", "spin", "shear_rate"))
    ok = np.isfinite(r.shear_rate)
    L, D, W = r.velocity_gradient[ok], r.strain_rate[ok], r.spin[ok]
    assert np.array_equal(D, np.swapaxes(D, -1, -2))
    assert np.array_equal(W, -np.swapaxes(W, -1, -2))
    assert np.all(np.trace(W, axis1=-2, axis2=-1) == 0.0)
    assert np.allclose(D + W, L, rtol=0, atol=1e-14 * np.abs(L).max())
    assert np.all(r.shear_rate[ok] >= 0.0)


def primaries_with_gradient(L, dim):
    """Primaries of one node with rho = 1, V = 0 and velocity gradient L exactly."""
    return {"rho": np.ones(1), "p_w": np.zeros((1, dim)), "grad_rho": np.zeros((1, dim)),
            "grad_p_w": np.asarray(L, float)[None]}


@pytest.mark.parametrize("dim", [2, 3])
def test_simple_shear_gives_its_shear_rate_exactly(dim):
    gamma = 0.37
    L = np.zeros((dim, dim))
    L[0, dim - 1] = gamma                                      # v_x = gamma z
    out = derive(primaries_with_gradient(L, dim), ("shear_rate", "strain_rate", "spin"), np.zeros(dim), dim,
                 "tension")
    assert out["shear_rate"][0] == pytest.approx(gamma, rel=1e-15)
    # rigid rotation (an antisymmetric L): no strain, no shear rate, spin = L
    R = L - L.T
    out = derive(primaries_with_gradient(R, dim), ("shear_rate", "strain_rate", "spin"), np.zeros(dim), dim, "tension")
    assert out["shear_rate"][0] == 0.0 and not out["strain_rate"].any()
    assert np.array_equal(out["spin"][0], R)


def test_uniform_translation_has_no_velocity_gradient():
    """p = u rho for a uniform velocity u, so L = 0 to round-off on any arrangement."""
    snap = random_snapshot(8)
    u = np.array([3.0, -1.0, 2.0])
    snap = cg.Snapshot(snap.positions, np.tile(u, (snap.n_particles, 1)), snap.masses, box=snap.box)
    r = cg.coarse_grain(snap, cg.Grid(snap.box, 6), cg.Lucy(1.4), fields=("velocity_gradient", "density",
                                                                         "density_gradient"))
    ok = r.density > 0
    scale = np.linalg.norm(u) * np.abs(r.density_gradient[ok]).max() / r.density[ok].min()
    assert np.abs(r.velocity_gradient[ok]).max() <= 1e-13 * scale


def lattice_snapshot(velocity_of, n=25, spacing=1.0):
    """A cubic lattice of n^3 unit masses centred on the origin, velocities velocity_of(positions)."""
    k = (np.arange(n) - (n - 1) / 2) * spacing
    pos = np.stack(np.meshgrid(k, k, k, indexing="ij"), axis=-1).reshape(-1, 3)
    half = (n / 2 + 1) * spacing
    return cg.Snapshot(pos, velocity_of(pos), np.ones(len(pos)), box=cg.Box([-half] * 3, [half] * 3))


def test_rigid_rotation_and_simple_shear_of_a_lattice():
    """Deep inside a lattice a Gaussian of width 1.2 spacings sees a uniform medium (Poisson summation: the
    lattice modulation is ~exp(-2 pi^2 1.2^2) = 5e-13), so a rigid rotation has D = 0 and Omega = its rotation,
    and a simple shear v_x = gamma z has gamma_dot = gamma, to that accuracy."""
    kernel = cg.Gaussian(1.2, cutoff=9 * 1.2)
    points = cg.Points(np.random.default_rng(0).uniform(-0.5, 0.5, (6, 3)))
    omega = np.array([0.3, -0.2, 0.5])
    snap = lattice_snapshot(lambda x: np.cross(omega, x))
    r = cg.coarse_grain(snap, points, kernel, fields=("strain_rate", "spin", "shear_rate"))
    # v = omega x r: L_ab = eps_acb omega_c
    expected = np.array([[0, -omega[2], omega[1]], [omega[2], 0, -omega[0]], [-omega[1], omega[0], 0]])
    assert np.abs(r.strain_rate).max() <= 1e-10 * np.linalg.norm(omega)
    assert np.abs(r.spin - expected).max() <= 1e-10 * np.linalg.norm(omega)
    gamma = 0.8
    snap = lattice_snapshot(lambda x: np.stack([gamma * x[:, 2], 0 * x[:, 0], 0 * x[:, 0]], axis=1))
    r = cg.coarse_grain(snap, points, kernel, fields=("shear_rate",))
    assert np.abs(r.shear_rate - gamma).max() <= 1e-10 * gamma


def test_shear_stress_friction_and_stress_ratio_of_a_pure_shear_stress():
    """sigma = -p I + tau (e_x e_z + e_z e_x): |tau| = tau, mu = tau / p, sigma_xz / sigma_zz = -tau / p."""
    p, tau = 2.0, 0.7
    sigma = -p * np.eye(3)
    sigma[0, 2] = sigma[2, 0] = tau
    pr = {"rho": np.ones(1), "p_w": np.zeros((1, 3)), "sk": np.zeros((1, 3, 3)), "sb": sigma[None],
          "sw": np.zeros((1, 3, 3))}
    out = derive(pr, ("shear_stress", "friction", "stress"), np.zeros(3), 3, "compression")
    assert out["shear_stress"][0] == pytest.approx(tau, rel=1e-15)
    assert out["friction"][0] == pytest.approx(tau / p, rel=1e-15)


# --- 4. the shipped chute (steady uniform flow at 26 degrees) -----------------------------------

TAN_26 = math.tan(math.radians(26.0))


@pytest.fixture(scope="module")
def chute():
    from cgbound.paper import datasets
    frames = datasets.chute_steady()
    first = frames[0]
    lower, upper = np.array(first.box.lower, float), np.array(first.box.upper, float)
    lower[2], upper[2] = -1.0, 8.0
    return frames, cg.Box(lower, upper, periodic=first.box.periodic)


def test_chute_friction_is_tan_theta_in_the_bulk(chute):
    """-sigma_xz / sigma_zz = tan 26 deg at every node of the bulk (1.5 <= z <= 4.5: over two widths from
    the base contacts and the surface) within three standard errors from five blocks of 20 frames."""
    frames, box = chute
    g = frames[0].body_force[0]
    assert math.degrees(math.atan2(g[0], -g[2])) == pytest.approx(26.0, abs=1e-9)
    grid = cg.Grid(box, (1, 1, 72), average=("x", "y"))
    kernel = cg.Gaussian(0.5)
    z = grid.axis_coordinates[2]
    bulk = (z >= 1.5) & (z <= 4.5)

    def ratio(indices):
        r = cg.CoarseGrain([frames[i] for i in indices], grid, kernel, fields=("stress",),
                           convention="compression").run().results
        return -cg.stress_ratio(r, "xz", "zz").reshape(-1)

    full = ratio(range(100))
    blocks = np.array([ratio(range(b * 20, b * 20 + 20)) for b in range(5)])
    standard_error = blocks.std(axis=0, ddof=1) / math.sqrt(5)
    assert np.all(np.abs(full[bulk] - TAN_26) <= 3 * standard_error[bulk])
    assert 0.005 < standard_error[bulk].max() < 0.05          # the check has teeth: a few per cent


def test_chute_shear_rate_is_the_derivative_of_the_velocity_profile(chute):
    """dV_x/dz of the time-averaged profile against Richardson differences of the profile itself, and the
    shear rate against the same invariant of the differenced gradient."""
    frames, box = chute
    frames = [frames[i] for i in range(0, 101, 5)]
    kernel = cg.Gaussian(0.5, cutoff=9 * 0.5)
    grid = cg.Grid(box, (1, 1, 36), average=("x", "y"))
    res = cg.CoarseGrain(frames, grid, kernel, fields=("velocity_gradient", "shear_rate", "density")).run().results

    def value_at(axis, shift):
        moved = cg.Box(box.lower + np.array([0, 0, shift]), box.upper + np.array([0, 0, shift]), periodic=box.periodic)
        r = cg.CoarseGrain(frames, cg.Grid(moved, (1, 1, 36), average=("x", "y")), kernel,
                           fields=("velocity",)).run().results
        return r.velocity.reshape(-1, 3)

    fd = richardson_gradient(value_at, 1, 0.01)[:, :, 0]        # dV_a/dz
    dense = res.density.reshape(-1) > 0.05 * res.density.max()
    L = res.velocity_gradient.reshape(-1, 3, 3)
    assert_fields_close(L[dense][:, :, 2], fd[dense], 1e-6, "dV/dz")
    L_fd = np.zeros((dense.sum(), 3, 3))
    L_fd[:, :, 2] = fd[dense]
    D = 0.5 * (L_fd + np.swapaxes(L_fd, 1, 2))
    D -= np.trace(D, axis1=1, axis2=2)[:, None, None] / 3 * np.eye(3)
    gamma_fd = np.sqrt(2 * np.einsum("pab,pab->p", D, D))
    assert_fields_close(res.shear_rate.reshape(-1)[dense], gamma_fd, 1e-6, "shear rate")
    # in the bulk the shear rate is dV_x/dz to a few per cent (the flow is a simple shear there)
    z = grid.axis_coordinates[2]
    bulk = (z >= 1.5) & (z <= 4.5)
    assert np.allclose(res.shear_rate.reshape(-1)[bulk], L[bulk, 0, 2], rtol=0.05)


# --- 5. stress_ratio ---------------------------------------------------------------------------

def test_stress_ratio_is_the_same_in_both_conventions_and_checks_its_arguments():
    snap = random_snapshot(9)
    grid = cg.Grid(snap.box, 3)
    t = cg.coarse_grain(snap, grid, cg.Lucy(1.2), fields=("stress", "density"))
    c = cg.coarse_grain(snap, grid, cg.Lucy(1.2), fields=("stress",), convention="compression")
    a = cg.stress_ratio(t, "xz", "zz")
    assert np.array_equal(a, cg.stress_ratio(c, "xz", "zz"), equal_nan=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        assert np.array_equal(a, np.where(t.stress[..., 2, 2] != 0, t.stress[..., 0, 2] / t.stress[..., 2, 2], np.nan),
                              equal_nan=True)
    with pytest.raises(ValueError, match="numerator: expected a component"):
        cg.stress_ratio(t, "xw", "zz")
    with pytest.raises(ValueError, match="field: expected one of"):
        cg.stress_ratio(t, "xz", "zz", field="density")
    with pytest.raises(ValueError, match="result: expected the field 'extended_stress'"):
        cg.stress_ratio(t, "xz", "zz", field="extended_stress")
    with pytest.raises(TypeError, match="result: expected a cgbound.Result"):
        cg.stress_ratio({"stress": 1}, "xz", "zz")


# --- 6. through the other front doors ----------------------------------------------------------

def test_tiles_give_the_same_gradients():
    snap = random_snapshot(12, n=16)
    grid = cg.Grid(snap.box, (6, 5, 4))
    fields = ("velocity_gradient", "shear_rate", "inertial_number")
    whole = cg.coarse_grain(snap, grid, KERNELS["lucy"], fields=fields)
    tiled = cg.coarse_grain_tiled(snap, grid, KERNELS["lucy"], fields=fields, tiles=(2, 2, 1), backend="serial")
    for field in fields:
        assert_fields_close(tiled[field], whole[field], 1e-12, field)


def test_command_line_writes_the_gradient_fields_and_names_the_kernel_flag(tmp_path, capsys):
    from cgbound.cli import main
    snaps = [random_snapshot(k, dim=3) for k in range(2)]
    cg.readers.write_snapshots(tmp_path / "in.h5", snaps)
    out = tmp_path / "out.npz"
    assert main(["run", str(tmp_path / "in.h5"), "--grid", "1,1,12", "--average", "x,y", "--width", "0.4",
                 "--fields", "velocity_gradient,shear_rate", "-o", str(out), "-q"]) == 0
    expected = cg.CoarseGrain(snaps, cg.Grid(snaps[0].box, (1, 1, 12), average=("x", "y")), cg.Gaussian(0.4),
                              fields=("velocity_gradient", "shear_rate")).run().results
    with np.load(out) as data:
        np.testing.assert_allclose(data["velocity_gradient"], expected.velocity_gradient, rtol=1e-13)
    capsys.readouterr()
    assert main(["run", str(tmp_path / "in.h5"), "--grid", "1,1,12", "--average", "x,y", "--kernel", "heaviside",
                 "--cutoff", "0.8", "--fields", "shear_rate", "-o", str(tmp_path / "x.npz"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "--kernel" in err and "differentiable" in err
    assert not (tmp_path / "x.npz").exists()
