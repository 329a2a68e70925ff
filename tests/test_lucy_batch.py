"""Lucy's (and Heaviside's) segments on grids, the whole-box path and the batched passes (csrc/cg_lucy.c, csrc/cg_lucy_line.c):
short segments along the axes (lattice contacts) take the stencil box whole instead of narrowing it row by row,
Lucy's gathered nodes take their frames and values in one vector pass (Heaviside's: frames and a reach test
first, then the values of the nodes that may reach); a contact stress's 9 values are added as one vector.
Points of Lucy and Heaviside: each particle's nodes in a batch, values and sums vectorised. Checked against the node-by-node path bit for bit
with 9 random values per segment (lattices in 2-D and 3-D, long segments that overflow a batch, nodes exactly on
the support's edge, coordinates near 1e6, periodic boxes), against 50-digit quadrature at 1e-12, and the slabs'
scheduling (csrc/cg_scatter.c) for thread counts bit for bit on grids with odd and even slab counts."""
import mpmath as mp
import numpy as np
import pytest

import cgbound as cg
from cgbound import _core, _engine
from helpers import narrow_build
from stability_log import record
from test_hard_cases import rel_error
from test_lucy_closed_form import grid_nodes
from test_lucy_lines import mp_lucy_psi

RTOL = 1e-12


def scatter(box, shape, kernel, starts, vectors, values, per_node=False, n_threads=1, segments=True):
    """The core's sums at the grid's nodes, shape (P, K); per_node: the node-by-node path."""
    grid = cg.Grid(box, shape)
    kernel._per_node = per_node
    target = _engine.core_target(grid, box)
    core_kernel = _engine.core_kernel(kernel, 1.0)
    starts = np.ascontiguousarray(np.atleast_2d(np.asarray(starts, float)))
    values = np.ascontiguousarray(values, dtype=float)
    if not segments:
        return _core.scatter_points(target, core_kernel, starts, values, n_threads=n_threads)
    vectors = np.ascontiguousarray(np.atleast_2d(np.asarray(vectors, float)))
    return _core.scatter_segments(target, core_kernel, starts, vectors, values, n_threads=n_threads)


def lattice_contacts(n, dim, spacing=0.99, offset=0.5):
    """Neighbour pairs of an n^dim simple-cubic lattice: starts and branch vectors along the axes."""
    axis = offset + spacing * np.arange(n)
    pos = np.stack(np.meshgrid(*([axis] * dim), indexing="ij"), axis=-1).reshape(-1, dim)
    idx = np.arange(n ** dim).reshape((n,) * dim)
    starts, vectors = [], []
    for a in range(dim):
        i = np.take(idx, range(n - 1), axis=a).ravel()
        j = np.take(idx, range(1, n), axis=a).ravel()
        starts.append(pos[i])
        vectors.append(pos[j] - pos[i])
    return np.concatenate(starts), np.concatenate(vectors)


KERNELS = {"Lucy": cg.Lucy, "Heaviside": cg.Heaviside}


def assert_fast_equals_node_by_node(box, shape, R, starts, vectors, what, seed=0, n_values=9, kernel="Lucy"):
    rng = np.random.default_rng(seed)
    values = rng.normal(size=(len(np.atleast_2d(starts)), n_values))
    values[3::7] = 0.0                                    # zero tensors add nothing, on both paths
    make = KERNELS[kernel]
    fast = scatter(box, shape, make(R), starts, vectors, values)
    slow = scatter(box, shape, make(R), starts, vectors, values, per_node=True)
    assert np.count_nonzero(fast) > 0, what
    assert np.array_equal(fast, slow), what
    return fast


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("R", [1.5, 1.2, 2.0, 0.99, 3.1])
@pytest.mark.parametrize("dim", [2, 3])
def test_lattice_contacts_equal_node_by_node(dim, R, kernel):
    """W1's geometry in small: contacts along the axes, grid nodes nearly on the particles (the whole box),
    with 9 values (the vectorised sum) and 1 (the general sum)."""
    n = 7 if dim == 3 else 12
    starts, vectors = lattice_contacts(n, dim)
    side = (n - 1) * 0.99 + 1.0
    box = cg.Box(np.zeros(dim), np.full(dim, side))
    shape = (n,) * dim
    assert_fast_equals_node_by_node(box, shape, R, starts, vectors, f"{dim}D R {R}", kernel=kernel)
    assert_fast_equals_node_by_node(box, shape, R, starts, vectors, f"{dim}D R {R}, 1 value", n_values=1,
                                    kernel=kernel)
    # one contact at a time: nothing of one object's batch leaks into the next
    for k in range(0, len(starts), max(1, len(starts) // 9)):
        assert_fast_equals_node_by_node(box, shape, R, starts[k], vectors[k], f"{dim}D R {R}, contact {k}",
                                        kernel=kernel)


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("offset", [0.5, 0.0, 0.25])
@pytest.mark.parametrize("R", [1.0, 1.5, 2.0])
def test_nodes_on_the_support_edge(R, offset, kernel):
    """Segments from nodes (offset 0.5: nodes at whole distances from the segment, so at exactly R along the
    axes beyond its ends and across it) or between them, of whole, half and tiny lengths along each axis and
    against them: the whole box's margins and the reach test keep every node the closed form accepts."""
    box, shape = cg.Box([0, 0, 0], [9, 9, 9]), (9, 9, 9)      # nodes at 0.5, 1.5, ..., 8.5
    starts, vectors = [], []
    for axis in range(3):
        for length in (1.0, 2.0, 0.5, 1e-9, -1.0, -3.0):
            v = np.zeros(3)
            v[axis] = length
            starts.append(np.full(3, 4.0 + offset))
            vectors.append(v)
    starts, vectors = np.array(starts), np.array(vectors)
    for k in range(len(starts)):
        assert_fast_equals_node_by_node(box, shape, R, starts[k], vectors[k], f"R {R}, offset {offset}, {k}",
                                        kernel=kernel)


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("direction", [[0, 0, 1], [1, 0, 0], [0, 1, 0], [1e-7, 0, 1], [0.3, -0.2, 1]])
def test_long_segments_overflow_a_batch(direction, kernel):
    """Segments 40 spacings long reach more nodes than one batch holds (256): flushed part-way through a box
    or a row, the sums are unchanged."""
    box, shape = cg.Box([0, 0, 0], [12, 12, 60]), (12, 12, 60)
    d = np.asarray(direction, float)
    d /= np.linalg.norm(d)
    starts = np.array([[6.0, 6.0, 8.0], [5.5, 6.5, 9.5], [6.2, 5.9, 8.3]])
    vectors = np.array([40.0 * d] * 3)
    for R in (1.5, 1.0, 2.5):
        assert_fast_equals_node_by_node(box, shape, R, starts, vectors, f"{direction}, R {R}", kernel=kernel)


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("dim", [2, 3])
def test_lattice_far_from_the_origin(dim, kernel):
    """Lattice contacts near 1e6 with R = 1.5e-3 on a 1e-3 grid (the margins for the rounding of offsets)."""
    n = 6
    lo = np.array([1e6, -1e6, 1e6][:dim])
    starts, vectors = lattice_contacts(n, dim, spacing=0.99e-3, offset=0.5e-3)
    box = cg.Box(lo, lo + (n - 1) * 0.99e-3 + 1e-3)
    assert_fast_equals_node_by_node(box, (n,) * dim, 1.5e-3, starts + lo, vectors, f"{dim}D near 1e6",
                                    kernel=kernel)


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("dim", [2, 3])
def test_periodic_lattice(dim, kernel):
    """Contacts across the periodic boundary (their images) on the whole-box path."""
    n = 8
    starts, vectors = lattice_contacts(n, dim, spacing=1.0, offset=0.5)
    # the last layer's contacts to the first layer's particles through the boundary
    wrap = starts[:, 0] > n - 1
    extra_s = starts.copy()
    extra_s[:, 0] = n - 0.5
    extra_v = np.zeros_like(vectors)
    extra_v[:, 0] = 1.0
    starts, vectors = np.concatenate([starts, extra_s[~wrap][: n ** (dim - 1)]]), \
        np.concatenate([vectors, extra_v[~wrap][: n ** (dim - 1)]])
    box = cg.Box(np.zeros(dim), np.full(dim, float(n)), periodic=(True,) * dim)
    assert_fast_equals_node_by_node(box, (n,) * dim, 1.5, starts, vectors, f"{dim}D periodic", kernel=kernel)


@pytest.mark.parametrize("seed", range(6))
def test_heaviside_random_segments_equal_node_by_node(seed):
    """Heaviside's segments take the same path (its value: the clipped part of the segment): random segments
    in 2-D and 3-D, periodic or not, nearly zero length, nearly along the row axis, and along special
    directions, against the node-by-node path bit for bit."""
    rng = np.random.default_rng(100 + seed)
    for dim in (2, 3):
        for periodic in ((False,) * dim, (True,) * dim):
            box = cg.Box(np.zeros(dim), np.full(dim, 6.0), periodic=periodic)
            shape = tuple(rng.integers(5, 14, size=dim))
            R = float(10 ** rng.uniform(-0.4, 0.4))
            starts = rng.uniform(-0.5, 6.5, size=(40, dim))
            vectors = rng.normal(size=(40, dim)) * 10 ** rng.uniform(-3, 0.3, size=(40, 1))
            vectors[:5] *= 1e-12                                  # nearly zero length
            vectors[5:10, :-1] *= 1e-10                           # nearly along the row axis
            assert_fast_equals_node_by_node(box, shape, R, starts, vectors, f"seed {seed}, {dim}D, {periodic}",
                                            kernel="Heaviside")
    box, shape = cg.Box([0, 0, 0], [8, 8, 8]), (8, 8, 8)
    for d in ([1, 1, 1], [1e-9, 0, 1], [1, -1, 1e-7], [1, 1, 0]):
        d = np.asarray(d, float) / np.linalg.norm(d)
        for start in ([3.5, 3.5, 3.5], [3.2, 4.1, 3.7]):
            for length in (1.0, 2.0, 1e-9):
                assert_fast_equals_node_by_node(box, shape, 1.0 + seed % 3 * 0.5, start, length * d,
                                                f"{d}, {start}, {length}", kernel="Heaviside")


def test_heaviside_against_chord_lengths():
    """Heaviside's values on the grid path against the chord of the ball (exact, NumPy): prefactor times
    the length of the segment inside the ball over its length, at 1e-14."""
    R = 1.5
    box, shape = cg.Box([0, 0, 0], [8, 8, 8]), (8, 8, 8)
    start, vector = np.array([3.49, 3.52, 3.5]), np.array([0.3, -0.2, 0.9])
    got = scatter(box, shape, cg.Heaviside(R), start, vector, np.ones((1, 1)))[:, 0]
    nodes = grid_nodes(cg.Grid(box, shape))
    L = np.linalg.norm(vector)
    n = vector / L
    u = (nodes - start) @ n
    a2 = np.sum((nodes - start - u[:, None] * n) ** 2, axis=1)
    b = np.sqrt(np.clip(R * R - a2, 0, None))
    inside = np.clip(np.minimum(u + b, L) - np.maximum(u - b, 0.0), 0, None) / L
    inside[a2 >= R * R] = 0.0
    want = inside * 3.0 / (4.0 * np.pi * R ** 3)
    assert np.count_nonzero(want) > 0
    assert np.max(np.abs(got - want)) <= 1e-14 * np.max(want)


@pytest.mark.parametrize("case", ["along z", "along x", "2d along y"])
def test_whole_box_values_against_mpmath(case):
    """The whole-box path's values against 50-digit quadrature, relative to the field's scale."""
    R = 1.5
    box, shape = cg.Box([0, 0, 0], [8, 8, 8]), (8, 8, 8)
    start, vector = np.array([3.49, 3.52, 3.5]), np.array([0.0, 0.0, 0.99])
    if case == "along x":
        vector = np.array([0.99, 0.0, 0.0])
    elif case == "2d along y":
        box, shape = cg.Box([0, 0], [8, 8]), (8, 8)
        start, vector = np.array([3.49, 3.52]), np.array([0.0, 0.99])
    mp.mp.dps = 50
    got = scatter(box, shape, cg.Lucy(R), start, vector, np.ones((1, 1)))[:, 0]
    grid = cg.Grid(box, shape)
    want = np.array([float(mp_lucy_psi(p - start, vector, R)) for p in grid_nodes(grid)])
    err = rel_error(got, want)
    record(f"Lucy whole box against mpmath: {case}", err)
    assert np.count_nonzero(want) > 0
    assert err <= RTOL, case


@pytest.mark.parametrize("dim", [2, 3])
def test_segments_batched_across_contacts_equal_node_by_node(dim):
    """Lucy's whole boxes wait in a batch of several contacts (their values computed together, their terms added
    in object order): mixed with zero-length segments (the node-by-node path), oblique ones (narrowed rows) and boxes
    of 5-8 and more than 8 nodes per row, shuffled, the sums equal the node-by-node path's bit for bit, on 1 and 2
    threads and with factors (the outer product formed per object)."""
    rng = np.random.default_rng(dim)
    n = 8 if dim == 3 else 20
    starts, vectors = lattice_contacts(n, dim)
    m = len(starts)
    along = rng.integers(0, m, m // 6)
    vectors[along] *= rng.uniform(3.0, 9.0, (len(along), 1))          # rows of 5-8 and more nodes
    vectors[rng.integers(0, m, m // 20)] = 0.0                          # zero length: node by node
    oblique = rng.integers(0, m, m // 10)
    vectors[oblique] = rng.normal(scale=1.5, size=(len(oblique), dim))  # narrowed rows
    order = rng.permutation(m)
    starts, vectors = starts[order], vectors[order]
    side = (n - 1) * 0.99 + 1.0
    box = cg.Box(np.zeros(dim), np.full(dim, side))
    shape = (n,) * dim
    fast = assert_fast_equals_node_by_node(box, shape, 1.5, starts, vectors, f"{dim}D mixed", seed=dim)
    rng = np.random.default_rng(dim)
    values = rng.normal(size=(m, 9))
    values[3::7] = 0.0
    assert np.array_equal(fast, scatter(box, shape, cg.Lucy(1.5), starts, vectors, values, n_threads=2))
    if dim == 3:
        forces = rng.normal(size=(m, 3))
        grid = cg.Grid(box, shape)
        target = _engine.core_target(grid, box)
        outer = [_core.scatter_segments_outer(target, _engine.core_kernel(cg.Lucy(1.5), 1.0), starts, vectors,
                                              forces, n_threads=t) for t in (1, 2)]
        kernel = cg.Lucy(1.5)
        kernel._per_node = True
        slow = _core.scatter_segments(target, _engine.core_kernel(kernel, 1.0), starts, vectors,
                                      np.ascontiguousarray(np.einsum("ni,nj->nij", forces, vectors).reshape(m, 9)),
                                      n_threads=1)
        assert np.array_equal(outer[0], slow)
        assert np.array_equal(outer[1], slow)


@pytest.mark.skipif(not cg.have_openmp(), reason="serial build")
@pytest.mark.parametrize("n0", [47, 46, 40, 37])
def test_slab_schedule_thread_counts_bit_for_bit(n0):
    """Grids with a non-periodic first axis at least 6 slabs wide are cut into slabs (odd and even counts per
    colour for these first-axis sizes); slabs start as soon as their overlapping slabs of earlier colours are done. Every
    thread count and both vector builds give the same bits, for Lucy segments (9 values), Gaussian segments
    and Lucy points."""
    rng = np.random.default_rng(n0)
    side = float(n0)
    box = cg.Box([0, 0, 0], [side, 12.0, 12.0])
    shape = (n0, 12, 12)
    m = 6000
    starts = rng.uniform([0, 0, 0], [side, 12, 12], size=(m, 3))
    vectors = np.clip(rng.normal(scale=0.6, size=(m, 3)), -1.5, 1.5)  # short: slabs of 6 nodes
    vectors[: m // 2] = np.eye(3)[rng.integers(0, 3, m // 2)] * 0.99     # lattice-like: the whole box
    values = rng.normal(size=(m, 9))
    sparse = values * (rng.uniform(size=(m, 9)) < 0.4)     # zero components
    cases = [(cg.Lucy(1.5), True), (cg.Gaussian(0.7, cutoff=2.5), True), (cg.Lucy(1.5), False),
             (cg.Heaviside(1.5), True), (cg.Lucy(1.5), "sparse")]
    for kernel, segments in cases:
        if segments == "sparse":
            values, segments = sparse, True
        def run(t):
            return scatter(box, shape, kernel, starts, vectors, values, n_threads=t, segments=segments)
        one = run(1)
        assert np.count_nonzero(one) > 0
        for t in (2, 3, 4, 5):
            assert np.array_equal(one, run(t)), (type(kernel).__name__, segments, t)
        narrow = narrow_build(lambda: run(2))
        assert np.array_equal(one, narrow), (type(kernel).__name__, segments, "narrow build")


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("kernel", ["Lucy", "Heaviside"])
def test_lattice_points_equal_node_by_node(dim, kernel):
    """Particles of a jittered lattice with 13 values each (mass, momentum, momentum flux: the W1 frame's
    particle block) and 5 values (a width the vector sums split unevenly): the batched point path against the
    node-by-node path bit for bit, for thread counts and the narrow build."""
    rng = np.random.default_rng(dim)
    n = 14 if dim == 3 else 40
    axis = 0.5 + 0.99 * np.arange(n)
    pos = np.stack(np.meshgrid(*([axis] * dim), indexing="ij"), axis=-1).reshape(-1, dim)
    pos += rng.uniform(-0.2, 0.2, size=pos.shape)
    side = 0.99 * (n - 1) + 1.0
    box = cg.Box([0.0] * dim, [side] * dim)
    shape = (n,) * dim
    make = KERNELS[kernel]
    for width in (13, 5):
        values = rng.normal(size=(len(pos), width))
        for R in (1.5, 0.6):
            fast = scatter(box, shape, make(R), pos, None, values, segments=False)
            slow = scatter(box, shape, make(R), pos, None, values, per_node=True, segments=False)
            what = f"{kernel} dim {dim} width {width} R {R}"
            assert np.count_nonzero(fast) > 0, what
            assert np.array_equal(fast, slow), what
            if cg.have_openmp():
                for t in (2, 3):
                    many = scatter(box, shape, make(R), pos, None, values, n_threads=t, segments=False)
                    assert np.array_equal(fast, many), what + f" {t} threads"
            narrow = narrow_build(lambda: scatter(box, shape, make(R), pos, None, values, segments=False))
            assert np.array_equal(fast, narrow), what + " narrow build"


@pytest.mark.parametrize("fine", [1, 3])
@pytest.mark.parametrize("dim", [2, 3])
def test_values_with_zero_components_equal_node_by_node(dim, fine):
    """Contact stresses -f (x) a with zero components (W1's contacts along the axes: one non-zero component;
    random patterns of zeros, and signed zeros): the batched path against the node-by-node path bit for bit, no
    -0 where that has +0; likewise the narrow build. fine = 3: a grid three times finer than the lattice (longer
    rows, and boxes that overflow a batch)."""
    rng = np.random.default_rng(10 * dim + fine)
    n = 7 if dim == 3 else 12
    starts, vectors = lattice_contacts(n, dim)
    side = (n - 1) * 0.99 + 1.0
    box = cg.Box(np.zeros(dim), np.full(dim, side))
    shape = (fine * n,) * dim
    force = -vectors * rng.uniform(0.9, 1.1, len(vectors))[:, None]
    full = np.zeros((len(vectors), 3, 3))
    full[:, :dim, :dim] = -np.einsum("ni,nj->nij", force, vectors)
    patterns = rng.normal(size=(len(vectors), 9)) * (rng.uniform(size=(len(vectors), 9)) < 0.5)
    patterns[::5] *= -0.0                                   # signed zeros in every component
    for name, values in (("axis", full.reshape(-1, 9)), ("pattern", patterns)):
        values = np.ascontiguousarray(values)
        for R in (1.5, 0.7):
            fast = scatter(box, shape, cg.Lucy(R), starts, vectors, values)
            slow = scatter(box, shape, cg.Lucy(R), starts, vectors, values, per_node=True)
            what = f"{dim}D fine {fine} {name} R {R}"
            assert np.count_nonzero(fast) > 0, what
            assert np.array_equal(fast, slow), what
            assert not np.signbit(fast[fast == 0.0]).any(), what   # no -0 where the node-by-node path has +0
            narrow = narrow_build(lambda: scatter(box, shape, cg.Lucy(R), starts, vectors, values))
            assert np.array_equal(fast, narrow), what + " narrow build"
