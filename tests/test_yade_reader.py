"""The Yade path: yade_export (inside Yade) -> YadeReader -> Snapshots, checked against what Yade reported."""
import json
import os
import shutil
import subprocess

import numpy as np
import pytest

import cgbound as cg
from cgbound.readers import yade_export
from cgbound.readers.yade import YadeReader

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "data", "yade")
GRAVITY = np.array([0.0, 0.0, -9.81])


def summary(directory):
    with open(os.path.join(directory, "yade_summary.json")) as fh:
        return json.load(fh)


@pytest.fixture(scope="module", params=["walls", "periodic"])
def yade_run(request, tmp_path_factory):
    """A fresh Yade run of tests/data/yade/settle.py (skipped without yade)."""
    if shutil.which("yade") is None:
        pytest.skip("yade is not installed")
    out = tmp_path_factory.mktemp("yade_" + request.param)
    env = dict(os.environ, CGBOUND_YADE_OUT=str(out), CGBOUND_YADE_PERIODIC="1" if request.param == "periodic" else "0",
               CGBOUND_YADE_EXPORT=yade_export.__file__)
    proc = subprocess.run(["yade", "-n", "-x", os.path.join(DATA, "settle.py")], env=env, cwd=str(out),
                          capture_output=True, text=True, timeout=600)
    assert "CGBOUND_YADE_DONE" in proc.stdout, proc.stdout[-2000:] + proc.stderr[-2000:]
    return str(out), request.param == "periodic"


def check_against_yade(directory, periodic):
    info = summary(directory)
    reader = YadeReader(directory)
    assert reader.iterations == sorted(reader.iterations) and reader.iterations[-1] == info["iter"]
    frame = reader.frame(-1)
    snap = frame.snapshot
    # counts and masses as Yade printed them
    assert snap.n_particles == info["n_flow"] + info["n_bed"]
    assert int(snap.fixed.sum()) == info["n_bed"]
    assert snap.masses[snap.flowing].sum() == pytest.approx(info["flow_mass"], rel=1e-12)
    assert snap.time == pytest.approx(info["time"], rel=1e-12)
    assert np.max(snap.positions[snap.flowing, 2]) == pytest.approx(info["max_z"], rel=1e-12)
    assert np.array_equal(snap.body_force[0], GRAVITY)
    assert snap.box.periodic == (periodic,) * 3
    # every frame balances: contact forces reproduce O.forces.f to round-off
    for k in range(len(reader)):
        assert reader.force_mismatch(k) < 1e-12
    # the boundary pushes the flow with minus the force the flow exerts on the boundary bodies (Yade's number)
    _, boundary = snap.split_contacts()
    total = boundary["force"].sum(axis=0)
    weight = info["flow_mass"] * 9.81
    assert np.allclose(total, -np.array(info["boundary_force"]), rtol=0, atol=1e-9 * weight)
    # settled: the boundary carries the weight (physics, independent of Yade's own sums)
    assert total[2] == pytest.approx(weight, rel=2e-2)
    # the integral of the IFD over the domain is the total boundary force; of the density, the flowing mass
    grid = cg.Grid(snap.box, (1, 1, 1), average=("x", "y", "z"))
    res = cg.coarse_grain(snap, grid, cg.Lucy(0.6), fields=["interaction_force_density", "density"])
    ifd = res["interaction_force_density"].reshape(3) * grid.avg_extent
    assert np.allclose(ifd, total, rtol=0, atol=1e-9 * weight)
    assert float(res["density"].ravel()[0]) * grid.avg_extent == pytest.approx(info["flow_mass"], rel=1e-9)
    return reader


@pytest.mark.parametrize("name,periodic", [("periodic", True), ("walls", False)])
def test_committed_export(name, periodic):
    reader = check_against_yade(os.path.join(DATA, name), periodic)
    snap = reader[-1]
    # walls and facets are j = -1 contacts; fixed spheres are fixed particles with contacts
    assert np.any(snap.contacts.j == -1)
    assert np.any(snap.fixed[snap.contacts.i[snap.contacts.j >= 0]] | snap.fixed[snap.contacts.j[snap.contacts.j >= 0]])
    if periodic:
        assert np.all((snap.positions >= 0) & (snap.positions < snap.box.upper))


def test_fresh_yade_run(yade_run):
    directory, periodic = yade_run
    check_against_yade(directory, periodic)


def test_yade_force_sign():
    """Yade's normalForce acts on id2 from id1: a flowing sphere on a fixed one is pushed away from it."""
    frame = YadeReader(os.path.join(DATA, "walls"))[-1]
    c = frame.contacts
    pair = c.j >= 0
    branch = frame.positions[c.i[pair]] - frame.positions[c.j[pair]]
    # repulsive contacts: the force on i points from j to i
    assert np.all(np.einsum("ij,ij->i", c.force[pair], branch) > 0)


def test_order_pattern_and_list(tmp_path):
    src = os.path.join(DATA, "periodic")
    # names whose string order is not the iteration order
    shutil.copy(os.path.join(src, "yade_0000003000.npz"), tmp_path / "f_3000.npz")
    shutil.copy(os.path.join(src, "yade_0000004000.npz"), tmp_path / "f_10.npz")
    shutil.copy(os.path.join(src, "yade_0000004000.npz"), tmp_path / "other.npz")
    r = YadeReader(str(tmp_path / "f_*.npz"))
    assert r.iterations == [3000, 4000]
    r2 = YadeReader([tmp_path / "f_10.npz", tmp_path / "f_3000.npz"])
    assert r2.iterations == [3000, 4000]
    with pytest.raises(ValueError, match="two files hold iteration 4000"):
        YadeReader(str(tmp_path))
    with pytest.raises(FileNotFoundError, match="matches no file"):
        YadeReader(str(tmp_path / "none_*.npz"))
    with pytest.raises(FileNotFoundError, match="no such file"):
        YadeReader(str(tmp_path / "missing.npz"))


def tampered(tmp_path, **changes):
    with np.load(os.path.join(DATA, "walls", "yade_0000004000.npz")) as d:
        data = {k: d[k] for k in d.files}
    for key, fn in changes.items():
        data[key] = fn(data[key].copy())
    path = tmp_path / "yade_0000004000.npz"
    np.savez(path, **data)
    return str(path)


def test_errors_name_file_and_body(tmp_path):
    def nudge(f):
        f[50, 2] += 1.0
        return f
    path = tampered(tmp_path, force=nudge)
    with with_body(path):
        YadeReader(path)[0]
    assert len(YadeReader(path, check_forces=False)[0].contacts) > 0   # the user can opt out

    def partly(b):
        b[-1] = "z"
        return b
    path = tampered(tmp_path, blocked=partly)
    with pytest.raises(ValueError, match="partly blocked"):
        YadeReader(path)[0]

    path = tampered(tmp_path, version=lambda v: np.array(2))
    with pytest.raises(ValueError, match="format version 1"):
        YadeReader(path)
    bad = tmp_path / "x.npz"
    np.savez(bad, a=np.zeros(1))
    with pytest.raises(ValueError, match="cgbound-yade"):
        YadeReader(str(bad))


class with_body:
    """Asserts a force-balance error that names the file, the body and the fix."""

    def __init__(self, path):
        self.path = path

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb):
        assert kind is ValueError, kind
        msg = str(exc)
        assert self.path in msg and "body " in msg and "PyRunner" in msg and "check_forces=False" in msg, msg
        return True


def test_clump_members_are_particles():
    path = os.path.join(DATA, "clump", "yade_0000003000.npz")
    frame = YadeReader(path).frame(0)
    snap = frame.snapshot
    with np.load(path) as d:
        clump_mass = float(d["mass"][d["id"] == 7][0])
        shapes = list(d["shape"])
    assert shapes[7] == "Clump" and 7 not in frame.ids          # the clump body is not a particle
    members = frame.clump_id == 7
    assert list(frame.ids[members]) == [5, 6]
    assert snap.masses[members].sum() == pytest.approx(clump_mass, rel=1e-14)
    assert not snap.fixed[members].any() and snap.fixed.sum() == 4
    assert YadeReader(path).force_mismatch(0) < 1e-12


def test_fixed_ids_naming_no_sphere_and_a_refused_value_name_the_file_and_body(tmp_path):
    path = os.path.join(DATA, "walls")
    # an id that is no sphere of the frame (a typo, a wall's id) left the particle meant flowing, silently
    for ids in ([99999], [0], [40, -1]):
        with pytest.raises(ValueError, match=r"fixed_ids: \[.*\] is not a sphere of the frame .*yade_0000004000.npz "
                                             r"\(its spheres' ids: 5..60\)"):
            YadeReader(path, fixed_ids=ids)[0]
    assert YadeReader(path, fixed_ids=[40])[0].fixed.sum() == YadeReader(path)[0].fixed.sum() + 1

    def massless(m):
        m[24] = 0.0    # body 24, a flowing sphere
        return m
    bad = tampered(tmp_path, mass=massless)
    with pytest.raises(ValueError, match=r"yade_0000004000.npz: masses: expected positive masses .* at index 19 "
                                         r"\(index 19 is Yade body 24\)"):
        YadeReader(bad, check_forces=False)[0]


def test_a_body_force_other_than_the_runs_gravity_is_refused(tmp_path, capsys):
    # body_force= (--gravity) replaced the NewtonIntegrator's gravity silently: the force check cannot see it
    path = os.path.join(DATA, "walls")
    with pytest.raises(ValueError, match=r"body_force: \[0.0, 0.0, -1.0\] is not the gravity of the run, "
                                         r"\[0.0, 0.0, -9.81\]"):
        YadeReader(path, body_force=(0, 0, -1))[0]
    assert np.array_equal(YadeReader(path, body_force=GRAVITY)[0].body_force[0], GRAVITY)
    from cgbound.cli import main
    assert main(["run", path, "--gravity", "0,0,-1", "--width", "0.1", "-q", "-o", str(tmp_path / "o.h5")]) == 2
    assert "--gravity: [0.0, 0.0, -1.0] is not the gravity of the run" in capsys.readouterr().err


def test_a_given_body_force_is_used_when_the_runs_gravity_is_zero_or_on_override(tmp_path):
    # weight from another engine or addF leaves the NewtonIntegrator's gravity 0: --gravity was refused, no way out
    zero = tampered(tmp_path, gravity=lambda g: 0 * g)
    with pytest.warns(UserWarning, match=r"the run's gravity \(the NewtonIntegrator's\) is 0; the given body force "
                                         r"\[0.0, 0.0, -9.8\] is used"):
        assert np.array_equal(YadeReader(zero, body_force=(0, 0, -9.8))[0].body_force[0], [0, 0, -9.8])
    assert not np.any(YadeReader(zero)[0].body_force)
    path = os.path.join(DATA, "walls")
    with pytest.raises(ValueError, match=r"leave it out to use the export's, or, .* pass body_force_override=True "
                                         r"\(--gravity-override\)"):
        YadeReader(path, body_force=(0, 0, -9.8))[0]
    # a contradicting body force on demand (changed during the run); the override needs the body force
    assert np.array_equal(YadeReader(path, body_force=(0, 0, -9.8), body_force_override=True)[0].body_force[0],
                          [0, 0, -9.8])
    with pytest.raises(ValueError, match=r"body_force_override: True needs body_force="):
        YadeReader(path, body_force_override=True)
