"""No reference or memory leaks in the binding (csrc/_coremodule.c).

Every entry point, and every error path, is called 10,000 times with tiny
inputs; the process's resident memory must not grow by more than 2 MB after a
warm-up, and the reference counts of the arrays passed in must not change. A
leaked output or converted array per call would cost several MB here.
"""
import gc
import os
import sys

import numpy as np
import pytest

import cgbound as cg
from cgbound import _core

N_CALLS = 10_000
WARMUP = 500
MAX_GROWTH = 2 * 1024 * 1024  # bytes
# AddressSanitizer (tools/sanitize.sh) keeps freed memory in quarantine, so RSS
# grows by design there; the reference-count checks still apply
UNDER_ASAN = "libasan" in os.environ.get("LD_PRELOAD", "")

pytestmark = pytest.mark.skipif(not os.path.exists("/proc/self/statm"), reason="needs /proc/self/statm (Linux)")


def rss():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def assert_no_growth(call, *watched, n=N_CALLS):
    """Run call() n times after a warm-up; RSS and the refcounts of `watched` must not grow."""
    for _ in range(WARMUP):
        call()
    gc.collect()
    refs = [sys.getrefcount(obj) for obj in watched]
    before = rss()
    for _ in range(n):
        call()
    gc.collect()
    growth = rss() - before
    assert [sys.getrefcount(obj) for obj in watched] == refs, "reference count of an input changed"
    if not UNDER_ASAN:
        assert growth <= MAX_GROWTH, f"RSS grew by {growth / 1e6:.1f} MB over {n} calls"


def raises(exc, fn, *args, **kwargs):
    def call():
        try:
            fn(*args, **kwargs)
        except exc:
            return
        raise AssertionError(f"{fn.__name__} did not raise {exc.__name__}")
    return call


# tiny inputs: a 4 x 4 x 4 grid, 5 objects, 3 value columns
COORD = np.linspace(0.125, 0.875, 4)
PERIOD = [1.0, 1.0, 1.0]
GRID = (3, (0, 1, 2), [COORD, COORD, COORD], None, [True, False, True], PERIOD)
POINTS = np.array([[0.5, 0.5, 0.5], [0.1, 0.9, 0.2], [0.3, 0.3, 0.9]])
POINT_TARGET = (3, (0, 1, 2), None, POINTS, [False, False, False], PERIOD)
AVERAGED = (3, (2,), [COORD], None, [False], [1.0])
GAUSS = (0, 0.2, 0.6, 0, 1.0)
LUCY = (1, 0.4, 0.4, 0, 1.0)
LUCY_AVG = (1, 0.4, 0.4, 0, 1.0)
RNG = np.random.default_rng(1)
POS = RNG.uniform(0, 1, (5, 3))
VEC = RNG.normal(scale=0.2, size=(5, 3))
VAL = RNG.normal(size=(5, 3))
MASS = RNG.uniform(0.5, 1.5, 5)
VEL = RNG.normal(size=(5, 3))
NODE_V = RNG.normal(size=(64, 3))
DOWN = np.tile([0.1, -1.0, 0.2], (5, 1))  # leaves through the walls of y
ALONG = np.tile([1.0, 0.0, 0.0], (5, 1))  # along periodic x only: a divergent ray
POS_NAN = POS.copy()
POS_NAN[2, 1] = np.nan
VAL_INF = VAL.copy()
VAL_INF[0, 0] = np.inf
COORD_NAN = COORD.copy()
COORD_NAN[1] = np.nan
WATCHED = (COORD, POINTS, POS, VEC, VAL, MASS, VEL, NODE_V, DOWN, ALONG)


class FailingSequence:
    """A sequence of grid coordinates whose second item cannot be read."""

    def __init__(self, first):
        self.first = first

    def __len__(self):
        return 3

    def __getitem__(self, i):
        if i == 0:
            return self.first
        raise RuntimeError("unreadable coordinates")


SUCCESS = {
    "scatter_points": lambda: _core.scatter_points(GRID, GAUSS, POS, VAL),
    "scatter_points_gradient": lambda: _core.scatter_points(GRID, LUCY, POS, VAL, gradient=True),
    "scatter_points_on_points": lambda: _core.scatter_points(POINT_TARGET, LUCY, POS, VAL),
    "scatter_points_averaged": lambda: _core.scatter_points(AVERAGED, LUCY_AVG, POS, VAL),
    "scatter_segments": lambda: _core.scatter_segments(GRID, LUCY, POS, VEC, VAL),
    "scatter_segments_ray": lambda: _core.scatter_segments(GRID, GAUSS, POS, DOWN, VAL, ray=True),
    "scatter_segments_gradient": lambda: _core.scatter_segments(POINT_TARGET, GAUSS, POS, VEC, VAL, gradient=True),
    "scatter_segments_outer": lambda: _core.scatter_segments_outer(GRID, LUCY, POS, VEC, VAL[:, :3]),
    "scatter_segments_outer_gradient": lambda: _core.scatter_segments_outer(POINT_TARGET, GAUSS, POS, VEC, VAL[:, :1],
                                                                            gradient=True),
    "scatter_fluctuation": lambda: _core.scatter_fluctuation(GRID, LUCY, POS, MASS, VEL, NODE_V),
    "scatter_points_kinetic": lambda: _core.scatter_points_kinetic(GRID, GAUSS, POS, MASS, VEL, VEL[0], 7),
    "minimum_image": lambda: _core.minimum_image(VEC, [True, False, True], PERIOD),
    "lists_not_arrays": lambda: _core.scatter_points(GRID, GAUSS, POS.tolist(), VAL.tolist()),
    "float32_input": lambda: _core.scatter_points(GRID, GAUSS, POS.astype(np.float32), VAL[:, :1]),
}

ERRORS = {
    "positions_wrong_width": raises(ValueError, _core.scatter_points, GRID, GAUSS, POS[:, :2], VAL),
    "values_wrong_length": raises(ValueError, _core.scatter_points, GRID, GAUSS, POS, VAL[:3]),
    "positions_nan": raises(ValueError, _core.scatter_points, GRID, GAUSS, POS_NAN, VAL),
    "values_inf": raises(ValueError, _core.scatter_points, GRID, GAUSS, POS, VAL_INF),
    "values_no_columns": raises(ValueError, _core.scatter_points, GRID, GAUSS, POS, VAL[:, :0]),
    "values_not_numbers": raises(TypeError, _core.scatter_points, GRID, GAUSS, POS, [["a"]] * 5),
    "coords_nan": raises(ValueError, _core.scatter_points, (3, (0, 1, 2), [COORD, COORD, COORD_NAN], None,
                                                            [False] * 3, PERIOD), GAUSS, POS, VAL),
    "coords_unreadable": raises(RuntimeError, _core.scatter_points, (3, (0, 1, 2), FailingSequence(COORD), None,
                                                                     [False] * 3, PERIOD), GAUSS, POS, VAL),
    "points_wrong_width": raises(ValueError, _core.scatter_points, (3, (0, 1, 2), None, POINTS[:, :2],
                                                                    [False] * 3, PERIOD), GAUSS, POS, VAL),
    "bad_target": raises(TypeError, _core.scatter_points, (3, (0, 1, 2)), GAUSS, POS, VAL),
    "bad_axes": raises(ValueError, _core.scatter_points, (3, (2, 1), [COORD, COORD], None, [False] * 2,
                                                          [1.0] * 2), GAUSS, POS, VAL),
    "bad_period": raises(ValueError, _core.scatter_points, (3, (0, 1, 2), [COORD] * 3, None, [True] * 3,
                                                            [1.0, -1.0, 1.0]), GAUSS, POS, VAL),
    "bad_kernel": raises(ValueError, _core.scatter_points, GRID, (0, -1.0, 0.6, 0, 1.0), POS, VAL),
    "kernel_not_a_tuple": raises(TypeError, _core.scatter_points, GRID, [0, 0.2, 0.6, 0, 1.0], POS, VAL),
    "vectors_wrong_shape": raises(ValueError, _core.scatter_segments, GRID, LUCY, POS, VEC[:4], VAL),
    "vectors_nan": raises(ValueError, _core.scatter_segments, GRID, LUCY, POS, POS_NAN, VAL),
    "divergent_ray": raises(ValueError, _core.scatter_segments, GRID, GAUSS, POS, ALONG, VAL, ray=True),
    "unsupported_gradient": raises(NotImplementedError, _core.scatter_segments, AVERAGED, LUCY_AVG, POS, VEC, VAL,
                                   gradient=True),
    "factors_too_many": raises(ValueError, _core.scatter_segments_outer, GRID, LUCY, POS, VEC, np.ones((5, 10))),
    "factors_wrong_length": raises(ValueError, _core.scatter_segments_outer, GRID, LUCY, POS, VEC, VAL[:4]),
    "masses_wrong_length": raises(ValueError, _core.scatter_fluctuation, GRID, LUCY, POS, MASS[:4], VEL, NODE_V),
    "node_velocity_wrong_shape": raises(ValueError, _core.scatter_fluctuation, GRID, LUCY, POS, MASS, VEL,
                                        NODE_V[:10]),
    "velocities_nan": raises(ValueError, _core.scatter_fluctuation, GRID, LUCY, POS, MASS, POS_NAN, NODE_V),
    "kinetic_bad_parts": raises(ValueError, _core.scatter_points_kinetic, GRID, GAUSS, POS, MASS, VEL, VEL[0], 9),
    "kinetic_overflow": raises(ValueError, _core.scatter_points_kinetic, GRID, GAUSS, POS, MASS, VEL * 1e160,
                               VEL[0], 4),
    "minimum_image_bad_period": raises(ValueError, _core.minimum_image, VEC, [True, True, True], [1.0, 0.0, 1.0]),
    "minimum_image_wrong_length": raises(ValueError, _core.minimum_image, VEC, [True], [1.0]),
    "minimum_image_nan": raises(ValueError, _core.minimum_image, POS_NAN, [True] * 3, PERIOD),
    "missing_argument": raises(TypeError, _core.scatter_points, GRID, GAUSS, POS),
}


@pytest.mark.parametrize("name", sorted(SUCCESS))
def test_entry_point_does_not_leak(name):
    assert_no_growth(SUCCESS[name], *WATCHED)


@pytest.mark.parametrize("name", sorted(ERRORS))
def test_error_path_does_not_leak(name):
    assert_no_growth(ERRORS[name], *WATCHED)


def test_coarse_grain_does_not_leak():
    rng = np.random.default_rng(2)
    box = cg.Box([0.0, 0.0], [1.0, 1.0], periodic=(True, False))
    n = 4
    pos = rng.uniform(0.2, 0.8, (n, 2))
    contacts = cg.Contacts([0, 1], [1, -1], rng.normal(size=(2, 2)), [pos[0] * 0.5 + pos[1] * 0.5, [pos[1, 0], 0.1]])
    snap = cg.Snapshot(pos, rng.normal(size=(n, 2)), np.ones(n), box=box, contacts=contacts)
    grid = cg.Grid(box, (3, 3))
    kernel = cg.Lucy(0.4)
    fields = ("density", "velocity", "stress", "extended_stress")

    def call():
        cg.coarse_grain(snap, grid, kernel, fields=fields)

    assert_no_growth(call, snap.positions, snap.velocities, snap.masses)
