"""The MercuryDPM reader on genuine MercuryDPM output (a chute with particle insertion), checked against
MercuryCG's own .stat files of the same run (tests/data/mercurydpm/README.md says how both were made)."""
import os
import shutil

import numpy as np
import pytest

import cgbound as cg
from cgbound.cli import main
from cgbound.readers import MercuryReader

HERE = os.path.join(os.path.dirname(__file__), "data", "mercurydpm", "ChutePeriodicDemo")
STEM = os.path.join(HERE, "ChutePeriodicDemo")


def reader(restart=STEM + ".restart", **options):
    return MercuryReader(STEM + ".data", STEM + ".fstat", restart_path=restart, **options)


def test_fixed_base_particles_found_in_every_frame_while_particles_are_inserted():
    frames = reader()
    counts = [frames[k].n_particles for k in range(len(frames))]
    assert counts[0] == 960 and counts[-1] == 1025 and counts == sorted(counts)
    for k in range(len(frames)):
        snap = frames[k]
        # the 210 base particles are the first rows of every frame (the insertion boundary's template
        # particle in the .restart is not a particle)
        assert snap.fixed.sum() == 210 and snap.fixed[:210].all()


def test_domain_averages_agree_with_mercurycg_to_its_printed_digits():
    # MercuryCG ... -coordinates O -tmin 15: every field averaged over the domain, 6 significant digits,
    # compression-positive ContactStress = bulk + boundary contact stress, symmetric MomentumFlux
    stat = np.loadtxt(STEM + ".O.stat", skiprows=2)
    frames = reader()
    upper = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]
    times = [frames[k].time for k in range(len(frames))]
    for row in stat:
        snap = frames[times.index(row[0])]
        grid = cg.Grid(snap.box, (1, 1, 1), average=("x", "y", "z"))
        out = cg.coarse_grain(snap, grid, cg.Lucy(1.0), convention="compression",
                              fields=("volume_fraction", "density", "momentum", "momentum_flux", "contact_stress",
                                      "boundary_stress", "interaction_force_density"))
        flux = out.momentum_flux.reshape(3, 3)
        ours = np.concatenate([out.volume_fraction.ravel(), out.density.ravel(), out.momentum.ravel(),
                               [flux[a, b] for a, b in upper], (out.contact_stress + out.boundary_stress).ravel(),
                               out.interaction_force_density.ravel()])
        np.testing.assert_allclose(ours, row[1:24], rtol=5e-6, atol=0)


def test_cli_uses_the_companion_files_and_reproduces_mercurycg_density(tmp_path, capsys):
    out = tmp_path / "o.npz"
    assert main(["run", STEM + ".data", "--kernel", "lucy", "--cutoff", "1", "--grid", "1",
                 "--average", "x,y,z", "--fields", "density", "--time-average", "none", "--start", "6", "-o",
                 str(out), "-q"]) == 0
    err = capsys.readouterr().err
    assert "ChutePeriodicDemo.fstat" in err and "ChutePeriodicDemo.restart" in err
    stat = np.loadtxt(STEM + ".O.stat", skiprows=2)
    with np.load(out) as result:
        np.testing.assert_allclose(result["density"].ravel(), stat[:, 2], rtol=5e-6)


def copy_restart(tmp_path, edit):
    lines = open(STEM + ".restart").read().splitlines(keepends=True)
    target = tmp_path / "c.restart"
    target.write_text("".join(edit(lines)))
    return str(target)


def test_truncated_restart_is_refused_naming_the_file_and_line(tmp_path):
    path = copy_restart(tmp_path, lambda lines: lines[:600])
    with pytest.raises(ValueError, match=r"c.restart:19: 'Particles 1025' but \d+ particle lines follow"):
        reader(path)


def test_restart_whose_fixed_particle_moved_is_refused(tmp_path):
    def swap(lines):
        # the first two particle lines exchanged: a fixed particle now claims another's place
        k = next(i for i, line in enumerate(lines) if line.startswith("BaseParticle"))
        lines[k], lines[k + 1] = lines[k + 1], lines[k]
        return lines
    frames = reader(copy_restart(tmp_path, swap))
    with pytest.raises(ValueError, match="particle 0 is fixed in .* but sits at"):
        frames[0]


def test_frame_with_more_particles_than_the_restart_is_refused(tmp_path):
    def drop_last(lines):
        k = max(i for i, line in enumerate(lines) if line.startswith("BaseParticle"))
        del lines[k]
        return [line.replace("Particles 1025", "Particles 1024") for line in lines]
    frames = reader(copy_restart(tmp_path, drop_last))
    frames[0]                                  # 960 particles: fine
    with pytest.raises(ValueError, match="holds 1024 particles but the frame at t = 20.0001 .* has 1025"):
        frames[len(frames) - 1]


def test_without_restart_and_fixed_the_reader_has_no_fixed_particles_but_fixed_ids_work(tmp_path):
    # no restart: the user names the fixed particles (the CLI's --fixed-ids)
    frames = MercuryReader(STEM + ".data", STEM + ".fstat", density=6 / np.pi, fixed=np.arange(210),
                           periodic=(True, True, False))
    assert frames[3].fixed.sum() == 210
    shutil.copy(STEM + ".data", tmp_path / "alone.data")
    assert MercuryReader(tmp_path / "alone.data", density=1.0)[0].fixed.sum() == 0


def test_a_fixed_predicate_that_selects_nothing_is_an_error():
    frames = MercuryReader(STEM + ".data", STEM + ".fstat", density=6 / np.pi, periodic=(True, True, False),
                           fixed=lambda radius, species: species == 3)
    with pytest.raises(ValueError, match="fixed: selects no particle of the frame at t = 0"):
        frames[0]


def fstat_with(tmp_path, edit):
    """The genuine .data and an .fstat whose lines (a list of strings) ``edit`` changed; the reader of both."""
    lines = open(STEM + ".fstat").read().split("\n")
    edit(lines)
    (tmp_path / "c.fstat").write_text("\n".join(lines))
    return MercuryReader(STEM + ".data", tmp_path / "c.fstat", restart_path=STEM + ".restart")


def first_line(lines, time, test):
    """The index of the first interaction line of the frame at ``time`` whose words pass ``test``."""
    return next(k for k, line in enumerate(lines) if line.split()[:1] == [time] and test(line.split()))


@pytest.mark.parametrize("column, side", [(1, "particle"), (2, "partner")])
def test_a_contact_line_naming_a_particle_away_from_its_contact_point_is_refused(tmp_path, column, side):
    # a contact with a fixed base particle is listed once, so no pairing check sees an index changed (a damaged line,
    # or an .fstat of another run with the same times): it was read as a force on (or from) another particle
    at = {}

    def edit(lines):
        k = at["k"] = first_line(lines, "20", lambda w: 0 <= int(w[2]) < 210 <= int(w[1]))
        words = lines[k].split()
        words[column] = str(int(words[column]) + 1)
        lines[k] = " ".join(words)

    frames = fstat_with(tmp_path, edit)
    with pytest.raises(ValueError, match=rf"c.fstat:{at['k'] + 1}: the contact point .* from the centre of {side} "
                                         r".* not a contact of that particle"):
        frames[8]
    frames[7]   # the other frames read


def test_an_fstat_frame_of_another_time_is_refused_by_its_contact_points_not_its_pairing(tmp_path):
    # the lines of t = 20 labelled t = 17.5 (their particles exist in that frame): the pairing found two lines of a
    # pair "inconsistent" (their orientations flip at the wrong positions), a message about a damaged listing
    def edit(lines):
        frames = [k for k, line in enumerate(lines) if line.startswith("# ") and len(line.split()) == 3]
        head = {lines[k].split()[1]: k for k in frames}
        a, b = head["17.5"], head["20"]
        stop = frames[frames.index(b) + 1]
        moved = [" ".join(["17.5"] + line.split()[1:]) for line in lines[b + 3:stop]
                 if max(int(line.split()[1]), int(line.split()[2])) < 1018]
        lines[a + 3:b] = moved

    with pytest.raises(ValueError, match=r"c.fstat:\d+: the contact point .* not a contact of that particle, so the "
                                         r".fstat frame does not belong to this .data frame"):
        fstat_with(tmp_path, edit)[7]


@pytest.mark.parametrize("radius", ["0", "-0.5"])
def test_a_flowing_particle_without_a_positive_radius_is_refused_naming_its_line(tmp_path, radius, capsys):
    # its mass (density x volume) was refused as "--masses: expected positive masses ... at index 499" (exit 2, a
    # flag not given, no file or line)
    for suffix in (".fstat", ".restart"):
        shutil.copy(STEM + suffix, tmp_path / ("c" + suffix))
    lines = open(STEM + ".data").read().split("\n")
    words = lines[500].split()
    words[6] = radius
    lines[500] = " ".join(words)
    (tmp_path / "c.data").write_text("\n".join(lines))
    status = main(["run", str(tmp_path / "c.data"), "-q", "-o", str(tmp_path / "o.h5")])
    err = capsys.readouterr().err
    assert status == 1 and f"c.data:501: particle 499 of the frame at t = 0 has radius {radius}" in err, err


def per_frame_files(tmp_path, count=3):
    """MercuryDPM's MULTIPLE_FILES layout of the genuine run's first frames: c.data.000k and c.fstat.000k."""
    data = open(STEM + ".data").read().split("\n")
    heads = [k for k, line in enumerate(data) if len(line.split()) == 8][:count + 1]
    fstat = open(STEM + ".fstat").read().split("\n")
    marks = [k for k, line in enumerate(fstat) if line.startswith("# ") and len(line.split()) == 3][:count + 1]
    for k in range(count):
        (tmp_path / f"c.data.{k:04d}").write_text("\n".join(data[heads[k]:heads[k + 1]]) + "\n")
        (tmp_path / f"c.fstat.{k:04d}").write_text("\n".join(fstat[marks[k]:marks[k + 1]]) + "\n")
    shutil.copy(STEM + ".restart", tmp_path / "c.restart")
    return ["run", str(tmp_path / "c.data.*"), "--restart", str(tmp_path / "c.restart"),
            "--grid", "1,1,4", "--average", "x,y", "-q", "-o", str(tmp_path / "o.h5")]


def test_per_frame_files_missing_a_contact_file_or_out_of_time_order_are_refused(tmp_path, capsys):
    args = per_frame_files(tmp_path)
    assert main(args) == 0
    capsys.readouterr()
    # a frame's .fstat lost: every frame was read without contacts (a warning per file, exit 0)
    os.rename(tmp_path / "c.fstat.0001", tmp_path / "lost")
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "--pairs: 1 of the 3 .data files have no .fstat beside them (c.data.0001)" in err, err
    os.rename(tmp_path / "lost", tmp_path / "c.fstat.0001")
    # names whose numbers do not give the time order (the frames were coarse-grained in the names' order)
    for suffix in ("data", "fstat"):
        os.rename(tmp_path / f"c.{suffix}.0000", tmp_path / f"c.{suffix}.0007")
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "PATH: the frames of c.data.0007 (first time 0) do not come after those of c.data.0002 (last time 5)" in err


def test_fixed_ids_beyond_the_frame_name_the_flag(tmp_path, capsys):
    # an IndexError ("fixed: indices must lie in [0, 960)", exit 1) that named neither the flag nor the frame
    status = main(["run", STEM + ".data", "--fixed-ids", "0,5000", "-q", "-o",
                   str(tmp_path / "o.h5")])
    err = capsys.readouterr().err
    assert status == 2 and "--fixed-ids: particle indices must lie in [0, 960) (the frame at t = 0 has 960 " \
                           "particles), got [5000]" in err, err


def test_contacts_across_a_face_not_known_periodic_say_so():
    # without the .restart (its PeriodicBoundary lines) the chute's x and y were not periodic: a contact across a face
    # was "listed inconsistently" (the orientation flips at a box length), or with a fixed particle read wrong, silently
    frames = MercuryReader(STEM + ".data", STEM + ".fstat", restart_path=False, density=6 / np.pi,
                           fixed=np.arange(210))
    with pytest.raises(ValueError, match=r"ChutePeriodicDemo.fstat:8: the contact point lies a box length from particle "
                                         r"564 along x .* a contact across a periodic face, but x is not periodic here"):
        frames[1]
    frames = MercuryReader(STEM + ".data", STEM + ".fstat", restart_path=False, density=6 / np.pi,
                           fixed=np.arange(210), periodic=(True, True, False))
    assert len(frames[1].contacts) == 90


def test_the_body_force_is_the_restarts_tilted_gravity_and_a_contradicting_one_is_refused(tmp_path, capsys):
    # the chute's gravity is (sin 24, 0, -cos 24) (Chute::setChuteAngle); --gravity 0,0,-1 (the examples') was taken
    # silently, so every momentum balance missed g_x = 0.41 and 9 % of g_z
    frames = reader()
    g = frames[0].body_force[0]
    np.testing.assert_allclose(g, [np.sin(np.radians(24)), 0, -np.cos(np.radians(24))], rtol=1e-12, atol=1e-15)
    # the flow is near steady late in the run: the contacts carry the weight of the tilted gravity, per unit mass
    carried = []
    for k in range(4, len(frames)):
        snap = frames[k]
        c, flowing = snap.contacts, ~snap.fixed
        total = np.zeros_like(snap.positions)
        np.add.at(total, c.i, c.force)
        np.add.at(total, c.j[c.j >= 0], -c.force[c.j >= 0])
        carried.append(total[flowing].sum(axis=0) / snap.masses[flowing].sum())
    np.testing.assert_allclose(np.mean(carried, axis=0), -g, atol=0.05)
    with pytest.raises(ValueError, match=r"body_force: \[0.0, 0.0, -1.0\] is not the gravity the run used, "
                                         r"\[0.4067366430758, 0.0, -0.913545457642601\]"):
        reader(body_force=(0, 0, -1))
    assert np.array_equal(reader(body_force=(0.40674, 0, -0.91355))[0].body_force[0], g)
    status = main(["run", STEM + ".data", "--gravity", "0,0,-1", "-q", "-o", str(tmp_path / "o.h5")])
    assert status == 2 and "--gravity: [0.0, 0.0, -1.0] is not the gravity the run used" in capsys.readouterr().err
