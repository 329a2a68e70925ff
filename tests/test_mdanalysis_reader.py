"""MDAnalysisReader: Snapshots from MDAnalysis Universes (in memory and written with MDAnalysis's writers)."""
import pickle
import warnings

import numpy as np
import pytest

mda = pytest.importorskip("MDAnalysis")

import cgbound as cg  # noqa: E402
from cgbound.readers.mdanalysis import MDAnalysisReader  # noqa: E402

N, FRAMES = 8, 4
LENGTHS = np.array([10.0, 12.0, 14.0])


def make_arrays(seed=0, n=N, frames=FRAMES, lengths=LENGTHS):
    rng = np.random.default_rng(seed)
    pos = (rng.random((frames, n, 3)) * lengths).astype(np.float32)
    vel = rng.normal(size=(frames, n, 3)).astype(np.float32)
    frc = rng.normal(size=(frames, n, 3)).astype(np.float32)
    masses = rng.uniform(1.0, 3.0, n)
    return pos, vel, frc, masses


def memory_universe(pos, vel, frc, masses, dimensions=None, velocities=True, forces=True):
    from MDAnalysis.coordinates.memory import MemoryReader
    frames, n, _ = pos.shape
    u = mda.Universe.empty(n, n_residues=n, atom_resindex=np.arange(n))
    u.add_TopologyAttr("masses", masses)
    u.add_TopologyAttr("names", [f"A{k % 2}" for k in range(n)])
    u.add_TopologyAttr("resids", np.arange(1, n + 1))
    kwargs = {}
    if dimensions is not None:
        kwargs["dimensions"] = np.tile(np.asarray(dimensions, np.float32), (frames, 1))
    u.load_new(pos, format=MemoryReader, velocities=vel if velocities else None,
               forces=frc if forces else None, dt=0.5, **kwargs)
    return u


@pytest.fixture
def arrays():
    return make_arrays()


@pytest.fixture
def universe(arrays):
    pos, vel, frc, masses = arrays
    return memory_universe(pos, vel, frc, masses, dimensions=[*LENGTHS, 90, 90, 90])


@pytest.fixture
def files(tmp_path):
    """A GRO topology and a TRR trajectory (positions, velocities, forces, box) written by MDAnalysis."""
    pos, vel, frc, _ = make_arrays(seed=1)
    u = mda.Universe.empty(N, n_residues=N, atom_resindex=np.arange(N), trajectory=True, velocities=True,
                           forces=True)
    u.add_TopologyAttr("names", ["C"] * N)
    u.add_TopologyAttr("types", ["C"] * N)
    u.add_TopologyAttr("resnames", ["SOL"] * N)
    u.add_TopologyAttr("resids", np.arange(1, N + 1))
    u.dimensions = [*LENGTHS, 90, 90, 90]
    u.atoms.positions = pos[0]
    top, traj = str(tmp_path / "top.gro"), str(tmp_path / "traj.trr")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        u.atoms.write(top)
        with mda.Writer(traj, N) as w:
            for k in range(FRAMES):
                u.atoms.positions, u.atoms.velocities, u.atoms.forces = pos[k], vel[k], frc[k]
                u.trajectory.ts.time = 0.5 * k
                w.write(u.atoms)
    return top, traj, (pos, vel, frc)


# ------------------------------------------------------------------------------------------------

def test_round_trip_exact(universe, arrays):
    pos, vel, frc, masses = arrays
    r = MDAnalysisReader(universe)
    assert len(r) == FRAMES
    for k in range(FRAMES):
        s = r[k]
        assert isinstance(s, cg.Snapshot)
        assert s.positions.dtype == np.float64
        np.testing.assert_array_equal(s.positions, pos[k].astype(float))
        np.testing.assert_array_equal(s.velocities, vel[k].astype(float))
        np.testing.assert_array_equal(s.masses, masses)
        np.testing.assert_array_equal(r.forces(k), frc[k].astype(float))
        assert s.box == cg.Box([0, 0, 0], LENGTHS, periodic=True)
        assert not s.fixed.any()
        assert len(s.contacts) == 0
        assert s.time == pytest.approx(0.5 * k)
        assert r.time(k) == pytest.approx(0.5 * k)
    np.testing.assert_array_equal(r[-1].positions, pos[-1].astype(float))


def test_no_velocities_no_forces_no_box(arrays):
    pos, vel, frc, masses = arrays
    u = memory_universe(pos, vel, frc, masses, velocities=False, forces=False)
    r = MDAnalysisReader(u)
    s = r[1]
    assert s.velocities is None
    np.testing.assert_array_equal(s.positions, pos[1].astype(float))
    assert s.box.periodic == (False, False, False)
    assert np.all(s.box.lower <= s.positions.min(axis=0)) and np.all(s.box.upper >= s.positions.max(axis=0))
    with pytest.raises(ValueError, match="forces"):
        r.forces(0)


def test_wrap_into_periodic_box(arrays):
    pos, vel, frc, masses = arrays
    shifted = pos.copy()
    shifted[:, 0, 0] += LENGTHS[0]      # one atom a box length out along +x
    shifted[:, 1, 2] -= 2 * LENGTHS[2]  # one two box lengths out along -z
    u = memory_universe(shifted, vel, frc, masses, dimensions=[*LENGTHS, 90, 90, 90])
    s = MDAnalysisReader(u)[0]
    assert np.all(s.positions >= 0) and np.all(s.positions < LENGTHS)
    np.testing.assert_allclose(s.positions, pos[0], atol=1e-5)
    np.testing.assert_array_equal(s.positions[2:], pos[0, 2:].astype(float))
    raw = MDAnalysisReader(u, wrap=False)[0]
    np.testing.assert_array_equal(raw.positions, shifted[0].astype(float))


def test_len_slicing_iteration(universe, arrays):
    pos = arrays[0]
    r = MDAnalysisReader(universe)
    sub = r[1::2]
    assert isinstance(sub, MDAnalysisReader)
    assert len(sub) == 2 and sub.frames == [1, 3]
    np.testing.assert_array_equal(sub[1].positions, pos[3].astype(float))
    np.testing.assert_array_equal(sub[-1].positions, pos[3].astype(float))
    np.testing.assert_array_equal(sub[::-1][0].positions, pos[3].astype(float))
    assert len(r[10:]) == 0
    assert [s.time for s in r] == pytest.approx([0.0, 0.5, 1.0, 1.5])
    with pytest.raises(IndexError, match="index"):
        r[FRAMES]
    with pytest.raises(IndexError, match="index"):
        sub[-3]
    with pytest.raises(TypeError, match="index"):
        r[1.0]
    assert "4 frames" in repr(r)


def test_pickle_memory_universe(universe, arrays):
    pos, vel, _, _ = arrays
    r = MDAnalysisReader(universe, select="index 2:5")[1:]
    r2 = pickle.loads(pickle.dumps(r))
    assert len(r2) == len(r) == FRAMES - 1
    np.testing.assert_array_equal(r2[0].positions, pos[1, 2:6].astype(float))
    np.testing.assert_array_equal(r2[2].velocities, vel[3, 2:6].astype(float))


def test_files_round_trip_and_pickle_cheaply(files):
    top, traj, (pos, vel, frc) = files
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = MDAnalysisReader((top, traj))
        data = pickle.dumps(r)
        # the pickle holds the file names and a few per-atom arrays, not the trajectory
        assert len(data) < 4000
        assert b"traj.trr" in data
        r2 = pickle.loads(data)
        assert r2._universe is None
        for rr in (r, r2):
            assert len(rr) == FRAMES
            for k in range(FRAMES):
                s = rr[k]
                # TRR stores nm and nm/ps: the conversion round trip costs float32 round-off
                np.testing.assert_allclose(s.positions, pos[k], rtol=1e-6, atol=1e-5)
                np.testing.assert_allclose(s.velocities, vel[k], rtol=1e-6, atol=1e-6)
                np.testing.assert_allclose(rr.forces(k), frc[k], rtol=1e-5, atol=1e-6)
                assert s.box.periodic == (True, True, True)
                np.testing.assert_allclose(s.box.upper, LENGTHS, rtol=1e-6)
                np.testing.assert_array_equal(s.box.lower, 0.0)
                np.testing.assert_allclose(s.masses, 12.011)  # guessed by MDAnalysis from the atom type
        u = mda.Universe(top, traj)
        r3 = MDAnalysisReader(u)
        np.testing.assert_array_equal(r3[2].positions, r[2].positions)
        np.testing.assert_array_equal(pickle.loads(pickle.dumps(r3))[2].positions, r[2].positions)
        r4 = MDAnalysisReader({"args": (top, traj)}, select="index 0 1")
        np.testing.assert_array_equal(r4[1].positions, r[1].positions[:2])


def test_select_subset(universe, arrays):
    pos, vel, frc, masses = arrays
    r = MDAnalysisReader(universe, select="name A1")
    idx = np.arange(1, N, 2)
    np.testing.assert_array_equal(r.indices, idx)
    s = r[2]
    assert s.n_particles == idx.size
    np.testing.assert_array_equal(s.positions, pos[2, idx].astype(float))
    np.testing.assert_array_equal(s.velocities, vel[2, idx].astype(float))
    np.testing.assert_array_equal(s.masses, masses[idx])
    np.testing.assert_array_equal(r.forces(2), frc[2, idx].astype(float))
    assert r.atoms.n_atoms == idx.size
    with pytest.raises(ValueError, match="select"):
        MDAnalysisReader(universe, select="name nothing_here")
    with pytest.raises(ValueError, match="select"):
        MDAnalysisReader(universe, select="this is not ( a selection")


def test_fixed_selection_and_array(universe):
    r = MDAnalysisReader(universe, fixed="index 0 3")
    expected = np.zeros(N, bool)
    expected[[0, 3]] = True
    np.testing.assert_array_equal(r[0].fixed, expected)
    r2 = MDAnalysisReader(universe, fixed=expected)
    np.testing.assert_array_equal(r2[1].fixed, expected)
    # subset: a selection string or bools over all atoms map onto the selected atoms
    sub = MDAnalysisReader(universe, select="index 2:7", fixed="index 0 3")
    np.testing.assert_array_equal(sub[0].fixed, [False, True, False, False, False, False])
    sub2 = MDAnalysisReader(universe, select="index 2:7", fixed=expected)
    np.testing.assert_array_equal(sub2[0].fixed, sub[0].fixed)
    with pytest.raises(ValueError, match="fixed"):
        MDAnalysisReader(universe, fixed=np.zeros(3, bool))
    # a selection of nothing is a typo, not "no boundary"
    with pytest.raises(ValueError, match="fixed: the selection 'index 1000' selects none of the"):
        MDAnalysisReader(universe, fixed="index 1000")
    with pytest.raises(TypeError, match="fixed"):
        MDAnalysisReader(universe, fixed=[0, 3])


def test_fixed_atoms_may_have_zero_mass(arrays):
    pos, vel, frc, masses = arrays
    m = masses.copy()
    m[0] = 0.0
    u = memory_universe(pos, vel, frc, m, dimensions=[*LENGTHS, 90, 90, 90])
    with pytest.raises(ValueError, match="mass"):
        MDAnalysisReader(u)
    s = MDAnalysisReader(u, fixed="index 0")[0]
    assert s.fixed[0] and s.masses[0] > 0


def test_triclinic_box_is_an_error(arrays):
    pos, vel, frc, masses = arrays
    u = memory_universe(pos, vel, frc, masses, dimensions=[*LENGTHS, 90, 90, 60])
    r = MDAnalysisReader(u)
    with pytest.raises(ValueError, match="universe_or_args.*triclinic"):
        r[0]


def test_bad_arguments(universe):
    with pytest.raises(ValueError, match="dimension"):
        MDAnalysisReader(universe, dimension=4)
    with pytest.raises(ValueError, match="body_force"):
        MDAnalysisReader(universe, body_force=(0, -1))
    with pytest.raises(TypeError, match="contacts"):
        MDAnalysisReader(universe, contacts="no")
    with pytest.raises(TypeError, match="universe_or_args"):
        MDAnalysisReader(42)
    with pytest.raises(TypeError, match="select"):
        MDAnalysisReader(universe, select=None)


def test_missing_file(tmp_path):
    with pytest.raises(OSError, match="universe_or_args.*could not open"):
        MDAnalysisReader((str(tmp_path / "no.gro"), str(tmp_path / "no.trr")))


def test_missing_masses_message():
    from MDAnalysis.coordinates.memory import MemoryReader
    u = mda.Universe.empty(3)
    u.load_new(np.zeros((1, 3, 3), np.float32), format=MemoryReader)
    with pytest.raises(ValueError, match="masses"):
        MDAnalysisReader(u)


def test_two_dimensions(universe, arrays):
    pos, vel, _, _ = arrays
    r = MDAnalysisReader(universe, dimension=2, body_force=(0.0, -1.0))
    s = r[1]
    assert s.dim == 2
    np.testing.assert_array_equal(s.positions, pos[1, :, :2].astype(float))
    np.testing.assert_array_equal(s.velocities, vel[1, :, :2].astype(float))
    assert s.box == cg.Box([0, 0], LENGTHS[:2], periodic=True)
    np.testing.assert_array_equal(s.body_force[0], [0.0, -1.0])
    assert r.forces(1).shape == (N, 2)


def _wall_contacts(frame, snap):
    """Every particle pushed up by a wall with force (0, 0, frame + 1) at its own height."""
    n = snap.n_particles
    point = snap.positions.copy()
    point[:, 2] = 0.0
    force = np.zeros((n, 3))
    force[:, 2] = frame + 1.0
    return cg.Contacts(np.arange(n), -np.ones(n, np.int64), force, point)


def test_contacts_callable(universe):
    r = MDAnalysisReader(universe, contacts=_wall_contacts, body_force=(0, 0, -1))
    s = r[2]
    assert len(s.contacts) == N
    np.testing.assert_array_equal(s.contacts.force[:, 2], 3.0)
    np.testing.assert_array_equal(s.body_force[0], [0, 0, -1])
    # frame numbers are trajectory frames, also in a sliced reader
    np.testing.assert_array_equal(r[2:][0].contacts.force[:, 2], 3.0)
    r2 = pickle.loads(pickle.dumps(r))
    np.testing.assert_array_equal(r2[1].contacts.force[:, 2], 2.0)
    bad = MDAnalysisReader(universe, contacts=lambda frame, snap: "nope")
    with pytest.raises(TypeError, match="contacts"):
        bad[0]
    res = cg.coarse_grain(s, cg.Grid(s.box, (2, 2, 3)), cg.Lucy(4.0), fields=("density", "stress"))
    assert np.all(np.isfinite(res["stress"]))


def test_coarse_grain_matches_hand_built_snapshot(universe, arrays):
    pos, vel, _, masses = arrays
    box = cg.Box([0, 0, 0], LENGTHS, periodic=True)
    grid = cg.Grid(box, (3, 3, 4))
    kernel = cg.Lucy(4.0)
    fields = ("density", "momentum", "kinetic_stress")
    r = MDAnalysisReader(universe)
    hand = [cg.Snapshot(pos[k].astype(float), vel[k].astype(float), masses, box=box, time=0.5 * k)
            for k in range(FRAMES)]
    one = cg.coarse_grain(r[1], grid, kernel, fields=fields)
    ref = cg.coarse_grain(hand[1], grid, kernel, fields=fields)
    for name in fields:
        np.testing.assert_array_equal(one[name], ref[name])
    assert np.all(one["density"] >= 0) and one["density"].max() > 0

    run = cg.CoarseGrain(r, grid, kernel, fields=fields).run()
    run_ref = cg.CoarseGrain(hand, grid, kernel, fields=fields).run()
    for name in fields:
        np.testing.assert_allclose(run.results[name], run_ref.results[name], rtol=1e-13, atol=1e-15)
    assert run.n_frames == FRAMES

    sub = cg.CoarseGrain(r, grid, kernel, fields=("density",), time_average="none").run(1, None, 2)
    sub_ref = cg.CoarseGrain(hand, grid, kernel, fields=("density",), time_average="none").run(1, None, 2)
    np.testing.assert_array_equal(sub.results["density"], sub_ref.results["density"])
    assert sub.results["density"].shape[0] == 2


def test_no_import_at_cgbound_import(tmp_path):
    import subprocess
    import sys
    code = "import sys, cgbound, cgbound.readers, cgbound.readers.mdanalysis; print('MDAnalysis' in sys.modules)"
    # run outside the checkout: `python -c` puts the working directory first on sys.path, where the
    # source tree (without the compiled core) would shadow the installed package
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=tmp_path)
    assert out.stdout.strip() == "False"
