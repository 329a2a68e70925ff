"""The Gaussian's exact line integrals for segments along a grid axis (cg_separable.c, visit_axis: every node's
value from 1-D tables along the segment and a cross-section table, the nodes whose terms cancel through the cut
batch) against the general exact path on the same segments, the node-by-node erf form and 50-digit mpmath, and
itself across vector builds and thread counts.

The general exact path is reached by tilting the segment by 1e-200 of a length into another slot (it then moves
along two slots; the values change by far less than round-off). Each comparison is at 1e-12 relative to each
value, and the nodes left empty must be the same.
"""
import math

import numpy as np
import pytest

import cgbound as cg
from cgbound import _core, _engine
from helpers import narrow_build
import mpmath as mp

from test_hard_cases import mp_gauss, mp_psi

RTOL = 1e-12


def scatter(box, shape, starts, vectors, values, w, cutoff, per_node=False, n_threads=0):
    """the grid's values, cutoff in units of w"""
    grid = cg.Grid(box, shape)
    kernel = cg.Gaussian(w, cutoff=cutoff * w)
    kernel._per_node = per_node
    target = _engine.core_target(grid, box)
    longest = float(np.max(np.linalg.norm(vectors, axis=1)))
    return _core.scatter_segments(target, _engine.core_kernel(kernel, 1.0, longest), np.asarray(starts, float),
                                  np.asarray(vectors, float), np.asarray(values, float), n_threads=n_threads)


def tilted(vectors):
    """the same segments moving along a second slot by 1e-200 of their length: the general exact path"""
    out = np.array(vectors, float)
    for row in out:
        a = int(np.argmax(np.abs(row)))
        row[(a + 1) % len(row)] = 1e-200 * abs(row[a])
    return out


def assert_values_equal(fast, slow, what, skip=None):
    """equal to 1e-12 of each value, the same nodes empty (skip: nodes left out, flat)"""
    assert np.all(np.isfinite(fast)), what
    assert np.count_nonzero(slow) > 0, what
    if skip is not None:
        keep = ~skip.reshape(-1)
        fast, slow = fast.reshape(len(keep), -1)[keep], slow.reshape(len(keep), -1)[keep]
    assert np.array_equal(fast == 0.0, slow == 0.0), what
    nz = slow != 0.0
    err = float(np.max(np.abs(fast[nz] - slow[nz]) / np.abs(slow[nz])))
    assert err <= RTOL, (what, err)
    return err


def axis_segments(rng, dim, n, length, on_nodes, lo, hi, grid=None):
    """n segments along the axes in turn, +, -; from the grid's nodes if on_nodes"""
    starts = rng.uniform(lo, hi, size=(n, dim))
    if on_nodes:
        for a, c in enumerate(grid.axis_coordinates):
            starts[:, a] = c[np.argmin(np.abs(starts[:, a, None] - c[None]), axis=1)]
    vectors = np.zeros((n, dim))
    axes = np.arange(n) % dim
    signs = np.where(np.arange(n) // dim % 2 == 0, 1.0, -1.0)
    vectors[np.arange(n), axes] = signs * length
    return starts, vectors


BOX3 = cg.Box([0, 0, 0], [8, 8, 8])
SHAPE3 = (17, 17, 17)   # spacing 8/17
GRID3 = cg.Grid(BOX3, SHAPE3)


@pytest.mark.parametrize("cutoff", [1.5, 3.0, 5.0, 7.0])
def test_axis_segments_equal_the_general_path(cutoff):
    """Along each axis, both directions, from nodes and between them, lengths from 1e-9 w (every node's
    W by the Gauss-Legendre fallback; 1e-7 and 1e-5 w: about the fallback's threshold) to 4.5 w (the longest rule);
    cutoff 7 w takes erfcx's long series."""
    rng = np.random.default_rng(int(cutoff * 10))
    w = 0.6
    for length_over_w in (1e-9, 1e-7, 1e-5, 1e-3, 0.07, 0.4, 1.0, 2.5, 4.5):
        for on_nodes in (True, False):
            starts, vectors = axis_segments(rng, 3, 6, length_over_w * w, on_nodes, 3.0, 5.0, GRID3)
            values = rng.uniform(0.5, 1.5, size=(6, 1))   # (one sign: no cancellation between segments)
            fast = scatter(BOX3, SHAPE3, starts, vectors, values, w, cutoff)
            slow = scatter(BOX3, SHAPE3, starts, tilted(vectors), values, w, cutoff)
            assert_values_equal(fast, slow, (cutoff, length_over_w, on_nodes))


def test_axis_segments_equal_node_by_node_and_mpmath():
    """Against the node-by-node erf form everywhere and 50-digit mpmath at nodes on the segment's line, 3 to
    20 w beyond an end (the closed form's tails), and just inside the cutoff sphere."""
    w, cutoff = 0.25, 5.0
    box, shape = cg.Box([0, 0, 0], [8, 8, 8]), (33, 33, 33)   # spacing 0.25 = w
    starts = np.array([[4.0, 4.0, 4.0], [4.1, 3.95, 4.05], [4.0, 4.0, 4.0]])
    vectors = np.array([[0.0, 0.0, 0.3], [0.0, -0.45, 0.0], [1e-3, 0.0, 0.0]])
    for s, v in zip(starts, vectors):
        fast = scatter(box, shape, s[None], v[None], [[1.0]], w, cutoff)[:, 0]
        slow = scatter(box, shape, s[None], v[None], [[1.0]], w, cutoff, per_node=True)[:, 0]
        big = np.abs(slow) > 1e-3 * np.abs(slow).max()
        assert np.max(np.abs(fast[big] - slow[big]) / np.abs(slow[big])) <= RTOL
        assert np.max(np.abs(fast - slow)) <= RTOL * np.abs(slow).max()
        nodes = np.stack(np.meshgrid(*cg.Grid(box, shape).axis_coordinates, indexing="ij"), -1).reshape(-1, 3)
        q = nodes - s
        a = int(np.argmax(np.abs(v)))
        along = q[:, a] * np.sign(v[a])
        across = np.sqrt(np.sum(np.delete(q, a, axis=1) ** 2, axis=1))
        L = abs(v[a])
        pick = ((across < 1e-9) | ((along > L + 3 * w) & (along < L + 20 * w) & (across < 0.6)) |
                ((along < -3 * w) & (along > -20 * w) & (across < 0.6)))
        pick &= fast != 0.0
        pick[np.flatnonzero(pick)[12:]] = False
        assert pick.sum() >= 6
        want = [float(mp_psi(list(p), list(v), w, cutoff * w)) for p in q[pick]]
        assert min(abs(x) for x in want) > 0.0
        got = fast[pick]
        assert np.max(np.abs(got - want) / np.abs(want)) <= RTOL


def test_axis_segments_near_1e6_with_small_width():
    w, cutoff = 1e-3, 3.0
    box = cg.Box([1e6, 1e6, 1e6], [1e6 + 0.016, 1e6 + 0.016, 1e6 + 0.016])
    shape = (17, 17, 17)
    rng = np.random.default_rng(3)
    starts, vectors = axis_segments(rng, 3, 6, 1.3e-3, False, 1e6 + 0.006, 1e6 + 0.009)
    fast = scatter(box, shape, starts, vectors, np.ones((6, 1)), w, cutoff)
    slow = scatter(box, shape, starts, tilted(vectors), np.ones((6, 1)), w, cutoff)
    assert_values_equal(fast, slow, "near 1e6")


def test_axis_segments_in_periodic_boxes_and_planar_grids():
    """A periodic box (segments across its faces and images of the stencil) and 2-D grids (a missing slot: the
    axes are slots 1 and 2), one periodic."""
    rng = np.random.default_rng(7)
    w, cutoff = 0.5, 3.0
    box = cg.Box([0, 0, 0], [4, 4, 4], periodic=True)
    starts, vectors = axis_segments(rng, 3, 12, 0.8, False, 0.0, 4.0)
    values = rng.uniform(0.5, 1.5, size=(12, 3))
    fast = scatter(box, (16, 16, 16), starts, vectors, values, w, cutoff)
    slow = scatter(box, (16, 16, 16), starts, tilted(vectors), values, w, cutoff)
    assert_values_equal(fast, slow, "periodic")
    for box2, shape in ((cg.Box([0, 0], [6, 6]), (25, 25)), (cg.Box([0, 0], [6, 6], periodic=True), (24, 20))):
        starts, vectors = axis_segments(rng, 2, 8, 0.7, False, 0.5, 5.5)
        values = rng.uniform(0.5, 1.5, size=(8, 2))
        fast = scatter(box2, shape, starts, vectors, values, w, cutoff)
        slow = scatter(box2, shape, starts, tilted(vectors), values, w, cutoff)
        assert_values_equal(fast, slow, ("2-D", shape))


@pytest.mark.skipif(not cg.have_openmp(), reason="serial build")
@pytest.mark.parametrize("cutoff", [3.0, 5.0])
def test_axis_segments_bit_for_bit_across_builds_and_threads(cutoff):
    """Axis segments with one value, three picked of nine (a force across the branch), one picked (a force along
    it: its sums kept apart, added to the output at the end of each slab's part) and nine, with a few tilted ones
    among them (the general path beside the axis one): the same bits from both vector builds and from 1, 2 and 3
    threads."""
    rng = np.random.default_rng(11)
    w = 0.5
    box = cg.Box([0, 0, 0], [48, 4, 4])   # long along x: the threads' slabs (cg_scatter.c) equal across counts
    starts, vectors = axis_segments(rng, 3, 240, 0.9, False, 0.5, 3.5)
    starts[:, 0] *= 12.0
    vectors[::17] = tilted(vectors[::17])
    branch = vectors / np.linalg.norm(vectors, axis=1)[:, None]
    force = rng.normal(size=(240, 3))
    along = rng.uniform(0.5, 1.5, size=(240, 1)) * branch   # one value picked: its sums kept apart
    for values in (rng.normal(size=(240, 1)), np.einsum("ni,nj->nij", force, branch).reshape(240, 9),
                   np.einsum("ni,nj->nij", along, branch).reshape(240, 9), rng.normal(size=(240, 9))):
        def run(n_threads):
            return scatter(box, (192, 16, 16), starts, vectors, values, w, cutoff, n_threads=n_threads)

        one = run(1)
        assert np.count_nonzero(one) > 0
        assert np.array_equal(one, narrow_build(lambda: run(1)))
        for k in (2, 3):
            assert np.array_equal(one, run(k)), k


@pytest.mark.parametrize("axis", [0, 2])
def test_axis_segments_the_sphere_cuts_near_an_end(axis):
    """Nodes whose sphere crosses the segment within delta of an end, of its start, or barely meets it (h small):
    the terms of the tails cancel, and those nodes go to the cut batch (its Gauss-Legendre fallback)."""
    w, cutoff = 0.5, 3.0
    R, L = cutoff * w, 0.8 * w
    node = np.array([GRID3.axis_coordinates[a][8] for a in range(3)])
    across = (axis + 1) % 3
    for delta in (1e-3 * w, 1e-6 * w, 1e-9 * w):
        starts, vectors = [], []
        for rho in (2 * GRID3.spacing[across], R - 1e-7 * w):
            h = np.sqrt(R * R - rho * rho)
            for u, sign in ((h + L - delta, 1.0), (-h + delta, 1.0), (h + L - delta, -1.0)):
                s = node.copy()
                s[across] -= rho
                s[axis] -= sign * u
                v = np.zeros(3)
                v[axis] = sign * L
                starts.append(s)
                vectors.append(v)
        starts, vectors = np.array(starts), np.array(vectors)
        for s, v in zip(starts, vectors):
            fast = scatter(BOX3, SHAPE3, s[None], v[None], [[1.0]], w, cutoff)[:, 0]
            slow = scatter(BOX3, SHAPE3, s[None], tilted(v[None]), [[1.0]], w, cutoff)[:, 0]
            assert_values_equal(fast, slow, (axis, delta))
            k = np.ravel_multi_index(tuple(np.argmin(np.abs(c - x)) for c, x in zip(GRID3.axis_coordinates, node)),
                                     SHAPE3)
            # the general path (its fallback's span from exact differences) keeps each value here
            want = float(mp_psi(list(node - s), list(tilted(v[None])[0]), w, R))
            assert want > 0.0 and abs(slow[k] - want) <= RTOL * want, (axis, delta, slow[k], want)
            # and visit_axis (its cancelling nodes' span from exact differences too)
            want = float(mp_psi(list(node - s), list(v), w, R))
            assert want > 0.0 and abs(fast[k] - want) <= RTOL * want, (axis, delta, fast[k], want)


def test_axis_segments_with_picked_values():
    """Nine values per segment of which one (a force along the branch: W1's contact stress) or three are not 0
    (the values picked: one folds into the row's terms), against the general path."""
    rng = np.random.default_rng(13)
    w, cutoff = 0.5, 4.0
    starts, vectors = axis_segments(rng, 3, 12, 0.9, False, 2.5, 5.5)
    branch = vectors / np.linalg.norm(vectors, axis=1)[:, None]
    magnitude = rng.uniform(0.5, 1.5, size=(12, 1))
    across = np.roll(branch, 1, axis=1)
    for force in (magnitude * branch, magnitude * (branch + 0.3 * across)):
        values = np.einsum("ni,nj->nij", force, branch).reshape(12, 9)
        fast = scatter(BOX3, SHAPE3, starts, vectors, values, w, cutoff)
        slow = scatter(BOX3, SHAPE3, starts, tilted(vectors), values, w, cutoff)
        assert_values_equal(fast, slow, "picked values")


@pytest.mark.parametrize("cutoff", [4.5, 6.0])   # 4.7 and 6.2 node spacings: held from 4 (HOLD_REACH)
def test_axis_segments_one_picked_value_held_apart(cutoff):
    """One picked value (a force along the branch): with a cutoff of 4 node spacings or more visit_axis holds the
    output's value of that kind apart, node-major, over a window of nodes copied from the output as the segments ask
    for more, and copied back before any other visit writes. Segments along each axis in input order (too few to be
    sorted), jumping back and forth along x so that each window grows on both sides and moves what it holds, with
    tilted ones among them (the general path: the values go back first), long ones (node by node: the same) and
    other values' segments (three picked). The same bits as the plain update (every value added straight to the
    output: 9 more columns of ones), and the general path's values to 1e-12."""
    rng = np.random.default_rng(17)
    w = 0.5
    box = cg.Box([0, 0, 0], [12, 10, 8])
    shape = (25, 21, 17)
    starts, vectors = axis_segments(rng, 3, 90, 0.9, False, 1.0, 7.0)
    starts[:, 0] = rng.uniform(0.5, 11.5, size=90)
    starts[::2, 0] = np.where(starts[::2, 0] < 6.0, starts[::2, 0] + 5.5, starts[::2, 0] - 5.5)
    branch = vectors / np.linalg.norm(vectors, axis=1)[:, None]
    force = rng.uniform(0.5, 1.5, size=(90, 1)) * branch
    force[::7] += 0.3 * np.roll(branch[::7], 1, axis=1)   # across the branch too: three picked
    values = 0.0 + np.einsum("ni,nj->nij", force, branch).reshape(90, 9)
    mixed = vectors.copy()
    mixed[::11] = tilted(mixed[::11])
    mixed[5::13] *= 2.6 / 0.9   # longer than the exact path's rules (4.6 w): node by node
    padded = np.concatenate([values, np.ones_like(values)], axis=1)
    for build in (lambda f: f(), narrow_build):
        # (one thread: the thread count chosen for a job depends on its number of values; the grid is too short
        # along x for slabs at 5 w, whose terms per node are in the same order on any count)
        held = build(lambda: scatter(box, shape, starts, mixed, values, w, cutoff, n_threads=1))
        plain = build(lambda: scatter(box, shape, starts, mixed, padded, w, cutoff, n_threads=1))[:, :9]
        assert np.count_nonzero(held[:, [0, 4, 8]]) > 0
        assert np.array_equal(held.view(np.uint64), plain.view(np.uint64))
    slow = scatter(box, shape, starts, tilted(mixed), values, w, cutoff)
    assert_values_equal(held, slow, "one picked value")


@pytest.mark.parametrize("cutoff", [12.0, 20.0, 34.6])
def test_axis_segments_with_large_cutoffs(cutoff):
    """Cutoffs of 12, 20 and 34.6 w (R^2 / 2w^2 = 599, just under AXIS_EXPONENT_MAX): the crossing's term Pc by
    erfcx's long series (h > 4 sqrt2 w), against mpmath at nodes whose sphere crosses the segment there, and for
    12 and 20 w against the node-by-node erf form everywhere (at 34.6 w it is itself up to 7e-13 off mpmath, and
    the general path 2e-12)."""
    box, shape = cg.Box([0, 0, 0], [20, 20, 20]), (40, 40, 40)   # spacing 0.5
    grid = cg.Grid(box, shape)
    nodes = np.stack(np.meshgrid(*grid.axis_coordinates, indexing="ij"), -1).reshape(-1, 3)
    R = 9.0
    w = R / cutoff
    for s, v in (([10.1, 9.8, 10.2], [0.0, 0.0, 0.5 * w]), ([10.0, 10.3, 9.9], [-3.0 * w, 0.0, 0.0])):
        s, v = np.array(s), np.array(v)
        fast = scatter(box, shape, s[None], v[None], [[1.0]], w, cutoff)[:, 0]
        if cutoff < 30.0:
            slow = scatter(box, shape, s[None], v[None], [[1.0]], w, cutoff, per_node=True)[:, 0]
            assert_values_equal(fast, slow, cutoff)
        a = int(np.argmax(np.abs(v)))
        q = nodes - s
        u = q[:, a] * np.sign(v[a])
        h = np.sqrt(np.maximum(R * R - (np.sum(q * q, axis=1) - q[:, a] ** 2), 0.0))
        crossing = ((u - h > 0.0) | (u + h < abs(v[a]))) & (h > 6.0 * w) & (fast != 0.0)
        pick = np.flatnonzero(crossing)[::53][:6]
        assert len(pick) == 6
        want = np.array([float(mp_psi(list(q[k]), list(v), w, R)) for k in pick])
        assert np.min(want) > 0.0
        assert np.max(np.abs(fast[pick] - want) / want) <= RTOL, cutoff


def test_short_axis_segments_with_a_large_cutoff():
    """Segments of 1e-40 to 1e-100 w at a cutoff of 34.6 w: every node's value is normal (the point Gaussian to
    relative L / w), though (L / w) exp(-R^2 / 2w^2), the scale of W's fallback, is not: against the general path
    and mpmath's point Gaussian."""
    box, shape = cg.Box([0, 0, 0], [12, 12, 12]), (25, 25, 25)
    grid = cg.Grid(box, shape)
    nodes = np.stack(np.meshgrid(*grid.axis_coordinates, indexing="ij"), -1).reshape(-1, 3)
    w, cutoff = 0.17, 34.6
    s = np.array([6.1, 5.9, 6.05])
    for length_over_w in (1e-40, 1e-60, 1e-100):
        v = np.array([0.0, 0.0, length_over_w * w])
        fast = scatter(box, shape, s[None], v[None], [[1.0]], w, cutoff)[:, 0]
        slow = scatter(box, shape, s[None], tilted(v[None]), [[1.0]], w, cutoff)[:, 0]
        assert_values_equal(fast, slow, length_over_w)
        order = np.argsort(np.where(fast != 0.0, fast, np.inf))[:4]   # the smallest values
        want = np.array([float(mp_gauss(sum(mp.mpf(float(x)) ** 2 for x in nodes[k] - s), w, cutoff * w, 3))
                         for k in order])
        assert np.max(np.abs(fast[order] - want) / want) <= RTOL, length_over_w


def test_axis_segments_sliver_at_an_end_on_the_line():
    """A node on the segment's line (rho = 0: h = R exactly) whose sphere crosses the segment within a few ulp of
    an end, before the start (a sliver [0, u + h], or nothing) or beyond it (the part [u - h, L]): visit_axis
    integrates over the part, its span from exact differences (cg_cut_span_lane), against mpmath; so does the
    general path (tilted), whose fallback takes the span the same way (it rebuilt the part in units of the
    segment and lost the sliver: up to 20 % off at L = 0.3 w)."""
    w, cutoff = 0.5, 3.0
    R = cutoff * w
    node = np.array([c[8] for c in GRID3.axis_coordinates])
    k = np.ravel_multi_index((8, 8, 8), SHAPE3)
    for axis, length_over_w in ((2, 1e-3), (0, 0.3), (1, 4.0)):
        for ulps in (-3, -1, 2, 20):
            for sign in (1.0, -1.0):
                s = node.copy()
                s[axis] = node[axis] + sign * R * (1 + ulps * 2.0 ** -52)
                v = np.zeros(3)
                v[axis] = (sign if ulps < 0 else -sign) * length_over_w * w
                got = scatter(BOX3, SHAPE3, s[None], v[None], [[1.0]], w, cutoff)[k, 0]
                want = float(mp_psi(list(node - s), list(v), w, R))
                assert abs(got - want) <= RTOL * want, (axis, length_over_w, ulps, sign, got, want)
                slow = scatter(BOX3, SHAPE3, s[None], tilted(v[None]), [[1.0]], w, cutoff)[k, 0]
                assert abs(slow - want) <= RTOL * want, (axis, length_over_w, ulps, sign, slow, want)
    # a short segment at a small cutoff, the node just inside its sphere at the segment's start
    box, shape = cg.Box([0, 0], [8, 8]), (8, 8)
    s, v = np.array([4.5, 3.721026658511189]), np.array([0.0, -1.7255666894195883e-05])
    w = 0.7789733414888114
    got = scatter(box, shape, s[None], v[None], [[1.0]], w, 1.0)[:, 0]
    nodes = np.stack(np.meshgrid(*cg.Grid(box, shape).axis_coordinates, indexing="ij"), -1).reshape(-1, 2)
    want = float(mp_psi(list(nodes[36] - s), list(v), w, w))
    assert want > 0.0 and abs(got[36] - want) <= RTOL * want, (got[36], want)


@pytest.mark.parametrize("cutoff", [3.0, 5.0])
def test_axis_contact_stress_integrates_to_minus_f_outer_b(cutoff):
    """A physical identity through the axis path: a contact along each axis, its contact stress summed over a fine
    grid (times the cell volume) is -f (x) b times the kernel's mass inside its cutoff ball, P(chi_3 < c) =
    erf(c/sqrt2) - sqrt(2/pi) c exp(-c^2/2) (the Gaussian normalized over all space); a sign or factor error in a
    table or the crossing term breaks it."""
    w, box = 0.5, cg.Box([0, 0, 0], [6, 6, 6])
    mass = math.erf(cutoff / math.sqrt(2)) - math.sqrt(2 / math.pi) * cutoff * math.exp(-cutoff ** 2 / 2)
    grid = cg.Grid(box, (48, 48, 48))
    # a general force (three values of nine), and a central one (one value: held apart, 12-20 node spacings)
    forces = [(a, np.array([0.3, -0.2, 1.0])) for a in range(3)] + [(a, -0.7 * np.eye(3)[a]) for a in range(3)]
    for axis, force in forces:
        p = np.full((2, 3), 3.03)
        p[1, axis] += 0.97
        snap = cg.Snapshot(p, np.zeros((2, 3)), np.ones(2), box=box, radii=np.full(2, 0.5),
                           contacts=cg.Contacts([0], [1], [force], [0.5 * (p[0] + p[1])]))
        r = cg.coarse_grain(snap, grid, cg.Gaussian(w, cutoff=cutoff * w), fields=("contact_stress",))
        total = np.asarray(r.contact_stress).sum(axis=(0, 1, 2)) * np.prod(np.asarray(grid.spacing))
        assert np.allclose(total, -np.outer(force, p[0] - p[1]) * mass, rtol=1e-4, atol=1e-6), (axis, total)


def test_axis_segments_with_many_cancelling_nodes():
    """Short segments (L = 0.02 to 0.2 w) on a fine grid (w / 10): hundreds of nodes near the cutoff sphere have a
    short part of the segment inside their ball and cancelling terms, more than one cut batch holds in a segment,
    and in a plane of it (the batch is flushed between two nodes of a plane); against the general path."""
    box, shape = cg.Box([0, 0, 0], [6, 6, 6]), (60, 60, 60)
    w, cutoff = 1.0, 2.5
    s = np.array([[3.02, 2.97, 3.01]])
    for length_over_w in (0.02, 0.05, 0.2):
        for axis in range(3):
            v = np.zeros((1, 3))
            v[0, axis] = length_over_w * w
            fast = scatter(box, shape, s, v, [[1.0]], w, cutoff)
            slow = scatter(box, shape, s, tilted(v), [[1.0]], w, cutoff)
            assert_values_equal(fast, slow, (length_over_w, axis))


def test_axis_segments_ending_within_rounding_of_a_node_plane():
    """A segment's start or end a few ulp beyond a plane of nodes (the plane lies before the start, or after the end,
    by less than the near-miss margin 2^-40 R): the plane's near misses go to the cut batch, its packed entries only
    (never the padding lanes past them, whose h = 0 and offsets are not nodes); against the general path."""
    box, shape = cg.Box([0, 0, 0], [8, 8, 8]), (16, 16, 16)     # nodes at 0.25 + 0.5 k
    w, cutoff = 0.6, 3.0
    node = 0.25 + 0.5 * 8
    for eps in (0.0, 2.0 ** -52, 4e-16, -4e-16, 1e-13):
        for axis in range(3):
            for sign in (1.0, -1.0):
                v = np.zeros((1, 3))
                v[0, axis] = sign * 0.7
                for end in (False, True):
                    s = np.array([[4.1, 3.9, 4.05]])
                    s[0, axis] = node + eps * sign - (v[0, axis] if end else 0.0)
                    fast = scatter(box, shape, s, v, [[1.0]], w, cutoff)
                    slow = scatter(box, shape, s, tilted(v), [[1.0]], w, cutoff)
                    assert_values_equal(fast, slow, (eps, axis, sign, end))
