"""The public API: shapes, field selection, sign convention, time averaging, species."""
import warnings

import numpy as np
import pytest

import cgbound as cg
import cgbound.fields
from helpers import assert_fields_close, random_snapshot
from oracle import oracle_coarse_grain

LINEAR = ("density", "momentum", "momentum_flux", "contact_stress", "boundary_stress",
          "interaction_force_density", "body_force_density")


def test_result_shapes_follow_the_grid():
    snap = random_snapshot(1, dim=3)
    grid = cg.Grid(snap.box, (1, 1, 40), average=("x", "y"))
    out = cg.coarse_grain(snap, grid, cg.Gaussian(0.4), fields=("density", "velocity", "stress"))
    assert out.density.shape == (1, 1, 40)
    assert out.velocity.shape == (1, 1, 40, 3)
    assert out.stress.shape == (1, 1, 40, 3, 3)
    assert out.coordinates.shape == (1, 1, 40, 3)
    np.testing.assert_allclose(out.coordinates[0, 0, :, 2], snap.box.lower[2] + (np.arange(40) + 0.5) * snap.box.lengths[2] / 40)
    assert "density" in repr(out) and out.fields == ("density", "velocity", "stress")
    with pytest.raises(AttributeError, match="not requested"):
        out.pressure


def test_points_accept_arrays():
    snap = random_snapshot(2, dim=2)
    pts = snap.box.lower + 0.5 * snap.box.lengths + np.zeros((3, 2))
    a = cg.coarse_grain(snap, pts, cg.Lucy(1.2), fields=("density",))
    b = cg.coarse_grain(snap, cg.Points(pts), cg.Lucy(1.2), fields=("density",))
    assert a.density.shape == (3,)
    np.testing.assert_array_equal(a.density, b.density)


class Forbidden:
    """Stands in for the core: any contact work raises."""

    def __init__(self, real):
        self.real = real

    def scatter_segments(self, *args, **kwargs):
        raise AssertionError("a contact loop ran although no contact field was requested")

    scatter_segments_outer = scatter_segments

    def __getattr__(self, name):
        return getattr(self.real, name)


def test_no_contact_work_without_contact_fields(monkeypatch):
    snap = random_snapshot(3, dim=3)
    monkeypatch.setattr(cgbound._engine, "_core", Forbidden(cgbound._engine._core))
    monkeypatch.setattr(cg.Snapshot, "split_contacts", lambda self: (_ for _ in ()).throw(AssertionError("split")))
    grid = cg.Grid(snap.box, (4, 4, 4))
    out = cg.coarse_grain(snap, grid, cg.Gaussian(0.5), fields=("density", "velocity", "kinetic_stress",
                                                                "temperature", "body_force_density"))
    assert np.all(np.isfinite(out.density))
    with pytest.raises(AssertionError, match="contact loop|split"):
        cg.coarse_grain(snap, grid, cg.Gaussian(0.5), fields=("contact_stress",))


def test_only_requested_primaries_are_computed(monkeypatch):
    snap = random_snapshot(4, dim=3)
    calls = []
    real = cgbound._engine._core

    class Counting:
        def __getattr__(self, name):
            fn = getattr(real, name)
            # only the scatters: the engine also asks the core for its thread defaults
            return lambda *a, **k: (name.startswith("scatter") and calls.append(name), fn(*a, **k))[1]

    monkeypatch.setattr(cgbound._engine, "_core", Counting())
    cg.coarse_grain(snap, cg.Grid(snap.box, (3, 3, 3)), cg.Gaussian(0.5), fields=("density",))
    assert calls == ["scatter_points_kinetic"]    # (the masses' column formed in the core)
    calls.clear()
    cg.coarse_grain(snap, cg.Grid(snap.box, (3, 3, 3)), cg.Gaussian(0.5), fields=("interaction_force_density",))
    assert "scatter_segments" not in calls and "scatter_fluctuation" not in calls


def test_static_snapshot_skips_the_kinetic_pass(monkeypatch):
    snap = random_snapshot(5, dim=3, velocities=False)
    monkeypatch.setattr(cgbound._engine, "_core", type("NoKinetic", (), {
        "__getattr__": lambda self, n: getattr(cgbound._core, n),
        "scatter_fluctuation": lambda self, *a, **k: (_ for _ in ()).throw(AssertionError("kinetic pass"))})())
    out = cg.coarse_grain(snap, cg.Grid(snap.box, (3, 3, 3)), cg.Lucy(1.5), fields=("stress",))
    assert np.any(out.stress != 0)


def test_compression_convention_flips_stresses_only():
    snap = random_snapshot(6, dim=3)
    grid = cg.Grid(snap.box, (3, 3, 4))
    fields = ("stress", "kinetic_stress", "contact_stress", "boundary_stress", "extended_stress", "pressure",
              "interaction_force_density")
    t = cg.coarse_grain(snap, grid, cg.Gaussian(0.5), fields=fields)
    c = cg.coarse_grain(snap, grid, cg.Gaussian(0.5), fields=fields, convention="compression")
    for name in fields[:5]:
        np.testing.assert_array_equal(c[name], -t[name])
    np.testing.assert_array_equal(c.pressure, t.pressure)
    np.testing.assert_array_equal(c.interaction_force_density, t.interaction_force_density)
    # pressure is compression-positive: a compressed static packing has positive pressure
    np.testing.assert_allclose(t.pressure, -np.trace(t.stress, axis1=-2, axis2=-1) / 3, rtol=1e-14)


def test_empty_regions_give_nan_velocity_and_zero_elsewhere_without_warnings():
    snap = random_snapshot(7, dim=3, lengths=(4, 3.5, 30.0))
    grid = cg.Grid(snap.box, (1, 1, 120), average=("x", "y"))
    R = 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = cg.coarse_grain(snap, grid, cg.Lucy(R), fields=("density", "velocity", "temperature", "stress",
                                                              "interaction_force_density"))
    z = grid.axis_coordinates[2]
    ends = np.concatenate([snap.positions[:, 2], snap.contacts.point[:, 2]])
    beyond = (z < ends.min() - R) | (z > ends.max() + R)   # no particle, contact or branch reaches here
    assert beyond.any()
    empty = out.density[0, 0] == 0
    assert np.all(empty[beyond])
    assert np.all(np.isnan(out.velocity[0, 0][empty])) and np.all(np.isnan(out.temperature[0, 0][empty]))
    assert np.all(np.isfinite(out.velocity[0, 0][~empty]))
    assert np.all(out.stress[0, 0][beyond] == 0) and np.all(out.interaction_force_density[0, 0][beyond] == 0)


# --- many snapshots ----------------------------------------------------------------

def frames(n=4, dim=3):
    base = random_snapshot(8, dim=dim)
    out = []
    rng = np.random.default_rng(1)
    for k in range(n):
        c = base.contacts
        out.append(cg.Snapshot(base.positions + 0.05 * rng.normal(size=base.positions.shape),
                               base.velocities + rng.normal(size=base.velocities.shape) + [3.0, 0, 0][:dim],
                               base.masses, box=base.box,
                               contacts=cg.Contacts(c.i, c.j, c.force * (1 + 0.1 * k), c.point),
                               fixed=base.fixed, body_force=base.body_force, radii=base.radii, time=0.5 * k))
    return out


def test_mean_over_snapshots():
    snaps = frames()
    grid = cg.Grid(snaps[0].box, (1, 1, 12), average=("x", "y"))
    kernel = cg.Gaussian(0.5)
    fields = LINEAR + ("kinetic_stress", "velocity")
    avg = cg.CoarseGrain(snaps, grid, kernel, fields=fields).run()
    assert avg.run() is avg
    per = [oracle_coarse_grain(s, grid, kernel, fields) for s in snaps]
    for name in LINEAR:
        mean = np.mean([p[name] for p in per], axis=0)
        assert_fields_close(avg.results[name].reshape(mean.shape), mean, 1e-10, name)
    rho = np.mean([p["density"] for p in per], axis=0)
    mom = np.mean([p["momentum"] for p in per], axis=0)
    flux = np.mean([p["momentum_flux"] for p in per], axis=0)
    V = mom / rho[:, None]
    expected = -(flux - rho[:, None, None] * V[:, :, None] * V[:, None, :])
    assert_fields_close(avg.results.kinetic_stress.reshape(expected.shape), expected, 1e-10, "kinetic stress")
    assert_fields_close(avg.results.velocity.reshape(V.shape), V, 1e-10, "velocity")
    assert avg.results.times == pytest.approx([np.mean([s.time for s in snaps])])


def test_frames_start_stop_step_and_none():
    snaps = frames(5)
    grid = cg.Grid(snaps[0].box, (2, 2, 3))
    kernel = cg.Lucy(1.3)
    run = cg.CoarseGrain(snaps, grid, kernel, fields=("density", "stress"), time_average="none").run(1, 5, 2)
    assert run.results.density.shape == (2, 2, 2, 3)
    for k, index in enumerate([1, 3]):
        single = cg.coarse_grain(snaps[index], grid, kernel, fields=("stress",))
        np.testing.assert_allclose(run.results.stress[k], single.stress, rtol=1e-13, atol=1e-15)
    np.testing.assert_array_equal(run.results.times, [0.5, 1.5])


def test_iterables_and_progress(capsys):
    snaps = frames(3)
    grid = cg.Grid(snaps[0].box, (1, 1, 5), average=("x", "y"))
    a = cg.CoarseGrain(iter(snaps), grid, cg.Lucy(1.3), fields=("density",)).run(verbose=True)
    b = cg.CoarseGrain(snaps, grid, cg.Lucy(1.3), fields=("density",)).run()
    np.testing.assert_allclose(a.results.density, b.results.density, rtol=1e-15)


def test_gaussian_time_smoothing():
    snaps = frames(5)
    grid = cg.Grid(snaps[0].box, (1, 1, 6), average=("x", "y"))
    kernel = cg.Gaussian(0.5)
    tau = 0.6
    run = cg.CoarseGrain(snaps, grid, kernel, fields=LINEAR, time_average=tau, times=[0.3, 1.1]).run()
    per = [cg.coarse_grain(s, grid, kernel, fields=LINEAR) for s in snaps]
    for k, t_out in enumerate([0.3, 1.1]):
        w = np.array([np.exp(-0.5 * ((s.time - t_out) / tau) ** 2) for s in snaps])
        for name in LINEAR:
            expected = sum(wi * p[name] for wi, p in zip(w, per)) / w.sum()
            assert_fields_close(run.results[name][k], expected, 1e-12, name)


def test_bad_frame_is_named():
    snaps = frames(3)
    snaps[1] = "not a snapshot"
    with pytest.raises(TypeError, match="frame 1"):
        cg.CoarseGrain(snaps, cg.Grid(snaps[0].box, (2, 2, 2)), cg.Lucy(1.0)).run()


# --- species -----------------------------------------------------------------------

def two_species(seed):
    rng = np.random.default_rng(seed)
    n = 16
    box = cg.Box([0, 0, 0], [4, 4, 6], periodic=(True, True, False))
    pos = rng.uniform([0, 0, 1], [4, 4, 5], (n, 3))
    species = rng.integers(0, 2, n)
    I, J, F, C = [], [], [], []
    for _ in range(12):
        i, j = rng.choice(n, 2, replace=False)
        if (i, j) in zip(I, J) or (j, i) in zip(I, J):
            continue
        d = pos[j] - pos[i]
        d[:2] -= 4 * np.round(d[:2] / 4)
        I.append(i); J.append(j); F.append(rng.normal(size=3)); C.append(pos[i] + rng.uniform(0.2, 0.8) * d)
    return cg.Snapshot(pos, rng.normal(size=(n, 3)), rng.uniform(1, 2, n), box=box,
                       contacts=cg.Contacts(I, J, F, C), species=species)


def test_a_species_in_no_frame_is_an_error_not_zero_fields():
    snap = two_species(3)
    grid = cg.Grid(snap.box, (2, 2, 3))
    with pytest.raises(ValueError, match=r"species: 7 is not among the snapshot's flowing particles \(their species: "
                                         r"\[0, 1\]"):
        cg.coarse_grain(snap, grid, cg.Gaussian(0.5), fields=("density",), species=7)
    # a species only among the fixed particles: the species view keeps them fixed, so its fields are zero too
    base = cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box, contacts=snap.contacts,
                       species=snap.species, fixed=snap.species == 1)
    with pytest.raises(ValueError, match=r"species: 1 is not among the snapshot's flowing particles"):
        cg.coarse_grain(base, grid, cg.Gaussian(0.5), fields=("density",), species=1)
    with pytest.raises(ValueError, match=r"species: 1 is in none of the 1 frames read \(species of flowing particles "
                                         r"present: \[0\]; fixed particles do not count\)"):
        cg.CoarseGrain([base], grid, cg.Gaussian(0.5), fields=("density",), species=1).run()
    with pytest.raises(ValueError, match=r"species: 7 is in none of the 2 frames read"):
        cg.CoarseGrain([snap, two_species(4)], grid, cg.Gaussian(0.5), fields=("density",), species=7).run()
    # a species absent from some frames only (inserted later, say) is fine
    other = two_species(5)
    only_zero = cg.Snapshot(other.positions, other.velocities, other.masses, box=other.box, contacts=other.contacts,
                            species=np.zeros(other.n_particles, int))
    out = cg.CoarseGrain([only_zero, snap], grid, cg.Gaussian(0.5), fields=("density",), species=1).run()
    assert out.results.density.max() > 0


def test_species_partial_fields_add_up_and_interaction_is_antisymmetric():
    snap = two_species(3)
    grid = cg.Grid(snap.box, (4, 4, 6))
    kernel = cg.Gaussian(0.5)
    fields = ("density", "momentum", "contact_stress", "boundary_stress", "interaction_force_density")
    total = cg.coarse_grain(snap, grid, kernel, fields=fields)
    a = cg.coarse_grain(snap, grid, kernel, fields=fields, species=0)
    b = cg.coarse_grain(snap, grid, kernel, fields=fields, species=1)
    assert_fields_close(a.density + b.density, total.density, 1e-13, "density")
    assert_fields_close(a.momentum + b.momentum, total.momentum, 1e-13, "momentum")
    assert np.abs(a.interaction_force_density).max() > 0
    assert_fields_close(a.interaction_force_density, -b.interaction_force_density, 1e-13, "IFD")
    # contact points on the centre lines: the two partial stresses rebuild the bulk stress
    partial = a.contact_stress + a.boundary_stress + b.contact_stress + b.boundary_stress
    assert_fields_close(partial, total.contact_stress, 1e-12, "contact stress")


def test_the_gil_is_released_during_core_work():
    """While a long computation runs in a thread, the main thread keeps running Python code."""
    import threading
    import time

    rng = np.random.default_rng(0)
    box = cg.Box([0, 0, 0], [10, 10, 10])
    snap = cg.Snapshot(rng.uniform(0, 10, (10000, 3)), None, np.ones(10000), box=box)
    grid = cg.Grid(box, (40, 40, 40))
    kernel = cg.Lucy(4.0)  # a wide Lucy: long enough to tell (the separable Gaussian is too fast)
    start = time.perf_counter()
    cg.coarse_grain(snap, grid, kernel, fields=("density",))
    single = time.perf_counter() - start
    worker = threading.Thread(target=cg.coarse_grain, args=(snap, grid, kernel), kwargs={"fields": ("density",)})
    stamps = []
    worker.start()
    while worker.is_alive():
        stamps.append(time.perf_counter())
        time.sleep(0.001)
    worker.join()
    assert single > 0.2, "workload too small to tell"
    gaps = np.diff(stamps)
    assert len(stamps) > 20 and gaps.max() < 0.25 * single


def test_jupyter_repr_lists_every_field():
    snap = random_snapshot(9, dim=2)
    out = cg.coarse_grain(snap, cg.Grid(snap.box, (4, 5)), cg.Lucy(1.2), fields=("density", "stress"))
    page = out._repr_html_()
    assert "<table>" in page and "<code>density</code>" in page and "(4, 5, 2, 2)" in page
