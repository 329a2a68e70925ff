"""The MercuryDPM scans read a file in windows of whole lines (memory: one window, never the whole file):
every window size, plain or gzipped, finds the same frames and raises the same errors as one window."""
import functools
import gzip
import os

import pytest

from cgbound.readers import _mercury_files
from cgbound.readers._mercury_files import scan_data, scan_fstat
from cgbound.readers._text import iter_chunks

HERE = os.path.dirname(__file__)
STEM = os.path.join(HERE, "data", "mercurydpm", "ChutePeriodicDemo", "ChutePeriodicDemo")
SIZES = [1, 7, 100, 4096]


def outcome(scan, path, *args):
    try:
        return scan(path, *args)
    except ValueError as exc:
        return str(exc).replace(str(path), "<file>")


def outcomes(monkeypatch, scan, path, *args):
    """The scan with one window, then with every size in SIZES (small gzip chunks, so gzip windows vary too)."""
    monkeypatch.setattr(_mercury_files, "SCAN_WINDOW", 1 << 40)
    whole = outcome(scan, path, *args)
    small_chunks = functools.partial(iter_chunks, chunk_size=53)
    monkeypatch.setattr(_mercury_files, "iter_chunks", small_chunks)
    got = []
    for size in SIZES:
        monkeypatch.setattr(_mercury_files, "SCAN_WINDOW", size)
        got.append(outcome(scan, path, *args))
    return whole, got


def variants(tmp_path, name, text):
    plain = tmp_path / name
    plain.write_bytes(text)
    packed = tmp_path / (name + ".gz")
    packed.write_bytes(gzip.compress(text))
    return [plain, packed]


def genuine(ext):
    with open(STEM + ext, "rb") as f:
        return f.read()


def damaged_data():
    text = genuine(".data")
    lines = text.split(b"\n")
    return {
        "genuine": text,
        "truncated": b"\n".join(lines[:len(lines) // 2]) + b"\n",
        "no final newline": text.rstrip(b"\n"),
        "comments only": b"# a comment\n\n# another\n",
        "blank": b"\n \n\t\n",
        "bad header": b"\n".join(lines[:1] + [b"1 2 3"] + lines[1:]),
        "comment lines and CRLF": b"# written by hand\r\n" + text.replace(b"\n", b"\r\n"),
        "a zero-particle frame": b"0 0 0 0 0 1 1 1\n" + text,
    }


def damaged_fstat():
    text = genuine(".fstat")
    lines = text.split(b"\n")
    heads = [k for k, line in enumerate(lines) if line.startswith(b"#")]
    last_body = heads[-1] + 1
    return {
        "genuine": text,
        "text before the first header": b"\n1 2 3\n" + text,
        "no header": b"1 2 3\n4 5 6\n",
        "blank": b"  \n\n",
        "a header line missing": b"\n".join(lines[:heads[4]] + lines[heads[4] + 1:]),
        "last frame cut off": b"\n".join(lines[:last_body]) + b"\n",
        "no final newline": text.rstrip(b"\n"),
        "an empty header line": b"\n".join(lines[:heads[3]] + [b"#"] + lines[heads[3] + 1:]),
    }


@pytest.mark.parametrize("case", list(damaged_data()))
def test_data_windows_agree(tmp_path, monkeypatch, case):
    for path in variants(tmp_path, "x.data", damaged_data()[case]):
        whole, got = outcomes(monkeypatch, scan_data, path, None)
        assert all(g == whole for g in got), (case, path)
        # no final newline: the last line was cut while written or copied (a cut in its last number keeps its length)
        if case in ("genuine", "comment lines and CRLF", "a zero-particle frame"):
            assert isinstance(whole, list) and len(whole) > 1
        else:
            assert isinstance(whole, str)


@pytest.mark.parametrize("case", list(damaged_fstat()))
def test_fstat_windows_agree(tmp_path, monkeypatch, case):
    for path in variants(tmp_path, "x.fstat", damaged_fstat()[case]):
        whole, got = outcomes(monkeypatch, scan_fstat, path)
        assert all(g == whole for g in got), (case, path)
        if case == "genuine":
            assert isinstance(whole, list) and len(whole) > 1
        else:
            assert isinstance(whole, str)


def test_window_errors_name_the_line(tmp_path, monkeypatch):
    """The truncated .data file and the misplaced .fstat text report the lines a reader of the file sees."""
    monkeypatch.setattr(_mercury_files, "SCAN_WINDOW", 64)
    path = tmp_path / "t.fstat"
    path.write_bytes(b"\n\n\n1 2 3\n" + genuine(".fstat"))
    with pytest.raises(ValueError, match=r"t\.fstat:4: contact line before the first '# time' header \(the first "
                                         r"header is on line 5\)"):
        scan_fstat(path)
    path.write_bytes(b"\n\n\t  \n \t1 2 3\n" + genuine(".fstat"))    # text after blanks on its line
    with pytest.raises(ValueError, match=r"t\.fstat:4: contact line before the first '# time' header \(the first "
                                         r"header is on line 5\)"):
        scan_fstat(path)
    path = tmp_path / "t.data"
    path.write_bytes(b"3 0 0 0 0 1 1 1\n" + b"0 0 0 0 0 0 0.5 0 0 0 0 0 0 1\n" * 2)
    with pytest.raises(ValueError, match=r"t\.data:1: the frame at t = 0 declares 3 particles but only 2 lines "
                                         r"follow"):
        scan_data(path, None)


@pytest.mark.parametrize("ext, scan", [(".data", lambda p: scan_data(p, None)), (".fstat", scan_fstat)])
def test_a_last_line_cut_inside_its_last_number_is_refused_naming_it(tmp_path, ext, scan):
    # a cut inside the last number keeps the line's length: the species (.data) or tz (.fstat) was read wrong
    text = genuine(ext)
    cut = text.rstrip(b"\n")[:-2]
    lines = cut.count(b"\n") + 1
    for path in variants(tmp_path, "c" + ext, cut):
        with pytest.raises(ValueError, match=rf"c{ext}(.gz)?:{lines}: the last line has no newline at its end: the "
                                             r"file was cut"):
            scan(path)


def test_a_complete_file_without_a_final_newline_is_refused_with_a_hint_that_keeps_the_data(tmp_path):
    # a converter's "\n".join leaves a complete .data without its final newline: the hint said to delete the frame
    path = tmp_path / "j.data"
    path.write_bytes(genuine(".data").rstrip(b"\n"))
    with pytest.raises(ValueError, match=r"if the file is complete, add the final newline \(echo >> .*j\.data\); "
                                         r"if it was cut, .* delete that line and its frame"):
        scan_data(path, None)
    with open(path, "ab") as fh:   # the hint followed: the file is read
        fh.write(b"\n")
    assert len(scan_data(path, None)) > 0
