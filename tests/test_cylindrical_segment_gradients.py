"""Exact θ-averages of the gradients of the stresses' line integrals on θ-averaged CylindricalGrids
(cylindrical_ring.ring_average_segments with gradient=True, csrc/cg_ring.c's cg_ring_segment_gradient_sum);
the cylindrical momentum balance they make exact for Lucy is tests/test_cylindrical_balance.py's.

The reference swaps the order of the integrals: at each point of the ring the Cartesian engine's line integral
of the kernel's gradient along the segment (analytic in s), rotated into the local basis, then QUADPACK
(scipy's quad_vec) over θ. The geometries are those that limited the rule along the segments: a segment through
the ring, one passing it at 1e-3, one just missing the surface where the whole ring enters the support.
"""
import math

import numpy as np
import pytest
from scipy.integrate import quad_vec

import cgbound as cg
from cgbound import _engine
from cgbound.cylindrical_ring import ring_average_segments

KERNELS = {"lucy": cg.Lucy(1.2), "gauss5w": cg.Gaussian(0.4)}
R0, Z0 = 0.9, 0.2
ON_RING = np.array([R0 * math.cos(0.4), R0 * math.sin(0.4), Z0])
START = np.array([-0.3, -0.5, -0.1])
#: (start, vector, ring radius): the segment's line through the ring at s = 1/2, passing it at 1e-3, and (ring
#: radius 0.3) running at 0.902 from the axis, 2e-3 outside where the whole ring enters Lucy's support
CASES = {
    "through": (START, 2 * (ON_RING - START), R0),
    "near": (START, 2 * (ON_RING + np.array([0.0, 0.0, 1e-3]) - START), R0),
    "whole-ring-graze": (np.array([-1.0, 0.902, Z0]), np.array([2.0, 0.0, 0.0]), 0.3),
}
VALUE = np.random.default_rng(1).normal(size=(3, 3))


def local_basis(theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def swapped_order_reference(kernel, start, vector, value, r, z):
    """(1/2π) ∫ dθ B (∇ ∫_0^1 W(x(θ) - start - s vector) ds ⊗ value) in the local basis B(θ), [a, b, c] =
    ∂T_ab/∂x_c: the Cartesian engine's exact line integral at each x(θ), QUADPACK over θ."""
    flat = np.ascontiguousarray(value.reshape(1, 9))
    core = _engine.ring_kernel(kernel)

    def f(theta):
        x = np.array([[r * math.cos(theta), r * math.sin(theta), z]])
        grad = np.asarray(_engine.scatter_segments(_engine.point_target(x), core, start[None], vector[None], flat,
                                                   gradient=True)).reshape(3, 3, 3)
        B = local_basis(theta)
        return np.einsum("ia,jb,kc,abc->ijk", B, B, B, grad).ravel()

    # the arc where the ring meets the segment's support has kinks (Lucy) or jumps (the Gaussian's cutoff): QUADPACK's
    # adaptive bisection finds them
    total, _ = quad_vec(f, 0.0, 2 * math.pi, epsabs=1e-15, epsrel=1e-13, limit=4000)
    return total.reshape(3, 3, 3) / (2 * math.pi)


def ring_gradient(kernel, start, vector, value, r, z):
    box = cg.Box([-4, -4, -4], [4, 4, 4])
    grid = cg.CylindricalGrid(box, (0, 0, 0), "z", r=(r - 0.01, r + 0.01, 1), z=(z - 0.01, z + 0.01, 1))
    return ring_average_segments(grid, kernel, start[None], vector[None], value[None], np.array([[z]]),
                                 np.ones((1, 1)), gradient=True)[0]


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("name", KERNELS)
def test_segment_gradients_against_adaptive_quadrature(name, case):
    kernel = KERNELS[name]
    start, vector, r = CASES[case]
    got = ring_gradient(kernel, start, vector, VALUE, r, Z0)
    want = swapped_order_reference(kernel, start, vector, VALUE, r, Z0)
    assert got.shape == (3, 3, 3) and np.abs(want).max() > 0
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * np.abs(want).max())     # measured <= 1e-14


def test_segment_gradient_is_the_derivative_of_the_segment_average():
    """∂/∂r and ∂/∂z of the exact θ-averaged line integral (its own tests: tests/test_cylindrical_ring.py) by a
    fourth-order central difference with step 1e-3 (measured 8e-12 of the largest derivative; 6e-10 with step
    3e-3: the difference's h⁴). The e_θ column has no such check (θ-averages do not depend on θ); the
    quadrature above and the balance (tests/test_cylindrical_balance.py) check it."""
    kernel = KERNELS["lucy"]
    start, vector, r = CASES["near"]
    box = cg.Box([-4, -4, -4], [4, 4, 4])
    h = 1e-3

    def sigma(r_, z_):
        grid = cg.CylindricalGrid(box, (0, 0, 0), "z", r=(r_ - 0.01, r_ + 0.01, 1), z=(z_ - 0.01, z_ + 0.01, 1))
        return ring_average_segments(grid, kernel, start[None], vector[None], VALUE[None], np.array([[z_]]),
                                     np.ones((1, 1)))[0]

    def fourth_order(f):
        return (f(-2) - 8 * f(-1) + 8 * f(1) - f(2)) / (12 * h)

    grad = ring_gradient(kernel, start, vector, VALUE, r, Z0)
    d_dr = fourth_order(lambda k: sigma(r + k * h, Z0))
    d_dz = fourth_order(lambda k: sigma(r, Z0 + k * h))
    scale = np.abs(grad).max()
    np.testing.assert_allclose(grad[..., 0], d_dr, rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(grad[..., 2], d_dz, rtol=0, atol=1e-10 * scale)
