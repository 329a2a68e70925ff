"""Units (cgbound.units): every field's dimension, the named systems, and units carried from snapshots and
readers to results and into HDF5, xarray, .npz and VTK files."""
import json
import os

import numpy as np
import pytest

import cgbound as cg
from cgbound import units as cu
from cgbound.fields import FIELDS
from helpers import random_snapshot

DATA = os.path.join(os.path.dirname(__file__), "data")


# --- every field's dimension, checked by physics: rescale the units of the data -------------------------

def scaled(snap, length, mass, time):
    """The same physical snapshot in other units: a length unit 1/length times as large, and so on."""
    force = mass * length / time ** 2
    c = snap.contacts
    contacts = cg.Contacts(c.i, c.j, c.force * force, c.point * length)
    box = cg.Box(snap.box.lower * length, snap.box.upper * length, periodic=snap.box.periodic)
    return cg.Snapshot(snap.positions * length, snap.velocities * length / time, snap.masses * mass, box=box,
                       contacts=contacts, fixed=snap.fixed, body_force=snap.body_force * length / time ** 2,
                       radii=snap.radii * length, time=snap.time * time)


@pytest.mark.parametrize("dim", [2, 3])
def test_every_field_scales_with_the_units_as_its_dimension_says(dim):
    """Coarse-graining the same data in units 2, 4 and 1/2 times smaller (length, mass, time) multiplies each
    field by 2^L 4^M (1/2)^T: the exponents of DIMENSIONS, tested against what the pipeline computes."""
    assert set(FIELDS) <= set(cu.DIMENSIONS), f"fields without a dimension: {set(FIELDS) - set(cu.DIMENSIONS)}"
    snap = random_snapshot(7, dim=dim)
    a, b, c = 2.0, 4.0, 0.5
    big = scaled(snap, a, b, c)
    shape = (5,) * dim
    # the rotational fields scale as their dimensions say too: tests/test_rotation.py (these data do not spin)
    fields = tuple(f for f in FIELDS if f not in cg.ROTATION_FIELDS)
    out = cg.coarse_grain(snap, cg.Grid(snap.box, shape), cg.Gaussian(0.6), fields=fields)
    out_scaled = cg.coarse_grain(big, cg.Grid(big.box, shape), cg.Gaussian(0.6 * a), fields=fields)
    for name in fields:
        m, length, t = cu.dimension(name, dim)
        factor = b ** m * a ** length * c ** t
        expected = out[name] * factor
        np.testing.assert_allclose(out_scaled[name], expected, rtol=1e-10,
                                   atol=1e-12 * np.nanmax(np.abs(expected)), err_msg=name)


def test_dimensions_agree_with_each_other():
    """Identities between fields: stress is a momentum flux, a force density times a length, p = -tr/D."""
    for dim in (2, 3):
        d = {name: np.array(cu.dimension(name, dim)) for name in cu.DIMENSIONS}
        assert (d["momentum"] == d["density"] + d["velocity"]).all()
        assert (d["stress"] == d["momentum_flux"]).all() and (d["pressure"] == d["stress"]).all()
        assert (d["stress"] == d["interaction_force_density"] + np.array(cu.dimension("length"))).all()
        assert (d["temperature"] == 2 * d["velocity"]).all()
        assert (d["volume_fraction"] == 0).all()
    assert cu.dimension("density", 2) == (1, -2, 0) and cu.dimension("density", 3) == (1, -3, 0)


# --- the named systems ---------------------------------------------------------------------------------

def test_unit_strings_of_the_named_systems():
    assert cu.unit("stress", "si") == "kg m^-1 s^-2"
    assert cu.unit("stress", "si", dim=2) == "kg s^-2"
    assert cu.unit("density", "cgs") == "g cm^-3"
    assert cu.unit("velocity", "micro") == "um us^-1"
    assert cu.unit("stress", "nano", pretty=True) == "ag / (nm ns²)"
    assert cu.unit("stress", "lj", pretty=True) == "m / (σ τ²)"
    assert cu.unit("stress", "lj") == "m sigma^-1 tau^-2"
    assert cu.unit("stress", "mercury", pretty=True) == "m g / d²"      # the example
    assert cu.unit("velocity", "mercury", pretty=True) == "√(g d)"
    assert cu.unit("density", "real", pretty=True) == "(g/mol) / Å³"
    assert cu.unit("contact_stress", "metal") == "(eV/Angstrom) Angstrom^-2"
    assert cu.unit("stress", None) is None
    assert cu.label_units("stress", None) == "(simulation units)"


def test_si_factors_match_known_conversions():
    assert cu.to_si("stress", "cgs") == pytest.approx(0.1)                 # 1 barye = 0.1 Pa
    assert cu.to_si("density", "cgs") == pytest.approx(1e3)                # 1 g/cm^3 = 1000 kg/m^3
    # LAMMPS' pressure conversions (nktv2p): kcal/mol/A^3 -> atm (real), eV/A^3 -> bar (metal)
    assert cu.to_si("contact_stress", "real") / 101325.0 == pytest.approx(68568.415, rel=1e-6)
    assert cu.to_si("contact_stress", "metal") / 1e5 == pytest.approx(1.6021765e6, rel=1e-6)
    assert cu.to_si("stress", "lj") is None


def test_real_and_metal_refuse_adding_kinetic_to_contact_stress_before_work():
    snap = random_snapshot(1, dim=3)
    snap.units = "metal"
    with pytest.raises(ValueError, match="fields: stress .*metal"):
        cg.coarse_grain(snap, cg.Grid(snap.box, (3, 3, 3)), cg.Gaussian(0.5), fields=("density", "stress"))
    with pytest.raises(ValueError, match="commensurate"):
        cu.unit("pressure", "real")
    out = cg.coarse_grain(snap, cg.Grid(snap.box, (3, 3, 3)), cg.Gaussian(0.5),
                          fields=("kinetic_stress", "contact_stress"))
    assert out.unit("kinetic_stress") == "(g/mol) Angstrom^-1 ps^-2"
    assert out.unit("contact_stress") == "(eV/Angstrom) Angstrom^-2"


@pytest.mark.parametrize("bad, kind, match", [
    ("furlongs", ValueError, "units: expected one of lj"),
    ({"length": "m", "mass": "kg"}, ValueError, "units: .*time"),
    ({"length": "m", "mass": "kg", "time": "s", "colour": "red"}, ValueError, "units: expected keys"),
    ({"length": "m", "mass": "kg", "time": "s", "length_si": -1.0}, ValueError, "length_si"),
    (3.0, TypeError, "units: expected a cg.Units"),
])
def test_bad_units_name_the_argument(bad, kind, match):
    with pytest.raises(kind, match=match):
        cg.Snapshot(np.zeros((1, 3)), masses=[1.0], units=bad)


def test_a_mapping_makes_units_and_round_trips_through_json():
    u = cu.as_units({"length": "mm", "mass": "mg", "time": "ms", "length_si": 1e-3, "mass_si": 1e-6,
                     "time_si": 1e-3})
    assert cu.unit("stress", u) == "mg mm^-1 ms^-2"
    assert cu.to_si("stress", u) == pytest.approx(1e-6 / 1e-3 / 1e-6)
    assert cu.as_units(json.loads(json.dumps(u.as_dict()))) == u
    for name, system in cu.SYSTEMS.items():
        assert cu.as_units(json.loads(json.dumps(system.as_dict()))) == system, name


# --- carried from snapshots and readers to results -----------------------------------------------------

def test_units_travel_from_snapshot_to_result_and_time_averages_count_frames():
    frames = [random_snapshot(s, dim=3) for s in (1, 2, 3)]
    for f in frames:
        f.units = "si"
    grid = cg.Grid(frames[0].box, (1, 1, 6), average=("x", "y"))
    one = cg.coarse_grain(frames[0], grid, cg.Gaussian(0.5), fields=("density", "stress"))
    assert one.units.name == "si" and one.unit("stress") == "kg m^-1 s^-2" and one.n_frames == 1
    assert "1 snapshot at t = 1" in repr(one) and "kg m^-1 s^-2" in repr(one)
    mean = cg.CoarseGrain(frames, grid, cg.Gaussian(0.5), fields=("density",)).run().results
    assert mean.n_frames == 3 and "mean over 3 frames" in repr(mean) and "si units" in repr(mean)
    assert "mean over 3 frames" in mean._repr_html_()
    stacked = cg.CoarseGrain(frames, grid, cg.Gaussian(0.5), fields=("density",), time_average="none").run().results
    assert stacked.n_frames == 3 and "3 frames, one per leading index" in repr(stacked)
    smooth = cg.CoarseGrain(frames, grid, cg.Gaussian(0.5), fields=("density",), time_average=0.5).run().results
    assert smooth.n_frames == 3 and "Gaussian time smoothing (width 0.5) of 3 frames at 3 time(s)" in repr(smooth)
    frames[2].units = "cgs"
    with pytest.raises(ValueError, match="frame 2.*units of the first frame"):
        cg.CoarseGrain(frames, grid, cg.Gaussian(0.5), fields=("density",)).run()


def test_without_units_results_say_simulation_units():
    snap = random_snapshot(4, dim=2)
    out = cg.coarse_grain(snap, cg.Grid(snap.box, (4, 4)), cg.Gaussian(0.5), fields=("density",))
    assert out.units is None and out.unit("density") is None
    assert "simulation units" in repr(out)


def test_readers_carry_units_and_the_lammps_input_script_names_them(tmp_path):
    from cgbound.readers import LammpsReader, read_input
    base = os.path.join(DATA, "lammps")
    atoms, pairs = os.path.join(base, "hooke3d", "atoms.dump"), os.path.join(base, "hooke3d", "pairs.dump")
    assert read_input(os.path.join(base, "in.hooke3d")).units == "lj"
    by_script = LammpsReader(atoms, pairs, input=os.path.join(base, "in.hooke3d"))
    assert by_script.units.name == "lj" and by_script[0].units.name == "lj"
    assert all(s.units.name == "lj" for s in by_script[:2]) and by_script[1:].units.name == "lj"
    assert "units='lj'" in repr(by_script)
    told = LammpsReader(atoms, pairs, input=os.path.join(base, "in.hooke3d"), units="si")
    assert told[0].units.name == "si"                        # units= wins over the script
    plain = LammpsReader(atoms, pairs, pair_values=("dist", "fx", "fy", "fz", "p1", "p2", "p3", "p4"),
                         fixed_types=[2], walls=["w"], body_force=(0, 0, -1))
    assert plain.units is None and plain[0].units is None
    with pytest.raises(ValueError, match="units: expected one of"):
        LammpsReader(atoms, pairs, units="imperial")
    # a style cgbound has no table for leaves the units unknown (labels: "simulation units")
    script = tmp_path / "in.electron"
    script.write_text(open(os.path.join(base, "in.hooke3d")).read().replace("units           lj", "units electron"))
    assert read_input(str(script)).units == "electron"
    assert LammpsReader(atoms, pairs, input=str(script)).units is None
    liggghts = os.path.join(DATA, "liggghts")
    from cgbound.readers import LiggghtsReader
    settle = LiggghtsReader(os.path.join(liggghts, "atoms.dump"), os.path.join(liggghts, "pairs.dump"),
                            input=os.path.join(liggghts, "in.settle"))
    assert settle.units.name == "si" and settle[0].units.name == "si"


def test_shipped_datasets_are_in_the_papers_units():
    from cgbound.paper.datasets import boundary_2d, chute_dense_profiles, chute_steady
    assert chute_steady()[0].units.name == "mercury"
    assert boundary_2d().units.name == "mercury"
    assert chute_dense_profiles().units.name == "mercury"


# --- written to files and read back ----------------------------------------------------------------------

@pytest.fixture
def si_result():
    snap = random_snapshot(5, dim=3)
    snap.units = "si"
    return cg.coarse_grain(snap, cg.Grid(snap.box, (3, 4, 5)), cg.Gaussian(0.5),
                           fields=("density", "velocity", "stress"))


def test_hdf5_units_attributes(si_result, tmp_path):
    h5py = pytest.importorskip("h5py")
    path = si_result.to_hdf5(str(tmp_path / "f.h5"))
    with h5py.File(path, "r") as f:
        assert f["fields/stress"].attrs["units"] == "kg m^-1 s^-2"
        assert f["fields/density"].attrs["units"] == "kg m^-3"
        assert f["fields/velocity"].attrs["units"] == "m s^-1"
        assert f["axes/z"].attrs["units"] == "m" and f["coordinates"].attrs["units"] == "m"
        assert cu.as_units(json.loads(f.attrs["units_system"])) == cu.SYSTEMS["si"]
        assert f.attrs["n_frames"] == 1


def test_hdf5_without_units_has_no_units_attributes(tmp_path):
    h5py = pytest.importorskip("h5py")
    snap = random_snapshot(5, dim=3)
    out = cg.coarse_grain(snap, cg.Grid(snap.box, (3, 4, 5)), cg.Gaussian(0.5), fields=("density",))
    with h5py.File(out.to_hdf5(str(tmp_path / "f.h5")), "r") as f:
        assert "units" not in f["fields/density"].attrs and "units_system" not in f.attrs


def test_xarray_units_attributes(si_result, tmp_path):
    xr = pytest.importorskip("xarray")
    ds = si_result.to_xarray()
    assert ds["stress"].attrs["units"] == "kg m^-1 s^-2" and ds["x"].attrs["units"] == "m"
    path = str(tmp_path / "f.nc")
    try:
        ds.to_netcdf(path)
    except (ValueError, ImportError) as exc:          # no netCDF engine installed
        pytest.skip(f"cannot write netCDF here: {exc}")
    back = xr.open_dataset(path)
    assert back["stress"].attrs["units"] == "kg m^-1 s^-2"
    back.close()


def test_npz_and_vtk_carry_the_units(si_result, tmp_path):
    data = np.load(si_result.to_npz(str(tmp_path / "f.npz")))
    meta = json.loads(str(data["metadata"]))
    assert cu.as_units(json.loads(meta["units_system"])).name == "si"
    with open(si_result.to_vtk(str(tmp_path / "f.vtk")), "rb") as f:
        f.readline()
        title = f.readline().decode()
    assert "units si" in title and "stress [kg m^-1 s^-2]" in title and len(title) <= 256
    meshio = pytest.importorskip("meshio")
    mesh = meshio.read(str(tmp_path / "f.vtk"))
    assert "stress" in mesh.point_data


def test_depth_profiles_keep_their_units_in_their_file(tmp_path):
    h5py = pytest.importorskip("h5py")
    from cgbound.paper.datasets import chute_steady
    from cgbound.paper.profiles import DepthProfiles
    profiles = DepthProfiles(width=0.5).run(chute_steady()[:3])
    assert profiles.units.name == "mercury" and profiles.dim == 3
    path = profiles.to_hdf5(str(tmp_path / "p.h5"))
    with h5py.File(path, "r") as f:
        assert f["stress_zz"].attrs["units"] == "m g d^-2" and f["z"].attrs["units"] == "d"
        assert f["density"].attrs["units"] == "m d^-3"
    back = DepthProfiles.from_hdf5(path)
    assert back.units == profiles.units and back.dim == 3
