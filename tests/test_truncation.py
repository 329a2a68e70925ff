"""The Gaussian's truncated-mass fraction and the cutoff chosen for a requested accuracy."""
import math

import mpmath
import numpy as np
import pytest

import cgbound as cg
from cgbound.kernels import gaussian_cutoff_for as from_kernels
from helpers import random_snapshot


@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("c", [0.1, 0.5, 1.0, 2.0, 3.0, 4.5, 5.0, 8.0, 12.0, 30.0])
def test_tail_fraction_is_the_regularised_upper_incomplete_gamma(dim, c):
    expected = float(mpmath.gammainc(mpmath.mpf(dim) / 2, mpmath.mpf(c) ** 2 / 2, mpmath.inf, regularized=True))
    assert cg.gaussian_tail_fraction(c, dim) == pytest.approx(expected, rel=1e-13, abs=1e-300)


def test_tail_fraction_by_quadrature_of_the_radial_density():
    """Independent of the gamma function: integrate r^2 exp(-r^2/2) over r > c in 3D."""
    c = 2.5
    r = np.linspace(c, 40.0, 400_001)
    f = r ** 2 * np.exp(-0.5 * r ** 2) * math.sqrt(2 / math.pi)
    assert cg.gaussian_tail_fraction(c, 3) == pytest.approx(float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(r))), rel=1e-7)


@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("rtol", [0.5, 1e-2, 1e-4, 1e-6, 1e-10, 1e-15, 1e-30])
def test_cutoff_for_is_the_smallest_meeting_rtol(dim, rtol):
    c = cg.gaussian_cutoff_for(rtol, dim)
    assert cg.gaussian_tail_fraction(c, dim) <= rtol
    assert cg.gaussian_tail_fraction(c * (1 - 1e-9), dim) > rtol


def test_cutoff_for_matches_known_values_and_grows_with_accuracy():
    # 3D: the tail at 5 w is 1.49e-5, at 6 w 7.7e-8 (numbers the study measured as stress errors)
    assert cg.gaussian_cutoff_for(1.5e-5) == pytest.approx(5.0, abs=0.01)
    assert cg.gaussian_cutoff_for(7.7e-8) == pytest.approx(6.0, abs=0.01)
    cuts = [cg.gaussian_cutoff_for(10.0 ** -k) for k in range(1, 16)]
    assert all(b > a for a, b in zip(cuts, cuts[1:]))
    assert from_kernels(1e-6) == cg.gaussian_cutoff_for(1e-6)


@pytest.mark.parametrize("rtol", [1e-3, 1e-6])
def test_a_kernel_cut_for_rtol_loses_that_much_mass(rtol):
    """The full-normalised Gaussian cut for rtol loses that fraction of the mass on a resolved periodic grid.

    The grid sum is not exact for a kernel with a jump at the cutoff (about 1% of the tail here), but a
    wrong dimension or formula would be off by factors.
    """
    snap = random_snapshot(1, dim=3, periodic=(True, True, True))
    w = 0.3
    grid = cg.Grid(snap.box, tuple(int(math.ceil(L / (w / 2))) for L in snap.box.lengths))
    c = cg.gaussian_cutoff_for(rtol, 3)
    out = cg.coarse_grain(snap, grid, cg.Gaussian(w, cutoff=c * w), fields=("density",))
    total = snap.masses[snap.flowing].sum()
    lost = 1.0 - out.density.sum() * np.prod(grid.spacing) / total
    assert lost == pytest.approx(rtol, rel=3e-2)


@pytest.mark.parametrize("bad", [0.0, -1e-3, 1.0, 2.0, float("nan"), float("inf")])
def test_bad_rtol_is_named(bad):
    with pytest.raises(ValueError, match="rtol"):
        cg.gaussian_cutoff_for(bad)


@pytest.mark.parametrize("bad", ["1e-3", None, True])
def test_rtol_of_the_wrong_type_is_named(bad):
    with pytest.raises(TypeError, match="rtol"):
        cg.gaussian_cutoff_for(bad)


@pytest.mark.parametrize("dim", [0, 4, 2.5, True, "3"])
def test_bad_dim_is_named(dim):
    with pytest.raises(ValueError, match="dim"):
        cg.gaussian_cutoff_for(1e-3, dim)
    with pytest.raises(ValueError, match="dim"):
        cg.gaussian_tail_fraction(3.0, dim)


@pytest.mark.parametrize("bad", [0.0, -2.0, float("nan")])
def test_bad_cutoff_is_named(bad):
    with pytest.raises(ValueError, match="cutoff_over_width"):
        cg.gaussian_tail_fraction(bad)


def test_on_a_profile_the_one_dimensional_tail_is_lost():
    """Averaged axes use the untruncated marginal, so a Z profile loses only the 1-D tail erfc(c / sqrt 2)."""
    snap = random_snapshot(2, dim=3, periodic=(True, True, True))
    w = 0.2
    # fine nodes: the kernel jumps at the cutoff, which a grid sum over 10 particles resolves only roughly
    grid = cg.Grid(snap.box, (1, 1, int(math.ceil(snap.box.lengths[2] / (w / 20)))), average=("x", "y"))
    rtol = 1e-4
    c = cg.gaussian_cutoff_for(rtol, 1)
    out = cg.coarse_grain(snap, grid, cg.Gaussian(w, cutoff=c * w), fields=("density",))
    total = snap.masses[snap.flowing].sum()
    lost = 1.0 - out.density.sum() * np.prod(grid.spacing) / total
    assert lost == pytest.approx(rtol, rel=0.1)   # 2D or 3D tails would be 5x or 15x this
