"""Numeric text tables at disk speed: the Python face of the C text layer (csrc/cg_text.h).

``parse_table`` turns a byte range of a dump (bytes, bytearray, mmap or memoryview; nothing is
copied) into a float64 table, and the integer columns also into an int64 table, in one C pass
with the GIL released. ``find_lines`` returns the offsets of the lines that start with a prefix
(``b"ITEM: TIMESTEP"``), for lazy frame access. ``iter_frames`` streams a plain or gzipped file
frame by frame (zlib, never a temporary file).

Errors are ``ValueError`` naming the file (``name``), the frame (``frame``, e.g. "timestep 4500")
and the 1-based line of the file, with the offending token or line quoted.
"""
import contextlib
import mmap
import os
import threading
import weakref
import zlib
from typing import NamedTuple

import numpy as np

from .. import _engine, _threads

# the C status codes of the text layer (cg.h); the messages come from cg_strerror
_ROW_LENGTH = 9
_ROWS = 10


class Table(NamedTuple):
    """A parsed table: ``values`` (rows, ncols) float64 with every column, ``ints`` (rows,
    len(int_columns)) int64 with the integer columns in ``int_columns`` order, ``end`` the offset in
    data where the table ended."""

    values: np.ndarray
    ints: np.ndarray
    end: int  # offset in data where the table ended (stop, or with stop_after_rows the next line's start)


def _quote(raw):
    """A token or line for a message: its bytes shown as Python would, clipped."""
    text = bytes(raw).decode("utf-8", errors="backslashreplace")
    return repr(text if len(text) <= 80 else text[:77] + "...")


def _line_of(data, offset):
    """1-based line number of byte ``offset`` of ``data`` (newlines before it, counted in blocks)."""
    view = np.frombuffer(data, dtype=np.uint8, count=offset) if offset else np.zeros(0, np.uint8)
    block = 1 << 24
    return 1 + sum(int(np.count_nonzero(view[i:i + block] == 10)) for i in range(0, offset, block))


def _size(data):
    """Bytes in data (bytes, bytearray, mmap, memoryview), or the TypeError the C binding would give."""
    try:
        with memoryview(data) as view:
            return view.nbytes
    except TypeError:
        raise TypeError(f"data: expected bytes, bytearray, mmap or a contiguous memoryview, "
                        f"got {type(data).__name__}") from None


def _where(name, frame, line):
    return f"{name}{f' ({frame})' if frame else ''}, line {line}"


def _thread_count(threads):
    """threads as the text functions take it: a positive count, or None for the core's setting."""
    if threads is None:
        return _threads.get_num_threads()
    if (isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1
            or threads > _threads.MAX_THREADS):
        raise ValueError(f"threads: expected a positive number of threads (at most {_threads.MAX_THREADS}) or None, "
                         f"got {threads!r}")
    return int(threads)


def parse_table(data, start=0, stop=None, ncols=None, *, int_columns=(), nrows=None, skip_blank=False,
                stop_after_rows=False, allow_nonfinite=False, name="<data>", frame=None, first_line=None,
                column_names=None, threads=None, reuse=False):
    """Parse ``data[start:stop]`` as rows of exactly ``ncols`` whitespace-separated numbers.

    int_columns: column indices that must hold integers (exact int64; '1.0', 'nan' or values
    outside int64 are errors). nrows: the count the file declares; a different count of rows is
    an error (None: as many as there are). stop_after_rows: the table ends after ``nrows`` rows
    (frames delimited only by a declared count, as in MercuryDPM .data files; ``Table.end`` is where
    the next frame starts); fewer rows are still an error. skip_blank: blank lines are skipped instead of being an
    error. allow_nonfinite: nan/inf values are returned instead of being an error. name, frame:
    how the file and the frame are called in messages. first_line: the 1-based line number of
    ``start`` in the file, if the caller knows it (otherwise counted, on errors only). column_names:
    the columns' names, quoted beside their numbers in messages. threads: how many threads may parse a
    large range (cut at line starts; the same values and errors for any count); None: the core's setting
    (:func:`cgbound.get_num_threads`). reuse: the tables are views of memory kept from an earlier table (a
    spare table, :func:`hold_spare`) instead of new arrays, whose pages the kernel must fault in and zero (a
    W1 .fstat frame's values and ints: 80 MB), if they take SPARE_TABLE_MIN bytes or more; for callers that take what
    they keep from the table (copies, gathers) and drop it. Memory is reused only once nothing views it any
    more, so an array kept from a table is never overwritten (a kept view only costs the next table new
    memory).

    Returns a ``Table`` (values, ints).
    """
    stop = _size(data) if stop is None else stop
    if ncols is None or isinstance(ncols, bool) or not isinstance(ncols, (int, np.integer)) or ncols < 1:
        raise ValueError(f"ncols: expected a positive number of columns, got {ncols!r}")
    ncols = int(ncols)
    mask = bytearray(ncols)
    for c in int_columns:
        if isinstance(c, bool) or not isinstance(c, (int, np.integer)) or not 0 <= c < ncols:
            raise ValueError(f"int_columns: expected column indices in [0, {ncols}), got {c!r}")
        mask[int(c)] = 1
    order = sorted({int(c) for c in int_columns})
    if list(int_columns) != order:
        raise ValueError(f"int_columns: expected increasing distinct column indices, got {tuple(int_columns)!r}")
    if nrows is not None and (isinstance(nrows, bool) or not isinstance(nrows, (int, np.integer)) or nrows < 0):
        raise ValueError(f"nrows: expected a non-negative row count or None, got {nrows!r}")
    max_rows = -1 if nrows is None else int(nrows)
    if stop_after_rows and nrows is None:
        raise ValueError("stop_after_rows: needs nrows (the declared row count)")
    flags = (1 if skip_blank else 0) | (2 if stop_after_rows else 0)
    threads = _thread_count(threads)

    lease = _TableLease() if reuse else None
    try:
        values, ints, found, end, error, nonfinite = _engine.text_parse_table(data, start, stop, ncols, bytes(mask),
                                                                               max_rows, flags, threads, 0, lease)
    finally:
        if lease is not None:
            lease.give_back()
    status, message, line, column, offset, length = error

    def column_label(column):
        if column_names is not None and 0 <= column < len(column_names):
            return f"column {column + 1} ({column_names[column]!r})"
        return f"column {column + 1}"

    def line_number(relative_line):
        base = first_line if first_line is not None else _line_of(data, start)
        return base + relative_line

    if status:
        where = _where(name, frame, line_number(line))
        raw = memoryview(data)[start + offset:start + offset + length]
        if status == _ROW_LENGTH:
            if length == 0:
                got = "no values (a blank line)"
            else:
                got = f"{column} value{'' if column == 1 else 's'}" if column < ncols else "more values"
            raise ValueError(f"{where}: expected {ncols} values, found {got}: {_quote(raw)}")
        if status == _ROWS:
            raise ValueError(f"{where}: the table should end after {nrows} rows (the declared count), "
                             f"but it continues: {_quote(raw)}")
        raise ValueError(f"{where}, {column_label(column)}: {message}: {_quote(raw)}")
    if nrows is not None and found != nrows:
        raise ValueError(f"{_where(name, frame, line_number(_lines_in(data, start, stop)))}: expected "
                         f"{nrows} rows (the declared count), found {found}: the table is truncated")
    count, line, column, offset, length = nonfinite
    if count and not allow_nonfinite:
        raw = memoryview(data)[start + offset:start + offset + length]
        raise ValueError(f"{_where(name, frame, line_number(line))}, {column_label(column)}: non-finite value "
                         f"{_quote(raw)} ({count} nan/inf values in the table); expected finite numbers")
    if found < len(values):  # blank lines were skipped: the tables shrunk in place (a copy of a 70 MB frame: 20+ ms)
        if values.base is not None:  # views of a spare table: their first rows
            values, ints = values[:found], ints[:found]
        else:
            values, ints = _shrunk(values, found), _shrunk(ints, found)
    return Table(values, ints, end)


def _shrunk(table, rows):
    """table's first rows, its memory given back without a copy (realloc shrinks a large block in place); a copy
    if something else holds a reference to it (e.g. a debugger), as resize then refuses."""
    try:
        table.resize((rows, table.shape[1]))
        return table
    except ValueError:
        return table[:rows].copy()


def _lines_in(data, start, stop):
    """Index (0-based, from start) of the last line of data[start:stop]."""
    view = np.frombuffer(data, dtype=np.uint8, count=stop - start, offset=start)
    n = int(np.count_nonzero(view == 10))
    return max(n - 1, 0) if len(view) and view[-1] == 10 else n


def find_lines(data, prefix, start=0, stop=None, threads=None):
    """Byte offsets (from the start of data, int64) of the lines of data[start:stop] that begin with prefix,
    searched on up to ``threads`` threads (None: the core's setting) for ranges of 4 MB and more: the first
    pass over a file's fresh mmap is mostly page faults, which the threads share."""
    if isinstance(prefix, str):
        prefix = prefix.encode()
    stop = _size(data) if stop is None else stop
    threads = _thread_count(threads)
    return _engine.text_find_lines(data, start, stop, prefix, threads)


def count_lines(data, start=0, stop=None, threads=1):
    """The lines of data[start:stop] (its newlines, plus one if it is not empty and does not end with one),
    counted by the C text layer 16 bytes at a time, on up to ``threads`` threads (None: the core's setting)
    for ranges of 4 MB and more; no offsets are kept."""
    stop = _size(data) if stop is None else stop
    threads = _thread_count(threads)
    return _engine.text_count_lines(data, start, stop, threads)


def _is_gzip(path):
    with open(path, "rb") as f:
        return f.read(2) == b"\x1f\x8b"


def iter_chunks(path, chunk_size=1 << 22, checkpoints=None, spacing=1 << 24, resume=None):
    """The bytes of the file, decompressed as a stream if it is gzip (by its magic number), in chunks.

    checkpoints: a list to which, for gzip input, ``(decompressed offset, compressed offset, zlib
    state)`` is appended about every ``spacing`` decompressed bytes, so that :func:`read_range` can
    resume there instead of decompressing from the start. resume: one such checkpoint to start from
    (the chunks then begin at its decompressed offset).
    """
    if not _is_gzip(path):
        with open(path, "rb") as f:
            if resume is not None:
                f.seek(resume[0])
            while chunk := f.read(chunk_size):
                yield chunk
        return
    with open(path, "rb") as f:
        produced, inflate = 0, zlib.decompressobj(wbits=47)
        if resume is not None:
            produced, consumed, state = resume
            f.seek(consumed)
            inflate = state.copy()
        in_member = resume is not None
        last = None
        try:
            while raw := f.read(chunk_size):
                data = raw
                # checkpoint where the state holds no unconsumed input: a copy taken mid-chunk keeps its
                # unconsumed_tail (up to chunk_size bytes) alive with it
                if checkpoints is not None and (last is None or produced - last >= spacing):
                    checkpoints.append((produced, f.tell() - len(data), inflate.copy()))
                    last = produced
                while data:
                    in_member = True
                    out = inflate.decompress(data, chunk_size)  # bounded output: one chunk at a time
                    if out:
                        produced += len(out)
                        yield out
                    if inflate.eof:  # a member ended; another may follow (concatenated gzip files)
                        data = inflate.unused_data
                        inflate = zlib.decompressobj(wbits=47)
                        in_member = False
                    else:
                        data = inflate.unconsumed_tail
            if in_member:
                out = inflate.flush()
                if out:
                    yield out
        except zlib.error as exc:
            raise ValueError(f"{os.fspath(path)}: damaged gzip data ({exc}); the file is corrupt: "
                             f"compress it again from the original") from None
        if in_member and not inflate.eof:
            raise ValueError(f"{os.fspath(path)}: the gzip data ends early (a truncated file); copy or "
                             f"compress it again from the original") from None


def gzip_checkpoints(path, spacing=1 << 24):
    """One pass over a gzip file collecting the checkpoints of :func:`iter_chunks` (output discarded)."""
    checkpoints = []
    for _ in iter_chunks(path, checkpoints=checkpoints, spacing=spacing):
        pass
    return checkpoints


def frame_buffer(size):
    """A writable buffer of ``size`` (> 0) bytes for a frame's text: an anonymous map (``find``, ``rfind``, slices
    giving bytes, ``re`` and the buffer protocol, but not ``count`` or ``split``), with transparent huge pages
    where the system has them. A new bytes object of a 60 MB frame costs 15,000 page faults and the kernel's
    zeroing (35-50 ms, three times the copy from the page cache); this, 30 (11 ms in all)."""
    try:
        buf = mmap.mmap(-1, size, flags=mmap.MAP_PRIVATE)
    except (AttributeError, TypeError):  # no flags (Windows)
        return mmap.mmap(-1, size)
    if hasattr(mmap, "MADV_HUGEPAGE"):
        try:
            buf.madvise(mmap.MADV_HUGEPAGE)
        except OSError:  # a kernel without transparent huge pages: small pages then
            pass
    return buf


#: the frame buffer kept for the next frame's text (:func:`frame_text`): a new buffer's pages are faulted and zeroed
#: by the kernel as the file is copied in (``perf``: 7 % of a MercuryDPM read in ``clear_page``, 6 ms per 60 MB
#: frame), the spare's already were. At most one, of at most SPARE_MAX bytes, and only while a reader that reads
#: frames is alive (:func:`hold_spare`): memory grows by one frame's text while files are open, and is given back
#: when the last of their readers is gone.
_spare = []
#: reentrant: a reader's finalizer (_release_spare) may run inside a locked block on the same thread, when an
#: allocation there starts the cyclic garbage collector and it frees a reader held in a cycle
_spare_lock = threading.RLock()
_spare_holders = 0
SPARE_MAX = 1 << 29


def hold_spare(reader):
    """Let frame_text keep a spare buffer, and parse_table(reuse=True) spare tables, for as long as ``reader`` lives
    (readers call it when made)."""
    global _spare_holders
    with _spare_lock:
        _spare_holders += 1
    weakref.finalize(reader, _release_spare)


def _release_spare():
    global _spare_holders
    with _spare_lock:
        _spare_holders -= 1
        drop = _spare.pop() if _spare and _spare_holders <= 0 else None
        tables = _spare_tables[:] if _spare_holders <= 0 else []
        if tables:
            _spare_tables.clear()
    if drop is not None:
        _close(drop)
    del tables  # (the spare tables' memory is freed with the last reference: at once, unless arrays still view it)


def _after_fork_in_child():
    """A child process starts without the parent's spare (its pages would be copied on the first write) and with a
    new lock (a thread of the parent may have held the old one at the fork)."""
    global _spare_lock
    _spare_lock = threading.RLock()
    _spare.clear()
    _spare_tables.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


def _close(buf):
    try:
        buf.close()
    except BufferError:  # an error's traceback still views it: it is freed with the traceback
        pass


def _take_buffer(size):
    """A frame_buffer of at least ``size`` bytes: the spare if it is large enough, else a new one."""
    with _spare_lock:
        buf = _spare.pop() if _spare else None
    if buf is not None and len(buf) >= size:
        return buf
    if buf is not None:
        _close(buf)
    # room for a larger frame than this one (frames of one file differ by a few bytes, or by some rows), in whole
    # huge pages
    return frame_buffer(-(-(size + (size >> 4)) // (1 << 21)) << 21)


def _keep_buffer(buf):
    """Keep buf as the spare (the larger of it and the one kept, up to SPARE_MAX bytes); close the other."""
    if len(buf) > SPARE_MAX:
        _close(buf)
        return
    with _spare_lock:
        if _spare_holders <= 0 or (_spare and len(_spare[0]) >= len(buf)):
            drop = buf
        else:
            drop = _spare.pop() if _spare else None
            _spare.append(buf)
    if drop is not None:
        _close(drop)


#: the memory kept for parse_table(reuse=True)'s tables, most recently used first: at most SPARE_TABLES blocks (a
#: LAMMPS frame parses an atoms table, then a pairs table while the atoms table is still in use) of at most
#: SPARE_MAX bytes each, kept only while a reader that reads frames is alive (:func:`hold_spare`), as the text's
#: spare. A new table's pages are faulted in and zeroed by the kernel as the parser first writes them (``perf``:
#: 11 % of a 2-thread .fstat parse); a kept block's were already.
_spare_tables = []
SPARE_TABLES = 2
#: tables smaller than this are new arrays even with reuse: the C library recycles their memory as it is (glibc's
#: threshold for mapping a block of its own grows, as blocks are freed, up to 32 MB); kept, they would only keep
#: memory from the arrays made after them (W1's LAMMPS tables, 8-11 MB: 2-4 % slower kept, 1 thread)
SPARE_TABLE_MIN = 1 << 25


class _SpareTable:
    """A block of memory for tables (a NumPy byte array: allocated as NumPy allocates the new tables, so that the
    C library recycles a block of up to 32 MB given back with a reader for the next reader, as it did the tables,
    and a larger one gets huge pages), and a weak reference to the memoryview of it lent to the last tables made
    from it: the binding holds an export of that memoryview for as long as any array views those tables (their
    base, which is not itself a buffer), so the block is free for new tables once that memoryview is gone."""

    __slots__ = ("buf", "lent")

    def __init__(self, nbytes):
        # room for a larger table than this one (frames of one file differ by some rows)
        self.buf, self.lent = np.empty(nbytes + (nbytes >> 4), np.uint8), None

    def free(self):
        return self.lent is None or self.lent() is None


class _TableLease:
    """parse_table's out= callable: memory of at least nbytes for a table, from a free spare block or new; give_back
    keeps the block as a spare for later tables (it is only lent again once the tables made now are gone)."""

    __slots__ = ("spare",)

    def __init__(self):
        self.spare = None

    def __call__(self, nbytes):
        if nbytes < SPARE_TABLE_MIN:
            return None
        with _spare_lock:
            spare = None  # the smallest free block that fits
            for s in _spare_tables:
                if len(s.buf) >= nbytes and s.free() and (spare is None or len(s.buf) < len(spare.buf)):
                    spare = s
            if spare is not None and spare in _spare_tables:  # (a finalizer run meanwhile may have emptied the list)
                _spare_tables.remove(spare)
        if spare is None:
            spare = _SpareTable(nbytes)
        self.spare = spare
        view = memoryview(spare.buf)
        spare.lent = weakref.ref(view)
        return view

    def give_back(self):
        spare, self.spare = self.spare, None
        if spare is None:
            return
        with _spare_lock:
            if _spare_holders > 0 and len(spare.buf) <= SPARE_MAX:
                _spare_tables.insert(0, spare)
                del _spare_tables[SPARE_TABLES:]


@contextlib.contextmanager
def frame_text(path, start, stop, checkpoints=None, compressed=None):
    """Bytes [start, stop) of the file's (decompressed, if gzip) content as ``(buf, got)``: the text is
    ``buf[:got]`` (got < stop - start if the file was cut since it was scanned: the caller says so). Only the
    first ``got`` bytes are the range: a plain file's text goes into the spare frame buffer when it is large
    enough (the rest of it holds an earlier frame's text), which is kept again for the next frame when the block
    ends without an error. gzip: as :func:`read_range`. compressed: whether the file is gzip, if the caller knows
    (None: its magic number is read)."""
    size = max(stop - start, 0)
    if size == 0 or (_is_gzip(path) if compressed is None else compressed):
        data = read_range(path, start, stop, checkpoints)
        yield data, len(data)
        return
    buf = _take_buffer(size)
    try:
        with open(path, "rb") as f, memoryview(buf) as whole, whole[:size] as part:
            f.seek(start)
            got = f.readinto(part) or 0
        yield buf, got
    except BaseException:
        _close(buf)
        raise
    _keep_buffer(buf)


def read_range(path, start, stop, checkpoints=None):
    """Bytes [start, stop) of the file's (decompressed, if gzip) content: a :func:`frame_buffer` of exactly that
    size (b"" for an empty range; it may be shorter if the file was cut), or a bytearray for gzip.

    For gzip input, decompression resumes at the last of ``checkpoints`` (from :func:`iter_chunks`)
    at or before ``start``; without them it starts at the beginning. Memory: the range plus a chunk.
    """
    if not _is_gzip(path):
        size = max(stop - start, 0)
        if size == 0:
            return b""
        buf = frame_buffer(size)
        with open(path, "rb") as f:
            f.seek(start)
            got = f.readinto(buf)
        return buf if got == size else buf[:got]  # cut since it was scanned: bytes, shorter (the caller says so)
    resume = None
    for point in checkpoints or ():
        if point[0] <= start:
            resume = point
        else:
            break
    out = bytearray()
    position = resume[0] if resume is not None else 0
    for chunk in iter_chunks(path, resume=resume):
        end = position + len(chunk)
        if end > start:
            out += chunk[max(start - position, 0):stop - position]
        position = end
        if position >= stop:
            break
    return out


def iter_frames(path, prefix, chunk_size=1 << 22, chunks=None):
    """Stream a plain or gzipped file as frames: yields (frame bytes, 1-based line of its first line).

    A frame runs from a line starting with ``prefix`` to the next one (or the end). Text before the
    first such line is yielded as its own piece if there is any. Memory: one frame plus one chunk.
    chunks: the file's bytes as an iterable of chunks (default :func:`iter_chunks` of path).
    """
    if isinstance(prefix, str):
        prefix = prefix.encode()
    buf = bytearray()
    scan_from = 0  # a line start up to which buf has been searched
    starts = []  # frame starts found in buf
    line = 1
    for chunk in iter_chunks(path, chunk_size) if chunks is None else chunks:
        buf += chunk
        found = find_lines(buf, prefix, scan_from, len(buf))
        starts.extend(int(s) for s in found if not starts or s != starts[-1])
        last_newline = buf.rfind(b"\n", scan_from)
        if last_newline >= 0:
            scan_from = last_newline + 1
        # emit every frame that the next frame start closes
        if len(starts) >= 2 or (starts and starts[0] > 0):
            bounds = ([0] if starts[0] > 0 else []) + starts
            for a, b in zip(bounds[:-1], bounds[1:]):
                frame = bytes(buf[a:b])
                yield frame, line
                line += frame.count(b"\n")
            cut = bounds[-1]
            del buf[:cut]
            scan_from -= cut
            starts = [0]
    if buf:
        yield bytes(buf), line
