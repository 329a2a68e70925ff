"""The cgbound command line: demo and run; every error one line naming the flag, before any work."""
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

import cgbound as cg
from cgbound.cli import main
from helpers import random_snapshot

h5py = pytest.importorskip("h5py")

HOOKE3D = os.path.join(os.path.dirname(__file__), "data", "lammps", "hooke3d")
ATOMS, PAIRS = os.path.join(HOOKE3D, "atoms.dump"), os.path.join(HOOKE3D, "pairs.dump")
GRAN = "dist,fx,fy,fz,p1,p2,p3,p4"   # the compute pair/local line of tests/data/lammps/in.hooke3d
LAMMPS_ARGS = ["--pairs", PAIRS, "--pair-values", GRAN, "--fixed-types", "2", "--walls", "w", "--gravity", "0,0,-1"]


def test_demo_runs_fig3_on_the_shipped_chute(tmp_path, capsys):
    out = tmp_path / "demo.h5"
    assert main(["demo", "--output", str(out), "-q"]) == 0
    text = capsys.readouterr().out
    assert "lithostatic error" in text and "bed height" in text and "surface height" in text
    assert "with the paper's sampling" in text
    with h5py.File(out, "r") as f:
        # the shipped frames sample impacts sparsely: a few per cent, reported with the sampling error
        assert f.attrs["lithostatic_error"] < 0.1 and 0 < f.attrs["lithostatic_standard_error"] < 0.1
        assert f.attrs["bed"] < f.attrs["surface"]
        assert f["z"].shape == f["extended_stress_zz"].shape


def test_run_writes_the_same_fields_as_the_api(tmp_path, capsys):
    snaps = [random_snapshot(k, dim=3) for k in range(3)]
    cg.readers.write_snapshots(tmp_path / "in.h5", snaps)
    out = tmp_path / "out.npz"
    assert main(["run", str(tmp_path / "in.h5"), "--grid", "1,1,30", "--average", "x,y", "--width", "0.4",
                 "--fields", "density,stress", "-o", str(out), "-q"]) == 0
    assert "3 frames" in capsys.readouterr().out
    expected = cg.CoarseGrain(snaps, cg.Grid(snaps[0].box, (1, 1, 30), average=("x", "y")), cg.Gaussian(0.4),
                              fields=("density", "stress")).run().results
    with np.load(out) as data:
        np.testing.assert_allclose(data["stress"], expected.stress, rtol=1e-13)


def test_help_explains_every_option_with_an_example_per_format(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = capsys.readouterr().out
    for option in ("--kernel", "--width", "--cutoff", "--grid", "--average", "--fields", "--convention",
                   "--pair-values", "--pair-compute", "--fixed-types", "--fixed-ids", "--restart", "--masses",
                   "--dt", "--walls", "--lower", "--upper", "--figure", "--debug", "examples"):
        assert option in text
    for fmt in ("HDF5", "LAMMPS", "LIGGGHTS", "MercuryDPM", "MDAnalysis"):
        assert fmt in text


def lammps_expected(fields=("interaction_force_density",), grid_shape=(1, 1, 40), average=("x", "y"), box=None):
    from cgbound.readers import LammpsReader
    frames = LammpsReader(ATOMS, PAIRS, pair_values=GRAN.split(","), fixed_types=[2], walls=["w"], body_force=[0, 0, -1])
    grid = cg.Grid(box or frames[0].box, grid_shape, average=average)
    return cg.CoarseGrain(frames, grid, cg.Gaussian(0.25), fields=fields).run().results


def test_run_reads_lammps_dumps_told_from_their_first_line(tmp_path):
    out = tmp_path / "profile.npz"
    assert main(["run", ATOMS] + LAMMPS_ARGS + ["--grid", "1,1,40", "--average", "x,y", "--fields",
                 "density,interaction_force_density", "-o", str(out), "-q"]) == 0
    expected = lammps_expected()
    with np.load(out) as result:
        np.testing.assert_allclose(result["interaction_force_density"], expected.interaction_force_density,
                                   rtol=1e-13, atol=1e-15)


def split_frames(path, directory, stem, names):
    """Write each frame of a LAMMPS dump to its own file (as ``dump ... stem.*`` does)."""
    with open(path) as f:
        text = f.read()
    frames = ["ITEM: TIMESTEP" + part for part in text.split("ITEM: TIMESTEP")[1:]]
    out = []
    for frame, name in zip(frames, names):
        target = directory / f"{stem}.{name}.dump"
        target.write_text(frame)
        out.append(target)
    return out


def test_run_reads_per_frame_files_by_pattern_in_numeric_order(tmp_path):
    # numbers whose string order differs from their numeric order: 900 < 1000 < 20000
    names = ["900", "1000", "20000"]
    split_frames(ATOMS, tmp_path, "atoms", names)
    split_frames(PAIRS, tmp_path, "pairs", names)
    out = tmp_path / "p.npz"
    assert main(["run", str(tmp_path / "atoms.*.dump"), "--pairs", str(tmp_path / "pairs.*.dump"), "--pair-values",
                 GRAN, "--fixed-types",
                 "2", "--walls", "w", "--gravity", "0,0,-1", "--grid", "1,1,40", "--average", "x,y", "--fields",
                 "interaction_force_density", "--time-average", "none", "-o", str(out), "-q"]) == 0
    from cgbound.readers import LammpsReader
    frames = LammpsReader(ATOMS, PAIRS, pair_values=GRAN.split(","), fixed_types=[2], walls=["w"], body_force=[0, 0, -1])
    grid = cg.Grid(frames[0].box, (1, 1, 40), average=("x", "y"))
    expected = cg.CoarseGrain(frames, grid, cg.Gaussian(0.25), fields=("interaction_force_density",),
                              time_average="none").run().results
    with np.load(out) as result:
        np.testing.assert_array_equal(result["interaction_force_density"], expected.interaction_force_density)


def test_run_refuses_files_whose_numbers_contradict_their_timesteps(tmp_path, capsys):
    # the first frame (timestep 4500) named 2, the second named 1: numeric order is not time order
    split_frames(ATOMS, tmp_path, "atoms", ["2", "1"])
    assert main(["run", str(tmp_path / "atoms.*.dump"), "--grid", "1,1,5", "--average", "x,y", "--fields",
                 "density", "-o", str(tmp_path / "x.npz"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "do not come after" in err and "timestep" in err


@pytest.mark.parametrize("ext, magic", [(".png", b"\x89PNG"), (".pdf", b"%PDF"), (".svg", b"<?xml")])
def test_figure_format_follows_the_extension(tmp_path, ext, magic):
    pytest.importorskip("matplotlib")
    fig = tmp_path / f"f{ext}"
    assert main(["run", ATOMS] + LAMMPS_ARGS + ["--grid", "1,1,40", "--average", "x,y", "--fields",
                 "density,stress", "-o", str(tmp_path / "p.npz"), "--figure", str(fig), "-q"]) == 0
    assert fig.read_bytes().startswith(magic)
    # a figure of an earlier run is replaced; another file with the extension is not
    assert main(["run", ATOMS] + LAMMPS_ARGS + ["--grid", "1,1,40", "--average", "x,y", "--fields", "density", "-o",
                 str(tmp_path / "p.npz"), "--figure", str(fig), "-q"]) == 0
    mine = tmp_path / f"mine{ext}"
    mine.write_bytes(magic + b" not a figure of cgbound's")
    assert main(["run", ATOMS] + LAMMPS_ARGS + ["--grid", "1,1,40", "--average", "x,y", "--fields", "density", "-o",
                 str(tmp_path / "q.npz"), "--figure", str(mine), "-q"]) == 2
    assert mine.read_bytes() == magic + b" not a figure of cgbound's" and not (tmp_path / "q.npz").exists()


def test_run_grid_extent_from_lower_and_upper(tmp_path):
    out = tmp_path / "p.npz"
    assert main(["run", ATOMS] + LAMMPS_ARGS + ["--grid", "1,1,20", "--average", "x,y", "--lower", ",,1",
                 "--upper", ",,5", "--fields", "density", "-o", str(out), "-q"]) == 0
    from cgbound.readers import LammpsReader
    box = LammpsReader(ATOMS)[0].box
    expected = lammps_expected(("density",), (1, 1, 20), ("x", "y"), cg.Box([0, 0, 1], [6, 6, 5]))
    with np.load(out) as result:
        np.testing.assert_array_equal(result["density"], expected.density)
        np.testing.assert_allclose(result["coordinates"][0, 0, [0, -1], 2], [1.1, 4.9])
    assert box.upper[2] == 10


def test_a_pair_dump_without_pair_values_is_refused_naming_the_flag(tmp_path, capsys):
    status, err = run_error(["run", ATOMS, "--pairs", PAIRS, "--fixed-types", "2", "--walls", "w", "--gravity",
                             "0,0,-1", "-o", str(tmp_path / "o.npz")], capsys)
    assert status == 2 and err.startswith("cgbound: error: --pair-values: the contact dump")


def test_no_check_forces_reads_a_dump_written_during_a_run(tmp_path, capsys):
    atoms, pairs = os.path.join(HOOKE3D, "run_atoms.dump"), os.path.join(HOOKE3D, "run_pairs.dump")
    args = ["run", atoms, "--pairs", pairs, "--pair-values", GRAN, "--fixed-types", "2", "--walls", "w", "--gravity",
            "0,0,-1", "--grid", "1,1,10", "--average", "x,y", "--fields", "stress", "-o", str(tmp_path / "o.npz"),
            "-q"]
    status, err = run_error(args, capsys)
    assert status == 1 and "inside 'run 0'" in err and "--no-check-forces" in err
    assert main(args + ["--no-check-forces"]) == 0


def test_a_wrong_pair_values_order_fails_loudly_not_silently(tmp_path, capsys):
    # the genuine dump read with the keywords in another order: its 'dist' column (read from a tangential
    # force) is not the distance between the positions, and the error says so (the CLI exited 0 with wrong
    # physics before; then the force balance refused it, which still would without the 'dist')
    status, err = run_error(["run", ATOMS, "--pairs", PAIRS, "--pair-values", "fx,fy,fz,p1,p2,p3,p4,dist",
                             "--fixed-types", "2", "--walls", "w", "--gravity", "0,0,-1", "--grid", "1,1,10",
                             "--average", "x,y", "--fields", "stress", "-o", str(tmp_path / "o.npz"), "-q"], capsys)
    assert status == 1 and "contacts have a distance ('dist', column c_pl[8])" in err and "--pair-values" in err
    # the positions give touching distances: the contact dump's column order leads the causes and the fix
    assert "The positions look right" in err
    assert err.index("Likely causes: the contact dump's columns are not pair_values=") < err.index("labels swapped")
    assert "Fix: name the contact dump's columns in the order" in err
    assert not (tmp_path / "o.npz").exists()


def test_pair_values_name_a_reordered_pair_dump(tmp_path):
    # the same contacts written as compute pair/local fx fy fz p1 p2 p3 p4 dist (its header says only c_pl[k])
    lines = open(PAIRS).read().splitlines()
    out_lines, in_entries = [], False
    for line in lines:
        if line.startswith("ITEM:"):
            in_entries = line.startswith("ITEM: ENTRIES")
            out_lines.append(line)
        elif in_entries:
            w = line.split()
            out_lines.append(" ".join(w[:3] + w[4:11] + [w[3]]))
        else:
            out_lines.append(line)
    reordered = tmp_path / "pairs_reordered.dump"
    reordered.write_text("\n".join(out_lines) + "\n")
    out = tmp_path / "p.npz"
    args = ["run", ATOMS, "--pairs", str(reordered), "--pair-values", "fx,fy,fz,p1,p2,p3,p4,dist", "--fixed-types",
            "2", "--walls", "w", "--gravity", "0,0,-1", "--grid", "1,1,40", "--average", "x,y", "--fields",
            "interaction_force_density,contact_stress", "-o", str(out), "-q"]
    assert main(args) == 0
    expected = lammps_expected(("interaction_force_density", "contact_stress"))
    with np.load(out) as result:
        np.testing.assert_array_equal(result["contact_stress"], expected.contact_stress)


def run_error(args, capsys):
    status = main(args)
    err = capsys.readouterr().err
    return status, err


BAD = [
    (["--gravity", "0,-1"], "--gravity", "expected 3 comma-separated numbers for 3-D data, got '0,-1'"),
    (["--gravity", "0,0,abc"], "--gravity", "'abc' is not a number"),
    (["--grid", "1,1"], "--grid", "expected 3"),
    (["--grid", "1,0,4"], "--grid", "positive"),
    (["--average", "q"], "--average", "axis names"),
    (["--width", "-1"], "--width", "positive"),
    (["--width", "abc"], "--width", "not a number"),
    (["--cutoff", "nan"], "--cutoff", "finite"),
    (["--kernel", "lucy", "--width", "1e308"], "--width", "gives a Lucy cutoff of 3 x 1e+308 = inf"),
    (["--kernel", "heaviside", "--width", "1e-300"], "--width", "gives a Heaviside cutoff of 1 x 1e-300"),
    (["--kernel", "lucy", "--cutoff", "1e300"], "--cutoff", "between 1e-60 and 1e+60"),
    (["--fields", "density,nonsense"], "--fields", "unknown field 'nonsense'"),
    (["--time-average", "soon"], "--time-average", "expected mean, none"),
    (["--step", "0"], "--step", "non-zero"),
    (["--fixed-types", "3"], "--fixed-types", "select no particle"),
    (["--fixed-ids", "100000"], "--fixed-ids", "are not in"),
    (["--restart", "/nonexistent/x.restart"], "--restart", "no such file"),
    (["--density", "2"], "--density", "applies to mercury"),
    (["--lower", "0,0"], "--lower", "expected 3"),
    (["--lower", "1,,"], "--lower", "averaged"),
    (["--upper", ",,-5"], "--upper", "lower < upper"),
    (["--masses", "1:2"], "--masses", "TYPE=MASS"),
    (["--dt", "0"], "--dt", "positive"),
    (["--figure", "x.jpg"], "--figure", ".png, .pdf, .svg"),
    (["--figure-fields", "density"], "--figure-fields", "without --figure"),
    (["--pairs", "/nonexistent/p.dump"], "--pairs", "no such file"),
]


@pytest.mark.parametrize("extra, flag, text", BAD, ids=[b[1] + ":" + " ".join(b[0]) for b in BAD])
def test_every_error_is_one_line_naming_the_flag_with_status_2(tmp_path, capsys, extra, flag, text):
    out = tmp_path / "never.npz"
    base = {"--pair-values": GRAN, "--fixed-types": "2", "--walls": "w", "--gravity": "0,0,-1", "--grid": "1,1,10", "--average": "x,y",
            "--fields": "density"}
    merged = dict(base)
    for k in range(0, len(extra), 2):
        merged[extra[k]] = extra[k + 1]
    args = ["run", ATOMS, "--pairs", merged.pop("--pairs", PAIRS), "-o", str(out), "-q"]
    for key, value in merged.items():
        args += [key, value]
    status, err = run_error(args, capsys)
    assert status == 2
    assert err.startswith(f"cgbound: error: {flag}: ") and text in err, err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists()


def test_figure_on_a_grid_with_three_resolved_axes_is_refused_before_work(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    out = tmp_path / "never.npz"
    status, err = run_error(["run", ATOMS] + LAMMPS_ARGS + ["--grid", "4,4,4", "--fields", "density",
                                                            "--figure", str(tmp_path / "f.png"), "-o", str(out)],
                            capsys)
    assert status == 2 and err.startswith("cgbound: error: --figure: ") and not out.exists()


def test_a_flag_of_another_format_is_an_error_not_ignored(tmp_path, capsys):
    snaps = [random_snapshot(1, dim=3)]
    cg.readers.write_snapshots(tmp_path / "in.h5", snaps)
    status, err = run_error(["run", str(tmp_path / "in.h5"), "--fixed-types", "2", "-o", str(tmp_path / "o.npz")],
                            capsys)
    assert status == 2 and "--fixed-types: applies to lammps, liggghts input, not to hdf5 input" in err
    status, err = run_error(["run", str(tmp_path / "in.h5"), "--no-check-forces", "-o", str(tmp_path / "o.npz")],
                            capsys)
    assert status == 2 and "--no-check-forces: applies to lammps, liggghts, yade input, not to hdf5" in err


def test_unknown_format_is_named(tmp_path, capsys):
    junk = tmp_path / "junk.txt"
    junk.write_text("hello\n")
    status, err = run_error(["run", str(junk), "-o", str(tmp_path / "o.npz")], capsys)
    assert status == 2 and err.startswith("cgbound: error: --format: ") and "junk.txt" in err


def test_gzipped_per_frame_dumps_read_as_the_plain_ones(tmp_path):
    import gzip
    names = ["4500", "5000", "5500"]
    for path in split_frames(ATOMS, tmp_path, "atoms", names) + split_frames(PAIRS, tmp_path, "pairs", names):
        with open(path, "rb") as src, gzip.open(str(path) + ".gz", "wb") as dst:
            dst.write(src.read())
        os.remove(path)
    out = tmp_path / "p.npz"
    assert main(["run", str(tmp_path / "atoms.*.dump.gz"), "--pairs", str(tmp_path / "pairs.*.dump.gz"),
                 "--pair-values", GRAN, "--fixed-types", "2", "--walls", "w", "--gravity", "0,0,-1", "--grid",
                 "1,1,40", "--average", "x,y", "--fields", "interaction_force_density,stress", "--time-average",
                 "none", "-o", str(out), "-q"]) == 0
    frames = cg.readers.LammpsReader(ATOMS, PAIRS, pair_values=GRAN.split(","), fixed_types=[2], walls=["w"],
                                     body_force=[0, 0, -1])
    expected = cg.CoarseGrain(frames, cg.Grid(frames[0].box, (1, 1, 40), average=("x", "y")), cg.Gaussian(0.25),
                              fields=("stress",), time_average="none").run().results
    with np.load(out) as result:
        np.testing.assert_array_equal(result["stress"], expected.stress)


def test_missing_input_and_empty_pattern_are_named(tmp_path, capsys):
    status, err = run_error(["run", str(tmp_path / "none.dump"), "-o", str(tmp_path / "o.npz")], capsys)
    assert status == 2 and "no such file" in err
    status, err = run_error(["run", str(tmp_path / "none.*.dump"), "-o", str(tmp_path / "o.npz")], capsys)
    assert status == 2 and "matches no file" in err


def test_argparse_errors_are_one_line_with_status_2(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["run", ATOMS, "--kernel", "cubic"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("cgbound: error: argument --kernel: invalid choice") and err.count("\n") == 1


def test_data_errors_exit_1_without_traceback_and_debug_shows_it(tmp_path, capsys):
    bad = tmp_path / "atoms.dump"
    text = open(ATOMS).read().replace("ITEM: ATOMS id type", "ITEM: ATOMS idx type", 1)
    bad.write_text(text)
    args = ["run", str(bad), "--grid", "1,1,5", "--average", "x,y", "--fields", "density", "-o",
            str(tmp_path / "o.npz"), "-q"]
    status, err = run_error(args, capsys)
    assert status in (1, 2) and err.startswith("cgbound: error: ") and "Traceback" not in err and "id" in err
    with pytest.raises(Exception):
        main(args + ["--debug"])


def test_the_installed_command_prints_no_traceback(tmp_path):
    exe = shutil.which("cgbound")
    cmd = [exe] if exe else [sys.executable, "-m", "cgbound"]
    proc = subprocess.run(cmd + ["run", ATOMS, "--gravity", "0,-1", "-o", str(tmp_path / "o.npz")],
                          capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.strip() == ("cgbound: error: --gravity: expected 3 comma-separated numbers for 3-D data, "
                                   "got '0,-1'")


def test_contact_fields_without_a_contact_file_warn(tmp_path, capsys):
    assert main(["run", ATOMS, "--fixed-types", "2", "--walls", "w", "--gravity", "0,0,-1", "--grid", "1,1,10",
                 "--average", "x,y", "--fields", "stress", "-o", str(tmp_path / "o.npz"), "-q"]) == 0
    err = capsys.readouterr().err
    assert "cgbound: warning: " in err and "no contact dump" in err and "bulk contact stress is zero" in err
    assert "UserWarning" not in err


def test_mercury_companion_files_are_used_and_announced(tmp_path, capsys):
    # two frames with the same fixed particles (fixed particles stay fixed; --fixed-ids is one list)
    # (radii that reach the random contact points: the reader refuses a contact point outside its particles)
    first = random_snapshot(0, dim=3, n_wall=0)
    second = random_snapshot(1, dim=3, n_wall=0)
    snaps = [cg.Snapshot(s.positions, s.velocities, s.masses, box=s.box, contacts=s.contacts, fixed=first.fixed,
                         radii=np.full(len(s.masses), 5.0), time=t) for t, s in enumerate((first, second))]
    from cgbound.readers import write_mercury
    write_mercury(snaps, tmp_path / "m.data", tmp_path / "m.fstat")
    out = tmp_path / "o.npz"
    status = main(["run", str(tmp_path / "m.data"), "--density", "1.0", "--fixed-ids",
                   ",".join(str(k) for k in np.flatnonzero(snaps[0].fixed)), "--grid", "1,1,10", "--average", "x,y",
                   "--fields", "density,contact_stress", "-o", str(out), "-q"])
    err = capsys.readouterr().err
    assert status == 0, err
    assert "contacts from m.fstat" in err


@pytest.mark.parametrize("option", ["--output", "--figure"])
def test_demo_refuses_an_output_in_a_missing_directory_before_work(tmp_path, capsys, option):
    target = str(tmp_path / "missing" / ("x.png" if option == "--figure" else "x.h5"))
    args = ["demo", "-q", option, target] + (["--output", str(tmp_path / "d.h5")] if option == "--figure" else [])
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"cgbound: error: {option}: directory") and not (tmp_path / "d.h5").exists()


def test_input_script_gives_the_columns_types_walls_and_gravity(tmp_path):
    out = tmp_path / "p.npz"
    script = os.path.join(os.path.dirname(__file__), "data", "lammps", "in.hooke3d")
    assert main(["run", ATOMS, "--pairs", PAIRS, "--input", script, "--grid", "1,1,40", "--average", "x,y",
                 "--fields", "density,stress", "-o", str(out), "-q"]) == 0
    expected = lammps_expected(("density", "stress"))
    with np.load(out) as result:
        np.testing.assert_array_equal(result["stress"], expected.stress)


def test_var_needs_input_and_input_must_exist(tmp_path, capsys):
    status, err = run_error(["run", ATOMS, "--var", "tilt=10", "-o", str(tmp_path / "o.npz")], capsys)
    assert status == 2 and err.startswith("cgbound: error: --var: given without --input")
    status, err = run_error(["run", ATOMS, "--input", str(tmp_path / "in.none"), "-o", str(tmp_path / "o.npz")],
                            capsys)
    assert status == 2 and err.startswith("cgbound: error: --input: no such file")


def test_yade_exports_by_directory(tmp_path):
    d = os.path.join(os.path.dirname(__file__), "data", "yade", "walls")
    out = tmp_path / "y.npz"
    assert main(["run", d, "--grid", "1,1,20", "--average", "x,y", "--fields", "density,stress", "-o", str(out),
                 "-q"]) == 0
    frames = cg.readers.YadeReader(d)
    expected = cg.CoarseGrain(frames, cg.Grid(frames[0].box, (1, 1, 20), average=("x", "y")), cg.Gaussian(0.25),
                              fields=("density", "stress")).run().results
    with np.load(out) as result:
        np.testing.assert_array_equal(result["stress"], expected.stress)


def test_stat_output_is_mercurycg_format_and_its_kernel_is_checked_before_work(tmp_path, capsys):
    from cgbound.mercurycg import read_stat
    out = tmp_path / "p.stat"
    status, err = run_error(["run", ATOMS] + LAMMPS_ARGS + ["--grid", "1,1,20", "--average", "x,y", "-o", str(out)],
                            capsys)
    assert status == 2 and "--output: a MercuryCG .stat file holds MercuryCG's Gauss" in err and not out.exists()
    lucy = ["--kernel", "lucy", "--cutoff", "1", "--grid", "1,1,20", "--average", "x,y", "--fields", "density,momentum",
            "-o", str(out), "-q"]
    status, err = run_error(["run", ATOMS] + LAMMPS_ARGS + lucy, capsys)
    assert status == 2 and "--output: a MercuryCG .stat file holds MercuryCG's lower-dimensional lucy" in err
    assert "--averaged-kernel lower-dimensional" in err and not out.exists()
    assert main(["run", ATOMS] + LAMMPS_ARGS + lucy + ["--averaged-kernel", "lower-dimensional"]) == 0
    stat = read_stat(out)
    frames = cg.readers.LammpsReader(ATOMS, PAIRS, pair_values=GRAN.split(","), fixed_types=[2], walls=["w"],
                                     body_force=[0, 0, -1])
    expected = cg.CoarseGrain(frames, cg.Grid(frames[0].box, (1, 1, 20), average=("x", "y")),
                              cg.Lucy(1.0, averaged_axes="lower-dimensional"), fields=("density",)).run().results
    np.testing.assert_allclose(stat.columns["Density"].ravel(), expected.density.ravel(), rtol=5e-6)


def test_run_refuses_an_output_that_is_an_input_file_or_cannot_be_written_before_work(tmp_path, capsys):
    # `cgbound run snap.h5 -o snap.h5` replaced the snapshots by the fields; a directory, a link loop or a link into
    # a missing directory failed only after the work
    snaps = tmp_path / "snap.h5"
    cg.readers.write_snapshots(snaps, [random_snapshot(0, dim=3)])
    before = snaps.read_bytes()
    os.symlink("snap.h5", tmp_path / "link.h5")
    os.mkdir(tmp_path / "dir.h5")
    os.symlink("loop2.h5", tmp_path / "loop1.h5")
    os.symlink("loop1.h5", tmp_path / "loop2.h5")
    os.symlink(os.path.join("missing", "x.h5"), tmp_path / "dangling.h5")
    for target, expected in (("snap.h5", "is the input file"), ("link.h5", "is the input file"),
                             ("dir.h5", "is a directory"), ("loop1.h5", "cannot be followed"),
                             ("dangling.h5", "does not exist")):
        status, err = run_error(["run", str(snaps), "--grid", "1,1,4", "--average", "x,y", "-q",
                                 "-o", str(tmp_path / target)], capsys)
        assert status == 2 and err.startswith("cgbound: error: --output: ") and expected in err, (target, err)
    assert snaps.read_bytes() == before


def test_a_data_mass_that_is_not_positive_is_the_datas_error_not_the_masses_flags(tmp_path, capsys):
    path = tmp_path / "s.h5"
    cg.readers.write_snapshots(path, [random_snapshot(0, dim=3)])
    with h5py.File(path, "r+") as f:
        masses = f["frames/000000/masses"][()]
        masses[~f["frames/000000/fixed"][()]] = 0.0
        del f["frames/000000/masses"]
        f["frames/000000/masses"] = masses
    status, err = run_error(["run", str(path), "-q", "-o", str(tmp_path / "o.h5")], capsys)
    assert status == 1 and "--masses" not in err and "s.h5: frame 000000" in err, err


def test_a_grid_no_particle_reaches_is_said(tmp_path, capsys):
    # a --lower/--upper outside the data wrote zero fields (velocity NaN) with exit 0 and no word
    snaps = tmp_path / "snap.h5"
    cg.readers.write_snapshots(snaps, [random_snapshot(0, dim=3)])
    args = ["run", str(snaps), "--grid", "2,2,2", "-q", "-o", str(tmp_path / "o.h5")]
    assert main(args + ["--lower", "100,100,100", "--upper", "200,200,200"]) == 0
    err = capsys.readouterr().err
    assert "cgbound: warning: the density is zero at every node of every frame: no particle came within" in err, err
    assert main(args) == 0
    assert "warning" not in capsys.readouterr().err


def test_the_default_width_is_refused_on_particles_far_from_unit_size(tmp_path, capsys):
    # LIGGGHTS grains of 0.9 mm in SI: the default width 0.25 (for d ~ 1) smoothed the 12 mm column into one
    # uniform density of 2.2 kg/m^3 (the packing's is ~1500), exit 0
    data = os.path.join(os.path.dirname(__file__), "data", "liggghts")
    args = ["run", os.path.join(data, "atoms.dump"), "--format", "liggghts", "--pairs", os.path.join(data, "pairs.dump"),
            "--input", os.path.join(data, "in.settle"), "--grid", "1,1,10", "--average", "x,y", "--stop", "1", "-q",
            "-o", str(tmp_path / "o.h5")]
    status, err = run_error(args, capsys)
    assert status == 2 and err.startswith("cgbound: error: --width: not given, and the default 0.25 is 272 times the "
                                          "particles' median diameter d = 0.000918"), err
    assert main(args + ["--width", "0.00025"]) == 0


def test_a_2d_lammps_run_read_as_3d_is_refused_naming_dimension(tmp_path, capsys):
    # without --dimension 2 the discs were coarse-grained in 3-D: per volume through z = 0, with a "profile" along
    # z, exit 0
    data = os.path.join(os.path.dirname(__file__), "data", "lammps")
    atoms = os.path.join(data, "hooke2d", "atoms.dump")
    args = ["run", atoms, "--stop", "1", "-q", "-o", str(tmp_path / "o.h5")]
    status, err = run_error(args + ["--grid", "1,1,10", "--average", "x,y"], capsys)
    assert status == 2 and err.startswith("cgbound: error: --dimension: not given, so the data are read as 3-D, but "
                                          "every particle of the first frame has z = 0 and vz = 0"), err
    assert main(args + ["--dimension", "2", "--grid", "1,10", "--average", "x"]) == 0


def test_a_2d_lammps_run_takes_its_dimension_from_the_input_script(tmp_path, capsys):
    # the script's 'dimension 2' is the run's dimension (it was read as 3-D unless --dimension 2 was also given);
    # --gravity then takes the 2 components of the run's plane, and a --dimension the script contradicts is refused
    data = os.path.join(os.path.dirname(__file__), "data", "lammps")
    args = ["run", os.path.join(data, "hooke2d", "atoms.dump"), "--pairs", os.path.join(data, "hooke2d", "pairs.dump"),
            "--input", os.path.join(data, "in.hooke2d"), "--stop", "1", "-q", "--grid", "1,10", "--average", "x"]
    assert main(args + ["-o", str(tmp_path / "a.h5")]) == 0
    assert main(args + ["--gravity", "0,-1", "-o", str(tmp_path / "b.h5")]) == 0
    with h5py.File(tmp_path / "a.h5") as a, h5py.File(tmp_path / "b.h5") as b:
        assert sorted(a["axes"]) == ["x", "z"] and a["fields/density"].shape[-1] == 10
        assert np.array_equal(a["fields/density"][()], b["fields/density"][()]) and np.any(a["fields/density"][()] > 0)
    status, err = run_error(args + ["--dimension", "3", "-o", str(tmp_path / "c.h5")], capsys)
    assert status == 2 and "--dimension: 3 given, but the input script" in err and "says 'dimension 2'" in err, err
    assert not (tmp_path / "c.h5").exists()


def test_the_script_decides_the_dimension_only_where_it_states_it(tmp_path, capsys):
    # a script without a 'dimension' line (a run continued from a restart file) leaves --dimension 2 to the user;
    # a script that says 'dimension 3' is a 3-D run even where its first frame is a layer at z = 0 (not refused
    # as a 2-D run read in 3-D, the check the CLI makes without a script)
    data = os.path.join(os.path.dirname(__file__), "data", "lammps")
    lines = open(os.path.join(data, "in.hooke2d")).read().splitlines(keepends=True)
    assert any(line.split()[:1] == ["dimension"] for line in lines)
    (tmp_path / "in.nodim").write_text("".join(line for line in lines if line.split()[:1] != ["dimension"]))
    (tmp_path / "in.dim3").write_text("".join("dimension 3\n" if line.split()[:1] == ["dimension"] else line
                                              for line in lines))
    atoms, pairs = os.path.join(data, "hooke2d", "atoms.dump"), os.path.join(data, "hooke2d", "pairs.dump")
    base = ["run", atoms, "--pairs", pairs, "--stop", "1", "-q", "--no-check-forces"]
    assert main(base + ["--input", str(tmp_path / "in.nodim"), "--dimension", "2", "--grid", "1,10", "--average", "x",
                        "-o", str(tmp_path / "a.h5")]) == 0
    assert main(base + ["--input", str(tmp_path / "in.dim3"), "--grid", "1,1,10", "--average", "x,y",
                        "-o", str(tmp_path / "b.h5")]) == 0
    status, err = run_error(base + ["--input", str(tmp_path / "in.nodim"), "--grid", "1,1,10", "--average", "x,y",
                                    "-o", str(tmp_path / "c.h5")], capsys)
    assert status == 2 and "--dimension: not given" in err and "or --dimension 3 if the run is 3-D" in err, err


def test_gravity_override_lets_a_given_gravity_replace_the_runs(tmp_path, capsys):
    # the Yade export's gravity is (0, 0, -9.81): another --gravity is refused (it replaced the run's silently), the
    # message names the way out, which works; the flag alone, or for LAMMPS input, is an error naming it
    walls = os.path.join(os.path.dirname(__file__), "data", "yade", "walls")
    args = ["run", walls, "--width", "0.002", "--grid", "1,1,10", "--average", "x,y", "-q"]
    status, err = run_error(args + ["--gravity", "0,0,-9.8", "-o", str(tmp_path / "a.h5")], capsys)
    assert status == 2 and "--gravity: " in err and "--gravity-override" in err, err
    assert main(args + ["--gravity", "0,0,-9.8", "--gravity-override", "-o", str(tmp_path / "b.h5")]) == 0
    status, err = run_error(args + ["--gravity-override", "-o", str(tmp_path / "c.h5")], capsys)
    assert status == 2 and "--gravity-override: " in err, err
    status, err = run_error(["run", ATOMS, "--gravity-override"] + LAMMPS_ARGS + ["-o", str(tmp_path / "d.h5")],
                            capsys)
    assert status == 2 and "--gravity-override: applies to mercury, yade input" in err, err


@pytest.mark.parametrize("time_average", ["none", "0.5"])
def test_a_vtk_output_of_many_results_is_refused_before_work(tmp_path, capsys, time_average):
    # the VTK writer took frame 0 only: "2 frames -> ... wrote t.vtk" with the other frames dropped
    snaps = tmp_path / "snap.h5"
    cg.readers.write_snapshots(snaps, [random_snapshot(k, dim=3) for k in range(2)])
    status, err = run_error(["run", str(snaps), "--grid", "2,2,2", "--time-average", time_average, "-q",
                             "-o", str(tmp_path / "t.vtk")], capsys)
    assert status == 2 and "--output: a .vtk file holds one result" in err and not (tmp_path / "t.vtk").exists()


def test_an_existing_output_is_replaced_only_when_cgbound_wrote_it_as_a_result(tmp_path, capsys):
    # any existing file with the extension was replaced: another snapshot file, another program's HDF5 or .npz
    snaps = tmp_path / "snap.h5"
    cg.readers.write_snapshots(snaps, [random_snapshot(0, dim=3)])
    shutil.copy(snaps, tmp_path / "other.h5")
    np.savez(tmp_path / "mine.npz", x=np.arange(3))
    with h5py.File(tmp_path / "foreign.h5", "w") as f:
        f["data"] = np.arange(3)
    with h5py.File(tmp_path / "profiles.h5", "w") as f:     # a cgbound file that is not fields: hours of work
        f.attrs["format"] = "cgbound-depth-profiles"
    args = ["run", str(snaps), "--grid", "1,1,4", "--average", "x,y", "-q", "-o"]
    for name in ("other.h5", "mine.npz", "foreign.h5", "profiles.h5"):
        before = (tmp_path / name).read_bytes()
        status, err = run_error(args + [str(tmp_path / name)], capsys)
        assert status == 2 and "--output: " in err and "exists and is not a result file cgbound wrote" in err, err
        assert (tmp_path / name).read_bytes() == before
    for name in ("r.h5", "r.npz", "r.vtk"):       # a result of an earlier run is replaced
        assert main(args + [str(tmp_path / name)]) == 0 and main(args + [str(tmp_path / name)]) == 0
    status, err = run_error(["demo", "-q", "--output", str(snaps)], capsys)   # the demo's output as well
    assert status == 2 and "exists and is not a result file cgbound wrote" in err
    # a result made read-only to keep it: replacing by rename ignores the file's mode (as root, even its directory's)
    os.chmod(tmp_path / "r.h5", 0o444)
    before = (tmp_path / "r.h5").read_bytes()
    status, err = run_error(args + [str(tmp_path / "r.h5")], capsys)
    assert status == 2 and "--output: " in err and "is read-only (mode 0444)" in err, err
    assert (tmp_path / "r.h5").read_bytes() == before


def test_files_of_another_format_or_the_same_times_are_refused(tmp_path, capsys):
    # a copy of a snapshot file among the paths was averaged in twice; a file of another format was read as the
    # first file's format (and its errors named the wrong thing)
    first = [random_snapshot(k, dim=3) for k in range(2)]
    first = [cg.Snapshot(s.positions, s.velocities, s.masses, box=s.box, contacts=s.contacts, fixed=s.fixed,
                         radii=s.radii, time=float(k)) for k, s in enumerate(first)]
    cg.readers.write_snapshots(tmp_path / "a1.h5", first)
    shutil.copy(tmp_path / "a1.h5", tmp_path / "a2.h5")
    args = ["--grid", "1,1,4", "--average", "x,y", "-q", "-o", str(tmp_path / "o.h5")]
    status, err = run_error(["run", str(tmp_path / "a1.h5"), str(tmp_path / "a2.h5")] + args, capsys)
    assert status == 2 and "PATH: the frames of a2.h5 (first time 0) do not come after those of a1.h5 (last time 1)" \
        in err, err
    (tmp_path / "b.data").write_text("1 0 0 0 0 1 1 1\n0.5 0.5 0.5 0 0 0 0.1 0 0 0 0 0 0 0\n")
    status, err = run_error(["run", str(tmp_path / "a1.h5"), str(tmp_path / "b.data")] + args, capsys)
    assert status == 2 and "b.data is mercury data but" in err and "a1.h5 is hdf5 data" in err, err
    # a companion file among the paths (it was '--format: cannot tell the format', which --format does not mend)
    (tmp_path / "b.fstat").write_text("not a data file\n")
    status, err = run_error(["run", str(tmp_path / "b.data"), str(tmp_path / "b.fstat")] + args, capsys)
    assert status == 2 and "PATH: " in err and "b.fstat is not a data file of a known format but" in err and \
        "contact files with --pairs" in err, err


def test_a_stat_output_of_2d_data_is_refused_before_work(tmp_path, capsys):
    snaps = tmp_path / "snap.h5"
    cg.readers.write_snapshots(snaps, [random_snapshot(0, dim=2)])
    status, err = run_error(["run", str(snaps), "--grid", "1,4", "--average", "x", "--kernel", "lucy", "--averaged-kernel",
                             "lower-dimensional", "-q", "-o", str(tmp_path / "o.stat")], capsys)
    assert status == 2 and "--output: MercuryCG's .stat files are 3-D, the data are 2-D" in err, err
