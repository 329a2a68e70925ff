"""The Gaussian's points on grids take a visit of their own (csrc/cg_separable.c's visit_point; one value by
rows of masks, several by the rows' walks). Its sums are those of the general visit node for node: one value
alone (visit_point, rows_of_point), the same value beside a zero one (picked: the general visit) and beside
itself (visit_point, rows_of_one_point) give the same bits, in both vector builds and on 1 and 2 threads, over
the stencils' lengths where its paths change (63, 64, 65 nodes on the last axis: 64 is the longest it takes),
periodic boxes and one-node axes. The values against the slow twins: tests/test_oracle*.py."""
import numpy as np
import pytest

from cgbound import _engine
from helpers import narrow_build


def scatter_column0(target, kernel, positions, values, threads):
    return np.asarray(_engine.scatter_points(target, kernel, positions, values, n_threads=threads))[..., 0]


@pytest.mark.parametrize("nz, radius", [(1, 3.0), (9, 3.0), (100, 31.6), (100, 32.0), (100, 32.6), (8, 40.0)])
@pytest.mark.parametrize("periodic", [False, True])
def test_point_visit_gives_the_general_visits_bits(nz, radius, periodic):
    rng = np.random.default_rng(nz + int(10 * radius) + periodic)
    shape = (10, 7, nz)
    target = _engine.CoreTarget(3, (0, 1, 2), [np.arange(s) + 0.5 for s in shape], None, [periodic] * 3,
                                [float(s) for s in shape])
    kernel = _engine.CoreKernel(0, radius / 3, radius, 1, 1.0)
    positions = rng.uniform(-2.0, 12.0, size=(40, 3))
    positions[:, 2] = rng.uniform(-3.0, nz + 3.0, 40)
    v = rng.uniform(-2.0, 2.0, size=(40, 1))
    results = []
    for build in (lambda f: f(), narrow_build):
        for threads in (1, 2):
            for values in (v, np.hstack([v, np.zeros_like(v)]), np.hstack([v, v])):
                results.append(build(lambda: scatter_column0(target, kernel, positions, values, threads)))
    assert np.any(results[0] != 0.0)
    for r in results[1:]:
        np.testing.assert_array_equal(r.view(np.int64), results[0].view(np.int64))
