"""The LAMMPS and LIGGGHTS readers refuse a frame whose positions are not positions.

An atoms dump whose ``ITEM: ATOMS`` labels lie (``x y z`` swapped with ``vx vy vz``, or shifted by a column)
balances its forces (the balance does not involve positions) and used to give wrong fields silently. The
copies here are made from genuine dumps (tests/data) by relabelling the header only, and refused by the box
check or the contact geometry check, whichever sees it first; each geometry path is tested on copies whose
positions stay in the box (each row given the next row's position); the genuine dumps, cohesive ones
included (tests/data/lammps/in.jkr3d, tests/data/liggghts/in.easo), are accepted.
"""
import os
import re

import numpy as np
import pytest

import cgbound
from cgbound.cli import main
from cgbound.readers import LammpsReader, open_dataset
from cgbound.readers.lammps_input import read_input
from cgbound.readers.liggghts import LiggghtsReader

DATA = os.path.join(os.path.dirname(__file__), "data")
LAMMPS = os.path.join(DATA, "lammps")
LIGGGHTS = os.path.join(DATA, "liggghts")

#: header relabellings: positions and velocities swapped; forces as positions; the position labels one column late
RELABEL = {"swap_v": {"x": "vx", "y": "vy", "z": "vz", "vx": "x", "vy": "y", "vz": "z"},
           "swap_f": {"x": "fx", "y": "fy", "z": "fz", "fx": "x", "fy": "y", "fz": "z"},
           "shift": {"x": "vx", "y": "x", "z": "y", "vx": "z"}}


def relabelled(src, dst, kind):
    """A copy of the dump ``src`` whose ITEM: ATOMS headers name the columns as ``RELABEL[kind]`` says (the data
    as written)."""
    mapping = RELABEL[kind]
    with open(src) as fh, open(dst, "w") as out:
        for line in fh:
            if line.startswith("ITEM: ATOMS"):
                line = "ITEM: ATOMS " + " ".join(mapping.get(c, c) for c in line.split()[2:]) + "\n"
            out.write(line)
    return str(dst)


def misaligned(src, dst):
    """A copy of the dump ``src`` whose position columns are one row off (row k holds row k+1's x y z, the last
    the first's): positions in the box, of the wrong atoms (as a merge of two differently sorted dumps gives)."""
    with open(src) as fh:
        lines = fh.readlines()
    k = 0
    while k < len(lines):
        if lines[k].startswith("ITEM: NUMBER OF ATOMS"):
            n = int(lines[k + 1])
        if lines[k].startswith("ITEM: ATOMS"):
            names = lines[k].split()[2:]
            at = [names.index(c) for c in ("x", "y", "z")]
            rows = [line.split() for line in lines[k + 1:k + 1 + n]]
            for r in range(n):
                new = list(rows[r])
                for c in at:
                    new[c] = rows[(r + 1) % n][c]
                lines[k + 1 + r] = " ".join(new) + "\n"
            k += n
        k += 1
    with open(dst, "w") as out:
        out.writelines(lines)
    return str(dst)


def lammps(atoms, case, **options):
    directory = os.path.join(LAMMPS, case)
    options.setdefault("input", os.path.join(LAMMPS, f"in.{case}"))
    return LammpsReader(atoms or os.path.join(directory, "atoms.dump"), os.path.join(directory, "pairs.dump"),
                        **options)


def read_all(reader):
    return [reader.frame(k) for k in range(len(reader))]


# ---- LAMMPS ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("case,kind", [("hooke3d", "swap_v"), ("granular3d", "shift"), ("jkr3d", "swap_f")])
def test_relabelled_positions_are_refused(tmp_path, case, kind):
    bad = relabelled(os.path.join(LAMMPS, case, "atoms.dump"), tmp_path / "atoms.dump", kind)
    good, reader = lammps(None, case, check_forces=False), lammps(bad, case, check_forces=False)
    refused = 0
    for k in range(len(reader)):
        frame = good.frame(k)
        try:
            reader.frame(k)
        except ValueError as exc:
            refused += 1
            message = str(exc)
            assert message.startswith(f"{bad}: timestep {good.timesteps[k]}: ")
            assert "outside the box" in message or "the positions do not fit" in message
            assert "labels swapped" in message and "Fix:" in message
        else:     # (a frame without contacts whose positions stay in the box: jkr3d's first, forces 0 as positions)
            assert len(frame.snapshot.contacts) == 0
    assert refused >= 2


@pytest.mark.parametrize("case,columns,what", [
    ("hooke3d", {}, r"have a distance \('dist', column c_pl\[1\]\)"),
    ("granular3d", {}, r"have a branch vector x_i - x_j \(columns c_pl\[14\] c_pl\[15\] c_pl\[16\]\)"),
    # without 'dist': gran/hooke/history pulls nowhere beyond contact
    ("hooke3d", {"dist": None}, r"carry a force while their particles do not touch"),
])
def test_misplaced_positions_are_refused_by_the_contacts(tmp_path, case, columns, what):
    bad = misaligned(os.path.join(LAMMPS, case, "atoms.dump"), tmp_path / "atoms.dump")
    script = read_input(os.path.join(LAMMPS, f"in.{case}"))
    cols = dict(script.pair_columns("pairs.dump"), **columns)
    reader = lammps(bad, case, pair_columns=cols)
    good = lammps(None, case, pair_columns=cols)
    for k in range(len(reader)):
        assert len(good.frame(k).snapshot.contacts)       # (the genuine frame is read)
        with pytest.raises(ValueError) as info:
            reader.frame(k)
        message = str(info.value)
        assert message.startswith(f"{bad}: timestep {good.timesteps[k]}: the positions do not fit the contacts of")
        assert re.search(what, message), message
        assert "the contact dump's line" in message and "the atoms dump's lines" in message
        assert "labels swapped" in message and "Fix:" in message
        assert "The positions look right" not in message   # (they do not: the labels lead)


def test_positions_outside_the_box_are_refused(tmp_path):
    # forces as positions: in hooke3d's first frame some lie boxes away (the atoms dump alone: no contacts needed)
    bad = relabelled(os.path.join(LAMMPS, "hooke3d", "atoms.dump"), tmp_path / "atoms.dump", "swap_f")
    with pytest.raises(ValueError, match=r"atoms\.dump: timestep 4500: atom \d+ \(line \d+\) has [xyz] = -?[0-9.]+, "
                                         r"outside the box \[0, (6|10)\] along that (non-)?periodic axis by [0-9.]+ box "
                                         r"lengths .*labels swapped"):
        LammpsReader(bad).frame(0)
    assert len(read_all(LammpsReader(os.path.join(LAMMPS, "hooke3d", "atoms.dump")))) == 3


@pytest.mark.parametrize("case", ["shrink_layer", "shrink_pair"])
def test_shrink_wrapped_boxes_thinner_than_the_stray_are_read(tmp_path, case):
    # genuine output: along a shrink-wrapped axis the box can be far thinner than an atom's stray between
    # re-neighbourings (a falling layer: 4e-4 thick, an atom 0.04 out, 94 box lengths; two spheres colliding: 0.26)
    reader = lammps(None, case, check_forces=False)
    assert len(read_all(reader)) == 2
    if case == "shrink_pair":
        return      # (its velocities, +-1 along x, lie in its box)
    # a length of slack, not none: velocities as positions still lie far out of the layer's box
    bad = relabelled(os.path.join(LAMMPS, case, "atoms.dump"), tmp_path / "atoms.dump", "swap_v")
    with pytest.raises(ValueError, match=r"timestep 0: atom 1 \(line 10\) has z = -1, outside the box .* along "
                                         r"that shrink-wrapped axis by [0-9.]+ \(refused beyond [0-9.]+: the largest"):
        read_all(lammps(bad, case, check_forces=False))


@pytest.mark.parametrize("case", ["deform", "deform_mpi"])
def test_fast_deforming_box_is_read_and_misplaced_positions_refused(tmp_path, case):
    # genuine output, 2e-3 strain per step (fix deform ... remap x): the ghost images pair/local takes for contacts
    # across the periodic boundary keep the old box length, their 'dist' off by up to 1e-2 of it; held only to the
    # rule for most contacts (those inside the box: exact). On 2 processes the ghost copies of the other process's
    # atoms inside the box are stale too: the box's change per step (from the neighbouring frames) is allowed
    script = os.path.join(LAMMPS, "in.deform")
    frames = read_all(lammps(None, case, check_forces=False, input=script))
    assert [len(f.snapshot.contacts) for f in frames][-1] > 50
    # (frame 0, a lattice, is read: each atom given its neighbour's position keeps the distances)
    bad = misaligned(os.path.join(LAMMPS, case, "atoms.dump"), tmp_path / "atoms.dump")
    with pytest.raises(ValueError, match=r"timestep 40: the positions do not fit .* have a distance \('dist'"):
        read_all(lammps(bad, case, check_forces=False, input=script))


def split_per_frame(src, directory, name):
    """The frames of the dump ``src`` written one per file, ``directory/name.TIMESTEP.dump`` (as ``dump ...
    name.*.dump`` writes them)."""
    with open(src) as fh:
        text = fh.read()
    for frame in text.split("ITEM: TIMESTEP\n")[1:]:
        with open(os.path.join(directory, f"{name}.{frame.split(chr(10), 1)[0].strip()}.dump"), "w") as out:
            out.write("ITEM: TIMESTEP\n" + frame)


@pytest.mark.parametrize("engine,case", [("lammps", "deform_mpi"), ("liggghts", "deform")])
def test_deforming_box_one_frame_per_file_is_read(tmp_path, engine, case):
    # genuine output (fix deform ... remap x, 2e-3 strain per step) written one file per frame, as 'dump ...
    # atoms.*.dump' does: each frame's allowance for the box's change per step comes from its neighbours in the other
    # files (was 0: a genuine frame refused, the contact dump's columns blamed). A frame read alone takes it from the
    # script's fix deform ('final': the box's way to its final size over the run); at the run's last step (the box
    # final, its start not known) it cannot: refused, the script's fix deform named first with the fix
    data = LAMMPS if engine == "lammps" else LIGGGHTS
    for name in ("atoms", "pairs"):
        split_per_frame(os.path.join(data, case, f"{name}.dump"), tmp_path, name)
    with open(os.path.join(data, "in.deform")) as fh:     # (its dumps as 'dump ... atoms.*.dump' writes them)
        script = re.sub(r"^(dump .* )(atoms|pairs)\.dump ", r"\1\2.*.dump ", fh.read(), flags=re.M)
    (tmp_path / "in.deform").write_text(script)
    options = dict(format=engine, input=str(tmp_path / "in.deform"), check_forces=False)
    whole = open_dataset(os.path.join(data, case, "atoms.dump"), pairs=os.path.join(data, case, "pairs.dump"),
                         **dict(options, input=os.path.join(data, "in.deform")))
    split = open_dataset(str(tmp_path / "atoms.*.dump"), pairs=str(tmp_path / "pairs.*.dump"), **options)
    assert len(split) == 4 and [len(s.contacts) for s in split] == [len(s.contacts) for s in whole]
    for step in (40, 80):
        alone = open_dataset(str(tmp_path / f"atoms.{step}.dump"), pairs=str(tmp_path / f"pairs.{step}.dump"),
                             **options)
        assert len(alone[0].contacts) == len(whole[step // 40].contacts)
    alone = open_dataset(str(tmp_path / "atoms.120.dump"), pairs=str(tmp_path / "pairs.120.dump"), **options)
    with pytest.raises(ValueError, match=r"timestep 120: the positions do not fit .* Likely causes: a deforming box "
                                         r"\(fix deform def in .*in\.deform: line \d+\), its change per step unknown "
                                         r"from one frame: .* Fix: read the frames together"):
        alone[0]


def test_deforming_box_not_blamed_after_unfix(tmp_path):
    # tests/data/lammps/in.thin deforms its box, then 'unfix'es it before the frames: a refused frame (positions of
    # the wrong atoms) is not put down to the deforming box
    bad = misaligned(os.path.join(LAMMPS, "thin", "atoms.dump"), tmp_path / "atoms.dump")
    with pytest.raises(ValueError, match=r"timestep 7300: the positions do not fit") as refused:
        lammps(bad, "thin").frame(0)
    assert "deforming box" not in str(refused.value)


def test_particle_touching_its_own_image_is_refused(tmp_path):
    # genuine output (tests/data/lammps/in.self): a periodic box 0.95 wide along x, diameters 0.85..1: a particle
    # touches its own image and pair/local lists it with itself (patom1 == patom2; was refused blaming the atoms
    # dump's labels). Refused naming the axis, the length, the diameter, the lines and the fix
    reader = lammps(None, "self")
    with pytest.raises(ValueError, match=r"self/pairs\.dump: timestep 7300: atom 6 \(the atoms dump's line 11\) is "
                                         r"listed in contact with itself, the contact dump's line 13 \(8 such rows .*"
                                         r"the periodic length along x, 0\.95, is less than the particle's diameter "
                                         r"\(0\.959533\), so it touches its own periodic image; cgbound does not model "
                                         r"self-contacts .* Fix: make the box at least one diameter wide"):
        reader.frame(0)
    # (edited copy: the rows of a particle with itself that carry a force deleted) those without a force, its image
    # within the cutoff but not touching, carry nothing: dropped, the frame read
    with open(os.path.join(LAMMPS, "self", "pairs.dump")) as fh:
        lines = fh.read().splitlines(True)
    rows = [r for r in lines[9:] if not (r.split()[1] == r.split()[2] and any(float(v) for v in r.split()[4:10]))]
    assert len(lines) - 9 - len(rows) == 8
    lines[3] = f"{len(rows)}\n"
    (tmp_path / "pairs.dump").write_text("".join(lines[:9] + rows))
    snap = LammpsReader(os.path.join(LAMMPS, "self", "atoms.dump"), tmp_path / "pairs.dump", check_forces=False,
                        input=os.path.join(LAMMPS, "in.self")).frame(0).snapshot
    assert len(snap.contacts) > 0 and not np.any(snap.contacts.i == snap.contacts.j)


def _virial(k):
    """LAMMPS' pair virial W / V of frame k of tests/data/lammps/thin (compute pressure ... virial: xx yy zz xy xz yz,
    W_ab = sum r_a f_b / V over the pairs, f on the atom at r_i from j, r = r_i - r_j)."""
    return np.loadtxt(os.path.join(LAMMPS, "thin", "virial.txt"))[k, 2:]


def _as_virial(stress):
    """-(sigma_xx, sigma_yy, sigma_zz, sigma_yx, sigma_zx, sigma_zy) of a contact stress sigma_ab = -sum f_a b_b / V:
    LAMMPS' virial components (its xy is sum r_x f_y)."""
    return -np.array([stress[0, 0], stress[1, 1], stress[2, 2], stress[1, 0], stress[2, 0], stress[2, 1]])


@pytest.mark.parametrize("columns", ["branch and dist", "branch", "dist"])
def test_thin_periodic_box_reads_each_image_as_its_own_contact(columns):
    # genuine output: a periodic box 1.5 wide, diameters 0.85..1: 12 pairs a frame touch through two images of each
    # other and pair/local lists them once per image (with newton on). Each listing is its own contact, its
    # branch the image its branch vector (or else 'dist', and the normal force where two images are as far) says;
    # the box-averaged contact stress is then minus LAMMPS' virial to round-off. The minimum image gives the
    # second listing the first's branch: sigma_xx 44% low. (The branch alone: pair granular's zero rows, an image
    # it finds not touching, were given the touching one's image and refused as the pair written twice)
    reader = lammps(None, "thin")
    if columns != "branch and dist":
        names = dict(reader.pair_columns, **{"branch" if columns == "dist" else "dist": None})
        reader = lammps(None, "thin", pair_columns=names)
    for k, frame in enumerate(read_all(reader)):
        snap = frame.snapshot
        c = snap.contacts
        key = np.minimum(c.i, c.j) * snap.n_particles + np.maximum(c.i, c.j)
        assert len(c) == 79 and key.size - np.unique(key).size == 12 and c.branch is not None
        grid = cgbound.Grid(snap.box, (1, 1, 1), average=("x", "y", "z"))
        stress = np.asarray(cgbound.coarse_grain(snap, grid, cgbound.Gaussian(0.3),
                                                 fields=("contact_stress",)).contact_stress).reshape(3, 3)
        want = _virial(k)
        assert np.abs(_as_virial(stress) - want).max() <= 1e-12 * np.abs(want).max(), (k, stress, want)
        nearest = snap.box.minimum_image(snap.positions[c.i] - snap.positions[c.j])
        wrong = -np.einsum("ma,mb->ab", c.force, nearest) / np.prod(snap.box.upper - snap.box.lower)
        assert np.abs(_as_virial(wrong) - want).max() > 0.1 * np.abs(want).max()


@pytest.mark.parametrize("check_forces", [True, False])
def test_thin_periodic_box_with_newton_off_is_refused(check_forces):
    # the same run with 'newton off': every overlapping image is listed, but LAMMPS evaluates such pairs from each side
    # and neither the per-atom forces nor pair/local's values give their stress (the contacts' virial 0.4 % (xx) to
    # 46 % (yz) off compute pressure's): refused whether or not the force balance runs
    directory = os.path.join(LAMMPS, "thin_newton_off")
    reader = LammpsReader(os.path.join(directory, "atoms.dump"), os.path.join(directory, "pairs.dump"),
                          input=os.path.join(LAMMPS, "in.thin"), variables={"newton": "off"}, check_forces=check_forces)
    with pytest.raises(ValueError, match=r"thin_newton_off/pairs.dump: timestep 7300: pairs listed once per periodic "
                                         r"image .* with 'newton off' in the input script .*in.thin.* Fix: run with "
                                         r"'newton on'"):
        reader.frame(0)


def test_thin_periodic_box_without_dist_is_refused():
    # the positions alone cannot tell a pair's two listings apart (the minimum image would give both one branch)
    names = dict(lammps(None, "thin").pair_columns, branch=None, dist=None)
    with pytest.raises(ValueError, match=r"thin/atoms.dump: timestep 7300: atoms 1 and 20 are listed 2 times in "
                                         r".*thin/pairs.dump \(the contact dump's lines 10, 11\): the periodic box "
                                         r"length along x \(1.5\) is less than two contact distances, .* Fix: add "
                                         r"'dist' to compute pair/local"):
        read_all(lammps(None, "thin", pair_columns=names))


def test_contacts_branch_is_checked():
    # Contacts.branch: r_i - r_j plus whole box lengths along periodic axes; a pair once per image
    box = cgbound.Box([0, 0, 0], [1.5, 4, 4], periodic=(True, True, True))
    pos = np.array([[0.2, 1.0, 1.0], [0.9, 1.0, 1.0]])
    f = np.array([[-1.0, 0, 0], [1.0, 0, 0]])

    def snap(branch, j=(1, 1)):
        contacts = cgbound.Contacts([0, 0], list(j), f, [[0.55, 1, 1], [1.3, 1, 1]], branch=branch)
        return cgbound.Snapshot(pos, None, np.ones(2), box=box, radii=np.full(2, 0.45), contacts=contacts)

    s = snap([[-0.7, 0, 0], [0.8, 0, 0]])
    assert np.allclose(s.split_contacts()[0]["branch"], [[-0.7, 0, 0], [0.8, 0, 0]])
    with pytest.raises(ValueError, match=r"contacts.branch: expected r_i - r_j plus whole box lengths .* at contact 1"):
        snap([[-0.7, 0, 0], [0.75, 0, 0]])
    with pytest.raises(ValueError, match=r"expected each pair once per periodic image .* got the pair \(0, 1\) at "
                                         r"contacts 0, 1"):
        snap([[-0.7, 0, 0], [-0.7, 0, 0]])
    with pytest.raises(ValueError, match=r"expected each pair once \(as"):
        snap(None)


def test_frames_without_contacts_are_held_to_the_skin(tmp_path):
    # jkr3d's step 0 has no contacts, so no contact geometry checks its positions: forces written as positions lay
    # 0.086 box lengths out along z (under the 0.25 of a non-periodic axis) and were read. Where the script
    # re-neighbours without a delay, such a frame's atoms may stray one skin out of a non-periodic box (genuine
    # dumps: 0.39 skin at most, along a shrink-wrapped axis). in.jkr3d has LAMMPS' default delay (10 steps in the
    # installed LAMMPS): no skin bound; the same script with 'neigh_modify delay 0' holds the frame to it
    bad = relabelled(os.path.join(LAMMPS, "jkr3d", "atoms.dump"), tmp_path / "atoms.dump", "swap_f")
    lammps(bad, "jkr3d", check_forces=False).frame(0)      # (the default delay: the 0.25 box lengths of main)
    with open(os.path.join(LAMMPS, "in.jkr3d")) as f:
        text = f.read()
    undelayed = tmp_path / "in.jkr3d"
    undelayed.write_text(text.replace("\nrun", "\nneigh_modify delay 0\nrun", 1))
    with pytest.raises(ValueError, match=r"atoms.dump: timestep 0: atom 41 \(line 58\) has z = -0.685119, outside "
                                         r"the box \[0, 8\] along that non-periodic axis by 0.685 \(0.0856 box "
                                         r"lengths; refused beyond one neighbor skin, 0.3: the default skin for units "
                                         r"lj, as it has no 'neighbor' command in .*in.jkr3d\), in a frame without "
                                         r"contacts.* Likely causes: the atoms dump's position columns are not the "
                                         r"positions.* Fix: read the dump as LAMMPS wrote it"):
        lammps(bad, "jkr3d", check_forces=False, input=str(undelayed)).frame(0)
    # the skin from the script: its 'neighbor' command, else the units' default; only without a delay, and not
    # known where re-neighbouring is not checked every step or the units come from a restart file
    script = tmp_path / "in.x"
    undelayed = "neigh_modify delay 0\n"
    for text, bound in [("units si\n" + undelayed, 0.001), ("neighbor 0.2 bin\n" + undelayed, 0.2),
                        ("neighbor v_s bin\n" + undelayed, None), ("units electron\n" + undelayed, None),
                        ("neigh_modify delay 0 every 2 check yes\n", None), ("neigh_modify delay 0 check no\n", None),
                        ("neigh_modify delay 0 once yes\n", None), ("neigh_modify delay 5\n", None),
                        ("units si\n", None), ("neighbor 0.2 bin\n", None), (undelayed, 0.3),
                        ("read_restart r.bin\n" + undelayed, None),
                        ("read_restart r.bin\nneighbor 0.2 bin\n" + undelayed, 0.2)]:
        script.write_text(text)
        assert read_input(str(script)).stray_bound() == bound, text


def test_few_decimals_are_read_and_relabelled_refused(tmp_path):
    # genuine output written with 'format float %.2f': a distance from such positions is off by up to
    # 2 sqrt(3) 0.005, more than 1e-3 of the coordinates (< 20): the written decimals are added to the tolerance
    frames = read_all(lammps(None, "rounded", check_forces=False))
    assert len(frames[-1].snapshot.contacts) > 20
    bad = relabelled(os.path.join(LAMMPS, "rounded", "atoms.dump"), tmp_path / "atoms.dump", "shift")
    reader = lammps(bad, "rounded", check_forces=False)
    with pytest.raises(ValueError, match=r"timestep 3000: the positions do not fit .* have a distance \('dist'"):
        reader.frame(1)
    # step 0 has no contacts: its positions only the box checks (in.rounded re-neighbours with LAMMPS' default
    # delay: 0.25 box lengths, which this shift stays inside)
    reader.frame(0)


def test_tolerance_follows_the_coordinates_not_the_box_bounds(tmp_path):
    # particles of d ~1 in a corner of a 3000 x 3000 x 20 box: a tolerance of 1e-3 of the box bounds (3, three
    # diameters) read positions shifted by a column; the coordinates written (< 5) set it
    assert len(read_all(lammps(None, "corner", check_forces=False))[-1].snapshot.contacts) > 20
    bad = relabelled(os.path.join(LAMMPS, "corner", "atoms.dump"), tmp_path / "atoms.dump", "shift")
    reader = lammps(bad, "corner", check_forces=False, walls=())
    with pytest.raises(ValueError, match=r"timestep 3000: the positions do not fit .* have a distance \('dist'"):
        reader.frame(1)


def test_genuine_cohesive_frames_with_zero_rows_are_read():
    # pair granular jkr, pair/local without 'cutoff radius': LAMMPS writes zeros (force and branch) for the pairs it
    # finds not touching; the reader once called those 'two atoms at the same position'
    reader = lammps(None, "jkr3d", check_forces=False)
    assert reader.contact_reach == 2.0             # the script's jkr: cohesive
    frames = read_all(reader)
    assert sum(len(f.snapshot.contacts) for f in frames) > 100
    from cgbound.readers._lammps_dump import scan_dump
    pairs = scan_dump(os.path.join(LAMMPS, "jkr3d", "pairs.dump"), "local")
    table = pairs.read(pairs.frames[-1][0])["data"]
    branch = np.stack([table[f"c_pl[{k}]"] for k in (14, 15, 16)], axis=1)
    assert np.all(branch == 0, axis=1).any()
    # without the branch and 'dist', the reach of a cohesive model (2 (r_i + r_j)): accepted, and relabelled refused
    cols = dict(reader.pair_columns, branch=None, dist=None)
    assert len(read_all(lammps(None, "jkr3d", check_forces=False, pair_columns=cols))) == 3


def test_misplaced_cohesive_frames_are_refused(tmp_path):
    bad = misaligned(os.path.join(LAMMPS, "jkr3d", "atoms.dump"), tmp_path / "atoms.dump")
    with pytest.raises(ValueError, match=r"timestep 1500: .* have a branch vector"):
        read_all(lammps(bad, "jkr3d", check_forces=False))
    cols = dict(read_input(os.path.join(LAMMPS, "in.jkr3d")).pair_columns("pairs.dump"), branch=None, dist=None)
    with pytest.raises(ValueError, match=r"timestep 1500: .* apart by more than 2 \(r_i \+ r_j\)"):
        read_all(lammps(bad, "jkr3d", check_forces=False, pair_columns=cols))


def test_contact_reach_from_the_pair_style():
    assert lammps(None, "hooke3d").contact_reach == 1.0                 # gran/hooke/history
    assert lammps(None, "granular3d").contact_reach == 1.0              # granular hertz: not cohesive
    plain = dict(input=None, pair_values=("dist", "fx", "fy", "fz", "p1", "p2", "p3", "p4"))
    assert lammps(None, "hooke3d", **plain).contact_reach == 1.0        # the default: LAMMPS' gran/* styles
    assert lammps(None, "hooke3d", pair_style="granular", **plain).contact_reach == 2.0   # may be jkr
    assert lammps(None, "hooke3d", pair_style="total", **plain).contact_reach is None


# ---- LIGGGHTS ------------------------------------------------------------------------------------

def liggghts(atoms, directory=LIGGGHTS, pairs=None, **options):
    return LiggghtsReader(atoms or os.path.join(directory, "atoms.dump"), pairs or os.path.join(directory, "pairs.dump"),
                          **options)


SETTLE = dict(input=os.path.join(LIGGGHTS, "in.settle"))


@pytest.mark.parametrize("keep,kind,what", [
    (("pos", "id", "force", "torque", "delta", "contactPoint"), "rows", r"have positions \(pair/gran/local 'pos'"),
    (("id", "force", "delta"), "rows", r"have an overlap \(pair/gran/local 'delta', column c_pgl\[16\]\)"),
    (("id", "force"), "rows", r"carry a force while their particles do not touch"),
    # forces (1e-5 N) as positions (radii 5e-4 m), in the box: every contact's centres nearly on top of each other
    (("id", "force"), "swap_f", r"88 of 88 contacts carry a force with their centres closer than \(r_i \+ r_j\) / 2"),
])
def test_liggghts_misplaced_positions_are_refused(tmp_path, keep, kind, what):
    src = os.path.join(LIGGGHTS, "atoms.dump")
    bad = misaligned(src, tmp_path / "atoms.dump") if kind == "rows" else relabelled(src, tmp_path / "atoms.dump", kind)
    full = liggghts(None, **SETTLE).pair_columns
    cols = {k: v for k, v in full.items() if k in keep}
    assert len(read_all(liggghts(None, pair_columns=cols, **SETTLE))) == 3
    reader = liggghts(bad, pair_columns=cols, check_forces=False, **SETTLE)
    with pytest.raises(ValueError, match=r"atoms\.dump: timestep \d+: the positions do not fit the contacts of .*"
                                         + what):
        read_all(reader)


@pytest.mark.parametrize("keep,what", [(("pos", "id", "force", "delta"), r"have positions \(pair/gran/local 'pos'"),
                                       (("id", "force", "delta"), r"have an overlap \(pair/gran/local 'delta'")])
def test_liggghts_fast_deforming_box_is_read_and_misplaced_positions_refused(tmp_path, keep, what):
    # genuine LIGGGHTS output, 2e-3 strain per step (fix deform ... remap x, tests/data/liggghts/in.deform): the
    # ghost images pair/gran/local takes for contacts across the periodic boundary keep the old box length, their
    # 'pos' (and 'delta') off by the step's change of the box (5.9e-6 m, the box 2.9e-3 m: 11 of 33 contacts at step 40
    # were refused); twice the box's change per step is allowed, as for LAMMPS
    directory = os.path.join(LIGGGHTS, "deform")
    options = dict(input=os.path.join(LIGGGHTS, "in.deform"), check_forces=False)
    cols = {k: v for k, v in liggghts(None, directory, **options).pair_columns.items() if k in keep}
    frames = read_all(liggghts(None, directory, pair_columns=cols, **options))
    assert [len(f.snapshot.contacts) for f in frames] == [0, 33, 74, 81]
    bad = misaligned(os.path.join(directory, "atoms.dump"), tmp_path / "atoms.dump")
    with pytest.raises(ValueError, match=r"atoms\.dump: timestep 40: the positions do not fit the contacts of .*"
                                         + what):
        read_all(liggghts(bad, directory, pair_columns=cols, **options))


def test_liggghts_thin_periodic_box_is_refused():
    # genuine LIGGGHTS output (tests/data/liggghts/in.thin): a box 1.5 mm wide, diameters 0.85..1 mm; pairs listed
    # once per periodic image, whose forces do not balance: refused, naming the pair's lines and the fix (it was
    # refused by the Snapshot's "expected each pair once", naming neither file nor frame)
    directory = os.path.join(LIGGGHTS, "thin")
    reader = liggghts(None, directory, input=os.path.join(LIGGGHTS, "in.thin"))
    with pytest.raises(ValueError, match=r"thin/atoms.dump: timestep 5300: atoms 14 and 3 are listed 2 times in .*"
                                         r"thin/pairs.dump \(the contact dump's lines 12, 13\): the periodic box is "
                                         r"thinner than two contact distances along x \(0.0015\), so .* Fix: make the "
                                         r"box at least two contact distances wide"):
        reader.frame(0)


def test_liggghts_liquid_bridges_pull_beyond_contact_and_are_read():
    directory = os.path.join(LIGGGHTS, "easo")
    script = os.path.join(LIGGGHTS, "in.easo")
    reader = liggghts(None, directory, input=script, check_forces=False)
    assert reader.contact_reach == 2.0       # cohesion easo/capillary/viscous
    frames = read_all(reader)
    # forces between particles apart: a genuine cohesive frame the reach check must (and does) accept
    stretched = 0
    for f in frames:
        c, s = f.snapshot.contacts, f.snapshot
        pairs = c.j >= 0
        i, j = c.i[pairs], c.j[pairs]
        dist = np.linalg.norm(s.box.minimum_image(s.positions[i] - s.positions[j]), axis=1)
        stretched += int(np.sum((dist > s.radii[i] + s.radii[j]) & np.any(c.force[pairs] != 0, axis=1)))
    assert stretched > 0
    cols = {k: v for k, v in reader.pair_columns.items() if k in ("id", "force")}
    assert len(read_all(liggghts(None, directory, input=script, pair_columns=cols, check_forces=False))) == 3


def test_liggghts_cohesion_read_from_the_script():
    assert liggghts(None, **SETTLE).contact_reach == 1.0
    values = ("pos", "id", "force", "torque", "delta", "contactPoint")
    assert liggghts(None, pair_values=values).contact_reach == 2.0      # no script: cohesion not known


# ---- command line ----------------------------------------------------------------------------------

def test_cli_refuses_relabelled_positions(tmp_path, capsys):
    bad = relabelled(os.path.join(LAMMPS, "hooke3d", "atoms.dump"), tmp_path / "atoms.dump", "swap_v")
    out = tmp_path / "o.h5"
    args = ["run", bad, "--pairs", os.path.join(LAMMPS, "hooke3d", "pairs.dump"), "--input",
            os.path.join(LAMMPS, "in.hooke3d"), "--grid", "4,4,4", "-o", str(out), "-q"]
    assert main(args) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"cgbound: error: {bad}: timestep 4500: the positions do not fit the contacts of")
    assert "labels swapped" in err and "Traceback" not in err
    assert not out.exists()
    args[1] = os.path.join(LAMMPS, "hooke3d", "atoms.dump")
    assert main(args) == 0


def test_wall_contacts_of_relabelled_positions_are_refused(tmp_path):
    # the atoms dump alone (no contact dump): its wall contacts (fix wall/gran ... contacts, a point on the wall)
    # must lie within a radius of the particle's centre for in.hooke3d's repulsive wall
    bad = relabelled(os.path.join(LAMMPS, "hooke3d", "atoms.dump"), tmp_path / "atoms.dump", "swap_v")
    script = os.path.join(LAMMPS, "in.hooke3d")
    with pytest.warns(UserWarning, match="no contact dump"):
        good = LammpsReader(os.path.join(LAMMPS, "hooke3d", "atoms.dump"), input=script)
    assert good.wall_reach == 1.0 and sum(int(np.sum(f.snapshot.contacts.j < 0)) for f in read_all(good)) > 0
    with pytest.warns(UserWarning, match="no contact dump"):
        reader = LammpsReader(bad, input=script)
    with pytest.raises(ValueError, match=r"atoms\.dump: timestep 4500: the positions do not fit the wall contacts of "
                                         r"fix w: \d+ of \d+ contacts have their contact point \(f_w\[5\.\.7\]\) "
                                         r"further than the radius .*The worst: atom \d+ \(the atoms dump's line \d+\)"):
        reader.frame(0)


def test_errors_without_line_numbers(tmp_path):
    # a frame whose first line is not known (first_line None): the errors name the atoms without lines
    bad = relabelled(os.path.join(LAMMPS, "hooke3d", "atoms.dump"), tmp_path / "atoms.dump", "swap_v")
    with pytest.warns(UserWarning, match="no contact dump"):
        reader = LammpsReader(bad, input=os.path.join(LAMMPS, "in.hooke3d"))
    read = reader._atoms_dump.read

    def without_lines(*args, **kwargs):
        frame = read(*args, **kwargs)
        frame.pop("first_line", None)
        return frame

    reader._atoms_dump.read = without_lines
    with pytest.raises(ValueError, match=r"the wall contacts of fix w: .*The worst: atom \d+: the contact point"):
        reader.frame(0)


def test_scaled_positions_outside_the_box_are_shown_unscaled_too(tmp_path):
    src = os.path.join(LAMMPS, "hooke3d", "atoms_scaled.dump")
    dst = tmp_path / "atoms.dump"
    with open(src) as fh, open(dst, "w") as out:     # forces labelled as the scaled positions
        swap = {"xs": "fx", "ys": "fy", "zs": "fz", "fx": "xs", "fy": "ys", "fz": "zs"}
        for line in fh:
            if line.startswith("ITEM: ATOMS"):
                line = "ITEM: ATOMS " + " ".join(swap.get(c, c) for c in line.split()[2:]) + "\n"
            out.write(line)
    with pytest.raises(ValueError, match=r"timestep 4500: atom \d+ \(line \d+\) has ([xyz])s = -?[0-9.]+ \(\1 = "
                                         r"-?[0-9.]+\), outside the box \[0, (6|10)\]"):
        LammpsReader(dst).frame(0)


def _dist_edited(tmp_path, fraction, count):
    """A copy of hooke3d's contact dump whose first frame has the 'dist' of ``count`` contacts (inside the box) off by
    ``fraction`` of (dist + the largest coordinate written), the documented scale; the reader on it."""
    with open(os.path.join(LAMMPS, "hooke3d", "atoms.dump")) as fh:
        lines = fh.readlines()
    start = next(k for k, line in enumerate(lines) if line.startswith("ITEM: ATOMS")) + 1
    n = int(lines[3])
    names = lines[start - 1].split()[2:]
    rows = np.array([[float(w) for w in line.split()] for line in lines[start:start + n]])
    pos = {int(r[names.index("id")]): r[[names.index(c) for c in ("x", "y", "z")]] for r in rows}
    extent = float(np.max(np.abs(rows[:, [names.index(c) for c in ("x", "y", "z")]])))
    with open(os.path.join(LAMMPS, "hooke3d", "pairs.dump")) as fh:
        pairs = fh.readlines()
    start = next(k for k, line in enumerate(pairs) if line.startswith("ITEM: ENTRIES")) + 1
    m = int(pairs[3])
    edited = 0
    for k in range(start, start + m):
        words = pairs[k].split()
        sep = pos[int(words[1])] - pos[int(words[2])]
        if edited == count or np.any(np.abs(sep[:2]) > 3.0):     # (contacts across the periodic x, y boundary: kept)
            continue
        d = float(np.linalg.norm(sep))
        words[3] = repr((d + fraction * extent) / (1 - fraction))  # d' - d = fraction (d' + extent)
        pairs[k] = " ".join(words) + "\n"
        edited += 1
    assert edited == count
    out = tmp_path / "pairs.dump"
    out.write_text("".join(pairs))
    return LammpsReader(os.path.join(LAMMPS, "hooke3d", "atoms.dump"), out,
                        input=os.path.join(LAMMPS, "in.hooke3d")), m


@pytest.mark.parametrize("fraction,count,refused", [
    (1.03e-3, 1, True), (0.97e-3, 1, False),       # any contact: 1e-3 of (dist + the largest coordinate)
    (1.03e-4, 22, True), (0.97e-4, 22, False),     # most contacts (22 of 43): 1e-4
    (3e-4, 21, False),                             # 1e-4 < off < 1e-3 on fewer than half: read
])
def test_geometry_tolerances_hold_at_their_values(tmp_path, fraction, count, refused):
    reader, m = _dist_edited(tmp_path, fraction, count)
    assert m == 43
    if refused:
        tol = "0.001" if count == 1 else "0.0001"
        with pytest.raises(ValueError, match=rf"timestep 4500: .*: {count} of 43 contacts have a distance \('dist'.*"
                                             rf"\(tolerance {tol[:3]}"):
            reader.frame(0)
    else:
        assert int(np.sum(reader.frame(0).snapshot.contacts.j >= 0)) == 43


@pytest.mark.parametrize("column", [1, 4])     # x_i's x, x_j's x
def test_liggghts_one_wrong_position_in_the_contact_dump_is_refused(tmp_path, column):
    # the contact dump's pos (x_i, x_j) of one contact moved by 2e-4 (0.4 radii; tolerance 1e-3 of the largest
    # coordinate, 1.2e-5): refused whichever of the two is off
    with open(os.path.join(LIGGGHTS, "pairs.dump")) as fh:
        lines = fh.readlines()
    row = next(k for k, line in enumerate(lines) if line.startswith("ITEM: ENTRIES")) + 1
    words = lines[row].split()
    words[column - 1] = repr(float(words[column - 1]) + 2e-4)
    lines[row] = " ".join(words) + "\n"
    pairs = tmp_path / "pairs.dump"
    pairs.write_text("".join(lines))
    reader = liggghts(None, pairs=pairs, check_forces=False, **SETTLE)
    with pytest.raises(ValueError, match=r"timestep 22500: .*: 1 of 88 contacts have positions \(pair/gran/local 'pos'"):
        reader.frame(0)


def test_written_resolution():
    from cgbound.readers.checks import written_resolution
    values = np.random.default_rng(1).uniform(-10, 10, 1000)
    assert written_resolution(np.round(values, 2)) == 0.005
    assert written_resolution(np.round(values, 5), np.round(values, 2)) == 5e-6   # the finest column's
    assert written_resolution(values) < 1e-10                 # full precision: relative rounding only
    assert written_resolution(np.zeros(0)) == 0.0
