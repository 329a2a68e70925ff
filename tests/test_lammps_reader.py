"""The LAMMPS reader on genuine LAMMPS output (tests/data/lammps/in.*).

When ``lmp`` is on PATH the input scripts are run afresh in a temporary directory (a second or so
each); otherwise the dumps committed next to the scripts (written by LAMMPS 29 Sep 2021, Debian
20220106) are used.
"""
import os
import pickle
import shutil
import subprocess

import numpy as np
import pytest

import cgbound as cg
from cgbound.readers import LammpsReader

DATA = os.path.join(os.path.dirname(__file__), "data", "lammps")
LMP = shutil.which("lmp")

#: the keywords of 'compute pl all pair/local ...' in tests/data/lammps/in.*
GRAN_VALUES = ("dist", "fx", "fy", "fz", "p1", "p2", "p3", "p4")
GRANULAR_VALUES = ("dist", "fx", "fy", "fz") + tuple(f"p{k}" for k in range(1, 13))

CASES = {
    # name: reader options (gravity 1 along -z in 3D, along LAMMPS -y = cgbound -z in 2D)
    "hooke3d": dict(pair_style="gran", pair_values=GRAN_VALUES, body_force=(0.0, 0.0, -1.0)),
    "granular3d": dict(pair_style="granular", pair_values=GRANULAR_VALUES, body_force=(0.0, 0.0, -1.0)),
    "hooke2d": dict(pair_style="granular", pair_values=GRANULAR_VALUES, body_force=(0.0, -1.0), dimension=2),
}
TOL = 1e-9


@pytest.fixture(scope="session")
def lammps_dir(tmp_path_factory):
    """Directory holding <case>/*.dump: fresh LAMMPS runs, or the committed dumps without lmp."""
    if LMP is None:
        if all(os.path.exists(os.path.join(DATA, name, "atoms.dump")) for name in CASES):
            return DATA
        pytest.skip("LAMMPS ('lmp') is not on PATH and no committed dumps were found")
    root = tmp_path_factory.mktemp("lammps")
    for name in CASES:
        work = root / name
        work.mkdir()
        proc = subprocess.run([LMP, "-in", os.path.join(DATA, f"in.{name}"), "-log", "none", "-screen", "none"],
                              cwd=work, capture_output=True, text=True, timeout=300)
        if proc.returncode != 0 or not (work / "atoms.dump").exists():
            pytest.fail(f"lmp -in in.{name} failed ({proc.returncode}): {proc.stdout[-2000:]} {proc.stderr[-2000:]}")
    return str(root)


def reader(lammps_dir, name, consistent=True, **extra):
    pre = "" if consistent else "run_"
    # frames dumped during a run do not balance (see test_dumps_during_a_run_do_not_balance)
    opts = dict(CASES[name], walls=["w"], fixed_types=[2], check_forces=consistent)
    opts.update(extra)
    return LammpsReader(os.path.join(lammps_dir, name, f"{pre}atoms.dump"),
                        os.path.join(lammps_dir, name, f"{pre}pairs.dump"), **opts)


def contact_frames(r):
    return [k for k in range(len(r)) if len(r[k].contacts)]


# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", CASES)
def test_run0_dumps_balance_to_round_off(lammps_dir, name):
    r = reader(lammps_dir, name)
    assert len(r) == 3
    for k in range(len(r)):
        fr = r.frame(k)
        snap = fr.snapshot
        assert len(snap.contacts) > 10
        assert np.any(snap.contacts.j == -1), "expected wall contacts"
        # flowing particles (contacts + m g) and fixed particles (contacts only) both balance
        assert r.force_mismatch(k) < TOL
        assert r.force_mismatch(k, fixed=True) < TOL
        fb = fr.force_balance(fixed=True)
        assert fb["scale"] > 0
        assert np.all(fb["mismatch"] <= TOL * fb["scale"])


@pytest.mark.parametrize("name", CASES)
def test_dumps_during_a_run_do_not_balance(lammps_dir, name):
    # end-of-step pair/local values vs mid-step per-atom forces: damping makes them differ
    r = reader(lammps_dir, name, consistent=False)
    worst = max(r.force_mismatch(k) for k in contact_frames(r))
    assert worst > 1e-4


def test_sign_conventions_of_pair_local(lammps_dir):
    # the reader's force = (fx fy fz) + (p1 p2 p3), on patom1 from patom2; any other combination fails
    r = reader(lammps_dir, "hooke3d")
    fr = r.frame(2)
    assert fr.force_balance()["relative"] < TOL
    tangential_only = reader(lammps_dir, "hooke3d", pair_style="total", check_forces=False)
    assert tangential_only.force_mismatch(2) > 1e-2
    with pytest.raises(ValueError, match="timestep .*: the contact forces plus the body forces do not reproduce"):
        reader(lammps_dir, "hooke3d", pair_style="total")[2]
    snap = fr.snapshot
    c = snap.contacts
    pair = c.j >= 0
    bulk, _ = snap.split_contacts()
    # repulsive on average: force on i points from j to i
    r_ij = snap.positions[c.i[pair]] - snap.positions[c.j[pair]]
    r_ij -= snap.box.lengths * np.round(r_ij / snap.box.lengths) * np.array(snap.box.periodic)
    assert np.mean(np.sum(c.force[pair] * r_ij, axis=1) > 0) > 0.7


@pytest.mark.parametrize("name", CASES)
def test_fixed_type_contacts_become_boundary(lammps_dir, name):
    r = reader(lammps_dir, name)
    snap = r[len(r) - 1]
    fr = r.frame(len(r) - 1)
    assert np.array_equal(snap.fixed, fr.types == 2)
    c = snap.contacts
    wall = c.j < 0
    fixed_i = snap.fixed[c.i]
    fixed_j = np.where(wall, True, snap.fixed[np.where(wall, 0, c.j)])
    n_boundary = int(np.sum(fixed_i ^ fixed_j))
    n_fixed_particle = int(np.sum((fixed_i ^ fixed_j) & ~wall))
    assert n_fixed_particle > 0, "expected contacts with fixed particles"
    bulk, boundary = snap.split_contacts()
    assert len(boundary["i"]) == n_boundary
    assert len(bulk["i"]) == int(np.sum(~fixed_i & ~fixed_j))
    assert not np.any(snap.fixed[boundary["i"]])
    assert not np.any(snap.fixed[bulk["i"]]) and not np.any(snap.fixed[bulk["j"]])
    # the boundary forces are the forces on the flowing particles: sum them back per particle
    total = np.zeros((snap.n_particles, snap.dim))
    np.add.at(total, bulk["i"], bulk["force"])
    np.add.at(total, bulk["j"], -bulk["force"])
    np.add.at(total, boundary["i"], boundary["force"])
    total += snap.masses[:, None] * snap.body_force
    flow = snap.flowing
    scale = np.sqrt(np.mean(np.sum(c.force ** 2, axis=1)))
    assert np.max(np.abs(total[flow] - fr.forces[flow])) < TOL * scale
    # the same with the fixed particles given as IDs (a group) instead of a type
    by_ids = reader(lammps_dir, name, fixed_types=(), fixed_ids=fr.ids[fr.types == 2].tolist())
    assert np.array_equal(by_ids[len(r) - 1].fixed, snap.fixed)


@pytest.mark.parametrize("name", CASES)
def test_contact_points_and_minimum_image(lammps_dir, name):
    r = reader(lammps_dir, name)
    crossings = 0
    for k in range(len(r)):
        fr = r.frame(k)
        snap = fr.snapshot
        c = snap.contacts
        box = snap.box
        per = np.array(box.periodic)
        assert np.all((c.point[:, per] >= box.lower[per]) & (c.point[:, per] < box.upper[per]))
        assert np.all((snap.positions[:, per] >= box.lower[per]) & (snap.positions[:, per] < box.upper[per]))
        pair = c.j >= 0
        i, j = c.i[pair], c.j[pair]
        raw = snap.positions[i] - snap.positions[j]
        crossings += int(np.sum(np.any(np.abs(raw[:, per]) > 0.5 * box.lengths[per], axis=1)))
        r_ij = raw - box.lengths * np.round(raw / box.lengths) * per
        dist = np.linalg.norm(r_ij, axis=1)
        R = snap.radii
        assert np.all(dist < R[i] + R[j])      # only touching pairs are kept
        delta = R[i] + R[j] - dist
        assert np.allclose(fr.overlap[pair], delta, rtol=0, atol=1e-12)
        # c = x_i - (R_i - delta/2) n: on the centre line, half the overlap inside each sphere
        a = snap.positions[i] - c.point[pair]
        a -= box.lengths * np.round(a / box.lengths) * per
        expect = (R[i] - delta / 2)[:, None] * r_ij / dist[:, None]
        assert np.allclose(a, expect, rtol=0, atol=1e-12)
        b = snap.positions[j] - c.point[pair]
        b -= box.lengths * np.round(b / box.lengths) * per
        assert np.allclose(np.linalg.norm(b, axis=1), R[j] - delta / 2, rtol=0, atol=1e-12)
        # split_contacts' boundary branch vectors are short (minimum image): |a| <= R
        _, boundary = snap.split_contacts()
        assert np.all(np.linalg.norm(boundary["branch"], axis=1) <= R[boundary["i"]] + 1e-12)
    assert crossings > 0, "expected contacts across a periodic boundary"


def test_granular_branch_vector_matches_minimum_image(lammps_dir):
    # pair granular's p10-p12 (x_i - x_j from LAMMPS) and the reader's own minimum image agree
    with_branch = reader(lammps_dir, "granular3d")
    assert with_branch.pair_columns["branch"] == ("c_pl[14]", "c_pl[15]", "c_pl[16]")
    cols = dict(with_branch.pair_columns, branch=None)
    without = reader(lammps_dir, "granular3d", pair_columns=cols)
    for k in range(len(with_branch)):
        a, b = with_branch[k].contacts, without[k].contacts
        assert np.array_equal(a.i, b.i) and np.array_equal(a.j, b.j)
        assert np.allclose(a.point, b.point, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", CASES)
def test_wall_contacts(lammps_dir, name):
    r = reader(lammps_dir, name)
    snap = r[0]
    c = snap.contacts
    w = c.j == -1
    assert w.any()
    # the floor wall is the plane z = 0 (LAMMPS y = 0 in 2D, which is cgbound's z): the fix reports
    # the contact point on the wall, below the particle centre
    assert np.allclose(c.point[w, -1], 0.0, atol=1e-12)
    assert np.allclose(c.point[w, :-1], snap.positions[c.i[w], :-1], atol=1e-12)
    assert np.mean(c.force[w, -1] > 0) > 0.5  # mostly pushing up (damping can pull a rebounding particle)
    assert np.all(snap.positions[c.i[w], -1] < snap.radii[c.i[w]])
    # without the wall the balance breaks, and reading the frame says so
    assert reader(lammps_dir, name, walls=(), check_forces=False).force_mismatch(0) > 1e-3
    with pytest.raises(ValueError, match="walls are not marked"):
        reader(lammps_dir, name, walls=())[0]


def test_scaled_unwrapped_positions_and_column_order(lammps_dir):
    plain = reader(lammps_dir, "hooke3d")
    base = os.path.join(lammps_dir, "hooke3d")
    opts = dict(CASES["hooke3d"], walls=["w"], fixed_types=[2])
    for fname in ("atoms_scaled.dump", "atoms_unwrapped.dump"):
        other = LammpsReader(os.path.join(base, fname), os.path.join(base, "pairs.dump"), **opts)
        assert len(other) == len(plain)
        for k in range(len(plain)):
            a, b = plain[k], other[k]
            assert np.allclose(a.positions, b.positions, rtol=0, atol=1e-12)
            assert np.array_equal(a.velocities, b.velocities)
            assert np.array_equal(a.masses, b.masses)
            assert np.allclose(a.contacts.point, b.contacts.point, rtol=0, atol=1e-12)
            assert np.array_equal(a.contacts.force, b.contacts.force)
            assert other.force_mismatch(k, fixed=True) < TOL
    # the unwrapped dump really has atoms outside the box, which the reader wraps
    raw = open(os.path.join(base, "atoms_unwrapped.dump")).read()
    assert any(line.split()[4:7] != ["0", "0", "0"] for line in raw.splitlines()
               if len(line.split()) > 10 and line[0].isdigit())


def test_two_dimensions_map_lammps_xy_to_x_z(lammps_dir):
    r = reader(lammps_dir, "hooke2d")
    snap = r[0]
    assert snap.dim == 2
    assert snap.box.periodic == (True, False)
    assert np.allclose(snap.box.lower, [0.0, 0.0]) and np.allclose(snap.box.upper, [7.2, 12.0])
    assert np.array_equal(snap.body_force[0], [0.0, -1.0])
    # a 3-vector in LAMMPS axes is accepted too
    r3 = reader(lammps_dir, "hooke2d", body_force=(0.0, -1.0, 0.0))
    assert r3.force_mismatch(0) < TOL
    with pytest.raises(ValueError, match="body_force"):
        reader(lammps_dir, "hooke2d", body_force=(0.0, -1.0, 1.0))


def test_the_dimension_comes_from_the_input_script(lammps_dir):
    # 'dimension 2' in the script is the run's dimension (without dimension=2 the discs were read in 3-D); a
    # dimension the script contradicts is refused
    base = os.path.join(lammps_dir, "hooke2d")
    script = os.path.join(DATA, "in.hooke2d")
    r = LammpsReader(os.path.join(base, "atoms.dump"), os.path.join(base, "pairs.dump"), input=script)
    assert r.dimension == 2 and r[0].dim == 2 and r.force_mismatch(0) < TOL
    with pytest.raises(ValueError, match=r"dimension: 3 given, but the input script .*in.hooke2d says .dimension 2."):
        LammpsReader(os.path.join(base, "atoms.dump"), os.path.join(base, "pairs.dump"), input=script, dimension=3)
    assert LammpsReader(os.path.join(base, "atoms.dump"), os.path.join(base, "pairs.dump"), input=script,
                        dimension=2).dimension == 2


def test_a_timestep_written_twice_is_read_with_a_warning(lammps_dir, tmp_path):
    # a run restarted and appending to its dump writes the restart's step again: each copy is read (a time average
    # counts it twice), which is said, not silent
    atoms = open(os.path.join(lammps_dir, "hooke3d", "atoms.dump")).read()
    pairs = open(os.path.join(lammps_dir, "hooke3d", "pairs.dump")).read()
    first = "ITEM: TIMESTEP" + atoms.split("ITEM: TIMESTEP")[1]
    first_pairs = "ITEM: TIMESTEP" + pairs.split("ITEM: TIMESTEP")[1]
    step = first.split("\n")[1]
    (tmp_path / "atoms.dump").write_text(atoms + first)
    (tmp_path / "pairs.dump").write_text(pairs + first_pairs)
    lines = atoms.count("\n") + 1
    opts = dict(CASES["hooke3d"], walls=["w"], fixed_types=[2])
    with pytest.warns(UserWarning, match=rf"atoms.dump: timestep {step} is written 2 times \(frames at lines 1, "
                                         rf"{lines}\).*counts it 2 times"):
        r = LammpsReader(tmp_path / "atoms.dump", tmp_path / "pairs.dump", **opts)
    assert len(r) == len(LammpsReader(os.path.join(lammps_dir, "hooke3d", "atoms.dump"),
                                      os.path.join(lammps_dir, "hooke3d", "pairs.dump"), **opts)) + 1


def test_len_slicing_and_pickling(lammps_dir):
    r = reader(lammps_dir, "granular3d")
    assert len(r) == 3
    steps = r.timesteps
    assert steps == sorted(steps) and len(set(steps)) == 3
    assert r[-1].time == r[2].time == float(steps[2])
    sub = r[1:]
    assert isinstance(sub, LammpsReader) and len(sub) == 2 and sub.timesteps == steps[1:]
    assert np.array_equal(sub[0].positions, r[1].positions)
    assert len(r[::2]) == 2 and r[::-1].timesteps == steps[::-1]
    with pytest.raises(IndexError):
        r[3]
    with pytest.raises(TypeError):
        r[1.0]
    r.frame(0)  # fill the cache: it must not be pickled
    blob = pickle.dumps(r)
    assert len(blob) < 4000
    back = pickle.loads(blob)
    assert len(back) == 3
    for k in range(3):
        a, b = r[k], back[k]
        assert np.array_equal(a.positions, b.positions)
        assert np.array_equal(a.contacts.force, b.contacts.force)
    assert len(pickle.dumps(sub)) < 4000
    assert [s.time for s in r] == [float(t) for t in steps]
    assert reader(lammps_dir, "granular3d", dt=0.001)[0].time == pytest.approx(steps[0] * 0.001)


@pytest.mark.parametrize("name", CASES)
def test_coarse_grain_and_momentum_balance(lammps_dir, name):
    r = reader(lammps_dir, name)
    snap = r[len(r) - 1]
    forces = r.dumped_forces(len(r) - 1)
    kernel = cg.Lucy(1.5)
    res = cg.coarse_grain(snap, cg.Grid(snap.box, (4, 4, 8) if snap.dim == 3 else (6, 10)), kernel)
    assert np.all(np.isfinite(res["density"]))
    assert np.all(np.isfinite(res["stress"]))
    rng = np.random.default_rng(1)
    lo, hi = snap.box.lower.copy(), snap.box.upper.copy()
    hi[-1] = np.max(snap.positions[:, -1]) + 1.0
    points = lo + rng.random((150, snap.dim)) * (hi - lo)
    mb = cg.momentum_balance_residual(snap, points, kernel, forces=forces)
    assert mb.scale > 0 and np.max(mb.relative) < TOL
    # frames dumped during a run: the dumped forces do not match the dumped contacts
    bad = reader(lammps_dir, name, consistent=False)
    k = contact_frames(bad)[-1]
    mb_bad = cg.momentum_balance_residual(bad[k], points, kernel, forces=bad.dumped_forces(k))
    assert np.max(mb_bad.relative) > 1e-5


def test_coarse_grain_over_the_reader(lammps_dir):
    r = reader(lammps_dir, "hooke3d")
    box = r[0].box
    run = cg.CoarseGrain(r, cg.Grid(box, (1, 1, 20), average=("x", "y")), cg.Lucy(1.0)).run()
    assert run.n_frames == 3
    rho = run.results["density"]
    assert np.all(np.isfinite(rho)) and np.max(rho) > 0


def test_errors_name_the_problem(lammps_dir, tmp_path):
    base = os.path.join(lammps_dir, "hooke3d")
    atoms, pairs = os.path.join(base, "atoms.dump"), os.path.join(base, "pairs.dump")
    # a pairs dump without the atoms dump's timesteps
    gran = CASES["hooke3d"]["pair_values"]
    with pytest.raises(ValueError, match="no contact frame for timestep"):
        LammpsReader(atoms, os.path.join(base, "run_pairs.dump"), pair_values=gran)
    # files swapped
    with pytest.raises(ValueError, match="dump local"):
        LammpsReader(pairs)
    # compute IDs that do not match the dump's columns
    r = LammpsReader(atoms, pairs, pair_compute="forces", pair_values=gran, walls=["w"])
    with pytest.raises(ValueError, match="c_forces"):
        r[0]
    with pytest.raises(ValueError, match="f_nowall"):
        LammpsReader(atoms, pairs, pair_values=gran, walls=["nowall"])[0]
    with pytest.raises(ValueError, match="pair_style"):
        LammpsReader(atoms, pairs, pair_values=gran, pair_style="hooke")
    # a truncated file
    text = open(atoms).read()
    bad = tmp_path / "cut.dump"
    for cut in (100, 2000):
        bad.write_text(text[: len(text) - cut])
        with pytest.raises(ValueError, match="truncated"):
            LammpsReader(str(bad))
    # no pairs: particles only
    with pytest.warns(UserWarning, match="no contact dump .* the bulk contact stress is zero"):
        only = LammpsReader(atoms, fixed_types=[2])
    assert len(only) == 3 and len(only[0].contacts) == 0


# --- what the reader verifies instead of assuming (nothing silently wrong) ----------------------------

def test_a_pair_dump_without_its_column_meanings_is_refused(lammps_dir):
    base = os.path.join(lammps_dir, "hooke3d")
    with pytest.raises(ValueError, match=r"pair_values: the contact dump .* names its columns only by compute "
                                         r"and index .*c_pl\[8\].*--pair-values"):
        LammpsReader(os.path.join(base, "atoms.dump"), os.path.join(base, "pairs.dump"))
    with pytest.raises(ValueError, match="pair_values: 9 keywords .* holds 8 columns of compute 'pl'"):
        LammpsReader(os.path.join(base, "atoms.dump"), os.path.join(base, "pairs.dump"),
                     pair_values=GRAN_VALUES + ("p5",))


def test_a_wrong_column_order_fails_the_force_balance(lammps_dir, tmp_path):
    # the dump written as 'pair/local fx fy fz p1 p2 p3 p4 dist' but read as 'dist fx fy fz ...': every
    # frame read says so (the CLI exited 0 with a wrong IFD integral before this check)
    base = os.path.join(lammps_dir, "hooke3d")
    wrong = reader(lammps_dir, "hooke3d", pair_values=("fx", "fy", "fz", "p1", "p2", "p3", "p4", "dist"))
    # its 'dist' is a tangential force: not the distance between the positions; without it, the balance
    no_dist = reader(lammps_dir, "hooke3d", pair_columns=dict(wrong.pair_columns, dist=None))
    for k in range(len(wrong)):
        if len(reader(lammps_dir, "hooke3d")[k].contacts):
            with pytest.raises(ValueError, match=r"have a distance \('dist'.*pair_values=.*--pair-values"):
                wrong[k]
            with pytest.raises(ValueError, match="do not reproduce the dumped per-particle forces.*--pair-values"):
                no_dist[k]
    assert os.path.exists(os.path.join(base, "pairs.dump"))


def test_a_missing_body_force_fails_the_force_balance(lammps_dir):
    with pytest.raises(ValueError, match="a body force is missing or wrong"):
        reader(lammps_dir, "hooke3d", body_force=None)[0]


def test_dumps_during_a_run_are_refused_unless_asked(lammps_dir):
    unchecked = reader(lammps_dir, "hooke3d", consistent=False)
    worst = max(contact_frames(unchecked), key=unchecked.force_mismatch)
    with pytest.raises(ValueError, match="inside 'run 0'.*check_forces=False"):
        reader(lammps_dir, "hooke3d", consistent=False, check_forces=True)[worst]


@pytest.mark.parametrize("option, value, message", [
    ("fixed_types", [3], r"fixed_types: type\(s\) \[3\] select no particle .*types present: \[1, 2\]"),
    ("fixed_types", [2, 7], r"fixed_types: type\(s\) \[7\]"),
    ("fixed_ids", [10 ** 6], r"fixed_ids: atom ID\(s\) \[1000000\] are not in"),
    ("fixed_ids", [1, 10 ** 6, 2, 0, 999999], r"fixed_ids: atom ID\(s\) \[0, 999999, 1000000\] are not in"),
])
def test_a_selection_of_nothing_is_an_error(lammps_dir, option, value, message):
    with pytest.raises(ValueError, match=message):
        reader(lammps_dir, "hooke3d", **{option: value})[0]
