"""Heaviside's line integral over a grid with one averaged axis (csrc/cg_kernels.c heaviside_chord_integral):
the marginal is 2 C sqrt(b^2 - t^2) along the segment, integrated in closed form. For a chord much shorter
than the support the closed form's two ends cancel; checked against 40-digit quadrature for segment lengths
from 1e-13 R to longer than the support, at every node of a grid around the segment (inside, at the edge of
and beyond the support)."""
import mpmath as mp
import numpy as np
import pytest

import cgbound as cg
from cgbound import _core, _engine
from stability_log import record
from test_hard_cases import rel_error

R = 0.9
LZ = 10.0           # the averaged extent: the marginal is divided by it
BOX = cg.Box([-5.0] * 3, [5.0] * 3)
GRID = cg.Grid(BOX, (71, 71, 1), average="z")


def mp_psi(node, start, vector):
    """(1 / LZ) int_0^1 int W(node - start - s vector, z) dz ds for the 3-D uniform ball W = 3 / (4 pi R^3), in 40
    digits (floats taken exactly; the chord's ends are the quadrature's breakpoints)."""
    with mp.workdps(40):
        d = [mp.mpf(float(node[i])) - mp.mpf(float(start[i])) for i in range(2)]
        e = [mp.mpf(float(vector[i])) for i in range(2)]
        radius = mp.mpf(R)

        def marginal(s):
            r2 = (d[0] - s * e[0]) ** 2 + (d[1] - s * e[1]) ** 2
            return 2 * mp.sqrt(radius**2 - r2) if r2 < radius**2 else mp.mpf(0)

        L2 = e[0] ** 2 + e[1] ** 2
        if L2 == 0:
            value = marginal(mp.mpf(0))
        else:
            # where the line leaves the support: s = (d.e +- sqrt((d.e)^2 - L2 (|d|^2 - R^2))) / L2
            de = d[0] * e[0] + d[1] * e[1]
            disc = de**2 - L2 * (d[0] ** 2 + d[1] ** 2 - radius**2)
            if disc <= 0:
                return 0.0
            lo = max(mp.mpf(0), (de - mp.sqrt(disc)) / L2)
            hi = min(mp.mpf(1), (de + mp.sqrt(disc)) / L2)
            if lo >= hi:
                return 0.0
            value = mp.quad(marginal, [lo, hi])
        return float(value * 3 / (4 * mp.pi * radius**3) / LZ)


def psi_on_grid(start, vector):
    target = _engine.core_target(GRID, BOX)
    kernel = _engine.core_kernel(cg.Heaviside(R), LZ)
    return _core.scatter_segments(target, kernel, start[None], vector[None], np.ones((1, 1)))[:, 0]


@pytest.mark.parametrize("length", [0.0, 1e-13, 1e-10, 1e-7, 1e-4, 0.05, 0.6, 1.5, 3.0])
def test_chord_integral_against_40_digits(length):
    rng = np.random.default_rng(int(length * 1e3) + 7)
    start = np.array([0.13, -0.21, 0.3])
    direction = rng.normal(size=3)
    direction[2] = 0.0
    vector = length * direction / np.linalg.norm(direction)
    psi = psi_on_grid(start, vector)
    x, y = np.meshgrid(*GRID.axis_coordinates[:2], indexing="ij")
    nodes = np.column_stack([x.ravel(), y.ravel()])
    near = np.flatnonzero(np.hypot(*(nodes - start[:2]).T) < R + length + 0.2)
    ref = np.array([mp_psi(nodes[i], start, vector) for i in near])
    assert np.count_nonzero(ref) > 100                       # the support is well sampled
    assert not psi[np.setdiff1d(np.arange(len(psi)), near)].any()
    err = rel_error(psi[near], ref)
    record(f"Heaviside over one averaged axis: segment of length {length:g} (R = {R})", err)
    assert err <= 1e-13
