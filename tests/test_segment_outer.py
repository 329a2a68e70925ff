"""_core.scatter_segments_outer (csrc/cg_scatter.c): segments whose values are the outer product of a factor with
their own vector, formed in the core per segment (the contact stress -f (x) a = f (x) (-a) without an (n, 9) array).
Against scatter_segments with the twin's values (tests/oracle.py, oracle_outer_values) bit for bit, for every kernel,
layout, periodicity, rays and gradients; against the slow twin of the sums at 1e-12; thread counts and both vector
builds bit for bit; the contact, boundary and extended stresses of coarse_grain bit for bit as with the NumPy values
(primaries.negated_outer); bad factors refused."""
import numpy as np
import pytest

import cgbound as cg
from cgbound import _core, _engine
from cgbound.primaries import compute_primaries, longest_branch, negated_outer, segment_sources, segment_starts
from helpers import assert_fields_close, narrow_build, random_snapshot
from oracle import OracleKernel, oracle_outer_values, oracle_scatter_segments
from test_core_sweep import KERNELS, LUCY, case_id, cases, make_kernel, make_target, objects, seed_of, \
    supports_gradient

RTOL = 1e-12


def same_bits(a, b):
    return a.shape == b.shape and np.array_equal(a, b) and np.array_equal(np.signbit(a), np.signbit(b))


def factors_of(n, n_factors, seed):
    rng = np.random.default_rng(seed)
    f = rng.normal(size=(n, n_factors))
    f[::5, 0] = 0.0                      # zero products, of either sign
    f[1::5, -1] = -0.0
    return f


def test_twin_is_the_negated_outer():
    """(-f) (x) a = f (x) (-a) to the bit, the zeros' signs included: the values the pipeline summed before."""
    rng = np.random.default_rng(1)
    f, a = rng.normal(size=(50, 3)), rng.normal(size=(50, 3))
    f[::4, 1] = 0.0
    a[::3, 2] = 0.0
    a[1::3, 0] = -0.0
    assert same_bits(oracle_outer_values(f, np.negative(a)), negated_outer(f, a))


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("case", cases(), ids=case_id)
@pytest.mark.parametrize("n_factors", [1, 3])
def test_outer_equals_values_path(case, kernel, n_factors):
    """Values, rays and (where the kernel has them) gradients: the same bits as scatter_segments given the
    twin's values; and the sums against the slow twin."""
    dim, layout, which = case
    periodic = [{"none": False, "some": d == 0, "all": True}[which] for d in range(dim)]
    target, tgt = make_target(dim, layout, periodic, seed=seed_of(case, kernel))
    core_kernel, ref_kernel = make_kernel(kernel, dim, tgt[4])
    starts, vectors, _ = objects(dim, 7, seed_of(case, kernel, "outer"), periodic)
    factors = factors_of(7, n_factors, seed_of(case, kernel, n_factors))
    values = oracle_outer_values(factors, vectors)
    out = _core.scatter_segments_outer(target, core_kernel, starts, vectors, factors)
    assert out.shape == (tgt[0].shape[0], n_factors * dim)
    assert same_bits(out, _core.scatter_segments(target, core_kernel, starts, vectors, values))
    # negate: the vectors negated in the core, as np.negative gives them (zeros' signs too)
    negated = np.negative(vectors)
    negated[::3, 0] = -0.0
    assert same_bits(_core.scatter_segments_outer(target, core_kernel, starts, np.negative(negated), factors,
                                                  negate=True),
                     _core.scatter_segments_outer(target, core_kernel, starts, negated, factors))
    if n_factors == 3 and kernel in ("lucy", "gaussian", "heaviside"):
        assert_fields_close(out, oracle_scatter_segments(ref_kernel, tgt, starts, vectors, values), RTOL,
                            "scatter_segments_outer")
    rays_ok = not all(periodic[d] for d in tgt[1]) and len(tgt[1]) > 0
    if rays_ok:
        far = np.abs(vectors).min(axis=1) > 0.05        # rays nearly along an axis may never leave
        ray_out = _core.scatter_segments_outer(target, core_kernel, starts[far], vectors[far], factors[far], ray=True)
        assert same_bits(ray_out, _core.scatter_segments(target, core_kernel, starts[far], vectors[far],
                                                         values[far], ray=True))
        assert same_bits(ray_out, _core.scatter_segments_outer(target, core_kernel, starts[far],
                                                               np.negative(vectors[far]), factors[far], ray=True,
                                                               negate=True))
    if supports_gradient(KERNELS[kernel][0], dim, len(tgt[1]), segments=True):
        grad = _core.scatter_segments_outer(target, core_kernel, starts, vectors, factors, gradient=True)
        assert same_bits(grad, _core.scatter_segments(target, core_kernel, starts, vectors, values, gradient=True))
        assert same_bits(grad, _core.scatter_segments_outer(target, core_kernel, starts, np.negative(vectors),
                                                            factors, gradient=True, negate=True))


def lattice_segments(n, spacing=1.0):
    """Contacts of an n^3 simple-cubic lattice along the axes (W1 in small): starts, vectors -a, forces."""
    axis = 0.5 * spacing + spacing * np.arange(n)
    pos = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
    idx = np.arange(n ** 3).reshape(n, n, n)
    starts, vectors = [], []
    for a in range(3):
        i = np.take(idx, range(n - 1), axis=a).ravel()
        j = np.take(idx, range(1, n), axis=a).ravel()
        starts.append(pos[i])
        vectors.append(pos[j] - pos[i])
    starts, vectors = np.concatenate(starts), np.concatenate(vectors)
    forces = np.random.default_rng(n).normal(size=starts.shape)
    forces[::3, 1:] = 0.0                                   # central forces along x on a third
    return cg.Box(np.zeros(3), np.full(3, n * spacing)), starts, vectors, forces


@pytest.mark.parametrize("kind", ["Lucy", "Heaviside", "Gaussian"])
def test_lattice_threads_and_builds_bit_for_bit(kind):
    """A lattice on a grid long enough for slabs: the same bits for 1, 2 and 3 threads and both vector builds,
    and the same bits as scatter_segments with the twin's values."""
    n = 31                        # slabs need 6 slab widths (cutoff + branch + 2 nodes) along x
    box, starts, vectors, forces = lattice_segments(n)
    kernel = {"Lucy": cg.Lucy(1.5), "Heaviside": cg.Heaviside(1.5), "Gaussian": cg.Gaussian(0.5, cutoff=1.5)}[kind]
    grid = cg.Grid(box, (n, n, n))
    target, ck = _engine.core_target(grid, box), _engine.core_kernel(kernel, 1.0)
    runs = [_core.scatter_segments_outer(target, ck, starts, vectors, forces, n_threads=t) for t in (1, 2, 3)]
    runs.append(narrow_build(lambda: _core.scatter_segments_outer(target, ck, starts, vectors, forces, n_threads=2)))
    runs += [_core.scatter_segments_outer(target, ck, starts, np.negative(vectors), forces, n_threads=t, negate=True)
             for t in (1, 2)]
    reference = _core.scatter_segments(target, ck, starts, vectors, oracle_outer_values(forces, vectors), n_threads=1)
    assert np.count_nonzero(reference) > 0.5 * reference.size
    for i, run in enumerate(runs):
        assert same_bits(run, reference), i


@pytest.mark.parametrize("kernel", [cg.Lucy(1.3), cg.Heaviside(1.1), cg.Gaussian(0.4),
                                    cg.Gaussian(0.4, line_quadrature="auto")], ids=repr)
@pytest.mark.parametrize("seed", [0, 1])
def test_stress_primaries_as_numpy_values(kernel, seed):
    """The contact, boundary and extended stresses' primaries (sb, sw, sx): the same bits as summing the NumPy
    values -f (x) a (segment_sources) with scatter_segments, for 1 and 2 threads; and coarse_grain's contact
    stress is its primary."""
    snap = random_snapshot(seed)
    grid = cg.Grid(snap.box, (5, 4, 6))
    bulk, boundary = snap.split_contacts()
    target = _engine.core_target(grid, snap.box)
    longest = longest_branch(bulk, boundary) if kernel.resolves_from_branch else None
    line_kernel = _engine.core_kernel(kernel, grid.avg_extent, longest)
    for nt in (1, 2):
        with cg.threads(nt):
            sums = compute_primaries(snap, grid, kernel, {"sb", "sw", "sx"}, np.zeros(3))
            res = cg.coarse_grain(snap, grid, kernel, fields=("contact_stress",))
        for name, part, ray in (("sb", bulk, False), ("sw", boundary, False), ("sx", boundary, True)):
            assert part["i"].size
            starts, vectors, values = segment_sources(snap, part)
            expected = _core.scatter_segments(target, line_kernel, starts, vectors, values, ray=ray, n_threads=nt)
            assert same_bits(sums[name].reshape(expected.shape), expected), (name, nt)
        assert same_bits(res["contact_stress"].reshape(-1, 3, 3), sums["sb"].reshape(-1, 3, 3)), nt


@pytest.mark.parametrize("all_bulk", [False, True])
def test_split_contacts_starts_are_the_particles_centres(all_bulk):
    """split_contacts' start (the segments' starts, gathered once) is r_i of each part's particles, in the
    all-bulk path and the general one; segment_starts takes it, and gathers r_i for parts without it."""
    snap = random_snapshot(0)
    if all_bulk:
        c = snap.contacts
        keep = (c.j >= 0) & ~snap.fixed[c.i] & ~snap.fixed[np.maximum(c.j, 0)]
        snap = cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box,
                           contacts=cg.Contacts(c.i[keep], c.j[keep], c.force[keep], c.point[keep]))
    bulk, boundary = snap.split_contacts()
    assert bulk["i"].size and (boundary["i"].size or all_bulk)
    for part in (bulk, boundary):
        assert np.array_equal(part["start"], snap.positions[part["i"]])
        assert segment_starts(snap, part) is part["start"]
        without = {key: value for key, value in part.items() if key != "start"}
        assert np.array_equal(segment_starts(snap, without), part["start"])


def test_bad_factors_are_refused():
    dim = 3
    target, tgt = make_target(dim, ("grid", ()), [False] * dim)
    core_kernel, _ = make_kernel("lucy", dim, 1.0)
    starts, vectors, _ = objects(dim, 4, 0, [False] * dim)
    with pytest.raises(ValueError, match="factors: expected at most 9 columns"):
        _core.scatter_segments_outer(target, core_kernel, starts, vectors, np.ones((4, 10)))
    with pytest.raises(ValueError, match="factors"):
        _core.scatter_segments_outer(target, core_kernel, starts, vectors, np.ones((3, 3)))
    with pytest.raises(ValueError, match="factors: expected at least one column"):
        _core.scatter_segments_outer(target, core_kernel, starts, vectors, np.ones((4, 0)))
    assert LUCY == KERNELS["lucy"][0] and OracleKernel      # the sweep's tables, as imported


@pytest.mark.parametrize("kind", ["Lucy", "Gaussian"])
def test_slab_plan_from_node_buckets_as_general_plan(kind):
    """With at least one object per node the slabs are read off the spatial order's node buckets
    (csrc/cg_scatter.c, plan_slabs); with fewer, they are counted object by object. Segments given in node order
    keep that order in both, so adding objects far outside the grid (they reach no node: they add nothing) to pass
    from the one plan to the other must leave every bit of the sums as it was, for 1 and 2 threads."""
    n = 24
    box, starts, vectors, forces = lattice_segments(n)
    grid = cg.Grid(box, (2 * n, 2 * n, 2 * n))                     # P = 8 n^3 > 3 n^2 (n - 1) segments
    h = box.lengths / (2 * n)
    node = np.floor((starts - (box.lower + 0.5 * h)) / h + 0.5).astype(int)
    by_node = np.lexsort((node[:, 2], node[:, 1], node[:, 0]))
    starts, vectors, forces = starts[by_node], vectors[by_node], forces[by_node]
    values = oracle_outer_values(forces, vectors)
    P = grid.size
    assert len(starts) < P
    extra = P - len(starts) + 5
    far_starts = np.vstack([starts, np.full((extra, 3), -1e3)])
    far_vectors = np.vstack([vectors, np.tile([[0.5, 0.0, 0.0]], (extra, 1))])
    far_values = np.vstack([values, np.ones((extra, 9))])
    kernel = {"Lucy": cg.Lucy(1.5), "Gaussian": cg.Gaussian(0.5, cutoff=1.5)}[kind]
    target, ck = _engine.core_target(grid, box), _engine.core_kernel(kernel, 1.0)
    for nt in (1, 2):
        counted = _core.scatter_segments(target, ck, starts, vectors, values, n_threads=nt)
        from_buckets = _core.scatter_segments(target, ck, far_starts, far_vectors, far_values, n_threads=nt)
        assert np.count_nonzero(counted) > 0.5 * counted.size
        assert same_bits(from_buckets, counted), nt
