"""The Gaussian's line_quadrature option: Gauss-Legendre rules along contact branches against the oracle,
convergence to the exact form, rays staying exact, and the separable fast path against node-by-node evaluation."""
import numpy as np
import pytest

import cgbound as cg
from cgbound.rotation import SPIN_FIELDS
from cgbound.fields import PRESSURE_RATIO_FIELDS
from cgbound import _core
from helpers import ILL_CONDITIONED_FIELDS, assert_fields_close, random_snapshot
from oracle import oracle_coarse_grain
from test_oracle import averagings, grid_for

RTOL = 1e-10
CONTACT_FIELDS = ("contact_stress", "boundary_stress", "stress", "extended_stress")


@pytest.mark.parametrize("n", [1, 2, 3, 5, 16])
@pytest.mark.parametrize("dim,average", [(3, ()), (3, ("x",)), (3, ("x", "y")), (2, ()), (2, ("x",))])
def test_gauss_legendre_matches_oracle_on_grids(dim, average, n):
    snap = random_snapshot(31 + dim, dim=dim)
    grid = grid_for(snap.box, average)
    for kernel in (cg.Gaussian(0.6, cutoff=1.8, line_quadrature=n),
                   cg.Gaussian(0.55, cutoff=1.65, normalize="truncated", line_quadrature=n)):
        out = cg.coarse_grain(snap, grid, kernel, fields=CONTACT_FIELDS)
        ref = oracle_coarse_grain(snap, grid, kernel, CONTACT_FIELDS)
        for name in CONTACT_FIELDS:
            assert_fields_close(out[name].reshape(ref[name].shape), ref[name], RTOL, f"{name} n={n}")


@pytest.mark.parametrize("n", [1, 4])
@pytest.mark.parametrize("dim", [2, 3])
def test_gauss_legendre_matches_oracle_at_points(dim, n):
    snap = random_snapshot(41 + dim, dim=dim)
    rng = np.random.default_rng(dim)
    pts = cg.Points(snap.box.lower + rng.uniform(0, 1, (17, dim)) * (snap.box.upper - snap.box.lower))
    kernel = cg.Gaussian(0.7, cutoff=2.1, line_quadrature=n)
    out = cg.coarse_grain(snap, pts, kernel, fields=CONTACT_FIELDS)
    ref = oracle_coarse_grain(snap, pts, kernel, CONTACT_FIELDS)
    for name in CONTACT_FIELDS:
        assert_fields_close(out[name].reshape(ref[name].shape), ref[name], RTOL, name)


def test_gauss_legendre_converges_to_the_exact_form():
    """Branches shorter than the width: the error falls fast with n and 16 points reach round-off
    (with a cutoff well beyond the branches, so the cut does not slice any branch near a node)."""
    snap = random_snapshot(5, dim=3)
    grid = cg.Grid(snap.box, (6, 5, 7))
    exact = cg.coarse_grain(snap, grid, cg.Gaussian(1.5, cutoff=12.0), fields=("contact_stress",)).contact_stress
    errors = []
    for n in (1, 2, 4, 8, 16):
        gl = cg.coarse_grain(snap, grid, cg.Gaussian(1.5, cutoff=12.0, line_quadrature=n),
                             fields=("contact_stress",)).contact_stress
        errors.append(np.abs(gl - exact).max() / np.abs(exact).max())
    assert errors[0] > 1e-4                                   # one point is visibly not exact
    assert all(b < a for a, b in zip(errors[:3], errors[1:4]))
    assert errors[-1] < 1e-12


def test_rays_stay_exact():
    """extended_stress - contact_stress is the kinetic part plus the rays: independent of the segment rule."""
    snap = random_snapshot(7, dim=3)
    grid = cg.Grid(snap.box, (5, 4, 6))
    fields = ("extended_stress", "contact_stress")
    exact = cg.coarse_grain(snap, grid, cg.Gaussian(0.6, cutoff=1.8), fields=fields)
    gl = cg.coarse_grain(snap, grid, cg.Gaussian(0.6, cutoff=1.8, line_quadrature=1), fields=fields)
    assert np.abs(gl.contact_stress - exact.contact_stress).max() > 1e-6
    assert_fields_close(gl.extended_stress - gl.contact_stress, exact.extended_stress - exact.contact_stress,
                        1e-12, "rays")


@pytest.mark.parametrize("wide", [True, False])
@pytest.mark.parametrize("line_quadrature", ["exact", 1, 2, 3, 5])
@pytest.mark.parametrize("dim", [2, 3])
def test_separable_path_agrees_with_node_by_node(dim, line_quadrature, wide):
    """The outer-product fast path (either vector build) and the straightforward per-node loop (kept for
    benchmarks) agree."""
    previous = _core.set_wide_vectors(wide)
    try:
        _separable_path_agrees_with_node_by_node(dim, line_quadrature)
    finally:
        _core.set_wide_vectors(previous)


def _separable_path_agrees_with_node_by_node(dim, line_quadrature):
    snap = random_snapshot(51 + dim, dim=dim, n=40, n_bulk=30)
    # the ratios to the pressure are functions of fields compared here, with round-off amplified where p ~ 0
    fields = tuple(f for f in cg.FIELD_NAMES if f != "extended_stress" and f not in ILL_CONDITIONED_FIELDS
                   and f not in PRESSURE_RATIO_FIELDS and f not in SPIN_FIELDS)    # these data do not spin
    for average in averagings(dim):
        grid = grid_for(snap.box, average)
        for kernel in (cg.Gaussian(0.6, cutoff=1.8, line_quadrature=line_quadrature),
                       cg.Gaussian(0.3, cutoff=2.4, normalize="truncated", line_quadrature=line_quadrature),
                       cg.Gaussian(2.5, cutoff=7.5, line_quadrature=line_quadrature)):
            fast = cg.coarse_grain(snap, grid, kernel, fields=fields)
            kernel._per_node = True
            slow = cg.coarse_grain(snap, grid, kernel, fields=fields)
            for name in fields:
                assert_fields_close(fast[name], slow[name], 1e-12, f"{name} {average} {kernel}")


@pytest.mark.parametrize("bad,error", [(0, ValueError), (17, ValueError), (-2, ValueError), ("erf", ValueError),
                                       (2.0, TypeError), (True, TypeError), (None, TypeError)])
def test_bad_line_quadrature_is_refused(bad, error):
    with pytest.raises(error, match="line_quadrature"):
        cg.Gaussian(1.0, line_quadrature=bad)


def test_line_quadrature_attribute_and_repr():
    assert cg.Gaussian(1.0).line_quadrature == cg.kernels.DEFAULT_LINE_QUADRATURE == "exact"
    k = cg.Gaussian(1.0, line_quadrature=np.int64(3))
    assert k.line_quadrature == 3 and type(k.line_quadrature) is int
    assert "line_quadrature=3" in repr(k)


def test_auto_rule_follows_the_study():
    """n = ceil(2 L / w + 2) Gauss-Legendre points, the exact form beyond 8."""
    rule = cg.kernels.auto_line_points
    assert [rule(1.0, w) for w in (4.0, 2.0, 1.0, 0.5, 0.25)] == [3, 3, 4, 6, 0]
    assert rule(0.0, 1.0) == 1 and rule(3.0, 1.0) == 8 and rule(3.01, 1.0) == 0


def _longest(snap):
    bulk, boundary = snap.split_contacts()
    return max(np.linalg.norm(part["branch"], axis=1).max() for part in (bulk, boundary) if len(part["branch"]))


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("width", [0.5, 0.9, 2.0])
def test_auto_is_the_rules_gauss_legendre_rule(dim, width):
    snap = random_snapshot(61 + dim, dim=dim)
    grid = cg.Grid(snap.box, (9, 7, 8)[:dim])
    n = cg.kernels.auto_line_points(_longest(snap), width)
    fields = ("contact_stress", "boundary_stress")
    auto = cg.coarse_grain(snap, grid, cg.Gaussian(width, line_quadrature="auto"), fields=fields)
    same = cg.coarse_grain(snap, grid, cg.Gaussian(width, line_quadrature=n if n else "exact"), fields=fields)
    exact = cg.coarse_grain(snap, grid, cg.Gaussian(width), fields=fields)
    for name in fields:
        np.testing.assert_array_equal(auto[name], same[name])
        # at the default 5w cutoff's accuracy (the tail leaves ~1.5e-5)
        err = np.linalg.norm(auto[name] - exact[name]) / np.linalg.norm(exact[name])
        assert err < 1e-4, (name, n, err)
    pts = cg.Points(snap.box.lower + np.random.default_rng(dim).uniform(0, 1, (20, dim)) * snap.box.lengths)
    res_auto = cg.momentum_balance_residual(snap, pts, cg.Gaussian(width, line_quadrature="auto"))
    res_same = cg.momentum_balance_residual(snap, pts, cg.Gaussian(width, line_quadrature=n if n else "exact"))
    np.testing.assert_array_equal(res_auto.relative, res_same.relative)


def test_auto_attribute_and_repr():
    k = cg.Gaussian(1.0, line_quadrature="auto")
    assert k.line_quadrature == "auto" and "line_quadrature='auto'" in repr(k)


@pytest.mark.parametrize("line_quadrature", ["exact", 1, 2, 4])
def test_separable_path_on_long_rows(line_quadrature):
    """Stencils of more than 8 and more than 64 nodes along the last axis (the separable path sums rows
    8 nodes at a time, and falls back to one pass per rule point beyond 64) agree with node by node."""
    snap = random_snapshot(71, dim=3, n=30, n_bulk=25)
    fields = ("density", "momentum", "contact_stress", "boundary_stress")
    for shape, width in (((4, 5, 40), 0.8), ((3, 3, 300), 1.5)):
        grid = cg.Grid(snap.box, shape)
        spacing = float(snap.box.lengths[2]) / shape[2]
        kernel = cg.Gaussian(width, cutoff=3 * width, line_quadrature=line_quadrature)
        assert 2 * kernel.cutoff / spacing > (8 if shape[2] == 40 else 64)
        fast = cg.coarse_grain(snap, grid, kernel, fields=fields)
        kernel._per_node = True
        slow = cg.coarse_grain(snap, grid, kernel, fields=fields)
        for name in fields:
            assert_fields_close(fast[name], slow[name], 1e-12, f"{name} {shape} {line_quadrature}")
