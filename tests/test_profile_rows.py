"""Profiles: Lucy's and Heaviside's kernels on a grid of one resolved axis with the two others averaged
(csrc/cg_profile.c: each object's nodes in a vectorised batch, the segment's constants once per object).
Checked against the node-by-node path bit for bit (the bytes, signed zeros included): lattice contacts (two
thirds of them of zero length along the resolved axis), random segments and points, segments through nodes and
ending on them, near-zero lengths, coordinates near 1e6, stencils longer than a batch, periodic axes, rays, the
contact stress's outer-product form (9 values), 1, 10 (the particle fields, a fixed width) and 13 values, Lucy's point gradients; both vector builds and thread counts bit for
bit. (The slow twin at 1e-12: tests/test_core_sweep.py, whose grids average every combination of axes.)"""
import numpy as np
import pytest

import cgbound as cg
from cgbound import _core, _engine
from helpers import narrow_build
from test_lucy_batch import lattice_contacts

KERNELS = {"Lucy": cg.Lucy, "Heaviside": cg.Heaviside}
AXES = {"z": ("x", "y"), "x": ("y", "z"), "y": ("x", "z")}


def profile(box, n, axis, make, R, per_node=False):
    shape = tuple(n if a == axis else 1 for a in "xyz")
    grid = cg.Grid(box, shape, average=AXES[axis])
    kernel = make(R)
    kernel._per_node = per_node
    return grid, _engine.core_target(grid, box), _engine.core_kernel(kernel, grid.avg_extent)


def sums(box, n, axis, make, R, starts, vectors, values, per_node=False, n_threads=1, ray=False, outer=False,
         gradient=False):
    _, target, kernel = profile(box, n, axis, make, R, per_node)
    starts = np.ascontiguousarray(starts, dtype=float)
    values = np.ascontiguousarray(values, dtype=float)
    if vectors is None:
        return _core.scatter_points(target, kernel, starts, values, gradient=gradient, n_threads=n_threads)
    vectors = np.ascontiguousarray(vectors, dtype=float)
    if outer:
        return _core.scatter_segments_outer(target, kernel, starts, vectors, values, ray=ray, n_threads=n_threads)
    return _core.scatter_segments(target, kernel, starts, vectors, values, ray=ray, n_threads=n_threads)


def assert_same_bits(box, n, axis, make, R, starts, vectors, values, what, **kw):
    fast = sums(box, n, axis, make, R, starts, vectors, values, **kw)
    slow = sums(box, n, axis, make, R, starts, vectors, values, per_node=True, **kw)
    assert np.count_nonzero(fast) > 0, what
    assert fast.tobytes() == slow.tobytes(), f"{what}: largest difference {np.abs(fast - slow).max()}"
    return fast


def lattice(n=7, spacing=0.99):
    starts, vectors = lattice_contacts(n, 3, spacing)
    side = (n - 1) * spacing + 1.0
    return cg.Box(np.zeros(3), np.full(3, side)), starts, vectors


def random_segments(rng, box, count, scale=1.5):
    starts = box.lower + rng.uniform(size=(count, 3)) * box.lengths
    return starts, rng.normal(scale=scale, size=(count, 3))


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("axis", sorted(AXES))
@pytest.mark.parametrize("R", [1.5, 0.7, 2.3])
def test_lattice_contacts(kernel, axis, R):
    """W2's geometry in small: axis-aligned contacts, most of zero length along the profile's axis; 9 values
    (the stress's vector sum), 1 value, and the outer-product form."""
    box, starts, vectors = lattice()
    rng = np.random.default_rng(1)
    for nv in (9, 1):
        values = rng.normal(size=(len(starts), nv))
        values[2::5] = 0.0
        assert_same_bits(box, 23, axis, KERNELS[kernel], R, starts, vectors, values, f"{axis} R {R} {nv} values")
    factors = rng.normal(size=(len(starts), 3))
    assert_same_bits(box, 23, axis, KERNELS[kernel], R, starts, vectors, factors, "outer", outer=True)


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("seed", range(4))
def test_random_segments_and_points(kernel, seed):
    rng = np.random.default_rng(seed)
    box = cg.Box([0, 0, 0], [10, 8, 12])
    starts, vectors = random_segments(rng, box, 400)
    vectors[::9] *= 1e-12                                # near-zero lengths
    vectors[1::9, 2] = 0.0                               # zero along the resolved axis
    vectors[2::9] *= 8.0                                 # long: stencils of more than a batch
    for nv in (9, 10, 13, 1):
        values = rng.normal(size=(len(starts), nv))
        assert_same_bits(box, 150, "z", KERNELS[kernel], 1.3, starts, vectors, values, f"segments {nv}")
        assert_same_bits(box, 150, "z", KERNELS[kernel], 1.3, starts, None, values, f"points {nv}")


@pytest.mark.parametrize("kernel", sorted(KERNELS))
def test_blocks_of_objects(kernel):
    """Objects are taken in blocks of (object, node) pairs (cg_visit_profile_objects): blocks that fill up
    mid-way, stencils longer than a block (taken alone), a profile of one node (every object takes it)."""
    rng = np.random.default_rng(11)
    box = cg.Box([0, 0, 0], [6, 6, 30])
    starts, vectors = random_segments(rng, box, 300)
    vectors[::3, 2] *= 12.0                              # 600 nodes and more
    values = rng.normal(size=(len(starts), 9))
    assert_same_bits(box, 1500, "z", KERNELS[kernel], 1.1, starts, vectors, values, "long stencils")
    assert_same_bits(box, 1500, "z", KERNELS[kernel], 1.1, starts, vectors, values[:, :3], "outer", outer=True)
    assert_same_bits(box, 1, "z", KERNELS[kernel], 1.1, starts, vectors, values, "one node")
    assert_same_bits(box, 1, "z", KERNELS[kernel], 1.1, starts, None, values, "one node, points")


@pytest.mark.parametrize("kernel", sorted(KERNELS))
def test_nodes_on_ends_and_support_edges(kernel):
    """Segments that start, end and pass exactly on nodes, and whose supports end exactly on nodes."""
    box = cg.Box([0, 0, 0], [4, 4, 10])
    grid, _, _ = profile(box, 11, "z", KERNELS[kernel], 1.0)
    z = grid.axis_coordinates[2]
    starts = np.array([[1.0, 2.0, z[3]], [1.0, 1.0, z[2]], [2.0, 2.0, z[5] + 0.25], [1.0, 1.0, z[4]]])
    vectors = np.array([[0.3, 0.1, z[5] - z[3]], [0.0, 0.0, -1.0], [0.0, 1.0, 0.5], [0.0, 0.0, 2.0]])
    values = np.arange(1.0, 1.0 + 9 * len(starts)).reshape(-1, 9)
    assert_same_bits(box, 11, "z", KERNELS[kernel], 1.0, starts, vectors, values, "on nodes")
    assert_same_bits(box, 11, "z", KERNELS[kernel], 1.0, starts, None, values, "points on nodes")


@pytest.mark.parametrize("kernel", sorted(KERNELS))
def test_far_from_origin(kernel):
    rng = np.random.default_rng(7)
    box = cg.Box([1e6, 1e6, 1e6], [1e6 + 6, 1e6 + 6, 1e6 + 6])
    starts, vectors = random_segments(rng, box, 200, scale=0.8)
    values = rng.normal(size=(len(starts), 9))
    assert_same_bits(box, 40, "z", KERNELS[kernel], 0.9, starts, vectors, values, "near 1e6")
    assert_same_bits(box, 40, "z", KERNELS[kernel], 0.9, starts, None, values, "points near 1e6")


@pytest.mark.parametrize("kernel", sorted(KERNELS))
def test_periodic_and_rays(kernel):
    rng = np.random.default_rng(3)
    periodic = cg.Box([0, 0, 0], [5, 5, 6], periodic=[True, True, True])
    starts, vectors = random_segments(rng, periodic, 300)
    values = rng.normal(size=(len(starts), 9))
    assert_same_bits(periodic, 30, "z", KERNELS[kernel], 1.4, starts, vectors, values, "periodic")
    assert_same_bits(periodic, 30, "z", KERNELS[kernel], 1.4, starts, None, values, "periodic points")
    box = cg.Box([0, 0, 0], [5, 5, 6])
    starts, vectors = random_segments(rng, box, 100)
    vectors[:, 2] = np.where(np.abs(vectors[:, 2]) < 0.1, 0.5, vectors[:, 2])   # rays leave along z
    assert_same_bits(box, 30, "z", KERNELS[kernel], 1.4, starts, vectors, values[:100], "rays", ray=True)


@pytest.mark.parametrize("kernel", sorted(KERNELS))
def test_vector_builds_and_threads_bit_for_bit(kernel):
    """Short objects on a long profile: the slabs (csrc/cg_scatter.c) apply, so any thread count gives the
    same bits."""
    rng = np.random.default_rng(5)
    box, starts, vectors = lattice(16)
    starts = np.concatenate([starts, random_segments(rng, box, 3000)[0]])
    vectors = np.concatenate([vectors, rng.normal(scale=0.1, size=(3000, 3))])
    values = rng.normal(size=(len(starts), 9))
    for vec in (vectors, None):
        one = sums(box, 400, "z", KERNELS[kernel], 1.5, starts, vec, values, n_threads=1)
        two = sums(box, 400, "z", KERNELS[kernel], 1.5, starts, vec, values, n_threads=2)
        narrow = narrow_build(lambda: sums(box, 400, "z", KERNELS[kernel], 1.5, starts, vec, values, n_threads=1))
        assert np.count_nonzero(one) > 0
        assert one.tobytes() == two.tobytes()
        assert one.tobytes() == narrow.tobytes()


@pytest.mark.parametrize("seed", range(3))
def test_lucy_point_gradients(seed):
    """The gradients of Lucy's marginal (density_gradient on a profile): the node-by-node bits, on nodes, near
    1e6, periodic; both vector builds and thread counts."""
    rng = np.random.default_rng(seed)
    box = cg.Box([0, 0, 0], [10, 8, 12], periodic=[False, False, seed == 1])
    starts = box.lower + rng.uniform(size=(500, 3)) * box.lengths
    grid, _, _ = profile(box, 150, "z", cg.Lucy, 1.3)
    starts[:20, 2] = grid.axis_coordinates[2][5:25]      # on nodes: the gradient 0, the value not
    for nv in (4, 1):
        values = rng.normal(size=(len(starts), nv))
        fast = assert_same_bits(box, 150, "z", cg.Lucy, 1.3, starts, None, values, f"gradient {nv}", gradient=True)
        two = sums(box, 150, "z", cg.Lucy, 1.3, starts, None, values, gradient=True, n_threads=2)
        narrow = narrow_build(lambda: sums(box, 150, "z", cg.Lucy, 1.3, starts, None, values, gradient=True))
        assert fast.tobytes() == two.tobytes() == narrow.tobytes()
    far = cg.Box([1e6] * 3, [1e6 + 6] * 3)
    starts = far.lower + rng.uniform(size=(200, 3)) * far.lengths
    assert_same_bits(far, 40, "z", cg.Lucy, 0.9, starts, None, rng.normal(size=(200, 3)), "near 1e6", gradient=True)


def test_gaussian_points():
    """The Gaussian's points on a profile go through the blocks too where stencils are short (cg_profile.c,
    job.profile_gauss: at most 16 nodes; the separable path's bits, checked against its build when the route
    was added), through the separable path where they are longer: the node-by-node path's to 1e-12; both
    vector builds and thread counts bit for bit."""
    rng = np.random.default_rng(17)
    box = cg.Box([0, 0, 0], [6, 6, 30])
    starts = box.lower + rng.uniform(size=(400, 3)) * box.lengths
    starts[:, 2] = 4.0 + 22.0 * rng.uniform(size=400)
    grid, _, _ = profile(box, 1500, "z", cg.Lucy, 1.0)
    starts[:20, 2] = grid.axis_coordinates[2][300:320]   # on nodes
    values = rng.normal(size=(len(starts), 13))
    values[0] = -0.0
    # the objects 80 times over for the thread check: enough work for 2 threads (MIN_WORK_PER_THREAD), which
    # 400 objects of 7-11 nodes are not (they ran on one)
    many_starts, many_values = np.tile(starts, (80, 1)), np.tile(values, (80, 1))
    for width in (0.02, 0.012, 0.4):                     # 11 and 7 nodes an object (blocks), 201 (separable)
        make = lambda R: cg.Gaussian(width)              # noqa: E731
        fast = sums(box, 1500, "z", make, 1.0, starts, None, values)
        assert np.count_nonzero(fast) > 0
        many = sums(box, 1500, "z", make, 1.0, many_starts, None, many_values)
        assert many.tobytes() == sums(box, 1500, "z", make, 1.0, many_starts, None, many_values,
                                      n_threads=2).tobytes()
        narrow = narrow_build(lambda: sums(box, 1500, "z", make, 1.0, starts, None, values))
        assert fast.tobytes() == narrow.tobytes()
        slow = sums(box, 1500, "z", make, 1.0, starts, None, values, per_node=True)
        assert np.abs(fast - slow).max() <= 1e-12 * np.abs(slow).max()
    long = lambda R: cg.Gaussian(2.0)                    # noqa: E731  (about 1200 nodes an object)
    fast = sums(box, 1500, "z", long, 1.0, starts[:60], None, values[:60, :3])
    slow = sums(box, 1500, "z", long, 1.0, starts[:60], None, values[:60, :3], per_node=True)
    assert np.abs(fast - slow).max() <= 1e-12 * np.abs(slow).max()


def gaussian_segments_case(rng, box, w, count=1500):
    """Segments of every rule's length along z (+-0, near 0, 0.05 w to 8 w: the last too long for a rule), a
    lattice's contacts (two thirds of length +0 along z), some starting and ending on nodes; all at least
    cutoff + length clear of the profile's ends (a periodic copy's other images then reach no node)."""
    z0, side = box.lower[2], box.lengths[2]
    starts = box.lower + rng.uniform(size=(count, 3)) * box.lengths
    starts[:, 2] = z0 + side * (0.3 + 0.4 * rng.uniform(size=count))
    length = w * rng.choice([0.0, 1e-9, 0.05, 0.3, 1.0, 2.0, 4.0, 8.0], size=count)
    vectors = rng.normal(size=(count, 3)) * length[:, None]
    vectors[:, 2] = np.clip(vectors[:, 2], -0.2 * side, 0.2 * side)
    vectors[1::7, 2] = -0.0
    grid = cg.Grid(box, (1, 1, 300), average=("x", "y"))
    h = grid.axis_coordinates[2][1] - grid.axis_coordinates[2][0]
    on = slice(2, None, 11)                              # on nodes, node to node
    starts[on, 2] = grid.axis_coordinates[2][100 + rng.integers(0, 100, size=len(starts[on]))]
    vectors[on, 2] = h * rng.integers(-4, 5, size=len(starts[on]))
    lattice_starts, lattice_vectors = lattice_contacts(5, 3, 0.99)
    starts = np.concatenate([starts, lattice_starts + [box.lower[0], box.lower[1], z0 + 0.45 * side]])
    vectors = np.concatenate([vectors, lattice_vectors])
    return starts, vectors


@pytest.mark.parametrize("far", [False, True])
def test_gaussian_segments(far):
    """The Gaussian's segments (exact line integrals) on a profile go through the blocks where stencils have at
    most 40 nodes (cg_profile.c, job.profile_gauss; its points: 16): cg_visit_separable's bits for segments it
    takes (those of a rule, at most 4.6 w along the axis: checked against it on a periodic copy of the profile,
    which it takes object by object), the closed form at every node for longer ones (the node-by-node erf
    form's values to 1e-12 of the largest and of each value above 1e-3 of it); far: a cutoff of 6 w (nodes far
    beyond an end take the closed form), 25 nodes a stencil. 9 values, the outer form's 3 factors, 10, 13 and 1
    value; near 1e6; the separable path where stencils are longer; both vector builds and thread counts bit
    for bit."""
    rng = np.random.default_rng(23 + far)
    w, cutoff = (0.2, 6.0) if far else (0.25, 3.0)       # 25 and 16 nodes a stencil: the blocks
    make = lambda R: cg.Gaussian(w, cutoff=cutoff * w)   # noqa: E731
    for box in (cg.Box([0, 0, 0], [6, 6, 30]), cg.Box([1e6] * 3, [1e6 + 6, 1e6 + 6, 1e6 + 30]))[:2 - far]:
        periodic = cg.Box(box.lower, box.upper, periodic=[False, False, True])
        starts, vectors = gaussian_segments_case(rng, box, w)
        ruled = np.abs(vectors[:, 2]) <= 4.6 * w
        # and a segment of value 0 below the profile, as long as it: no slabs (cg_scatter.c's plan_slabs), so
        # that both runs add each node's terms in the objects' order; it reaches no node (its periodic images
        # add zeros)
        s_ruled = np.concatenate([starts[ruled], [box.lower - [0, 0, 3 * box.lengths[2]]]])
        v_ruled = np.concatenate([vectors[ruled], [[0.0, 0.0, box.lengths[2]]]])
        for nv, outer in ((9, False), (3, True), (10, False), (13, False), (1, False)):
            values = rng.normal(size=(len(s_ruled), nv))
            values[-1] = 0.0
            kw = dict(outer=outer)
            fast = sums(box, 300, "z", make, 1.0, s_ruled, v_ruled, values, **kw)
            separable = sums(periodic, 300, "z", make, 1.0, s_ruled, v_ruled, values, **kw)
            assert np.count_nonzero(fast) > 0
            assert fast.tobytes() == separable.tobytes(), (nv, outer, np.abs(fast - separable).max())
        ones = np.ones((len(starts), 1))
        for sel in (~ruled, slice(None)):
            fast = sums(box, 300, "z", make, 1.0, starts[sel], vectors[sel], ones[sel])[:, 0]
            slow = sums(box, 300, "z", make, 1.0, starts[sel], vectors[sel], ones[sel], per_node=True)[:, 0]
            assert np.abs(fast - slow).max() <= 1e-12 * np.abs(slow).max()
            big = slow > 1e-3 * slow.max()
            assert np.max(np.abs(fast[big] - slow[big]) / slow[big]) <= 1e-12
            assert np.array_equal(fast == 0.0, slow == 0.0)
        # segments short enough for slabs (any thread count the same sums), some too long for a rule; 5 times
        # over (enough work for 2 threads: cg_scatter.c's MIN_WORK_PER_THREAD)
        short = np.abs(vectors[:, 2]) <= 2.0
        assert np.any(short & ~ruled)
        s, v = np.tile(starts[short], (5, 1)), np.tile(vectors[short], (5, 1))
        values = rng.normal(size=(len(s), 9))
        one = sums(box, 300, "z", make, 1.0, s, v, values)
        assert one.tobytes() == sums(box, 300, "z", make, 1.0, s, v, values, n_threads=2).tobytes()
        assert one.tobytes() == narrow_build(lambda: sums(box, 300, "z", make, 1.0, s, v, values)).tobytes()
    if far:
        # tails: single segments too long for a rule, a cutoff of 20 w (values down to 1e-80 of the peak), each
        # nonzero value to 1e-12 of itself
        make = lambda R: cg.Gaussian(0.05, cutoff=1.0)   # noqa: E731  (21 nodes a stencil)
        for length in (0.3, -0.7, 1.4):
            start, vector = np.array([[1.0, 2.0, 12.34]]), np.array([[0.3, 0.1, length]])
            fast = sums(box, 300, "z", make, 1.0, start, vector, np.ones((1, 1)))[:, 0]
            slow = sums(box, 300, "z", make, 1.0, start, vector, np.ones((1, 1)), per_node=True)[:, 0]
            assert np.array_equal(fast == 0.0, slow == 0.0) and slow.min() == 0.0 and slow.max() > 1e70 * \
                slow[slow > 0].min()
            assert np.max(np.abs(fast - slow)[slow > 0] / slow[slow > 0]) <= 1e-12
    else:                                                # 73 nodes a stencil: the separable path
        wide = lambda R: cg.Gaussian(1.2, cutoff=3.6)    # noqa: E731
        fast = sums(box, 300, "z", wide, 1.0, starts, vectors, ones)
        slow = sums(box, 300, "z", wide, 1.0, starts, vectors, ones, per_node=True)
        assert np.abs(fast - slow).max() <= 1e-12 * np.abs(slow).max()


def test_gaussian_segment_slivers_against_mpmath():
    """A profile's segment (oblique; its part along z) whose start or end lies within 1e-3 w to a few ulp inside a
    node's cutoff (a sliver of the segment in the node's ball): the node's value against 50-digit mpmath (the 1-D
    line integral over the box's cross-section), relative to itself. The blocks' closed form (cut_batch_flush's
    twin) rebuilt the part in units of the segment (1e-7 off at 1e-9 w, 5 % at 1e-14 w); now its fallback takes
    the span from exact differences (cg_cut_span_lane)."""
    import mpmath as mp
    from test_hard_cases import mp_psi
    w, cutoff = 0.25, 3.0
    R = cutoff * w
    make = lambda R_: cg.Gaussian(w, cutoff=cutoff * w)   # noqa: E731  (16 nodes a stencil: the blocks)
    box = cg.Box([0, 0, 0], [6, 6, 30])
    grid, _, _ = profile(box, 300, "z", make, 1.0)
    k = 150
    zn = grid.axis_coordinates[-1][k]
    mp.mp.dps = 50
    for end in (False, True):
        for delta in (1e-3 * w, 1e-9 * w, 1e-14 * w, 4 * np.spacing(zn + R)):   # (the last: 4 ulp of z0)
            for L in (0.3 * w, 2.0 * w):
                z0 = zn - R + delta - L if end else zn + R - delta   # the node beyond the end, before the start
                s, v = np.array([[3.0, 3.1, z0]]), np.array([[0.37 * L, -0.2 * L, L]])
                got = sums(box, 300, "z", make, 1.0, s, v, np.ones((1, 1)))[k, 0]
                want = float(mp_psi([mp.mpf(float(zn)) - mp.mpf(float(z0))], [L], w, R)) / 36.0
                assert want > 0.0 and abs(got - want) <= 1e-12 * want, (end, delta / w, L / w, got, want)
