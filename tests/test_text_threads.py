"""The text layer's fast path and its threaded table parse (csrc/cg_text.c), against float() and
against the one-thread parse.

Tokens the fast path decides (<= 19 significant digits, Clinger or Eisel-Lemire) and tokens it
hands on (more digits, subnormals, overflow, nan/inf, malformed) must give float()'s value bit for
bit. A range parsed over several threads (cut at line starts) must give the same table, the same
errors (line, column, token) and the same nan/inf report as one thread.
"""
import random
import struct

import numpy as np
import pytest

from cgbound.readers import _text

# csrc/cg_text.h: CG_TEXT_BYTES_PER_THREAD; ranges shorter than two of these parse on one thread
BYTES_PER_THREAD = 1 << 21


def bits(values):
    return np.ascontiguousarray(values, dtype=np.float64).view(np.int64)


def float_bits(x):
    return struct.unpack("<q", struct.pack("<d", x))[0]


EDGE_TOKENS = [
    # 17-19 significant digits (fast path) and 20+ (the general path), around 2^53 and 2^64
    "0.10000000000000001", "1.2345678901234567", "12345678901234567", "123456789012345678",
    "1234567890123456789", "9999999999999999999", "12345678901234567890", "18446744073709551615",
    "18446744073709551616", "9007199254740993", "9007199254740992", "9007199254740991.5",
    "4.9406564584124654e-324", "2.4703282292062327e-324", "2.4703282292062328e-324",
    # leading zeros: many digits, few significant ones
    "0.000000000000000000001234", "00000000000000000000001", "0000000000000000000000.5e1",
    "000000000000000000001234567890123456789", "-0.0000000000000000000000000000",
    # subnormals, underflow, the largest doubles, overflow (to inf: reported as non-finite)
    "1e-320", "-1e-320", "2.2250738585072011e-308", "2.2250738585072014e-308", "1e-400",
    "1e+308", "1.7976931348623157e308", "1.7976931348623158e+308", "-1e+308",
    # signs, points, exponents
    "-0", "+0", "-0.0", "+.5", "-.5", "5.", "-5.", ".5e-3", "5.E+2", "1e+05", "1E5", "1e0005", "1e-0",
    "123e-22", "123e22", "123e23", "9007199254740992e22", "9007199254740993e-22",
    "7.2057594037927933e16", "0.1e1", "1.5e-45", "3.4028235e38",
    # halfway cases between doubles (round half to even)
    "9007199254740993.0", "9007199254740995", "1.00000000000000011102230246251565404236316680908203125",
    "1.00000000000000011102230246251565404236316680908203124", "5e-324", "3e-324", "2e-324",
]
SPECIAL_TOKENS = ["nan", "NaN", "-nan", "+NAN", "inf", "-inf", "+Inf", "INFINITY", "-Infinity", "1e999",
                  "-1e999"]
BAD_TOKENS = ["1e", "1e+", ".", "-", "+", "e5", "1.2.3", "1e5.5", "--1", "0x10", "1_0", "1d5", "5..", "1,5",
              "1e5e5", "in", "nana", "infinit", ".e1", "+-1"]


@pytest.mark.parametrize("ending", [b"\n", b"\r\n", b""])
def test_edge_tokens_equal_python_float(ending):
    tokens = EDGE_TOKENS + SPECIAL_TOKENS
    # one per line (the token at the range end, with or without a line end) and all on one line
    for text, ncols in [(b"\n".join(t.encode() for t in tokens), 1),
                        ((" \t".join(tokens)).encode(), len(tokens))]:
        for line_end in (ending,):
            data = text.replace(b"\n", line_end) + line_end if line_end else text
            got = _text.parse_table(data, ncols=ncols, allow_nonfinite=True).values.ravel()
            np.testing.assert_array_equal(bits(got), [float_bits(float(t)) for t in tokens])


@pytest.mark.parametrize("token", BAD_TOKENS)
def test_malformed_tokens_are_errors_wherever_they_stand(token):
    if "_" not in token:  # float() accepts '1_0' (a documented difference: no engine writes it)
        with pytest.raises(ValueError):
            float(token)
    for text, line, column in [(f"{token}\n", 1, 1), (f"1 2\n3 {token}\n", 2, 2), (f"1 2\n{token} 3", 2, 1),
                               (f"1 2\r\n3 {token}\r\n", 2, 2)]:
        with pytest.raises(ValueError, match=rf"line {line}, column {column}: not a number"):
            _text.parse_table(text.encode(), ncols=len(text.splitlines()[0].split()))


def test_integer_columns_fast_and_general_paths():
    tokens = ["0", "-0", "+7", "123456789012345678", "-123456789012345678", "1234567890123456789",
              "9223372036854775807", "-9223372036854775808", "000000000000000000000042"]
    table = _text.parse_table(("\n".join(f"{t} 1.5" for t in tokens)).encode(), ncols=2, int_columns=(0,))
    np.testing.assert_array_equal(table.ints[:, 0], [int(t) for t in tokens])
    for bad, message in [("9223372036854775808", "outside"), ("1.0", "integer"), ("12a", "not a number"),
                         ("1e3", "integer")]:
        with pytest.raises(ValueError, match=rf"line 2, column 1"):
            _text.parse_table(f"1 1\n{bad} 1\n".encode(), ncols=2, int_columns=(0,))


# ------------------------------------------------------------------------------------------------
# the threaded parse

def big_table(seed, rows=60000):
    """~7 MB of rows 'id type x y z vx vy vz' in the formats engines write (ints in columns 0 and 1)."""
    rng = random.Random(seed)
    formats = ["%.17g", "%r", "%g", "%.6e", "%.10f"]
    lines = []
    for k in range(rows):
        fmt = rng.choice(formats)
        values = [rng.uniform(-1, 1) * 10.0 ** rng.randint(-12, 12) for _ in range(6)]
        body = " ".join(repr(v) if fmt == "%r" else fmt % v for v in values)
        lines.append(f"{k + 1} {rng.randint(1, 3)} {body}")
    return lines


def parse_both(data, **kw):
    """(threads=1 result or error message, threads=2 ..., threads=3 ...)."""
    out = []
    for threads in (1, 2, 3):
        try:
            table = _text.parse_table(data, threads=threads, **kw)
            out.append(("ok", bits(table.values).tobytes(), table.ints.tobytes(), table.end))
        except ValueError as exc:
            out.append(("error", str(exc)))
    return out


@pytest.fixture(scope="module")
def lines():
    return big_table(0)


def test_threaded_table_equals_one_thread_and_python_float(lines):
    data = ("\n".join(lines) + "\n").encode()
    assert len(data) > 3 * BYTES_PER_THREAD
    results = parse_both(data, ncols=8, int_columns=(0, 1), nrows=len(lines), name="big.dump")
    assert results[0][0] == "ok" and results[1] == results[0] and results[2] == results[0]
    table = _text.parse_table(data, ncols=8, int_columns=(0, 1), threads=2)
    expected = np.array([[float_bits(float(w)) for w in line.split()] for line in lines[::997]])
    np.testing.assert_array_equal(bits(table.values[::997]), expected)
    np.testing.assert_array_equal(table.ints[:, 0], np.arange(1, len(lines) + 1))
    # CRLF line ends and no final line end
    crlf = "\r\n".join(lines).encode()
    results = parse_both(crlf, ncols=8, int_columns=(0, 1))
    assert results[0][0] == "ok" and results[1] == results[0] and results[2] == results[0]


@pytest.mark.parametrize("where", [0.1, 0.55, 0.999])
@pytest.mark.parametrize("damage", ["token", "few", "many", "blank", "nan", "int"])
def test_threaded_errors_equal_one_thread(lines, where, damage):
    k = int(where * len(lines))
    damaged = list(lines)
    words = damaged[k].split()
    if damage == "token":
        words[4] = "1.2.3"
    elif damage == "few":
        words = words[:-1]
    elif damage == "many":
        words.append("7")
    elif damage == "blank":
        words = []
    elif damage == "nan":
        words[5] = "nan"
        later = damaged[min(k + 5000, len(lines) - 1)].split()
        later[3] = "-inf"
        damaged[min(k + 5000, len(lines) - 1)] = " ".join(later)
    elif damage == "int":
        words[0] = "1.0"
    damaged[k] = " ".join(words)
    data = ("\n".join(damaged) + "\n").encode()
    results = parse_both(data, ncols=8, int_columns=(0, 1), name="big.dump", first_line=10)
    assert results[0][0] == "error"
    assert f"line {k + 10}" in results[0][1]
    assert results[1] == results[0] and results[2] == results[0]
    if damage == "nan":
        results = parse_both(data, ncols=8, int_columns=(0, 1), allow_nonfinite=True)
        assert results[0][0] == "ok" and results[1] == results[0] and results[2] == results[0]


def test_threaded_declared_counts(lines):
    data = ("\n".join(lines) + "\n").encode()
    n = len(lines)
    for nrows in (n - 1, n + 1, n // 3):  # more rows than declared, fewer (truncated)
        results = parse_both(data, ncols=8, int_columns=(0, 1), nrows=nrows, name="big.dump")
        assert results[0][0] == "error" and results[1] == results[0] and results[2] == results[0]
    # frames delimited by their declared count: the table ends after nrows lines, whatever follows
    for nrows, tail in [(n // 2, ""), (n - 1, ""), (n, "\n\n3 frames of junk 1.2.3"), (n // 2 + 1, "")]:
        results = parse_both(data + tail.encode(), ncols=8, int_columns=(0, 1), nrows=nrows,
                             stop_after_rows=True)
        assert results[1] == results[0] and results[2] == results[0]
        assert results[0][0] == "ok"
        assert results[0][3] == len(("\n".join(lines[:nrows]) + "\n").encode())
    # blank lines skipped (rows closed up after the parts), with nan/inf and declared counts
    spaced = ("\n\n".join(lines[:n // 2]) + "\n \t\n\n" + "\n".join(lines[n // 2:]) + "\n  \n").encode()
    for kw in [{}, {"nrows": n}, {"nrows": n - 1}, {"nrows": n + 1}]:
        results = parse_both(spaced, ncols=8, int_columns=(0, 1), skip_blank=True, **kw)
        assert results[0][0] == ("ok" if kw.get("nrows", n) == n else "error")
        assert results[1] == results[0] and results[2] == results[0]
    with_nan = spaced.replace(lines[n // 3 * 2].encode(), lines[n // 3 * 2].rsplit(" ", 1)[0].encode() + b" -NaN")
    assert with_nan != spaced
    for allow in (False, True):
        results = parse_both(with_nan, ncols=8, int_columns=(0, 1), skip_blank=True, allow_nonfinite=allow)
        assert results[0][0] == ("ok" if allow else "error")
        assert results[1] == results[0] and results[2] == results[0]
    nan_line = 1 + next(k for k, line in enumerate(with_nan.split(b"\n")) if b"NaN" in line)
    assert f"line {nan_line}, column 8" in parse_both(with_nan, ncols=8, skip_blank=True)[0][1]
    results = parse_both(data + b"   \n  ", ncols=8, int_columns=(0, 1))
    assert results[0][0] == "error" and results[1] == results[0] and results[2] == results[0]


def test_threads_argument_is_checked():
    for bad in (0, -1, 1.5, True, "2", 4097, 10 ** 30):
        with pytest.raises(ValueError, match="threads: expected a positive number of threads"):
            _text.parse_table(b"1 2\n", ncols=2, threads=bad)


def test_threaded_line_count(lines):
    data = ("\n".join(lines) + "\n").encode()
    for text in (data, data[:-1], data[:-7]):
        expected = text.count(b"\n") + (not text.endswith(b"\n"))
        assert [_text.count_lines(text, threads=t) for t in (1, 2, 3, None)] == [expected] * 4
        assert _text.count_lines(text, 5, len(text) - 3, threads=2) == _text.count_lines(text[5:-3])


# ------------------------------------------------------------------------------------------------
# the row path (quick_row in cg_text.c): rows that start ncols * 48 bytes or more before the range's end
# are parsed without per-byte range checks; anything unusual is parsed again by the general loop

def row_path_token(rng, integer=False):
    """A token as engines write them, or one of the edge cases of the row path's word arithmetic."""
    if integer:
        return rng.choice(["0", "-0", "7", "-1", "+7", "007", str(rng.randint(0, 10 ** rng.randint(1, 15))),
                           str(-rng.randint(0, 10 ** 15)), str(rng.randint(10 ** 15, 2 ** 63 - 1)),
                           "-9223372036854775808", "9223372036854775807"])
    kind = rng.random()
    if kind < 0.25:  # the one-digit tokens of unused columns, in runs
        return rng.choice(["0", "0", "0", "1", "-1", "-0", "9"])
    if kind < 0.55:
        x = rng.uniform(-1, 1) * 10.0 ** rng.randint(-8, 8)
        return rng.choice([f"{x:.17g}", repr(x), f"{x:g}", f"{x:.6e}", f"{x:.{rng.randint(0, 12)}f}"])
    if kind < 0.65:  # any double: subnormals, huge exponents
        x = struct.unpack("<d", struct.pack("<Q", rng.getrandbits(64)))[0]
        return repr(x) if x == x and abs(x) != float("inf") else "1.5"
    if kind < 0.85:  # d.ddd and dd.ddd with 1 to 26 fraction digits, leading zeros, 1-4 exponent digits
        head = rng.choice(["0", "1", "-0", "-9", "12", "0.000", "123456789012345"])
        frac = "".join(rng.choice("0123456789") for _ in range(rng.randint(1, 26)))
        tail = rng.choice(["", "", "e5", "E-3", "e+05", "e-0307", "e308", "e-330"])
        return (head if "." in head else head + ".") + frac + tail
    return rng.choice(EDGE_TOKENS + [".5", "5.", "-.5e1", "+1.5", "1e0005", "16777217", "9007199254740993"])


def row_path_text(rng, rows, ncols, int_columns, plain):
    seps = [" "] if plain else [" "] * 8 + ["  ", "\t", " \t ", "\v", "\f", "\r "]
    ends = ["\n"] if plain else ["\n"] * 6 + ["\r\n", " \n", "\t\r\n"]
    lines = []
    for _ in range(rows):
        sparse = rng.random() < 0.3  # rows of mostly one-digit tokens (the runs the row path takes 4 at a time)
        words = [rng.choice("0000123456789") if sparse and rng.random() < 0.8 and c not in int_columns
                 else row_path_token(rng, c in int_columns) for c in range(ncols)]
        lead = "" if plain or rng.random() < 0.9 else rng.choice(seps)
        lines.append(lead + "".join(w + rng.choice(seps) for w in words[:-1]) + words[-1] + rng.choice(ends))
    return "".join(lines).encode()


def twin(data, ncols, int_columns):
    """Python's reading of the table: (float bits, ints) per row (int columns are stored as float(int) too)."""
    values, ints = [], []
    lines = data.split(b"\n")
    for line in lines[:-1] if lines[-1] == b"" else lines:
        words = line.split()
        assert len(words) == ncols
        values.append([float_bits(float(int(w)) if c in int_columns else float(w)) for c, w in enumerate(words)])
        ints.append([int(words[c]) for c in int_columns])
    return np.array(values, dtype=np.int64), np.array(ints, dtype=np.int64).reshape(len(values), -1)


@pytest.mark.parametrize("plain", [True, False])
def test_row_path_equals_python_float_on_adversarial_rows(plain):
    """Rows of engine-formatted and edge-case tokens (one-digit runs, 17-26 digit mantissas, leading zeros,
    exponents, subnormals, signs, int64 limits) with single spaces, or with tabs, runs of separators, CR,
    CRLF and leading/trailing separators; every cut near the end (tokens straddling the last row-path row and
    the range end, with and without a final line end): float() and int() bit for bit."""
    rng = random.Random(14 + plain)
    ncols, int_columns = 7, (1,)
    data = row_path_text(rng, 1500, ncols, int_columns, plain)
    expected = twin(data, ncols, int_columns)
    table = _text.parse_table(data, ncols=ncols, int_columns=int_columns, threads=1, allow_nonfinite=True)
    np.testing.assert_array_equal(bits(table.values), expected[0])
    np.testing.assert_array_equal(table.ints, expected[1])
    for cut in range(len(data) - 8 * 48, len(data), 7):
        text = data[:cut]
        try:
            want = twin(text, ncols, int_columns)
        except (AssertionError, ValueError):
            with pytest.raises(ValueError):
                _text.parse_table(text, ncols=ncols, int_columns=int_columns, threads=1, allow_nonfinite=True)
            continue
        got = _text.parse_table(text, ncols=ncols, int_columns=int_columns, threads=1, allow_nonfinite=True)
        np.testing.assert_array_equal(bits(got.values), want[0])
        np.testing.assert_array_equal(got.ints, want[1])


ROW_DAMAGE = BAD_TOKENS + ["1\x00", "\x00", "0\xff", "\xc3\xa9", "1.0 ", "nan", "-1.#INF", "1e99999", "0x1p3"]


@pytest.mark.parametrize("at", [3, 200])
def test_row_path_errors_equal_the_general_loop(at):
    """A damaged row among good ones (bad tokens, NUL and non-ASCII bytes, too few or too many tokens, a blank
    line, a float or an out-of-range value in the int column, nan): the message is the one the general loop
    gives for that row alone (parsed as a short range, which the row path never takes)."""
    rng = random.Random(at)
    ncols, int_columns = 6, (0,)
    good = [line for line in row_path_text(rng, 500, ncols, int_columns, plain=True).split(b"\n")[:-1]
            if all(abs(float(w)) < float("inf") for w in line.split())]
    cases = []
    for token in ROW_DAMAGE:
        for column in (0, 2, 5):
            words = good[at].split()
            words[column] = token.encode("latin-1")
            cases.append(b" ".join(words))
    words = good[at].split()
    cases += [b" ".join(words[:-1]), b" ".join(words + [b"0"]), b"", b"  \t", b"0 " + b" ".join(words[1:]) + b" 0",
              b"99999999999999999999 " + b" ".join(words[1:]), b"1.5 " + b" ".join(words[1:])]
    def outcome(data, row, **kw):
        """The error message, or the bits of the row-th row."""
        try:
            table = _text.parse_table(data, ncols=ncols, int_columns=int_columns, threads=1, **kw)
            return bits(table.values[row]).tolist() + table.ints[row].tolist()
        except ValueError as exc:
            return str(exc)

    errors = 0
    for row in cases:
        data = b"\n".join(good[:at + 1] + [row] + good[at + 1:]) + b"\n"
        alone = outcome(row + b"\n", 0, first_line=at + 2)
        assert outcome(data, at + 1) == alone, row
        errors += isinstance(alone, str)
    assert errors >= len(cases) - 8  # the few damages that leave a valid row (e.g. '1.0 ' in a float column)
    assert errors >= len(cases) - 12
