"""The LIGGGHTS reader on genuine LIGGGHTS output (tests/data/liggghts/in.settle).

When ``liggghts`` is on PATH the input script is run afresh in a temporary directory (under a
second); otherwise the dumps committed next to it (written by LIGGGHTS-PUBLIC 3.8.0, Debian) are used.
"""
import os
import pickle
import shutil
import subprocess

import numpy as np
import pytest

import cgbound as cg
from cgbound.readers.liggghts import LiggghtsReader, pair_gran_local_columns

DATA = os.path.join(os.path.dirname(__file__), "data", "liggghts")
LIGGGHTS = shutil.which("liggghts")
VALUES = ("pos", "id", "force", "torque", "delta", "contactPoint")   # as in in.settle
G = (0.0, 0.0, -9.81)
TOL = 1e-9


@pytest.fixture(scope="session")
def liggghts_dir(tmp_path_factory):
    if LIGGGHTS is None:
        if os.path.exists(os.path.join(DATA, "atoms.dump")):
            return DATA      # 'liggghts' not on PATH: not regenerated, the committed dumps are used
        pytest.skip("LIGGGHTS ('liggghts') is not on PATH and no committed dumps were found")
    work = tmp_path_factory.mktemp("liggghts")
    proc = subprocess.run([LIGGGHTS, "-in", os.path.join(DATA, "in.settle"), "-log", "none", "-screen", "none"],
                          cwd=work, capture_output=True, text=True, timeout=300)
    if proc.returncode != 0 or not (work / "atoms.dump").exists():
        pytest.fail(f"liggghts -in in.settle failed ({proc.returncode}): {proc.stdout[-2000:]} {proc.stderr[-2000:]}")
    return str(work)


def reader(d, consistent=True, **extra):
    pre = "" if consistent else "run_"
    # frames dumped during a run do not balance (test_dumps_during_a_run_do_not_balance)
    opts = dict(pair_values=VALUES, fixed_types=[2], body_force=G, check_forces=consistent)
    opts.update(extra)
    return LiggghtsReader(os.path.join(d, f"{pre}atoms.dump"), os.path.join(d, f"{pre}pairs.dump"), **opts)


def test_column_layout_is_fixed_order():
    a = pair_gran_local_columns("pgl", VALUES)
    b = pair_gran_local_columns("pgl", VALUES[::-1])
    assert a == b
    assert a["id"] == ("c_pgl[7]", "c_pgl[8]", "c_pgl[9]")
    assert a["force"] == ("c_pgl[10]", "c_pgl[11]", "c_pgl[12]")
    assert a["delta"] == ("c_pgl[16]",) and a["contactPoint"][-1] == "c_pgl[19]"
    full = pair_gran_local_columns("x", ("pos", "vel", "id", "force", "torque", "delta", "contactPoint"))
    assert full["contactPoint"] == ("c_x[23]", "c_x[24]", "c_x[25]")
    # heat flux is always the last value (LIGGGHTS' ComputePairGranLocal::add_heat writes it at nvalues - 1): after
    # the contact point, whatever the keywords' order
    heat = pair_gran_local_columns("h", ("heatFlux", "id", "force", "contactPoint"))
    assert heat["contactPoint"] == ("c_h[7]", "c_h[8]", "c_h[9]") and heat["heatFlux"] == ("c_h[10]",)
    with pytest.raises(ValueError, match="unknown"):
        pair_gran_local_columns("pgl", ("pos", "bogus"))
    with pytest.raises(ValueError, match="history"):
        pair_gran_local_columns("pgl", ("id", "force", "history"))


def test_run0_dumps_balance(liggghts_dir):
    r = reader(liggghts_dir)
    assert len(r) == 3
    for k in range(len(r)):
        fr = r.frame(k)
        snap = fr.snapshot
        bulk, boundary = snap.split_contacts()
        assert len(bulk["i"]) > 10 and len(boundary["i"]) > 10
        # measured ~1e-13..1e-12: newton off evaluates a periodic contact once from each side
        assert r.force_mismatch(k) < TOL
        assert r.force_mismatch(k, fixed=True) < TOL


def test_dumps_during_a_run_do_not_balance(liggghts_dir):
    r = reader(liggghts_dir, consistent=False)
    worst = max(r.force_mismatch(k) for k in range(len(r)) if len(r[k].contacts))
    assert worst > 1e-3


def test_sign_convention(liggghts_dir):
    # force is on the FIRST id from the second: flipping it breaks the balance; it is repulsive
    r = reader(liggghts_dir)
    snap = r[2]
    c = snap.contacts
    flipped = cg.Contacts(c.i, c.j, -c.force, c.point)
    fr = r.frame(2)
    total = cg.Snapshot(snap.positions, velocities=snap.velocities, masses=snap.masses, box=snap.box,
                        contacts=flipped, fixed=snap.fixed, body_force=snap.body_force).particle_forces()
    scale = np.sqrt(np.mean(np.sum(c.force ** 2, axis=1)))
    assert np.max(np.abs(total - fr.forces)[snap.flowing]) > 0.1 * scale
    r_ij = snap.positions[c.i] - snap.positions[c.j]
    r_ij -= snap.box.lengths * np.round(r_ij / snap.box.lengths) * np.array(snap.box.periodic)
    significant = np.linalg.norm(c.force, axis=1) > 1e-12 * scale
    assert np.mean(np.sum(c.force * r_ij, axis=1)[significant] > 0) > 0.7


def test_fixed_type_contacts_become_boundary(liggghts_dir):
    r = reader(liggghts_dir)
    fr = r.frame(2)
    snap = fr.snapshot
    assert np.array_equal(snap.fixed, fr.types == 2)
    c = snap.contacts
    fi, fj = snap.fixed[c.i], snap.fixed[c.j]
    bulk, boundary = snap.split_contacts()
    assert len(boundary["i"]) == int(np.sum(fi ^ fj)) > 0
    assert len(bulk["i"]) == int(np.sum(~fi & ~fj))
    assert np.sum(fi & fj) > 0            # fixed-fixed (the floor touches itself): ignored
    assert not np.any(snap.fixed[boundary["i"]])
    total = np.zeros((snap.n_particles, 3))
    np.add.at(total, bulk["i"], bulk["force"])
    np.add.at(total, bulk["j"], -bulk["force"])
    np.add.at(total, boundary["i"], boundary["force"])
    total += snap.masses[:, None] * snap.body_force
    scale = np.sqrt(np.mean(np.sum(c.force ** 2, axis=1)))
    assert np.max(np.abs(total - fr.forces)[snap.flowing]) < TOL * scale
    by_ids = reader(liggghts_dir, fixed_types=(), fixed_ids=fr.ids[fr.types == 2].tolist())
    assert np.array_equal(by_ids[2].fixed, snap.fixed)


def test_contact_points_wrapped_and_on_the_centre_line(liggghts_dir):
    r = reader(liggghts_dir)
    raw_outside = crossings = 0
    for k in range(len(r)):
        fr = r.frame(k)
        snap = fr.snapshot
        c, box = snap.contacts, snap.box
        per = np.array(box.periodic)
        assert np.all((c.point[:, per] >= box.lower[per]) & (c.point[:, per] < box.upper[per]))
        raw = r.__class__(r.atoms_path, r.pairs_path, pair_values=VALUES, fixed_types=[2], body_force=G,
                          wrap=False)[k].contacts.point
        raw_outside += int(np.sum(np.any((raw[:, per] < box.lower[per]) | (raw[:, per] >= box.upper[per]), axis=1)))
        d = snap.positions[c.i] - snap.positions[c.j]
        crossings += int(np.sum(np.any(np.abs(d[:, per]) > 0.5 * box.lengths[per], axis=1)))
        r_ij = d - box.lengths * np.round(d / box.lengths) * per
        dist = np.linalg.norm(r_ij, axis=1)
        R = snap.radii
        assert np.allclose(fr.overlap, R[c.i] + R[c.j] - dist, rtol=0, atol=1e-15)
        # LIGGGHTS' contact point: c = x_i - R_i/(R_i+R_j) r_ij (minimum image relative to i)
        a = snap.positions[c.i] - c.point
        a -= box.lengths * np.round(a / box.lengths) * per
        expect = (R[c.i] / (R[c.i] + R[c.j]))[:, None] * r_ij
        assert np.allclose(a, expect, rtol=0, atol=1e-15)
        # the rebuilt point (without the contactPoint columns) is the same
        cols = pair_gran_local_columns("pgl", VALUES)
        del cols["contactPoint"]
        rebuilt = LiggghtsReader(r.atoms_path, r.pairs_path, pair_columns=cols, fixed_types=[2],
                                 body_force=G)[k].contacts.point
        assert np.allclose(rebuilt, c.point, rtol=0, atol=1e-15)
        _, boundary = snap.split_contacts()
        assert np.all(np.linalg.norm(boundary["branch"], axis=1) <= R[boundary["i"]] + 1e-15)
    assert crossings > 0, "expected contacts across a periodic boundary"
    assert raw_outside > 0, "expected LIGGGHTS contact points outside the box"


def test_len_slicing_and_pickling(liggghts_dir):
    r = reader(liggghts_dir)
    steps = r.timesteps
    assert len(r) == 3 and steps == sorted(steps) and len(set(steps)) == 3
    sub = r[1:]
    assert isinstance(sub, LiggghtsReader) and len(sub) == 2 and sub.timesteps == steps[1:]
    assert np.array_equal(sub[0].contacts.point, r[1].contacts.point)
    assert r[::-1].timesteps == steps[::-1]
    with pytest.raises(IndexError):
        r[3]
    with pytest.raises(TypeError):
        r[1.0]
    r.frame(0)
    blob = pickle.dumps(r)
    assert len(blob) < 4000
    back = pickle.loads(blob)
    assert isinstance(back, LiggghtsReader) and len(back) == 3
    for k in range(3):
        assert np.array_equal(back[k].contacts.force, r[k].contacts.force)
        assert np.array_equal(back[k].positions, r[k].positions)
    assert len(pickle.dumps(sub)) < 4000
    assert "LiggghtsReader" in repr(sub)
    assert reader(liggghts_dir, dt=2e-6)[0].time == pytest.approx(steps[0] * 2e-6)


def test_coarse_grain_runs_on_a_frame(liggghts_dir):
    r = reader(liggghts_dir)
    snap = r[2]
    kernel = cg.Lucy(0.002)
    res = cg.coarse_grain(snap, cg.Grid(snap.box, (3, 3, 6)), kernel)
    assert np.all(np.isfinite(res["density"])) and np.max(res["density"]) > 0
    assert np.all(np.isfinite(res["stress"]))
    rng = np.random.default_rng(1)
    lo, hi = snap.box.lower.copy(), snap.box.upper.copy()
    hi[-1] = np.max(snap.positions[:, -1]) + 0.001
    points = lo + rng.random((100, 3)) * (hi - lo)
    mb = cg.momentum_balance_residual(snap, points, kernel, forces=r.dumped_forces(2))
    assert mb.scale > 0 and np.max(mb.relative) < TOL


def test_errors_name_the_problem(liggghts_dir):
    a = os.path.join(liggghts_dir, "atoms.dump")
    p = os.path.join(liggghts_dir, "pairs.dump")
    with pytest.raises(ValueError, match="no contact frame for timestep"):
        LiggghtsReader(a, os.path.join(liggghts_dir, "run_pairs.dump"), pair_values=VALUES)
    with pytest.raises(ValueError, match="c_other"):
        LiggghtsReader(a, p, pair_compute="other", pair_values=VALUES)[0]
    with pytest.raises(ValueError, match="'id'"):
        LiggghtsReader(a, p, pair_values=("pos", "force"))
    with pytest.raises(ValueError, match="'force'"):
        LiggghtsReader(a, p, pair_values=("pos", "id"))


def test_keywords_that_do_not_match_the_dump_are_refused(liggghts_dir):
    a, p = os.path.join(liggghts_dir, "atoms.dump"), os.path.join(liggghts_dir, "pairs.dump")
    with pytest.raises(ValueError, match="pair_values: the keywords .* make 13 columns but .* holds 19"):
        LiggghtsReader(a, p, pair_values=("pos", "id", "force", "delta"))


def test_a_missing_body_force_is_refused_by_the_force_balance(liggghts_dir):
    with pytest.raises(ValueError, match="a body force is missing or wrong"):
        reader(liggghts_dir, body_force=None)[0]


def test_a_contact_dump_of_another_step_is_refused_by_its_positions(liggghts_dir, tmp_path):
    # the contact frames rotated by one (each timestep label kept: same IDs, same steps): with the force check off
    # (as for frames dumped during a run) they were read as this step's contacts, silently
    frames = open(os.path.join(liggghts_dir, "pairs.dump")).read().split("ITEM: TIMESTEP\n")[1:]
    labels = [f.split("\n", 1)[0] for f in frames]
    bodies = [f.split("\n", 1)[1] for f in frames]
    (tmp_path / "pairs.dump").write_text("".join(f"ITEM: TIMESTEP\n{labels[k]}\n{bodies[(k + 1) % len(frames)]}"
                                                 for k in range(len(frames))))
    shifted = LiggghtsReader(os.path.join(liggghts_dir, "atoms.dump"), tmp_path / "pairs.dump", pair_values=VALUES,
                             fixed_types=[2], body_force=G, check_forces=False)
    with pytest.raises(ValueError, match=r"atoms.dump: timestep 22500: the positions do not fit the contacts of "
                                         r".*pairs.dump: \d+ of \d+ contacts have positions \(pair/gran/local 'pos'.*"
                                         r"the two dumps are not of the same run"):
        shifted[0]
    reader(liggghts_dir, consistent=False)[1]     # frames dumped during a run: their positions agree


def test_a_run_with_walls_fails_the_force_check_naming_the_walls():
    # a genuine LIGGGHTS run on a primitive wall (tests/data/liggghts/wall/in.wall): the hints named LAMMPS's
    # --pair-style and --walls, which LIGGGHTS input does not take, and not the walls this reader does not read
    d = os.path.join(DATA, "wall")
    frames = LiggghtsReader(os.path.join(d, "atoms.dump"), os.path.join(d, "pairs.dump"), pair_values=VALUES,
                            body_force=G)
    with pytest.raises(ValueError, match=r"timestep 22500: the contact forces plus the body forces do not reproduce .* "
                                         r"the run has walls \(fix wall/gran\) whose contacts are not given: .*"
                                         r"--wall-contacts.*primitive walls are not read") as info:
        frames[0]
    assert "--pair-style" not in str(info.value) and "--walls" not in str(info.value)



def test_a_type_the_script_declares_for_a_wall_material_only_is_no_boundary_and_no_error():
    # in.wall's 'create_box 2' declares type 2 for the wall's material; no particle has it and only type 1 is
    # integrated, so the script makes type 2 boundary. Reading with input= refused every frame ("fixed_types: type(s)
    # [2] select no particle"), an argument the user never gave; a type the user names is still refused
    d = os.path.join(DATA, "wall")
    atoms, pairs, script = (os.path.join(d, f) for f in ("atoms.dump", "pairs.dump", "in.wall"))
    frames = LiggghtsReader(atoms, pairs, input=script)
    assert frames.fixed_types == (2,)
    with pytest.raises(ValueError, match=r"the run has walls whose contacts are not read \(fix floor: a primitive "
                                         r"wall"):
        frames[0]                      # its primitive wall's contacts are in no dump: the force check, not the types
    snap = LiggghtsReader(atoms, pairs, input=script, check_forces=False)[0]
    assert not snap.fixed.any() and len(snap.positions) == 50
    with pytest.raises(ValueError, match=r"fixed_types: type\(s\) \[2\] select no particle .*types present: \[1\]"):
        LiggghtsReader(atoms, pairs, input=script, fixed_types=[2], check_forces=False)[0]

# ---- wall contacts (compute wall/gran/local, mesh walls): tests/data/liggghts/mesh/in.mesh, settled at rest ----
MESH = os.path.join(DATA, "mesh")
WALL_VALUES = ("pos", "vel", "id", "force", "force_normal", "force_tangential", "torque", "delta", "contactArea")


def mesh_reader(walls="walls.dump", **extra):
    return LiggghtsReader(os.path.join(MESH, "atoms.dump"), os.path.join(MESH, "pairs.dump"),
                          wall_contacts=None if walls is None else os.path.join(MESH, walls),
                          input=os.path.join(MESH, "in.mesh"), **extra)


def test_mesh_wall_contacts_balance_every_particle():
    frames = mesh_reader()
    assert frames.wall_values == WALL_VALUES        # from the script's compute wall/gran/local line
    for k in range(len(frames)):
        assert frames.force_mismatch(k) < TOL
        contacts = frames[k].contacts
        assert np.count_nonzero(contacts.j < 0) == 31


def test_mesh_wall_force_of_a_packing_at_rest_is_its_weight_and_the_ifd_integrates_to_it():
    snap = mesh_reader(wall_values=WALL_VALUES)[0]
    wall = snap.contacts.j < 0
    weight = snap.masses.sum() * 9.81
    np.testing.assert_allclose(snap.contacts.force[wall].sum(axis=0), [0, 0, weight], rtol=0, atol=1e-5 * weight)   # at rest to 1e-6
    # the contact points lie on the floor z = 0
    np.testing.assert_array_equal(snap.contacts.point[wall][:, 2], 0.0)
    box = cg.Box((0, 0, -0.002), (0.006, 0.006, 0.002), (True, True, False))
    shape = (24, 24, 80)
    fields = cg.coarse_grain(snap, cg.Grid(box, shape), cg.Lucy(0.0008), fields=("interaction_force_density",))
    cell = np.prod((np.array(box.upper) - np.array(box.lower)) / np.array(shape))
    integral = fields.interaction_force_density.reshape(-1, 3).sum(axis=0) * cell
    np.testing.assert_allclose(integral, [0, 0, weight], rtol=0, atol=2e-3 * weight)


def test_a_mesh_run_without_its_wall_dump_fails_the_force_check_naming_the_option():
    with pytest.raises(ValueError, match=r"timestep 302500: the contact forces .* whose contacts are not read \(fix "
                                         r"floor: a mesh wall: give its compute wall/gran/local dump \(wall_contacts=, "
                                         r"--wall-contacts\)"):
        mesh_reader(walls=None)[0]


def without_forces(tmp_path, name):
    """The atoms dump of tests/data/liggghts/NAME without its fx fy fz columns (as many users dump it)."""
    out = []
    drop = None
    for line in open(os.path.join(DATA, name, "atoms.dump")):
        if line.startswith("ITEM: ATOMS"):
            words = line.split()[2:]
            drop = [words.index(c) for c in ("fx", "fy", "fz")]
            out.append("ITEM: ATOMS " + " ".join(w for k, w in enumerate(words) if k not in drop) + "\n")
        elif drop is not None and not line.startswith("ITEM:") and len(line.split()) > max(drop):
            out.append(" ".join(w for k, w in enumerate(line.split()) if k not in drop) + "\n")
        else:
            out.append(line)
            if line.startswith("ITEM:"):
                drop = None if not line.startswith("ITEM: ATOMS") else drop
    path = tmp_path / "atoms.dump"
    path.write_text("".join(out))
    return path


def test_walls_whose_contacts_are_not_read_are_refused_where_no_force_check_can_notice(tmp_path):
    # without fx fy fz no force balance can show a wall's forces missing: a mesh wall without its wall dump, and a
    # primitive wall (never reported by wall/gran/local), read silently with exit 0 and no wall force in any field.
    # Where the input script shows them, the frame is refused; --no-check-forces reads it anyway
    atoms = without_forces(tmp_path, "mesh")
    with pytest.raises(ValueError, match=r"mesh/in.mesh has walls whose contacts are not read \(fix floor: a mesh "
                                         r"wall: give .*--wall-contacts.*no fx fy fz.*--no-check-forces"):
        LiggghtsReader(atoms, os.path.join(MESH, "pairs.dump"), input=os.path.join(MESH, "in.mesh"))[0]
    with_walls = LiggghtsReader(atoms, os.path.join(MESH, "pairs.dump"), input=os.path.join(MESH, "in.mesh"),
                                wall_contacts=os.path.join(MESH, "walls.dump"))[0]
    assert np.count_nonzero(with_walls.contacts.j < 0) == 31
    unchecked = LiggghtsReader(atoms, os.path.join(MESH, "pairs.dump"), input=os.path.join(MESH, "in.mesh"),
                               check_forces=False)[0]
    assert not np.any(unchecked.contacts.j < 0)
    d = os.path.join(DATA, "wall")
    with pytest.raises(ValueError, match=r"fix floor: a primitive wall, whose contacts LIGGGHTS' wall/gran/local does "
                                         r"not report.*no fx fy fz"):
        LiggghtsReader(without_forces(tmp_path, "wall"), os.path.join(d, "pairs.dump"),
                       input=os.path.join(d, "in.wall"))[0]


def test_wall_rows_without_a_force_are_near_walls_not_contacts(tmp_path):
    # neigh_modify contact_distance_factor > 1 makes LIGGGHTS list walls near a particle that do not touch it: delta
    # < 0, force 0. Such a row (here: its contact point moved 0.3 radii below the floor) was refused as a contact
    # point beyond the radius (with input=), or counted as a contact (coordination numbers, fabric) without it
    def near(zero_force):
        def edit(lines):
            words = lines[9].split()
            r = float(words[5]) + float(words[28])      # the centre's z + delta: the radius (contact point z = 0)
            words[2] = repr(-0.3 * r)
            words[28] = repr(-0.3 * r)
            if zero_force:
                for c in range(15, 27):                  # force, its parts, the torque
                    words[c] = "0"
            lines[9] = " ".join(words) + "\n"
        return edit
    snap = damaged(tmp_path, near(True))
    snap.check_forces = False                            # (the atoms' forces still hold that wall's force)
    assert np.count_nonzero(snap[0].contacts.j < 0) == 30
    with pytest.raises(ValueError, match=r"contact point .*further than the radius"):
        damaged(tmp_path, near(False))[0]


def test_wrong_wall_keywords_are_refused_naming_the_file_and_the_flag():
    with pytest.raises(ValueError, match=r"wall_values: the keywords pos id force make 12 columns but the wall "
                                         r"contact dump .*walls.dump holds 29 columns .*--wall-values"):
        mesh_reader(wall_values=("pos", "id", "force"))


def test_wall_values_without_a_wall_dump_or_keywords_are_refused():
    with pytest.raises(ValueError, match="wall_values: given without wall_contacts"):
        mesh_reader(walls=None, wall_values=WALL_VALUES)
    with pytest.raises(ValueError, match=r"wall_values: .*needs 'pos'"):
        mesh_reader(wall_values=("vel", "id", "force", "force_normal", "force_tangential", "torque", "delta",
                                 "contactArea"))


def damaged(tmp_path, edit):
    text = open(os.path.join(MESH, "walls.dump")).read().splitlines(keepends=True)
    edit(text)
    path = tmp_path / "walls.dump"
    path.write_text("".join(text))
    return LiggghtsReader(os.path.join(MESH, "atoms.dump"), os.path.join(MESH, "pairs.dump"), wall_contacts=path,
                          wall_values=WALL_VALUES, input=os.path.join(MESH, "in.mesh"))


def test_a_wall_contact_on_the_wrong_particle_is_refused_with_its_line(tmp_path):
    def swap_particle(lines):
        words = lines[9].split()
        words[14] = "3" if words[14] != "3" else "4"     # the particle's ID (id's third value)
        lines[9] = " ".join(words) + "\n"
    with pytest.raises(ValueError, match=r"timestep 302500: the positions do not fit the wall contacts of .*walls.dump"
                                         r": .*particle centre .*line 10.*--wall-values"):
        damaged(tmp_path, swap_particle)[0]


def test_a_wall_contact_of_an_absent_particle_is_refused(tmp_path):
    def absent(lines):
        words = lines[9].split()
        words[14] = "999"
        lines[9] = " ".join(words) + "\n"
    with pytest.raises(ValueError, match=r"walls.dump: contact between atom IDs 999 and 999 at timestep 302500: an ID "
                                         r"is not in the atoms dump"):
        damaged(tmp_path, absent)[0]


def test_a_contact_point_off_the_wall_is_refused(tmp_path):
    def lift(lines):
        words = lines[9].split()
        words[2] = repr(float(words[5]) + 0.002)       # the contact point 2 mm above the centre
        lines[9] = " ".join(words) + "\n"
    with pytest.raises(ValueError, match=r"timestep 302500: .*contact point .*further than the radius"):
        damaged(tmp_path, lift)[0]


def test_a_wall_dump_of_other_timesteps_is_refused(tmp_path):
    def shift(lines):
        for k, line in enumerate(lines):
            if line.strip() == "302500":
                lines[k] = "302499\n"
    with pytest.raises(ValueError, match=r"wall_contacts: no frame for timestep\(s\) \[302500\] of the atoms dump .* "
                                         r"in the wall contact dump .*walls.dump.*dump both at the same steps"):
        damaged(tmp_path, shift)


def test_cli_reads_mesh_walls_and_refuses_wrong_keywords(tmp_path, capsys):
    from cgbound.cli import main
    base = ["run", os.path.join(MESH, "atoms.dump"), "--format", "liggghts", "--pairs", os.path.join(MESH, "pairs.dump"),
            "--input", os.path.join(MESH, "in.mesh"), "--wall-contacts", os.path.join(MESH, "walls.dump"), "--grid",
            "2,2,4", "--kernel", "lucy", "--width", "0.001", "--fields", "density,boundary_stress", "-q"]
    assert main(base + ["-o", str(tmp_path / "out.npz")]) == 0
    assert (tmp_path / "out.npz").exists()
    capsys.readouterr()
    assert main(base + ["--wall-values", "pos,id,force", "-o", str(tmp_path / "bad.npz")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cgbound: error: --wall-values: ") and "Traceback" not in err and "12 columns" in err
    assert not (tmp_path / "bad.npz").exists()


def test_a_wall_compute_with_history_is_read_its_count_from_the_dump():
    # tests/data/liggghts/history: 'compute wgl all wall/gran/local' without keywords, LIGGGHTS' default set with the
    # hertz/history wall's 3 history values (25 columns). With --input the script's parse refused the dump ("comes
    # after its 'history' values"); with --wall-values 'history' was refused for want of a count no flag could give
    d = os.path.join(DATA, "history")
    atoms, pairs, walls, script = (os.path.join(d, f) for f in ("atoms.dump", "pairs.dump", "walls.dump", "in.history"))
    for options in ({"input": script},
                    {"input": script, "wall_values": ("pos", "vel", "id", "force", "torque", "history", "contactArea")},
                    {"wall_values": ("pos", "vel", "id", "force", "torque", "history", "contactArea"),
                     "pair_values": VALUES, "body_force": G}):
        frames = LiggghtsReader(atoms, pairs, wall_contacts=walls, **options)
        # pos 6, vel 6, id 3, force 3, torque 3, then history, then the area: the 25th and last column
        assert frames.wall_columns["history"] == ("c_wgl[22]", "c_wgl[23]", "c_wgl[24]")
        assert frames.wall_columns["contactArea"] == ("c_wgl[25]",)
        for k in range(len(frames)):
            assert frames.force_mismatch(k) < TOL
            assert np.count_nonzero(frames[k].contacts.j < 0) > 0
    # a count that does not fit the dump is still refused
    with pytest.raises(ValueError, match=r"wall_values: the keywords .* make 24 columns but the wall contact dump .* "
                                         r"holds 25"):
        LiggghtsReader(atoms, pairs, wall_contacts=walls, input=script, wall_history=2)


def test_the_verbose_flag_of_a_compute_writes_no_column(tmp_path):
    # LIGGGHTS 3.8 takes 'verbose' on a wall/gran/local line and writes no column for it (a genuine run dumped 23
    # columns for 'pos vel id force torque delta contactArea verbose'); the script was refused ("unknown keyword")
    text = open(os.path.join(MESH, "in.mesh")).read().replace("delta contactArea\n", "delta contactArea verbose\n")
    assert "contactArea verbose" in text
    (tmp_path / "in.mesh").write_text(text)
    frames = LiggghtsReader(os.path.join(MESH, "atoms.dump"), os.path.join(MESH, "pairs.dump"),
                            wall_contacts=os.path.join(MESH, "walls.dump"), input=tmp_path / "in.mesh")
    assert frames.wall_values == WALL_VALUES
    assert frames.force_mismatch(0) < TOL


def test_a_pattern_of_wall_files_is_refused_naming_the_flag_and_the_fix(tmp_path, capsys):
    # one wall file per frame ('dump ... walls.*.dump') was refused as "no such file: 'walls.*.dump'"
    from cgbound.cli import main
    args = ["run", os.path.join(MESH, "atoms.dump"), "--format", "liggghts", "--pairs", os.path.join(MESH, "pairs.dump"),
            "--input", os.path.join(MESH, "in.mesh"), "--wall-contacts", os.path.join(MESH, "walls.*.dump"), "--grid",
            "2,2,4", "--kernel", "lucy", "--width", "0.001", "-o", str(tmp_path / "o.npz"), "-q"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("cgbound: error: --wall-contacts: one file holding every frame's wall contacts, not a "
                          "pattern") and "cat walls.*.dump > walls.dump" in err


def test_a_force_mismatch_names_the_dumps_default_six_digits(tmp_path):
    # a wall dump in LIGGGHTS' default %g (6 significant digits) mismatched by 3.5e-6 of the RMS contact force and
    # was refused naming columns, gravity, walls and runs, not the precision it was written with
    lines = open(os.path.join(MESH, "walls.dump")).read().splitlines()
    for k, line in enumerate(lines):
        if not line.startswith("ITEM:") and len(line.split()) > 3:      # (a contact's row)
            lines[k] = " ".join(f"{float(w):g}" for w in line.split())
    (tmp_path / "walls.dump").write_text("\n".join(lines) + "\n")
    frames = LiggghtsReader(os.path.join(MESH, "atoms.dump"), os.path.join(MESH, "pairs.dump"),
                            wall_contacts=tmp_path / "walls.dump", input=os.path.join(MESH, "in.mesh"))
    with pytest.raises(ValueError, match=r"timestep 302500: the contact forces .* mismatch [0-9.e-]+ of the RMS .*"
                                         r"6 significant digits .*format float %.17g"):
        frames[0]
