"""cg_ring_segment_columns (csrc/cg_ring.c): the segment sums of many rings (columns) in one call.

Against its NumPy twin (tests/oracle.py, a different rule for the moments: 1e-12), and bit for bit against
cg_ring_segment_sum column by column (the same blocks added in order), over input dtypes and layouts, column
shapes (empty columns, one piece, more than a block) and thread counts.
"""
import numpy as np
import pytest

import cgbound as cg
from cgbound import _engine

from oracle import oracle_ring_segment_columns
from test_ring_core import KERNELS, segment_case


def columns_case(kernel, seed=0):
    """Rings (r, z, weight) with their pieces: column sizes 0, 1, 3, 40 (more than one block of 32), 7, 0."""
    rng = np.random.default_rng(seed)
    segment, lo, hi, panels, geometry, tensors = segment_case(kernel, 1.0, 0.3, n_segments=20, seed=seed)
    sizes = np.array([0, 1, 3, 40, 7, 0])
    pick = rng.integers(0, len(lo), sizes.sum())
    first = np.concatenate([[0], np.cumsum(sizes)])
    rings = np.column_stack([rng.uniform(0.0, 2.0, sizes.size), rng.uniform(-0.5, 0.8, sizes.size),
                             rng.uniform(0.2, 1.5, sizes.size)])
    rings[0, 0] = 0.0                                      # a ring on the axis
    return rings, first, segment[pick], lo[pick], hi[pick], panels[pick], geometry, tensors


def per_column(kernel, rings, first, segment, lo, hi, panels, geometry, tensors, gradient):
    """cg_ring_segment_sum column by column, flat."""
    width = 27 if gradient else 9
    out = np.zeros((len(rings), width))
    for c, (r, z, weight) in enumerate(rings):
        part = slice(first[c], first[c + 1])
        out[c] = np.ravel(_engine.ring_segment_sum(kernel, r, z, segment[part], lo[part], hi[part], panels[part],
                                                   geometry, tensors, weight, gradient=gradient))
    return out


CASES = [(name, gradient) for name in KERNELS for gradient in (False, True) if not (gradient and name == "heaviside")]


@pytest.mark.parametrize("name, gradient", CASES)
def test_ring_segment_columns_against_twin(name, gradient):
    kernel = KERNELS[name]
    case = columns_case(kernel)
    got = _engine.ring_segment_columns(kernel, *case, gradient=gradient)
    want = oracle_ring_segment_columns(kernel, *case, gradient=gradient)
    assert got.shape == (6, 27 if gradient else 9)
    size = np.abs(want).max()
    assert size > 0
    np.testing.assert_array_less(np.abs(got - want), 1e-12 * size)
    assert not got[0].any() and not got[-1].any()          # empty columns


@pytest.mark.parametrize("name, gradient", CASES)
@pytest.mark.parametrize("threads", [1, 2, 3])
def test_ring_segment_columns_has_the_bits_of_ring_segment_sum(name, gradient, threads):
    kernel = KERNELS[name]
    case = columns_case(kernel, seed=3)
    got = _engine.ring_segment_columns(kernel, *case, gradient=gradient, n_threads=threads)
    assert np.array_equal(got, per_column(kernel, *case, gradient))


def test_ring_segment_columns_over_dtypes_and_layouts():
    kernel = KERNELS["lucy"]
    rings, first, segment, lo, hi, panels, geometry, tensors = columns_case(kernel, seed=4)
    want = _engine.ring_segment_columns(kernel, rings, first, segment, lo, hi, panels, geometry, tensors)

    def strided(a):                                         # the same values, every other element of a bigger array
        big = np.zeros((2 * a.shape[0],) + a.shape[1:], a.dtype)
        big[::2] = a
        return big[::2]
    variants = [
        (np.asfortranarray(rings), first.astype(np.int32), segment.astype(np.int32), lo, hi, panels.astype(np.int16),
         np.asfortranarray(geometry), np.asfortranarray(tensors)),
        (strided(rings), strided(first), strided(segment), strided(lo), strided(hi), strided(panels),
         strided(geometry), strided(tensors)),
        (rings.tolist(), first.tolist(), segment.tolist(), lo.tolist(), hi.tolist(), panels.tolist(),
         geometry.tolist(), tensors.tolist()),
    ]
    for args in variants:
        assert np.array_equal(_engine.ring_segment_columns(kernel, *args), want)
    # float32 rings and tensors: the values converted to float64 first
    r32 = rings.astype(np.float32)
    t32 = tensors.astype(np.float32)
    got = _engine.ring_segment_columns(kernel, r32, first, segment, lo, hi, panels, geometry, t32)
    assert np.array_equal(got, _engine.ring_segment_columns(kernel, r32.astype(float), first, segment, lo, hi,
                                                            panels, geometry, t32.astype(float)))


def test_ring_segment_columns_with_no_columns():
    kernel = KERNELS["gauss5w"]
    _, _, _, _, _, _, geometry, tensors = columns_case(kernel)
    empty = np.zeros(0)
    got = _engine.ring_segment_columns(kernel, np.zeros((0, 3)), [0], np.zeros(0, int), empty, empty,
                                       np.zeros(0, int), geometry, tensors)
    assert got.shape == (0, 9)


def test_heaviside_has_no_column_gradient():
    kernel = KERNELS["heaviside"]
    with pytest.raises(NotImplementedError):
        _engine.ring_segment_columns(kernel, *columns_case(kernel), gradient=True)


def test_ring_segment_columns_refuses_bad_arguments():
    kernel = KERNELS["gauss5w"]
    rings, first, segment, lo, hi, panels, geometry, tensors = columns_case(kernel)
    with pytest.raises(ValueError, match="first: expected one entry per ring and one more"):
        _engine.ring_segment_columns(kernel, rings, first[:-1], segment, lo, hi, panels, geometry, tensors)
    with pytest.raises(ValueError, match="first: expected its last entry to be the number of pieces"):
        _engine.ring_segment_columns(kernel, rings, first - 0 + np.r_[0, 0, 0, 0, 0, 0, 1], segment, lo, hi, panels,
                                     geometry, tensors)
    with pytest.raises(ValueError, match="segment: expected one entry per piece"):
        _engine.ring_segment_columns(kernel, rings, first, segment[:-1], lo, hi, panels, geometry, tensors)
    with pytest.raises(ValueError, match="rings: expected length 3 along axis 1"):
        _engine.ring_segment_columns(kernel, rings[:, :2], first, segment, lo, hi, panels, geometry, tensors)
    for row, col, value, message in ((0, 0, -1.0, "expected finite rows .r, z, weight. with r >= 0"),
                                     (1, 1, np.nan, "rings: expected finite values"),
                                     (2, 2, np.inf, "rings: expected finite values")):
        r = rings.copy()
        r[row, col] = value
        with pytest.raises(ValueError, match=message):
            _engine.ring_segment_columns(kernel, r, first, segment, lo, hi, panels, geometry, tensors)
    decreasing = first.copy()
    decreasing[2], decreasing[3] = decreasing[3], decreasing[2]
    with pytest.raises(ValueError, match="nondecreasing first from 0"):
        _engine.ring_segment_columns(kernel, rings, decreasing, segment, lo, hi, panels, geometry, tensors)
    for name, value in (("segment", 99), ("lo", -0.5), ("hi", 1.5), ("panels", 0)):
        args = dict(segment=segment.copy(), lo=lo.copy(), hi=hi.copy(), panels=panels.copy())
        args[name][0] = value
        with pytest.raises(ValueError, match="rows of geometry"):
            _engine.ring_segment_columns(kernel, rings, first, args["segment"], args["lo"], args["hi"],
                                         args["panels"], geometry, tensors)


def test_ring_average_segments_does_not_depend_on_its_blocks(monkeypatch):
    """The (column, segment) pairs found in blocks of whole columns: tiny blocks and masks give the same bits."""
    from cgbound import cylindrical_ring
    rng = np.random.default_rng(2)
    box = cg.Box([-3, -3, 0], [3, 3, 5], periodic=[False, False, True])
    starts = np.c_[rng.uniform(-2.5, 2.5, (30, 2)), rng.uniform(0, 5, 30)]
    vectors, values = rng.normal(size=(30, 3)) * 0.6, rng.normal(size=(30, 3, 3))
    grid = cg.CylindricalGrid(box, axis_point=(0.1, -0.2, 0.0), axis="z", r=(0.0, 2.5, 4), z=(0.5, 4.5, 5))
    z_nodes = grid.z[:, None] + np.array([[-0.1, 0.0, 0.2]])
    z_weights = rng.uniform(0.1, 1.0, z_nodes.shape)
    for kernel in (cg.Lucy(1.1), cg.Gaussian(0.4)):
        for gradient in (False, True):
            want = cylindrical_ring.ring_average_segments(grid, kernel, starts, vectors, values, z_nodes, z_weights,
                                                          gradient=gradient)
            assert np.abs(want).max() > 0
            for pairs, mask in ((1, 1), (7, 40), (50, 130)):
                monkeypatch.setattr(cylindrical_ring, "PAIRS_PER_BLOCK", pairs)
                monkeypatch.setattr(cylindrical_ring, "CANDIDATES_PER_MASK", mask)
                got = cylindrical_ring.ring_average_segments(grid, kernel, starts, vectors, values, z_nodes,
                                                             z_weights, gradient=gradient)
                assert np.array_equal(got, want)
            monkeypatch.undo()
