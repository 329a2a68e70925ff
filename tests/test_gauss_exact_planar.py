"""The Gaussian's exact line integrals on grids for segments that do not move along some grid axis (a component
of the segment exactly +-0: along an axis, in a grid plane; every segment of a 2-D target in its missing slot):
cg_separable.c computes such a slot's exponentials once for all the rule's points. Against the node-by-node path
at 1e-12 (field- and value-relative, as tests/test_gauss_exact_fast.py), 50-digit mpmath near 1e6 with w = 1e-3,
and bit for bit across vector builds and thread counts.
"""
import mpmath as mp
import numpy as np
import pytest

import cgbound as cg
from helpers import narrow_build
from test_gauss_exact_fast import BOX3, SHAPE3, assert_grid_equals_node_by_node, gauss_grid_psi, grid_nodes
from test_hard_cases import mp_psi, rel_error

RTOL = 1e-12
# the zero components: one (in a grid plane), two (along an axis), and -0.0
DIRECTIONS = {
    "along x": [1.0, 0.0, 0.0],
    "along y": [0.0, 1.0, 0.0],
    "along z": [0.0, 0.0, 1.0],
    "in the xy plane": [0.6, -0.8, 0.0],
    "in the xz plane": [0.8, 0.0, 0.6],
    "in the yz plane": [0.0, 0.28, -0.96],
    "along -z with -0.0": [-0.0, -0.0, -1.0],
}


@pytest.mark.parametrize("direction", sorted(DIRECTIONS))
@pytest.mark.parametrize("length_over_w", [0.0, 1e-9, 0.07, 0.2, 0.4, 0.99, 1.5, 2.5, 4.5])
@pytest.mark.parametrize("cutoff", [3.0, 5.0])
def test_planar_segments_equal_node_by_node_for_every_rule(direction, length_over_w, cutoff):
    """Each round-off rule (4 to 16 points), zero and near-zero lengths; starts off the nodes and on them."""
    w = 0.6
    unit = np.array(DIRECTIONS[direction])
    starts = np.array([[3.7, 4.1, 3.3], [4.0, 4.0, 4.0], [2.9, 4.5, 5.2]])
    vectors = np.tile(unit * length_over_w * w, (len(starts), 1))
    assert_grid_equals_node_by_node(BOX3, SHAPE3, starts, vectors, w, cutoff, f"{direction}, L = {length_over_w} w")


@pytest.mark.parametrize("distance", [3.0, 10.0, 20.0])
def test_planar_segment_nodes_far_beyond_an_end(distance):
    """Nodes 3-20 w beyond the end of a segment along an axis (cutoff 25 w: all inside the ball)."""
    w, cutoff = 0.2, 25.0
    box = cg.Box([0, 0, 0], [12, 2, 2])
    start, vector = np.array([1.0, 1.0, 1.0]), np.array([0.9, 0.0, 0.0])
    grid, _, got = gauss_grid_psi(box, (121, 5, 5), start, vector, w, cutoff)
    nodes = grid_nodes(grid)
    x_end = start[0] + vector[0] + distance * w
    pick = np.flatnonzero(np.isclose(nodes[:, 0], grid.axis_coordinates[0][np.argmin(
        np.abs(grid.axis_coordinates[0] - x_end))]))
    mp.mp.dps = 50
    want = np.array([float(mp_psi(p - start, vector, w, cutoff * w)) for p in nodes[pick]])
    assert np.all(want > 0)
    assert rel_error(got[pick], want) <= RTOL


def test_planar_segment_near_1e6_with_small_width():
    w, cutoff = 1e-3, 5.0
    lo = np.array([1e6, -2e6, 1e6])
    box = cg.Box(lo, lo + 0.016)
    start = lo + np.array([7.3e-3, 8.1e-3, 7.7e-3])
    vector = np.array([4e-4, 0.0, -3e-4])
    grid, _, got = gauss_grid_psi(box, (17, 17, 17), start, vector, w, cutoff)
    _, _, slow = gauss_grid_psi(box, (17, 17, 17), start, vector, w, cutoff, per_node=True)
    assert rel_error(got, slow) <= RTOL
    nodes = grid_nodes(grid)
    pick = np.argsort(-slow)[:60:3]
    mp.mp.dps = 50
    want = [float(mp_psi([mp.mpf(float(p[d])) - mp.mpf(float(start[d])) for d in range(3)], vector, w, cutoff * w))
            for p in nodes[pick]]
    assert rel_error(got[pick], want) <= RTOL


@pytest.mark.skipif(not cg.have_openmp(), reason="serial build")
@pytest.mark.parametrize("cutoff", [3.0, 5.0])
def test_lattice_contacts_bit_for_bit_across_builds_and_threads(cutoff):
    """A simple-cubic lattice's contacts (every branch along an axis) and a sheared copy (in grid planes)."""
    shape = (48, 4, 4)   # long along x: the threads' slabs (cg_scatter.c) make runs equal across thread counts
    axes = [0.5 + 0.99 * np.arange(m) for m in shape]
    pos = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    idx = np.arange(pos.shape[0]).reshape(shape)
    i = np.concatenate([np.take(idx, range(shape[a] - 1), axis=a).ravel() for a in range(3)])
    j = np.concatenate([np.take(idx, range(1, shape[a]), axis=a).ravel() for a in range(3)])
    rng = np.random.default_rng(5)
    for shear in (0.0, 0.3):
        p = pos.copy()
        p[:, 0] += shear * p[:, 1]   # x-y shear: y-contacts tilt into the xy plane
        force = rng.normal(size=(i.size, 3))
        box = cg.Box([-1, -1, -1], [shape[0] + 3.0, shape[1] + 1.0, shape[2] + 1.0])
        snap = cg.Snapshot(p, np.zeros_like(p), np.ones(len(p)), box=box,
                           contacts=cg.Contacts(i, j, force, 0.5 * (p[i] + p[j])))
        grid = cg.Grid(box, (2 * shape[0] + 8, 2 * shape[1] + 4, 2 * shape[2] + 4))

        def stress():
            return cg.coarse_grain(snap, grid, cg.Gaussian(0.5, cutoff=cutoff),
                                   fields=("contact_stress",)).contact_stress

        with cg.threads(1):
            one = stress()
            narrow = narrow_build(stress)
        assert np.count_nonzero(one) > 0
        assert np.array_equal(one, narrow), shear
        for k in (2, 3):
            with cg.threads(k):
                assert np.array_equal(one, stress()), (shear, k)
