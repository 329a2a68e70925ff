"""Error bars on time averages (CoarseGrain(..., errors="blocks")): the standard error of block means, and the
warning when consecutive block means are correlated (docs/theory.md, "Error bars on time averages")."""
import warnings

import numpy as np
import pytest

import cgbound as cg


def frames_with_masses(mass_per_frame, seed=0, n=30):
    """Frames of particles at fixed positions whose (common) mass is ``mass_per_frame[t]``: every density is
    that mass times the density of unit masses, so its block means are known by hand."""
    rng = np.random.default_rng(seed)
    box = cg.Box([0, 0, 0], [3, 3, 3], periodic=(True, True, True))
    pos = rng.uniform(0, 3, (n, 3))
    vel = rng.normal(size=(n, 3))
    return box, [cg.Snapshot(pos, vel, np.full(n, m), box, time=float(t)) for t, m in enumerate(mass_per_frame)]


def run(frames, grid, n_blocks, fields=("density", "velocity")):
    return cg.CoarseGrain(frames, grid, cg.Gaussian(0.6), fields=fields, errors="blocks", n_blocks=n_blocks).run()


def test_standard_error_is_that_of_the_block_means_computed_by_hand():
    rng = np.random.default_rng(3)
    masses = 1.0 + 0.2 * rng.normal(size=103)          # independent frames with a known variance
    box, frames = frames_with_masses(masses)
    grid = cg.Grid(box, (2, 3, 2))
    with warnings.catch_warnings():
        warnings.simplefilter("error", cg.CorrelatedBlocksWarning)
        r = run(frames, grid, 10).results
    unit = cg.coarse_grain(frames[0], grid, cg.Gaussian(0.6), fields=("density",)).density / masses[0]
    block_means = np.array([b.mean() for b in np.array_split(masses, 10)])   # 103 frames: blocks of 11 and 10
    by_hand = block_means.std(ddof=1) / np.sqrt(10)
    np.testing.assert_allclose(r.errors["density"], by_hand * unit, rtol=1e-10)
    # the velocity does not change from frame to frame: no error bar beyond rounding
    assert np.all(r.errors["velocity"] <= 1e-12 * np.abs(r.velocity).max())
    assert r.errors["density"].shape == r.density.shape and r.errors["velocity"].shape == r.velocity.shape
    assert r.n_blocks == 10 and set(r.block_correlation) == {"density", "velocity"}
    # the mean itself is the ordinary time average, bit for bit
    plain = cg.CoarseGrain(frames, grid, cg.Gaussian(0.6), fields=("density", "velocity")).run().results
    np.testing.assert_array_equal(r.density, plain.density)
    np.testing.assert_array_equal(r.velocity, plain.velocity)
    assert plain.errors is None


def test_the_error_bar_estimates_the_spread_of_the_time_average():
    # known variance: 400 independent frames with sd 0.2 -> the mean's standard error is 0.2 / sqrt(400) = 0.01
    rng = np.random.default_rng(11)
    masses = 1.0 + 0.2 * rng.normal(size=400)
    box, frames = frames_with_masses(masses)
    r = run(frames, cg.Grid(box, (1, 1, 1), average=("x", "y", "z")), 20, fields=("density",)).results
    unit = 30 / 27.0
    # the block estimate has 19 degrees of freedom: within 40 % of the truth (a chi distribution, ~3 sigma)
    assert float(r.errors["density"].ravel()[0]) / unit == pytest.approx(0.01, rel=0.4)


def test_correlated_frames_give_the_warning_and_independent_ones_do_not():
    rng = np.random.default_rng(5)
    n_frames, n_blocks = 400, 20
    walk = 1.0 + 0.02 * np.cumsum(rng.normal(size=n_frames))        # a slow drift: consecutive blocks alike
    box, frames = frames_with_masses(np.abs(walk) + 0.1, seed=1)
    grid = cg.Grid(box, (2, 2, 2))
    with pytest.warns(cg.CorrelatedBlocksWarning, match="density"):
        r = run(frames, grid, n_blocks, fields=("density",)).results
    assert r.block_correlation["density"] > 2 / np.sqrt(n_blocks)
    independent = 1.0 + 0.2 * rng.normal(size=n_frames)
    box, frames = frames_with_masses(independent, seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", cg.CorrelatedBlocksWarning)
        r = run(frames, grid, n_blocks, fields=("density",)).results
    assert r.block_correlation["density"] < 2 / np.sqrt(n_blocks)


def test_dask_blocks_give_the_same_error_bars():
    pytest.importorskip("dask.distributed")
    rng = np.random.default_rng(2)
    box, frames = frames_with_masses(1.0 + 0.2 * rng.normal(size=24))
    grid = cg.Grid(box, (2, 2, 2))
    serial = run(frames, grid, 4).results
    spread = cg.CoarseGrain(frames, grid, cg.Gaussian(0.6), fields=("density", "velocity"), errors="blocks",
                            n_blocks=4).run(backend="dask", n_workers=2).results
    for name in ("density", "velocity"):
        np.testing.assert_allclose(spread.errors[name], serial.errors[name], rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize("kwargs, match", [
    ({"errors": "bootstrap"}, "errors"),
    ({"errors": "blocks", "n_blocks": 1}, "n_blocks"),
    ({"errors": "blocks", "n_blocks": 2.5}, "n_blocks"),
    ({"errors": "blocks", "time_average": "none"}, "errors"),
])
def test_bad_error_arguments_are_refused(kwargs, match):
    box, frames = frames_with_masses([1.0, 1.1, 0.9])
    with pytest.raises((ValueError, TypeError), match=match):
        cg.CoarseGrain(frames, cg.Grid(box, 2), cg.Gaussian(0.6), **kwargs)


def test_more_blocks_than_frames_and_unsized_frames_are_refused_before_work():
    box, frames = frames_with_masses([1.0, 1.1, 0.9])
    with pytest.raises(ValueError, match="n_blocks"):
        cg.CoarseGrain(frames, cg.Grid(box, 2), cg.Gaussian(0.6), errors="blocks", n_blocks=4).run()
    with pytest.raises(TypeError, match="snapshots"):
        cg.CoarseGrain(iter(frames), cg.Grid(box, 2), cg.Gaussian(0.6), errors="blocks", n_blocks=2).run()


def test_blocks_that_cannot_fit_are_refused_naming_n_blocks():
    from cgbound.block_errors import check_block_memory
    box = cg.Box([0, 0, 0], [1, 1, 1])
    huge = cg.Grid(box, (2000, 2000, 2000))
    with pytest.raises(MemoryError, match="n_blocks"):
        check_block_memory(huge, ("stress",), 3, 10)
    check_block_memory(cg.Grid(box, (4, 4, 4)), ("stress",), 3, 10)
