"""Every `_core` entry point against its slow twin in tests/oracle.py, swept in the manner of bottleneck's
test suite: kernels x dimensions x averaged axes (and point targets) x periodicity, then dtypes and memory
layouts of every array argument, and zero-length inputs.

The values are compared to the twin relative to the field's scale (RTOL); where the computation is the same
(a layout or dtype that converts to the same float64 numbers, minimum_image) the results must be identical.
The binding accepts what NumPy casts safely to float64 (bool, integers, float16/32/64; lists) and refuses
the rest (object, complex, strings, long double) with a TypeError naming the argument; the Python layer in
front of it (cgbound._validate.real_array) is stricter still and hands the core float64 C arrays only.
"""
import itertools
import re
import zlib

import numpy as np
import pytest

from cgbound import _core
from helpers import assert_fields_close
from oracle import (OracleKernel, oracle_minimum_image, oracle_scatter_fluctuation, oracle_scatter_points,
                    oracle_scatter_segments)

RTOL = 1e-12
LOWER = {2: np.array([-0.3, 0.2]), 3: np.array([-0.3, 0.2, -1.0])}
LENGTHS = {2: np.array([3.0, 3.5]), 3: np.array([3.0, 2.5, 3.5])}
NODES = {2: (4, 3), 3: (3, 2, 3)}          # grid nodes along each data axis when resolved
GAUSSIAN, LUCY, HEAVISIDE = 0, 1, 2

# name: (core type, width, cutoff radius, truncated normalisation, line_points, per_node)
KERNELS = {
    "gaussian": (GAUSSIAN, 0.45, 1.35, 0, 0, 0),
    "gaussian-truncated": (GAUSSIAN, 0.5, 1.2, 1, 0, 0),
    "gaussian-3point": (GAUSSIAN, 0.45, 1.35, 0, 3, 0),
    "gaussian-per-node": (GAUSSIAN, 0.45, 1.35, 1, 0, 1),   # the per-node path instead of the separable one
    "gaussian-wide": (GAUSSIAN, 1.0, 3.0, 0, 0, 0),         # cutoff wider than half of every box length
    "lucy": (LUCY, 1.1, 1.1, 0, 0, 0),
    "lucy-wide": (LUCY, 2.2, 2.2, 0, 0, 0),
    "heaviside": (HEAVISIDE, 0.9, 0.9, 0, 0, 0),
}
ORACLE_KIND = {GAUSSIAN: "gaussian", LUCY: "lucy", HEAVISIDE: "heaviside"}
PERIODICITY = ("none", "some", "all")


def periodic_flags(dim, which):
    return {"none": [False] * dim, "some": [True] + [False] * (dim - 1), "all": [True] * dim}[which]


def layouts(dim):
    """Every subset of averaged axes on a grid, and a point target (all axes resolved)."""
    return [("grid", avg) for k in range(dim + 1) for avg in itertools.combinations(range(dim), k)] + \
           [("points", ())]


def make_target(dim, layout, periodic, seed=0):
    """The core's target tuple and the oracle's (nodes, resolved, periodic, periods, avg_extent)."""
    kind, averaged = layout
    lower, lengths = LOWER[dim], LENGTHS[dim]
    resolved = [d for d in range(dim) if d not in averaged]
    flags = [periodic[d] for d in resolved]
    periods = [float(lengths[d]) for d in resolved]
    if kind == "grid":
        coords = [lower[d] + (np.arange(NODES[dim][d]) + 0.5) * lengths[d] / NODES[dim][d] for d in resolved]
        nodes = (np.stack([m.ravel() for m in np.meshgrid(*coords, indexing="ij")], axis=1) if resolved
                 else np.zeros((1, 0)))
        core = (dim, tuple(resolved), coords, None, flags, periods)
    else:
        nodes = lower + np.random.default_rng(seed).uniform(0, 1, (6, dim)) * lengths
        core = (dim, tuple(resolved), None, nodes, flags, periods)
    avg_extent = float(np.prod([lengths[d] for d in averaged])) if averaged else 1.0
    return core, (nodes, resolved, flags, periods, avg_extent)


def make_kernel(name, dim, avg_extent):
    ktype, width, radius, truncated, line_points, per_node = KERNELS[name]
    core = (ktype, width, radius, truncated, avg_extent, line_points, per_node)
    return core, OracleKernel(ORACLE_KIND[ktype], dim, width, radius, truncated=bool(truncated),
                              line_points=line_points)


def objects(dim, n, seed, periodic):
    """n positions in and around the box (unwrapped by whole periods along periodic axes), vectors, values."""
    rng = np.random.default_rng(seed)
    lower, lengths = LOWER[dim], LENGTHS[dim]
    x = lower + rng.uniform(-0.1, 1.1, (n, dim)) * lengths
    for d in range(dim):
        if periodic[d]:
            x[:, d] += lengths[d] * rng.integers(-2, 3, n)
    vectors = rng.normal(scale=0.8, size=(n, dim))
    values = rng.normal(size=(n, 2))
    return x, vectors, values


def cases(dims=(2, 3)):
    """(dim, layout, periodicity) with every layout of each dimension under each periodicity."""
    return [(dim, layout, p) for dim in dims for layout in layouts(dim) for p in PERIODICITY]


def case_id(case):
    dim, (kind, averaged), p = case
    return f"{dim}d-{kind}" + (f"-avg{''.join(map(str, averaged))}" if averaged else "") + f"-periodic_{p}"


def seed_of(*parts):
    """A seed that is the same in every run (str hashes are salted per process)."""
    return zlib.crc32(repr(parts).encode())


def supports_gradient(ktype, dim, n_resolved, segments=False):
    """Over averaged axes: the Gaussian's gradients, and Lucy's for points (csrc/cg_gradient.c)."""
    return ktype == GAUSSIAN or n_resolved == dim or (ktype == LUCY and not segments)


# ----------------------------------------------------------------------
# values against the twins


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("case", cases(), ids=case_id)
def test_scatter_points_matches_oracle(case, kernel):
    dim, layout, which = case
    periodic = periodic_flags(dim, which)
    target, tgt = make_target(dim, layout, periodic, seed_of(case))
    core_kernel, ref_kernel = make_kernel(kernel, dim, tgt[4])
    x, _, values = objects(dim, 5, seed_of(case, kernel), periodic)
    out = _core.scatter_points(target, core_kernel, x, values)
    assert_fields_close(out, oracle_scatter_points(ref_kernel, tgt, x, values), RTOL, "scatter_points")


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("case", cases(), ids=case_id)
def test_scatter_points_gradient_matches_oracle(case, kernel):
    dim, layout, which = case
    periodic = periodic_flags(dim, which)
    target, tgt = make_target(dim, layout, periodic, seed_of(case))
    core_kernel, ref_kernel = make_kernel(kernel, dim, tgt[4])
    x, _, values = objects(dim, 4, seed_of(case, kernel), periodic)
    if not supports_gradient(core_kernel[0], dim, len(tgt[1])):
        with pytest.raises(NotImplementedError):
            _core.scatter_points(target, core_kernel, x, values, gradient=True)
        return
    out = _core.scatter_points(target, core_kernel, x, values, gradient=True)
    ref = oracle_scatter_points(ref_kernel, tgt, x, values, gradient=True)
    assert_fields_close(out, ref, RTOL, "scatter_points gradient")


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("case", cases(), ids=case_id)
def test_scatter_fluctuation_matches_oracle(case, kernel):
    dim, layout, which = case
    periodic = periodic_flags(dim, which)
    target, tgt = make_target(dim, layout, periodic, seed_of(case))
    core_kernel, ref_kernel = make_kernel(kernel, dim, tgt[4])
    x, velocities, values = objects(dim, 4, seed_of(case, kernel), periodic)
    masses = 1.0 + np.abs(values[:, 0])
    node_velocity = np.random.default_rng(seed_of(kernel, case)).normal(size=(tgt[0].shape[0], dim))
    out = _core.scatter_fluctuation(target, core_kernel, x, masses, velocities, node_velocity)
    ref = oracle_scatter_fluctuation(ref_kernel, tgt, x, masses, velocities, node_velocity)
    assert_fields_close(out, ref, RTOL, "scatter_fluctuation")


# Segments: the twin's line integrals are slow, so every layout meets every kernel under one periodicity
# (rotating through none/some/all with the kernel), and two objects per case.
SEGMENT_CASES = [(dim, layout, PERIODICITY[(i + j) % 3], kernel)
                 for dim in (2, 3) for i, layout in enumerate(layouts(dim)) for j, kernel in enumerate(sorted(KERNELS))]


def segment_id(case):
    return case_id(case[:3]) + "-" + case[3]


def diverges(periodic, resolved):
    """A ray (with a component along every axis) stays in the target iff no resolved axis bounds it."""
    return all(periodic[d] for d in resolved)


def steer_rays(vectors, periodic, resolved):
    """Rays leave the target at a fair angle: at least 0.5 of a unit along every bounding axis. (A ray
    grazing a periodic axis is cut to one segment many periods long; see test_grazing_ray_keeps_precision.)"""
    for d in resolved:
        if not periodic[d]:
            vectors[:, d] += np.where(vectors[:, d] < 0, -0.5, 0.5)


@pytest.mark.parametrize("ray", [False, True], ids=["segment", "ray"])
@pytest.mark.parametrize("case", SEGMENT_CASES, ids=segment_id)
def test_scatter_segments_matches_oracle(case, ray):
    dim, layout, which, kernel = case
    periodic = periodic_flags(dim, which)
    target, tgt = make_target(dim, layout, periodic, seed_of(case))
    core_kernel, ref_kernel = make_kernel(kernel, dim, tgt[4])
    starts, vectors, values = objects(dim, 2, seed_of(case, ray), periodic)
    if ray and diverges(periodic, tgt[1]):
        with pytest.raises(ValueError):
            _core.scatter_segments(target, core_kernel, starts, vectors, values, ray=True)
        return
    if ray:
        steer_rays(vectors, periodic, tgt[1])
    else:
        vectors[0] = 0.0   # a segment of zero length is a point
    out = _core.scatter_segments(target, core_kernel, starts, vectors, values, ray=ray)
    ref = oracle_scatter_segments(ref_kernel, tgt, starts, vectors, values, ray=ray)
    assert_fields_close(out, ref, RTOL, "scatter_segments")


# gradients of line integrals: the slowest twin, so one object and a third of the segment cases
@pytest.mark.parametrize("ray", [False, True], ids=["segment", "ray"])
@pytest.mark.parametrize("case", SEGMENT_CASES[::3], ids=segment_id)
def test_scatter_segments_gradient_matches_oracle(case, ray):
    dim, layout, which, kernel = case
    periodic = periodic_flags(dim, which)
    target, tgt = make_target(dim, layout, periodic, seed_of(case))
    core_kernel, ref_kernel = make_kernel(kernel, dim, tgt[4])
    starts, vectors, values = objects(dim, 1, seed_of(case, ray, "gradient"), periodic)
    if ray:
        steer_rays(vectors, periodic, tgt[1])
    call = lambda: _core.scatter_segments(target, core_kernel, starts, vectors, values, ray=ray, gradient=True)
    if not supports_gradient(core_kernel[0], dim, len(tgt[1]), segments=True):
        with pytest.raises(NotImplementedError):
            call()
        return
    if ray and diverges(periodic, tgt[1]):
        with pytest.raises(ValueError):
            call()
        return
    ref = oracle_scatter_segments(ref_kernel, tgt, starts, vectors, values, ray=ray, gradient=True)
    assert_fields_close(call(), ref, RTOL, "scatter_segments gradient")


@pytest.mark.xfail(strict=True, reason="the core cuts a ray to one segment of length s_max |e| and integrates each "
                                     "periodic image of it from its far start: a ray at 0.8 degrees to a periodic "
                                     "axis (about 90 periods long) loses about 1e-11 of the field's scale")
def test_grazing_ray_keeps_precision():
    case = (2, ("points", ()), "some")
    periodic = periodic_flags(2, "some")
    target, tgt = make_target(2, ("points", ()), periodic, seed_of(case))
    core_kernel, ref_kernel = make_kernel("lucy", 2, 1.0)
    starts = np.array([[0.4, 1.1]])
    vectors = np.array([[0.71308109, 0.00965372]])
    values = np.array([[1.0, -0.5]])
    out = _core.scatter_segments(target, core_kernel, starts, vectors, values, ray=True)
    ref = oracle_scatter_segments(ref_kernel, tgt, starts, vectors, values, ray=True)
    assert_fields_close(out, ref, RTOL, "grazing ray")


@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("which", PERIODICITY)
def test_minimum_image_matches_oracle(dim, which):
    rng = np.random.default_rng(dim * 7 + len(which))
    period = rng.uniform(0.5, 3.0, dim)
    vectors = rng.uniform(-3, 3, (40, dim)) * period
    vectors[:3] = 0.5 * period          # exactly half a period stays (ties round to even in both)
    vectors[3:6] = -1.5 * period
    periodic = ([False] * dim) if which == "none" else ([True] + [False] * (dim - 1)) if which == "some" else [True] * dim
    out = _core.minimum_image(vectors, periodic, period)
    assert np.array_equal(out, oracle_minimum_image(vectors, periodic, period))


# ----------------------------------------------------------------------
# dtypes and memory layouts of every array argument: the same numbers give the same bits


def _unaligned(a):
    buf = np.zeros(a.nbytes + 1, np.uint8)
    out = np.ndarray(a.shape, dtype=a.dtype, buffer=buf, offset=1)
    out[...] = a
    assert not out.flags.aligned
    return out


def _strided(a):
    big = np.zeros(tuple(2 * s + 1 for s in a.shape))
    view = big[tuple(slice(1, None, 2) for _ in a.shape)]
    view[...] = a
    return view


def _negative(a):
    flipped = np.ascontiguousarray(a[(slice(None, None, -1),) * a.ndim])
    return flipped[(slice(None, None, -1),) * a.ndim]


def _readonly(a):
    out = a.copy()
    out.setflags(write=False)
    return out


VARIANTS = {
    "fortran": np.asfortranarray,
    "strided": _strided,
    "negative-strides": _negative,
    "unaligned": _unaligned,
    "read-only": _readonly,
    "list": lambda a: a.tolist(),
    "float32": lambda a: a.astype(np.float32),
    "float16": lambda a: a.astype(np.float16),
    "int64": lambda a: np.round(4 * a).astype(np.int64),
    "int32-fortran": lambda a: np.asfortranarray(np.round(4 * a).astype(np.int32)),
    "uint8": lambda a: np.abs(np.round(4 * a)).astype(np.uint8),
    "bool": lambda a: a > 0,
}
REFUSED = {
    "object": lambda a: a.astype(object),
    "complex": lambda a: a.astype(complex),
    "str": lambda a: a.astype(str),
    "longdouble": lambda a: a.astype(np.longdouble),
}


def _entry_calls(dim=3):
    """name -> (function of the keyword arguments, the float64 keyword arguments of one call)."""
    periodic = [True, True, False]
    grid, tgt = make_target(dim, ("grid", (1,)), periodic)
    points, ptgt = make_target(dim, ("points", ()), periodic)
    kernel, _ = make_kernel("lucy", dim, tgt[4])
    full_kernel, _ = make_kernel("lucy", dim, 1.0)
    gauss, _ = make_kernel("gaussian", dim, tgt[4])
    x, vectors, values = objects(dim, 5, 99, periodic)
    vectors[:, 2] -= 1.0    # rays leave through the non-periodic axis
    masses = 1.0 + np.abs(values[:, 0])
    node_velocity = np.random.default_rng(5).normal(size=(tgt[0].shape[0], dim))

    def with_grid(f):
        axes, coords, flags, periods = grid[1], grid[2], grid[4], grid[5]
        return lambda coords0=coords[0], coords1=coords[1], **kw: f((dim, axes, [coords0, coords1], None, flags,
                                                                       periods), **kw)

    def with_points(f):
        axes, nodes, flags, periods = points[1], points[3], points[4], points[5]
        return lambda points=nodes, **kw: f((dim, axes, None, points, flags, periods), **kw)

    return {
        "scatter_points": (with_grid(lambda t, **kw: _core.scatter_points(t, gauss, **kw)),
                           dict(positions=x, values=values, coords0=grid[2][0], coords1=grid[2][1])),
        "scatter_points-on-points": (with_points(lambda t, **kw: _core.scatter_points(t, full_kernel, **kw)),
                                     dict(positions=x, values=values, points=points[3])),
        "scatter_points-gradient": (with_points(lambda t, **kw: _core.scatter_points(t, full_kernel, gradient=True,
                                                                                     **kw)),
                                    dict(positions=x, values=values, points=points[3])),
        "scatter_segments": (with_grid(lambda t, **kw: _core.scatter_segments(t, kernel, **kw)),
                             dict(starts=x, vectors=vectors, values=values)),
        "scatter_segments-ray": (with_grid(lambda t, **kw: _core.scatter_segments(t, gauss, ray=True, **kw)),
                                 dict(starts=x, vectors=vectors, values=values)),
        "scatter_segments-gradient": (with_points(lambda t, **kw: _core.scatter_segments(t, full_kernel,
                                                                                         gradient=True, **kw)),
                                      dict(starts=x, vectors=vectors, values=values)),
        "scatter_fluctuation": (with_grid(lambda t, **kw: _core.scatter_fluctuation(t, kernel, **kw)),
                                dict(positions=x, masses=masses, velocities=vectors, node_velocity=node_velocity)),
        "minimum_image": (lambda **kw: _core.minimum_image(kw["vectors"], periodic, LENGTHS[dim]),
                          dict(vectors=3 * vectors)),
    }


ENTRY_ARGUMENTS = [(entry, arg) for entry, (_, kwargs) in _entry_calls().items() for arg in kwargs]


@pytest.mark.parametrize("entry,argument", ENTRY_ARGUMENTS, ids=[f"{e}-{a}" for e, a in ENTRY_ARGUMENTS])
def test_layouts_and_dtypes_give_identical_results(entry, argument):
    call, kwargs = _entry_calls()[entry]
    for name, make in VARIANTS.items():
        variant = make(kwargs[argument])
        as_float64 = np.array(variant, dtype=np.float64, order="C")
        before = np.array(variant, copy=True)
        try:
            expected = call(**{**kwargs, argument: as_float64})
        except ValueError as exc:   # e.g. bool vectors give rays along periodic axes only: the same refusal
            with pytest.raises(ValueError, match=f"^{re.escape(str(exc))}$"):
                call(**{**kwargs, argument: variant})
            continue
        got = call(**{**kwargs, argument: variant})
        assert got.dtype == np.float64 and got.flags.c_contiguous, name
        assert np.array_equal(got, expected), f"{entry}: {argument} as {name} changed the result"
        assert np.array_equal(np.asarray(variant), before), f"{entry}: {argument} as {name} was written to"
        if name in ("fortran", "strided", "negative-strides", "unaligned", "read-only", "list"):
            assert np.array_equal(as_float64, kwargs[argument]), name   # the same numbers: the same result
    for name, make in REFUSED.items():
        with pytest.raises(TypeError, match=r"^(vectors|starts|positions|values|masses|velocities|node_velocity|"
                                            r"grid coordinates|points): expected an array of real numbers"):
            call(**{**kwargs, argument: make(kwargs[argument])})


def test_minimum_image_returns_a_new_array():
    vectors = np.array([[2.5, 0.1], [-2.5, 0.2]])
    out = _core.minimum_image(vectors, [True, False], [3.0, 1.0])
    assert out is not vectors and not np.shares_memory(out, vectors)
    assert np.array_equal(vectors, [[2.5, 0.1], [-2.5, 0.2]])


@pytest.mark.parametrize("entry", sorted(_entry_calls()))
def test_zero_objects_give_zeros(entry):
    call, kwargs = _entry_calls()[entry]
    empty = {k: (v[:0] if k not in ("node_velocity", "coords0", "coords1", "points") else v)
             for k, v in kwargs.items()}
    full = call(**kwargs)
    out = call(**empty)
    if entry == "minimum_image":
        assert out.shape == (0, 3)
        return
    assert out.shape == full.shape and not np.any(out)


@pytest.mark.parametrize("entry", [e for e in sorted(_entry_calls()) if "on-points" in e or e.endswith("gradient")])
def test_zero_nodes_give_empty_results(entry):
    call, kwargs = _entry_calls()[entry]
    out = call(**{**kwargs, "points": np.zeros((0, 3))})
    assert out.shape[0] == 0 and out.shape[1:] == call(**kwargs).shape[1:]
