"""Point targets of 16 points or more are sorted by their first coordinate, and each object visits only the points
whose first coordinate is inside its support's box (csrc/cg_scatter.c, sort_points and visit_nodes). Each point
still receives its terms in object order, so the sums are the bits of the scan over all points: checked against
the same points given 8 at a time with the extreme ones (below 16: scanned), for every kernel, points and segments, values and
gradients, periodic and open boxes, repeated first coordinates and points outside the box."""
import numpy as np
import pytest

import cgbound as cg
from cgbound import _core, _engine

KERNELS = {"Gaussian": lambda: cg.Gaussian(0.6, cutoff=1.8), "Gaussian GL2": lambda: cg.Gaussian(0.6, cutoff=1.8,
           line_quadrature=2), "Lucy": lambda: cg.Lucy(1.3), "Heaviside": lambda: cg.Heaviside(1.3)}


def core_sums(box, points, kernel, starts, vectors, values, gradient):
    target = _engine.core_target(cg.Points(points), box)
    core_kernel = _engine.core_kernel(kernel, 1.0)
    if vectors is None:
        return _core.scatter_points(target, core_kernel, starts, values, gradient=gradient, n_threads=1)
    return _core.scatter_segments(target, core_kernel, starts, vectors, values, gradient=gradient, n_threads=1)


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("segments", [False, True])
@pytest.mark.parametrize("gradient", [False, True])
def test_sorted_points_give_the_scan_bits(kernel, periodic, segments, gradient):
    if gradient and kernel == "Heaviside":
        pytest.skip("Heaviside has no gradient")
    rng = np.random.default_rng(hash((kernel, periodic, segments, gradient)) % 2**32)
    box = cg.Box([0, 0, 0], [6, 5, 7], periodic=[periodic] * 3)
    points = rng.uniform(-0.5, 7.5, size=(70, 3))
    points[10:20, 0] = points[5, 0]                      # repeated first coordinates
    points[20:25, 0] = np.array([0.0, 6.0, 3.0, 3.0, 1e-300])
    starts = rng.uniform(0, 6, size=(300, 3))
    vectors = rng.normal(scale=0.8, size=(300, 3)) if segments else None
    values = rng.normal(size=(300, 4))
    whole = core_sums(box, points, KERNELS[kernel](), starts, vectors, values, gradient)
    # each piece holds the points of the least and greatest coordinates too: the extent of the points (the
    # periodic images' range is taken from it) is the same in every call
    extremes = np.unique(np.concatenate([points.argmin(axis=0), points.argmax(axis=0)]))
    rest = np.setdiff1d(np.arange(len(points)), extremes)
    pieces = np.empty_like(whole)
    for i in range(0, len(rest), 8):
        rows = np.concatenate([extremes, rest[i:i + 8]])
        assert len(rows) < 16
        pieces[rows] = core_sums(box, points[rows], KERNELS[kernel](), starts, vectors, values, gradient)
    assert np.count_nonzero(whole) > 0
    assert whole.tobytes() == pieces.tobytes()


def test_cells_of_clustered_points():
    """The sorted points' cells (where an object starts looking): points crowded into a few cells, with one far
    off; objects below, above and inside them; the scan's bits."""
    rng = np.random.default_rng(4)
    box = cg.Box([0, 0, 0], [6, 5, 7])
    points = np.concatenate([rng.uniform(2.0, 2.0 + 1e-9, size=(40, 3)), rng.uniform(0, 6, size=(20, 3)),
                             [[1e5, 1.0, 1.0]]])
    starts = np.concatenate([rng.uniform(-3, 9, size=(300, 3)), points[:30] + 1e-10])
    values = rng.normal(size=(len(starts), 2))
    kernel = cg.Lucy(1.3)
    whole = core_sums(box, points, kernel, starts, None, values, False)
    scanned = np.concatenate([core_sums(box, np.concatenate([points[:-1][i:i + 8], points[-1:]]), kernel, starts, None,
                                        values, False)[:-1] for i in range(0, len(points) - 1, 8)]
                             + [core_sums(box, points[-1:], kernel, starts, None, values, False)])
    assert np.count_nonzero(whole) > 0
    assert whole.tobytes() == scanned.tobytes()
