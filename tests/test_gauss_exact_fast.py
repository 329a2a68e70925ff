"""The Gaussian's exact (round-off) line integrals on grids (cg_separable.c, the "hybrid" form: the segment's
Gauss-Legendre rule at nodes whose ball holds the whole segment, the closed erf form in tails (erfcx, with a short
Gauss-Legendre rule where it would cancel) on the clipped part at the nodes the cutoff sphere cuts it for and at
nodes far beyond an end) against the node-by-node path (erf form, cg_kernels.c), 50-digit mpmath, the slow NumPy
twin (tests/oracle.py), and itself across thread counts and vector builds.

Each comparison is at 1e-12 relative to the field's scale (its largest value) and, where stated, to the value
itself. The node-by-node path is forced with the kernel's ``_per_node`` switch.
"""
import mpmath as mp
import numpy as np
import pytest

import cgbound as cg
from cgbound import _core, _engine
from oracle import oracle_kernel_of, oracle_scatter_segments, oracle_target
from helpers import narrow_build
from stability_log import record
from test_hard_cases import mp_psi, rel_error

RTOL = 1e-12


def gauss_grid_psi(box, shape, starts, vectors, w, cutoff, per_node=False, n_threads=0):
    """sum over the segments of psi at the grid's nodes (every segment's value 1)."""
    grid = cg.Grid(box, shape)
    kernel = cg.Gaussian(w, cutoff=cutoff)
    kernel._per_node = per_node
    target = _engine.core_target(grid, box)
    starts = np.atleast_2d(np.asarray(starts, float))
    vectors = np.atleast_2d(np.asarray(vectors, float))
    longest = float(np.max(np.linalg.norm(vectors, axis=1))) if len(vectors) else 0.0
    out = _core.scatter_segments(target, _engine.core_kernel(kernel, 1.0, longest), starts, vectors,
                                 np.ones((len(starts), 1)), n_threads=n_threads)
    return grid, kernel, out[:, 0]


def grid_nodes(grid):
    return np.stack(np.meshgrid(*grid.axis_coordinates, indexing="ij"), axis=-1).reshape(-1, grid.dim)


def assert_grid_equals_node_by_node(box, shape, starts, vectors, w, cutoff, what, value_floor=1e-3):
    """field-relative everywhere, value-relative where the value is above value_floor times the largest"""
    _, _, fast = gauss_grid_psi(box, shape, starts, vectors, w, cutoff)
    _, _, slow = gauss_grid_psi(box, shape, starts, vectors, w, cutoff, per_node=True)
    assert np.count_nonzero(slow) > 0, what + ": no node inside the support"
    err = rel_error(fast, slow)
    assert err <= RTOL, (what, err)
    big = np.abs(slow) > value_floor * np.abs(slow).max()
    value_err = float(np.max(np.abs(fast[big] - slow[big]) / np.abs(slow[big])))
    assert value_err <= RTOL, (what, value_err)
    # nodes the exact path leaves empty are outside the capsule for the node-by-node path too
    assert np.array_equal(fast == 0.0, slow == 0.0), what
    return err


BOX3 = cg.Box([0, 0, 0], [8, 8, 8])
SHAPE3 = (17, 17, 17)


@pytest.mark.parametrize("length_over_w", [0.0, 1e-9, 1e-3, 0.07, 0.2, 0.4, 0.99, 1.5, 2.5, 4.5])
@pytest.mark.parametrize("cutoff", [3.0, 5.0])
def test_grid_equals_node_by_node_for_every_rule(length_over_w, cutoff):
    """Segment lengths that select each round-off rule (4 to 16 points), zero and near-zero lengths."""
    rng = np.random.default_rng(int(length_over_w * 1000) + int(cutoff))
    w = 0.6
    starts = rng.uniform(2.5, 5.5, size=(6, 3))
    d = rng.normal(size=(6, 3))
    vectors = d / np.linalg.norm(d, axis=1)[:, None] * length_over_w * w
    err = assert_grid_equals_node_by_node(BOX3, SHAPE3, starts, vectors, w, cutoff, f"L = {length_over_w} w")
    record(f"Gaussian exact grid vs node by node, L = {length_over_w:g} w, cutoff {cutoff:g} w", err)


@pytest.mark.parametrize("case", ["along rows", "across rows", "on node lines", "diagonal", "grazing"])
def test_grid_equals_node_by_node_on_special_directions(case):
    w, cutoff = 0.5, 3.0
    start, vector = np.array([3.2, 4.1, 3.7]), np.array([0.4, -0.15, 0.25])
    if case == "along rows":
        vector = np.array([0.0, 0.0, 0.49])
    elif case == "across rows":
        vector = np.array([0.49, 0.0, 0.0])
    elif case == "on node lines":
        start, vector = np.array([3.5, 3.5, 1.5]), np.array([0.0, 0.0, 0.5])
    elif case == "diagonal":
        vector = np.array([0.3, 0.3, 0.3])
    elif case == "grazing":
        # the cutoff sphere passes (nearly) through nodes: start 1.5 = 3 w from the nodes at x = 2.0, 5.0
        start, vector = np.array([3.5, 3.5, 3.5]), np.array([0.5, 0.0, 0.0])
    assert_grid_equals_node_by_node(BOX3, SHAPE3, start, vector, w, cutoff, case)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("periodic", [False, True])
def test_grid_equals_node_by_node_many_segments(dim, periodic):
    rng = np.random.default_rng(3 * dim + periodic)
    L = 6.0
    box = cg.Box(np.zeros(dim), np.full(dim, L), periodic=periodic)
    n = 40
    starts = rng.uniform(0, L, size=(n, dim))
    scale = rng.choice([0.0, 1e-9, 0.3, 1.0, 2.0], size=n)
    vectors = rng.normal(size=(n, dim)) * scale[:, None]
    shape = (23,) * dim
    for w, cutoff in ((0.7, 3.0), (0.45, 5.0)):
        assert_grid_equals_node_by_node(box, shape, starts, vectors, w, cutoff, f"{dim}-D periodic={periodic}")


# Far beyond an end the integrand falls by many orders across the segment: the grid path's rule (exact relative to
# the kernel's peak) would lose digits of the tiny value itself (1.7e-8 at 10 w, 1.2e-4 at 20 w); such nodes take the
# closed form in tails (erfcx), which keeps them.
@pytest.mark.parametrize("distance", [3.0, 6.0, 10.0, 20.0])
def test_nodes_far_beyond_a_segment_end(distance):
    """Nodes `distance` w beyond a segment's end along its line (and off it), with a cutoff that holds them:
    the tiny values against 50-digit mpmath, relative to each value."""
    w, cutoff, L = 0.25, 24.0, 0.45                      # L = 1.8 w: a 10-point rule
    box = cg.Box([0.0, 0.0, 0.0], [1.0, 1.0, 1.0])
    shape = (5, 5, 5)
    x0 = grid_nodes(cg.Grid(box, shape))[:, 0].min()
    start = np.array([x0 - distance * w - L, 0.5, 0.5])  # the end `distance` w before the first plane of nodes
    vector = np.array([L, 0.0, 0.0])
    grid, _, got = gauss_grid_psi(box, shape, start, vector, w, cutoff)
    nodes = grid_nodes(grid)
    plane = nodes[:, 0] == x0
    mp.mp.dps = 50
    want = np.array([float(mp_psi(p - start, vector, w, cutoff * w)) for p in nodes[plane]])
    assert np.all(want > 0)
    err = float(np.max(np.abs(got[plane] - want) / want))
    record(f"Gaussian exact grid, nodes {distance:g} w beyond a segment end (value-relative)", err)
    assert err <= RTOL, err


def test_subnormal_values_far_beyond_an_end():
    """A cutoff of 40 w holds nodes about 38 w away, where the kernel is subnormal (exp(-724)): the closed form
    keeps them nonzero like the node-by-node path (exp(x) of its vectorised exponential stops at x = -708)."""
    start, vector = np.full(3, 1.45), np.array([-0.04, 0.03, -0.028])
    err = assert_grid_equals_node_by_node(cg.Box([0, 0, 0], [6, 6, 6]), (19, 19, 19), start, vector, 0.2, 40.0,
                                          "subnormal far values")
    _, _, fast = gauss_grid_psi(cg.Box([0, 0, 0], [6, 6, 6]), (19, 19, 19), start, vector, 0.2, 40.0)
    assert 0.0 < fast[-1] < 1e-307        # the far corner, about 7.6 = 38 w away
    record("Gaussian exact grid, subnormal values at 38 w", err)


def test_nodes_exactly_on_the_segment_line():
    w, cutoff = 0.25, 8.0
    box = cg.Box([0, 0, 0], [4, 4, 4])
    start, vector = np.array([1.0, 2.0, 2.0]), np.array([0.375, 0.0, 0.0])   # along a node line
    grid, _, got = gauss_grid_psi(box, (17, 17, 17), start, vector, w, cutoff)
    nodes = grid_nodes(grid)
    on_line = (nodes[:, 1] == 2.0) & (nodes[:, 2] == 2.0)
    mp.mp.dps = 50
    want = np.array([float(mp_psi(p - start, vector, w, cutoff * w)) for p in nodes[on_line]])
    err = rel_error(got[on_line], want)
    record("Gaussian exact grid, nodes on the segment line", err)
    assert err <= RTOL


def test_positions_near_1e6_with_small_width():
    w, cutoff = 1e-3, 5.0
    lo = np.array([1e6, -2e6, 1e6])
    box = cg.Box(lo, lo + 0.016)
    start = lo + np.array([7.3e-3, 8.1e-3, 7.7e-3])
    vector = np.array([4e-4, 2e-4, -3e-4])
    grid, _, got = gauss_grid_psi(box, (17, 17, 17), start, vector, w, cutoff)
    _, _, slow = gauss_grid_psi(box, (17, 17, 17), start, vector, w, cutoff, per_node=True)
    assert rel_error(got, slow) <= RTOL
    nodes = grid_nodes(grid)
    pick = np.argsort(-slow)[:60:3]   # 20 of the largest values
    mp.mp.dps = 50
    want = [float(mp_psi([mp.mpf(float(p[d])) - mp.mpf(float(start[d])) for d in range(3)], vector, w, cutoff * w))
            for p in nodes[pick]]
    err = rel_error(got[pick], want)
    record("Gaussian exact grid, positions near 1e6, w = 1e-3", err)
    assert err <= RTOL


@pytest.mark.parametrize("dim", [2, 3])
def test_grid_against_the_numpy_twin(dim):
    rng = np.random.default_rng(40 + dim)
    L = 5.0
    box = cg.Box(np.zeros(dim), np.full(dim, L), periodic=(True,) + (False,) * (dim - 1))
    starts = rng.uniform(0, L, size=(8, dim))
    vectors = rng.normal(size=(8, dim)) * 0.6
    vectors[0] = 0.0
    values = rng.normal(size=(8, 3))
    grid = cg.Grid(box, (11,) * dim)
    kernel = cg.Gaussian(0.5, cutoff=3.0)
    target = _engine.core_target(grid, box)
    got = _core.scatter_segments(target, _engine.core_kernel(kernel, 1.0, float(np.abs(vectors).max() * 2)),
                                 starts, vectors, values)
    want = oracle_scatter_segments(oracle_kernel_of(kernel, dim), oracle_target(grid, box), starts, vectors, values)
    assert np.count_nonzero(want) > 0
    assert rel_error(got, want) <= RTOL


@pytest.mark.skipif(not cg.have_openmp(), reason="serial build")
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("cutoff", [3.0, 5.0])
def test_thread_counts_and_vector_builds_bit_for_bit(dim, cutoff):
    """A disordered packing with many contacts on a grid long enough along its first axis for the threads'
    slabs (cg_scatter.c; elsewhere per-thread buffers make a run deterministic only per thread count)."""
    rng = np.random.default_rng(21 + dim)
    extent = np.array([40.0] + [10.0] * (dim - 1))
    n = int(np.prod(extent) / (4.0 if dim == 3 else 0.5))
    pos = rng.uniform(0, extent, size=(n, dim))
    i = rng.integers(0, n, size=6 * n)
    j = (i + rng.integers(1, 40, size=i.size)) % n
    close = np.linalg.norm(pos[i] - pos[j], axis=1) < 2.0
    pairs = np.unique(np.sort(np.stack([i[close], j[close]], axis=1), axis=1), axis=0)
    i, j = pairs[:, 0], pairs[:, 1]
    point = 0.5 * (pos[i] + pos[j])
    force = rng.normal(size=(i.size, dim))
    box = cg.Box(np.zeros(dim), extent, periodic=(False,) + (True,) * (dim - 1))
    snap = cg.Snapshot(pos, np.zeros((n, dim)), np.ones(n), box=box, contacts=cg.Contacts(i, j, force, point))
    grid = cg.Grid(box, tuple(int(2 * e) for e in extent))

    def stress():
        return cg.coarse_grain(snap, grid, cg.Gaussian(0.5, cutoff=cutoff), fields=("contact_stress",)).contact_stress

    with cg.threads(1):
        one = stress()
    assert np.count_nonzero(one) > 0
    for k in (2, 3):
        with cg.threads(k):
            assert np.array_equal(one, stress()), k
    with cg.threads(1):
        narrow = narrow_build(lambda: stress())
    assert np.array_equal(one, narrow)


@pytest.mark.parametrize("nz", [41, 321])
@pytest.mark.parametrize("cutoff", [3.0, 5.0, 12.0])
def test_row_bookkeeping_short_and_long_rows(nz, cutoff):
    """A row's rule interval, its far-node trim and its closed-form nodes are found as vector masks where the
    stencil's rows along the last axis have at most 64 nodes (nz = 41: rows of 10 to 38 nodes), by scalar walks
    where they are longer (nz = 321: rows of 72 to 300 nodes): both against the node-by-node path (value-relative too), and the
    two vector builds bit for bit. Cutoffs 5 w and 12 w with segments shorter than w have nodes more than 4 w
    beyond an end inside the ball (the far trim)."""
    rng = np.random.default_rng(7 * nz + int(cutoff))
    w = 0.3
    box = cg.Box([0, 0, 0], [8, 8, 8])
    shape = (9, 9, nz)
    starts = rng.uniform(3.0, 5.0, size=(5, 3))
    d = rng.normal(size=(5, 3))
    vectors = d / np.linalg.norm(d, axis=1)[:, None] * np.array([0.0, 0.1, 0.5, 0.9, 1.7])[:, None] * w
    assert_grid_equals_node_by_node(box, shape, starts, vectors, w, cutoff, f"nz = {nz}, cutoff {cutoff:g} w",
                                    value_floor=1e-12)
    _, _, wide = gauss_grid_psi(box, shape, starts, vectors, w, cutoff)
    _, _, narrow = narrow_build(lambda: gauss_grid_psi(box, shape, starts, vectors, w, cutoff))
    assert np.array_equal(wide, narrow)


@pytest.mark.parametrize("cutoff", [3.0, 5.0])
def test_row_intervals_with_nodes_exactly_on_the_spheres(cutoff):
    """Nodes exactly on a cutoff sphere, or on the edge of the rule's region (within R of both ends), are classified
    by the rows' masks (cg_separable.c) as node by node. Segments from a node to a node, w = h = 0.5, so the squared
    distances are exact in binary and R = 3 or 5 spacings puts nodes such as (2, 2, 1) h and (3, 4, 0) h from an
    end on its sphere; also a segment at 1e-3 rad to the rows and one whose shadow on a plane is almost along its
    rows (cases a row classification by intervals from the geometry must treat apart). Against the node-by-node
    path (value-relative) and the two vector builds bit for bit."""
    w = 0.5
    box = cg.Box([0, 0, 0], [8, 8, 8])
    shape = (16, 16, 16)                                   # nodes at 0.25 + 0.5 k
    steps = [[0, 0, 1], [0, 0, 2], [1, 0, 0], [0, 2, 0], [0, 1, 1], [1, 1, 0], [3, 4, 0], [0, 3, 4], [1, 2, 2],
             [2, -1, 2], [0, 0, -2], [-1, 0, 0]]
    vectors = [0.5 * np.array(v, float) for v in steps] + [np.array([1e-3, 0.0, 0.7]), np.array([0.004, 0.8, 0.3])]
    starts = np.tile([4.25, 4.25, 4.25], (len(vectors), 1))
    vectors = np.array(vectors)
    _, _, wide = gauss_grid_psi(box, shape, starts, vectors, w, cutoff)
    _, _, slow = gauss_grid_psi(box, shape, starts, vectors, w, cutoff, per_node=True)
    assert rel_error(wide, slow) <= RTOL
    # (node by node leaves a round-off value, 6e-25 of the largest, at nodes on a sphere the segment only touches,
    # where the closed form gives 0: compared to the scale only)
    big = np.abs(slow) > 1e-12 * np.abs(slow).max()
    assert np.count_nonzero(big) > 1000
    assert np.max(np.abs(wide[big] - slow[big]) / np.abs(slow[big])) <= RTOL
    _, _, narrow = narrow_build(lambda: gauss_grid_psi(box, shape, starts, vectors, w, cutoff))
    assert np.array_equal(wide, narrow)


def test_erfcx_against_mpmath_over_its_whole_range():
    """The closed form's erfcx (cg_separable.c): the short polynomial on [0, 4], where the cut nodes' arguments lie for
    cutoffs up to 4 sqrt(2) w, and the long series beyond, within 4 ulp of 40-digit mpmath; a value does not depend on
    the other arguments of its batch (the long series is chosen lane by lane)."""
    rng = np.random.default_rng(16)
    short = np.concatenate([np.linspace(0.0, 4.0, 2001), rng.uniform(0.0, 4.0, 2000),
                            [5e-324, 1e-300, 1e-8, np.nextafter(4.0, 0.0)]])
    long = np.concatenate([[np.nextafter(4.0, 5.0)], rng.uniform(4.0, 40.0, 300), np.geomspace(4.0, 1e8, 300)])
    x = np.concatenate([long[:50], short, long[50:]])   # batches of both kinds and mixed ones
    got = _engine.gaussian_erfcx(x)
    with mp.workdps(40):
        exact = [mp.exp(mp.mpf(t) ** 2) * mp.erfc(mp.mpf(t)) for t in x]
        ulps = np.array([float(abs(mp.mpf(g) - e) / mp.mpf(np.spacing(float(e)))) for g, e in zip(got, exact)])
    assert ulps.max() <= 4.0, (ulps.max(), x[np.argmax(ulps)])
    np.testing.assert_array_equal(_engine.gaussian_erfcx(short), got[50:50 + len(short)])
    np.testing.assert_array_equal(_engine.gaussian_erfcx(long), np.concatenate([got[:50], got[50 + len(short):]]))
    with pytest.raises(ValueError, match="x: expected values >= 0"):
        _engine.gaussian_erfcx(np.array([1.0, -0.5]))


def test_exp_against_mpmath_over_its_whole_range():
    """The Gaussian paths' exponential (cg_vmath.h's cg_exp_in_place, a Taylor polynomial of degree 13 in split
    Horner form): within 1 ulp of 40-digit mpmath on [-708, 0] (0.92 at most here), exactly 1 at 0 and 0 below -708; a
    value does not depend on the other arguments of its batch. Positive exponents are refused."""
    rng = np.random.default_rng(21)
    x = np.concatenate([rng.uniform(-708.0, 0.0, 1500), rng.uniform(-2.0, 0.0, 1500), -np.geomspace(1e-300, 708.0, 500),
                        -np.log(2.0) * np.arange(0.0, 40.0, 0.5), [-0.0, -5e-324, -708.0]])
    got = _engine.gaussian_exp(x)
    with mp.workdps(40):
        exact = [mp.exp(mp.mpf(t)) for t in x]
        ulps = np.array([float(abs(mp.mpf(g) - e) / mp.mpf(np.spacing(float(e)))) for g, e in zip(got, exact)])
    assert ulps.max() <= 1.0, (ulps.max(), x[np.argmax(ulps)])
    assert got[-3] == 1.0 and got[-2] == 1.0
    assert np.array_equal(_engine.gaussian_exp(np.array([-708.5, -1e4, -1e300])), np.zeros(3))
    np.testing.assert_array_equal(_engine.gaussian_exp(x[::-1].copy()), got[::-1])
    with pytest.raises(ValueError, match="x: expected values <= 0"):
        _engine.gaussian_exp(np.array([-1.0, 0.5]))


def sliver_start(node, n, L, R, case, delta, rng):
    """A segment start for direction n (unit) and length L such that the part of the segment inside the node's
    ball (radius R) is a sliver of about delta: "start" (the node before the start, the start just inside),
    "end" (the node beyond the end, the end just inside), "side" (the sphere barely clips the segment's side: a
    chord of delta about its middle), "long" (the end just outside: the part ends delta before it)."""
    if case == "side":
        p = rng.normal(size=3)
        p -= (p @ n) * n
        p /= np.linalg.norm(p)
        return node - (np.sqrt(R * R - (delta / 2) ** 2) * p + 0.5 * L * n)
    m = rng.normal(size=3)
    m /= np.linalg.norm(m)
    sign = 1.0 if case == "end" else -1.0              # the node's offset from the end (start) along n
    m = m + (sign * 0.6 - m @ n) * n                    # 53 degrees off the line
    m /= np.linalg.norm(m)
    c = m @ n
    part = {"start": lambda r: r * c + np.sqrt(R * R - r * r * (1 - c * c)),     # u + h, the start inside
            "end": lambda r: np.sqrt(R * R - r * r * (1 - c * c)) - r * c,       # h - (u - L), the end inside
            "long": lambda r: r * c + np.sqrt(R * R - r * r * (1 - c * c))}[case]
    target = L - delta if case == "long" else delta
    lo, hi = 0.5 * R, R                                 # part decreases in r on [R / 2, R]
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if part(mid) > target else (lo, mid)
    return node - lo * m - (L * n if case == "end" else 0.0)


def test_slivers_of_oblique_segments_against_mpmath():
    """Oblique segments (the general exact path's cut nodes) whose end lies within 1e-3 w to a few ulp of a
    node's cutoff sphere, inside (a sliver of the segment in the node's ball) or outside, and segments whose
    side the sphere barely clips: the node's value against 50-digit mpmath, relative to itself (and 0 where
    mpmath's is). The lanes of the closed form rebuild the part inside the ball in units of the segment and
    kept only eps R / span of it (1e-7 off at 1e-9 w, 5 % at 1e-14 w; a side's chord of 1e-6 w 4e-3 off,
    of 1e-9 w: 0), and so did the node-by-node path's clipping; both now take the span from exact differences
    (cg_cut_span_lane). Both builds bit for bit."""
    w, cutoff = 0.5, 3.0
    R = cutoff * w
    box, shape = cg.Box([0, 0, 0], [8, 8, 8]), (17, 17, 17)
    grid = cg.Grid(box, shape)
    node = np.array([c[8] for c in grid.axis_coordinates])
    k = np.ravel_multi_index((8, 8, 8), shape)
    rng = np.random.default_rng(18)
    mp.mp.dps = 50
    worst, nonzero = 0.0, 0
    for case in ("start", "end", "side", "long"):
        for delta in (1e-3 * w, 1e-6 * w, 1e-9 * w, 1e-12 * w, 4 * 2.0 ** -52 * R):
            for L in (0.3 * w, 2.0 * w):
                n = rng.normal(size=3)
                n /= np.linalg.norm(n)
                start, vector = sliver_start(node, n, L, R, case, delta, rng), n * L
                _, _, got = gauss_grid_psi(box, shape, start, vector, w, cutoff * w)
                q = [mp.mpf(float(a)) - mp.mpf(float(b)) for a, b in zip(node, start)]   # (exact here)
                want = float(mp_psi(q, vector, w, R))
                what = (case, delta / w, L / w, got[k], want)
                if want == 0.0:
                    assert got[k] == 0.0, what
                    continue
                nonzero += 1
                err = abs(got[k] - want) / want
                assert err <= RTOL, what
                worst = max(worst, err)
                if case in ("start", "end") or delta >= 1e-6 * w:
                    # the node-by-node path (its Gauss-Legendre branch on the same exact span; where the sphere
                    # only grazes the segment's side by less, its clipping, in units of the segment, finds nothing)
                    slow = gauss_grid_psi(box, shape, start, vector, w, cutoff * w, per_node=True)[2][k]
                    assert abs(slow - want) <= RTOL * want, what + (slow,)
                if L > w:
                    wide = got
                    assert narrow_build(lambda: gauss_grid_psi(box, shape, start, vector, w, cutoff * w)[2]).tobytes() \
                        == wide.tobytes(), what
    assert nonzero >= 30
    record("Gaussian exact grid, slivers of oblique segments in a node's ball (value-relative)", worst)
