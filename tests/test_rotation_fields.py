"""The rotational fields as fields like the others (cgbound.fields.field_shape): coarse_grain and CoarseGrain
compute them on grids with and without averaged axes and at points, the time average is the mean of the
frames' fields (the kinetic spin flux: about the mean velocity), block error bars, 2-D shapes, the writers and
the command line (docs/theory.md, "Rotation and couple stress")."""
import os

import numpy as np
import pytest

import cgbound
import cgbound as cg
from cgbound.fields import field_shape
from cgbound.rotation import ROTATION_FIELDS
from helpers import ForbiddenCore, random_snapshot
from test_rotation import TARGETS, spinning, target_for

KERNELS = {"lucy": cg.Lucy(1.3), "gaussian": cg.Gaussian(0.45, cutoff=1.6), "heaviside": cg.Heaviside(1.1)}
LINEAR = tuple(f for f in ROTATION_FIELDS if f != "kinetic_spin_flux")   # linear in the primaries


def frames(dim, n=4, seed=60):
    return [spinning(random_snapshot(seed + k, dim=dim, n=10, n_fixed=3, n_bulk=6, n_fixed_contacts=3, n_wall=2),
                     seed + k) for k in range(n)]


def test_field_shape_rule():
    assert field_shape("stress", 3) == (3, 3) and field_shape("stress", 2) == (2, 2)
    assert field_shape("density", 2) == ()
    assert field_shape("spin_density", 3) == (3,) and field_shape("spin_density", 2) == ()
    assert field_shape("couple_stress", 3) == (3, 3) and field_shape("couple_stress", 2) == (2,)
    assert field_shape("spin_flux", 2) == (2,) and field_shape("kinetic_spin_flux", 3) == (3, 3)
    assert field_shape("stress_torque_density", 2) == () and field_shape("boundary_couple_density", 3) == (3,)
    assert set(ROTATION_FIELDS) <= set(cg.FIELD_NAMES)


@pytest.mark.parametrize("kname", sorted(KERNELS))
@pytest.mark.parametrize("dim, layout", TARGETS)
def test_coarse_grain_gives_the_rotation_fields(kname, dim, layout):
    """The same numbers, bit for bit, with the other fields alongside; shapes by field_shape."""
    snap = frames(dim, 1)[0]
    where = target_for(snap, layout, 7)
    fields = ROTATION_FIELDS + ("density", "stress")
    out = cg.coarse_grain(snap, where, KERNELS[kname], fields=fields)
    want = cg.rotation_fields(snap, where, KERNELS[kname])
    for name in ROTATION_FIELDS:
        assert out[name].shape == where.field_shape + field_shape(name, dim), name
        np.testing.assert_array_equal(out[name], want[name], err_msg=name)
        assert np.any(out[name] != 0), name
    alone = cg.coarse_grain(snap, where, KERNELS[kname], fields=("density", "stress"))
    np.testing.assert_array_equal(out.stress, alone.stress)


@pytest.mark.parametrize("dim, layout", [(2, ("x",)), (3, ()), (3, "points"), (3, ("x", "y"))])
def test_time_average_is_the_mean_of_the_frames(dim, layout):
    snaps = frames(dim)
    where = target_for(snaps[0], layout, 3)
    kernel = cg.Lucy(1.3)
    fields = ROTATION_FIELDS + ("density", "momentum")
    mean = cg.CoarseGrain(snaps, where, kernel, fields=fields).run().results
    each = [cg.coarse_grain(s, where, kernel, fields=fields) for s in snaps]
    for name in LINEAR + ("density", "momentum"):
        want = np.mean([r[name] for r in each], axis=0)
        assert mean[name].shape == want.shape
        np.testing.assert_allclose(mean[name], want, rtol=1e-13, atol=1e-14 * np.abs(want).max(), err_msg=name)
    # the kinetic spin flux of the mean: about the mean velocity, J' = <J> - <s> (x) <p> / <rho>
    rho, p = mean.density, mean.momentum
    V = np.zeros(p.shape)
    np.divide(p, rho[..., None], out=V, where=rho[..., None] > 0)
    s = mean.spin_density if dim == 3 else mean.spin_density[..., None]
    want = (mean.spin_flux if dim == 3 else mean.spin_flux[..., None, :]) - s[..., :, None] * V[..., None, :]
    np.testing.assert_allclose(mean.kinetic_spin_flux, want.reshape(mean.kinetic_spin_flux.shape), rtol=1e-12,
                               atol=1e-13 * np.abs(want).max())
    # every frame on a leading axis: each frame's own fields
    stacked = cg.CoarseGrain(snaps, where, kernel, fields=ROTATION_FIELDS, time_average="none").run().results
    for name in LINEAR:
        np.testing.assert_array_equal(stacked[name], np.stack([r[name] for r in each]), err_msg=name)
    # (a run sums every frame's velocities relative to the first frame's mean velocity: rounding differs)
    want = np.stack([r.kinetic_spin_flux for r in each])
    np.testing.assert_allclose(stacked.kinetic_spin_flux, want, rtol=0, atol=1e-13 * np.abs(want).max())


def test_block_errors_of_rotational_fields():
    snaps = frames(3, 6)
    where = cg.Grid(snaps[0].box, (3, 1, 4), average=("y",))
    kernel = cg.Gaussian(0.5, cutoff=1.5)
    run = cg.CoarseGrain(snaps, where, kernel, fields=LINEAR, errors="blocks", n_blocks=3).run()
    blocks = [cg.CoarseGrain(snaps[2 * k:2 * k + 2], where, kernel, fields=LINEAR).run().results for k in range(3)]
    for name in LINEAR:
        b = np.stack([r[name] for r in blocks])
        want = np.sqrt(((b - b.mean(axis=0)) ** 2).sum(axis=0) / (3 * 2))
        assert run.results.errors[name].shape == run.results[name].shape
        np.testing.assert_allclose(run.results.errors[name], want, rtol=1e-9, atol=1e-12 * np.abs(want).max(),
                                   err_msg=name)
        assert np.any(want > 0), name


def test_two_d_shapes_on_grids_points_and_time_axes():
    snaps = frames(2, 2)
    grid = cg.Grid(snaps[0].box, (4, 5))
    profile = cg.Grid(snaps[0].box, (1, 6), average=("x",))
    pts = cg.Points(snaps[0].positions[:3])
    expect = {"spin_density": (), "angular_momentum_density": (), "spin_flux": (2,), "kinetic_spin_flux": (2,),
              "couple_stress": (2,), "stress_torque_density": (), "boundary_couple_density": ()}
    for where, nodes in ((grid, (4, 5)), (profile, (1, 6)), (pts, (3,))):
        out = cg.coarse_grain(snaps[0], where, cg.Lucy(1.3), fields=ROTATION_FIELDS)
        for name in ROTATION_FIELDS:
            assert out[name].shape == nodes + expect[name], name
    run = cg.CoarseGrain(snaps, profile, cg.Lucy(1.3), fields=ROTATION_FIELDS, time_average="none").run()
    for name in ROTATION_FIELDS:
        assert run.results[name].shape == (2, 1, 6) + expect[name], name


@pytest.mark.parametrize("dim", [2, 3])
def test_writers_round_trip(tmp_path, dim):
    h5py = pytest.importorskip("h5py")
    snap = frames(dim, 1)[0]
    grid = cg.Grid(snap.box, (4, 3, 5) if dim == 3 else (4, 5))
    out = cg.coarse_grain(snap, grid, cg.Lucy(1.3), fields=ROTATION_FIELDS + ("stress",))
    path = out.to_hdf5(tmp_path / "r.h5")
    with h5py.File(path, "r") as f:
        for name in ROTATION_FIELDS:
            np.testing.assert_array_equal(f["fields"][name][()], out[name], err_msg=name)
    with np.load(out.to_npz(tmp_path / "r.npz")) as data:
        for name in ROTATION_FIELDS:
            np.testing.assert_array_equal(data[name], out[name], err_msg=name)
    text = open(out.to_vtk(tmp_path / "r.vtk"), "rb").read()
    for name in ROTATION_FIELDS:
        kind = {0: b"SCALARS", 1: b"VECTORS", 2: b"TENSORS"}[len(field_shape(name, dim))]
        assert kind + b" " + name.encode() in text, name
    pytest.importorskip("xarray")
    ds = out.to_xarray()
    for name in ROTATION_FIELDS:
        np.testing.assert_array_equal(ds[name].values, out[name], err_msg=name)


@pytest.fixture
def no_work(monkeypatch):
    monkeypatch.setattr(cgbound._engine, "_core", ForbiddenCore(cgbound._engine._core))


def test_spin_fields_refuse_snapshots_without_angular_velocities_before_work(no_work):
    snap = random_snapshot(2, dim=3, n=8, n_fixed=2, n_bulk=3, n_fixed_contacts=1, n_wall=1)
    grid = cg.Grid(snap.box, (2, 2, 2))
    for name in ("spin_density", "spin_flux", "kinetic_spin_flux", "angular_momentum_density"):
        with pytest.raises(ValueError, match=f"snapshot.angular_velocities: .*'{name}'"):
            cg.coarse_grain(snap, grid, cg.Lucy(1.0), fields=("density", name))
    with pytest.raises(ValueError, match="snapshot.angular_velocities"):
        cg.CoarseGrain([snap, snap], grid, cg.Lucy(1.0), fields=("spin_density",)).run()
    with pytest.raises(ValueError, match="couple_stress_form: expected 'contact_point' or 'branch_line'"):
        cg.coarse_grain(snap, grid, cg.Lucy(1.0), fields=("couple_stress",), couple_stress_form="midpoint")
    with pytest.raises(ValueError, match="couple_stress_form: expected 'contact_point' or 'branch_line'"):
        cg.CoarseGrain([snap], grid, cg.Lucy(1.0), fields=("couple_stress",), couple_stress_form=1)
    with pytest.raises(ValueError, match="couple_stress_form: 'branch_line'.*needs exact line integrals"):
        cg.coarse_grain(snap, cg.Grid(snap.box, (1, 1, 3), average=("x", "y")),
                        cg.Gaussian(0.4, line_quadrature="mercurycg"), fields=("couple_stress",),
                        couple_stress_form="branch_line")
    rings = cg.CylindricalGrid(snap.box, snap.box.lower + 0.5 * snap.box.lengths, "z", r=(0.5, 1.0, 2),
                               z=(-0.5, 0.5, 2))
    with pytest.raises(ValueError, match="fields: expected fields without a pseudo-vector index on a "
                                         r"cg.CylindricalGrid, got \['couple_stress'\]"):
        cg.coarse_grain(snap, rings, cg.Lucy(1.0), fields=("couple_stress",))
    with pytest.raises(ValueError, match=r"pseudo-vector index on a cg.CylindricalGrid, got \['couple_stress'\]"):
        cg.CoarseGrain([snap, snap], rings, cg.Lucy(1.0), fields=("density", "couple_stress")).run()


def test_contact_fields_need_no_angular_velocities():
    snap = random_snapshot(4, dim=3)
    out = cg.coarse_grain(snap, cg.Points(snap.positions[:4]), cg.Lucy(1.5),
                          fields=("couple_stress", "stress_torque_density", "boundary_couple_density"))
    assert out.couple_stress.shape == (4, 3, 3) and np.any(out.couple_stress != 0)


SPIN3D = os.path.join(os.path.dirname(__file__), "data", "lammps", "spin3d")
PAIR_VALUES = ("dist", "fx", "fy", "fz") + tuple(f"p{k}" for k in range(1, 13))


def test_cli_writes_a_rotational_field_of_lammps_data(tmp_path):
    """tests/data/lammps/spin3d (genuine LAMMPS, omega and tq dumped): `cgbound run --fields spin_density,
    couple_stress` writes what CoarseGrain gives."""
    h5py = pytest.importorskip("h5py")
    from cgbound.cli import main
    from cgbound.readers import LammpsReader
    atoms, pairs = os.path.join(SPIN3D, "atoms.dump"), os.path.join(SPIN3D, "pairs.dump")
    out = tmp_path / "spin.h5"
    assert main(["run", atoms, "--pairs", pairs, "--pair-style", "granular", "--pair-values", ",".join(PAIR_VALUES),
                 "--fixed-types", "2", "--walls", "w", "--gravity", "0,0,-1", "--grid", "1,1,12", "--average", "x,y",
                 "--width", "0.5", "--fields", "spin_density,couple_stress", "-o", str(out), "-q"]) == 0
    reader = LammpsReader(atoms, pairs, pair_style="granular", pair_values=PAIR_VALUES, body_force=(0.0, 0.0, -1.0),
                          walls=["w"], fixed_types=[2])
    grid = cg.Grid(reader[0].box, (1, 1, 12), average=("x", "y"))
    want = cg.CoarseGrain(reader, grid, cg.Gaussian(0.5), fields=("spin_density", "couple_stress")).run().results
    with h5py.File(out, "r") as f:
        for name in ("spin_density", "couple_stress"):
            got = f["fields"][name][()]
            assert got.shape == (1, 1, 12) + field_shape(name, 3)
            np.testing.assert_allclose(got, want[name], rtol=1e-13, atol=1e-15 * np.abs(want[name]).max())
            assert np.abs(got).max() > 0


def test_tiles_give_the_rotational_fields():
    """Tiles once refused them; now the same numbers as one process (more in tests/test_tiled_fields.py)."""
    from cgbound.tiled import coarse_grain_tiled
    snap = frames(3, 1)[0]
    grid = cg.Grid(snap.box, (4, 2, 4))
    fields = ("density",) + ROTATION_FIELDS
    tiled = coarse_grain_tiled(snap, grid, cg.Lucy(1.3), fields=fields, tiles=(2, 1, 2), backend="serial")
    whole = cg.coarse_grain(snap, grid, cg.Lucy(1.3), fields=fields)
    for name in fields:
        np.testing.assert_allclose(tiled[name], whole[name], rtol=0, atol=1e-12 * np.abs(whole[name]).max(),
                                   err_msg=name)
