"""The separable Gaussian's two builds, AVX-512 (on CPUs that have it) and AVX2/baseline, give identical
results: the same operations in the same order, only more of them per instruction."""
import numpy as np
import pytest

import cgbound as cg
from cgbound.rotation import SPIN_FIELDS
from cgbound import _core
from helpers import narrow_build, random_snapshot
from test_oracle import averagings, grid_for


def test_switch_and_restore():
    default = _core.wide_vectors()
    assert narrow_build(_core.wide_vectors) is False
    assert _core.wide_vectors() is default


@pytest.mark.parametrize("line_quadrature", ["exact", 1, 2, 3, 5])
@pytest.mark.parametrize("dim", [2, 3])
def test_builds_agree_bit_for_bit(dim, line_quadrature):
    if not _core.wide_vectors():
        pytest.skip("this CPU runs only the AVX2/baseline build")
    snap = random_snapshot(81 + dim, dim=dim, n=40, n_bulk=30)
    fields = tuple(f for f in cg.FIELD_NAMES if f != "extended_stress" and f not in SPIN_FIELDS)   # no spins here
    for average in averagings(dim):
        grid = grid_for(snap.box, average)
        for kernel in (cg.Gaussian(0.6, cutoff=1.8, line_quadrature=line_quadrature),
                       cg.Gaussian(2.5, cutoff=7.5, line_quadrature=line_quadrature)):
            wide = cg.coarse_grain(snap, grid, kernel, fields=fields)
            narrow = narrow_build(lambda: cg.coarse_grain(snap, grid, kernel, fields=fields))
            for name in fields:
                np.testing.assert_array_equal(wide[name], narrow[name], err_msg=f"{name} {average} {kernel}")
