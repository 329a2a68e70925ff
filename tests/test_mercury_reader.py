"""The MercuryDPM reader on small .data/.fstat/.restart files written by hand.

The files follow the layouts of DPMBase::outputXBallsData (.data), DPMBase::writeFstatHeader and
BaseInteraction::writeToFStat (.fstat: a pair of flowing particles twice, i and j swapped and n, t
negated; walls once with j = -1 - wallIndex and n, t flipped) and BaseParticle::write /
ParticleSpecies::write (.restart keys); see cgbound/readers/mercury.py.
"""
import math
import os
import pickle
import warnings

import numpy as np
import pytest

import cgbound as cg
from cgbound.readers.mercury import MercuryReader, write_mercury

# ------------------------------------------------------------------------------------------------
# 3D: particles 0, 1 (species 0) and 2 (species 1, fixed); wall 0 at z = 0 (plus wall 1).
DATA3 = """\
3 0 -1 -1 0 2 2 2 
0 0 0.45 1 0 0 0.5 0 0 0 0 0 0 0
0.9 0 0.45 0 0 0 0.5 0 0 0 0 0 0 0
0 0.9 0.45 0 0 0 0.5 0 0 0 0 0 0 1
3 0.1 -1 -1 0 2 2 2 
0 0 0.45 1 0 -0.5 0.5 0 0 0 0 0 0 0 7
0.9 0 0.45 0 2 0 0.5 0.1 0.2 0.3 1 2 3 0 8
0 0.9 0.45 0 0 0 0.5 0 0 0 0 0 0 1 9
"""
# time i j cx cy cz delta deltat fn ft nx ny nz tx ty tz
FSTAT3 = """\
# 0 1
# -1 -1 0 2 2 2
# 0.5 0.5 0 0 0 0
# 0.1 1
# -1 -1 0 2 2 2
# 0.5 0.5 0 0 0 0
0.1 0 1 0.45 0 0.45 0.1 0 2 0.5 -1 0 0 0 0 1
0.1 1 0 0.45 0 0.45 0.1 0 2 0.5 1 0 0 0 0 -1
0.1 0 2 0 0.45 0.45 0.1 0 1 0 0 -1 0 0 0 0
0.1 0 -1 0 0 0 0.1 0 3 0.2 0 0 -1 -1 0 0
0.1 1 -2 0.9 0 0 0.1 0 1.5 0 0 0 -1 0 0 0
"""
RESTART3 = """\
restart_version 1.0 name test
dataFile name test.data fileType ONE_FILE saveCount 10 counter 2 nextSavedTimeStep 20
xMin -1 xMax 2 yMin -1 yMax 2 zMin 0 zMax 2
timeStep 0.01 time 0.1 ntimeSteps 10 timeMax 0.1
systemDimensions 3 particleDimensions 3 gravity 0 0 -1
Species 2
LinearViscoelasticSlidingFrictionSpecies id 0 density 2000 stiffness 100000 dissipation 0 slidingStiffness 0
LinearViscoelasticSlidingFrictionSpecies id 1 density 1000 stiffness 100000 dissipation 0 slidingStiffness 0
LinearViscoelasticSlidingFrictionMixedSpecies idA 1 idB 0 stiffness 100000 dissipation 0
Walls 1
InfiniteWall id 0 indSpecies 0 position 0 0 0 orientation 1 0 0 0 velocity 0 0 0 normal 0 0 -1
Boundaries 1
PeriodicBoundary id 0 normal 1 0 0 scaleFactor 1 distanceLeft -1 distanceRight 2 shift 3 0 0
Particles 3
SphericalParticle id 0 indSpecies 0 position 0 0 0.45 orientation 1 0 0 0 velocity 1 0 -0.5 angularVelocity 0 0 0 force 0 0 0 torque 0 0 0 radius 0.5 invMass 0.00095
SphericalParticle id 1 indSpecies 0 position 0.9 0 0.45 orientation 1 0 0 0 velocity 0 2 0 angularVelocity 1 2 3 force 0 0 0 torque 0 0 0 radius 0.5 invMass 0.00095
SphericalParticle id 2 indSpecies 1 position 0 0.9 0.45 orientation 1 0 0 0 velocity 0 0 0 angularVelocity 0 0 0 force 0 0 0 torque 0 0 0 radius 0.5 invMass 0
Interactions 0
"""

# 2D: MercuryDPM x, y -> cgbound (x, z); wall 0 at y = 0.
DATA2 = """\
2 0.5 -1 0 2 2 
0 0.45 1 -1 0.5 0 0 0
0.9 0.45 0 0 0.5 0 0 1
"""
FSTAT2 = """\
# 0.5 1
# -1 0 0 2 2 0
# 0.5 0.5 0 0 0 0
0.5 0 1 0.45 0.45 0 0.1 0 2 0.5 -1 0 0 0 1 0
0.5 1 0 0.45 0.45 0 0.1 0 2 0.5 1 0 0 0 -1 0
0.5 0 -1 0 0 0 0.1 0 3 0 0 -1 0 0 0 0
"""


def write(tmp_path, **files):
    out = {}
    for name, text in files.items():
        p = tmp_path / name
        p.write_text(text)
        out[name] = str(p)
    return out


@pytest.fixture
def files3(tmp_path):
    return write(tmp_path, **{"a.data": DATA3, "a.fstat": FSTAT3, "a.restart": RESTART3})


@pytest.fixture
def reader3(files3):
    return MercuryReader(files3["a.data"], files3["a.fstat"], restart_path=files3["a.restart"],
                         body_force=(0, 0, -1))


def contact_dict(snap):
    c = snap.contacts
    return {(int(i), int(j)): (f, p) for i, j, f, p in zip(c.i, c.j, c.force, c.point)}


# ------------------------------------------------------------------------------------------------
def test_3d_particles(reader3):
    assert len(reader3) == 2
    snap = reader3[1]
    assert snap.dim == 3 and snap.time == 0.1
    np.testing.assert_array_equal(snap.positions, [[0, 0, 0.45], [0.9, 0, 0.45], [0, 0.9, 0.45]])
    np.testing.assert_array_equal(snap.velocities, [[1, 0, -0.5], [0, 2, 0], [0, 0, 0]])
    np.testing.assert_array_equal(snap.radii, [0.5, 0.5, 0.5])
    np.testing.assert_array_equal(snap.species, [0, 0, 1])
    np.testing.assert_array_equal(snap.fixed, [False, False, True])      # invMass 0 in the restart
    m = 2000 * 4 / 3 * math.pi * 0.5 ** 3
    np.testing.assert_allclose(snap.masses[:2], [m, m], rtol=1e-15)
    np.testing.assert_array_equal(snap.box.lower, [-1, -1, 0])
    np.testing.assert_array_equal(snap.box.upper, [2, 2, 2])
    assert snap.box.periodic == (True, False, False)                    # PeriodicBoundary normal 1 0 0
    np.testing.assert_array_equal(snap.body_force[0], [0, 0, -1])


def test_3d_contacts(reader3):
    fr = reader3.frame(1)
    snap = fr.snapshot
    d = contact_dict(snap)
    assert len(snap.contacts) == 4                                       # the pair (0, 1) once
    assert set(d) == {(0, 1), (0, 2), (0, -1), (1, -1)}
    np.testing.assert_allclose(d[(0, 1)][0], [-2, 0, 0.5])               # on 0 from 1: fn n + ft t
    np.testing.assert_allclose(d[(0, 1)][1], [0.45, 0, 0.45])
    np.testing.assert_allclose(d[(0, 2)][0], [0, -1, 0])                 # fixed partner, listed once
    np.testing.assert_allclose(d[(0, -1)][0], [0.2, 0, 3])               # wall: -(fn n + ft t), n flipped
    np.testing.assert_allclose(d[(0, -1)][1], [0, 0, 0])
    np.testing.assert_allclose(d[(1, -1)][0], [0, 0, 1.5])
    walls = {int(i): int(w) for i, j, w in zip(snap.contacts.i, snap.contacts.j, fr.wall_index) if j == -1}
    assert walls == {0: 0, 1: 1}
    np.testing.assert_allclose(fr.overlap, 0.1)
    # first frame: header only, no contacts
    assert len(reader3[0].contacts) == 0


def test_force_on_each_particle(reader3):
    f = reader3[1].particle_forces()
    m = reader3[1].masses
    np.testing.assert_allclose(f[0], [-2 + 0 + 0.2, -1, 0.5 + 3 - m[0]])
    np.testing.assert_allclose(f[1], [2, 0, -0.5 + 1.5 - m[1]])


def test_unflipped_wall_normal_gives_same_force(tmp_path):
    fixed_walls = FSTAT3.replace("0.1 0 -1 0 0 0 0.1 0 3 0.2 0 0 -1 -1 0 0", "0.1 0 -1 0 0 0 0.1 0 3 0.2 0 0 1 1 0 0")
    f = write(tmp_path, **{"b.data": DATA3, "b.fstat": fixed_walls})
    snap = MercuryReader(f["b.data"], f["b.fstat"], density=1.0, fixed=[2])[1]
    np.testing.assert_allclose(contact_dict(snap)[(0, -1)][0], [0.2, 0, 3])


def test_2d(tmp_path):
    f = write(tmp_path, **{"c.data": DATA2, "c.fstat": FSTAT2})
    r = MercuryReader(f["c.data"], f["c.fstat"], density=1.0, body_force=(0, -1, 0))
    assert r.dim == 2 and len(r) == 1
    snap = r[0]
    np.testing.assert_array_equal(snap.positions, [[0, 0.45], [0.9, 0.45]])   # MercuryDPM (x, y) -> (x, z)
    np.testing.assert_array_equal(snap.velocities, [[1, -1], [0, 0]])
    np.testing.assert_array_equal(snap.species, [0, 1])
    np.testing.assert_allclose(snap.masses, math.pi * 0.25)                  # discs: rho pi R^2
    np.testing.assert_array_equal(snap.box.lower, [-1, 0])
    np.testing.assert_array_equal(snap.box.upper, [2, 2])
    np.testing.assert_array_equal(snap.body_force[0], [0, -1])
    d = contact_dict(snap)
    assert set(d) == {(0, 1), (0, -1)}
    np.testing.assert_allclose(d[(0, 1)][0], [-2, 0.5])
    np.testing.assert_allclose(d[(0, 1)][1], [0.45, 0.45])
    np.testing.assert_allclose(d[(0, -1)][0], [0, 3])
    r3 = MercuryReader(f["c.data"], f["c.fstat"], density=1.0, particle_dim=3)
    np.testing.assert_allclose(r3[0].masses, 4 / 3 * math.pi * 0.125)


def test_density_options(files3):
    # without the .restart beside them (restart_path=False): densities from density= alone
    r = MercuryReader(files3["a.data"], files3["a.fstat"], restart_path=False, density={0: 3.0},
                      fixed=np.array([False, False, True]))
    np.testing.assert_allclose(r[1].masses[:2], 3.0 * 4 / 3 * math.pi * 0.125)
    r = MercuryReader(files3["a.data"], files3["a.fstat"], restart_path=False, density={0: 3.0, 1: 5.0},
                      fixed=lambda radius, species: species == 1)
    np.testing.assert_array_equal(r[1].fixed, [False, False, True])
    with pytest.raises(ValueError, match="density"):
        MercuryReader(files3["a.data"], files3["a.fstat"], restart_path=False)[1]
    with pytest.raises(ValueError, match="no density for species"):
        MercuryReader(files3["a.data"], files3["a.fstat"], restart_path=False, density={1: 2.0})[1]


def test_len_slicing_pickle(reader3):
    tail = reader3[1:]
    assert len(tail) == 1 and tail[0].time == 0.1
    assert reader3[-1].time == 0.1
    assert [s.time for s in reader3] == [0.0, 0.1]
    blob = pickle.dumps(reader3)
    assert len(blob) < 4000
    again = pickle.loads(blob)
    np.testing.assert_array_equal(again[1].contacts.force, reader3[1].contacts.force)
    with pytest.raises(IndexError):
        reader3[2]
    with pytest.raises(TypeError):
        reader3[1.0]


def test_inconsistent_double_listing_raises(tmp_path):
    bad_force = FSTAT3.replace("0.1 1 0 0.45 0 0.45 0.1 0 2 0.5", "0.1 1 0 0.45 0 0.45 0.1 0 2.5 0.5")
    f = write(tmp_path, **{"d.data": DATA3, "d.fstat": bad_force})
    with pytest.raises(ValueError, match=r"d\.fstat: lines 7 and 8 list the pair \(0, 1\) inconsistently"):
        MercuryReader(f["d.data"], f["d.fstat"], density=1.0)[1]
    bad_point = FSTAT3.replace("0.1 1 0 0.45 0 0.45", "0.1 1 0 0.46 0 0.45")
    f = write(tmp_path, **{"e.data": DATA3, "e.fstat": bad_point})
    with pytest.raises(ValueError, match=r"e\.fstat: lines 7 and 8 .*contact points"):
        MercuryReader(f["e.data"], f["e.fstat"], density=1.0)[1]
    twice = FSTAT3.replace("0.1 1 0 0.45 0 0.45 0.1 0 2 0.5 1 0 0 0 0 -1",
                           "0.1 0 1 0.45 0 0.45 0.1 0 2 0.5 -1 0 0 0 0 1")
    f = write(tmp_path, **{"g.data": DATA3, "g.fstat": twice})
    with pytest.raises(ValueError, match=r"g\.fstat: the pair \(0, 1\) is listed 2 times \(lines 7, 8\)"):
        MercuryReader(f["g.data"], f["g.fstat"], density=1.0)[1]


def test_bad_files(tmp_path):
    ghost = FSTAT3 + "0.1 1 5 1.4 0 0.45 0.1 0 1 0 1 0 0 0 0 0\n"
    f = write(tmp_path, **{"h.data": DATA3, "h.fstat": ghost})
    with pytest.raises(ValueError, match=r"h\.fstat:12: partner index 5 .*periodic ghost"):
        MercuryReader(f["h.data"], f["h.fstat"], density=1.0)[1]
    short = FSTAT3.replace("0.1 0 2 0 0.45 0.45 0.1 0 1 0 0 -1 0 0 0 0", "0.1 0 2 0 0.45 0.45 0.1")
    f = write(tmp_path, **{"i.data": DATA3, "i.fstat": short})
    with pytest.raises(ValueError, match=r"i\.fstat:9: expected 16 columns"):
        MercuryReader(f["i.data"], f["i.fstat"], density=1.0)[1]
    f = write(tmp_path, **{"j.data": DATA3, "j.fstat": FSTAT3.replace("# 0.1 1", "# 0.2 1")})
    with pytest.raises(ValueError, match=r"no \.fstat frame for time\(s\) \[0\.1\]"):
        MercuryReader(f["j.data"], f["j.fstat"], density=1.0)
    f = write(tmp_path, **{"k.data": DATA3.replace("0.9 0 0.45 0 0 0 0.5 0 0 0 0 0 0 0\n", "0.9 0 0.45\n")})
    with pytest.raises(ValueError, match=r"k\.data:3: expected 14 columns"):
        MercuryReader(f["k.data"], density=1.0)[0]
    with pytest.raises(ValueError, match="dim=2"):
        MercuryReader(write(tmp_path, **{"l.data": DATA3})["l.data"], density=1.0, dim=2)


def test_round_trip(reader3, tmp_path):
    snaps = list(reader3)
    wall_idx = lambda s: [0 if i == 0 else 1 for i in s.contacts.i]     # noqa: E731
    assert write_mercury(snaps, tmp_path / "w.data", tmp_path / "w.fstat", wall_index=wall_idx) == 2
    back = MercuryReader(tmp_path / "w.data", tmp_path / "w.fstat", restart_path=reader3.restart_path,
                         body_force=(0, 0, -1))
    assert len(back) == 2
    for a, b in zip(snaps, back):
        for name in ("positions", "velocities", "radii", "species", "masses", "fixed"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        da, db = contact_dict(a), contact_dict(b)
        assert set(da) == set(db)
        for k in da:
            np.testing.assert_allclose(db[k][0], da[k][0], rtol=1e-14, atol=1e-14)
            np.testing.assert_allclose(db[k][1], da[k][1], rtol=1e-14, atol=1e-14)
    np.testing.assert_array_equal(back.frame(1).wall_index, reader3.frame(1).wall_index)


def test_frames_written_again_at_one_time_pair_in_file_order(tmp_path):
    """A run restarted and appended writes frames of one time twice: the second .data frame takes the second .fstat
    frame of that time (its own contacts, and its own errors), not the first one again."""
    pos = np.array([[0.5, 0.5, 0.5], [1.45, 0.5, 0.5], [0.5, 1.45, 0.5]])
    box = cg.Box([0, 0, 0], [3, 3, 3])

    def snap(j, f):
        return cg.Snapshot(pos, np.zeros((3, 3)), np.ones(3), box=box, radii=np.full(3, 0.5), time=1.0,
                           contacts=cg.Contacts([0], [j], [f], [0.5 * (pos[0] + pos[j])]))

    first, again = snap(1, [-2.0, 0.0, 0.0]), snap(2, [0.0, -3.0, 0.0])
    write_mercury([first, again], tmp_path / "r.data", tmp_path / "r.fstat")
    # each copy is read, so a time average counts that time twice: allowed, but said
    with pytest.warns(UserWarning, match=r"r.data: the frame at t = 1 is written 2 times \(lines 1, 5\), as by a run "
                                         r"restarted .* a time average counts it 2 times"):
        back = MercuryReader(tmp_path / "r.data", tmp_path / "r.fstat", restart_path=False, density=1.0,
                             periodic=(False,) * 3)
    for got, written in zip(back, (first, again)):
        a, b = contact_dict(got), contact_dict(written)
        assert set(a) == set(b)
        for k in a:
            np.testing.assert_allclose(a[k][0], b[k][0], rtol=1e-14, atol=1e-14)
    lines = (tmp_path / "r.fstat").read_text().splitlines()
    lines[-1] = lines[-1].replace(lines[-1].split()[4], "1.2.3", 1)    # damage the second frame's cy
    (tmp_path / "r.fstat").write_text("\n".join(lines) + "\n")
    with pytest.warns(UserWarning, match="written 2 times"):
        back = MercuryReader(tmp_path / "r.data", tmp_path / "r.fstat", restart_path=False, density=1.0,
                             periodic=(False,) * 3)
    back[0]
    with pytest.raises(ValueError, match=f"r.fstat \\(t = 1\\), line {len(lines)}, column 5: not a number: '1.2.3'"):
        back[1]


def test_round_trip_random_2d(tmp_path):
    rng = np.random.default_rng(3)
    n = 12
    pos = rng.uniform(0.5, 4.5, (n, 2))
    radii = rng.uniform(0.4, 0.6, n)
    pairs = [(i, j) for i in range(n) for j in range(i + 1, n) if np.linalg.norm(pos[i] - pos[j]) < radii[i] + radii[j]]
    ci = [p[0] for p in pairs] + [0, 3]
    cj = [p[1] for p in pairs] + [-1, -1]
    force = rng.normal(size=(len(ci), 2))
    point = np.array([(pos[i] + pos[j]) / 2 for i, j in pairs] + [[pos[0, 0], 0.0], [pos[3, 0], 0.0]]).reshape(-1, 2)
    fixed = np.zeros(n, bool)
    fixed[5] = True
    snap = cg.Snapshot(pos, velocities=rng.normal(size=(n, 2)), masses=np.pi * radii ** 2, radii=radii,
                       box=cg.Box([0, 0], [5, 5]), contacts=cg.Contacts(ci, cj, force, point), fixed=fixed,
                       species=np.zeros(n, np.int64), time=1.5)
    write_mercury([snap], tmp_path / "r.data", tmp_path / "r.fstat")
    back = MercuryReader(tmp_path / "r.data", tmp_path / "r.fstat", density=1.0, fixed=[5])[0]
    np.testing.assert_allclose(back.masses[~fixed], snap.masses[~fixed], rtol=1e-15)
    # a pair with the fixed particle 5 comes back oriented on the flowing particle (as MercuryDPM writes it)
    def canonical(s):
        return {((i, j) if j < 0 or i < j else (j, i)): (f if j < 0 or i < j else -f)
                for (i, j), (f, _) in contact_dict(s).items()}
    da, db = canonical(snap), canonical(back)
    assert set(da) == set(db)
    for k in da:
        np.testing.assert_allclose(db[k], da[k], rtol=1e-12, atol=1e-12)
    assert all(not back.fixed[i] for i in back.contacts.i)
    np.testing.assert_allclose(back.particle_forces(), snap.particle_forces(), rtol=1e-12, atol=1e-12)


def test_coarse_grain_runs(reader3):
    snap = reader3[1]
    grid = cg.Grid(snap.box, (3, 3, 4))
    out = cg.coarse_grain(snap, grid, cg.Gaussian(0.5), fields=("density", "stress", "interaction_force_density"))
    rho = np.asarray(out["density"])
    assert np.all(np.isfinite(rho)) and rho.max() > 0
    assert np.all(np.isfinite(np.asarray(out["stress"])))


def test_companion_files_not_given_are_named_in_a_warning(files3):
    """Reading name.data alone while name.fstat and name.restart lie beside it drops every contact and every
    fixed particle: allowed (fstat_path=False, restart_path=False), but never silently."""
    with pytest.warns(cg.readers.CompanionFileWarning) as record:
        alone = MercuryReader(files3["a.data"], density=1.0)
    messages = [str(w.message) for w in record]
    assert len(messages) == 2
    assert any(files3["a.fstat"] in m and "fstat_path=False" in m and "no contacts" in m for m in messages)
    assert any(files3["a.restart"] in m and "restart_path=False" in m and "no particle is fixed" in m
               and "no axis is periodic" in m for m in messages)
    assert alone[1].contacts is None or len(alone[1].contacts) == 0
    assert not alone[1].fixed.any()
    # what the warning says is lost is there when the files are given
    full = MercuryReader(files3["a.data"], files3["a.fstat"], restart_path=files3["a.restart"])
    assert len(full[1].contacts) > 0 and full[1].fixed.any()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        MercuryReader(files3["a.data"], False, restart_path=False, density=1.0)[1]
        MercuryReader(files3["a.data"], files3["a.fstat"], restart_path=files3["a.restart"])[1]
        # fixed= and periodic= given: the restart would add only densities, which density= gives
        MercuryReader(files3["a.data"], files3["a.fstat"], density=1.0, fixed=[2], periodic=False)[1]
    with pytest.warns(cg.readers.CompanionFileWarning, match="no axis is periodic") as record:
        MercuryReader(files3["a.data"], files3["a.fstat"], density=1.0, fixed=[2])
    assert "no particle is fixed" not in str(record[0].message)


def test_companion_arguments_other_than_paths_none_or_false_are_refused_by_name(files3):
    for name in ("fstat_path", "restart_path"):
        with pytest.raises(TypeError, match=f"{name}: expected a path, None or False, got 0"):
            MercuryReader(files3["a.data"], **{"fstat_path": False, "restart_path": False, name: 0}, density=1.0)


def test_no_warning_without_companion_files(tmp_path):
    f = write(tmp_path, **{"b.data": DATA3})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(MercuryReader(f["b.data"], density=1.0)) == 2


def test_write_mercury_replaces_the_files_only_when_every_frame_is_written(tmp_path):
    # it wrote in place: a frame it could not write (no radii) left both files truncated and half written
    snap = cg.Snapshot(np.array([[0.5, 0.5, 0.5]]), None, np.ones(1), box=cg.Box([0, 0, 0], [1, 1, 1]),
                       radii=np.full(1, 0.1))
    data, fstat = tmp_path / "r.data", tmp_path / "r.fstat"
    write_mercury([snap], data, fstat)
    before = data.read_bytes(), fstat.read_bytes()
    bare = cg.Snapshot(snap.positions, None, snap.masses, box=snap.box)
    with pytest.raises(ValueError, match="snapshots need radii"):
        write_mercury([snap, snap, bare], data, fstat)
    assert (data.read_bytes(), fstat.read_bytes()) == before and sorted(os.listdir(tmp_path)) == ["r.data", "r.fstat"]
    with pytest.raises(ValueError, match="fstat_path: the same file as data_path"):
        write_mercury([snap], data, data)


def test_a_given_body_force_is_used_when_the_restarts_gravity_is_zero_or_on_override(tmp_path):
    # a driver applying the weight in its own code writes gravity 0: --gravity was refused, no way out
    zero = RESTART3.replace("gravity 0 0 -1", "gravity 0 0 0")
    f = write(tmp_path, **{"z.data": DATA3, "z.fstat": FSTAT3, "z.restart": zero})
    with pytest.warns(UserWarning, match=r"the run's gravity is 0; the given body force \[0.0, 0.0, -2.0\] is used"):
        r = MercuryReader(f["z.data"], f["z.fstat"], restart_path=f["z.restart"], body_force=(0, 0, -2))
    np.testing.assert_array_equal(r[0].body_force[0], [0, 0, -2])
    f = write(tmp_path, **{"a.data": DATA3, "a.fstat": FSTAT3, "a.restart": RESTART3})
    with pytest.raises(ValueError, match=r"leave it out to use the restart's, or, .* pass body_force_override=True "
                                         r"\(--gravity-override\)"):
        MercuryReader(f["a.data"], f["a.fstat"], restart_path=f["a.restart"], body_force=(0, 0, -2))
    r = MercuryReader(f["a.data"], f["a.fstat"], restart_path=f["a.restart"], body_force=(0, 0, -2),
                      body_force_override=True)
    np.testing.assert_array_equal(r[0].body_force[0], [0, 0, -2])
    with pytest.raises(ValueError, match=r"body_force_override: True needs body_force="):
        MercuryReader(f["a.data"], f["a.fstat"], restart_path=f["a.restart"], body_force_override=True)


def test_2d_restart_gravity_with_a_z_component_gives_way_to_a_given_body_force(tmp_path):
    # a 2D .restart written with gravity 0 0 -1 refused even --gravity 0,-1: the plane's components, given, win
    restart = (RESTART3[:RESTART3.index("Species 2")].replace("systemDimensions 3 particleDimensions 3",
                                                              "systemDimensions 2 particleDimensions 2")
               + "Species 2\n" + RESTART3[RESTART3.index("Species 2") + 10:RESTART3.index("Walls 1")] + "Particles 0\n")
    f = write(tmp_path, **{"c.data": DATA2, "c.fstat": FSTAT2, "c.restart": restart})
    with pytest.raises(ValueError, match=r"a 2D run with gravity \[0.0, 0.0, -1.0\] .* pass body_force= \(--gravity\) "
                                         r"with the plane's two components"):
        MercuryReader(f["c.data"], f["c.fstat"], restart_path=f["c.restart"])
    with pytest.warns(UserWarning, match=r"the given body force \[0.0, -1.0\] is used"):
        r = MercuryReader(f["c.data"], f["c.fstat"], restart_path=f["c.restart"], body_force=(0, -1), fixed=[1])
    np.testing.assert_array_equal(r[0].body_force[0], [0, -1])
