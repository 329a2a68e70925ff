"""Lucy's segments on grids (csrc/cg_lucy.c rows, csrc/cg_lucy_line.c values): the batched row path against
the node-by-node path bit for bit on segments chosen to stress the narrowing of planes and rows (along, across
and nearly along the row axis, through nodes, grazing the support at nodes, near 1e6 with a small cutoff, nearly
zero length), and against 50-digit quadrature at 1e-12 of the field's scale; thread counts and vector builds
bit for bit."""
import mpmath as mp
import numpy as np
import pytest

import cgbound as cg
from cgbound import _core, _engine
from helpers import narrow_build
from stability_log import record
from test_hard_cases import rel_error
from test_lucy_lines import mp_lucy_psi

RTOL = 1e-12


def lucy_grid_psi(box, shape, starts, vectors, R, per_node=False, n_threads=0):
    """sum over segments of psi at the grid's nodes (one value per segment: 1)."""
    grid = cg.Grid(box, shape)
    kernel = cg.Lucy(R)
    kernel._per_node = per_node
    target = _engine.core_target(grid, box)
    starts = np.atleast_2d(np.asarray(starts, float))
    vectors = np.atleast_2d(np.asarray(vectors, float))
    out = _core.scatter_segments(target, _engine.core_kernel(kernel, 1.0), starts, vectors,
                                 np.ones((len(starts), 1)), n_threads=n_threads)
    return grid, out[:, 0]


def grid_nodes(grid):
    return np.stack(np.meshgrid(*grid.axis_coordinates, indexing="ij"), axis=-1).reshape(-1, grid.dim)


def assert_rows_equal_nodes(box, shape, starts, vectors, R, what, some_inside=True):
    _, fast = lucy_grid_psi(box, shape, starts, vectors, R)
    _, slow = lucy_grid_psi(box, shape, starts, vectors, R, per_node=True)
    assert np.array_equal(fast, slow), what
    if some_inside:
        assert np.count_nonzero(fast) > 0, what + ": no node inside the support"


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


BOX3 = cg.Box([0, 0, 0], [8, 8, 8])          # nodes at 0.5, 1.5, ..., 7.5
SHAPE3 = (8, 8, 8)
DIRECTIONS = {
    "along x": [1, 0, 0], "along y": [0, 1, 0], "along z (the rows)": [0, 0, 1], "diagonal": [1, 1, 1],
    "nearly along z 1e-9": [1e-9, 0, 1], "nearly along z 1e-4": [1e-4, -2e-4, 1], "in the xy plane": [1, 1, 0],
    "nearly in the xy plane": [1, -1, 1e-7], "nearly along x": [1, 1e-12, -1e-12],
}


@pytest.mark.parametrize("name", sorted(DIRECTIONS))
@pytest.mark.parametrize("R", [1.0, 1.5, 2.0, 0.7])
def test_rows_equal_node_by_node_along_special_directions(name, R):
    """Segments from a node and from between nodes; R a whole number of spacings puts nodes exactly on the
    support's edge (at the ends' spheres and the cylinder), the hardest case for the narrowing."""
    d = unit(DIRECTIONS[name])
    starts, vectors = [], []
    for start in ([3.5, 3.5, 3.5], [3.5, 3.5, 2.5], [3.2, 4.1, 3.7], [4.0, 4.0, 4.0]):
        for length in (1.0, 2.0, 0.5, 1e-9):
            starts.append(start)
            vectors.append(length * d)
    starts, vectors = np.array(starts), np.array(vectors)
    for k in range(len(starts)):
        assert_rows_equal_nodes(BOX3, SHAPE3, starts[k], vectors[k], R, f"{name}, R {R}, segment {k}",
                                some_inside=False)
    assert_rows_equal_nodes(BOX3, SHAPE3, starts, vectors, R, f"{name}, R {R}, all segments")


@pytest.mark.parametrize("seed", range(6))
def test_rows_equal_node_by_node_on_random_segments(seed):
    rng = np.random.default_rng(seed)
    for dim in (2, 3):
        for periodic in ((False,) * dim, (True,) * dim):
            box = cg.Box(np.zeros(dim), np.full(dim, 6.0), periodic=periodic)
            shape = tuple(rng.integers(5, 14, size=dim))
            R = float(10 ** rng.uniform(-0.4, 0.4))
            starts = rng.uniform(-0.5, 6.5, size=(40, dim))
            vectors = rng.normal(size=(40, dim)) * 10 ** rng.uniform(-3, 0.3, size=(40, 1))
            vectors[:5] *= 1e-12                                  # nearly zero length
            vectors[5:10, :-1] *= 1e-10                           # nearly along the row axis
            assert_rows_equal_nodes(box, shape, starts, vectors, R, f"seed {seed}, {dim}D, periodic {periodic}")


@pytest.mark.parametrize("tilt", [0.0, 1e-12, 1e-6, 0.3])
def test_rows_equal_node_by_node_far_from_the_origin(tilt):
    """Coordinates near 1e6 with R = 1e-3 and spacing 2.5e-4: the narrowing's margins for the rounding of the
    node positions and of the offsets."""
    lo = np.array([1e6, -1e6, 1e6])
    box = cg.Box(lo, lo + 4e-3)
    shape = (16, 16, 16)
    start = lo + np.array([1.3e-3, 2.1e-3, 1.7e-3])
    rng = np.random.default_rng(4)
    for d in ([0.0, tilt, 1.0], [1.0, tilt, 0.0], [tilt, 1.0, tilt]):
        for length in (1e-3, 4e-4, 1e-12):
            assert_rows_equal_nodes(box, shape, start, length * unit(d), 1e-3, f"tilt {tilt}, d {d}, L {length}")
    assert_rows_equal_nodes(box, shape, start + rng.uniform(-1e-3, 1e-3, size=(30, 3)),
                            rng.normal(size=(30, 3)) * 5e-4, 1e-3, f"tilt {tilt}, random")


def mp_grid_psi(grid, start, vector, R):
    return np.array([float(mp_lucy_psi(p - start, np.asarray(vector, float), R)) for p in grid_nodes(grid)])


@pytest.mark.parametrize("case", ["across rows", "along rows", "on node lines", "grazing", "short", "far",
                                  "2d"])
def test_grid_values_against_mpmath(case):
    """The row path's values against 50-digit quadrature, relative to the field's scale (its largest value)."""
    R, box, shape = 1.5, BOX3, SHAPE3
    start, vector = np.array([3.2, 4.1, 3.7]), np.array([0.8, -0.3, 0.5])
    if case == "along rows":
        vector = np.array([0.0, 0.0, 0.99])
    elif case == "on node lines":
        start, vector = np.array([3.5, 3.5, 1.5]), np.array([0.0, 0.0, 2.0])
    elif case == "grazing":
        start, vector, R = np.array([3.5, 3.5, 3.5]), np.array([1.0, 0.0, 0.0]), 2.0
    elif case == "short":
        vector = vector * 1e-9
    elif case == "far":
        lo = np.array([1e6, -1e6, 1e6])
        box, shape, R = cg.Box(lo, lo + 4e-3), (12, 12, 12), 1e-3
        start, vector = lo + np.array([1.3e-3, 2.1e-3, 1.7e-3]), np.array([4e-4, 1e-9, 3e-4])
    elif case == "2d":
        box, shape = cg.Box([0, 0], [8, 8]), (16, 16)
        start, vector = np.array([3.2, 4.1]), np.array([0.8, -0.3])
    mp.mp.dps = 50
    grid, got = lucy_grid_psi(box, shape, start, vector, R)
    want = mp_grid_psi(grid, start, vector, R)
    err = rel_error(got, want)
    record(f"Lucy rows against mpmath: {case}", err)
    assert np.count_nonzero(want) > 0
    assert err <= RTOL, case


@pytest.mark.skipif(not cg.have_openmp(), reason="serial build")
@pytest.mark.parametrize("dim", [2, 3])
def test_thread_counts_and_vector_builds_bit_for_bit(dim):
    """A disordered packing with many contacts (the pipeline orders the objects for the threads' slabs)."""
    rng = np.random.default_rng(11 + dim)
    n = 3000 if dim == 3 else 1500
    L = 20.0
    pos = rng.uniform(0, L, size=(n, dim))
    i = rng.integers(0, n, size=6 * n)
    j = (i + rng.integers(1, 40, size=i.size)) % n
    close = np.linalg.norm(pos[i] - pos[j], axis=1) < 2.5
    pairs = np.unique(np.sort(np.stack([i[close], j[close]], axis=1), axis=1), axis=0)
    i, j = pairs[:, 0], pairs[:, 1]
    point = 0.5 * (pos[i] + pos[j])
    force = rng.normal(size=(i.size, dim))
    box = cg.Box(np.zeros(dim), np.full(dim, L), periodic=(True,) + (False,) * (dim - 1))
    snap = cg.Snapshot(pos, np.zeros((n, dim)), np.ones(n), box=box, contacts=cg.Contacts(i, j, force, point))
    grid = cg.Grid(box, (40,) * dim)

    def stress():
        return cg.coarse_grain(snap, grid, cg.Lucy(1.5), fields=("contact_stress",)).contact_stress

    with cg.threads(1):
        one = stress()
    assert np.count_nonzero(one) > 0
    for k in (2, 3):
        with cg.threads(k):
            assert np.array_equal(one, stress()), k
    with cg.threads(1):
        narrow = narrow_build(lambda: stress())
    assert np.array_equal(one, narrow)
