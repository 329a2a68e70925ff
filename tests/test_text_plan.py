"""The text layer's plan (csrc/cg_text.h: cg_text_plan_lines, cg_text_parse_table_plan, cg_text_parse_table_parts):
a range cut at line starts into parts whose lines are counted once, in parallel, then parsed one part per thread;
and the threaded line search (cg_text_find_lines_threads).

The cuts and counts against a NumPy twin; the parse cut into 1 .. 16 parts (parts smaller than a line, empty parts,
cuts next to blank lines, errors and nan) against the one-pass parse: the same values bit for bit, the same rows,
end, error (line, column, offset, length) and nan/inf report.
"""
import random

import numpy as np
import pytest

from cgbound import _engine
from cgbound.readers import _text

# csrc/cg_text.h: CG_TEXT_BYTES_PER_THREAD; ranges shorter than two of these are searched on one thread
BYTES_PER_THREAD = 1 << 21


def twin_plan(data, start, stop, parts):
    """cg_text_plan_lines in NumPy: part k starts after the first '\\n' at or after byte (length // parts) * k."""
    text = np.frombuffer(data, np.uint8)[start:stop]
    length = len(text)
    newlines = np.flatnonzero(text == 10)
    starts = [0]
    for k in range(1, parts):
        cut = max(length // parts * k, starts[-1])
        after = newlines[newlines >= cut]
        starts.append(int(after[0]) + 1 if len(after) else length)
    starts.append(length)

    def lines(a, b):
        return int(np.count_nonzero(text[a:b] == 10)) + (b > a and text[b - 1] != 10)

    before = [sum(lines(starts[j], starts[j + 1]) for j in range(k)) for k in range(parts + 1)]
    return [start + s for s in starts], before


TEXTS = [b"", b"\n", b"\n\n\n", b"1 2", b"1 2\n", b"1 2\r\n3 4\r\n", b"1 2\r\n3 4", b"x" * 100, b"x" * 100 + b"\n",
         b"1\n" * 50, b"\n".join(b"%d %d" % (k, k * k) for k in range(40)),
         b"a" * 70 + b"\n" + b"b\n" * 3 + b"c" * 90]


@pytest.mark.parametrize("text", TEXTS)
def test_plan_cuts_and_counts_equal_a_numpy_twin(text):
    data = b"##" + text + b"##"  # a range inside the buffer
    for start, stop in [(2, 2 + len(text)), (0, len(data)), (3, max(3, 1 + len(text)))]:
        for parts in (1, 2, 3, 5, 16):
            starts, lines = _engine.text_plan_lines(data, start, stop, parts)
            expected_starts, expected_lines = twin_plan(data, start, stop, parts)
            assert list(starts) == expected_starts and list(lines) == expected_lines, (text, start, stop, parts)
            assert lines[-1] == _text.count_lines(data, start, stop)
    for bad in (0, -1, 17):
        with pytest.raises(ValueError, match="parts"):
            _engine.text_plan_lines(b"1\n", 0, 2, bad)


def raw_parse(data, ncols, int_mask, max_rows, flags, parts):
    values, ints, nrows, end, error, nonfinite = _engine.text_parse_table(data, 0, len(data), ncols, int_mask,
                                                                          max_rows, flags, 1, parts)
    return (values[:nrows].view(np.int64).tobytes(), ints[:nrows].tobytes(), nrows, end, error, nonfinite)


def small_tables(seed):
    """Tables of 3 columns (the first an integer) with the damage the parse must report the same whatever the cut."""
    rng = random.Random(seed)
    rows = [b"%d %r %.6e" % (k, rng.uniform(-1, 1), rng.uniform(-1e9, 1e9)) for k in range(30)]
    long_row = b"7 " + b"0" * 300 + b".5 1e-300"  # longer than most parts
    out = {"plain": b"\n".join(rows) + b"\n", "no final newline": b"\n".join(rows), "crlf": b"\r\n".join(rows),
           "long line": b"\n".join(rows[:5] + [long_row] + rows[5:]) + b"\n",
           "blank lines": b"\n\n" + b"\n \t\n".join(rows[:12]) + b"\n\n" + b"\n".join(rows[12:]) + b"\n  \n",
           "nan": b"\n".join(rows[:9] + [b"9 nan 1"] + rows[10:20] + [b"20 2 -inf"] + rows[21:]) + b"\n",
           "bad token": b"\n".join(rows[:17] + [b"17 1.2.3 1"] + rows[18:]) + b"\n",
           "short row": b"\n".join(rows[:23] + [b"23 1"] + rows[24:]),
           "long row": b"\n".join(rows[:3] + [b"3 1 2 3"] + rows[4:]) + b"\n",
           "not an integer": b"\n".join(rows[:28] + [b"2.5 1 2"] + rows[29:]) + b"\n",
           "blank line": b"\n".join(rows[:14] + [b"   "] + rows[14:]) + b"\n"}
    return out


@pytest.mark.parametrize("name", list(small_tables(0)))
def test_parse_in_any_number_of_parts_equals_one_pass(name):
    data = small_tables(0)[name]
    mask = bytes([1, 0, 0])
    nlines = _text.count_lines(data)
    checked = 0
    for flags in (0, 1, 2, 3):
        for max_rows in (-1, 0, 12, 29, 30, 31, nlines + 5):
            if max_rows < 0 and flags & 2:
                continue
            expected = raw_parse(data, 3, mask, max_rows, flags, 1)
            for parts in (2, 3, 4, 7, 16):
                assert raw_parse(data, 3, mask, max_rows, flags, parts) == expected, (name, flags, max_rows, parts)
                checked += 1
            # integer columns off: the plain double path
            assert raw_parse(data, 3, bytes(3), max_rows, flags, 5) == raw_parse(data, 3, bytes(3), max_rows, flags, 1)
    assert checked > 100


def test_parse_with_parts_larger_than_the_range_and_of_empty_ranges():
    for data in (b"", b"\n", b"  \n\n", b"1 2 3", b"1 2 3\n"):
        for flags in (0, 1):
            expected = raw_parse(data, 3, bytes(3), -1, flags, 1)
            for parts in (2, 16):
                assert raw_parse(data, 3, bytes(3), -1, flags, parts) == expected
    with pytest.raises(ValueError, match="parts"):
        _engine.text_parse_table(b"1\n", 0, 2, 1, bytes(1), -1, 0, 1, 17)


def test_skipped_blank_lines_shrink_the_tables_in_place():
    """An undeclared count sizes the tables by lines; rows skipped as blank are given back (resize, no copy)."""
    data = b"\n1 2 3\n \n4 5 6\n\n7 8 9\n\t\n"
    for threads in (1, 2):
        table = _text.parse_table(data, ncols=3, int_columns=(1,), skip_blank=True, threads=threads)
        assert table.values.tolist() == [[1, 2, 3], [4, 5, 6], [7, 8, 9]] and table.ints.tolist() == [[2], [5], [8]]
        for a in table:
            if isinstance(a, np.ndarray):
                assert a.flags.c_contiguous and a.flags.owndata and a.base is None


def twin_find_lines(data, prefix, start, stop):
    """Line starts in [start, stop) (a line starts at start or after a '\\n') whose bytes up to stop begin with
    prefix."""
    text = np.frombuffer(data, np.uint8)[:stop]
    after = np.flatnonzero(text[start:] == 10) + start + 1
    starts = np.concatenate([[start] if start < stop else [], after[after < stop]]).astype(np.int64)
    if prefix:
        starts = starts[text[starts] == prefix[0]]
    return [int(s) for s in starts if data.startswith(prefix, s, stop)]


@pytest.mark.parametrize("ending", [b"\n", b""])
def test_threaded_find_lines_equals_one_thread_and_a_twin(ending):
    """Frame starts right at, before and after each cut (length // parts * k for 2 and 3 parts), a cut inside the
    prefix, and every line start."""
    size = 2 * BYTES_PER_THREAD + 123457
    body = bytearray(b"0.5 1.25 -3e-7\n" * (size // 15))
    for parts in (2, 3):
        for k in range(1, parts):
            cut = len(body) // parts * k
            for at, text in [(cut - 40, b"ITEM: TIMESTEP\n"), (cut - 7, b"ITEM: TIMESTEP\n"), (cut, b"ITEM: TIM\n"),
                             (cut + 60, b"# 0.5 1\n")]:
                body[at:at + len(text)] = text
                body[at - 1:at] = b"\n"
    data = bytes(body[:-1]) + ending
    for start, stop in [(0, len(data)), (1, len(data) - 3)]:
        for prefix in (b"ITEM: TIMESTEP", b"ITEM: TIM", b"#", b"I", b""):
            expected = twin_find_lines(data, prefix, start, stop)
            assert prefix == b"" or len(expected) >= 2
            for threads in (1, 2, 3):
                got = _text.find_lines(data, prefix, start, stop, threads=threads)
                assert got.tolist() == expected, (prefix, start, stop, threads)
    with pytest.raises(ValueError, match="threads"):
        _text.find_lines(data, b"#", threads=0)
