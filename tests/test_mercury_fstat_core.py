"""cg_fstat_contacts (the C pass over a MercuryDPM .fstat frame, csrc/cg_fstat.h) against its NumPy twin
oracle_fstat_contacts (MercuryReader's NumPy code as it was): the same contacts bit for bit, or the same problem
at the same lines. On the frames the reader hands to the core from genuine MercuryDPM output and from the test
data (recorded through the reader), and on synthetic frames: lines in turn or shuffled, walls, fixed particles,
periodic boxes, 2-D, extra columns, and damaged ones (a side lost, a pair repeated, one side twice, forces or
contact points that disagree, another frame's time, indices out of range, self contacts, flat normals)."""
import os

import numpy as np
import pytest

import cgbound as cg
from cgbound import _engine
from cgbound.readers import MercuryReader, write_mercury
from cgbound.readers import mercury as mercury_module
from oracle import FSTAT_PROBLEMS, oracle_fstat_contacts

DATA = os.path.join(os.path.dirname(__file__), "data")
GENUINE = os.path.join(DATA, "mercurydpm", "ChutePeriodicDemo", "ChutePeriodicDemo")
T15 = os.path.join(DATA, "mercurycg", "ChutePeriodicDemo_t15")
CORE = _engine.fstat_contacts     # (the fixture below records the reader's calls by patching _engine)


def assert_same(got, want):
    """The core's answer and the twin's: the same problem and details, or the same arrays bit for bit."""
    assert got[0] == want[0], (got[:2], want[:2])
    if got[0]:
        kind = got[0]
        g, w = got[1], want[1]
        assert g[0] == w[0], (g, w)                         # the row
        if kind in (FSTAT_PROBLEMS["repeated"], FSTAT_PROBLEMS["inconsistent"]):
            assert g[2:5] == w[2:5], (g, w)                  # the pair and its count
        if kind == FSTAT_PROBLEMS["inconsistent"]:
            assert g[1] == w[1]
            np.testing.assert_array_equal(np.array(g[5:7]), np.array(w[5:7]))
            assert np.array(g[7:]).tobytes() == np.array(w[7:]).tobytes()
        return
    assert len(got[2]) == len(want[2]) == 6
    for a, b, name in zip(got[2], want[2], ("i", "j", "wall", "force", "point", "overlap")):
        assert a.dtype == b.dtype and a.shape == b.shape, (name, a.dtype, b.dtype, a.shape, b.shape)
        assert a.flags.c_contiguous
        assert a.tobytes() == b.tobytes(), name


def both(*args):
    got = CORE(*args)
    want = oracle_fstat_contacts(*args)
    assert_same(got, want)
    return got


@pytest.fixture
def recorded(monkeypatch):
    """The arguments of every call the reader makes to the core's fstat_contacts."""
    calls = []

    def record(*args):
        calls.append(tuple(np.array(a, copy=True) if isinstance(a, np.ndarray) else a for a in args))
        return CORE(*args)

    monkeypatch.setattr(mercury_module._engine, "fstat_contacts", record)
    return calls


def read_all(frames):
    return [frames.frame(k) for k in range(len(frames))]


def test_genuine_mercurydpm_frames_identical(recorded):
    frames = MercuryReader(GENUINE + ".data", GENUINE + ".fstat", restart_path=GENUINE + ".restart")
    read_all(frames)
    assert len(frames) == 10 and len(recorded) == 9     # (the frame at t = 0 has no contacts)
    kept = 0
    for args in recorded:
        got = both(*args)
        assert got[0] == 0
        kept += len(got[2][0])
        assert any(args[7])       # periodic in x and y: the minimum image is used
    assert kept > 1000


def test_mercurycg_test_data_frames_identical(recorded):
    frames = MercuryReader(T15 + ".data", T15 + ".fstat", density=6 / np.pi,
                           fixed=lambda radius, species: np.arange(radius.size) < 210, periodic=(True, True, False))
    read_all(frames)
    assert recorded
    for args in recorded:
        assert both(*args)[0] == 0


def lattice_snapshot(rng, dim=3, n_side=5, periodic=False, fixed_share=0.0, walls=0):
    """A jittered lattice with contacts between neighbours (each pair once, i < j or not), walls optional."""
    grid = np.stack(np.meshgrid(*[np.arange(n_side)] * dim, indexing="ij"), -1).reshape(-1, dim).astype(float)
    pos = grid + rng.normal(scale=0.02, size=grid.shape)
    n = len(pos)
    box = cg.Box(np.full(dim, -0.5), np.full(dim, n_side - 0.5), (periodic,) * dim)
    a, b = np.triu_indices(n, 1)
    d = np.abs(grid[a] - grid[b])
    if periodic:
        d = np.minimum(d, n_side - d)
    near = d.sum(axis=1) == 1.0
    a, b = a[near], b[near]
    swap = rng.random(a.size) < 0.5
    pairs = np.stack([np.where(swap, b, a), np.where(swap, a, b)], axis=1)
    branch = box.minimum_image(pos[pairs[:, 0]] - pos[pairs[:, 1]])
    point = pos[pairs[:, 0]] - 0.5 * branch
    force = rng.normal(size=(len(pairs), dim))
    i, j = pairs[:, 0], pairs[:, 1]
    if walls:
        w = rng.choice(n, walls)
        i = np.r_[i, w]
        j = np.r_[j, -np.ones(walls, np.int64)]
        wall_point = pos[w].copy()
        wall_point[:, -1] -= 0.5
        point = np.r_[point, wall_point]
        force = np.r_[force, rng.normal(size=(walls, dim))]
    fixed = rng.random(n) < fixed_share
    masses = np.where(fixed, 1.0, 1.0)
    return cg.Snapshot(pos, np.zeros((n, dim)), masses, box=box, contacts=cg.Contacts(i, j, force, point),
                       fixed=fixed, radii=np.full(n, 0.5), time=2.5)


def frame_args(path, snap, rtol=1e-9):
    """The core's arguments for the snapshot written with write_mercury and read back (tmp files)."""
    data, fstat = str(path / "f.data"), str(path / "f.fstat")
    write_mercury([snap], data, fstat)
    from cgbound.readers._mercury_files import fstat_rows, scan_fstat
    fr = scan_fstat(fstat)[0]
    with fstat_rows(fstat, fr[2], fr[4], fr[5], fr[6]) as (rows, ints, _):
        rows, ints = rows.copy(), ints.copy()   # (the table is in reused memory)
    return [rows, ints, fr[2], 1e-9 * max(1.0, abs(fr[2])), np.ascontiguousarray(snap.positions), snap.radii,
            snap.fixed, snap.box.periodic, [float(x) for x in snap.box.lengths], rtol]


CASES = [dict(dim=3), dict(dim=2), dict(dim=3, periodic=True), dict(dim=2, periodic=True),
         dict(dim=3, walls=7), dict(dim=3, fixed_share=0.3, walls=3), dict(dim=2, fixed_share=0.3, periodic=True)]


@pytest.mark.parametrize("case", range(len(CASES)))
@pytest.mark.parametrize("order", ["as written", "shuffled", "reversed pairs", "extra columns"])
def test_synthetic_frames_identical(tmp_path, case, order):
    rng = np.random.default_rng(case)
    args = frame_args(tmp_path, lattice_snapshot(rng, **CASES[case]))
    rows, ints = args[0], args[1]
    if order == "shuffled":
        perm = rng.permutation(len(rows))
        args[0], args[1] = np.ascontiguousarray(rows[perm]), np.ascontiguousarray(ints[perm])
    elif order == "reversed pairs":      # in turn, but the pairs in decreasing order
        pair = np.flatnonzero(ints[:, 1] >= 0)
        if len(pair) % 2 == 0:
            blocks = pair.reshape(-1, 2)[::-1].ravel()
            perm = np.arange(len(rows))
            perm[pair] = blocks
            args[0], args[1] = np.ascontiguousarray(rows[perm]), np.ascontiguousarray(ints[perm])
    elif order == "extra columns":
        args[0] = np.ascontiguousarray(np.c_[rows, rng.normal(size=(len(rows), 3))])
    got = both(*args)
    assert got[0] == 0 and len(got[2][0]) > 0


DAMAGES = ["drop a side", "repeat a pair", "one side twice", "force", "point", "time", "particle", "negative particle",
           "ghost", "self", "flat", "flat without force", "huge"]


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("damage", DAMAGES)
def test_damaged_frames_give_the_same_problem(tmp_path, seed, damage):
    rng = np.random.default_rng(100 + seed)
    snap = lattice_snapshot(rng, dim=3 if seed % 2 else 2, periodic=seed % 3 == 0, walls=3,
                            fixed_share=0.2 * (seed % 2))
    args = frame_args(tmp_path, snap)
    rows, ints = args[0].copy(), args[1].copy()
    if seed >= 3:          # the general path: lines out of turn
        perm = rng.permutation(len(rows))
        rows, ints = rows[perm], ints[perm]
    pair = np.flatnonzero(ints[:, 1] >= 0)
    k = int(rng.choice(pair))
    n = len(args[4])
    if damage == "drop a side":
        keep = np.ones(len(rows), bool)
        keep[k] = False
        rows, ints = rows[keep], ints[keep]
    elif damage == "repeat a pair":
        at = int(rng.integers(len(rows) + 1))
        rows, ints = np.insert(rows, at, rows[k], axis=0), np.insert(ints, at, ints[k], axis=0)
    elif damage == "one side twice":
        other = np.flatnonzero((ints[:, 0] == ints[k, 1]) & (ints[:, 1] == ints[k, 0]))
        if len(other):
            ints[other[0]] = ints[k]
    elif damage == "force":
        rows[k, 8] *= 1 + 1e-6
    elif damage == "point":
        rows[k, 3] += 1e-6
    elif damage == "time":
        rows[k, 0] += 1.0
    elif damage == "particle":
        ints[k, 0] = n + 3
    elif damage == "negative particle":
        ints[k, 0] = -1
    elif damage == "ghost":
        ints[k, 1] = n
    elif damage == "self":
        ints[k, 1] = ints[k, 0]
    elif damage in ("flat", "flat without force"):
        i = ints[k, 0]
        arm = args[4][i] - rows[k, 3:3 + len(args[8])]
        t = np.zeros(3)
        t[:len(arm)] = arm
        perp = np.cross(t, [0.3, 0.5, 0.8]) if len(arm) == 3 else np.array([-t[1], t[0], 0.0])
        rows[k, 10:13] = perp / np.linalg.norm(perp)
        if len(arm) == 2:
            rows[k, 12] = 0.0
        if damage == "flat without force":
            rows[k, 8:10] = 0.0
    elif damage == "huge":          # forces that overflow to inf; contact points far away
        rows[k, 8] = 1e308
        rows[k, 10] = 1e10
    args[0], args[1] = np.ascontiguousarray(rows), np.ascontiguousarray(ints)
    with np.errstate(over="ignore", invalid="ignore"):    # ("huge": the twin's products overflow to inf)
        got = both(*args)
    if damage in ("drop a side",) and not snap.fixed.any():
        assert got[0] == FSTAT_PROBLEMS["once"]
    if damage in ("time", "particle", "negative particle", "ghost", "self", "repeat a pair"):
        assert got[0] == FSTAT_PROBLEMS[{"negative particle": "particle", "repeat a pair": "repeated"}.get(damage,
                                                                                                       damage)]


def test_several_problems_the_first_kind_and_line_win(tmp_path):
    rng = np.random.default_rng(7)
    args = frame_args(tmp_path, lattice_snapshot(rng, walls=2))
    rows, ints = args[0].copy(), args[1].copy()
    n = len(args[4])
    ints[40, 1] = ints[40, 0]            # self (line 40) comes after a ghost (line 30) in kind order ...
    ints[30, 1] = n
    ints[50, 0] = n                      # ... and a bad particle index (line 50) before both
    rows[60, 0] += 1                     # ... and another frame's time before all
    for fix in (None, 60, 50, 30, 40):
        if fix == 60:
            rows[60, 0] -= 1
        elif fix == 50:
            ints[50, 0] = 0 if ints[50, 1] != 0 else 1
        elif fix == 30:
            ints[30, 1] = -1
        elif fix == 40:
            ints[40, 1] = -2
        args[0], args[1] = rows, ints
        both(*args)


def test_no_lines_and_only_walls(tmp_path):
    rng = np.random.default_rng(3)
    args = frame_args(tmp_path, lattice_snapshot(rng, walls=5))
    walls = args[1][:, 1] < 0
    args[0], args[1] = np.ascontiguousarray(args[0][walls]), np.ascontiguousarray(args[1][walls])
    got = both(*args)
    assert got[0] == 0 and np.all(got[2][1] == -1) and len(got[2][0]) == 5
    args[0], args[1] = np.zeros((0, 16)), np.zeros((0, 2), np.int64)
    got = both(*args)
    assert got[0] == 0 and got[2][3].shape == (0, len(args[4][0]))


def test_the_binding_refuses_wrong_shapes():
    pos = np.zeros((2, 3))
    good = [np.zeros((1, 16)), np.zeros((1, 2), np.int64), 0.0, 1e-9, pos, np.ones(2), np.zeros(2, bool),
            (False,) * 3, [1.0] * 3, 1e-9]
    for k, bad in [(0, np.zeros((1, 15))), (1, np.zeros((2, 2), np.int64)), (4, np.zeros((2, 4))),
                   (5, np.ones(3)), (6, np.zeros(3, bool)), (9, -1.0)]:
        args = list(good)
        args[k] = bad
        with pytest.raises(ValueError, match="fstat_contacts"):
            CORE(*args)
