"""The silo scene (a static column in a cylinder, LAMMPS fix wall/gran/region) and its shipped genuine output."""
import os

import numpy as np
import pytest

import cgbound as cg
from cgbound.paper import scenes
from cgbound.paper.scenes import (SILO_CONTACT_MODEL, SILO_TIMESTEP, ContactModel, CylinderWall, Frames, MoveWall,
                                  Run, Scene, Settle, silo)
from cgbound.paper.scenes.lammps import PAIR_VALUES
from cgbound.readers.lammps import LammpsReader

LAMMPS = scenes.find_lammps()
needs_lammps = pytest.mark.skipif(LAMMPS is None, reason="LAMMPS (lmp) not installed")

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "lammps", "silo")
#: the shipped run: silo() with its defaults, the bottom lowered from z = 0 to -0.2 (scripts/make_silo_data.py)
SILO_RADIUS = 4.0
N_PARTICLES = 2000
BOTTOM = -0.2
GRAVITY = np.array([0.0, 0.0, -1.0])


# --------------------------------------------------------------------------------------------
# the scene and its engine input (no LAMMPS needed)

def test_silo_effects_and_input_script():
    scene = silo()
    assert scene.n_particles == N_PARTICLES
    assert scene.effects == ("3D", "normal contact force", "normal contact damping", "tangential contact force",
                             "tangential contact damping", "sliding friction", "rotation", "gravity", "walls",
                             "cylinder wall")
    lines = scenes.input_script(scene, [Frames(1, 1.0)]).splitlines()
    assert "region          wall0region cylinder z 0.0 0.0 4.0 INF INF side in units box" in lines
    assert ("fix             wall0 flow wall/gran/region hooke/history 20000.0 5714.285714285714 88.0 44.0 0.5 1 "
            "region wall0region contacts") in lines
    assert ("fix             wall1 flow wall/gran hooke/history 20000.0 5714.285714285714 88.0 44.0 0.5 1 "
            "zplane 0.0 NULL contacts") in lines
    assert any(line.endswith("f_wall0[*] f_wall1[*]") for line in lines if line.startswith("dump            fa"))
    text = "\n".join(lines)
    for word in ("freeze", "viscous", "enforce2d", "group           fixed"):
        assert word not in text, word
    data = scenes.data_file(scene).splitlines()
    assert f"{N_PARTICLES} atoms" in data


def test_move_wall_redefines_the_same_wall_fix():
    scene = silo(n_particles=50)
    lines = scenes.input_script(scene, [Settle(), MoveWall(1, -0.05), Frames(1, 1.0)]).splitlines()
    k = lines.index("unfix           wall1")
    assert lines[k + 1] == ("fix             wall1 flow wall/gran hooke/history 20000.0 5714.285714285714 88.0 44.0 "
                            "0.5 1 zplane -0.05 NULL contacts")
    assert all(line.endswith("f_wall0[*] f_wall1[*]") for line in lines if line.startswith("dump            fa"))


def test_move_wall_slowly_uses_a_moving_plane_region():
    scene = silo(n_particles=50)
    lines = scenes.input_script(scene, [MoveWall(1, -0.2, 10.0)]).splitlines()
    k = lines.index("unfix           wall1")
    assert lines[k + 1:k + 7] == [
        'variable        wall1shift0 equal "ramp(0.0,-0.2)"',
        "region          wall1moving0 plane 0.0 0.0 0.0 0.0 0.0 1.0 side in move NULL NULL v_wall1shift0 units box",
        "fix             wall1 flow wall/gran/region hooke/history 20000.0 5714.285714285714 88.0 44.0 0.5 1 "
        "region wall1moving0 contacts",
        f"run             {int(round(10.0 / SILO_TIMESTEP))}",
        "unfix           wall1",
        "fix             wall1 flow wall/gran hooke/history 20000.0 5714.285714285714 88.0 44.0 0.5 1 "
        "zplane -0.2 NULL contacts"]


@pytest.mark.parametrize("stage, name", [(MoveWall(0, 0.0), "index"), (MoveWall(2, 0.0), "index"),
                                         (MoveWall(1, np.inf), "position"), (MoveWall(1, -0.2, -1.0), "duration"),
                                         (MoveWall(1, -0.2, 1e-5), "duration")])
def test_move_wall_needs_a_flat_wall_and_a_position(stage, name):
    with pytest.raises(ValueError, match=name):
        scenes.input_script(silo(n_particles=50), [stage])


def test_silo_particles_start_inside_the_cylinder_without_overlaps():
    scene = silo()
    x, r = scene.positions, scene.radii
    assert np.all(np.hypot(x[:, 0], x[:, 1]) + r < SILO_RADIUS)
    assert np.all(x[:, 2] - r > 0.0)
    d = np.linalg.norm(x[:, None, :] - x[None, :, :], axis=-1) - (r[:, None] + r[None, :])
    np.fill_diagonal(d, np.inf)
    assert d.min() > 0.0
    assert np.allclose(scene.masses, (2 * r) ** 3)
    # the time step resolves the shortest collision (two of the smallest particles) by 50 steps
    assert scene.timestep <= SILO_CONTACT_MODEL.collision_time(0.5 * scene.masses.min()) / 50


def test_silo_is_reproducible_and_seeded():
    a, b, c = silo(n_particles=50), silo(n_particles=50), silo(n_particles=50, seed=1)
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.radii, b.radii)
    assert not np.array_equal(a.positions, c.positions)


@pytest.mark.parametrize("make, name", [
    (lambda: silo(n_particles=0), "n_particles"),
    (lambda: silo(n_particles=2.5), "n_particles"),
    (lambda: silo(radius=1.0), "radius"),
    (lambda: silo(polydispersity=0.6), "polydispersity"),
    (lambda: CylinderWall("w", (0, 0), 1.0), "axis"),
    (lambda: CylinderWall("z", (0, 0, 0), 1.0), "center"),
    (lambda: CylinderWall("z", (0, np.nan), 1.0), "center"),
    (lambda: CylinderWall("z", (0, 0), -1.0), "radius"),
    (lambda: Scene("flat", cg.Box([0, 0], [4, 4]), [[1, 1]], [0.5], [1.0], ContactModel(kn=1e4),
                   walls=[CylinderWall("z", (0, 0), 1.0)]), "walls"),
])
def test_bad_silo_arguments_are_named(make, name):
    with pytest.raises(ValueError, match=name):
        make()


@needs_lammps
def test_small_silo_runs_and_its_wall_contacts_lie_on_the_cylinder(tmp_path):
    scene = silo(n_particles=60, radius=2.0)
    run = scenes.run_scene(scene, [Run(4.0), Frames(1, 0.5)], workdir=tmp_path)
    snap = run.snapshots[0]
    assert snap.n_particles == 60
    wall = snap.contacts.j < 0
    points = snap.contacts.point[wall]
    on_side = np.abs(np.hypot(points[:, 0], points[:, 1]) - 2.0) < 1e-12
    on_base = points[:, 2] == 0.0
    assert np.all(on_side | on_base) and on_side.any() and on_base.any()


# --------------------------------------------------------------------------------------------
# the shipped genuine output (tests/data/lammps/silo, made by scripts/make_silo_data.py)

@pytest.fixture(scope="module")
def reader():
    return LammpsReader(os.path.join(DATA, "frames.atoms.dump.gz"), os.path.join(DATA, "frames.pairs.dump.gz"),
                        pair_values=PAIR_VALUES, walls=["wall0", "wall1"], body_force=GRAVITY, dt=SILO_TIMESTEP)


def side_and_base(snap):
    """Masks of the contacts with the cylinder wall and with the bottom wall."""
    c = snap.contacts
    wall = c.j < 0
    r = np.hypot(c.point[:, 0], c.point[:, 1])
    side = wall & (np.abs(r - SILO_RADIUS) < 1e-12)
    base = wall & np.isclose(c.point[:, 2], BOTTOM, rtol=0, atol=1e-12)
    return side, base


def test_shipped_silo_input_is_what_the_scene_writes_today():
    # the shipped run is the scene of this code base with the stages of scripts/make_silo_data.py
    scene = silo()
    stages = [Settle(tolerance=1e-4, chunk=1.0, max_time=150.0), MoveWall(1, BOTTOM, 10.0),
              Settle(tolerance=1e-4, chunk=1.0, max_time=150.0), Frames(2, 1.0)]
    with open(os.path.join(DATA, "in.scene")) as f:
        assert f.read() == scenes.input_script(scene, stages)
    with open(os.path.join(DATA, "scene.data")) as f:
        assert f.read() == scenes.data_file(scene)


def test_shipped_silo_particles_and_contacts(reader):
    assert len(reader) >= 2
    for snap in reader:
        assert snap.n_particles == N_PARTICLES and not snap.fixed.any()
        x, r = snap.positions, snap.radii
        assert np.all(np.hypot(x[:, 0], x[:, 1]) - r < SILO_RADIUS) and np.all(x[:, 2] - r < 0.01 + x[:, 2].max())
        c = snap.contacts
        side, base = side_and_base(snap)
        wall = c.j < 0
        # every wall contact is on one of the two walls, both walls carry contacts, and the
        # particle-particle contacts outnumber the particles (a packed column)
        assert np.array_equal(wall, side | base) and not np.any(side & base)
        assert side.sum() > 100 and base.sum() > 20 and (~wall).sum() > N_PARTICLES
        # the contact point is where the particle touches the wall: a radius away from its centre
        gap = np.linalg.norm(x[c.i[wall]] - c.point[wall], axis=1) - r[c.i[wall]]
        assert np.all(gap < 0) and np.all(gap > -0.01)


def test_shipped_silo_per_particle_force_balance(reader):
    # contacts + weight = the force LAMMPS dumped for every particle (frames written inside run 0)
    for k in range(len(reader)):
        assert reader.force_mismatch(k) < 1e-12


def test_shipped_silo_wall_friction_obeys_coulomb(reader):
    for snap in reader:
        side, _ = side_and_base(snap)
        c = snap.contacts
        e_r = c.point[side] / SILO_RADIUS
        e_r[:, 2] = 0.0
        normal = np.einsum("ij,ij->i", c.force[side], e_r)
        tangential = np.linalg.norm(c.force[side] - normal[:, None] * e_r, axis=1)
        assert np.all(normal < 0)  # the wall pushes inwards
        assert np.all(tangential <= SILO_CONTACT_MODEL.friction * -normal * (1 + 1e-9))


def test_shipped_silo_column_force_balance(reader):
    """The static column: the forces of the cylinder wall and the bottom carry the weight, up to the
    kinetic residue (total mass times the mean acceleration, the sum of the dumped particle forces)."""
    for k, snap in enumerate(reader):
        side, base = side_and_base(snap)
        c = snap.contacts
        weight = snap.masses.sum() * GRAVITY
        wall_force = c.force[side].sum(axis=0) + c.force[base].sum(axis=0)
        residue = reader.dumped_forces(k).sum(axis=0)
        # an identity: pair forces cancel in the sum over particles
        assert np.allclose(wall_force + weight, residue, rtol=0, atol=1e-9 * np.abs(weight[2]))
        # at rest: the residue is a tiny fraction of the weight
        assert np.linalg.norm(residue) < 1e-3 * np.abs(weight[2])
        # the Janssen effect: the cylinder wall's friction carries a good part of the weight
        side_share = c.force[side, 2].sum() / -weight[2]
        assert 0.2 < side_share < 0.9
