"""_core.scatter_points_kinetic (csrc/cg_scatter.c): the particle fields' values m, m (v - u_ref) and m v v formed in
the core particle by particle (no (n, K) array of them). Against scatter_points with the twin's values
(tests/oracle.py, oracle_kinetic_values) bit for bit, for every kernel, layout and periodicity and every set of parts;
against the slow twin of the sums at 1e-12; thread counts and both vector builds bit for bit; the twin's values are
the pipeline's columns (primaries._particle_columns) bit for bit, and coarse_grain's particle fields the sums of
those columns; the particles' total momentum and momentum flux on a periodic grid; bad arguments and overflowing
products refused by name."""
import math

import numpy as np
import pytest

import cgbound as cg
from cgbound import _core, _engine
from cgbound.primaries import _particle_columns, compute_primaries
from helpers import assert_fields_close, narrow_build, random_snapshot
from oracle import oracle_kinetic_values, oracle_scatter_points
from test_core_sweep import KERNELS, case_id, cases, make_kernel, make_target, objects, seed_of
from test_identities import cell_volume, periodic_snapshot

RTOL = 1e-12
PARTS = [1, 2, 4, 3, 5, 6, 7]


def same_bits(a, b):
    return a.shape == b.shape and np.array_equal(a, b) and np.array_equal(np.signbit(a), np.signbit(b))


def particles(n, dim, seed):
    rng = np.random.default_rng(seed)
    m = rng.uniform(0.5, 2.0, n)
    v = rng.normal(size=(n, dim))
    v[::4, 0] = 0.0                        # zero products, of either sign
    v[1::4, -1] = -0.0
    return m, v, rng.normal(size=dim)


@pytest.mark.parametrize("dim", [2, 3])
def test_twin_is_the_pipelines_columns(dim):
    """The twin's values are those primaries._particle_columns forms with NumPy (rho, p_w, and of k the entries
    r <= c), to the bit; k's other entries equal their mirror images to the bit."""
    snap = random_snapshot(3, dim=dim)
    u_ref = np.array([0.3, -0.2, 0.1][:dim])
    block, layout = _particle_columns(snap, {"rho", "p_w", "k"}, u_ref)
    assert [name for name, *_ in layout] == ["rho", "p_w", "k"]
    rows, columns = np.triu_indices(dim)
    k = block[:, 1 + dim:].reshape(-1, dim, dim)
    assert same_bits(k, k.transpose(0, 2, 1))
    flowing = snap.flowing
    assert same_bits(oracle_kinetic_values(snap.masses[flowing], snap.velocities[flowing], u_ref, 7),
                     np.hstack([block[:, :1 + dim], k[:, rows, columns]]))


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_symmetric_index_mirrors_the_upper_triangle(dim):
    packed = np.arange(dim * (dim + 1) // 2) + 10.0
    full = np.zeros((dim, dim))
    full[np.triu_indices(dim)] = packed
    full = np.where(full == 0.0, full.T, full)
    np.testing.assert_array_equal(packed[list(_engine.symmetric_index(dim))].reshape(dim, dim), full)


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("case", cases(), ids=case_id)
def test_kinetic_equals_values_path(case, kernel):
    """Every set of parts: the same bits as scatter_points given the twin's values; all parts against the slow
    twin of the sums."""
    dim, layout, which = case
    periodic = [{"none": False, "some": d == 0, "all": True}[which] for d in range(dim)]
    target, tgt = make_target(dim, layout, periodic, seed=seed_of(case, kernel))
    core_kernel, ref_kernel = make_kernel(kernel, dim, tgt[4])
    positions, _, _ = objects(dim, 9, seed_of(case, kernel, "kinetic"), periodic)
    m, v, u = particles(9, dim, seed_of(case, kernel, "values"))
    for parts in PARTS:
        values = oracle_kinetic_values(m, v, u, parts)
        out = _core.scatter_points_kinetic(target, core_kernel, positions, m, v, u, parts)
        assert same_bits(out, _core.scatter_points(target, core_kernel, positions, values)), parts
    if kernel in ("lucy", "gaussian", "heaviside"):
        assert_fields_close(out, oracle_scatter_points(ref_kernel, tgt, positions, values), RTOL,
                            "scatter_points_kinetic")


@pytest.mark.parametrize("kind", ["Lucy", "Gaussian"])
def test_lattice_threads_and_builds_bit_for_bit(kind):
    """Particles on a grid long enough for slabs: the same bits for 1, 2 and 3 threads and both vector builds, and
    as scatter_points with the twin's values."""
    n = 24
    axis = 0.5 + np.arange(n)
    positions = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
    m, v, u = particles(len(positions), 3, n)
    box = cg.Box(np.zeros(3), np.full(3, float(n)))
    kernel = {"Lucy": cg.Lucy(1.5), "Gaussian": cg.Gaussian(0.5, cutoff=1.5)}[kind]
    grid = cg.Grid(box, (n, n, n))
    target, ck = _engine.core_target(grid, box), _engine.core_kernel(kernel, 1.0)
    runs = [_core.scatter_points_kinetic(target, ck, positions, m, v, u, 7, n_threads=t) for t in (1, 2, 3)]
    runs.append(narrow_build(lambda: _core.scatter_points_kinetic(target, ck, positions, m, v, u, 7, n_threads=2)))
    reference = _core.scatter_points(target, ck, positions, oracle_kinetic_values(m, v, u, 7), n_threads=1)
    assert np.count_nonzero(reference) > 0.5 * reference.size
    for i, run in enumerate(runs):
        assert same_bits(run, reference), i


@pytest.mark.parametrize("fields", [("density",), ("momentum",), ("density", "momentum", "momentum_flux"),
                                    ("momentum_flux", "body_force_density")])
@pytest.mark.parametrize("dim", [2, 3])
def test_particle_primaries_as_numpy_columns(fields, dim):
    """The particle primaries of compute_primaries: the same bits as summing the NumPy columns with scatter_points
    (the kinetic path where only rho, p_w and k are needed, its flux's upper triangle mirrored; the columns' block
    otherwise), fixed particles left out, for 1 and 2 threads."""
    snap = random_snapshot(5, dim=dim)
    assert snap.fixed.any()
    grid = cg.Grid(snap.box, (5, 4, 6)[:dim])
    kernel = cg.Gaussian(0.4)
    needed = cg.fields.needed_primaries(fields) & {"rho", "p_w", "k", "b"}
    u_ref = np.array([0.1, 0.2, -0.3][:dim])
    block, layout = _particle_columns(snap, needed, u_ref)
    target = _engine.core_target(grid, snap.box)
    for nt in (1, 2):
        with cg.threads(nt):
            sums = compute_primaries(snap, grid, kernel, needed, u_ref)
        expected = _core.scatter_points(target, _engine.core_kernel(kernel, 1.0), snap.positions[snap.flowing],
                                        block, n_threads=nt)
        for name, start, size, shape in layout:
            assert same_bits(sums[name].reshape(-1, size), expected[:, start:start + size]), (name, nt)


def test_bad_arguments_are_refused():
    dim = 3
    target, _ = make_target(dim, ("grid", ()), [False] * dim)
    core_kernel, _ = make_kernel("lucy", dim, 1.0)
    positions, _, _ = objects(dim, 4, 0, [False] * dim)
    m, v, u = particles(4, dim, 0)
    for parts in (0, 8, -1):
        with pytest.raises(ValueError, match="parts: expected a nonzero mask"):
            _core.scatter_points_kinetic(target, core_kernel, positions, m, v, u, parts)
    with pytest.raises(ValueError, match="masses"):
        _core.scatter_points_kinetic(target, core_kernel, positions, m[:3], v, u, 7)
    with pytest.raises(ValueError, match="velocities"):
        _core.scatter_points_kinetic(target, core_kernel, positions, m, v[:, :2], u, 7)
    with pytest.raises(ValueError, match="u_ref"):
        _core.scatter_points_kinetic(target, core_kernel, positions, m, v, u[:2], 7)
    with pytest.raises(ValueError, match="velocities: expected finite"):
        _core.scatter_points_kinetic(target, core_kernel, positions, m, np.where(v == v[0, 0], np.nan, v), u, 7)
    big = v.copy()
    big[2, 1] = 1e160                      # finite, but m v v overflows
    for parts in (4, 7):
        with pytest.raises(ValueError, match="velocities: expected the momentum .* got an overflow at particle 2"):
            _core.scatter_points_kinetic(target, core_kernel, positions, m, big, u, parts)
    huge = v.copy()
    huge[3, 0] = 1.7e308                   # m (v - u) overflows with m > 1
    m2 = m.copy()
    m2[3] = 2.0
    with pytest.raises(ValueError, match="overflow at particle 3"):
        _core.scatter_points_kinetic(target, core_kernel, positions, m2, huge, u, 2)
    # mass alone: the velocities' size does not matter
    assert np.all(np.isfinite(_core.scatter_points_kinetic(target, core_kernel, positions, m, big, u, 1)))


@pytest.mark.parametrize("dim", [2, 3])
def test_total_momentum_and_flux_on_a_resolved_periodic_grid(dim):
    """A physical identity through the kinetic path: on a periodic grid fine against the kernel, the fields summed
    over the cells are the particles' totals, sum m v and sum m v v (a sign or a factor in the core's values
    would show; the reference velocity u_ref cancels out of the momentum)."""
    snap = periodic_snapshot(1, dim=dim)
    w = 0.45
    grid = cg.Grid(snap.box, tuple(int(math.ceil(L / (w / 3))) for L in snap.box.lengths))
    out = cg.coarse_grain(snap, grid, cg.Gaussian(w, cutoff=10 * w), fields=("momentum", "momentum_flux"))
    m, v = snap.masses[snap.flowing], snap.velocities[snap.flowing]
    axes = tuple(range(dim))
    np.testing.assert_allclose(out.momentum.sum(axis=axes) * cell_volume(grid), m @ v, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(out.momentum_flux.sum(axis=axes) * cell_volume(grid),
                               np.einsum("n,ni,nj->ij", m, v, v), rtol=1e-12, atol=1e-13)
