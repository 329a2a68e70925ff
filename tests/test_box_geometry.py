"""Box.minimum_image and Box.wrap (C core: cg_minimum_image, cg_wrap) against slow NumPy twins."""
import numpy as np
import pytest

import cgbound as cg


def oracle_wrap(positions, periodic, lower, upper):
    """Twin of cg_wrap, one coordinate at a time: inside coordinates unchanged, others
    lower + np.mod(x - lower, L), and lower where that rounds up to upper."""
    out = np.array(positions, dtype=float)
    for a in range(out.shape[1]):
        if not periodic[a]:
            continue
        lo, hi = float(lower[a]), float(upper[a])
        L = hi - lo
        for k in range(out.shape[0]):
            x = out[k, a]
            if lo <= x < hi:
                continue
            w = lo + float(np.mod(x - lo, L))
            out[k, a] = lo if w >= hi else w
    return out


def oracle_minimum_image(vectors, periodic, lengths):
    """Twin of cg_minimum_image: v - L round(v / L) where |v| > L/2."""
    out = np.array(vectors, dtype=float)
    for a in range(out.shape[1]):
        if periodic[a]:
            L = float(lengths[a])
            for k in range(out.shape[0]):
                v = out[k, a]
                if abs(v) > 0.5 * L:
                    out[k, a] = v - L * np.round(v / L)
    return out


def same_bits(a, b):
    return a.shape == b.shape and np.array_equal(a.view(np.int64), np.asarray(b, float).view(np.int64))


BOXES = [cg.Box([0.0, 0.0, 0.0], [6.0, 6.0, 10.0], periodic=(True, True, False)),
         cg.Box([-0.5, 1.25, -3.0], [0.7, 2.0, 4.1], periodic=True),
         cg.Box([-1e-3, 0.1], [2e-3, 0.30000000000000004], periodic=(False, True)),
         cg.Box([0.0, 0.0], [1.0, 1.0], periodic=False)]


def edge_points(box):
    """Coordinates exactly on the edges, next to them, tiny negatives, and whole box lengths away."""
    lo, hi, L = box.lower, box.upper, box.lengths
    rows = [lo, hi, np.nextafter(lo, -np.inf), np.nextafter(hi, -np.inf), np.nextafter(hi, np.inf),
            lo - 1e-17, lo - 1e-300, lo - 5e-324, -np.zeros(box.dim), lo + L * 1e-16, hi + L, lo - L, lo - 3 * L,
            hi + 7 * L, lo + 0.5 * L, lo - 0.5 * L, lo - 1e-15 * L]
    return np.array(rows)


@pytest.mark.parametrize("box", BOXES, ids=range(len(BOXES)))
def test_wrap_matches_twin_bit_for_bit(box):
    rng = np.random.default_rng(7)
    x = box.lower + box.lengths * rng.uniform(-3.0, 4.0, (500, box.dim))
    x = np.concatenate([x, edge_points(box)])
    got = box.wrap(x)
    assert same_bits(got, oracle_wrap(x, box.periodic, box.lower, box.upper))
    per = np.array(box.periodic)
    assert np.all((got[:, per] >= box.lower[per]) & (got[:, per] < box.upper[per]))
    assert same_bits(got[:, ~per], x[:, ~per])
    assert same_bits(box.wrap(got), got)                     # wrapping twice changes nothing
    assert got.flags.writeable and not np.shares_memory(got, x)


def test_wrap_keeps_inside_points_and_fixes_mod_rounding_to_L():
    box = cg.Box([0.0, 0.0, 0.0], [6.0, 6.0, 10.0], periodic=(True, True, False))
    x = np.array([[-1e-17, 5.999999999999999, 3.0], [6.0, 0.0, -4.0]])
    got = box.wrap(x)
    # np.mod(-1e-17, 6) is 6.0: the point belongs at lower
    assert np.mod(-1e-17, 6.0) == 6.0
    np.testing.assert_array_equal(got, [[0.0, 5.999999999999999, 3.0], [0.0, 0.0, -4.0]])


@pytest.mark.parametrize("box", BOXES, ids=range(len(BOXES)))
def test_minimum_image_matches_twin_bit_for_bit(box):
    rng = np.random.default_rng(11)
    L = box.lengths
    v = L * rng.uniform(-4.0, 4.0, (500, box.dim))
    ties = np.array([0.5 * L, -0.5 * L, 1.5 * L, -2.5 * L, np.nextafter(0.5 * L, np.inf), np.zeros(box.dim)])
    v = np.concatenate([v, ties, edge_points(box)])
    got = box.minimum_image(v)
    assert same_bits(got, oracle_minimum_image(v, box.periodic, L))
    per = np.array(box.periodic)
    # within half a period, up to the round-off of v - L round(v / L) (an ulp of |v|)
    slack = 4 * np.finfo(float).eps * np.max(np.abs(v), axis=0)
    assert np.all(np.abs(got[:, per]) <= 0.5 * L[per] + slack[per])
    assert same_bits(got[:, ~per], v[:, ~per])


def test_empty_and_bad_input():
    box = BOXES[0]
    assert box.wrap(np.zeros((0, 3))).shape == (0, 3)
    assert box.minimum_image(np.zeros((0, 3))).shape == (0, 3)
    with pytest.raises(ValueError, match="positions: expected shape"):
        box.wrap(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="vectors: expected a 2-dimensional array"):
        box.minimum_image(np.zeros(3))
    with pytest.raises(ValueError, match="positions: expected finite values, got nan at index \\(1, 2\\)"):
        box.wrap([[0.0, 0.0, 0.0], [1.0, 1.0, np.nan]])
    with pytest.raises(TypeError, match="vectors: expected real numbers"):
        box.minimum_image([["a", "b", "c"]])
    # x - lower overflows: an error, not a silent NaN
    wide = cg.Box([-1e308, 0.0], [1e307, 1.0], periodic=True)
    with pytest.raises(ValueError, match="wrap: invalid argument"):
        wide.wrap([[1.7e308, 0.5]])
