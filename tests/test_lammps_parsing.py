"""The LAMMPS/LIGGGHTS dump parsing (readers/_lammps_dump.py on the C text layer) against np.loadtxt
and float(): every genuine dump in tests/data, plain and gzipped, bit for bit; adversarial text; and
every structural corruption an error naming the file, the timestep and the 1-based line."""
import glob
import gzip
import os
import pickle
import re
import shutil

import numpy as np
import pytest

from cgbound.readers import LammpsReader, LiggghtsReader
from cgbound.readers._lammps_dump import scan_dump

DATA = os.path.join(os.path.dirname(__file__), "data")
GENUINE = sorted(glob.glob(os.path.join(DATA, "lammps", "*", "*.dump"))
                 + glob.glob(os.path.join(DATA, "liggghts", "*.dump"))
                 + glob.glob(os.path.join(DATA, "lammps_input", "*.dump")))
GRAN_VALUES = ("dist", "fx", "fy", "fz", "p1", "p2", "p3", "p4")


def kind_of(path):
    return "local" if "pairs" in os.path.basename(path) else "atoms"


def gzipped(path, tmp_path):
    out = tmp_path / (os.path.basename(path) + ".gz")
    with open(path, "rb") as a, gzip.open(out, "wb") as b:
        shutil.copyfileobj(a, b)
    return str(out)


def loadtxt_frames(path):
    """Independent twin: split the file at 'ITEM: TIMESTEP' lines in Python, np.loadtxt the rows."""
    text = open(path, "rb").read().decode()
    frames = []
    for part in text.split("ITEM: TIMESTEP\n")[1:]:
        lines = part.splitlines()
        header = next(k for k, line in enumerate(lines) if line.startswith(("ITEM: ATOMS", "ITEM: ENTRIES")))
        n = int(lines[lines.index(next(x for x in lines if x.startswith("ITEM: NUMBER OF"))) + 1])
        rows = lines[header + 1:header + 1 + n]
        columns = lines[header].split()[2:]
        values = np.loadtxt(rows, ndmin=2) if n else np.zeros((0, len(columns)))
        frames.append((int(lines[0]), columns, values))
    return frames


def same_bits(a, b):
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("path", GENUINE, ids=lambda p: os.path.relpath(p, DATA))
@pytest.mark.parametrize("compressed", [False, True], ids=["plain", "gzip"])
def test_genuine_dumps_match_loadtxt_bit_for_bit(path, compressed, tmp_path):
    source = gzipped(path, tmp_path) if compressed else path
    index = scan_dump(source, kind_of(path))
    expected = loadtxt_frames(path)
    assert [ts for _, ts in index] == [ts for ts, _, _ in expected]
    for (offset, _), (ts, columns, values) in zip(index, expected):
        frame = index.read(offset)
        assert frame["timestep"] == ts and frame["columns"] == columns and frame["n"] == len(values)
        assert same_bits(frame["data"].values, values)
        for name in ("id", "type"):
            if name in columns:
                as_int = frame["data"].integers(name)
                assert as_int.dtype == np.int64
                assert np.array_equal(as_int, values[:, columns.index(name)].astype(np.int64))


def has_atom_id_columns(path):
    """A dump local with compute property/local patom1 patom2 (c_pp[1], c_pp[2])."""
    with open(path, "rb") as f:
        return kind_of(path) == "local" and b" c_pp[1] c_pp[2]" in f.read(1 << 16)


@pytest.mark.parametrize("path", [p for p in GENUINE if has_atom_id_columns(p)], ids=lambda p: os.path.relpath(p, DATA))
def test_contact_ids_of_genuine_dumps_match_loadtxt(path):
    """The atom-ID columns of a dump local, read as whole numbers (as int64 in the parse when written as
    integers), against np.loadtxt's floats; the float values of the table bit for bit as well."""
    index = scan_dump(path, "local")
    for (offset, _), (ts, columns, values) in zip(index, loadtxt_frames(path)):
        ids = ["c_pp[1]", "c_pp[2]"]
        frame = index.read(offset, (), ids)
        assert same_bits(frame["data"].values, values)
        for name in ids:
            got = frame["data"].integers(name)
            assert got.dtype == np.int64
            assert np.array_equal(got, values[:, columns.index(name)].astype(np.int64))
            assert np.array_equal(got.astype(float), values[:, columns.index(name)])


def test_gzipped_dumps_read_as_the_plain_ones(tmp_path):
    base = os.path.join(DATA, "lammps", "hooke3d")
    opts = dict(pair_values=GRAN_VALUES, walls=["w"], fixed_types=[2], body_force=(0, 0, -1.0))
    plain = LammpsReader(os.path.join(base, "atoms.dump"), os.path.join(base, "pairs.dump"), **opts)
    packed = LammpsReader(gzipped(os.path.join(base, "atoms.dump"), tmp_path),
                          gzipped(os.path.join(base, "pairs.dump"), tmp_path), **opts)
    again = pickle.loads(pickle.dumps(packed))  # gzip checkpoints are rebuilt after unpickling
    assert len(plain) == len(packed) == len(again) == 3
    for k in (2, 0, 1):  # out of order: each frame resumes at a checkpoint
        for other in (packed, again):
            a, b = plain[k], other[k]
            assert same_bits(a.positions, b.positions) and same_bits(a.velocities, b.velocities)
            assert same_bits(a.contacts.force, b.contacts.force) and same_bits(a.contacts.point, b.contacts.point)
            assert np.array_equal(plain.frame(k).ids, other.frame(k).ids)


def test_liggghts_ids_are_read_as_integers():
    base = os.path.join(DATA, "liggghts")
    values = ("pos", "id", "force", "torque", "delta", "contactPoint")  # as in tests/data/liggghts/in.settle
    r = LiggghtsReader(os.path.join(base, "atoms.dump"), os.path.join(base, "pairs.dump"), pair_values=values,
                       fixed_types=[2], body_force=(0, 0, -9.81))
    frame = r.frame(0)
    expected = loadtxt_frames(os.path.join(base, "pairs.dump"))[0][2][:, 6:8].astype(np.int64)
    assert frame.contact_ids.dtype == np.int64 and np.array_equal(frame.contact_ids, expected)


# --- adversarial text: every value as float() reads it, bit for bit ------------------------------------

COLUMNS = ["id", "type", "x", "y", "z"]


def dump_text(rows, steps=(0,), count=None, newline="\n", header_extra=""):
    out = []
    for step in steps:
        out += ["ITEM: TIMESTEP", str(step), "ITEM: NUMBER OF ATOMS", str(len(rows) if count is None else count),
                "ITEM: BOX BOUNDS pp pp ff", "0 10", "0 10", "0 10" + header_extra, "ITEM: ATOMS " + " ".join(COLUMNS)]
        out += rows
    return newline.join(out) + newline


def write(tmp_path, text, name="atoms.dump"):
    path = tmp_path / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return str(path)


def expected_values(rows):
    return np.array([[float(w) for w in row.split()] for row in rows])


ODD_VALUES = ["1e+05", "-0", "-0.0", "4.9406564584124654e-324", "2.2250738585072009e-308", "0.10000000000000001",
              "1.7976931348623157e+308", "+3.5", ".5", "5.", "1E-05", "123456789012345678", "2.2250738585072011e-308"]


@pytest.mark.parametrize("layout", ["spaces", "tabs", "crlf", "padded", "long line"])
def test_adversarial_layouts_read_as_float_reads_them(layout, tmp_path):
    rows = [f"{k + 1} 1 {ODD_VALUES[k % len(ODD_VALUES)]} {ODD_VALUES[(k + 3) % len(ODD_VALUES)]} "
            f"{ODD_VALUES[(k + 7) % len(ODD_VALUES)]}" for k in range(len(ODD_VALUES))]
    newline = "\n"
    shown = rows
    if layout == "tabs":
        shown = [r.replace(" ", "\t") for r in rows]
    elif layout == "spaces":
        shown = ["  " + r.replace(" ", "   ") + "  " for r in rows]
    elif layout == "padded":
        shown = [" \t" + r.replace(" ", " \t ") + " \t\v\f" for r in rows]
    elif layout == "crlf":
        newline = "\r\n"
    elif layout == "long line":
        shown = [r.replace(" ", " " * 5000) for r in rows]
    text = dump_text(shown, steps=(0, 10), newline=newline)
    index = scan_dump(write(tmp_path, text), "atoms")
    assert [ts for _, ts in index] == [0, 10]
    want = expected_values(rows)
    for offset, _ in index:
        got = index.read(offset)["data"]
        assert same_bits(got.values, want)  # -0 keeps its sign, subnormals and 17-digit values exact
        assert np.array_equal(got.integers("id"), np.arange(1, len(rows) + 1))


def test_a_missing_final_newline_is_a_truncated_file(tmp_path):
    """LAMMPS ends every line: a last line without its line end was cut, even when its values still parse
    ('2.5' cut to '2.'), so the reader refuses it rather than read a wrong last value."""
    text = dump_text(GOOD, steps=(0, 100))
    path = write(tmp_path, text[:-1])
    message = error_of(path, read=False)
    assert_names(message, path, 100, 24)
    assert "truncated" in message and "line end" in message
    assert scan_dump(write(tmp_path, text, "whole.dump"), "atoms").frames[-1][1] == 100


def test_blank_lines_between_frames_are_allowed(tmp_path):
    rows = ["1 1 0.5 0.5 0.5", "2 1 1.5 1.5 1.5"]
    one = dump_text(rows, steps=(0,))
    index = scan_dump(write(tmp_path, "\n\n" + one + "\n  \n" + one.replace("\n0\n", "\n5\n", 1) + "\n\n"), "atoms")
    assert [ts for _, ts in index] == [0, 5]
    for offset, _ in index:
        assert same_bits(index.read(offset)["data"].values, expected_values(rows))


# --- corruption: an error naming the file, the timestep and the line ---------------------------------

GOOD = ["1 1 0.5 0.5 0.5", "2 2 1.5 1.5 1.5", "3 1 2.5 2.5 2.5"]
# in dump_text, frame k (0-based, 12 lines each) has its rows at lines 12 k + 10 .. 12 k + 12


def error_of(path, read=True):
    with pytest.raises(ValueError) as info:
        r = LammpsReader(path, masses={1: 1.0, 2: 1.0})
        if read:
            for k in range(len(r)):
                r[k]
    return str(info.value)


def assert_names(message, path, timestep, line):
    assert path in message, message
    assert f"timestep {timestep}" in message, message
    assert re.search(rf"\bline {line}\b", message), message
    for leak in ("UnicodeDecodeError", "KeyError", "could not convert", "numpy"):
        assert leak not in message


@pytest.mark.parametrize("bad, column, line", [
    ("2 nan 1.5 1.5 1.5", "type", 23), ("2 1.5 1.5 1.5 1.5", "type", 23), ("2.5 1 1.5 1.5 1.5", "id", 23),
    ("nan 1 1.5 1.5 1.5", "id", 23), ("2 1e3 1.5 1.5 1.5", "type", 23), ("2 1 1.5 nan 1.5", "y", 23),
    ("2 1 1.5 inf 1.5", "y", 23), ("2 1 1.5 1.5 abc", "z", 23), ("2 1 1.5 1.5 1\x005", "z", 23),
    ("2 1 1.5 1.5 1.5é", "z", 23), ("2 99999999999999999999 1.5 1.5 1.5", "type", 23),
])
def test_bad_values_name_the_column(bad, column, line, tmp_path):
    text = dump_text(GOOD, steps=(0, 100)).splitlines()
    text[line - 1] = bad
    path = write(tmp_path, "\n".join(text) + "\n")
    message = error_of(path)
    assert_names(message, path, 100, line)
    assert f"'{column}'" in message


@pytest.mark.parametrize("cut", [1, 2, 5, 12, 20, 40])
def test_a_truncated_file_is_an_error_when_the_reader_is_made(cut, tmp_path):
    text = dump_text(GOOD, steps=(0, 100)).encode()
    path = write(tmp_path, text[:len(text) - cut])
    message = error_of(path, read=False)
    assert "truncated" in message
    assert path in message and "timestep 100" in message


def test_a_shortened_or_lengthened_frame_is_an_error(tmp_path):
    lines = dump_text(GOOD, steps=(0, 100, 200)).splitlines()
    del lines[12 + 10]  # a row of the frame at timestep 100 lost
    path = write(tmp_path, "\n".join(lines) + "\n")
    message = error_of(path, read=False)
    assert_names(message, path, 100, 12 + 11)
    assert "expected 3 rows" in message and "found 2" in message
    lines = dump_text(GOOD, steps=(0, 100)).splitlines()
    lines.insert(12 + 12, "4 1 3.5 3.5 3.5")
    path = write(tmp_path, "\n".join(lines) + "\n", "longer.dump")
    message = error_of(path, read=False)
    assert_names(message, path, 100, 12 + 13)
    assert "found 4" in message


@pytest.mark.parametrize("bad, line", [("2 1 1.5 1.5", 23), ("2 1 1.5 1.5 1.5 7", 23), ("", 23)])
def test_rows_of_the_wrong_length_are_errors(bad, line, tmp_path):
    text = dump_text(GOOD, steps=(0, 100)).splitlines()
    text[line - 1] = bad
    path = write(tmp_path, "\n".join(text) + "\n")
    message = error_of(path)
    assert_names(message, path, 100, line)
    assert "expected 5 values" in message


@pytest.mark.parametrize("line, bad, says", [
    (14, "abc", "timestep (one integer)"), (14, "100 5", "timestep (one integer)"),
    (16, "three", "number of rows"), (16, "-3", "number of rows"),
    (17, "ITEM: BOX BOUNDS pp pp", "three boundary flags"), (19, "0", "y bounds"), (19, "0 nan", "y bounds"),
    (15, "ITEM: NUMBER OF ATOMS 3", "expected the line 'ITEM: NUMBER OF ATOMS'"),
    (21, "garbage", "expected 'ITEM: ATOMS|ITEM: ..."),
])
def test_damaged_headers_are_errors(line, bad, says, tmp_path):
    text = dump_text(GOOD, steps=(0, 100)).splitlines()
    text[line - 1] = bad
    path = write(tmp_path, "\n".join(text) + "\n")
    message = error_of(path, read=False)
    assert path in message
    if line > 14:
        assert "timestep 100" in message
    if "|" not in says:
        assert says in message, message


def test_duplicate_columns_are_errors(tmp_path):
    text = dump_text(GOOD).replace("ITEM: ATOMS id type x y z", "ITEM: ATOMS id type x x z")
    message = error_of(write(tmp_path, text), read=False)
    assert "appear twice" in message and "line 9" in message


@pytest.mark.parametrize("content", [b"", b"   \n\t\n", b"\n"])
@pytest.mark.parametrize("compressed", [False, True])
def test_an_empty_file_is_an_error(content, compressed, tmp_path):
    path = write(tmp_path, gzip.compress(content) if compressed else content)
    message = error_of(path, read=False)
    assert path in message and ("empty" in message or "blank" in message)


def test_not_a_dump_and_non_ascii_headers_are_value_errors(tmp_path):
    path = write(tmp_path, b"\xff\xfe garbage\nITEM: TIMESTEP\n0\n")
    assert path in error_of(path, read=False)
    text = dump_text(GOOD).encode().replace(b"ITEM: NUMBER OF ATOMS", b"ITEM: NUMB\xe9R OF ATOMS")
    path = write(tmp_path, text, "latin.dump")
    assert path in error_of(path, read=False)


def test_a_truncated_gzip_file_is_an_error(tmp_path):
    packed = gzip.compress(dump_text(GOOD * 200, steps=(0, 100)).encode())
    path = write(tmp_path, packed[:len(packed) // 2], "cut.dump.gz")
    message = error_of(path, read=False)
    assert path in message and ("truncated" in message or "ends early" in message)


def test_gzip_ranges_resume_at_checkpoints(tmp_path):
    """Two gzip members, checkpoints every 8 kB: any byte range read by resuming equals the plain text."""
    from cgbound.readers import _text
    rows = [f"{k} 1 {k * 0.1!r} {k * 1e-7!r} 3.5" for k in range(1, 3001)]
    text = dump_text(rows, steps=range(0, 1000, 100)).encode()
    half = len(text) // 2
    path = write(tmp_path, gzip.compress(text[:half]) + gzip.compress(text[half:]), "multi.dump.gz")
    checkpoints = []
    assert b"".join(_text.iter_chunks(path, chunk_size=4096, checkpoints=checkpoints, spacing=8192)) == text
    assert len(checkpoints) > 20
    rng = np.random.default_rng(1)
    for a in [0, half - 3, half, len(text) - 10, *rng.integers(0, len(text), 20).tolist()]:
        b = min(len(text), a + int(rng.integers(1, 50000)))
        assert bytes(_text.read_range(path, a, b, checkpoints)) == text[a:b]
    plain, packed = scan_dump(write(tmp_path, text, "multi.dump"), "atoms"), scan_dump(path, "atoms")
    assert list(plain) == list(packed) and len(plain) == 10
    for offset, _ in packed:
        assert same_bits(plain.read(offset)["data"].values, packed.read(offset)["data"].values)


def test_paths_that_are_not_files_are_os_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="nowhere.dump: no such file"):
        LammpsReader(str(tmp_path / "nowhere.dump"))
    with pytest.raises(IsADirectoryError, match="a directory"):
        LammpsReader(str(tmp_path))


def test_text_columns_are_read_apart(tmp_path):
    global COLUMNS
    saved, COLUMNS = COLUMNS, ["id", "type", "element", "x", "y", "z"]
    try:
        rows = ["1 1 Si 0.5 0.25 1e-3", "2 2 O 1.5 -0 7"]
        index = scan_dump(write(tmp_path, dump_text(rows)), "atoms")
        table = index.read(index.frames[0][0])["data"]
        assert same_bits(table["z"], np.array([1e-3, 7.0])) and same_bits(table["y"], np.array([0.25, -0.0]))
        assert np.array_equal(table.integers("type"), [1, 2])
        bad = write(tmp_path, dump_text(["1 1 Si 0.5 0.25 1e-3", "2 x O 1.5 -0 7"]), "bad.dump")
        with pytest.raises(ValueError, match=r"bad.dump \(timestep 0\), line 11, column 1 \('type'\)"):
            scan_dump(bad, "atoms").read(0)
    finally:
        COLUMNS = saved


def corruptions(text, rng, count, id_columns):
    """Damaged copies of a dump: truncations, bytes replaced by a non-digit, lines deleted or repeated,
    values replaced by text, nan/inf/overflow or (in the ID columns, the first id_columns) a fraction.
    (A digit turned into another digit, or a number into another number, is still a valid dump.)"""
    lines = text.split(b"\n")
    for _ in range(count):
        kind = rng.integers(5)
        if kind == 0:
            yield bytes(text[:int(rng.integers(0, len(text)))])
        elif kind == 1:
            b = bytearray(text)
            b[int(rng.integers(len(b)))] = int(rng.choice([c for c in range(256) if not 48 <= c <= 57]))
            yield bytes(b)
        elif kind == 2:
            k = int(rng.integers(len(lines) - 1))
            yield b"\n".join(lines[:k] + lines[k + 1:])
        elif kind == 3:
            k = int(rng.integers(len(lines) - 1))
            yield b"\n".join(lines[:k + 1] + lines[k:])
        else:
            k = int(rng.integers(len(lines) - 1))
            words = lines[k].split(b" ")
            at = int(rng.integers(len(words)))
            words[at] = [b"nan", b"inf", b"x", b"", b"1e999"][int(rng.integers(5))] if at >= id_columns else b"1.5"
            yield b"\n".join(lines[:k] + [b" ".join(words)] + lines[k + 1:])


@pytest.mark.parametrize("name", ["atoms.dump", "pairs.dump"])
def test_corrupted_dumps_read_the_same_or_fail_naming_the_file(name, tmp_path):
    """A small corruption fuzz: every damaged copy reads exactly as the original (the damage did not
    matter, e.g. a duplicated blank) or raises a ValueError naming the file; never another exception."""
    source = os.path.join(DATA, "lammps", "hooke3d", name)
    text = open(source, "rb").read()
    kind = kind_of(source)
    ints, ids = ("index",), ("c_pp[1]", "c_pp[2]")  # as LammpsReader reads them
    original = scan_dump(source, kind)
    want = [original.read(offset, ints, ids)["data"].values for offset, _ in original]
    rng = np.random.default_rng(15)
    outcomes = {"same": 0, "error": 0}
    for k, damaged in enumerate(corruptions(text, rng, 150, 2 if kind == "atoms" else 3)):
        path = write(tmp_path, damaged, f"c{k}.dump")
        try:
            index = scan_dump(path, kind)
            got = [index.read(offset, ints, ids)["data"].values for offset, _ in index]
        except ValueError as exc:
            assert path in str(exc), str(exc)
            outcomes["error"] += 1
            continue
        assert len(got) == len(want) and all(same_bits(a, b) for a, b in zip(got, want))
        outcomes["same"] += 1
    assert outcomes["error"] > 100


@pytest.mark.parametrize("written, ok", [("15", True), ("15.000000", True), ("1.5e+01", True), ("15.5", False),
                                          ("9007199254740993", False), ("-9007199254740993", False),
                                          ("-9223372036854775808", False)])
def test_contact_ids_are_whole_numbers_in_any_float_format(written, ok, tmp_path):
    """The atom IDs of a dump local come from double-valued computes and follow the float format."""
    base = os.path.join(DATA, "lammps", "hooke3d")
    lines = open(os.path.join(base, "pairs.dump")).read().split("\n")
    row = lines[9].split()
    other = row[2]
    row[2] = written if written != "15" else other
    lines[9] = " ".join(row)
    path = write(tmp_path, "\n".join(lines), "pairs.dump")
    index = scan_dump(path, "local")
    if ok:
        table = index.read(0, ("index",), ("c_pp[1]", "c_pp[2]"))["data"]
        assert table.integers("c_pp[2]")[0] == (15 if written != "15" else int(other))
        assert table.integers("c_pp[2]").dtype == np.int64
    else:
        with pytest.raises(ValueError, match=r"pairs.dump \(timestep 4500\), line 10, column 3 \('c_pp\[2\]'\): "
                                             r"expected an atom ID"):
            index.read(0, ("index",), ("c_pp[1]", "c_pp[2]"))


def test_a_file_changed_after_the_scan_is_an_error_when_read(tmp_path):
    text = dump_text(GOOD, steps=(0, 100))
    path = write(tmp_path, text)
    index = scan_dump(path, "atoms")
    write(tmp_path, text[:-16])  # the last row gone
    with pytest.raises(ValueError, match=r"changed since it was scanned"):
        index.read(index.frames[1][0])
    lines = text.split("\n")
    lines[22] = " " * len(lines[22])  # same length, a row blanked
    write(tmp_path, "\n".join(lines))
    with pytest.raises(ValueError, match=r"atoms.dump \(timestep 100\), line 23: expected 5 values, found no values"):
        index.read(index.frames[1][0])
