"""Adversarial API suite (bounded for CI): every public argument of Box, Snapshot, Contacts, Grid, Points,
the kernels, coarse_grain, CoarseGrain, momentum_balance_residual and the writers, fed hostile values.

Each call gives a finite, correct result (the total mass where it is cheap) or a named exception
(ValueError / TypeError / MemoryError / IndexError whose message starts with the user's argument)
raised before work. tools/fuzz_api.py runs the same cases for longer.
"""
import os
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

sys.path.insert(0, os.path.dirname(__file__))
import adversarial_api as adv  # noqa: E402

import cgbound as cg  # noqa: E402

# a few thousand cases in all; no deadline (the machine may be loaded), derandomized for CI unless
# tools/fuzz_api.py asks for more examples and random seeds (CGBOUND_ADVERSARIAL_RANDOM=1)
SUITE = settings(max_examples=int(os.environ.get("CGBOUND_ADVERSARIAL_EXAMPLES", 300)),
                 deadline=int(os.environ.get("CGBOUND_DEADLINE_MS", 0)) or None,
                 derandomize=not os.environ.get("CGBOUND_ADVERSARIAL_RANDOM"),
                 suppress_health_check=list(HealthCheck), database=None)


@SUITE
@given(adv.box_case())
def test_box(case):
    adv.check_box(case)


@SUITE
@given(adv.contacts_case())
def test_contacts(args):
    adv.call(cg.Contacts, *args)


@SUITE
@given(adv.snapshot_case())
def test_snapshot(kw):
    snap = adv.make_snapshot(kw)
    if snap is not None:
        assert np.all(np.isfinite(snap.positions)) and np.all(np.isfinite(snap.masses))


@SUITE
@given(adv.kernel_case())
def test_kernels(case):
    kernel = adv.make_kernel(case)
    if kernel is not None:
        lo, hi = cg.kernels.LENGTH_RANGE
        assert lo <= kernel.radius <= hi * cg.kernels.DEFAULT_GAUSSIAN_CUTOFF   # a default cutoff is 5 widths
        assert kernel.width is None or lo <= kernel.width <= hi
        assert 0 < kernel.peak_bound(3) < np.inf


@SUITE
@given(st.sampled_from([2, 3]).flatmap(lambda d: st.tuples(st.just(d), adv.grid_case(d))))
def test_grid(case):
    dim, (shape, average) = case
    grid, exc = adv.call(cg.Grid, adv.base_box(dim), shape, average=average)
    if grid is not None:
        assert all(np.all(np.isfinite(c)) for c in grid.axis_coordinates)


@SUITE
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from([2, 3]), st.data())
def test_points(seed, dim, data):
    value = adv.hostile_array(data.draw, (3, dim)) if data.draw(st.booleans()) else data.draw(adv.scalars)
    adv.call(cg.Points, value)


@SUITE
@given(adv.snapshot_case(), adv.kernel_case(), st.data())
def test_coarse_grain(kw, kernel_case, data):
    snap = adv.make_snapshot(kw)
    kernel = adv.make_kernel(kernel_case)
    if snap is None:
        return
    grid_args = data.draw(adv.grid_case(snap.dim))
    fields = data.draw(st.sampled_from(adv.FIELD_LISTS))
    convention = data.draw(st.sampled_from(["tension", "compression", "x", None]))
    species = data.draw(st.sampled_from([None, None, 0, 1, -1, 2.5, "a", 10 ** 30]))
    adv.run_pipeline(snap, kernel, grid_args, fields, convention, species, data.draw(st.booleans()),
                     data.draw(st.integers(0, 2 ** 32 - 1)))


@SUITE
@given(adv.snapshot_case(), adv.kernel_case())
def test_total_mass(kw, kernel_case):
    """Whenever a snapshot and a kernel are accepted, the fully averaged density is the total mass / volume."""
    snap = adv.make_snapshot(kw)
    kernel = adv.make_kernel(kernel_case)
    if snap is None or kernel is None or snap.n_particles == 0 or snap.fixed.all():
        return
    try:
        adv.mass_identity(snap, kernel)
    except adv.NAMED as exc:
        adv.assert_named(exc)


@settings(SUITE, max_examples=max(SUITE.max_examples // 3, 10))
@given(adv.snapshot_case(), adv.kernel_case(), st.data())
def test_coarse_grain_class(kw, kernel_case, data):
    snap = adv.make_snapshot(kw)
    kernel = adv.make_kernel(kernel_case)
    if snap is None or kernel is None:
        return
    frames = data.draw(st.sampled_from([[snap, snap], [snap, None], [snap, 3], snap, [], (s for s in [snap])]))
    time_average = data.draw(st.sampled_from(["mean", "none", 0.5, -1.0, "x", None, np.nan]))
    fields = data.draw(st.sampled_from(adv.FIELD_LISTS))
    cg_obj, exc = adv.call(cg.CoarseGrain, frames, cg.Grid(snap.box, 2), kernel, fields=fields,
                           time_average=time_average)
    if cg_obj is not None:
        done, exc = adv.call(cg_obj.run)
        if done is not None and isinstance(done.results, cg.Result) and "density" in done.results.fields:
            assert np.all(np.isfinite(np.asarray(done.results["density"])))


@settings(SUITE, max_examples=max(SUITE.max_examples // 3, 10))
@given(adv.snapshot_case(), adv.kernel_case(), st.data())
def test_momentum_balance_residual(kw, kernel_case, data):
    snap = adv.make_snapshot(kw)
    kernel = adv.make_kernel(kernel_case)
    if snap is None:
        return
    forces = None
    if data.draw(st.booleans()):
        forces = adv.hostile_array(data.draw, (snap.n_particles, snap.dim))
    adv.residual_case(snap, kernel, forces)


@settings(SUITE, max_examples=max(SUITE.max_examples // 10, 10))
@given(st.sampled_from(["file", "dir", "missing_dir", "empty", "none", "int"]),
       st.sampled_from([None, 0, 1, -1, "a", 2.0]))
def test_writers(path_kind, frame):
    box = adv.base_box(3)
    snap = cg.Snapshot([[0.5, 0.5, 0.5]], velocities=[[1.0, 0, 0]], masses=[1.0], box=box)
    out = cg.coarse_grain(snap, cg.Grid(box, 2), cg.Lucy(0.5), fields=("density", "velocity"))
    adv.writers_case(out, path_kind, frame)


# ------------------------------------------------------------------ the cases, one by one
@pytest.mark.parametrize("make", [lambda w: cg.Gaussian(w), lambda w: cg.Gaussian(1.0, cutoff=w), cg.Lucy,
                                  cg.Heaviside])
@pytest.mark.parametrize("length", [1e-104, 1e-200, 1e61, 1e200, 10 ** 400, 5e-324])
def test_kernel_lengths_outside_the_range_are_refused(make, length):
    with pytest.raises(ValueError, match=r"^(width|cutoff|radius): expected "):
        make(length)


@pytest.mark.parametrize("length", [1e-60, 1e60])
def test_kernel_lengths_at_the_range_ends_give_finite_fields(length):
    box = cg.Box([0, 0, 0], [1, 1, 1])
    snap = cg.Snapshot([[0.5, 0.5, 0.5]], velocities=[[1.0, 2.0, 0]], masses=[1.0], box=box)
    for kernel in (cg.Gaussian(length), cg.Lucy(length), cg.Heaviside(length)):
        out = cg.coarse_grain(snap, cg.Points([[0.5, 0.5, 0.5]]), kernel, fields=("density", "velocity"))
        assert np.isfinite(out["density"]).all() and out["density"][0] > 0
        np.testing.assert_allclose(out["velocity"][0], [1.0, 2.0, 0.0], rtol=1e-12)


def test_momentum_overflow_is_refused_naming_velocities():
    box = cg.Box([0, 0, 0], [1, 1, 1])
    with pytest.raises(ValueError, match="^velocities: "):
        cg.Snapshot([[0.5, 0.5, 0.5]], velocities=[[1e160, 0, 0]], masses=[1.0], box=box)
    with pytest.raises(ValueError, match="^velocities: "):
        cg.Snapshot([[0.5, 0.5, 0.5]], velocities=[[1e200, 0, 0]], masses=[1e200], box=box)
    # fixed particles carry no momentum: not refused
    cg.Snapshot([[0.5, 0.5, 0.5], [0.2, 0.2, 0.2]], velocities=[[1e200, 0, 0], [0, 0, 0]], masses=[1.0, 1.0],
                box=box, fixed=[True, False])


def test_force_times_branch_overflow_is_refused_naming_the_force():
    box = cg.Box([0, 0, 0], [1, 1, 1])
    contacts = cg.Contacts([0], [1], [[1e308, 0, 0]], [[0.4, 0.5, 0.5]])
    with pytest.raises(ValueError, match=r"^contacts\.force: "):
        cg.Snapshot([[0.3, 0.5, 0.5], [0.5, 0.5, 0.5]], velocities=np.zeros((2, 3)), masses=[1.0, 1.0], box=box,
                    contacts=contacts)


def test_peak_times_momentum_overflow_is_refused_before_work():
    box = cg.Box([0, 0, 0], [1, 1, 1])
    snap = cg.Snapshot([[0.5, 0.5, 0.5]], velocities=[[1e140, 0, 0]], masses=[1.0], box=box)
    with pytest.raises(ValueError, match="^width: the kernel's peak"):
        cg.coarse_grain(snap, cg.Grid(box, 2), cg.Gaussian(1e-50), fields=("density", "velocity"))
    out = cg.coarse_grain(snap, cg.Points([[0.5, 0.5, 0.5]]), cg.Gaussian(0.1), fields=("density", "velocity"))
    np.testing.assert_allclose(out["velocity"][0], [1e140, 0, 0], rtol=1e-12)


@pytest.mark.parametrize("fields", [("density",), ("stress",), ("extended_stress",)])
def test_kernel_far_wider_than_a_periodic_box_is_refused_naming_width(fields):
    """Was: 'a ray stays inside the evaluation region forever' (the core's image cap) or tens of seconds."""
    box = cg.Box([0, 0, 0], [1, 1, 1], periodic=(True, True, True))
    rng = np.random.default_rng(1)
    snap = cg.Snapshot(rng.random((5, 3)), np.zeros((5, 3)), np.ones(5), box=box,
                       contacts=cg.Contacts([0], [1], [[1.0, 0, 0]], [[0.5, 0.5, 0.5]]))
    for kernel in (cg.Gaussian(40.0), cg.Gaussian(1e20), cg.Lucy(1e25)):
        with pytest.raises(ValueError, match=r"^(width|cutoff): expected a kernel whose support .* reaching "
                                             r"[0-9.e+]+ images on the periodic box "
                                             r"\(lengths x 1, y 1, z 1\)"):
            cg.coarse_grain(snap, cg.Grid(box, 2), kernel, fields=fields)
        with pytest.raises(ValueError, match=r"^(width|cutoff): "):
            cg.momentum_balance_residual(snap, [[0.5, 0.5, 0.5]], kernel) if kernel.differentiable else None


def test_wide_kernel_on_a_non_periodic_box_is_fine():
    box = cg.Box([0, 0, 0], [1, 1, 1])
    snap = cg.Snapshot([[0.3, 0.5, 0.5], [0.6, 0.5, 0.5]], np.zeros((2, 3)), [1.0, 1.0], box=box,
                       contacts=cg.Contacts([0], [1], [[1.0, 0, 0]], [[0.45, 0.5, 0.5]]))
    out = cg.coarse_grain(snap, cg.Grid(box, 2), cg.Gaussian(1e20), fields=("density", "stress"))
    assert np.isfinite(out["stress"]).all() and (out["density"] > 0).all()


def test_huge_grids_are_memory_errors_naming_shape_before_allocating():
    box = cg.Box([0, 0, 0], [1, 1, 1])
    for shape in [(10 ** 12, 1, 1), (2 ** 62, 1, 1)]:
        with pytest.raises(MemoryError, match="^shape: expected a request that fits in memory"):
            cg.Grid(box, shape)


def test_grid_own_arrays_are_counted_before_allocating(monkeypatch):
    """Was: Grid(box, (3e8, 1, 1)) refused only after 12.8 s and 4.7 GB: its own node coordinates (2.4 GB here)
    are in the estimate, so on a machine without that memory it is refused before allocating them."""
    import tracemalloc
    from cgbound import _memory
    monkeypatch.setattr(_memory, "physical_memory", lambda: 10 ** 9)
    box = cg.Box([0, 0, 0], [1, 1, 1])
    tracemalloc.start()
    try:
        with pytest.raises(MemoryError, match=r"^shape: expected a request that fits in memory, got one needing "
                                              r"about 2\.4 GB \(300000002 doubles of the grid itself"):
            cg.Grid(box, (3 * 10 ** 8, 1, 1))
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 20e6, f"{peak / 1e6:.1f} MB allocated before the MemoryError"
    assert cg.Grid(box, (1000, 1, 1)).shape == (1000, 1, 1)   # a grid that fits is still built


def test_ints_beyond_float_are_named_value_errors():
    with pytest.raises(ValueError, match="^width: expected a number within the floating-point range"):
        cg.Gaussian(10 ** 400)
    with pytest.raises(ValueError, match="^time: "):
        cg.Snapshot([[0.5, 0.5, 0.5]], masses=[1.0], time=10 ** 400)


def test_extended_stress_at_zero_points_is_empty():
    box = cg.Box([0, 0, 0], [1, 1, 1], periodic=(True, True, False))
    snap = cg.Snapshot([[0.2, 0.2, 0.5], [0.4, 0.2, 0.5]], velocities=np.zeros((2, 3)), masses=[1.0, 1.0], box=box,
                       contacts=cg.Contacts([0], [1], [[1.0, 0, 0]], [[0.3, 0.2, 0.5]]))
    out = cg.coarse_grain(snap, np.zeros((0, 3)), cg.Gaussian(0.1), fields=("density", "extended_stress"))
    assert out["extended_stress"].shape == (0, 3, 3) and out["density"].shape == (0,)


@pytest.mark.parametrize("scale", [1e-150, 1e-60, 1e60, 1e150, 1e290])
def test_extreme_but_representable_data_gives_finite_fields_or_a_named_error(scale):
    """Velocities, forces and positions at extreme scales: finite fields where the density is positive, or an
    error naming the user's argument (never the core's internal 'values:' / 'vectors:' / 'node_velocity:')."""
    box = cg.Box([0, 0, 0], [1, 1, 1], periodic=(True, False, False))
    pos = np.array([[0.2, 0.5, 0.5], [0.4, 0.5, 0.5], [0.6, 0.5, 0.5]])
    contacts = cg.Contacts([0, 1], [1, -1], [[scale, 0, 0], [0, scale, 0]], [[0.3, 0.5, 0.5], [0.4, 0.5, 0.45]])
    fields = ("density", "velocity", "stress", "extended_stress", "temperature", "interaction_force_density")
    for velocities, masses in [(np.full((3, 3), scale), np.ones(3)), (np.ones((3, 3)), np.full(3, scale))]:
        snap, exc = adv.call(cg.Snapshot, pos, velocities=velocities, masses=masses, box=box, contacts=contacts,
                             body_force=[0, 0, -scale])
        if snap is None:
            continue
        out, exc = adv.call(cg.coarse_grain, snap, cg.Grid(box, (4, 2, 2)), cg.Gaussian(0.2), fields=fields)
        if out is not None:
            adv.check_result(out, snap, None)


def test_huge_ints_in_arrays_are_named_value_errors():
    with pytest.raises(ValueError, match="^positions: expected numbers within the floating-point range"):
        cg.Snapshot([[0, 0, 10 ** 400]], masses=[1.0])
    with pytest.raises(ValueError, match="^upper: "):
        cg.Box([0, 0], [1, 10 ** 400])


def test_fuzz_finds_fixed():
    """Cases tools/fuzz_api.py found: a node count beyond a double, particle volumes that overflow."""
    box = cg.Box([0, 0], [1, 1])
    with pytest.raises(MemoryError, match="^shape: "):
        cg.Grid(box, 10 ** 400)
    with pytest.raises(ValueError, match="^radii: "):
        cg.Snapshot([[0.5, 0.5]], masses=[1.0], radii=[9e298], box=box)
    with pytest.raises(ValueError, match=r"^periodic: "):
        cg.Box([0, 0], [1, 1], periodic=[False, []])
    with pytest.raises(ValueError, match="^grid: expected averaged axes"):
        snap = cg.Snapshot([[1e-301, 1e-301]], masses=[1e-300], box=cg.Box([0, 0], [1e-300, 1e-300]))
        cg.coarse_grain(snap, cg.Grid(snap.box, 1, average=(0, 1)), cg.Lucy(1e-60), fields=("density",))


def test_kernel_infinitely_many_periods_wide_is_refused():
    """Found by tools/fuzz_api.py: 2 R / L overflowing gave OverflowError from the image count."""
    box = cg.Box([0, 0], [1e-300, 1e-300], periodic=True)
    snap = cg.Snapshot([[0.5e-300, 0.5e-300]], masses=[1.0], box=box)
    with pytest.raises(ValueError, match="^cutoff: expected a kernel whose support"):
        cg.coarse_grain(snap, cg.Points([[0.5e-300, 0.5e-300]]), cg.Lucy(1e60), fields=("density",))
