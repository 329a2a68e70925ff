"""LAMMPS text dumps (``dump custom`` and ``dump local``; also LIGGGHTS'): frames found once by a scan for
the ``ITEM: TIMESTEP`` lines, one frame parsed at a time by the C text layer (:mod:`._text`).

The scan checks the structure of every frame (the ITEM header lines, the declared count against the rows
present, the last row's length), so a truncated or shortened frame is an error when the reader is made;
parsing a frame checks every value (numbers, integers where LAMMPS writes integers, row lengths). Errors
are ``ValueError`` naming the file, the frame (timestep) and the 1-based line. Gzipped dumps are
decompressed as a stream (zlib) into the same parser, resuming at checkpoints instead of the start.
"""
import math
import mmap
import os
import re

import numpy as np

from . import _text
from .files import is_gzip

__all__ = ["DumpIndex", "Table", "scan_dump"]

#: atom columns LAMMPS writes as integers (the reader uses id and type; the others are checked too)
ATOM_INT_COLUMNS = ("id", "type", "mol", "proc", "procp1", "ix", "iy", "iz")
#: atom columns that hold text (``dump custom ... element``): read apart, not as numbers
TEXT_COLUMNS = ("element",)

_INTEGER = re.compile(rb"[+-]?[0-9]+")
_FLAG = re.compile(rb"[pfsm]{2}")
_WHITESPACE = b" \t\r\n\v\f"


class Table:
    """The numeric table of a frame: a column by its header name as float64 (``tab[name]``), and the
    integer columns as int64 (``tab.integers(name)``)."""

    def __init__(self, values, columns, ints=None, int_columns=()):
        self.values = values
        self.index = {c: k for k, c in enumerate(columns)}
        self.integer_columns = {c: ints[:, k] for k, c in enumerate(int_columns)}

    def __contains__(self, name):
        return name in self.index

    def __getitem__(self, name):
        return np.asarray(self.values[:, self.index[name]], dtype=float)

    def integers(self, name):
        """An integer column as int64, exactly as written (only the columns read as integers)."""
        return self.integer_columns[name]


def _show(raw):
    text = bytes(raw).decode("utf-8", errors="backslashreplace")
    return repr(text if len(text) <= 80 else text[:77] + "...")


class _Lines:
    """The lines of buf[start:stop], one at a time, with their 1-based line numbers in the file."""

    def __init__(self, buf, start, stop, line, where):
        self.buf, self.pos, self.stop, self.line, self.where = buf, start, stop, line, where

    def next(self, after):
        """The next line (bytes, without the line end) and its number; running out is a truncated frame."""
        if self.pos >= self.stop:
            raise ValueError(f"{self.where(self.line)}: the frame ends after {after}; the file is truncated "
                             f"(a run stopped while writing?): remove the incomplete last frame or dump again")
        end = self.buf.find(b"\n", self.pos, self.stop)
        nxt = self.stop if end < 0 else end + 1
        raw = bytes(self.buf[self.pos:self.stop if end < 0 else end]).rstrip(b"\r")
        number = self.line
        self.pos, self.line = nxt, self.line + 1
        return raw, number


def _header(buf, start, stop, kind, path, line):
    """Parse the ITEM lines of the frame at buf[start:stop] (start: its 'ITEM: TIMESTEP' line, the
    file's line ``line``). Returns a dict: timestep, time, n, bounds, flags, triclinic, columns,
    rows (offset in buf of the first row) and rows_line (its line number)."""
    def where(number):  # before its timestep is read, a frame is named by its first line
        return f"{path} (the frame starting at line {line}), line {number}"

    lines = _Lines(buf, start, stop, line, where)
    raw, number = lines.next("its start")
    if raw.rstrip() != b"ITEM: TIMESTEP":
        raise ValueError(f"{where(number)}: expected 'ITEM: TIMESTEP', found {_show(raw)}; not a LAMMPS dump")
    raw, number = lines.next("'ITEM: TIMESTEP'")
    words = raw.split()
    if len(words) != 1 or not _INTEGER.fullmatch(words[0]):
        raise ValueError(f"{where(number)}: expected the timestep (one integer) after 'ITEM: TIMESTEP', found "
                         f"{_show(raw)}; the file is damaged or not a LAMMPS dump")
    head = {"timestep": int(words[0]), "time": None, "n": None, "bounds": None, "flags": None,
            "triclinic": False}
    timestep = head["timestep"]

    def where(number):  # noqa: F811 - from here on the timestep is known
        return f"{path} (timestep {timestep}), line {number}"

    lines.where = where
    count_item = b"ITEM: NUMBER OF ATOMS" if kind == "atoms" else b"ITEM: NUMBER OF ENTRIES"
    table_item = b"ITEM: ATOMS" if kind == "atoms" else b"ITEM: ENTRIES"
    raw, number = lines.next("the timestep")
    while True:
        if raw.startswith(b"ITEM: TIMESTEP"):
            raise ValueError(f"{where(number)}: a new frame starts before this one's "
                             f"'{table_item.decode()}' line; the frame is truncated")
        if raw.startswith(b"ITEM: TIME"):
            _exact(raw, b"ITEM: TIME", number, where)
            value, number = lines.next("'ITEM: TIME'")
            head["time"] = _number(value, number, "the time (one number) after 'ITEM: TIME'", where)
        elif raw.startswith(b"ITEM: NUMBER OF"):
            if not raw.startswith(count_item):
                other = "dump local" if kind == "atoms" else "dump custom (atoms)"
                raise ValueError(f"{path}: found {raw.decode(errors='replace').strip()!r}; this looks like a "
                                 f"{other} file")
            _exact(raw, count_item, number, where)
            value, number = lines.next(f"'{count_item.decode()}'")
            words = value.split()
            if len(words) != 1 or not _INTEGER.fullmatch(words[0]) or int(words[0]) < 0:
                raise ValueError(f"{where(number)}: expected the number of rows (one integer >= 0) after "
                                 f"'{count_item.decode()}', found {_show(value)}; the file is damaged")
            head["n"] = int(words[0])
        elif raw.startswith(b"ITEM: BOX BOUNDS"):
            words = raw.split()[3:]
            if [w.lower() for w in words[:3]] == [b"xy", b"xz", b"yz"]:
                head["triclinic"] = True
                words = words[3:]
            if len(words) != 3 or not all(_FLAG.fullmatch(w) for w in words):
                raise ValueError(f"{where(number)}: expected three boundary flags after 'ITEM: BOX BOUNDS' "
                                 f"(such as 'pp pp ff'), found {_show(raw)}; the file is damaged")
            head["flags"] = [w.decode() for w in words]
            rows = []
            for axis in "xyz":
                value, number = lines.next("'ITEM: BOX BOUNDS'")
                words = value.split()
                if len(words) != (3 if head["triclinic"] else 2):
                    raise ValueError(f"{where(number)}: expected the {axis} bounds "
                                     f"({3 if head['triclinic'] else 2} numbers) of 'ITEM: BOX BOUNDS', found "
                                     f"{_show(value)}; the file is damaged")
                rows.append([_number(w, number, f"the {axis} bounds", where) for w in words[:2]])
            head["bounds"] = np.array(rows)
        elif raw.startswith(table_item):
            columns = raw.decode("utf-8", errors="backslashreplace").split()[2:]
            if not columns:
                raise ValueError(f"{where(number)}: '{table_item.decode()}' names no columns; the file is damaged")
            twice = sorted({c for c in columns if columns.count(c) > 1}) if len(set(columns)) < len(columns) else []
            if twice:
                raise ValueError(f"{where(number)}: the column(s) {twice} appear twice in the header; "
                                 f"dump every column once")
            head["columns"] = columns
            break
        elif raw.startswith(b"ITEM: ATOMS") or raw.startswith(b"ITEM: ENTRIES"):
            other = "dump local" if kind == "atoms" else "dump custom (atoms)"
            raise ValueError(f"{path}: found {raw.decode(errors='replace').strip()!r}; this looks like a "
                             f"{other} file")
        elif raw.startswith(b"ITEM:"):
            # an item this reader does not use (ITEM: UNITS ...): skip its lines up to the next item
            while True:
                raw, number = lines.next(_show(raw))
                if raw.startswith(b"ITEM:"):
                    break
            continue
        else:
            raise ValueError(f"{where(number)}: expected an 'ITEM: ...' line of the frame header, found "
                             f"{_show(raw)}; the file is damaged")
        raw, number = lines.next(_show(raw))
    if head["n"] is None:
        raise ValueError(f"{path}: no '{count_item.decode()}' in the frame at timestep {timestep}")
    head["rows"], head["rows_line"] = lines.pos, lines.line
    return head


def _exact(raw, item, number, where):
    if raw.rstrip() != item:
        raise ValueError(f"{where(number)}: expected the line {item.decode()!r}, found {_show(raw)}; the file is "
                         f"damaged (its value belongs on the next line)")


def _number(raw, number, what, where):
    words = raw.split()
    value = None
    if len(words) == 1 and b"_" not in words[0]:
        try:
            value = float(words[0])
        except ValueError:
            pass
    if value is None or not math.isfinite(value):
        raise ValueError(f"{where(number)}: expected {what}, found {_show(raw)}; the file is damaged")
    return value


def _content_end(buf, start, stop):
    """The end of buf[start:stop] without its trailing whitespace (blank lines between frames)."""
    end = stop
    while end > start:
        lo = max(start, end - 4096)
        tail = bytes(buf[lo:end]).rstrip(_WHITESPACE)
        if tail:
            return lo + len(tail)
        end = lo
    return start


def _count_newlines(buf, start, stop):
    """The '\\n' bytes of buf[start:stop] (the C line count, 16 bytes at a time: a NumPy comparison made a
    boolean array of the frame first, a third of the scan's time)."""
    if stop <= start:
        return 0
    return _text.count_lines(buf, start, stop, threads=None) - (buf[stop - 1] != 10)  # buf[k]: an int


def _check_rows(buf, head, stop, path):
    """The frame's rows (from head["rows"] to stop) must be head["n"] lines, the last one complete.
    Returns the end of the rows (trailing blank lines excluded) and the line ends in [rows, stop)."""
    start, n, ts = head["rows"], head["n"], head["timestep"]
    end = _content_end(buf, start, stop)
    newlines = _count_newlines(buf, start, end)
    found = 0 if end == start else newlines + 1
    line = head["rows_line"] + max(found - 1, 0)
    if found != n:
        what = ("the frame is truncated or a row was lost (a run stopped while writing, or the file was cut)"
                if found < n else "rows were added or the count is wrong")
        raise ValueError(f"{path} (timestep {ts}), line {line}: expected {n} rows (the declared count), found "
                         f"{found}: {what}; dump the frame again or remove it")
    if n:
        last = buf.rfind(b"\n", start, end) + 1 if end > start else start
        words = len(bytes(buf[max(last, start):end]).split())
        if words != len(head["columns"]):
            raise ValueError(f"{path} (timestep {ts}), line {line}: the last row has {words} values, expected "
                             f"{len(head['columns'])}; the frame is truncated (a run stopped while writing, or "
                             f"the file was cut): dump the frame again or remove it")
    return end, newlines + _count_newlines(buf, end, stop)


class DumpIndex:
    """The frames of one LAMMPS text dump, found by :func:`scan_dump`: iterating gives (offset,
    timestep) per frame; :meth:`read` parses one frame. Pickles as its offsets (gzip checkpoints are
    rebuilt, once, when a pickled index first reads a frame)."""

    def __init__(self, path, kind, frames, compressed, checkpoints):
        self.path, self.kind = path, kind
        self.frames = [(offset, ts) for offset, ts, _, _ in frames]
        self.extent = {offset: (stop, line) for offset, _, stop, line in frames}
        self.compressed = compressed
        self._checkpoints = checkpoints
        _text.hold_spare(self)

    def __iter__(self):
        return iter(self.frames)

    def __len__(self):
        return len(self.frames)

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_checkpoints"] = None
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        _text.hold_spare(self)

    def read(self, offset, int_columns=(), integral_columns=()):
        """The frame at ``offset``: dict with timestep, time (or None), box bounds/flags, column names,
        n (rows) and data (a :class:`Table`; the columns named in ``int_columns`` and the atom ID/type
        columns as int64 too). ``integral_columns``: columns of whole numbers that LAMMPS may write in
        its float format (the atom IDs of a dump local come from double-valued computes: '15' or
        '15.000000'): read as numbers, then each must be a whole number (exact in a double), as int64."""
        stop, line = self.extent[offset]
        if self.compressed:
            if self._checkpoints is None:
                self._checkpoints = _text.gzip_checkpoints(self.path)
            buf = _text.read_range(self.path, offset, stop, self._checkpoints)
            return _read_frame(buf, 0, len(buf), self.kind, self.path, line, int_columns, integral_columns)
        # one frame's text in memory (a map of the file would crash the process if the file were cut while
        # mapped), in anonymous memory with huge pages where the system has them, reused from frame to frame
        # (_text.frame_text): a 60 MB frame read into bytes costs 15,000 page faults (35-50 ms), into a new
        # buffer 30 and the kernel's zeroing (15 ms in all), into the spare 9 ms
        size = stop - offset
        with _text.frame_text(self.path, offset, stop, compressed=False) as (buf, got):
            if got != size:
                raise ValueError(f"{self.path}: the file changed since it was scanned (the frame at timestep "
                                 f"{dict(self.frames)[offset]} ends early); open the reader again")
            return _read_frame(buf, 0, size, self.kind, self.path, line, int_columns, integral_columns)


def _read_frame(buf, start, stop, kind, path, line, int_columns, integral_columns=()):
    head = _header(buf, start, stop, kind, path, line)
    columns, n, ts = head["columns"], head["n"], head["timestep"]
    # the scan checked the row count; parse_table checks it again (nrows), so the file may not have changed
    end = _content_end(buf, head["rows"], stop)
    wanted = set(int_columns) | (set(ATOM_INT_COLUMNS) if kind == "atoms" else set())
    ints = [k for k, c in enumerate(columns) if c in wanted]
    if any(c in TEXT_COLUMNS for c in columns):
        head["data"] = _text_columns(buf, head, end, path, ints)
    else:
        def parse(int_columns):
            # reuse: the table in memory kept from an earlier frame (not faulted in and zeroed again); the readers
            # take copies or gathers of its columns, and while anything views it, it is not reused
            table = _text.parse_table(buf, head["rows"], end, len(columns), int_columns=int_columns, nrows=n,
                                      allow_nonfinite=False, name=path, frame=f"timestep {ts}",
                                      first_line=head["rows_line"], column_names=columns, reuse=True)
            return Table(table.values, columns, table.ints, [columns[k] for k in int_columns])

        head["data"] = None
        integral = [k for k, c in enumerate(columns) if c in integral_columns and c not in wanted]
        if integral:
            # whole numbers written as integers (the usual output) parse as int64 in the same pass, instead
            # of floats checked afterwards; a float format ('15.000000'), a value from 2**53 on (not an exact
            # double, so not a double compute's ID) or a damaged file goes the general way below, which
            # accepts or reports it as before
            try:
                table = parse(sorted(ints + integral))
                if all(_within_doubles(table.integers(columns[k])) for k in integral):
                    head["data"] = table
            except ValueError:
                pass
        if head["data"] is None:
            table = None  # (the first try's table no longer holds the spare memory the parse below may reuse)
            try:
                head["data"] = parse(ints)
            except ValueError as exc:
                raise ValueError(f"{exc}{_hint(str(exc), columns, ints)}") from None
    for name in integral_columns:
        if name in head["data"] and name not in head["data"].integer_columns:
            head["data"].integer_columns[name] = _whole_numbers(head["data"][name], name, head, path)
    head["first_line"] = head["rows_line"]     # (the 1-based line of the first row: errors name a row's line)
    del head["rows"], head["rows_line"]  # offsets in buf are not part of the frame's description
    return head


def _within_doubles(ints):
    """Whether every value is in (-2**53, 2**53) (exact in a double): two reductions, no boolean arrays."""
    return ints.size == 0 or (int(ints.min()) > -2 ** 53 and int(ints.max()) < 2 ** 53)


def _whole_numbers(column, name, head, path):
    """A float column of whole numbers as int64; a fraction or a value from 2**53 on (maybe rounded) is an error."""
    bad = np.flatnonzero((column != np.floor(column)) | (np.abs(column) >= 2.0 ** 53))
    if bad.size:
        k = int(bad[0])
        raise ValueError(f"{path} (timestep {head['timestep']}), line {head['rows_line'] + k}, column "
                         f"{head['columns'].index(name) + 1} ({name!r}): expected an atom ID (a whole number), "
                         f"found {column[k]!r}; the column is not the one named (check pair_values / "
                         f"pair_columns) or the file is damaged")
    return column.astype(np.int64)


def _hint(message, columns, ints):
    if any(f"({columns[k]!r})" in message for k in ints) and ("integer" in message or "number" in message):
        return ("; LAMMPS writes this column as integers: a '%g'-style float format (dump_modify format) loses "
                "large IDs, or the file is damaged")
    if "not a number" in message:
        return "; the file is damaged (or the column holds text: dump numeric columns only)"
    return "; the file is damaged: dump the frame again"


def _text_columns(buf, head, end, path, ints):
    """A frame with text columns (element names): the numeric columns checked by the C parser one row
    at a time is not worth it here; split in Python, converting the numeric columns with the same rules."""
    columns, n, ts = head["columns"], head["n"], head["timestep"]
    text = bytes(buf[head["rows"]:end])
    rows = text.split(b"\n") if n else []
    values = np.zeros((n, len(columns)))
    int_values = np.zeros((n, len(ints)), np.int64)
    numeric = [k for k, c in enumerate(columns) if c not in TEXT_COLUMNS]
    for r, row in enumerate(rows):
        words = row.split()
        line = head["rows_line"] + r
        if len(words) != len(columns):
            raise ValueError(f"{path} (timestep {ts}), line {line}: expected {len(columns)} values, found "
                             f"{len(words)}: {_show(row)}; the file is damaged")
        for k in numeric:
            table = _text.parse_table(words[k] + b"\n", ncols=1, int_columns=(0,) if k in ints else (),
                                      name=path, frame=f"timestep {ts}", first_line=line,
                                      column_names=[columns[k]])
            values[r, k] = table.values[0, 0]
            if k in ints:
                int_values[r, ints.index(k)] = table.ints[0, 0]
    return Table(values, columns, int_values, [columns[k] for k in ints])


def scan_dump(path, kind):
    """The frames of a LAMMPS text dump (plain or gzip), their structure checked: a :class:`DumpIndex`."""
    path = os.fspath(path)
    if os.path.isdir(path):
        raise IsADirectoryError(f"{path}: a directory; expected a LAMMPS dump file")
    if not os.path.exists(path):
        raise FileNotFoundError(f"{path}: no such file; expected a LAMMPS dump")
    if is_gzip(path):
        checkpoints = []
        chunks = _text.iter_chunks(path, checkpoints=checkpoints)
        frames, offset, last = [], 0, b""
        for piece, line in _text.iter_frames(path, b"ITEM: TIMESTEP", chunks=chunks):
            frames += _scan_frames(piece, [0] if piece.startswith(b"ITEM: TIMESTEP") else [], len(piece), kind,
                                   path, line, offset)
            offset += len(piece)
            last = piece[-1:] or last
        _check_any(frames, offset, path)
        _check_final_newline(last, frames, path)
        return DumpIndex(path, kind, frames, True, checkpoints)
    size = os.path.getsize(path)
    if size == 0:
        _check_any([], 0, path)
    with open(path, "rb") as f:
        mm = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
    try:
        starts = [int(s) for s in _text.find_lines(mm, b"ITEM: TIMESTEP")]
        frames = _scan_frames(mm, starts, size, kind, path, 1, 0)
        last = mm[size - 1:size]
    finally:
        try:
            mm.close()
        except BufferError:  # an error's traceback still views it: it is freed with the traceback
            pass
    _check_any(frames, size, path)
    _check_final_newline(last, frames, path)
    return DumpIndex(path, kind, frames, False, None)


def _check_final_newline(last, frames, path):
    """LAMMPS ends every line; a file whose last line has no line end was cut (and its last value may
    still parse, '2.5' cut to '2.'), so it is refused."""
    if last != b"\n":
        _, timestep, _, _ = frames[-1]
        raise ValueError(f"{path} (timestep {timestep}), line {_last_line(path)}: the last line has no line end: "
                         f"the file is truncated (a run stopped while writing, or a copy was cut); LAMMPS ends "
                         f"every line. Dump the frame again, or remove the incomplete last line")


def _last_line(path):
    count, ends = 0, True
    for chunk in _text.iter_chunks(path):
        count += chunk.count(b"\n")
        ends = chunk.endswith(b"\n")
    return count + (0 if ends else 1)


def _check_any(frames, size, path):
    if not frames:
        what = "empty" if size == 0 else "blank (whitespace only)"
        raise ValueError(f"{path}: the file is {what}; expected a LAMMPS dump (frames starting with "
                         f"'ITEM: TIMESTEP'): check the path, or whether the run wrote its dump")


def _scan_frames(buf, starts, size, kind, path, line, base):
    """(offset + base, timestep, stop + base, line) of each frame of buf starting at ``starts``; text
    before the first frame must be blank."""
    first = starts[0] if starts else size
    if _content_end(buf, 0, first) > 0:
        lead = bytes(buf[0:min(first, 60)])
        raise ValueError(f"{path}, line {line}: expected 'ITEM: TIMESTEP' at byte {base}, got {lead!r}; this is "
                         f"not a LAMMPS dump (or its start is damaged)")
    out = []
    line += _count_newlines(buf, 0, first) if first else 0
    bounds = starts + [size]
    for a, b in zip(bounds[:-1], bounds[1:]):
        head = _header(buf, a, b, kind, path, line)
        _, newlines = _check_rows(buf, head, b, path)
        out.append((a + base, head["timestep"], b + base, line))
        line = head["rows_line"] + newlines
    return out
