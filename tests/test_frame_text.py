"""Frames read again in any order and from threads give the frames read first (each frame's text goes through
cgbound.readers._text.read_range's buffer); a file cut after the reader scanned it is refused by name."""
import math
import pickle
import threading

import numpy as np
import pytest

import cgbound as cg
from cgbound.readers import LammpsReader, MercuryReader, write_mercury


def _lattice(n, seed, time):
    """A simple-cubic lattice of n^3 spheres (radius 0.5), every neighbour pair in contact."""
    rng = np.random.default_rng(seed)
    ax = 0.5 + 0.99 * np.arange(n)
    pos = np.stack([g.ravel() for g in np.meshgrid(ax, ax, ax, indexing="ij")], axis=1)
    idx = np.arange(n ** 3).reshape(n, n, n)
    i = np.concatenate([np.take(idx, range(n - 1), axis=a).ravel() for a in range(3)])
    j = np.concatenate([np.take(idx, range(1, n), axis=a).ravel() for a in range(3)])
    normal = (pos[i] - pos[j]) / 0.99
    force = normal * rng.uniform(0.9, 1.1, i.size)[:, None]
    box = cg.Box([0, 0, 0], [n, n, n])
    return cg.Snapshot(pos, rng.normal(size=pos.shape), np.ones(len(pos)), box=box, radii=np.full(len(pos), 0.5),
                       time=time, contacts=cg.Contacts(i, j, force, 0.5 * (pos[i] + pos[j])))


def test_mercury_frames_in_any_order_and_threads(tmp_path):
    # frames of different sizes, so that the buffers grow and shrink
    write_mercury([_lattice(6, 0, 0.0), _lattice(4, 1, 1.0), _lattice(7, 2, 2.0)], tmp_path / "m.data",
                  tmp_path / "m.fstat")
    args = (tmp_path / "m.data", tmp_path / "m.fstat")
    options = dict(restart_path=False, periodic=(False,) * 3,
                   density=1.0 / (4.0 / 3.0 * math.pi * 0.5 ** 3))
    expected = list(MercuryReader(*args, **options))
    assert [len(s.positions) for s in expected] == [216, 64, 343]
    reader = MercuryReader(*args, **options)
    got = [(k, reader[k]) for k in (1, 0, 2, 2, 0, 1)]
    lock = threading.Lock()

    def read(k):
        snap = reader[k]
        with lock:
            got.append((k, snap))

    for _ in range(3):
        threads = [threading.Thread(target=read, args=(k,)) for k in (2, 0, 1, 2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        reader._cache = None
    got += [(k, pickle.loads(pickle.dumps(reader))[k]) for k in (2, 1)]
    assert len(got) == 6 + 12 + 2
    for k, snap in got:
        np.testing.assert_array_equal(snap.positions, expected[k].positions)
        np.testing.assert_array_equal(snap.contacts.force, expected[k].contacts.force)
        np.testing.assert_array_equal(snap.contacts.i, expected[k].contacts.i)


def test_lammps_frames_in_any_order(tmp_path):
    atoms, pairs = tmp_path / "a.dump", tmp_path / "p.dump"
    with open(atoms, "w") as fa, open(pairs, "w") as fp:
        for ts, snap in enumerate([_lattice(5, 0, 0.0), _lattice(3, 1, 1.0), _lattice(6, 2, 2.0)]):
            n, c = len(snap.positions), snap.contacts
            fa.write(f"ITEM: TIMESTEP\n{ts}\nITEM: NUMBER OF ATOMS\n{n}\nITEM: BOX BOUNDS ff ff ff\n"
                     + "0 8\n" * 3 + "ITEM: ATOMS id type x y z vx vy vz radius mass\n")
            for k in range(n):
                fa.write(f"{k + 1} 1 {' '.join(repr(float(x)) for x in snap.positions[k])} "
                         f"{' '.join(repr(float(x)) for x in snap.velocities[k])} 0.5 1\n")
            fp.write(f"ITEM: TIMESTEP\n{ts}\nITEM: NUMBER OF ENTRIES\n{len(c.i)}\nITEM: BOX BOUNDS ff ff ff\n"
                     + "0 8\n" * 3 + "ITEM: ENTRIES c_pp[1] c_pp[2] c_pl[1] c_pl[2] c_pl[3]\n")
            for m in range(len(c.i)):
                fp.write(f"{c.i[m] + 1} {c.j[m] + 1} {' '.join(repr(float(x)) for x in c.force[m])}\n")
    options = dict(pair_style="total", pair_values=("fx", "fy", "fz"))
    expected = list(LammpsReader(atoms, pairs, **options))
    reader = LammpsReader(atoms, pairs, **options)
    for k in (1, 2, 0, 2, 1):
        snap = reader[k]
        np.testing.assert_array_equal(snap.positions, expected[k].positions)
        np.testing.assert_array_equal(snap.contacts.force, expected[k].contacts.force)
    assert [len(s.positions) for s in expected] == [125, 27, 216]


def test_a_file_cut_after_the_scan_is_refused_naming_it(tmp_path):
    write_mercury([_lattice(4, 0, 0.0), _lattice(4, 1, 1.0)], tmp_path / "m.data", tmp_path / "m.fstat")
    reader = MercuryReader(tmp_path / "m.data", tmp_path / "m.fstat", restart_path=False, periodic=(False,) * 3,
                           density=1.0)
    reader[0]
    for name in ("m.fstat", "m.data"):
        path = tmp_path / name
        text = path.read_bytes()
        path.write_bytes(text[:text.rindex(b"\n", 0, text.rindex(b"\n", 0, len(text) - 1)) + 1])  # 2 whole lines
        reader._cache = None
        with pytest.raises(ValueError, match=rf"{name}: the file changed since it was scanned .*open the reader again"):
            reader[1]


def _spare_full_of_rows(size=1 << 22):
    """A spare frame buffer (cgbound.readers._text) holding text that would parse: rows of 16 numbers."""
    from cgbound.readers import _text
    row = b" ".join([b"1"] * 16) + b"\n"
    buf = _text.frame_buffer(size)
    buf[:] = (row * (size // len(row) + 1))[:size]
    _text._spare[:] = [buf]
    return buf


def test_frames_read_into_a_spare_holding_other_text_are_the_same(tmp_path):
    """A frame's text goes into the spare buffer, longer than the frame and holding an earlier frame's text: only
    the frame's bytes are read, so the frames, and a file cut since the scan, read as with a new buffer."""
    from cgbound.readers import _text
    write_mercury([_lattice(4, 0, 0.0), _lattice(3, 1, 1.0)], tmp_path / "m.data", tmp_path / "m.fstat")
    options = dict(restart_path=False, periodic=(False,) * 3, density=1.0)
    _text._spare.clear()
    expected = list(MercuryReader(tmp_path / "m.data", tmp_path / "m.fstat", **options))
    reader = MercuryReader(tmp_path / "m.data", tmp_path / "m.fstat", **options)
    for k in (1, 0):
        spare = _spare_full_of_rows()
        snap = reader[k]
        assert _text._spare == [spare]      # used and kept again
        for name in ("positions", "velocities", "radii", "masses"):
            assert getattr(snap, name).tobytes() == getattr(expected[k], name).tobytes()
        for name in ("i", "j", "force", "point"):
            assert getattr(snap.contacts, name).tobytes() == getattr(expected[k].contacts, name).tobytes()
    text = (tmp_path / "m.fstat").read_bytes()
    (tmp_path / "m.fstat").write_bytes(text[:text.rindex(b"\n", 0, len(text) - 1) + 1])   # its last line lost
    reader._cache = None
    _spare_full_of_rows()
    with pytest.raises(ValueError, match=r"m\.fstat: the file changed since it was scanned"):
        reader[1]
    assert _text._spare == []     # a buffer an error left is not kept


def test_lammps_frames_read_into_a_spare_holding_other_text_are_the_same():
    import os
    from cgbound.readers import _text
    base = os.path.join(os.path.dirname(__file__), "data", "lammps", "hooke3d")
    options = dict(pair_values=("dist", "fx", "fy", "fz", "p1", "p2", "p3", "p4"), walls=["w"], fixed_types=[2],
                   body_force=(0.0, 0.0, -1.0))
    _text._spare.clear()
    expected = [LammpsReader(os.path.join(base, "atoms.dump"), os.path.join(base, "pairs.dump"), **options).frame(k)
                for k in range(3)]
    reader = LammpsReader(os.path.join(base, "atoms.dump"), os.path.join(base, "pairs.dump"), **options)
    for k in (2, 0, 1):
        _spare_full_of_rows()
        got = reader.frame(k)
        assert got.ids.tobytes() == expected[k].ids.tobytes()
        assert got.snapshot.positions.tobytes() == expected[k].snapshot.positions.tobytes()
        assert got.snapshot.contacts.force.tobytes() == expected[k].snapshot.contacts.force.tobytes()


def test_the_spare_is_given_back_when_the_last_reader_is_gone(tmp_path):
    """The spare frame buffer lives only as long as a reader that reads frames: a notebook that read a file and
    dropped its readers does not keep a frame's text."""
    import gc
    from cgbound.readers import _text
    write_mercury([_lattice(3, 0, 0.0), _lattice(3, 1, 1.0)], tmp_path / "m.data", tmp_path / "m.fstat")
    options = dict(restart_path=False, periodic=(False,) * 3, density=1.0)
    gc.collect()
    _text._spare.clear()
    first = MercuryReader(tmp_path / "m.data", tmp_path / "m.fstat", **options)
    second = MercuryReader(tmp_path / "m.data", tmp_path / "m.fstat", **options)
    first[0]
    assert len(_text._spare) == 1      # kept for the next frame
    del first
    gc.collect()
    assert len(_text._spare) == 1      # the second reader still lives
    second[1]
    del second
    gc.collect()
    assert _text._spare == []
    list(MercuryReader(tmp_path / "m.data", tmp_path / "m.fstat", **options))
    gc.collect()
    assert _text._spare == []          # a reader used and dropped in one expression keeps nothing either


# ---------------------------------------------------------------------------------------------------------------
# the tables' spare memory (parse_table(reuse=True))

def _spare_arrays():
    """The spare table blocks of cgbound.readers._text, as uint8 arrays (for np.shares_memory)."""
    from cgbound.readers import _text
    return [np.frombuffer(s.buf, np.uint8) for s in _text._spare_tables]


def _arrays_of(snap):
    arrays = [snap.positions, snap.velocities, snap.masses, snap.radii, snap.fixed, snap.species,
              snap.contacts.i, snap.contacts.j, snap.contacts.force, snap.contacts.point]
    return [a for a in arrays if a is not None]


def test_a_reused_table_is_the_new_tables_values_and_a_kept_view_is_never_overwritten(monkeypatch):
    """parse_table(reuse=True) gives the same bits as new tables (one pass, threads, blank lines skipped, a count
    declared); the memory is lent again once the tables are dropped, and not while a view of them lives."""
    import gc
    from cgbound.readers import _text
    small = _text.parse_table(b"1 2\n", ncols=2, reuse=True)
    assert small.values.base is None and small.ints.base is None   # under SPARE_TABLE_MIN: new arrays
    monkeypatch.setattr(_text, "SPARE_TABLE_MIN", 1)               # (the tables here are small)

    class Holder:
        pass

    holder = Holder()
    _text.hold_spare(holder)
    rng = np.random.default_rng(3)
    rows = 120_000     # ~5 MB of text: cut over 2 threads
    values = rng.normal(size=(rows, 5)) * 10.0 ** rng.integers(-5, 5, size=(rows, 5))
    ids = rng.integers(-2 ** 40, 2 ** 40, size=rows)
    text = "".join(f"{i} {a!r} {b!r} {c!r} {d!r} {e!r}\n" for i, (a, b, c, d, e) in zip(ids.tolist(), values.tolist()))
    data = text.encode()
    blanks = data.replace(b"\n", b"\n\n", 1000)
    for threads in (1, 2):
        for text_, options in ((data, dict(nrows=rows)), (blanks, dict(skip_blank=True)), (data, {})):
            new = _text.parse_table(text_, ncols=6, int_columns=(0,), threads=threads, **options)
            got = _text.parse_table(text_, ncols=6, int_columns=(0,), threads=threads, reuse=True, **options)
            assert got.values.tobytes() == new.values.tobytes() and got.ints.tobytes() == new.ints.tobytes()
            assert got.end == new.end and got.values.shape == (rows, 6) and got.ints.shape == (rows, 1)
            assert any(np.shares_memory(got.values, s) for s in _spare_arrays())
            del got
    first = _text.parse_table(data, ncols=6, int_columns=(0,), reuse=True)
    address = first.values.__array_interface__["data"][0]
    del first
    again = _text.parse_table(data, ncols=6, int_columns=(0,), reuse=True)
    assert again.values.__array_interface__["data"][0] == address     # dropped: its memory lent again
    kept, kept_ids = again.values[:, 1:3], again.ints[:, 0]
    del again
    cut = data.index(b"\n") + 1
    other = data[cut:] + data[:cut]    # the rows rotated: other values in each row
    later = _text.parse_table(other, ncols=6, int_columns=(0,), reuse=True)
    assert not np.shares_memory(later.values, kept)                     # a view lives: new memory
    assert kept.tobytes() == np.ascontiguousarray(new.values[:, 1:3]).tobytes()
    assert kept_ids.tobytes() == new.ints[:, 0].tobytes()
    assert later.values[0].tolist() != new.values[0].tolist()
    assert len(_text._spare_tables) <= _text.SPARE_TABLES
    # errors are the same with reuse (file, line, token)
    bad = data[:1000] + b"1 2 x 4 5 6\n" + data[1000:]
    with pytest.raises(ValueError) as a:
        _text.parse_table(bad, ncols=6, int_columns=(0,), name="f.dump", frame="timestep 3")
    with pytest.raises(ValueError) as b:
        _text.parse_table(bad, ncols=6, int_columns=(0,), name="f.dump", frame="timestep 3", reuse=True)
    assert str(a.value) == str(b.value) and "f.dump (timestep 3), line" in str(b.value)
    del a, b, kept, kept_ids, later, holder
    gc.collect()
    assert _text._spare_tables == []     # given back with the last holder


def test_reader_frames_do_not_view_the_reused_table_and_stay_as_read(tmp_path, monkeypatch):
    """The LAMMPS and MercuryDPM readers parse frame after frame into the same table memory: read frame 2, then
    frames 1 and 0 (no larger: the same memory reused), frame 2's arrays are unchanged, and no array of a frame
    views it."""
    import gc
    import os
    from cgbound.readers import _text
    monkeypatch.setattr(_text, "SPARE_TABLE_MIN", 1)   # (the tables here are small)
    gc.collect()
    base = os.path.join(os.path.dirname(__file__), "data", "lammps", "hooke3d")
    options = dict(pair_values=("dist", "fx", "fy", "fz", "p1", "p2", "p3", "p4"), walls=["w"], fixed_types=[2],
                   body_force=(0.0, 0.0, -1.0))
    write_mercury([_lattice(5, 0, 0.0), _lattice(5, 1, 1.0), _lattice(5, 2, 2.0)], tmp_path / "m.data",
                  tmp_path / "m.fstat")
    for make in (lambda: LammpsReader(os.path.join(base, "atoms.dump"), os.path.join(base, "pairs.dump"),
                                      **options),
                 lambda: MercuryReader(tmp_path / "m.data", tmp_path / "m.fstat", restart_path=False,
                                       periodic=(False,) * 3, density=1.0)):
        _text._spare_tables.clear()
        reader = make()
        first = reader[2]
        copies = [a.copy() for a in _arrays_of(first)]
        blocks = []
        for k in (1, 0):
            reader._cache = None
            snap = reader[k]
            assert _text._spare_tables, "a table was parsed into spare memory"
            blocks.append([s.buf for s in _text._spare_tables])
            for a in _arrays_of(first) + _arrays_of(snap):
                assert not any(np.shares_memory(a, s) for s in _spare_arrays())
        assert all(any(b is c for c in blocks[0]) for b in blocks[1])   # frame 0's tables in frame 1's memory
        for a, c in zip(_arrays_of(first), copies):
            assert a.tobytes() == c.tobytes()
        del reader, first, snap
        gc.collect()
        assert _text._spare_tables == []


def test_the_binding_takes_the_tables_memory_from_out():
    """text_parse_table's out(nbytes): the tables as views of the buffer it returns (values, then ints from a
    64-byte boundary), new arrays for None, an error for a buffer too small or not writable."""
    from cgbound import _engine
    asked = []

    def out(nbytes):
        asked.append(nbytes)
        return block

    block = np.zeros(200, np.uint8)
    values, ints, found, *_ = _engine.text_parse_table(b"1 2.5\n3 4.5\n", 0, 12, 2, b"\1\0", -1, 0, 1, 0, out)
    assert asked == [64 + 2 * 8] and found == 2     # values: 2 x 2 doubles, ints from byte 64
    assert np.shares_memory(values, block) and np.shares_memory(ints, block)
    assert values.tolist() == [[1.0, 2.5], [3.0, 4.5]] and ints.tolist() == [[1], [3]]
    assert block[:32].view(np.float64).tolist() == [1.0, 2.5, 3.0, 4.5]
    assert block[64:80].view(np.int64).tolist() == [1, 3]
    values, ints, *_ = _engine.text_parse_table(b"1 2.5\n", 0, 6, 2, b"\1\0", -1, 0, 1, 0, lambda n: None)
    assert values.base is None and values.tolist() == [[1.0, 2.5]]
    for bad, kind, says in ((np.zeros(10, np.uint8), ValueError, "at least 72 bytes aligned to 8 bytes, got 10 bytes"),
                            (np.zeros(200, np.uint8)[1:], ValueError, "mod 8"),
                            (b"x" * 200, TypeError, "writable contiguous buffer, got bytes"),
                            (np.zeros(400, np.uint8)[::2], TypeError, "got numpy.ndarray")):
        with pytest.raises(kind, match="^out: expected") as info:
            _engine.text_parse_table(b"1 2.5\n", 0, 6, 2, b"\1\0", -1, 0, 1, 0, lambda n, bad=bad: bad)
        assert says in str(info.value)

    def failing(nbytes):
        raise RuntimeError("no memory for you")
    with pytest.raises(RuntimeError, match="no memory for you"):
        _engine.text_parse_table(b"1 2.5\n", 0, 6, 2, b"\1\0", -1, 0, 1, 0, failing)


def test_the_tables_hold_the_export_of_outs_buffer():
    """While the tables live, out()'s buffer can neither move (a bytearray's resize) nor be released (a
    memoryview), and their base is not a buffer that views could be made of behind the lending's back."""
    import gc
    from cgbound import _engine
    grown = bytearray(200)
    values, ints, *_ = _engine.text_parse_table(b"1 2.5\n3 4.5\n", 0, 12, 2, b"\1\0", -1, 0, 1, 0, lambda n: grown)
    with pytest.raises(BufferError):
        grown.extend(bytes(10_000_000))
    assert values.tolist() == [[1.0, 2.5], [3.0, 4.5]] and ints.tolist() == [[1], [3]]
    with pytest.raises(TypeError):
        memoryview(values.base)
    kept = values[1:]
    del values, ints
    gc.collect()
    with pytest.raises(BufferError):            # a view of the tables still holds the export
        grown.extend(b"x")
    assert kept.tolist() == [[3.0, 4.5]]
    del kept
    gc.collect()
    grown.extend(b"x")                          # the last view gone: the export with it
    lent = memoryview(bytearray(200))
    tables = _engine.text_parse_table(b"1 2.5\n", 0, 6, 2, b"\1\0", -1, 0, 1, 0, lambda n: lent)
    with pytest.raises(BufferError):
        lent.release()
    del tables
    gc.collect()
    lent.release()


def test_a_reader_freed_by_the_collector_during_a_lease_does_not_hang(monkeypatch):
    """A reader in a reference cycle is freed by the cyclic collector, which may run at any allocation, also inside
    the spare's locked blocks: its finalizer (_release_spare) takes the same lock on the same thread."""
    import gc
    from cgbound.readers import _text
    monkeypatch.setattr(_text, "SPARE_TABLE_MIN", 1)

    class Holder:
        pass

    keep = Holder()
    _text.hold_spare(keep)
    data = b"".join(b"%d 1.5 2.5\n" % k for k in range(2000))
    done = []

    def work():
        thresholds = gc.get_threshold()
        gc.set_threshold(1)
        try:
            for _ in range(300):
                cycle = Holder()
                cycle.self = cycle
                _text.hold_spare(cycle)
                del cycle                       # freed by the collector only
                table = _text.parse_table(data, ncols=3, int_columns=(0,), reuse=True)
                assert table.ints[-1, 0] == 1999
                del table
        finally:
            gc.set_threshold(*thresholds)
        done.append(True)

    worker = threading.Thread(target=work, daemon=True)
    worker.start()
    worker.join(120)
    assert done, "the lease and a finalizer deadlocked on the spare's lock"
    del keep
    gc.collect()
