"""CoarseGrain on a CylindricalGrid: time averages of the ring-averaged primaries, derived once (as on a Grid),
against per-frame results averaged by hand; block errors; writers."""
import json
import warnings

import numpy as np
import pytest

import cgbound as cg
from helpers import random_snapshot

#: primaries as fields (linear in the data: their time average is the average of the frames' values)
LINEAR = ("density", "momentum", "momentum_flux", "contact_stress", "boundary_stress",
          "interaction_force_density", "body_force_density", "density_gradient", "momentum_gradient")
DERIVED = ("velocity", "kinetic_stress", "stress", "pressure", "temperature", "velocity_gradient")


def frames(n=5):
    """Frames in one box: the same particles moved a little, new velocities and contact forces."""
    base = random_snapshot(3, n=40, n_bulk=30, lengths=[6.0, 6.0, 5.0], periodic=(False, False, False))
    rng = np.random.default_rng(11)
    out = []
    for k in range(n):
        c = base.contacts
        contacts = cg.Contacts(c.i, c.j, c.force * rng.uniform(0.5, 1.5, (len(c.i), 1)), c.point)
        out.append(cg.Snapshot(base.positions + 0.05 * rng.normal(size=base.positions.shape),
                               rng.normal(size=base.positions.shape) + [0.3, -0.2, 0.5], base.masses, box=base.box,
                               contacts=contacts, fixed=base.fixed, body_force=base.body_force, radii=base.radii,
                               time=0.1 * k))
    return out


def ring_grid(snap, **kw):
    c = 0.5 * (snap.box.lower + snap.box.upper)
    return cg.CylindricalGrid(snap.box, c, "z", **({"r": (0.0, 2.0, 4), "z": (-1.0, 1.0, 3)} | kw))


def by_hand(snaps, grid, kernel):
    """The time average from per-frame results: linear fields averaged, the others derived from those."""
    per = [cg.coarse_grain(s, grid, kernel, fields=LINEAR) for s in snaps]
    mean = {f: np.mean([getattr(r, f) for r in per], axis=0) for f in LINEAR}
    rho, p, k = mean["density"], mean["momentum"], mean["momentum_flux"]
    mean["velocity"] = p / rho[..., None]
    mean["kinetic_stress"] = np.einsum("...i,...j->...ij", p, p) / rho[..., None, None] - k
    mean["stress"] = mean["kinetic_stress"] + mean["contact_stress"] + mean["boundary_stress"]
    mean["pressure"] = -np.trace(mean["stress"], axis1=-2, axis2=-1) / 3
    mean["temperature"] = -np.trace(mean["kinetic_stress"], axis1=-2, axis2=-1) / (3 * rho)
    V = mean["velocity"]
    mean["velocity_gradient"] = (mean["momentum_gradient"] - V[..., :, None] * mean["density_gradient"][..., None, :]) \
        / rho[..., None, None]
    return mean


@pytest.mark.parametrize("kw", [{}, {"z": None}, {"theta": 3}])
def test_time_mean_is_mean_of_frame_primaries(kw):
    snaps = frames()
    grid = ring_grid(snaps[0], **kw)
    kernel = cg.Gaussian(0.4, cutoff=4.0)
    got = cg.CoarseGrain(snaps, grid, kernel, fields=LINEAR + DERIVED).run().results
    want = by_hand(snaps, grid, kernel)
    assert got.n_frames == len(snaps) and got.grid is grid
    for f in LINEAR + DERIVED:
        scale = np.abs(want[f]).max()
        assert scale > 0, f
        assert getattr(got, f).shape == want[f].shape, f
        np.testing.assert_allclose(getattr(got, f), want[f], rtol=0, atol=1e-13 * scale, err_msg=f)


def test_time_mean_is_not_mean_of_frame_velocities():
    """The averaged velocity is the ratio of averages, and it differs from the average of ratios here
    (the test above could not pass with the latter)."""
    snaps = frames()
    grid = ring_grid(snaps[0])
    kernel = cg.Gaussian(0.4, cutoff=4.0)
    got = cg.CoarseGrain(snaps, grid, kernel, fields=("velocity",)).run().results.velocity
    naive = np.mean([cg.coarse_grain(s, grid, kernel, fields=("velocity",)).velocity for s in snaps], axis=0)
    assert np.abs(got - naive).max() > 1e-4 * np.abs(got).max()


def test_none_and_smoothing_match_single_frames():
    snaps = frames(3)
    grid = ring_grid(snaps[0])
    kernel = cg.Gaussian(0.4, cutoff=4.0)
    fields = ("density", "velocity", "stress")
    stacked = cg.CoarseGrain(snaps, grid, kernel, fields=fields, time_average="none").run().results
    for k, s in enumerate(snaps):
        one = cg.coarse_grain(s, grid, kernel, fields=fields)
        for f in fields:
            np.testing.assert_array_equal(getattr(stacked, f)[k], getattr(one, f), err_msg=f)
    smooth = cg.CoarseGrain(snaps, grid, kernel, fields=fields, time_average=1e-3).run().results
    for k, s in enumerate(snaps):   # frames 0.1 apart, width 1e-3: each output time sees one frame
        one = cg.coarse_grain(s, grid, kernel, fields=fields)
        for f in fields:
            np.testing.assert_allclose(getattr(smooth, f)[k], getattr(one, f), rtol=1e-13,
                                       atol=1e-13 * np.abs(getattr(one, f)).max(), err_msg=f)


def test_block_errors_from_block_means():
    snaps = frames(6)
    grid = ring_grid(snaps[0])
    kernel = cg.Gaussian(0.4, cutoff=4.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cg.CorrelatedBlocksWarning)   # 3 random blocks: a chance correlation
        run = cg.CoarseGrain(snaps, grid, kernel, fields=("density", "velocity"), errors="blocks", n_blocks=3).run()
    blocks = [by_hand(snaps[2 * b:2 * b + 2], grid, kernel) for b in range(3)]
    for f in ("density", "velocity"):
        means = np.array([b[f] for b in blocks])
        want = means.std(axis=0, ddof=1) / np.sqrt(3)
        assert run.results.errors[f].shape == run.results[f].shape
        np.testing.assert_allclose(run.results.errors[f], want, rtol=1e-10, atol=1e-13 * want.max(), err_msg=f)


def test_species_and_bad_input():
    snaps = frames(2)
    grid = ring_grid(snaps[0])
    with pytest.raises(ValueError, match="kernel"):
        cg.CoarseGrain(snaps, grid, cg.Heaviside(0.5), fields=("velocity_gradient",))
    flat = [cg.Snapshot(s.positions[:, :2], s.velocities[:, :2], s.masses,
                        box=cg.Box(s.box.lower[:2], s.box.upper[:2])) for s in snaps]
    with pytest.raises(ValueError, match="frame 0: snapshot: expected a 3-D snapshot"):
        cg.CoarseGrain(flat, grid, cg.Gaussian(0.4)).run()


def test_writers_on_cylindrical_results(tmp_path):
    h5py = pytest.importorskip("h5py")
    snaps = frames(2)
    grid = ring_grid(snaps[0], theta=3)
    res = cg.CoarseGrain(snaps, grid, cg.Gaussian(0.4, cutoff=4.0), fields=("density", "velocity", "stress")).run().results
    path = res.to_hdf5(tmp_path / "cyl.h5")
    with h5py.File(path) as f:
        np.testing.assert_array_equal(f["fields/stress"][()], res.stress)
        np.testing.assert_array_equal(f["coordinates"][()], grid.coordinates)
        for name in ("r", "theta", "z"):
            np.testing.assert_array_equal(f[f"axes/{name}"][()], getattr(grid, name))
        assert json.loads(f.attrs["cylindrical"])["axis"] == [0.0, 0.0, 1.0]
        assert list(f.attrs["components"]) == ["r", "theta", "z"]
    npz = np.load(res.to_npz(tmp_path / "cyl.npz"))
    np.testing.assert_array_equal(npz["velocity"], res.velocity)
    assert json.loads(str(npz["metadata"]))["grid_shape"] == [4, 3, 3]
    ds = res.to_xarray()
    assert ds["stress"].dims == ("r", "theta", "z", "component", "component2")
    assert list(ds["component"].values) == ["r", "theta", "z"]
    np.testing.assert_array_equal(ds["r"].values, grid.r)
    with pytest.raises(TypeError, match="VTK"):
        res.to_vtk(tmp_path / "cyl.vtk")


def test_reader_frames_read_ahead_on_the_silo():
    """A reader (frames read one ahead in a thread): the genuine silo frames, averaged by hand."""
    import os
    from cgbound.paper.scenes import SILO_TIMESTEP
    from cgbound.paper.scenes.lammps import PAIR_VALUES
    from cgbound.readers.lammps import LammpsReader
    data = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "lammps", "silo")
    reader = LammpsReader(os.path.join(data, "frames.atoms.dump.gz"), os.path.join(data, "frames.pairs.dump.gz"),
                          pair_values=PAIR_VALUES, walls=["wall0", "wall1"], body_force=(0.0, 0.0, -1.0),
                          dt=SILO_TIMESTEP)
    grid = cg.CylindricalGrid(reader[0].box, (0.0, 0.0, 0.0), "z", r=(0.0, 4.5, 5), z=(0.0, 8.0, 3))
    kernel = cg.Gaussian(0.5)
    got = cg.CoarseGrain(reader, grid, kernel, fields=LINEAR + DERIVED).run().results
    want = by_hand([reader[k] for k in range(len(reader))], grid, kernel)
    assert got.n_frames == len(reader) == 2
    for f in LINEAR + DERIVED:
        np.testing.assert_allclose(getattr(got, f), want[f], rtol=0, atol=1e-13 * np.abs(want[f]).max(), err_msg=f)
