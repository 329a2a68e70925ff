"""The readers' fast paths against plain references: the LAMMPS contacts' atom positions (consecutive IDs
by subtraction, others by a search) against a dict of the IDs; the C line count against bytes.count."""
import mmap

import numpy as np
import pytest

from cgbound.readers._text import count_lines
from cgbound.readers.lammps import contact_indices

BIG = np.iinfo(np.int64).max


def positions_by_dict(ids, id1, id2):
    """Reference: the position of each ID in a dict; None where an ID is absent."""
    where = {int(v): k for k, v in enumerate(ids)}
    out = [(where.get(int(a)), where.get(int(b))) for a, b in zip(id1, id2)]
    bad = [k for k, (a, b) in enumerate(out) if a is None or b is None]
    return out, bad


ID_SETS = {
    "1..N": np.arange(1, 101, dtype=np.int64),
    "0..N-1": np.arange(0, 100, dtype=np.int64),
    "negative, consecutive": np.arange(-50, 50, dtype=np.int64),
    "near the int64 top": BIG - np.arange(99, -1, -1, dtype=np.int64),
    "near the int64 bottom": -BIG - 1 + np.arange(100, dtype=np.int64),
    "with gaps": np.sort(np.random.default_rng(1).choice(10 ** 6, 100, replace=False)).astype(np.int64),
    "one gap": np.r_[np.arange(1, 50), np.arange(51, 102)].astype(np.int64),
    "one atom": np.array([7], np.int64),
}


@pytest.mark.parametrize("name", sorted(ID_SETS))
@pytest.mark.parametrize("absent", [False, True])
def test_contact_indices_match_a_dict_of_the_ids(name, absent):
    ids = ID_SETS[name]
    rng = np.random.default_rng(len(name))
    id1, id2 = rng.choice(ids, 500), rng.choice(ids, 500)
    if absent:   # IDs just outside, far outside (where ID - first wraps around in int64) and in a gap
        strangers = [int(ids[0]) - 1, int(ids[-1]) + 1, -BIG - 1, BIG, int(ids[0]) + (1 if ids.size > 1 else 0)]
        strangers = [v for v in strangers if -BIG - 1 <= v <= BIG and v not in set(ids.tolist())]
        k = rng.choice(500, len(strangers), replace=False)
        id2[k] = strangers
    expected, bad = positions_by_dict(ids, id1, id2)
    if bad:
        k = bad[0]
        with pytest.raises(ValueError, match=rf"dump\.local: contact between atom IDs {id1[k]} and {id2[k]} at "
                                             rf"timestep 40: an ID is not in the atoms dump"):
            contact_indices(ids, id1, id2, "dump.local", 40)
        return
    assert not absent or name == "one atom"
    i, j = contact_indices(ids, id1, id2, "dump.local", 40)
    assert i.dtype == j.dtype == np.int64
    np.testing.assert_array_equal(i, [a for a, _ in expected])
    np.testing.assert_array_equal(j, [b for _, b in expected])


def test_contact_indices_of_no_atoms_are_an_error():
    with pytest.raises(ValueError, match="contact between atom IDs 1 and 2"):
        contact_indices(np.zeros(0, np.int64), np.array([1]), np.array([2]), "p", 0)


def lines_by_count(text):
    """Reference: newlines, plus one for a last line without one."""
    return text.count(b"\n") + (1 if text and not text.endswith(b"\n") else 0)


@pytest.mark.parametrize("text", [b"", b"\n", b"a", b"a\n", b"\n\n\n", b"a\r\nb\r\n", b"1 2\n3 4",
                                  b"x" * 7 + b"\n" * 9 + b"y" * 17, bytes(range(256)) * 3, b"\n" * 64 + b"z"])
def test_count_lines_matches_bytes_count(text):
    assert count_lines(text) == lines_by_count(text)
    for start in range(0, len(text) + 1, 3):      # every alignment of the 8-byte words
        for stop in range(start, len(text) + 1, 5):
            assert count_lines(text, start, stop) == lines_by_count(text[start:stop]), (start, stop)


def test_count_lines_on_random_text_and_an_mmap(tmp_path):
    rng = np.random.default_rng(5)
    text = rng.choice(np.frombuffer(b"0123456789 .-e\t\r\n\n", np.uint8), 100_003).tobytes()
    path = tmp_path / "t.txt"
    path.write_bytes(text)
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as mm:
        assert count_lines(mm) == lines_by_count(text)
        assert count_lines(mm, 11, 99_999) == lines_by_count(text[11:99_999])
    with pytest.raises(ValueError, match="start, stop: expected 0 <= start <= stop"):
        count_lines(text, 5, 4)
    with pytest.raises(ValueError, match="start, stop: expected 0 <= start <= stop"):
        count_lines(text, 0, len(text) + 1)


def lines_in_turn_by_norms(i, jraw, force, point, lines, tol_force, tol_point):
    """The twin of lines_in_turn's tolerance test as it was written: np.linalg.norm of every pair, compared."""
    a, b = lines[0::2], lines[1::2]
    df = np.linalg.norm(force[a] + force[b], axis=1)
    dc = np.linalg.norm(point[a] - point[b], axis=1)
    return not np.any((df > tol_force) | (dc > tol_point))


@pytest.mark.parametrize("seed", range(40))
def test_lines_in_turn_tolerances_match_the_norms(seed):
    """The twin's in-turn tolerance test (one square root per pair) against the norms it replaced; the C pass
    is held to the twin in tests/test_mercury_fstat_core.py."""
    from oracle import oracle_lines_in_turn as lines_in_turn
    rng = np.random.default_rng(seed)
    m = int(rng.integers(1, 60))
    lo = np.sort(rng.choice(10 * m, m, replace=False))
    hi = lo + 1 + rng.integers(0, 5, m)
    i, jraw = np.empty(2 * m, np.int64), np.empty(2 * m, np.int64)
    i[0::2], jraw[0::2], i[1::2], jraw[1::2] = lo, hi, hi, lo
    scale = 10.0 ** rng.integers(-200, 200)
    force = np.empty((2 * m, 3))
    force[0::2] = rng.normal(size=(m, 3)) * scale
    force[1::2] = -force[0::2] + rng.normal(size=(m, 3)) * scale * 10.0 ** rng.integers(-18, 1)
    point = np.repeat(rng.normal(size=(m, 3)), 2, axis=0) + rng.normal(size=(2 * m, 3)) * 10.0 ** rng.integers(-18, 1)
    if seed % 4 == 1:
        force[rng.integers(0, 2 * m)] = np.nan
    if seed % 4 == 2:
        force[rng.integers(0, 2 * m), 0] = 1e308    # its square overflows
    lines = np.arange(2 * m)
    for tol_force in (0.0, scale * 1e-9, scale * 1e-3, scale, np.inf):
        for tol_point in (0.0, 1e-12, 1e-6, 1.0):
            got = lines_in_turn(i, jraw, force, point, lines, tol_force, tol_point)
            assert (got is not None) == lines_in_turn_by_norms(i, jraw, force, point, lines, tol_force, tol_point)
            if got is not None:
                np.testing.assert_array_equal(got, np.where(i[0::2] < i[1::2], lines[0::2], lines[1::2]))


@pytest.mark.parametrize("dim", [2, 3])
def test_row_norms_are_numpys_norm_bit_for_bit(dim):
    """The LAMMPS reader's contact distances (a pass per column) against np.linalg.norm(axis=1), which they
    replaced: the same bits over the whole exponent range, with overflow to inf, zeros and nan."""
    from cgbound.readers.checks import row_norms, row_squares
    rng = np.random.default_rng(dim)
    v = rng.normal(size=(20_000, dim)) * 10.0 ** rng.integers(-300, 300, size=(20_000, 1)).astype(float)
    v[::97] = 0.0
    v[5, 0], v[7, -1] = np.nan, 1e308
    with np.errstate(over="ignore", invalid="ignore"):
        for got, expected in [(row_norms(v), np.linalg.norm(v, axis=1)), (row_squares(v), np.sum(v ** 2, axis=1))]:
            assert got.dtype == np.float64 and got.tobytes() == expected.tobytes()


@pytest.mark.parametrize("dim", [2, 3])
def test_particle_forces_are_the_snapshots_bit_for_bit(dim):
    """Snapshot.particle_forces' sums (np.bincount, also the LAMMPS reader's force-balance check) against their twin
    by np.add.at: particles in many contacts as i and as j, walls, fixed particles, a body force, forces over many
    magnitudes."""
    import cgbound as cg

    def add_at_twin(snap):
        f = np.zeros((snap.n_particles, snap.dim))
        c = snap.contacts
        np.add.at(f, c.i, c.force)
        pair = c.j >= 0
        np.add.at(f, c.j[pair], -c.force[pair])
        flow = snap.flowing
        f[flow] += snap.masses[flow, None] * snap.body_force[flow]
        return f
    rng = np.random.default_rng(dim)
    n, m = 300, 4000
    i = rng.integers(0, n, m)
    j = np.where(rng.random(m) < 0.1, -1, (i + rng.integers(1, n, m)) % n)
    keep = np.unique(np.stack([np.minimum(i, j), np.maximum(i, j)], axis=1), axis=0, return_index=True)[1]
    keep = np.union1d(keep, np.flatnonzero(j < 0))       # one listing per pair; every wall contact
    i, j = i[keep], j[keep]
    force = rng.normal(size=(len(i), dim)) * 10.0 ** rng.integers(-8, 8, size=(len(i), 1))
    pos = rng.normal(size=(n, dim))
    snap = cg.Snapshot(pos, masses=rng.uniform(0.5, 2.0, n), contacts=cg.Contacts(i, j, force, pos[i]),
                       fixed=rng.random(n) < 0.2, body_force=rng.normal(size=dim))
    assert np.bincount(i, minlength=n).max() > 5 and np.any(snap.fixed)
    assert snap.particle_forces().tobytes() == add_at_twin(snap).tobytes()
    pairs = j >= 0     # no walls, nothing fixed: the arrays taken whole
    snap = cg.Snapshot(pos, masses=snap.masses, contacts=cg.Contacts(i[pairs], j[pairs], force[pairs], pos[i[pairs]]),
                       body_force=snap.body_force[0])
    assert snap.particle_forces().tobytes() == add_at_twin(snap).tobytes()


def test_lammps_atoms_in_any_row_order_read_as_sorted_by_id(tmp_path):
    """A frame whose rows are sorted by ID (the columns copied) and the same frame in LAMMPS' order (gathered by
    the ID order) give the same frame, bit for bit: particles, walls, contacts, IDs and dumped forces."""
    import os
    from cgbound.readers import LammpsReader
    base = os.path.join(os.path.dirname(__file__), "data", "lammps", "hooke3d")
    out = []
    for part in open(os.path.join(base, "atoms.dump"), "rb").read().split(b"ITEM: TIMESTEP\n")[1:]:
        lines = part.rstrip(b"\n").split(b"\n")
        head = next(k for k, line in enumerate(lines) if line.startswith(b"ITEM: ATOMS")) + 1
        rows = sorted(lines[head:], key=lambda row: int(row.split()[0]))
        out.append(b"ITEM: TIMESTEP\n" + b"\n".join(lines[:head] + rows) + b"\n")
    sorted_dump = tmp_path / "atoms.dump"
    sorted_dump.write_bytes(b"".join(out))
    opts = dict(pair_values=("dist", "fx", "fy", "fz", "p1", "p2", "p3", "p4"), walls=["w"], fixed_types=[2],
                body_force=(0.0, 0.0, -1.0))
    a = LammpsReader(os.path.join(base, "atoms.dump"), os.path.join(base, "pairs.dump"), **opts)
    b = LammpsReader(sorted_dump, os.path.join(base, "pairs.dump"), **opts)
    assert len(a) == len(b) == 3
    for k in range(3):
        fa, fb = a.frame(k), b.frame(k)
        for x, y in [(fa.ids, fb.ids), (fa.types, fb.types), (fa.forces, fb.forces), (fa.contact_ids, fb.contact_ids),
                     (fa.overlap, fb.overlap)] + [(getattr(fa.snapshot, name), getattr(fb.snapshot, name)) for name in
                                                  ("positions", "velocities", "masses", "radii", "fixed", "species")] \
                + [(getattr(fa.snapshot.contacts, name), getattr(fb.snapshot.contacts, name))
                   for name in ("i", "j", "force", "point")]:
            assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes()
        assert np.any(fa.snapshot.contacts.j == -1) and not np.all(np.diff(a._atoms_dump.read(a._frames[k][0])["data"]
                                                                           .integers("id")) > 0)


def test_lammps_inactive_pair_rows_are_dropped_and_the_rest_kept_bit_for_bit(tmp_path):
    """drop_inactive: the rows of a dump local with no overlap and zero force (pairs within the force cutoff, not
    touching) are dropped; every other row (overlapping with zero force, or a force without overlap) is kept with
    the values read when nothing is dropped."""
    from cgbound.readers import LammpsReader
    ax = 0.5 + 0.99 * np.arange(3)
    pos = np.stack([g.ravel() for g in np.meshgrid(ax, ax, ax, indexing="ij")], axis=1)
    n = len(pos)
    rng = np.random.default_rng(3)
    rows = []
    for a in range(n):
        for b in range(a + 1, n):
            d = np.linalg.norm(pos[a] - pos[b])
            if d < 1.0:       # touching: a force, or none (kept for its overlap)
                f = rng.normal(size=3) if rng.random() < 0.8 else np.zeros(3)
            elif d < 2.0:     # within the cutoff, not touching: no force (dropped), or one (kept)
                f = np.zeros(3) if rng.random() < 0.8 else rng.normal(size=3)
            else:
                continue
            rows.append(f"{a + 1} {b + 1} {' '.join(repr(float(x)) for x in f)}\n")
    atoms, pairs = tmp_path / "a.dump", tmp_path / "p.dump"
    atoms.write_text(f"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n{n}\nITEM: BOX BOUNDS ff ff ff\n" + "0 3\n" * 3
                     + "ITEM: ATOMS id type x y z radius mass\n"
                     + "".join(f"{k + 1} 1 {' '.join(repr(float(x)) for x in pos[k])} 0.5 1\n" for k in range(n)))
    pairs.write_text(f"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ENTRIES\n{len(rows)}\nITEM: BOX BOUNDS ff ff ff\n"
                     + "0 3\n" * 3 + "ITEM: ENTRIES c_pp[1] c_pp[2] c_pl[1] c_pl[2] c_pl[3]\n" + "".join(rows))
    options = dict(pair_style="total", pair_values=("fx", "fy", "fz"), check_forces=False)
    every = LammpsReader(atoms, pairs, drop_inactive=False, **options).frame(0)
    active = LammpsReader(atoms, pairs, **options).frame(0)
    c = every.snapshot.contacts
    keep = (every.overlap > 0) | np.any(c.force != 0, axis=1)
    assert 0 < keep.sum() < len(keep) and np.any(every.overlap[keep] < 0) and np.any(np.all(c.force[keep] == 0, axis=1))
    for x, y in [(c.i[keep], active.snapshot.contacts.i), (c.j[keep], active.snapshot.contacts.j),
                 (c.force[keep], active.snapshot.contacts.force), (c.point[keep], active.snapshot.contacts.point),
                 (every.contact_ids[keep], active.contact_ids), (every.overlap[keep], active.overlap)]:
        assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes()
    np.testing.assert_array_equal(every.contact_ids, [[int(r.split()[0]), int(r.split()[1])] for r in rows])
