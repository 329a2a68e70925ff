"""Dask backends: CoarseGrain.run(backend="dask") and coarse_grain_tiled equal the serial results.

One LocalCluster (2 worker processes, 1 thread each) is shared by the module's tests. Tests that
need dask.distributed are skipped without it; argument checks that reject before any cluster is
made run anyway.
"""
import os
import pickle
import subprocess
import sys

import h5py
import numpy as np
import pytest

import cgbound as cg
from cgbound.readers import HDF5Snapshots, LammpsReader, write_snapshots
from helpers import assert_fields_close, random_snapshot

try:
    import distributed
except ImportError:  # pragma: no cover - dask is in the test extras
    distributed = None

needs_dask = pytest.mark.skipif(distributed is None, reason="dask.distributed is not installed")

RTOL = 1e-12
FIELDS = ("density", "velocity", "momentum_flux", "kinetic_stress", "contact_stress", "stress", "extended_stress",
          "interaction_force_density", "body_force_density", "volume_fraction", "temperature")


@pytest.fixture(scope="module")
def client():
    if distributed is None:
        pytest.skip("dask.distributed is not installed")
    from cgbound.executors import local_cluster
    cluster = local_cluster(2)  # LocalCluster(n_workers=2, processes=True, threads_per_worker=1), environment kept
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def frames(n=9, **kw):
    kw = dict(dict(n=40, n_bulk=30, n_fixed=8, n_fixed_contacts=6, n_wall=4), **kw)
    return [random_snapshot(seed, **kw) for seed in range(n)]


def assert_same(a, b, fields, what=""):
    for name in fields:
        assert_fields_close(np.asarray(b[name]), np.asarray(a[name]), RTOL, f"{what} {name}")
    np.testing.assert_array_equal(a.times, b.times)


def run_both(snapshots, client, grid, kernel, selection=(None, None, None), **options):
    serial = cg.CoarseGrain(snapshots, grid, kernel, fields=FIELDS, **options).run(*selection)
    dask = cg.CoarseGrain(snapshots, grid, kernel, fields=FIELDS, **options).run(*selection, backend="dask",
                                                                               client=client)
    assert dask.n_frames == serial.n_frames
    np.testing.assert_array_equal(dask.frame_times, serial.frame_times)
    return serial.results, dask.results


# --- CoarseGrain.run(backend="dask") ---------------------------------------------------------------

AVERAGES = {
    "mean": dict(time_average="mean"),
    "none": dict(time_average="none"),
    "smooth-at-frame-times": dict(time_average=1.3),
    "smooth-at-given-times": dict(time_average=0.8, times=[0.5, 3.2, 7.9]),
}


@needs_dask
@pytest.mark.parametrize("average", AVERAGES)
@pytest.mark.parametrize("selection", [(None, None, None), (1, 8, 2), (None, None, -1)])
def test_time_average_on_dask_equals_serial(client, average, selection):
    snaps = frames()
    grid = cg.Grid(snaps[0].box, (3, 2, 7))
    serial, dask = run_both(snaps, client, grid, cg.Gaussian(0.6), selection, **AVERAGES[average])
    assert_same(serial, dask, FIELDS, average)


@needs_dask
@pytest.mark.parametrize("average", ["mean", "smooth-at-frame-times"])
def test_reader_on_dask_equals_serial(client, tmp_path, average):
    snaps = frames(7, dim=2)
    path = tmp_path / "frames.h5"
    write_snapshots(path, snaps)
    reader = HDF5Snapshots(path)
    grid = cg.Grid(snaps[0].box, (1, 9), average="x")
    serial, dask = run_both(reader, client, grid, cg.Lucy(1.1), **AVERAGES[average])
    assert_same(serial, dask, FIELDS, average)


@needs_dask
def test_units_and_frame_count_on_dask_equal_serial(client, tmp_path):
    snaps = frames(5, dim=2)
    path = tmp_path / "frames.h5"
    write_snapshots(path, snaps)
    reader = HDF5Snapshots(path, units="cgs")
    grid = cg.Grid(snaps[0].box, (1, 9), average="x")
    serial, dask = run_both(reader, client, grid, cg.Lucy(1.1))
    assert serial.units.name == dask.units.name == "cgs" and serial.n_frames == dask.n_frames == 5
    assert dask.unit("stress") == "g s^-2"                                 # 2-D: a force per length


@needs_dask
def test_species_and_points_on_dask(client):
    snaps = frames(5)
    for s in snaps:
        s.species = np.arange(s.n_particles) % 2
    points = np.random.default_rng(3).uniform(0, 3, (11, 3))
    serial, dask = run_both(snaps, client, points, cg.Lucy(1.4), species=1)
    assert_same(serial, dask, FIELDS, "species 1 at points")


@needs_dask
def test_own_local_cluster_and_progress(capsys):
    snaps = frames(4)
    grid = cg.Grid(snaps[0].box, (1, 1, 5), average=("x", "y"))
    a = cg.CoarseGrain(snaps, grid, cg.Lucy(1.3), fields=("density",)).run(backend="dask", n_workers=1,
                                                                           verbose=True)
    b = cg.CoarseGrain(snaps, grid, cg.Lucy(1.3), fields=("density",)).run()
    assert_same(a.results, b.results, ("density",))


# --- failures on a worker --------------------------------------------------------------------------

def broken_hdf5(tmp_path, bad=3):
    path = tmp_path / "broken.h5"
    write_snapshots(path, frames(6))
    with h5py.File(path, "r+") as f:
        del f["frames"][f"{bad:06d}"]["positions"]
    return HDF5Snapshots(path)


def lammps_dump(path, n_frames=5, bad=None):
    """A small LAMMPS ``dump custom`` file; frame ``bad`` lists atom 1 twice."""
    rng = np.random.default_rng(0)
    lines = []
    for k in range(n_frames):
        ids = np.arange(1, 9)
        if k == bad:
            ids[1] = 1
        lines += ["ITEM: TIMESTEP", str(100 * k), "ITEM: NUMBER OF ATOMS", "8", "ITEM: BOX BOUNDS pp pp ff",
                  "0 4", "0 4", "0 4", "ITEM: ATOMS id type mass x y z vx vy vz"]
        for i, (x, v) in zip(ids, zip(rng.uniform(0, 4, (8, 3)), rng.normal(size=(8, 3)))):
            lines.append(f"{i} 1 1.0 " + " ".join(f"{c:.6f}" for c in (*x, *v)))
    path.write_text("\n".join(lines) + "\n")
    return LammpsReader(path)


@pytest.mark.parametrize("backend", ["serial", pytest.param("dask", marks=needs_dask)])
def test_corrupt_hdf5_frame_is_named(request, tmp_path, backend):
    reader = broken_hdf5(tmp_path, bad=3)
    options = {"client": request.getfixturevalue("client")} if backend == "dask" else {}
    grid = cg.Grid(reader[0].box, (2, 2, 3))
    with pytest.raises(ValueError, match="frame 3: .*positions"):
        cg.CoarseGrain(reader, grid, cg.Lucy(1.0)).run(backend=backend, **options)


@pytest.mark.parametrize("backend", ["serial", pytest.param("dask", marks=needs_dask)])
def test_corrupt_lammps_frame_is_named(request, tmp_path, backend):
    reader = lammps_dump(tmp_path / "atoms.dump", bad=2)
    options = {"client": request.getfixturevalue("client")} if backend == "dask" else {}
    grid = cg.Grid(reader[0].box, (2, 2, 2))
    with pytest.raises(ValueError, match="frame 2: .*duplicate atom IDs at timestep 200"):
        cg.CoarseGrain(reader, grid, cg.Lucy(1.0), time_average=0.5).run(backend=backend, **options)


@needs_dask
def test_lammps_reader_on_dask_equals_serial(client, tmp_path):
    reader = lammps_dump(tmp_path / "atoms.dump", n_frames=6)
    grid = cg.Grid(reader[0].box, (3, 3, 4))
    fields = ("density", "velocity", "kinetic_stress")
    serial = cg.CoarseGrain(reader, grid, cg.Lucy(1.5), fields=fields).run(0, 6, 1)
    dask = cg.CoarseGrain(reader, grid, cg.Lucy(1.5), fields=fields).run(0, 6, 1, backend="dask", client=client)
    assert_same(serial.results, dask.results, fields)


# --- readers travel as paths and frame locators -----------------------------------------------------

def test_readers_pickle_cheaply_and_take_frames(tmp_path):
    snaps = frames(6)
    write_snapshots(tmp_path / "f.h5", snaps)
    hdf5 = HDF5Snapshots(tmp_path / "f.h5")
    lammps = lammps_dump(tmp_path / "atoms.dump", n_frames=6)
    for reader in (hdf5, lammps):
        reader[0]  # fill any frame cache: it must not travel
        blob = pickle.dumps(reader)
        assert len(blob) < 4000, type(reader).__name__
        back = pickle.loads(blob)
        block = back.take([4, 1, -1])
        assert len(block) == 3 and len(pickle.dumps(block)) < 4000
        for position, index in enumerate([4, 1, 5]):
            assert np.array_equal(block[position].positions, reader[index].positions)
            assert block[position].time == reader[index].time
    with pytest.raises(IndexError):
        hdf5.take([6])
    # a plain list of Snapshots pickles too (its blocks are scattered to the workers as Snapshots)
    back = pickle.loads(pickle.dumps(snaps[:2]))
    assert np.array_equal(back[1].contacts.force, snaps[1].contacts.force)


def test_import_does_not_import_dask(tmp_path):
    code = "import sys, cgbound; print(any(m.split('.')[0] in ('dask', 'distributed') for m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


# --- coarse_grain_tiled ------------------------------------------------------------------------------

def big_snapshot(periodic, dim=3, seed=5):
    lengths = [8.0, 7.0, 9.0] if dim == 3 else [8.0, 9.0]
    return random_snapshot(seed, dim=dim, n=300, n_bulk=250, n_fixed=40, n_fixed_contacts=40, n_wall=20,
                           periodic=periodic, lengths=lengths, outside=True)


TILINGS = {
    "periodic": ((True, True, False), (9, 8, 10), (), (3, 2, 4)),
    "non-periodic": ((False, False, False), (9, 8, 10), (), (3, 2, 4)),
    "one-node-tiles": ((True, True, False), (4, 3, 5), (), (4, 3, 5)),
    "averaged-x": ((True, True, False), (1, 8, 10), ("x",), (1, 3, 2)),
    "all-periodic": ((True, True, True), (6, 6, 6), (), (2, 3, 2)),
}


@pytest.mark.parametrize("backend", ["serial", pytest.param("dask", marks=needs_dask)])
@pytest.mark.parametrize("tiling", TILINGS)
@pytest.mark.parametrize("kernel", [cg.Gaussian(0.5), cg.Lucy(1.2)], ids=["gaussian", "lucy"])
def test_tiled_equals_one_process(request, backend, tiling, kernel):
    periodic, shape, average, tiles = TILINGS[tiling]
    snap = big_snapshot(periodic)
    fields = FIELDS if not all(periodic) else tuple(f for f in FIELDS if f != "extended_stress")
    grid = cg.Grid(snap.box, shape, average=average)
    options = {"client": request.getfixturevalue("client")} if backend == "dask" else {"backend": "serial"}
    tiled = cg.coarse_grain_tiled(snap, grid, kernel, fields=fields, tiles=tiles, **options)
    assert_same(cg.coarse_grain(snap, grid, kernel, fields=fields), tiled, fields, tiling)


@needs_dask
def test_tiled_2d_static_snapshot_on_own_cluster():
    snap = big_snapshot((True, False), dim=2)
    snap.velocities = None
    grid = cg.Grid(snap.box, (12, 10))
    fields = ("density", "stress", "contact_stress")
    tiled = cg.coarse_grain_tiled(snap, grid, cg.Lucy(1.0), fields=fields, tiles=(3, 2), n_workers=1, verbose=True)
    assert_same(cg.coarse_grain(snap, grid, cg.Lucy(1.0), fields=fields), tiled, fields, "2D")


# --- bad arguments ---------------------------------------------------------------------------------

SNAPS = frames(2)
GRID = cg.Grid(SNAPS[0].box, (4, 4, 4))


def cg_run(**kw):
    return cg.CoarseGrain(SNAPS, GRID, cg.Lucy(1.0)).run(**kw)


def tiled(**kw):
    args = dict(snapshot=SNAPS[0], grid=GRID, kernel=cg.Lucy(1.0), tiles=(2, 2, 2), backend="serial")
    args.update(kw)
    return cg.coarse_grain_tiled(**args)


BAD = [
    (lambda: cg_run(backend="spark"), ValueError, r"backend: expected 'serial' or 'dask', got 'spark'"),
    (lambda: cg_run(backend=None), TypeError, r"backend: expected 'serial' or 'dask', got None"),
    (lambda: cg_run(backend="dask", n_workers=0), ValueError, r"n_workers: expected a positive integer or None, got 0"),
    (lambda: cg_run(backend="dask", n_workers=1.5), TypeError,
     r"n_workers: expected a positive integer or None, got 1.5"),
    (lambda: cg_run(backend="dask", n_workers=True), TypeError, r"n_workers: expected a positive integer"),
    (lambda: cg_run(n_workers=2), ValueError, r"n_workers: expected None with backend='serial'"),
    (lambda: cg_run(client="tcp://1.2.3.4"), ValueError, r"client: expected None with backend='serial'"),
    (lambda: cg_run(backend="dask", client=object(), n_workers=2), ValueError,
     r"n_workers: expected None when a client is given"),
    (lambda: cg.CoarseGrain(iter(SNAPS), GRID, cg.Lucy(1.0)).run(backend="dask"), TypeError,
     r"snapshots: expected a list or a reader \(len\(\) and indexing\) for backend='dask', got list_iterator"),
    (lambda: cg_run(backend="dask", start=5), ValueError, r"start, stop, step: expected a selection of at least one"),
    (lambda: tiled(tiles=(2, 2)), ValueError, r"tiles: expected 3 positive integers \(one per axis\), got \(2, 2\)"),
    (lambda: tiled(tiles=4), TypeError, r"tiles: expected 3 positive integers \(tiles along each axis\), got 4"),
    (lambda: tiled(tiles="222"), TypeError, r"tiles: expected 3 positive integers"),
    (lambda: tiled(tiles=(2, 0, 2)), ValueError, r"tiles: expected positive tile counts, got \(2, 0, 2\)"),
    (lambda: tiled(tiles=(2, 2.0, 2)), TypeError, r"tiles: expected 3 positive integers, got \(2, 2.0, 2\)"),
    (lambda: tiled(tiles=(5, 1, 1)), ValueError,
     r"tiles: expected at most 4 tiles along x \(the grid's nodes\), got 5"),
    (lambda: tiled(grid=cg.Grid(SNAPS[0].box, (1, 4, 4), average="x")), ValueError,
     r"tiles: expected 1 tile along the averaged axis x, got 2"),
    (lambda: tiled(grid=np.zeros((3, 3))), TypeError, r"grid: expected a cg.Grid for tiling .*got ndarray"),
    (lambda: tiled(snapshot=SNAPS), TypeError, r"snapshot: expected a cg.Snapshot, got list"),
    (lambda: tiled(backend="threads"), ValueError, r"backend: expected 'serial' or 'dask', got 'threads'"),
    (lambda: tiled(n_workers=-1), ValueError, r"n_workers: expected a positive integer or None, got -1"),
    (lambda: tiled(verbose="yes"), TypeError, r"verbose: expected True or False, got 'yes'"),
]


@pytest.mark.parametrize("call, exc, regex", BAD, ids=[f"bad-{k}" for k in range(len(BAD))])
def test_bad_arguments_are_named(call, exc, regex):
    with pytest.raises(exc, match=regex) as info:
        call()
    assert info.type is exc


@needs_dask
def test_client_of_the_wrong_type():
    with pytest.raises(TypeError, match=r"client: expected a dask.distributed.Client or None, got str"):
        cg_run(backend="dask", client="tcp://1.2.3.4")
    with pytest.raises(TypeError, match=r"client: expected a dask.distributed.Client or None, got str"):
        tiled(backend="dask", client="tcp://1.2.3.4")


@needs_dask
def test_local_cluster_leaves_the_thread_environment_alone(client):
    before = os.environ.get("OMP_NUM_THREADS")
    cg_run(backend="dask", n_workers=1)
    assert os.environ.get("OMP_NUM_THREADS") == before
    assert client.run(lambda: os.environ.get("OMP_NUM_THREADS")) and all(
        v == "1" for v in client.run(lambda: os.environ.get("OMP_NUM_THREADS")).values())


def test_without_dask_the_error_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(ImportError, match=r"pip install 'cgbound\[dask\]'"):
        cg_run(backend="dask")


def test_tiled_with_auto_line_quadrature_uses_the_whole_snapshots_rule():
    """"auto" picks n from the longest branch: tiles must not pick their own (each sees fewer branches)."""
    snap = big_snapshot((True, True, False))
    grid = cg.Grid(snap.box, (9, 8, 10))
    bulk, boundary = snap.split_contacts()
    lengths = np.concatenate([np.linalg.norm(p["branch"], axis=1) for p in (bulk, boundary)])
    # a width where the longest branch and a typical one ask for different n
    width = next(w for w in (0.9, 1.2, 1.6, 2.0, 3.0)
                 if cg.kernels.auto_line_points(lengths.max(), w) != cg.kernels.auto_line_points(np.median(lengths), w))
    kernel = cg.Gaussian(width, line_quadrature="auto")
    fields = ("contact_stress", "boundary_stress")
    tiled = cg.coarse_grain_tiled(snap, grid, kernel, fields=fields, tiles=(3, 2, 4), backend="serial")
    assert_same(cg.coarse_grain(snap, grid, kernel, fields=fields), tiled, fields, "auto")
    # the tiles get the whole snapshot's n (here every tile's halo happens to hold the longest branch too)
    from cgbound.tiled import resolve_auto_line_quadrature
    fixed = resolve_auto_line_quadrature(kernel, (bulk, boundary))
    n = cg.kernels.auto_line_points(lengths.max(), width)
    assert fixed.line_quadrature == (n if n else "exact") and kernel.line_quadrature == "auto"


@pytest.mark.parametrize("kernel", [cg.Gaussian(0.5), cg.Gaussian(0.5, line_quadrature="auto"), cg.Lucy(1.2)],
                         ids=["gaussian", "auto", "lucy"])
def test_tiled_without_contact_fields(kernel):
    """Fields that need no contacts: there is no split of the contacts (it raised a TypeError)."""
    snap = big_snapshot((True, True, False))
    grid = cg.Grid(snap.box, (9, 8, 10))
    fields = ("density", "velocity", "kinetic_stress", "body_force_density")
    tiled = cg.coarse_grain_tiled(snap, grid, kernel, fields=fields, tiles=(3, 2, 4), backend="serial")
    assert_same(cg.coarse_grain(snap, grid, kernel, fields=fields), tiled, fields, "no contacts")
    assert getattr(tiled.kernel, "line_quadrature", None) == getattr(kernel, "line_quadrature", None)


@needs_dask
@pytest.mark.parametrize("average", ["mean", "none"])
def test_cylindrical_grid_on_dask_equals_serial(client, average):
    snaps = frames(5)
    centre = 0.5 * (snaps[0].box.lower + snaps[0].box.upper)
    grid = cg.CylindricalGrid(snaps[0].box, centre, "z", r=(0.0, 1.5, 3), z=(-0.5, 0.5, 2))
    serial, dask = run_both(snaps, client, grid, cg.Gaussian(0.6), **AVERAGES[average])
    assert_same(serial, dask, FIELDS, average)
