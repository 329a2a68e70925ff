"""HDF5 snapshot schema round trip; result writers read back with independent readers; atomic writes."""
import json
import os
import pickle

import numpy as np
import pytest

import cgbound as cg
from helpers import random_snapshot

h5py = pytest.importorskip("h5py")
from cgbound.readers.hdf5 import HDF5Snapshots, write_snapshots  # noqa: E402


def same_snapshot(a, b):
    for name in ("positions", "velocities", "masses", "fixed", "radii", "body_force", "species", "angular_velocities",
                 "torques", "moments_of_inertia"):
        x, y = getattr(a, name), getattr(b, name)
        if x is None or y is None:
            assert x is None and y is None, name
        else:
            np.testing.assert_array_equal(x, y, err_msg=name)
    for name in ("i", "j", "force", "point"):
        np.testing.assert_array_equal(getattr(a.contacts, name), getattr(b.contacts, name))
    assert a.box == b.box and a.time == b.time


def test_snapshot_file_round_trip_lazy_and_picklable(tmp_path):
    snaps = [random_snapshot(k, dim=3) for k in range(4)] + [random_snapshot(9, dim=3, velocities=False)]
    path = tmp_path / "snaps.h5"
    assert write_snapshots(path, snaps, provenance={"source": "test"}) == 5
    reader = HDF5Snapshots(path)
    assert len(reader) == 5 and json.loads(reader.provenance) == {"source": "test"}
    for a, b in zip(snaps, reader):
        same_snapshot(a, b)
    part = reader[1:5:2]
    assert len(part) == 2
    same_snapshot(part[1], snaps[3])
    clone = pickle.loads(pickle.dumps(part))
    assert len(pickle.dumps(part)) < 1000      # carries the path, not arrays
    same_snapshot(clone[0], snaps[1])
    with pytest.raises(IndexError, match="index"):
        reader[7]
    avg = cg.CoarseGrain(reader, cg.Grid(snaps[0].box, (1, 1, 8), average=("x", "y")), cg.Lucy(1.0),
                         fields=("density",)).run()
    direct = cg.CoarseGrain(snaps, cg.Grid(snaps[0].box, (1, 1, 8), average=("x", "y")), cg.Lucy(1.0),
                            fields=("density",)).run()
    np.testing.assert_array_equal(avg.results.density, direct.results.density)


@pytest.mark.parametrize("dim", [2, 3])
def test_snapshot_file_keeps_angular_velocities_torques_and_moments_of_inertia(tmp_path, dim):
    rng = np.random.default_rng(dim)
    base = random_snapshot(5, dim=dim)
    n, spin = base.n_particles, (3,) if dim == 3 else ()
    snap = cg.Snapshot(base.positions, base.velocities, base.masses, box=base.box, contacts=base.contacts,
                       fixed=base.fixed, radii=base.radii, time=1.5, angular_velocities=rng.normal(size=(n,) + spin),
                       torques=rng.normal(size=(n,) + spin), moments_of_inertia=rng.uniform(0.1, 1.0, n))
    path = tmp_path / "spin.h5"
    write_snapshots(path, [snap, base])
    back = HDF5Snapshots(path)
    same_snapshot(back[0], snap)
    same_snapshot(back[1], base)          # absent stays absent
    where = cg.Points(base.positions[:3])
    np.testing.assert_array_equal(cg.rotation_fields(back[0], where, cg.Lucy(1.5), ("spin_density",))["spin_density"],
                                  cg.rotation_fields(snap, where, cg.Lucy(1.5), ("spin_density",))["spin_density"])


def write_snapshots_before_0_10(path, snapshots):
    """The layout write_snapshots wrote before the contiguous default (h5py's automatic chunks, gzip 4 and
    shuffle on every non-empty dataset), kept here so files of older versions stay read."""
    def put(group, name, data):
        data = np.asarray(data)
        kwargs = dict(chunks=True, compression="gzip", compression_opts=4, shuffle=True) if data.size else {}
        group.create_dataset(name, data=data, **kwargs)

    with h5py.File(path, "w", libver="latest") as f:
        f.attrs["format"], f.attrs["schema_version"] = "cgbound-snapshots", 1
        f.attrs["cgbound_version"], f.attrs["provenance"] = "0.9", "{}"
        frames = f.create_group("frames")
        for k, snap in enumerate(snapshots):
            g = frames.create_group(f"{k:06d}")
            g.attrs["time"] = snap.time
            if k == 0:
                b = f.create_group("box")
                b.attrs["lower"], b.attrs["upper"] = snap.box.lower, snap.box.upper
                b.attrs["periodic"] = np.array(snap.box.periodic)
                f.attrs["dim"] = snap.dim
            elif snap.box != snapshots[0].box:
                g.attrs["lower"], g.attrs["upper"] = snap.box.lower, snap.box.upper
                g.attrs["periodic"] = np.array(snap.box.periodic)
            for name in ("positions", "masses", "velocities", "radii", "species", "body_force"):
                if getattr(snap, name) is not None:
                    put(g, name, np.ascontiguousarray(getattr(snap, name)))
            if snap.fixed.any():
                put(g, "fixed", snap.fixed)
            c = g.create_group("contacts")
            for name in ("i", "j", "force", "point"):
                put(c, name, getattr(snap.contacts, name))
        f.attrs["n_frames"] = len(snapshots)


@pytest.mark.parametrize("compression", [None, "gzip", "lzf"])
def test_snapshot_file_layouts_read_back_the_same(tmp_path, compression):
    snaps = [random_snapshot(k, dim=3) for k in range(3)]
    path = tmp_path / "snaps.h5"
    write_snapshots(path, snaps, compression=compression)
    with h5py.File(path, "r") as f:
        for name in ("positions", "masses", "velocities"):
            data = f["frames/000001"][name]
            assert data.compression == compression, name
            if compression is None:
                assert data.chunks is None, name            # contiguous
            else:                                           # chunks of whole rows
                assert data.chunks[1:] == data.shape[1:] and data.shuffle, name
    for a, b in zip(snaps, HDF5Snapshots(path)):
        same_snapshot(a, b)


def test_snapshot_files_of_older_versions_read_the_same(tmp_path):
    snaps = [random_snapshot(k, dim=3) for k in range(3)]
    old, new = tmp_path / "old.h5", tmp_path / "new.h5"
    write_snapshots_before_0_10(old, snaps)
    write_snapshots(new, snaps)
    with h5py.File(old, "r") as f:
        assert f["frames/000000/positions"].compression == "gzip"
    for a, b, c in zip(snaps, HDF5Snapshots(old), HDF5Snapshots(new)):
        same_snapshot(a, b)
        same_snapshot(b, c)


@pytest.mark.parametrize("compression", ["zip", "GZIP", 4, True, np.array(["gzip", "lzf"]), ("gzip",)])
def test_snapshot_file_compression_is_checked_by_name(tmp_path, compression):
    with pytest.raises(ValueError, match="compression: expected one of"):
        write_snapshots(tmp_path / "x.h5", [random_snapshot(0, dim=3)], compression=compression)
    assert not (tmp_path / "x.h5").exists()


def test_snapshot_file_rejects_foreign_files(tmp_path):
    path = tmp_path / "other.h5"
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "something else"
    with pytest.raises(ValueError, match="not a cgbound snapshot file"):
        HDF5Snapshots(path)


@pytest.mark.parametrize("name, edit, message", [
    ("masses", lambda m: np.where(np.arange(m.size) == 2, 0.0, m), "masses: expected positive masses"),
    ("positions", lambda x: x.T.copy(), r"positions: expected shape"),
    ("contacts/i", lambda i: i + 1000, r"contacts.i: expected particle indices"),
])
def test_an_edited_snapshot_dataset_is_refused_naming_the_file_and_frame(tmp_path, name, edit, message):
    # the Snapshot's own message alone ("frame 1: masses: ...") named neither the file nor its frame; at the command
    # line a mass of the data's was even blamed on --masses
    path = tmp_path / "s.h5"
    write_snapshots(path, [random_snapshot(k, dim=3) for k in range(2)])
    with h5py.File(path, "r+") as f:
        value = edit(f["frames/000001/" + name][()])
        del f["frames/000001/" + name]
        f["frames/000001/" + name] = value
    frames = HDF5Snapshots(path)
    frames[0]
    with pytest.raises(ValueError, match=rf"s.h5: frame 000001 \(t = [^)]*\): {message}"):
        frames[1]


def result_3d():
    snap = random_snapshot(3, dim=3)
    return cg.coarse_grain(snap, cg.Grid(snap.box, (4, 3, 5)), cg.Gaussian(0.5),
                           fields=("density", "velocity", "stress"))


def result_2d():
    snap = random_snapshot(4, dim=2)
    return cg.coarse_grain(snap, cg.Grid(snap.box, (6, 5)), cg.Lucy(1.2), fields=("density", "velocity", "stress"))


def test_hdf5_result_round_trip(tmp_path):
    out = result_3d()
    path = out.to_hdf5(tmp_path / "fields.h5", provenance="unit test")
    with h5py.File(path, "r") as f:
        for name in out.fields:
            np.testing.assert_array_equal(f["fields"][name][()], out[name])
        np.testing.assert_array_equal(f["coordinates"][()], out.coordinates)
        assert f.attrs["kernel"] == "Gaussian" and f.attrs["width"] == 0.5 and f.attrs["cutoff"] == 2.5
        assert f.attrs["convention"] == "tension" and f.attrs["provenance"] == "unit test"
        assert f.attrs["cgbound_version"] == cg.__version__


def test_npz_round_trip(tmp_path):
    out = result_2d()
    path = out.to_npz(tmp_path / "fields.npz")
    with np.load(path) as data:
        for name in out.fields:
            np.testing.assert_array_equal(data[name], out[name])
        assert json.loads(str(data["metadata"]))["kernel"] == "Lucy"


@pytest.mark.parametrize("make", [result_3d, result_2d])
def test_vtk_is_read_back_by_meshio(tmp_path, make):
    meshio = pytest.importorskip("meshio")
    out = make()
    path = out.to_vtk(tmp_path / "fields.vtk")
    mesh = meshio.read(path)
    grid = out.grid
    dim = grid.dim
    # meshio lists points x fastest: rebuild our ordering from the coordinates it returns
    pts = mesh.points
    coords = out.coordinates.reshape(-1, dim)
    ours3 = coords if dim == 3 else np.stack([coords[:, 0], np.zeros(len(coords)), coords[:, 1]], axis=1)
    order = {tuple(np.round(p, 12)): k for k, p in enumerate(pts)}
    index = np.array([order[tuple(np.round(p, 12))] for p in ours3])
    np.testing.assert_allclose(mesh.point_data["density"].ravel()[index], out.density.ravel(), rtol=1e-15)
    vel = mesh.point_data["velocity"][index]
    expected = out.velocity.reshape(-1, dim)
    np.testing.assert_allclose(vel[:, [0, 1, 2] if dim == 3 else [0, 2]], expected, rtol=1e-15)
    stress = mesh.point_data["stress"].reshape(-1, 3, 3)[index]
    sel = [0, 1, 2] if dim == 3 else [0, 2]
    np.testing.assert_allclose(stress[:, sel][:, :, sel], out.stress.reshape(-1, dim, dim), rtol=1e-15)


def test_xarray_view():
    xr = pytest.importorskip("xarray")
    out = result_3d()
    ds = out.to_xarray()
    assert isinstance(ds, xr.Dataset)
    assert ds["stress"].dims == ("x", "y", "z", "component", "component2")
    np.testing.assert_array_equal(ds["density"].values, out.density)
    np.testing.assert_array_equal(ds["z"].values, out.grid.axis_coordinates[2])
    zz = ds["stress"].sel(component="z", component2="z").mean(dim=("x", "y"))
    np.testing.assert_allclose(zz.values, out.stress[..., 2, 2].mean(axis=(0, 1)))


def test_a_failed_write_leaves_the_existing_file_untouched(tmp_path, monkeypatch):
    out = result_3d()
    path = tmp_path / "fields.npz"
    path.write_bytes(b"precious")
    import cgbound.writers as writers

    def boom(*args, **kwargs):
        raise RuntimeError("disk full")
    monkeypatch.setattr(writers.np, "savez_compressed", boom)
    with pytest.raises(RuntimeError, match="disk full"):
        out.to_npz(path)
    assert path.read_bytes() == b"precious"
    assert [p.name for p in tmp_path.iterdir()] == ["fields.npz"]      # no temporary left behind


def test_atomic_write_gives_ordinary_file_permissions(tmp_path):
    """A new file gets the mode of a plain open() (the umask default)."""
    from cgbound._atomic import atomic_write
    target = tmp_path / "out.txt"
    atomic_write(target, lambda p: open(p, "w").write("x"))
    plain = tmp_path / "plain.txt"
    plain.write_text("x")
    assert (os.stat(target).st_mode & 0o777) == (os.stat(plain).st_mode & 0o777)


def test_snapshot_file_keeps_contact_branches(tmp_path):
    # Contacts.branch (a pair listed once per periodic image, tests/data/lammps/thin) is written and read back: the
    # minimum image would give the second listing the first's branch
    from cgbound.readers import LammpsReader
    data = os.path.join(os.path.dirname(__file__), "data", "lammps")
    snap = LammpsReader(os.path.join(data, "thin", "atoms.dump"), os.path.join(data, "thin", "pairs.dump"),
                        input=os.path.join(data, "in.thin"))[0]
    path = str(tmp_path / "thin.h5")
    write_snapshots(path, [snap, random_snapshot(0, dim=3)])
    back = HDF5Snapshots(path)
    assert np.array_equal(back[0].contacts.branch, snap.contacts.branch)
    assert np.array_equal(back[0].split_contacts()[0]["branch"], snap.split_contacts()[0]["branch"])
    assert back[1].contacts.branch is None
    # MercuryDPM's .fstat holds a pair once (its reader refused the writer's once-per-image output): refused, and the
    # files that were there are kept
    from cgbound.readers.mercury import write_mercury
    data_path, fstat_path = tmp_path / "t.data", tmp_path / "t.fstat"
    data_path.write_text("kept\n")
    with pytest.raises(ValueError, match=r"write_mercury: the snapshot at time .* lists a pair once per periodic image "
                                         r".* Write it with write_snapshots \(HDF5\)"):
        write_mercury([snap], str(data_path), str(fstat_path))
    assert data_path.read_text() == "kept\n" and not fstat_path.exists()
