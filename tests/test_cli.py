"""The cgbound command line: demo and run."""
import numpy as np
import pytest

import cgbound as cg
from cgbound.cli import main
from helpers import random_snapshot

h5py = pytest.importorskip("h5py")


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


def test_help_explains_every_option(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = capsys.readouterr().out
    for option in ("--kernel", "--width", "--cutoff", "--grid", "--average", "--fields", "--convention", "example:"):
        assert option in text


def test_run_reads_lammps_dumps(tmp_path, capsys):
    import os
    data = os.path.join(os.path.dirname(__file__), "data", "lammps", "hooke3d")
    out = tmp_path / "profile.npz"
    assert main(["run", os.path.join(data, "atoms.dump"), "--format", "lammps", "--pairs",
                 os.path.join(data, "pairs.dump"), "--fixed-types", "2", "--walls", "w", "--gravity", "0,0,-1",
                 "--grid", "1,1,40", "--average", "x,y", "--fields", "density,interaction_force_density",
                 "-o", str(out), "-q"]) == 0
    from cgbound.readers import LammpsReader
    frames = LammpsReader(os.path.join(data, "atoms.dump"), os.path.join(data, "pairs.dump"), fixed_types=[2],
                          walls=["w"], body_force=[0, 0, -1])
    grid = cg.Grid(frames[0].box, (1, 1, 40), average=("x", "y"))
    expected = cg.CoarseGrain(frames, grid, cg.Gaussian(0.25), fields=("interaction_force_density",)).run().results
    with np.load(out) as result:
        np.testing.assert_allclose(result["interaction_force_density"], expected.interaction_force_density,
                                   rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("option", ["--output", "--png"])
def test_demo_refuses_an_output_in_a_missing_directory_before_work(tmp_path, option):
    target = str(tmp_path / "missing" / "x.out")
    args = ["demo", "-q", option, target] + (["--output", str(tmp_path / "d.h5")] if option == "--png" else [])
    with pytest.raises(SystemExit, match=option):
        main(args)
