"""cg_ring_axial_point_sum (csrc/cg_ring.c): the θ-averages of point sources' tensors over a ring, averaged exactly
over z (the s-points of z_averaged_ring_segments), against its NumPy twin (tests/oracle.py: the same cuts and
points built source by source, the moments by the twin's own ring rule: 1e-12), independent of the thread count
bit for bit, over input dtypes and layouts, and refusing bad arguments."""
import numpy as np
import pytest

from cgbound import _engine

from oracle import oracle_ring_axial_point_sum
from test_ring_core import KERNELS


def sources(kernel, r, n=60, seed=0, lo=0.0, hi=4.0):
    """Point sources around the ring: through it, on the axis, on the box's ends, and random (some beyond
    the ends)."""
    rng = np.random.default_rng(seed)
    c = float(kernel.radius)
    rho = np.abs(r + rng.uniform(-1.2 * c, 1.2 * c, n))
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    rho[:5] = r
    rho[5:8] = 0.0
    zeta = rng.uniform(lo - c, hi + c, n)
    zeta[8:10] = lo, hi
    xy = np.column_stack([rho * np.cos(phi), rho * np.sin(phi)])
    return xy, zeta, rng.normal(size=(n, 9)), rng.uniform(0.1, 1.0, n)


@pytest.mark.parametrize("name", KERNELS)
@pytest.mark.parametrize("r", [0.0, 0.3, 2.0])
def test_ring_axial_point_sum_against_twin(name, r):
    kernel = KERNELS[name]
    case = sources(kernel, r)
    got = _engine.ring_axial_point_sum(kernel, r, 0.0, 4.0, *case)
    want = oracle_ring_axial_point_sum(kernel, r, 0.0, 4.0, *case)
    assert got.shape == (3, 3)
    size = np.abs(want).max()
    assert size > 0
    np.testing.assert_array_less(np.abs(got - want), 1e-12 * size)


def test_ring_axial_point_sum_does_not_depend_on_the_thread_count():
    for name in ("lucy", "gauss5w"):
        kernel = KERNELS[name]
        case = sources(kernel, 1.0, n=700, seed=3)
        runs = [_engine.ring_axial_point_sum(kernel, 1.0, 0.0, 4.0, *case, n_threads=t) for t in (1, 2, 3)]
        assert np.abs(runs[0]).max() > 0
        for other in runs[1:]:
            assert np.array_equal(runs[0], other)


def test_ring_axial_point_sum_over_dtypes_and_layouts():
    kernel = KERNELS["gauss3w"]
    xy, zeta, tensors, weights = sources(kernel, 1.0, seed=4)
    want = _engine.ring_axial_point_sum(kernel, 1.0, 0.0, 4.0, xy, zeta, tensors, weights)
    wide = np.zeros((len(zeta), 4))
    wide[:, ::2] = xy
    variants = [(np.asfortranarray(xy), zeta, np.asfortranarray(tensors), weights),
                (wide[:, ::2], np.repeat(zeta, 2)[::2], np.repeat(tensors, 2, axis=0)[::2], weights.tolist()),
                (xy.tolist(), zeta.tolist(), tensors.tolist(), weights)]
    for args in variants:
        assert np.array_equal(_engine.ring_axial_point_sum(kernel, 1.0, 0.0, 4.0, *args), want)
    t32 = tensors.astype(np.float32)
    assert np.array_equal(_engine.ring_axial_point_sum(kernel, 1.0, 0.0, 4.0, xy, zeta, t32, weights),
                          _engine.ring_axial_point_sum(kernel, 1.0, 0.0, 4.0, xy, zeta, t32.astype(float), weights))
    empty = _engine.ring_axial_point_sum(kernel, 1.0, 0.0, 4.0, np.zeros((0, 2)), np.zeros(0), np.zeros((0, 9)),
                                         np.zeros(0))
    assert np.array_equal(empty, np.zeros((3, 3)))


def test_ring_axial_point_sum_refuses_bad_arguments():
    kernel = KERNELS["lucy"]
    xy, zeta, tensors, weights = sources(kernel, 1.0, n=12)
    with pytest.raises(ValueError, match="r: expected a finite radius >= 0"):
        _engine.ring_axial_point_sum(kernel, -1.0, 0.0, 4.0, xy, zeta, tensors, weights)
    for lo, hi in ((4.0, 4.0), (5.0, 4.0), (float("nan"), 4.0), (0.0, float("inf"))):
        with pytest.raises(ValueError, match="lo, hi: expected finite numbers with lo < hi"):
            _engine.ring_axial_point_sum(kernel, 1.0, lo, hi, xy, zeta, tensors, weights)
    with pytest.raises(ValueError, match="zeta: expected length 12"):
        _engine.ring_axial_point_sum(kernel, 1.0, 0.0, 4.0, xy, zeta[:-1], tensors, weights)
    with pytest.raises(ValueError, match="tensors: expected length 9 along axis 1"):
        _engine.ring_axial_point_sum(kernel, 1.0, 0.0, 4.0, xy, zeta, tensors[:, :4], weights)
    bad = zeta.copy()
    bad[3] = np.nan
    with pytest.raises(ValueError, match="zeta: expected finite values"):
        _engine.ring_axial_point_sum(kernel, 1.0, 0.0, 4.0, xy, bad, tensors, weights)
    with pytest.raises(ValueError, match="kernel"):
        _engine._core.ring_axial_point_sum((0, -1.0, 1.0, 0, 1.0), 1.0, 0.0, 4.0, xy, zeta, tensors, weights)
