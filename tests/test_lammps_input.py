"""The LAMMPS/LIGGGHTS input-script parser: column meanings, fixed types, gravity, substitution, errors."""
import os
import shutil
import subprocess

import numpy as np
import pytest

from cgbound.readers.lammps import LammpsReader
from cgbound.readers.lammps_input import InputScriptError, _lattice_spacings, read_input

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "data")
REORDERED = os.path.join(DATA, "lammps_input", "in.reordered")


@pytest.mark.parametrize("name,style,dim,gravity,branch", [
    ("in.granular3d", "granular", 3, (0, 0, -1), ("c_pl[14]", "c_pl[15]", "c_pl[16]")),
    ("in.hooke2d", "granular", 2, (0, -1, 0), ("c_pl[14]", "c_pl[15]", "c_pl[16]")),
    ("in.hooke3d", "gran", 3, (0, 0, -1), None)])
def test_project_lammps_scripts(name, style, dim, gravity, branch):
    s = read_input(os.path.join(DATA, "lammps", name))
    assert s.pair_style == style and s.dimension == dim
    assert s.walls == ("w",) and s.fixed_types == (2,)
    assert np.array_equal(s.gravity, gravity)
    cols = s.pair_columns("pairs.dump")
    # these scripts write "index c_pp[*] c_pl[*]" with pair/local "dist fx fy fz p1 ..."
    assert cols == {"id1": "c_pp[1]", "id2": "c_pp[2]", "force": ("c_pl[2]", "c_pl[3]", "c_pl[4]"),
                    "tangential": ("c_pl[5]", "c_pl[6]", "c_pl[7]"), "branch": branch, "dist": "c_pl[1]"}
    atoms = s.dump_for("atoms.dump")
    assert atoms.names[:3] == ("id", "type", "x") and atoms.names[-8:] == tuple(f"f_w[{k}]" for k in range(1, 9))


def test_columns_agree_with_the_dump_headers():
    """The names the parser predicts are the names LAMMPS wrote in the genuine dumps' headers."""
    for case in ("hooke3d", "granular3d", "hooke2d"):
        s = read_input(os.path.join(DATA, "lammps", f"in.{case}"))
        for f in ("pairs.dump", "atoms.dump"):
            with open(os.path.join(DATA, "lammps", case, f)) as fh:
                header = next(line for line in fh if line.startswith(("ITEM: ENTRIES", "ITEM: ATOMS")))
            assert tuple(header.split()[2:]) == s.dump_for(f).names


def test_liggghts_script():
    s = read_input(os.path.join(DATA, "liggghts", "in.settle"))
    assert s.pair_style == "gran" and s.fixed_types == (2,) and np.array_equal(s.gravity, (0, 0, -9.81))
    spec = s.compute_for("pairs.dump")
    assert spec.style == "pair/gran/local"
    # LIGGGHTS's fixed order, whatever the keyword order: pos(6) id(3) force(3) torque(3) delta contactPoint(3)
    assert spec.columns == ("x1", "y1", "z1", "x2", "y2", "z2", "id1", "id2", "periodic", "fx", "fy", "fz",
                            "tqx", "tqy", "tqz", "delta", "cpx", "cpy", "cpz")
    dump = s.dump_for("pairs.dump")
    assert dump.meanings[6:9] == ("pgl:id1", "pgl:id2", "pgl:periodic")
    with open(os.path.join(DATA, "liggghts", "pairs.dump")) as fh:
        header = next(line for line in fh if line.startswith("ITEM: ENTRIES"))
    assert tuple(header.split()[2:]) == dump.names


def reordered_reader(directory, script):
    atoms = [f for f in os.listdir(directory) if f.startswith("atoms.")][0]
    pairs = [f for f in os.listdir(directory) if f.startswith("pairs.")][0]
    cols = script.pair_columns(pairs)
    good = LammpsReader(os.path.join(directory, atoms), os.path.join(directory, pairs), pair_columns=cols,
                        fixed_types=script.fixed_types, body_force=script.gravity)
    # the order the reader once assumed ('dist fx fy fz p1 p2 p3 p4'), checked off to see the mismatch
    default = LammpsReader(os.path.join(directory, atoms), os.path.join(directory, pairs),
                           pair_values=("dist", "fx", "fy", "fz", "p1", "p2", "p3", "p4"),
                           fixed_types=script.fixed_types, body_force=script.gravity, check_forces=False)
    return good, default


def check_reordered(directory):
    s = read_input(REORDERED, {"tilt": 10})
    assert s.pair_style == "gran" and s.fixed_types == (2,)
    angle = np.radians(10)
    assert np.allclose(s.gravity, [np.sin(angle), 0, -np.cos(angle)], rtol=0, atol=1e-15)
    cols = s.pair_columns("pairs.3000.dump")
    assert cols["force"] == ("c_pl[1]", "c_pl[2]", "c_pl[3]") and cols["tangential"] == ("c_pl[4]", "c_pl[5]", "c_pl[6]")
    good, default = reordered_reader(directory, s)
    snap = good[0]
    assert snap.fixed.sum() == 25 and len(snap.contacts) > 0
    # the columns (and the chute gravity) read from the script balance the dumped forces to round-off;
    # the reader's default column order is refused: its 'dist' (a force component) is not the distance the
    # positions give, nor do its forces balance
    assert good.force_mismatch(0) < 1e-12
    with pytest.raises(ValueError, match=r"atoms\.3000\.dump: timestep 3000: .* contacts have a distance "
                                         r"\('dist', column c_pl\[1\]\).*pair_values=\('dist'"):
        default.force_mismatch(0)
    cols = dict(default.pair_columns, dist=None)     # without its 'dist', the balance says it
    unchecked = LammpsReader(default.atoms_path, default.pairs_path, pair_columns=cols, fixed_types=s.fixed_types,
                             body_force=s.gravity, check_forces=False)
    assert unchecked.force_mismatch(0) > 0.1


def test_reordered_pair_dump_committed():
    check_reordered(os.path.join(DATA, "lammps_input"))


def test_reordered_pair_dump_fresh_lammps_run(tmp_path):
    if shutil.which("lmp") is None:
        pytest.skip("lmp is not installed")
    for f in ("in.reordered", "groups.in"):
        shutil.copy(os.path.join(DATA, "lammps_input", f), tmp_path / f)
    subprocess.run(["lmp", "-in", "in.reordered", "-var", "tilt", "10", "-log", "none", "-screen", "none"],
                   cwd=tmp_path, check=True, timeout=300)
    check_reordered(str(tmp_path))


def test_default_variables_and_var_override():
    s = read_input(REORDERED)   # tilt defaults to 0 (index variable): straight down
    assert np.allclose(s.gravity, [0, 0, -1], rtol=0, atol=0)
    s = read_input(REORDERED, {"tilt": 30, "g": "2.5"})
    assert np.allclose(s.gravity, 2.5 * np.array([0.5, 0, -np.sqrt(3) / 2]), rtol=1e-15)


def script(tmp_path, text, name="in.test"):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


HEAD = "dimension 3\ncreate_box 2 box\npair_style gran/hooke/history 1 1 1 1 0.5 1\n"


def test_substitution_and_gravity_styles(tmp_path):
    p = script(tmp_path, HEAD + "variable a equal 3*2\nvariable b string c_x\nvariable x index 7\n"
               "compute ${b} all pair/local p1 p2 p3 p4 fx fy fz dist # a comment, c_y\n"
               "compute pp all property/local patom1 patom2\n"
               "fix g all gravity $a spherical 0 $(v_a*15)\n"
               "dump d all local 5 pair_$x.dump c_pp[2] c_pp[1] c_${b}[5] c_${b}[6] c_${b}[7] c_c_x[1] &\n"
               "   c_c_x[2] c_c_x[3]\n")
    s = read_input(p)
    assert np.allclose(s.gravity, 6 * np.array([np.sin(np.pi / 2), 0, np.cos(np.pi / 2)]), atol=1e-14)
    cols = s.pair_columns("pair_7.dump")
    assert cols == {"id1": "c_pp[1]", "id2": "c_pp[2]", "force": ("c_c_x[5]", "c_c_x[6]", "c_c_x[7]"),
                    "tangential": ("c_c_x[1]", "c_c_x[2]", "c_c_x[3]"), "branch": None, "dist": None}
    s = read_input(p, {"x": 9})
    assert s.dump_for("pair_9.dump").file == "pair_9.dump"
    # quotes stop substitution (and comments), as in LAMMPS
    s = read_input(script(tmp_path, 'variable x index 3\nprint "${undefined} # not a comment"\n'
                          'dump d all custom 1 a$x.dump id\n'))
    assert s.dumps[0].file == "a3.dump"


@pytest.mark.parametrize("body,match", [
    ("dump d all local 1 p.dump c_nope[1]\n", "line 4: dump d: c_nope.1. names compute 'nope'"),
    ("compute pl all pair/local fx fy fz bogus\n", "line 4: compute pair/local: unknown keyword 'bogus'"),
    ("fix g all gravity ${undefined} vector 0 0 -1\n", "line 4: the variable 'undefined' is not defined"),
    ("fix g all gravity 1 vector 0 0 -1\nfix h all gravity 1 chute 3\n", "line 5: fix gravity h: a second gravity"),
    ("fix g all gravity 1 weird 0 0 -1\n", "style 'weird'"),
    ("variable v equal 1+step\nfix g all gravity $v vector 0 0 -1\n", "cannot evaluate the formula"),
    ("if \"1 > 0\" then \"dump d all local 1 x c_p[1]\"\n", "an 'if' command"),
    ("compute p all pair/gran/local pos history delta\ndump d all local 1 x.dump c_p[*]\n", "history"),
    ("compute p all pair/local fx fy fz\ndump d all local 1 x.dump c_p[4]\n", "compute p has 3 columns"),
    ("group g region r\nfix f g freeze\n", "not defined by atom type"),
    ("include missing.in\n", "cannot read the input script"),
])
def test_errors_name_script_and_line(tmp_path, body, match):
    p = script(tmp_path, HEAD + body)
    with pytest.raises(InputScriptError, match=match) as info:
        read_input(p)
    assert p in str(info.value) or "missing.in" in str(info.value)


def test_liggghts_columns_after_the_history_values_are_read_their_count_left_to_the_reader(tmp_path):
    # the number of history values depends on the contact model: a dump listing columns from the first history value
    # on was refused; their meanings stay unknown here, and the LIGGGHTS reader counts them from the dump
    p = script(tmp_path, HEAD + "compute p all pair/gran/local pos history delta\n"
                                "dump d all local 1 x.dump c_p[6] c_p[7] c_p[9]\n")
    s = read_input(p)
    assert s.dump_for("x.dump").meanings == ("p:z2", "p:after history 1", "p:after history 3")
    assert s.compute_for("x.dump").values == ("pos", "history", "delta")


def test_dump_lookup_errors(tmp_path):
    p = script(tmp_path, HEAD + "compute pl all pair/local fx fy fz\ncompute pp all property/local patom1 patom2\n"
               "dump a all local 1 x.dump c_pp[*] c_pl[*]\ndump b all local 1 x.dump c_pl[*] c_pp[*]\n"
               "dump c all local 1 y.dump c_pl[*]\n")
    s = read_input(p)
    with pytest.raises(InputScriptError, match="no dump command writes a file named 'z.dump'"):
        s.dump_for("z.dump")
    with pytest.raises(InputScriptError, match="different columns"):
        s.dump_for("x.dump")
    with pytest.raises(InputScriptError, match="has no 'patom1' column"):
        s.pair_columns("y.dump")


def test_include_and_never_integrated(tmp_path):
    script(tmp_path, "group flow type 1\ngroup wall type 3\n", "sub.in")
    p = script(tmp_path, "create_box 3 box\ninclude sub.in\nfix i flow nve\nfix f wall freeze\n"
               "fix w flow wall/gran hooke 1 1 1 1 1 0 zplane 0 NULL contacts\n")
    s = read_input(p)
    assert s.fixed_types == (2, 3) and s.walls == ("w",) and s.gravity is None


# --- the readers take the script itself: input= (the CLI's --input, --var) ------------------------------

def test_lammps_reader_with_its_input_script_reads_what_the_explicit_options_read():
    base = os.path.join(os.path.dirname(__file__), "data", "lammps")
    atoms, pairs = os.path.join(base, "hooke3d", "atoms.dump"), os.path.join(base, "hooke3d", "pairs.dump")
    by_script = LammpsReader(atoms, pairs, input=os.path.join(base, "in.hooke3d"))
    explicit = LammpsReader(atoms, pairs, pair_values=("dist", "fx", "fy", "fz", "p1", "p2", "p3", "p4"),
                            fixed_types=[2], walls=["w"], body_force=(0, 0, -1))
    assert by_script.walls == ("w",) and by_script.fixed_types == (2,)
    for k in range(len(explicit)):
        a, b = by_script[k], explicit[k]
        np.testing.assert_array_equal(a.fixed, b.fixed)
        np.testing.assert_array_equal(a.contacts.force, b.contacts.force)
        np.testing.assert_array_equal(a.body_force, b.body_force)


def test_the_reordered_dump_reads_balanced_through_its_script_with_variables():
    d = os.path.join(DATA, "lammps_input")
    frames = LammpsReader(os.path.join(d, "atoms.3000.dump"), os.path.join(d, "pairs.3000.dump"), input=REORDERED,
                          variables={"tilt": 10})
    assert frames.force_mismatch(0) < 1e-12 and frames[0].fixed.sum() == 25


def test_liggghts_reader_with_its_input_script():
    from cgbound.readers import LiggghtsReader
    d = os.path.join(os.path.dirname(__file__), "data", "liggghts")
    by_script = LiggghtsReader(os.path.join(d, "atoms.dump"), os.path.join(d, "pairs.dump"),
                               input=os.path.join(d, "in.settle"))
    explicit = LiggghtsReader(os.path.join(d, "atoms.dump"), os.path.join(d, "pairs.dump"),
                              pair_values=("pos", "id", "force", "torque", "delta", "contactPoint"), fixed_types=[2],
                              body_force=(0, 0, -9.81))
    for k in range(len(explicit)):
        np.testing.assert_array_equal(by_script[k].contacts.point, explicit[k].contacts.point)
        np.testing.assert_array_equal(by_script[k].fixed, explicit[k].fixed)


def test_a_loop_variable_without_its_count_is_an_error_naming_the_line(tmp_path):
    script = tmp_path / "in.cut"
    script.write_text("units lj\nvariable k loop\n")
    with pytest.raises(ValueError, match=r"in\.cut: line 2: variable k loop: expected 'N' or 'N1 N2'"):
        read_input(script)


@pytest.mark.parametrize("lines,cohesive", [
    ("pair_style gran/hooke/history 1 NULL 1 NULL 0.5 1\npair_coeff * *", False),
    ("pair_style granular\npair_coeff * * hertz/material 1e4 0.5 0.3 tangential mindlin NULL 1.0 0.5", False),
    ("pair_style granular\npair_coeff 1 1 hertz 1e4 0.5\npair_coeff 1 2 jkr 1e4 0.5 0.3 50.0 tangential mindlin NULL 1 0.5",
     True),
    ("pair_style gran model hertz tangential history cohesion sjkr\npair_coeff * *", True),
    ("pair_style gran model hertz tangential history\npair_coeff * *", False),
    ("pair_style lj/cut 2.5\npair_coeff * * 1 1", None),
    # a later pair_style replaces the earlier one and its coefficients
    ("pair_style granular\npair_coeff * * jkr 1e4 0.5 0.3 50.0\npair_style gran/hertz/history 1 NULL 1 NULL 0.5 1\n"
     "pair_coeff * *", False),
])
def test_cohesion_of_the_pair_style(tmp_path, lines, cohesive):
    s = read_input(script(tmp_path, "dimension 3\ncreate_box 2 box\n" + lines + "\n"))
    assert s.cohesive is cohesive
    last = [line for line in lines.split("\n") if line.startswith("pair_style")][-1]
    assert s.pair_command == tuple(last.split()[1:])


def test_wall_reach_of_the_wall_fixes(tmp_path):
    s = read_input(script(tmp_path, HEAD + "group flow type 1\n"
                          "fix a flow wall/gran hooke/history 1 NULL 1 NULL 0.5 1 zplane 0 NULL contacts\n"
                          "fix b flow wall/gran granular jkr 1e4 0.5 0.3 50 tangential mindlin NULL 1 0.5 zplane 0 NULL "
                          "contacts\n"))
    assert s.walls == ("a", "b")
    assert s.wall_reach(("a",)) == 1.0          # repulsive
    assert s.wall_reach(("a", "b")) == 2.0      # jkr pulls beyond contact
    assert s.wall_reach(("c",)) == 2.0          # not in the script: not known


def test_fix_deform_change_per_step(tmp_path):
    # the box's change per step as LAMMPS' fix deform defines it (the allowance of a frame read alone in a deforming
    # box): delta over the run, vel and erate per time step size, every N steps N times that, 'final' from the
    # frame's box to the final one over the run's remaining steps (lattice units by default in LAMMPS, box in
    # LIGGGHTS); 0 without a fix deform at that step; None where the script does not tell
    path = script(tmp_path, """units lj
lattice fcc 0.8
timestep 0.002
run 100
fix d all deform 2 x delta -1 1 y vel 0.5 z erate 0.01 units box remap x
run 200
unfix d
run 50
fix d2 all deform 1 x final 0 3
run 100
label again
run 10
""")
    s = read_input(path)
    lower, upper = np.zeros(3), np.array([4.0, 4.0, 4.0])
    assert s.deform_change(150, lower, upper) == pytest.approx(
        2 * np.sqrt(0.01 ** 2 + 0.001 ** 2 + (2e-5 * 4 / 1.001) ** 2), rel=1e-12)
    assert s.deform_change(50, lower, upper) == 0.0 and s.deform_change(320, lower, upper) == 0.0
    a = (4 / 0.8) ** (1 / 3)
    assert s.deform_change(400, lower, upper) == pytest.approx(abs(3 * a - 4) / 50, rel=1e-12)
    assert s.deform_change(400, lower, upper, "box") == pytest.approx(1 / 50, rel=1e-12)
    assert s.deform_change(450, lower, upper) is None       # (the final box: its start not known from the frame)
    assert s.deform_change(455, lower, upper) is None       # (a run after a label: its steps not known)
    wiggle = read_input(script(tmp_path, "fix d all deform 1 x wiggle 0.1 1.0\nrun 10\n", "in.wiggle"))
    assert wiggle.deform_change(5, lower, upper) is None
    # the lattice spacings LAMMPS printed (lj: a reduced density, hcp's cell sqrt(8) lattice constants cubed)
    assert np.allclose(_lattice_spacings(["lattice", "hcp", "0.9"], "lj", 3), (1.1625835, 2.0136537, 1.8984909),
                       rtol=1e-7)
    assert np.allclose(_lattice_spacings(["lattice", "hex", "0.8"], "lj", 2), (1.2014057, 2.0808957, 1.2014057),
                       rtol=1e-7)
