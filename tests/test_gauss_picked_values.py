"""The separable Gaussian adds only an object's values whose coefficient is not +-0 where there are at most 3 of
them and at most half (cg_separable.c's pick_values: a contact's stress along a grid axis has 1 value of 9), and
nothing for an object whose values are all +-0. That must change no output bit: a skipped term is w * (+-0) = +-0 and the outputs,
which start at +0, never hold -0.

Bit for bit (the doubles' bits: -0 and +0 differ) against the plain update of every value, which the same objects
take when 9 more columns of ones follow their values (then more than 3 are non-zero): the first 9 output columns
are the same products summed in the same order. For exact line integrals (the rule's rows and the closed form's
cut nodes), 3- and 1-point rules (rows_of_rule, rows_of_one_point) and points; on both vector builds and 1 and 2
threads (a grid long along its first axis: slabs, the same order of the terms per node whatever the thread
count); and against the node-by-node path at 1e-12.
"""
import numpy as np
import pytest

import cgbound as cg
from cgbound import _core, _engine
from helpers import narrow_build
from test_hard_cases import rel_error

BOX = cg.Box([0.0, 0.0, 0.0], [32.0, 6.0, 6.0])
SHAPE = (64, 12, 12)   # slabs along x for 2 threads (cg_scatter.c's plan_slabs: 64 nodes >= 6 slabs of 7)


def bits(a):
    return np.ascontiguousarray(a).view(np.uint64)


def scene(seed=0, n=1000):
    """Segments along the axes, in grid planes, in general directions and of zero length, with contact-like
    values (force (x) branch, 0.0 + products as the core forms them) of every kind: central along an axis (1
    non-zero), central in general directions (9, symmetric in value), 2 and 3 non-zero, in a plane (4), zero
    forces (none), -0.0 entries, general (9)."""
    rng = np.random.default_rng(seed)
    starts = rng.uniform([2.0, 1.5, 1.5], [30.0, 4.5, 4.5], size=(n, 3))
    kind = np.arange(n) % 5
    vec = rng.normal(size=(n, 3))
    vec /= np.linalg.norm(vec, axis=1)[:, None]
    vec[kind == 0] *= np.eye(3)[rng.integers(0, 3, size=(kind == 0).sum())]   # along an axis
    vec[kind == 1, rng.integers(0, 3)] = 0.0                                   # in a grid plane
    vec[kind == 2] = 0.0                                                       # zero length
    vec *= rng.uniform(0.2, 0.6, size=(n, 1))
    vec[kind == 2] = 0.0
    values = np.zeros((n, 9))
    for c in range(n):
        pattern = c % 8
        b = vec[c] if np.any(vec[c]) else rng.normal(size=3)
        if pattern == 0:      # central along an axis: 1 value
            a = rng.integers(0, 3)
            values[c, 4 * a] = rng.normal()
        elif pattern == 1:    # central: the force along the branch
            values[c] = 0.0 + np.outer(rng.normal() * b, b).ravel()
        elif pattern in (2, 3):   # 2 or 3 non-zero, anywhere
            at = rng.choice(9, size=pattern, replace=False)
            values[c, at] = rng.normal(size=pattern)
        elif pattern == 4:    # in the xy plane: 4 values
            f, g = rng.normal(size=3), rng.normal(size=3)
            f[2] = g[2] = 0.0
            values[c] = 0.0 + np.outer(f, g).ravel()
        elif pattern == 5:    # no force
            pass
        elif pattern == 6:    # -0.0 entries next to 1 non-zero
            values[c] = -0.0
            values[c, rng.integers(0, 9)] = rng.normal()
        else:                 # general
            values[c] = rng.normal(size=9)
    return starts, vec, values


def run(kind, quadrature, starts, vec, values, n_threads, per_node=False):
    kernel = cg.Gaussian(0.5, cutoff=3.0, line_quadrature=quadrature)
    kernel._per_node = per_node
    grid = cg.Grid(BOX, SHAPE)
    target = _engine.core_target(grid, BOX)
    core = _engine.core_kernel(kernel, 1.0, float(np.linalg.norm(vec, axis=1).max()))
    if kind == "points":
        return _core.scatter_points(target, core, starts, values, n_threads=n_threads)
    return _core.scatter_segments(target, core, starts, vec, values, n_threads=n_threads)


@pytest.mark.parametrize("kind, quadrature", [("segments", "exact"), ("segments", 3), ("segments", 1),
                                              ("points", "exact")])
def test_picked_values_equal_the_plain_update_bit_for_bit(kind, quadrature):
    starts, vec, values = scene(1)
    padded = np.concatenate([values, np.ones_like(values)], axis=1)
    results = []
    for build in ("default", "narrow"):
        for n_threads in (1, 2):
            def both():
                return (run(kind, quadrature, starts, vec, values, n_threads),
                        run(kind, quadrature, starts, vec, padded, n_threads)[:, :9])
            picked, plain = both() if build == "default" else narrow_build(both)
            assert np.count_nonzero(picked) > 0
            assert np.array_equal(bits(picked), bits(plain)), (build, n_threads)
            assert not np.any(np.signbit(picked) & (picked == 0.0)), "an output of -0"
            results.append(picked)
    for other in results[1:]:   # builds and thread counts
        assert np.array_equal(bits(results[0]), bits(other))


def test_picked_values_against_node_by_node():
    starts, vec, values = scene(2, n=200)
    fast = run("segments", "exact", starts, vec, values, 1)
    slow = run("segments", "exact", starts, vec, values, 1, per_node=True)
    assert np.count_nonzero(slow) > 0
    assert rel_error(fast, slow) <= 1e-12


def test_a_lattice_of_axis_contacts_equals_the_plain_update():
    """W1's kind of input through coarse_grain's contact stress (values formed in the core as force (x) branch):
    every contact has 1 non-zero value. Against the same contacts with the plain update (a tiny off-axis force
    component on one contact would change the numbers; instead the plain update's columns via scatter_segments)."""
    n = 8
    h = 32.0 / 64
    idx = np.stack(np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij"), -1).reshape(-1, 3)
    pos = np.array([6.0, 1.25, 1.25]) + 0.5 * idx + 0.013 * np.random.default_rng(3).normal(size=idx.shape) * h
    flat = lambda i: (i[:, 0] * n + i[:, 1]) * n + i[:, 2]
    pairs = []
    for a in range(3):
        ok = idx[:, a] < n - 1
        step = np.zeros(3, int)
        step[a] = 1
        pairs.append(np.stack([flat(idx[ok]), flat(idx[ok] + step)], 1))
    i, j = np.concatenate(pairs).T
    branch = pos[j] - pos[i]
    axis = np.argmax(np.abs(branch), axis=1)
    force = np.zeros_like(branch)
    force[np.arange(len(i)), axis] = np.random.default_rng(4).normal(size=len(i))   # central along the axis
    vec = np.zeros_like(branch)
    vec[np.arange(len(i)), axis] = branch[np.arange(len(i)), axis]
    values = 0.0 + np.einsum("ni,nj->nij", force, vec).reshape(-1, 9)
    assert np.all(np.count_nonzero(values, axis=1) == 1)
    starts = pos[i]
    padded = np.concatenate([values, np.ones_like(values)], axis=1)
    for build in (lambda f: f(), narrow_build):
        picked = build(lambda: run("segments", "exact", starts, vec, values, 2))
        plain = build(lambda: run("segments", "exact", starts, vec, padded, 2))[:, :9]
        assert np.count_nonzero(picked) > 0
        assert np.array_equal(bits(picked), bits(plain))
    # the core's own outer product (cg_scatter_segments_outer), as coarse_grain's contact stress forms it
    kernel = cg.Gaussian(0.5, cutoff=3.0)
    target = _engine.core_target(cg.Grid(BOX, SHAPE), BOX)
    core = _engine.core_kernel(kernel, 1.0, float(np.linalg.norm(vec, axis=1).max()))
    outer = _core.scatter_segments_outer(target, core, starts, vec, force, n_threads=1)
    assert np.array_equal(bits(outer), bits(run("segments", "exact", starts, vec, padded, 1)[:, :9]))
