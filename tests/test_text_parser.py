"""The C text layer (csrc/cg_text.c) through cgbound.readers._text, against np.loadtxt and float().

Values must be identical bit for bit (compared as int64 bit patterns, so -0.0 != 0.0 and every
rounding counts); errors must name the file, the frame and the 1-based line, and quote the token.
"""
import gzip
import math
import mmap
import pathlib
import random
import re
import struct
import zlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cgbound.readers import _text

DATA = pathlib.Path(__file__).parent / "data"
DUMPS = sorted(p for p in (DATA / "lammps").glob("*/*.dump")) + sorted((DATA / "liggghts").glob("*.dump"))


def bits(a):
    """Bit patterns of a float64 array (so the comparison is exact, signed zeros and all)."""
    return np.ascontiguousarray(a, dtype=np.float64).view(np.int64)


def assert_bitwise(got, expected):
    assert got.shape == expected.shape
    np.testing.assert_array_equal(bits(got), bits(expected))


def loadtxt(text, ncols):
    return np.loadtxt(text.decode().splitlines(), dtype=np.float64, ndmin=2).reshape(-1, ncols)


def parse(text, ncols, **kw):
    return _text.parse_table(text, ncols=ncols, **kw).values


def float_bits(x):
    return struct.unpack("<q", struct.pack("<d", x))[0]


# ------------------------------------------------------------------------------------------------
# the power-of-ten table of the Eisel-Lemire path, regenerated independently

def test_pow10_table_is_the_rounded_down_128_bit_mantissas():
    src = (pathlib.Path(__file__).parent.parent / "csrc" / "cg_text_pow10.h").read_text()
    entries = re.findall(r"\{0x([0-9A-F]{16})ULL, 0x([0-9A-F]{16})ULL\}, /\* 1e(-?\d+) \*/", src)
    assert [int(e) for _, _, e in entries] == list(range(-348, 348))
    for lo, hi, e in entries:
        e = int(e)
        m = (int(hi, 16) << 64) | int(lo, 16)
        # 10^e = m * 2^k * (1 + r), 0 <= r < 2^-127: m is the floor of the normalised mantissa
        from fractions import Fraction
        exact = Fraction(10) ** e
        k = exact.numerator.bit_length() - exact.denominator.bit_length() - 128
        scaled = exact / Fraction(2) ** k
        while scaled >= 2 ** 128:
            scaled /= 2
        while scaled < 2 ** 127:
            scaled *= 2
        assert m == math.floor(scaled), e


# ------------------------------------------------------------------------------------------------
# genuine dumps: every frame's rows, against np.loadtxt

def lammps_frames(raw):
    """(timestep, count, columns, start, stop) of each frame, found by a pure-Python twin of the scan."""
    lines = raw.split(b"\n")
    starts = np.cumsum([0] + [len(x) + 1 for x in lines])
    out = []
    for i, line in enumerate(lines):
        if line.startswith(b"ITEM: TIMESTEP"):
            timestep = int(lines[i + 1])
            count = int(lines[i + 3])
            k = i + 4
            while not (lines[k].startswith(b"ITEM: ATOMS") or lines[k].startswith(b"ITEM: ENTRIES")):
                k += 1
            ncols = len(lines[k].split()) - 2
            out.append((timestep, count, ncols, int(starts[k + 1]), int(min(starts[k + 1 + count], len(raw)))))
    return out


@pytest.mark.parametrize("path", DUMPS, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_genuine_dumps_bitwise_equal_to_loadtxt(path):
    raw = path.read_bytes()
    frames = lammps_frames(raw)
    assert frames
    offsets = _text.find_lines(raw, b"ITEM: TIMESTEP")
    twin = [m.start() for m in re.finditer(rb"(?m)^ITEM: TIMESTEP", raw)]
    np.testing.assert_array_equal(offsets, twin)
    assert offsets.dtype == np.int64
    for timestep, count, ncols, start, stop in frames:
        table = _text.parse_table(raw, start, stop, ncols, nrows=count, name=path.name, frame=f"timestep {timestep}")
        expected = loadtxt(raw[start:stop], ncols) if count else np.zeros((0, ncols))
        assert_bitwise(table.values, expected)


def test_genuine_dump_integer_columns_and_mmap(tmp_path):
    path = DATA / "lammps" / "hooke3d" / "atoms.dump"
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as mm:
        (timestep, count, ncols, start, stop), *_ = lammps_frames(bytes(mm))
        table = _text.parse_table(mm, start, stop, ncols, int_columns=(0, 1), nrows=count)
        expected = loadtxt(bytes(mm[start:stop]), ncols)
        assert_bitwise(table.values, expected)
        np.testing.assert_array_equal(table.ints, expected[:, :2].astype(np.int64))
        assert table.ints.dtype == np.int64
        view = memoryview(mm)
        try:
            assert_bitwise(_text.parse_table(view[start:stop], ncols=ncols).values, expected)
        finally:
            view.release()


def mercury_text(rng, n, dim=3, fmt="%.17g"):
    """A MercuryDPM .data frame (header + rows, species as an integer) and a .fstat block."""
    pos = rng.uniform(-1, 1, (n, dim)) * 10.0 ** rng.integers(-3, 3, (n, 1))
    vel = rng.normal(size=(n, dim)) * 1e-3
    rad = rng.uniform(0.4, 0.6, n)
    lines = [f"{n} 0.5 " + " ".join(["-1"] * dim + ["1"] * dim)]
    for k in range(n):
        extra = ["0"] * (6 if dim == 3 else 2)
        lines.append(" ".join([fmt % x for x in (*pos[k], *vel[k], rad[k])] + extra + [str(k % 3)]))
    data = ("\n".join(lines) + "\n").encode()
    f = ["# 0.5 1", "# -1 -1 -1 1 1 1", "# 0.4 0.6 0 0 0 0"]
    for k in range(n):
        vals = rng.normal(size=12)
        f.append(" ".join(["0.5", str(k), str(-1 - k % 2)] + [fmt % x for x in vals] + ["0"]))
    fstat = ("\n".join(f) + "\n").encode()
    return data, fstat


@pytest.mark.parametrize("fmt", ["%.17g", "%g", "%.10e", "%r"])
def test_mercury_layouts_bitwise_equal_to_loadtxt(fmt):
    rng = np.random.default_rng(7)
    data, fstat = mercury_text(rng, 300, fmt=fmt.replace("%r", "%s"))
    rows = data.index(b"\n") + 1
    table = _text.parse_table(data, rows, ncols=14, int_columns=(13,), nrows=300)
    assert_bitwise(table.values, loadtxt(data[rows:], 14))
    np.testing.assert_array_equal(table.ints[:, 0], np.arange(300) % 3)
    header = _text.find_lines(fstat, b"#")
    assert list(header) == [0, fstat.index(b"\n") + 1, fstat.index(b"# 0.4")]
    body = fstat.index(b"\n", header[-1]) + 1
    table = _text.parse_table(fstat, body, ncols=16, int_columns=(1, 2))
    assert_bitwise(table.values, loadtxt(fstat[body:], 16))
    np.testing.assert_array_equal(table.ints, np.stack([np.arange(300), -1 - np.arange(300) % 2], axis=1))


# ------------------------------------------------------------------------------------------------
# adversarial layouts: the same values as np.loadtxt

ADVERSARIAL = {
    "extra spaces": b"  1   2  \n   3 4   \n",
    "tabs": b"1\t2\n\t3 \t 4\t\n",
    "crlf": b"1 2\r\n3 4\r\n",
    "no final newline": b"1 2\n3 4",
    "crlf no final newline": b"1 2\r\n3 4\r",
    "exponents": b"1e+05 1E-05\n-1.5e300 +2.5E-300\n1e0 .5e1\n5. -.25\n",
    "signed zeros": b"-0 +0\n-0.0 0e-999\n-0e5 -.0\n",
    "subnormals": b"4.9406564584124654e-324 2.2250738585072009e-308\n-5e-324 2.225073858507201e-308\n"
                  b"1e-320 3e-324\n",
    "smallest underflow": b"2.4703282292062328e-324 2.4703282292062327e-324\n1e-400 -1e-400\n",
    "largest": b"1.7976931348623157e308 -1.7976931348623157e+308\n1.7976931348623158e308 0\n",
    "17 digits": b"0.10000000000000001 0.30000000000000004\n9007199254740993 1.2345678901234567e-100\n",
    "long mantissas": b"3.14159265358979323846264338327950288 0.000000000000000000000000000001\n"
                      b"123456789012345678901234567890 1" + b"0" * 300 + b"\n",
    "halfway": b"9007199254740993 9007199254740995\n2.2250738585072011e-308 1.00000000000000011102230246251565\n",
    "leading zeros": b"000001.5 -0000.000125\n007 0.0e0000000000000000000000001\n",
}


@pytest.mark.parametrize("name", sorted(ADVERSARIAL))
def test_adversarial_layouts_bitwise_equal_to_loadtxt(name):
    text = ADVERSARIAL[name]
    assert_bitwise(parse(text, 2), loadtxt(text, 2))
    # and every token equals Python's float()
    tokens = text.split()
    got = parse(b"\n".join(tokens), 1)[:, 0]
    np.testing.assert_array_equal(bits(got), [float_bits(float(t)) for t in tokens])


def test_very_long_lines_and_many_columns():
    rng = np.random.default_rng(1)
    values = rng.normal(size=(3, 20000)) * 10.0 ** rng.integers(-300, 300, (3, 20000))
    text = "\n".join(" ".join(repr(float(x)) for x in row) for row in values).encode()
    assert_bitwise(parse(text, 20000), values)
    one_token = b"1" + b"0" * 100000 + b"e-100000"   # a 100 kB token: the exact path's heap copy
    assert_bitwise(parse(one_token, 1), np.array([[1.0]]))


def test_page_end_is_never_read_past(tmp_path):
    """A file of exactly one page ending in a token: the mapping ends where the text ends."""
    page = mmap.PAGESIZE
    body = b"1.5 2\n" * ((page - 10) // 6)
    text = body + b"3 " + b"4" * (page - len(body) - 2)
    assert len(text) == page
    path = tmp_path / "page.txt"
    path.write_bytes(text)
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as mm:
        assert_bitwise(_text.parse_table(mm, ncols=2).values, loadtxt(text, 2))
        assert list(_text.find_lines(mm, b"4")) == []
        assert list(_text.find_lines(mm, b"3 ")) == [len(body)]


def test_nan_and_inf_spellings_are_parsed_and_reported_by_name():
    spellings = [b"nan", b"NaN", b"-nan", b"+NAN", b"inf", b"-inf", b"Inf", b"INFINITY", b"-Infinity",
                 b"1.#INF", b"-1.#INF", b"1.#IND", b"-1.#IND", b"1.#QNAN", b"1.#SNAN", b"1.#INF00", b"1e400", b"-1e999"]
    for s in spellings:
        text = b"1 2\n3 " + s + b"\n"
        with pytest.raises(ValueError, match=re.escape(f"dump.txt (timestep 7), line 2, column 2: non-finite value "
                                                       f"{s.decode()!r}")):
            _text.parse_table(text, ncols=2, name="dump.txt", frame="timestep 7")
        v = _text.parse_table(text, ncols=2, allow_nonfinite=True).values[1, 1]
        assert not math.isfinite(v)
        inf = b"INF" in s.upper() or b"e" in s
        assert math.isinf(v) == inf
        assert math.copysign(1.0, v) == (-1.0 if s.startswith(b"-") else 1.0)
        if b"#" not in s:  # the MSVC spellings are ours; Python's float() knows the others
            assert bits(np.array([v]))[0] == float_bits(float(s)) or math.isnan(v)


# ------------------------------------------------------------------------------------------------
# errors: status, file, frame, line, column, the token quoted

ERRORS = [
    (b"1 2\n3 4\n5\n", 3, r"line 3: expected 2 values, found 1 value: '5'"),
    (b"1 2\n3 4 5\n", 2, r"line 2: expected 2 values, found more values: '3 4 5'"),
    (b"1 2\n\n3 4\n", 2, r"line 2: expected 2 values, found no values \(a blank line\): ''"),
    (b"1 2\n3 4\n  \t\n", 3, r"line 3: expected 2 values, found no values \(a blank line\)"),
    (b"1 2\r\n3 x\r\n", 2, r"line 2, column 2: not a number: 'x'"),
    (b"1 2\n3 4\x005\n", 2, r"line 2, column 2: not a number: '4\\x005'"),
    (b"1 2\n3 4\xc3\xa95\n", 2, "line 2, column 2: not a number: '4\u00e95'"),
    (b"1 2\n3 \xff\n", 2, r"line 2, column 2: not a number: '\\\\xff'"),
    (b"1 2\n3 1_000\n", 2, r"line 2, column 2: not a number: '1_000'"),
    (b"1 2\n3 0x10\n", 2, r"line 2, column 2: not a number: '0x10'"),
    (b"1 2\n3 1.0D+00\n", 2, r"line 2, column 2: not a number: '1.0D\+00'"),
    (b"1 2\n3 1e\n", 2, r"line 2, column 2: not a number: '1e'"),
    (b"1 2\n3 --1\n", 2, r"line 2, column 2: not a number: '--1'"),
    (b"1 2\n3 .\n", 2, r"line 2, column 2: not a number: '\.'"),
    (b"1 2\n3 nan(1)\n", 2, r"line 2, column 2: not a number: 'nan\(1\)'"),
    (b"1 2\n3 1.2.3\n", 2, r"line 2, column 2: not a number: '1.2.3'"),
]


@pytest.mark.parametrize("text, line, message", ERRORS)
def test_errors_name_file_frame_line_and_token(text, line, message):
    with pytest.raises(ValueError, match=r"^f\.dump \(timestep 9\), " + message):
        _text.parse_table(text, ncols=2, name="f.dump", frame="timestep 9")
    # relative to a range that starts further into the file, the line is the file's line
    prefix = b"ITEM: header\nITEM: more\n"
    with pytest.raises(ValueError, match=rf"^f\.dump, line {line + 2}\b"):
        _text.parse_table(prefix + text, len(prefix), ncols=2, name="f.dump")
    with pytest.raises(ValueError, match=rf"^f\.dump, line {line + 100}\b"):
        _text.parse_table(prefix + text, len(prefix), ncols=2, name="f.dump", first_line=101)


def test_declared_counts_are_checked():
    text = b"1 2\n3 4\n5 6\n"
    assert_bitwise(_text.parse_table(text, ncols=2, nrows=3).values, loadtxt(text, 2))
    with pytest.raises(ValueError, match=r"^a\.dump \(timestep 3\), line 3: expected 4 rows \(the declared count\), "
                                         r"found 3: the table is truncated"):
        _text.parse_table(text, ncols=2, nrows=4, name="a.dump", frame="timestep 3")
    with pytest.raises(ValueError, match=r"line 3: the table should end after 2 rows .* it continues: '5 6'"):
        _text.parse_table(text, ncols=2, nrows=2)
    assert _text.parse_table(b"", ncols=2, nrows=0).values.shape == (0, 2)
    assert _text.parse_table(b"", ncols=3).values.shape == (0, 3)
    assert_bitwise(_text.parse_table(b"\n1 2\n\n \n3 4\n\n", ncols=2, skip_blank=True).values, loadtxt(text[:8], 2))


def test_integer_columns():
    big, small = 2 ** 63 - 1, -2 ** 63
    text = f"{big} 1.5\n{small} 2\n-0 3\n+17 4\n0000000000000000000000000042 5\n".encode()
    t = _text.parse_table(text, ncols=2, int_columns=(0,))
    np.testing.assert_array_equal(t.ints[:, 0], [big, small, 0, 17, 42])
    assert_bitwise(t.values[:, 1], np.array([1.5, 2, 3, 4, 5]))
    assert t.values[0, 0] == float(big)
    for token, message in [(str(big + 1), "integer out of the 64-bit range"),
                           (str(small - 1), "integer out of the 64-bit range"),
                           ("99999999999999999999999", "integer out of the 64-bit range"),
                           ("1.0", r"not an integer \(an integer column\)"), ("1e3", r"not an integer \(an integer column\)"),
                           ("nan", r"not an integer \(an integer column\)"), ("-inf", r"not an integer \(an integer column\)"),
                           ("1x", "not a number"), ("-", "not a number"), ("12345678901234567890x", "not a number")]:
        with pytest.raises(ValueError, match=rf"^t, line 2, column 1: {message}: '{re.escape(token)}'"):
            _text.parse_table(f"1 2\n{token} 3\n".encode(), ncols=2, int_columns=(0,), name="t")


def test_arguments_are_checked():
    with pytest.raises(ValueError, match="ncols"):
        _text.parse_table(b"1", ncols=0)
    with pytest.raises(ValueError, match="int_columns"):
        _text.parse_table(b"1", ncols=1, int_columns=(1,))
    with pytest.raises(ValueError, match="int_columns"):
        _text.parse_table(b"1 2", ncols=2, int_columns=(1, 0))
    with pytest.raises(ValueError, match="nrows"):
        _text.parse_table(b"1", ncols=1, nrows=-1)
    with pytest.raises(ValueError, match="start, stop"):
        _text.parse_table(b"1 2", 2, 1, ncols=1)
    with pytest.raises(ValueError, match="start, stop"):
        _text.parse_table(b"1 2", 0, 4, ncols=1)
    with pytest.raises(ValueError, match="start, stop"):
        _text.find_lines(b"1 2", b"1", -1, 2)
    with pytest.raises(TypeError, match="data: expected bytes"):
        _text.parse_table("1 2", ncols=2)
    assert_bitwise(_text.parse_table(bytearray(b"1 2"), ncols=2).values, np.array([[1.0, 2.0]]))


def test_find_lines_against_a_python_twin():
    rng = random.Random(3)
    alphabet = [b"I", b"IT", b"ITEM", b"ITEM: ", b"#", b"\n", b"\r\n", b" ", b"1", b"x"]
    for _ in range(300):
        text = b"".join(rng.choice(alphabet) for _ in range(rng.randrange(60)))
        for prefix in (b"ITEM: ", b"#", b"I", b""):
            twin = [i for i in range(len(text)) if (i == 0 or text[i - 1:i] == b"\n") and text.startswith(prefix, i)]
            if prefix == b"":
                twin = [i for i in twin if i < len(text)]
            assert list(_text.find_lines(text, prefix)) == twin, (text, prefix)
            start = rng.randrange(len(text) + 1)
            ranged = [i for i in twin if i >= start] if start == 0 or text[start - 1:start] == b"\n" else None
            if ranged is not None:
                assert list(_text.find_lines(text, prefix, start, len(text))) == ranged
    many = b"ITEM: TIMESTEP\n1\n" * 5000  # more matches than the first capacity guess
    assert list(_text.find_lines(many, b"ITEM: TIMESTEP")) == list(range(0, len(many), 17))


# ------------------------------------------------------------------------------------------------
# gzip: streamed through zlib into the same parser

def split_frames_twin(raw, prefix):
    starts = [m.start() for m in re.finditer(rb"(?m)^" + re.escape(prefix), raw)]
    bounds = ([0] if not starts or starts[0] > 0 else []) + starts + [len(raw)]
    return [raw[a:b] for a, b in zip(bounds[:-1], bounds[1:]) if b > a]


@pytest.mark.parametrize("chunk", [7, 4096, 1 << 22])
def test_gzip_and_plain_stream_frames(tmp_path, chunk):
    raw = (DATA / "lammps" / "hooke3d" / "run_atoms.dump").read_bytes()
    plain, packed, multi = tmp_path / "a.dump", tmp_path / "a.dump.gz", tmp_path / "m.dump.gz"
    plain.write_bytes(raw)
    packed.write_bytes(gzip.compress(raw))
    half = len(raw) // 2
    multi.write_bytes(gzip.compress(raw[:half]) + gzip.compress(raw[half:]))  # concatenated members
    expected = split_frames_twin(raw, b"ITEM: TIMESTEP")
    assert len(expected) > 1
    for path in (plain, packed, multi):
        frames = list(_text.iter_frames(path, b"ITEM: TIMESTEP", chunk_size=chunk))
        assert [f for f, _ in frames] == expected
        assert [line for _, line in frames] == [1 + raw[:raw.index(f)].count(b"\n") for f in expected]
        assert b"".join(_text.iter_chunks(path, chunk)) == raw
    # the frames' tables from the gzip stream equal the plain file's
    for frame, line in _text.iter_frames(packed, "ITEM: TIMESTEP", chunk_size=chunk):
        (_, count, ncols, start, stop), = lammps_frames(frame)
        got = _text.parse_table(frame, start, stop, ncols, nrows=count, first_line=line)
        assert_bitwise(got.values, loadtxt(frame[start:stop], ncols))


def test_damaged_gzip_names_the_file(tmp_path):
    raw = gzip.compress((DATA / "lammps" / "hooke3d" / "atoms.dump").read_bytes())
    cut = tmp_path / "cut.dump.gz"
    cut.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(ValueError, match=r"cut\.dump\.gz: the gzip data ends early"):
        list(_text.iter_chunks(cut))
    bad = tmp_path / "bad.dump.gz"
    bad.write_bytes(raw[:40] + bytes(b ^ 0x55 for b in raw[40:200]) + raw[200:])
    with pytest.raises(ValueError, match=r"bad\.dump\.gz: (damaged gzip data|the gzip data ends early)"):
        list(_text.iter_chunks(bad))
    empty = tmp_path / "empty.dump"
    empty.write_bytes(b"")
    assert list(_text.iter_frames(empty, b"ITEM:")) == []
    assert zlib  # zlib is what iter_chunks uses (wbits=47: gzip or zlib headers)


# ------------------------------------------------------------------------------------------------
# fuzz: random doubles in the formats engines write, random decimal strings, random junk;
# every accepted token equals float() bit for bit, every token float() rejects is rejected

FORMATS = ["%r", "%.17g", "%g", "%e", "%.{k}e", "%.{k}g", "%.{k}f"]


def format_double(x, fmt, k):
    if fmt == "%r":
        return repr(x)
    if fmt == "%.{k}f" and abs(x) > 1e30:
        fmt = "%.{k}e"
    return fmt.format(k=k) % x


@st.composite
def double_batches(draw):
    seed = draw(st.integers(0, 2 ** 32 - 1))
    rng = random.Random(seed)
    tokens = []
    for _ in range(1000):
        kind = rng.random()
        if kind < 0.5:  # any double, subnormals included
            x = struct.unpack("<d", struct.pack("<Q", rng.getrandbits(64)))[0]
            if not math.isfinite(x):
                x = rng.uniform(-1e3, 1e3)
        elif kind < 0.8:  # engine-like magnitudes
            x = rng.uniform(-1, 1) * 10.0 ** rng.randint(-30, 30)
        else:  # near halfway between doubles: many digits, the exact path and Eisel-Lemire's edges
            x = rng.uniform(1, 2) * 2.0 ** rng.randint(-1074, 1023)
            y = math.nextafter(x, math.inf)
            from decimal import Decimal
            mid = (Decimal(x) + Decimal(y)) / 2
            tokens.append(str(mid) if rng.random() < 0.5 else f"{mid:.{rng.randint(15, 25)}e}")
            continue
        tokens.append(format_double(x, rng.choice(FORMATS), rng.randint(0, 25)))
    for _ in range(200):  # random 19-digit and 1..25-digit decimals with exponents
        digits = "".join(rng.choice("0123456789") for _ in range(rng.randint(1, 25)))
        tokens.append(f"{rng.choice(['', '-', '+'])}{digits}e{rng.randint(-340, 320)}")
    return tokens


@settings(max_examples=90, deadline=None, derandomize=True)  # 90 x 1200 = 108,000 tokens
@given(double_batches())
def test_fuzz_doubles_equal_python_float(tokens):
    # rows of 6 columns (the last row padded) so the row machinery runs too
    while len(tokens) % 6:
        tokens.append("0")
    lines = [" ".join(tokens[i:i + 6]) for i in range(0, len(tokens), 6)]
    got = _text.parse_table("\n".join(lines).encode(), ncols=6, allow_nonfinite=True).values.ravel()
    expected = np.array([float_bits(float(t)) for t in tokens])
    np.testing.assert_array_equal(bits(got), expected)


def test_eight_byte_words_at_every_distance_from_the_range_end():
    """Digits are read 8 bytes at a time where the range has room (a partial last word too) and byte by byte
    near its end: tokens of 1 to 26 digits around the '.', leading zeros, 15-20 significant digits and
    exponents, each followed by 0 to 40 bytes to the range's end (so it is parsed by the word path, by the
    byte path, or ends exactly at the end), equal float() and int() bit for bit; malformed ones are refused."""
    rng = random.Random(8)
    floats, ints = [], []
    for a in range(0, 12):
        for b in [None, 0, 1, 2, 6, 7, 8, 9, 15, 16, 17, 18, 19, 20, 24]:
            if a == 0 and not b:
                continue
            lead = rng.choice([0, 0, 1, 3, 8, 9])
            head = "0" * min(lead, a) + "".join(rng.choice("0123456789") for _ in range(a - min(lead, a)))
            tail = "" if b is None else "." + "0" * min(lead, b) + "".join(
                rng.choice("0123456789") for _ in range(b - min(lead, b)))
            exp = rng.choice(["", "", "e+05", "E-5", "e12", "e-308", "e0", "e00000007", "e123456789"])
            floats.append(rng.choice(["", "-", "+"]) + head + tail + exp)
    floats += ["0", "-0", "-0.0", "1e+05", ".5", "5.", "-.0e-0", "9007199254740993", "1.7976931348623157e308",
               "4.9406564584124654e-324", "2.2250738585072011e-308", "123456789012345678901234567890",
               "0.000000000000000000000000000000123456789012345678", "00000000000000000000000001.5"]
    for n in range(1, 20):
        ints.append(rng.choice(["", "-", "+"]) + "".join(rng.choice("0123456789") for _ in range(n)))
        ints.append("0" * n + "7")
    ints += [str(2 ** 63 - 1), str(-2 ** 63)]
    for pad in range(0, 41):
        for ending in (b" ", b"\n", b"\t \r\n"):
            trailer = (ending * pad)[:pad]
            tokens = floats + ints
            column = np.array([float_bits(float(t)) for t in tokens])
            for k, t in enumerate(tokens):   # the token last: its distance to the end is len(t) + pad
                text = f"{k} {t}".encode() + trailer
                got = _text.parse_table(text, ncols=2, int_columns=(0,), skip_blank=True,
                                         allow_nonfinite=True).values[0, 1]
                assert float_bits(got) == column[k], (t, pad, ending)
            for t in ints:
                assert _text.parse_table(f"1 {t}".encode() + trailer, ncols=2, int_columns=(1,),
                                         skip_blank=True).ints[0, 0] == int(t), (t, pad)
    for bad in ["1.2.3", "1e", "1e+", "--1", "1-", "0x10", "1_0", "12345678.9x", "1234567890123456789012e5x"]:
        for pad in (0, 3, 9, 33):
            with pytest.raises(ValueError, match="not a number"):
                _text.parse_table(f"1 {bad}".encode() + b" " * pad, ncols=2)


def test_row_path_fractions_of_every_length_against_float():
    """The row path's fraction (SSE2 on x86-64: the 16 bytes after the '.' checked and converted at once, the
    next 16 for 17-23 digits): integer parts of 0-3 digits, fractions of 0-25 digits (leading zeros up to 20:
    8, 16, 17 significant digits and more), exponents; a non-digit byte put at every place of the 16-byte
    window is refused like float() refuses it. Rows long enough for the row path, values equal float() bit
    for bit, errors name the line and the column."""
    rng = random.Random(15)
    tokens = []
    for head in ["", "0", "7", "00", "12", "99", "123"]:
        for n in range(0, 26):
            for zeros in sorted({0, 1, 2, min(n, 7), min(n, 15), min(n, 16), min(n, 20)}):
                if zeros > n or (not head and not n):
                    continue
                frac = "0" * zeros + "".join(rng.choice("0123456789") for _ in range(n - zeros))
                exp = rng.choice(["", "", "", "e5", "E-07", "e+300", "e-320", "e0"])
                tokens.append(rng.choice(["", "", "-", "+"]) + head + "." + frac + exp)
    tokens += ["0.0", "-0.0", "0.00000000000000000000", "5.", "1.9999999999999999", "9.9999999999999999999",
               "0.30000000000000004", "0.0099999999999997868", "45.549999999999997", "123.45678901234567",
               "0.95395734275277411", "0.000000000000000000012345678901234567"]
    pad = "\n".join(["0 0 0"] * 40) + "\n"
    rows = "".join(f"{k} {t} 0\n" for k, t in enumerate(tokens))
    got = _text.parse_table((rows + pad).encode(), ncols=3, int_columns=(0,), allow_nonfinite=True).values
    np.testing.assert_array_equal(bits(got[:len(tokens), 1]), [float_bits(float(t)) for t in tokens])
    for t in ["1.2345678901234567", "12.345678901234567", "0.00012345678901234567"]:
        for at in range(t.index(".") + 1, len(t)):
            for junk in "x./:\x00\xff-e":
                bad = t[:at] + junk + t[at + 1:]
                if python_accepts(bad) is not False:
                    continue  # still a number (an exponent 'e' before digits): compared above's way
                text = ("0 0 0\n" + f"1 {bad} 0\n" + pad).encode("latin-1")
                with pytest.raises(ValueError, match="line 2, column 2: not a number"):
                    _text.parse_table(text, ncols=3, int_columns=(0,))


JUNK = "0123456789+-.eEnaiftyINFAY#_ x\x00\xe9"


def python_accepts(token):
    if "_" in token or "#" in token or " " in token or "\x00" in token:
        return None  # the documented differences (underscores, MSVC 1.#INF) and separators: not compared
    try:
        return float(token)
    except ValueError:
        return False


@settings(max_examples=40, deadline=None, derandomize=True)  # 12,000 tokens
@given(st.lists(st.text(alphabet=JUNK, min_size=1, max_size=12), min_size=300, max_size=300))
def test_fuzz_junk_tokens_agree_with_python_float(tokens):
    accepted, rejected = [], []
    for t in tokens:
        verdict = python_accepts(t)
        if verdict is None:
            continue
        (accepted if verdict is not False else rejected).append(t)
    if accepted:
        got = _text.parse_table("\n".join(accepted).encode(), ncols=1, allow_nonfinite=True).values[:, 0]
        np.testing.assert_array_equal(bits(got), [float_bits(float(t)) for t in accepted])
    for t in rejected:
        with pytest.raises(ValueError, match="line 2, column 1: not a number"):
            _text.parse_table(f"1\n{t}\n".encode(), ncols=1)


def test_fuzz_tool_mutated_dumps_and_doubles_agree_with_the_twin():
    """tools/fuzz_text.py (mutated genuine frames + formatted doubles vs a Python twin), bounded."""
    import subprocess
    import sys
    tool = pathlib.Path(__file__).parent.parent / "tools" / "fuzz_text.py"
    run = subprocess.run([sys.executable, str(tool), "--cases", "150", "--seed", "0"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr + run.stdout
    assert re.search(r"150 cases, \d+ tokens compared bit for bit, 0 failures", run.stdout)


def test_c_program_page_end_guard_and_valgrind(tmp_path):
    """csrc/tests/test_text.c: every prefix of adversarial texts placed right before an inaccessible
    page (a read past the range faults), built with -Wall -Wextra -Werror, run plain and under valgrind; built
    without the SSE2 row path (-DCG_TEXT_NO_SSE2) and at -O0 too, run plain."""
    import shutil
    import subprocess
    cc = shutil.which("cc") or shutil.which("gcc")
    if not cc:
        pytest.skip("no C compiler")
    root = pathlib.Path(__file__).parent.parent / "csrc"
    exe = tmp_path / "test_text"
    subprocess.run([cc, "-std=c11", "-Wall", "-Wextra", "-Werror", "-O2", "-g", str(root / "tests" / "test_text.c"),
                    str(root / "cg_text.c"), str(root / "cg_status.c"), "-lm", "-o", str(exe)], check=True)
    # not under the sanitizer run's preloaded libasan (valgrind and ASan exclude each other)
    import os
    env = {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}
    run = subprocess.run([str(exe)], capture_output=True, text=True, env=env)
    assert run.returncode == 0 and "test_text: ok" in run.stdout, run.stderr
    # the portable build (no SSE2 row path, as on other CPUs), at -O0 too
    for flags in (["-O2", "-DCG_TEXT_NO_SSE2"], ["-O0"]):
        other = tmp_path / ("test_text" + "".join(flags).replace("-", "_"))
        subprocess.run([cc, "-std=c11", "-Wall", "-Wextra", "-Werror", *flags, str(root / "tests" / "test_text.c"),
                        str(root / "cg_text.c"), str(root / "cg_status.c"), "-lm", "-o", str(other)], check=True)
        run = subprocess.run([str(other)], capture_output=True, text=True, env=env)
        assert run.returncode == 0 and "test_text: ok" in run.stdout, (flags, run.stderr)
    if shutil.which("valgrind"):
        run = subprocess.run(["valgrind", "-q", "--error-exitcode=1", "--leak-check=full", str(exe)],
                             capture_output=True, text=True, env=env)
        assert run.returncode == 0 and "test_text: ok" in run.stdout, run.stderr


def test_frames_delimited_by_declared_counts_stop_after_rows():
    """MercuryDPM .data: a header with N, N rows, the next header; the table ends after N rows."""
    text = b"2 0 -1 -1 1 1\n1 2\n3 4\n1 0.5 -1 -1 1 1\n5 6\n"
    first = text.index(b"\n") + 1
    table = _text.parse_table(text, first, ncols=2, nrows=2, stop_after_rows=True)
    assert_bitwise(table.values, np.array([[1.0, 2.0], [3.0, 4.0]]))
    assert text[table.end:].startswith(b"1 0.5")
    second = text.index(b"\n", table.end) + 1
    last = _text.parse_table(text, second, ncols=2, nrows=1, stop_after_rows=True)
    assert last.end == len(text) and last.values.tolist() == [[5.0, 6.0]]
    with pytest.raises(ValueError, match=r"^w\.data \(t = 0\.5\), line 5: expected 2 rows \(the declared count\), "
                                         r"found 1: the table is truncated"):
        _text.parse_table(text, second, ncols=2, nrows=2, stop_after_rows=True, name="w.data", frame="t = 0.5")
    with pytest.raises(ValueError, match=r"line 4: expected 2 values, found more values: '1 0.5 -1 -1 1 1'"):
        _text.parse_table(text, first, ncols=2, nrows=3, stop_after_rows=True)
    with pytest.raises(ValueError, match="stop_after_rows: needs nrows"):
        _text.parse_table(text, first, ncols=2, stop_after_rows=True)
