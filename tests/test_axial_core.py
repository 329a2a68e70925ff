"""cg_axial_segment_sum (csrc/cg_axial.c): the z-averaged line integrals of segment pieces at the node columns of
θ-resolved z-averaged CylindricalGrids, against its NumPy twin (tests/oracle.py), thread counts and bad input."""
import numpy as np
import pytest

import cgbound as cg
from cgbound import _engine

from oracle import oracle_axial_segment_sum

KERNELS = {"gauss5w": cg.Gaussian(0.4), "gauss3w-truncated": cg.Gaussian(0.4, cutoff=1.2, normalize="truncated"),
           "lucy": cg.Lucy(1.2), "heaviside": cg.Heaviside(1.0)}


def case(seed=3, columns=4, segments=6):
    rng = np.random.default_rng(seed)
    bottoms = np.c_[rng.uniform(-1, 1, (columns, 2)), np.full(columns, -1.0)]
    starts = rng.uniform(-1.2, 1.2, (segments, 3))
    vectors = rng.normal(size=(segments, 3)) * 0.7
    vectors[0] = 0.0                                  # a zero-length segment
    vectors[1] = [0.0, 0.0, 0.9]                      # an axial one
    values = rng.normal(size=(segments, 9))
    counts = rng.integers(0, 4, columns)
    counts[0] = 0                                      # a column without pieces
    first = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    n = int(first[-1])
    segment = rng.integers(0, segments, n).astype(np.int64)
    lo = rng.uniform(0, 0.6, n)
    hi = np.minimum(lo + rng.uniform(0, 0.6, n), 1.0)
    panels = rng.integers(1, 4, n).astype(np.int64)
    return bottoms, np.array([0.0, 0.0, -2.0]), first, segment, lo, hi, panels, starts, vectors, values


@pytest.mark.parametrize("name", list(KERNELS))
def test_axial_segment_sum_against_twin(name):
    kernel = KERNELS[name]
    args = case()
    got = _engine.axial_segment_sum(kernel, *args)
    want = oracle_axial_segment_sum(kernel, *args)
    assert np.abs(want).max() > 0
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())


def test_axial_segment_sum_does_not_depend_on_the_thread_count():
    args = case(5, columns=40, segments=30)
    runs = [_engine.axial_segment_sum(cg.Lucy(1.2), *args, n_threads=t) for t in (1, 2, 3)]
    assert all(np.array_equal(runs[0], r) for r in runs[1:])


def test_axial_segment_sum_refuses_bad_pieces():
    bottoms, column, first, segment, lo, hi, panels, starts, vectors, values = case()
    kernel = cg.Lucy(1.0)
    bad = [dict(segment=np.full_like(segment, len(starts))), dict(lo=hi + 0.1), dict(hi=hi + 1.0),
           dict(panels=np.zeros_like(panels)), dict(first=first[::-1].copy()), dict(column=np.array([0, 0, np.nan]))]
    for change in bad:
        args = dict(bottoms=bottoms, column=column, first=first, segment=segment, lo=lo, hi=hi, panels=panels,
                    starts=starts, vectors=vectors, values=values)
        args.update(change)
        with pytest.raises(ValueError):
            _engine.axial_segment_sum(kernel, **args)
    with pytest.raises(ValueError, match="first"):
        _engine.axial_segment_sum(kernel, bottoms, column, first[:-1], segment, lo, hi, panels, starts, vectors, values)
