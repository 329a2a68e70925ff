"""The ring entry points of the C core (csrc/cg_ring.c) against their NumPy twins (tests/oracle.py).

cg_ring_moments: the angular moments of the 3-D kernel over a ring's arc; cg_ring_segment_sum: θ-averages
of tensors spread along pieces of segments, rotated into the local basis; cg_ring_segment_gradient_sum: the
θ-averages of their gradients. The twins use a different rule
(graded Gauss-Legendre for every kernel) and, for the tensors, the θ-average itself rather than the
moment identities, so agreement at 1e-12 checks both the rules and the reduction.
"""
import math

import numpy as np
import pytest

import cgbound as cg
from cgbound import _engine

from oracle import oracle_ring_moments, oracle_ring_segment_sum

KERNELS = {
    "gauss3w": cg.Gaussian(0.7, cutoff=2.1),
    "gauss5w": cg.Gaussian(0.7),
    "gauss5w-truncated": cg.Gaussian(0.7, normalize="truncated"),
    "gauss9w": cg.Gaussian(0.5, cutoff=4.5),
    "lucy": cg.Lucy(1.3),
    "heaviside": cg.Heaviside(0.9),
}


def pairs(kernel, r, n=400, seed=0):
    """Sources around the ring of radius r: inside the support, on its edge, through the ring, on the axis,
    just outside, and (for small r) holding the whole ring."""
    rng = np.random.default_rng(seed)
    c = float(kernel.radius)
    rho = np.abs(r + rng.uniform(-1.2 * c, 1.2 * c, n))
    h = rng.uniform(-1.1 * c, 1.1 * c, n)
    rho[:20] = r                                   # rings through the source (d0 = 0 when h = 0)
    h[:10] = 0.0
    rho[20:30] = 0.0                               # sources on the axis
    h[30:40] = np.sqrt(np.clip(c * c - (r - rho[30:40]) ** 2, 0.0, None)) * (1 - 1e-12)   # grazing
    rho[40:50] = r + 1e-9                          # next to the ring
    h[40:50] = 1e-9
    return h, rho


def scale(kernel, M):
    """Each pair's M₀, floored at 1e-4 of the kernel's peak: at the support's edge (grazing pairs) Lucy's
    (1 - d/c)³ is known only to the rounding of d, far below the kernel's scale."""
    peak = oracle_ring_moments(kernel, 0.0, np.zeros(1), np.zeros(1))[0, 0]
    return np.maximum(np.abs(M[0]), 1e-4 * peak)


@pytest.mark.parametrize("name", KERNELS)
@pytest.mark.parametrize("r", [0.0, 1e-6, 0.4, 2.5, 40.0])
def test_ring_moments_against_twin(name, r):
    kernel = KERNELS[name]
    h, rho = pairs(kernel, r)
    got = _engine.ring_moments(kernel, r, h, rho)
    want = oracle_ring_moments(kernel, r, h, rho)
    assert got.shape == (3, len(h))
    inside = (r - rho) ** 2 + h * h < float(kernel.radius) ** 2
    assert np.all(got[:, ~inside] == 0.0)
    assert inside.sum() > 100
    np.testing.assert_array_less(np.abs(got - want) / scale(kernel, want), 1e-12)


@pytest.mark.parametrize("name", [k for k in KERNELS if k != "heaviside"])
@pytest.mark.parametrize("r", [0.0, 1e-6, 0.4, 2.5, 40.0])
def test_gradient_moments_against_twin(name, r):
    """The moments of G = W'(d)/d (gradient=True) against the twin's graded rule on the textbook derivative,
    scaled by each pair's N₀ (G has one sign), floored as the moments of W are."""
    kernel = KERNELS[name]
    h, rho = pairs(kernel, r, seed=3)
    got = _engine.ring_moments(kernel, r, h, rho, gradient=True)
    want = oracle_ring_moments(kernel, r, h, rho, gradient=True)
    inside = (r - rho) ** 2 + h * h < float(kernel.radius) ** 2
    assert np.all(got[:, ~inside] == 0.0) and np.all(want[0, inside] < 0.0)
    floor = 1e-4 * np.abs(oracle_ring_moments(kernel, 0.0, np.zeros(1), np.zeros(1), gradient=True)[0, 0])
    np.testing.assert_array_less(np.abs(got - want) / np.maximum(np.abs(want[0]), floor), 1e-12)
    assert not np.allclose(got, _engine.ring_moments(kernel, r, h, rho))


@pytest.mark.parametrize("name, gradient", [(k, g) for k in KERNELS for g in (False, True)
                                            if not (g and k == "heaviside")])
@pytest.mark.parametrize("r", [0.0, 0.4, 2.5, 40.0])
def test_fourth_moment_against_twin(name, gradient, r):
    """n_moments=4 adds M₃ (of W, or of G) and leaves M₀..M₂ as they were."""
    kernel = KERNELS[name]
    h, rho = pairs(kernel, r, seed=5)
    got = _engine.ring_moments(kernel, r, h, rho, gradient=gradient, n_moments=4)
    want = oracle_ring_moments(kernel, r, h, rho, gradient=gradient, n_moments=4)
    assert got.shape == (4, len(h))
    assert np.array_equal(got[:3], _engine.ring_moments(kernel, r, h, rho, gradient=gradient))
    if r > 0:
        assert np.abs(want[3]).max() > 1e-3 * np.abs(want[0]).max()
    floor = 1e-4 * np.abs(oracle_ring_moments(kernel, 0.0, np.zeros(1), np.zeros(1), gradient=gradient)[0, 0])
    np.testing.assert_array_less(np.abs(got[3] - want[3]) / np.maximum(np.abs(want[0]), floor), 1e-12)


def test_heaviside_has_no_gradient_moments():
    with pytest.raises(NotImplementedError):
        _engine.ring_moments(KERNELS["heaviside"], 1.0, np.zeros(2), np.ones(2), gradient=True)


def test_ring_moments_of_a_gaussian_ring_in_closed_form():
    """Without a cutoff in reach (the whole ring inside a wide support), the Gaussian's moments are the scaled
    Bessel functions: M_m = 2 W(d0 ...) e^{-β} I_m(β) with β = r ρ / w² (an independent closed form)."""
    scipy_special = pytest.importorskip("scipy.special")
    kernel = cg.Gaussian(1.0, cutoff=30.0)
    r, rho, h = 1.3, np.array([0.2, 1.0, 2.5, 4.0]), np.array([0.0, 0.5, -1.0, 2.0])
    beta = r * rho
    norm = (2 * math.pi) ** 1.5
    base = np.exp(-((r - rho) ** 2 + h * h) / 2) / norm
    want = np.stack([base * scipy_special.ive(m, beta) for m in (0, 1, 2)])
    got = _engine.ring_moments(kernel, r, h, rho)
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=0)


def segment_case(kernel, r, z, n_segments=9, seed=3):
    """Segments around the ring (r, z), some through the axis, some along it, one of zero length, with random
    pieces of [0, 1] on 1-3 panels."""
    rng = np.random.default_rng(seed)
    c = float(kernel.radius)
    start = np.column_stack([rng.uniform(-r - c, r + c, n_segments), rng.uniform(-r - c, r + c, n_segments),
                             z + rng.uniform(-c, c, n_segments)])
    vector = rng.normal(scale=0.6 * c, size=(n_segments, 3))
    start[0, :2], vector[0, :2] = (-0.5, 0.0), (1.0, 0.0)            # through the axis
    start[1, :2], vector[1, :2] = (0.0, 0.0), (0.0, 0.0)            # along the axis
    vector[2] = 0.0                                                   # zero length
    geometry = np.column_stack([start[:, 0], start[:, 1], start[:, 2], vector])
    n_pieces = 3 * n_segments
    segment = np.repeat(np.arange(n_segments), 3)
    lo = rng.uniform(0, 1, n_pieces)
    hi = np.minimum(lo + rng.uniform(0, 0.7, n_pieces), 1.0)
    lo[0], hi[0] = 0.0, 1.0
    panels = rng.integers(1, 4, n_pieces)
    tensors = rng.normal(size=(n_segments, 9))
    return segment, lo, hi, panels, geometry, tensors


@pytest.mark.parametrize("name", KERNELS)
@pytest.mark.parametrize("r", [0.0, 0.4, 3.0])
def test_ring_segment_sum_against_twin(name, r):
    kernel = KERNELS[name]
    case = segment_case(kernel, r, 0.3)
    got = _engine.ring_segment_sum(kernel, r, 0.3, *case, 0.7)
    want = oracle_ring_segment_sum(kernel, r, 0.3, *case, 0.7)
    size = np.abs(want).max()
    assert size > 0
    np.testing.assert_array_less(np.abs(got - want), 1e-12 * size)


@pytest.mark.parametrize("name", [k for k in KERNELS if k != "heaviside"])
@pytest.mark.parametrize("r", [0.0, 0.4, 3.0])
def test_ring_segment_gradient_sum_against_twin(name, r):
    """The twin takes the θ-average of B T Bᵀ ⊗ B G(d) (x - q) itself (no moments, no 8-angle rule)."""
    kernel = KERNELS[name]
    case = segment_case(kernel, r, 0.3)
    got = _engine.ring_segment_sum(kernel, r, 0.3, *case, 0.7, gradient=True)
    want = oracle_ring_segment_sum(kernel, r, 0.3, *case, 0.7, gradient=True)
    assert got.shape == (3, 3, 3)
    size = np.abs(want).max()
    assert size > 0
    np.testing.assert_array_less(np.abs(got - want), 1e-12 * size)


def test_heaviside_has_no_segment_gradient():
    kernel = KERNELS["heaviside"]
    with pytest.raises(NotImplementedError):
        _engine.ring_segment_sum(kernel, 1.0, 0.3, *segment_case(kernel, 1.0, 0.3), 1.0, gradient=True)


def test_ring_segment_sum_does_not_depend_on_the_thread_count():
    kernel = KERNELS["lucy"]
    case = segment_case(kernel, 1.5, 0.0, n_segments=400, seed=8)
    for gradient in (False, True):
        runs = [_engine.ring_segment_sum(kernel, 1.5, 0.0, *case, 1.0, gradient=gradient, n_threads=t)
                for t in (1, 2, 3)]
        for other in runs[1:]:
            assert np.array_equal(runs[0], other)
    rng = np.random.default_rng(5)
    h, rho = rng.uniform(-1, 1, 5000), rng.uniform(0, 3, 5000)
    moments = [_engine.ring_moments(kernel, 1.5, h, rho, n_threads=t) for t in (1, 2, 3)]
    for other in moments[1:]:
        assert np.array_equal(moments[0], other)


def test_ring_entry_points_refuse_bad_arguments():
    kernel = KERNELS["gauss5w"]
    h, rho = np.zeros(3), np.ones(3)
    with pytest.raises(ValueError, match="r: expected a finite radius"):
        _engine.ring_moments(kernel, -1.0, h, rho)
    with pytest.raises(ValueError, match="r: expected a finite radius"):
        _engine.ring_moments(kernel, float("nan"), h, rho)
    with pytest.raises(ValueError, match="h: expected finite values"):
        _engine.ring_moments(kernel, 1.0, np.array([0.0, np.nan, 0.0]), rho)
    with pytest.raises(ValueError, match="rho: expected length 3"):
        _engine.ring_moments(kernel, 1.0, h, np.ones(4))
    for n_moments in (0, 5):
        with pytest.raises(ValueError, match="n_moments: expected 1 to 4"):
            _engine.ring_moments(kernel, 1.0, h, rho, n_moments=n_moments)
    with pytest.raises(ValueError, match="kernel"):
        _engine._core.ring_moments((0, -1.0, 1.0, 0, 1.0), 1.0, h, rho)
    segment, lo, hi, panels, geometry, tensors = segment_case(kernel, 1.0, 0.0, n_segments=3)
    bad = {"segment": (5,), "lo": (-0.1,), "hi": (1.5,), "panels": (0,)}
    for name, (value,) in bad.items():
        args = dict(segment=segment.copy(), lo=lo.copy(), hi=hi.copy(), panels=panels.copy())
        args[name][0] = value
        with pytest.raises(ValueError, match="segment, lo, hi, panels: expected rows of geometry"):
            _engine.ring_segment_sum(kernel, 1.0, 0.0, args["segment"], args["lo"], args["hi"], args["panels"],
                                     geometry, tensors, 1.0)
    with pytest.raises(ValueError, match="segment: expected one entry per piece"):
        _engine.ring_segment_sum(kernel, 1.0, 0.0, segment[:-1], lo, hi, panels, geometry, tensors, 1.0)
    with pytest.raises(ValueError, match="panels: expected a 1-dimensional array with one entry per pair"):
        _engine.ring_segment_sum(kernel, 1.0, 0.0, segment, lo, hi, panels[:-1], geometry, tensors, 1.0)
    with pytest.raises(ValueError, match="tensors: expected length 3 along axis 0"):
        _engine.ring_segment_sum(kernel, 1.0, 0.0, segment, lo, hi, panels, geometry, tensors[:1], 1.0)
    with pytest.raises(ValueError, match="r, z, weight: expected finite"):
        _engine.ring_segment_sum(kernel, 1.0, float("inf"), segment, lo, hi, panels, geometry, tensors, 1.0)
