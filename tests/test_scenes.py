"""Scenes: engine input with exactly the effects asked for, the paper's contact model, LAMMPS runs."""
import numpy as np
import pytest

import cgbound as cg
from cgbound.paper import scenes
from cgbound.paper.scenes.lammps import PAIR_VALUES
from cgbound.paper.scenes import (PAPER_COLLISION_TIME, PAPER_CONTACT_MODEL, ContactModel, Frames, Run, Scene, Settle,
                            Wall)

LAMMPS = scenes.find_lammps()
needs_lammps = pytest.mark.skipif(LAMMPS is None, reason="LAMMPS (lmp) not installed")


def minimal_scene(**changes):
    """Two particles, 3D, normal contact force only: no other effect."""
    kw = dict(name="minimal", box=cg.Box([0, 0, 0], [4, 4, 4]), positions=[[1, 2, 2], [2.1, 2, 2]],
              radii=[0.5, 0.5], masses=[1.0, 1.0], contacts=ContactModel(kn=1e4), rotation=False)
    kw.update(changes)
    return Scene(**kw)


def script_lines(scene, stages=()):
    lines = scenes.input_script(scene, list(stages)).splitlines()
    return {line for line in lines if line and not line.startswith("#")}


FORBIDDEN_IN_MINIMAL = ("gravity", "viscous", "freeze", "wall/gran", "enforce2d", "history", "nve/sphere",
                        "exclude", "group           fixed")


def test_minimal_scene_input_has_no_other_effect():
    scene = minimal_scene()
    assert scene.effects == ("3D", "normal contact force")
    text = "\n".join(script_lines(scene))
    for word in FORBIDDEN_IN_MINIMAL:
        assert word not in text, word
    assert "pair_style      gran/hooke 10000.0 NULL 0.0 0.0 0.0 0" in text
    assert "fix             integrate flow nve" in text
    assert "boundary        m m m" in text


EFFECTS = {
    "gravity": (dict(gravity=[0.0, 0.0, -2.0]), {"fix             gravity flow gravity 2.0 vector 0.0 0.0 -1.0"}, ()),
    "normal contact damping": (dict(contacts=ContactModel(kn=1e4, gamma_n=3.0)),
                               {"pair_style      gran/hooke 10000.0 NULL 3.0 0.0 0.0 0"}, ()),
    "rotation": (dict(rotation=True), {"fix             integrate flow nve/sphere"}, ()),
    "background damping": (dict(damping=0.5), {"fix             damping flow viscous 0.5"}, ()),
    "fixed particles": (dict(fixed=[True, False]), {"group           fixed type 2", "fix             frozen fixed freeze",
                                                    "neigh_modify    delay 0 exclude type 2 2"}, ()),
    "walls": (dict(walls=[Wall("z", 0.0)]),
              {"fix             wall0 flow wall/gran hooke 10000.0 NULL 0.0 0.0 0.0 0 zplane 0.0 NULL contacts"}, ()),
    "periodic x": (dict(box=cg.Box([0, 0, 0], [4, 4, 4], periodic=(True, False, False))),
                   {"boundary        p m m"}, ()),
    "sliding friction": (dict(contacts=ContactModel(kn=1e4, kt=2e3, friction=0.5)),
                         {"pair_style      gran/hooke/history 10000.0 2000.0 0.0 0.0 0.5 0"},
                         ("tangential contact force",)),
}


@pytest.mark.parametrize("effect", sorted(EFFECTS))
def test_each_effect_adds_exactly_its_lines(effect):
    changes, added, also = EFFECTS[effect]
    base, scene = minimal_scene(), minimal_scene(**changes)
    assert set(scene.effects) - set(base.effects) == {effect, *also}
    new, old = script_lines(scene), script_lines(base)
    # the lines that changed are exactly the effect's (a replaced line shows up in both differences)
    assert new - old == added
    assert len(old - new) <= len(added)


def test_two_dimensional_scene_maps_axes():
    scene = Scene("flat", cg.Box([0, 0], [5, 5]), [[1, 1], [2.05, 1]], [0.5, 0.5], [1, 1], ContactModel(kn=1e4),
                  gravity=[0.0, -1.0], rotation=False)
    lines = script_lines(scene)
    assert {"dimension       2", "boundary        f f p", "fix             plane all enforce2d",
            "fix             gravity flow gravity 1.0 vector 0.0 -1.0 0.0"} <= lines
    data = scenes.data_file(scene)
    assert "-0.5 0.5 zlo zhi" in data and "1 1 1.0 1.9098593171027443 1.0 1.0 0.0" in data


def test_paper_contact_model_maps_to_the_papers_collision_time_and_restitution():
    """Damping per unit effective mass: t_c = pi / sqrt(kn / m_eff - gamma_n^2 / 4), e = exp(-gamma_n t_c / 2)."""
    tc = PAPER_CONTACT_MODEL.collision_time(m_eff=0.5)
    assert abs(tc / PAPER_COLLISION_TIME - 1) < 0.01
    assert abs(PAPER_CONTACT_MODEL.restitution(m_eff=0.5) - 0.88) < 0.01
    assert scenes.PAPER_TIMESTEP == PAPER_COLLISION_TIME / 50


@pytest.mark.parametrize("bad, match", [
    (lambda: ContactModel(kn=-1), "kn"),
    (lambda: ContactModel(kn=1e4, gamma_n=-1), "gamma_n"),
    (lambda: ContactModel(kn=1e4, friction=0.5), "kt"),
    (lambda: ContactModel(kn=1e4, kt=1e3), "friction"),
    (lambda: minimal_scene(positions=[[1, 2], [2, 2]]), "positions"),
    (lambda: minimal_scene(radii=[0.5, -0.5]), "radii"),
    (lambda: minimal_scene(masses=[1.0]), "masses"),
    (lambda: minimal_scene(gravity=[0, -1]), "gravity"),
    (lambda: minimal_scene(contacts="hooke"), "contacts"),
    (lambda: minimal_scene(damping=-1.0), "damping"),
    (lambda: minimal_scene(walls=[Wall("z", 0.0)], box=cg.Box([0, 0, 0], [4, 4, 4], periodic=True)), "walls"),
    (lambda: Wall("w", 0.0), "axis"),
    (lambda: scenes.input_script(minimal_scene(), [Run(1.5e-5)]), "duration"),
    (lambda: scenes.input_script(minimal_scene(), [Frames(0, 1.0)]), "count"),
    (lambda: scenes.input_script(minimal_scene(), ["run 100"]), "stages"),
    (lambda: scenes.run_scene("scene", [Run(1.0)]), "scene"),
    (lambda: scenes.run_scene(minimal_scene(), [Run(1.0)], executable="no-such-lammps-here"), "executable"),
])
def test_bad_input_is_refused_before_any_work(bad, match):
    with pytest.raises((ValueError, TypeError, FileNotFoundError), match=match):
        bad()


@needs_lammps
def test_binary_collision_reproduces_the_papers_collision_time_and_restitution():
    """LAMMPS at the paper's time step: t_c = 0.005 within 1 %, e = 0.88 within 0.01."""
    contact_time, restitution = scenes.measure_collision(scenes.binary_collision())
    assert abs(contact_time / PAPER_COLLISION_TIME - 1) < 0.01, contact_time
    assert abs(restitution - 0.88) < 0.01, restitution
    # and the engine agrees with the model's closed forms (Velocity-Verlet error at dt = t_c / 50)
    assert abs(contact_time / PAPER_CONTACT_MODEL.collision_time(0.5) - 1) < 0.005
    assert abs(restitution - PAPER_CONTACT_MODEL.restitution(0.5)) < 0.005


@needs_lammps
def test_boundary_2d_scene_relaxes_to_a_static_balanced_frame(tmp_path):
    run = scenes.run_scene(scenes.boundary_2d(), [Settle(1e-20, 0.5, 100.0), Frames(1, 0.5)], workdir=tmp_path)
    assert run.thermo["kinetic_energy"][-1] < 1e-20
    snap = run.snapshots[0]
    assert snap.dim == 2 and snap.fixed.sum() == 5 and len(snap.contacts) >= 8
    from cgbound.readers import LammpsReader
    reader = LammpsReader(tmp_path / "frames.atoms.dump", tmp_path / "frames.pairs.dump", fixed_types=[2],
                          pair_values=PAIR_VALUES, body_force=[0, -1], dimension=2)
    mismatch = reader.force_mismatch(0)
    assert np.nanmax(mismatch) < 1e-12
    # the whole weight goes into the base: boundary contact forces on the flow balance gravity
    c = snap.contacts
    on_flow = np.where(snap.fixed[c.i] & ~snap.fixed[c.j], -1.0, 0.0) + np.where(~snap.fixed[c.i] & snap.fixed[c.j], 1.0, 0.0)
    carried = (on_flow[:, None] * c.force).sum(axis=0)
    weight = snap.masses[~snap.fixed].sum()
    assert abs(carried[0]) < 1e-9 * weight and abs(carried[1] / weight - 1) < 1e-9
    run.write_snapshots(tmp_path / "b.h5")
    back = cg.readers.HDF5Snapshots(tmp_path / "b.h5")[0]
    np.testing.assert_array_equal(back.contacts.force, snap.contacts.force)
    assert "enforce2d" in cg.readers.HDF5Snapshots(tmp_path / "b.h5").provenance


@needs_lammps
def test_short_chute_frames_balance_and_round_trip(tmp_path):
    scene = scenes.chute(n_flowing=150, length=6.0, width=4.0, seed=5)
    assert {"gravity", "rotation", "sliding friction", "periodic x", "periodic y", "fixed particles"} <= set(scene.effects)
    run = scenes.run_scene(scene, [Run(1.0, thermo_every=0.25), Frames(2, 0.25)], workdir=tmp_path)
    assert len(run.snapshots) == 2 and run.snapshots[1].time == pytest.approx(1.25)
    assert np.all(np.diff(run.thermo["time"]) > 0) and run.thermo["time"][-1] == pytest.approx(1.25)
    from cgbound.readers import LammpsReader
    reader = LammpsReader(tmp_path / "frames.atoms.dump", tmp_path / "frames.pairs.dump", fixed_types=[2],
                          pair_values=PAIR_VALUES, body_force=scene.gravity)
    assert np.nanmax(reader.force_mismatch(1)) < 1e-12
    # the per-contact forces balance the particles: momentum balance residual at round-off
    snap = run.snapshots[1]
    pts = snap.box.lower + np.random.default_rng(0).random((50, 3)) * snap.box.lengths
    res = cg.momentum_balance_residual(snap, pts, cg.Lucy(1.0))
    assert res.relative.max() < 1e-10


def test_thermo_block_ends_at_a_line_that_is_not_three_numbers():
    from cgbound.paper.scenes.runner import _thermo
    log = "Step Time c_ke\n0 0 0\n10 0.5 2.5\n\nLoop time of 1\nStep Time c_ke\n10 0.5 2.5\n20 1.0 3.0\nWARNING: x\n"
    thermo = _thermo(log)
    assert list(thermo["step"]) == [0, 10, 20] and list(thermo["kinetic_energy"]) == [0.0, 2.5, 3.0]


def test_wall_position_is_written_as_a_plain_number():
    scene = minimal_scene(walls=[Wall("z", np.float64(0.25))])
    assert "zplane 0.25 NULL contacts" in scenes.input_script(scene, [])
