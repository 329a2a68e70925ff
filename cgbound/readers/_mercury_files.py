"""MercuryDPM text files (layouts in cgbound/readers/mercury.py): frames of ``.data`` and ``.fstat``
found by one fast scan (the C text layer's line finder), each frame parsed in one C pass when it is
read; the keys of a ``.restart``.

Structure is checked as the files are scanned and read: a ``.data`` frame holds the particle lines
its header declares, each with the same number of values; a ``.fstat`` frame has exactly three
``#`` header lines, its lines carry the frame's time, and the last frame is not cut off. Errors are
ValueErrors naming the file, the frame (time) and the 1-based line, with the likely cause.
"""
import contextlib
import mmap
import os
import re
import shlex

import numpy as np

from ._text import count_lines, find_lines, frame_text, gzip_checkpoints, iter_chunks, parse_table
from .files import is_gzip

__all__ = ["DATA_COLUMNS", "FSTAT_COLUMNS", "LINE_TIME_RTOL", "fstat_rows", "read_particles",
           "read_restart", "scan_data", "scan_fstat"]

DATA_COLUMNS = {3: 14, 2: 8}
DATA_SPECIES = {3: 13, 2: 7}     # the species column of a .data particle line
FSTAT_COLUMNS = 16
FSTAT_HEADER_LINES = 3
LINE_TIME_RTOL = 1e-9            # a .fstat line's time against its frame's (both written by the same stream)
_TEXT = re.compile(rb"\S")       # the first byte that is not whitespace


#: gzip checkpoints of the files scanned, by (real path, mtime, size): a frame read resumes decompressing at
#: the nearest one instead of the start (without them reading every frame of a gzipped file is quadratic)
_GZIP_CHECKPOINTS = {}
_GZIP_CHECKPOINTS_KEPT = 16


def _gzip_key(path):
    st = os.stat(path)
    return os.path.realpath(path), st.st_mtime_ns, st.st_size


def _remember_checkpoints(path, checkpoints):
    if len(_GZIP_CHECKPOINTS) >= _GZIP_CHECKPOINTS_KEPT:
        _GZIP_CHECKPOINTS.pop(next(iter(_GZIP_CHECKPOINTS)))
    _GZIP_CHECKPOINTS[_gzip_key(path)] = checkpoints


#: bytes per window of a scan: the scan holds one window (and its line offsets), never the whole file
SCAN_WINDOW = 1 << 24


def scan_windows(path, size=None, line_starts=True):
    """The file as windows of whole lines: yields (data, lo, hi, base, first_line, starts).

    ``data[lo:hi]`` is the window (an mmap of a plain file, or a decompressed piece of a gzip file), ``base``
    its offset in data's coordinates subtracted from the file's (0 for an mmap), ``first_line`` the 1-based
    line number of ``lo``, ``starts`` the offsets in data of the window's line starts. Without
    ``line_starts``, starts and first_line are None (a caller that numbers lines counts them itself, once).
    Each window but the last ends with a newline; a line longer than ``size`` makes a longer window. Memory:
    one window.
    """
    size = SCAN_WINDOW if size is None else size

    def lines(data, lo, hi):
        return find_lines(data, b"", lo, hi) if line_starts else None

    line = 1 if line_starts else None
    if is_gzip(path):
        checkpoints, buf, base = [], bytearray(), 0
        for chunk in iter_chunks(path, checkpoints=checkpoints):
            buf += chunk
            if len(buf) < size:
                continue
            cut = buf.rfind(b"\n") + 1
            if cut == 0:       # no line ends in the window yet: read on
                continue
            window = bytes(buf[:cut])
            del buf[:cut]
            starts = lines(window, 0, cut)
            yield window, 0, cut, base, line, starts
            base, line = base + cut, (line + len(starts) if line_starts else None)
        _remember_checkpoints(path, checkpoints)
        if buf:
            window = bytes(buf)
            yield window, 0, len(window), base, line, lines(window, 0, len(window))
        return
    with open(path, "rb") as fh:
        total = os.fstat(fh.fileno()).st_size
        if total == 0:
            return
        mm = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
        try:
            lo = 0
            while lo < total:
                hi = min(lo + size, total)
                if hi < total:
                    cut = mm.rfind(b"\n", lo, hi)
                    if cut < 0:
                        cut = mm.find(b"\n", hi)
                    hi = total if cut < 0 else cut + 1
                starts = lines(mm, lo, hi)
                yield mm, lo, hi, 0, line, starts
                line = (line + len(starts)) if line_starts else None
                lo = hi
        finally:
            try:
                mm.close()
            except BufferError:   # an error's traceback still holds a view of it: freed with the traceback
                pass


def _gzip_checkpoints_of(path):
    checkpoints = _GZIP_CHECKPOINTS.get(_gzip_key(path))
    if checkpoints is None:
        checkpoints = gzip_checkpoints(path)
        _remember_checkpoints(path, checkpoints)
    return checkpoints


def _changed(path, start, stop, got):
    return ValueError(f"{path}: the file changed since it was scanned (it ends at byte {start + got}, a "
                      f"frame was expected up to byte {stop}); open the reader again")


@contextlib.contextmanager
def frame_range(path, start, stop):
    """Bytes [start, stop) of the file (decompressed if gzip, from the scan's checkpoint before start) as ``(data,
    size)`` in the reused frame buffer (:func:`._text.frame_text`): the text is ``data[:size]`` (data may be
    longer), valid inside the block; a ValueError naming the file if it ends before stop (cut since it was scanned:
    an .fstat frame would lose contacts)."""
    compressed = is_gzip(path)
    with frame_text(path, start, stop, _gzip_checkpoints_of(path) if compressed else None, compressed) as (data, got):
        if got != max(stop - start, 0):
            raise _changed(path, start, stop, got)
        yield data, got


def _empty_file_error(path, what):
    return ValueError(f"{path}: the file is empty or holds only whitespace; expected {what} (a file cut off or "
                      f"not yet written? write it again)")


def _cut_line_error(path, line):
    """MercuryDPM ends every line with a newline: a last line without one was cut while being written or copied, and
    a cut inside its last number would leave a line of the right length with a wrong value. A converter joining
    lines with "\\n" leaves a complete file without one: the fix then is a newline, not deleting the frame."""
    name = os.fspath(path)
    add = "gunzip it, echo >> it, gzip it" if name.endswith(".gz") else f"echo >> {shlex.quote(name)}"
    return ValueError(f"{path}:{line}: the last line has no newline at its end: the file was cut while being written "
                      f"(a run still going?) or copied, or written without a final newline; if the file is complete, "
                      f"add the final newline ({add}); if it was cut, read it when the run has ended, copy it again, "
                      f"or delete that line and its frame")


def _words(data, start, stop):
    return bytes(data[start:stop]).split()


def scan_data(path, dim):
    """Frames of a .data file: list of (header offset, header line number, n, time, dim, header values,
    first particle line's offset, end of the frame's lines). One pass over windows of the file."""
    frames = []
    text_seen = False
    open_frame, remaining = None, 0       # a frame whose particle lines run on into the next window
    last_byte, last_line = b"\n", 0
    with contextlib.closing(scan_windows(path)) as windows:
        for data, lo, hi, base, first_line, starts in windows:
            nlines = len(starts)
            if hi > lo:
                last_byte, last_line = bytes(data[hi - 1:hi]), first_line + nlines - 1
            k = 0
            if open_frame is not None:
                k = min(remaining, nlines)
                remaining -= k
            while True:
                if open_frame is not None:
                    if remaining:
                        break
                    rows_stop = base + (int(starts[k]) if k < nlines else hi)
                    frames.append(open_frame + (rows_stop,))
                    open_frame = None
                if k >= nlines:
                    break
                a = int(starts[k])
                b = int(starts[k + 1]) if k + 1 < nlines else hi
                words = _words(data, a, b)
                if not words or words[0].startswith(b"#"):
                    text_seen = text_seen or bool(words)
                    k += 1
                    continue
                text_seen = True
                lineno = first_line + k
                if len(words) not in (6, 8):
                    raise ValueError(f"{path}:{lineno}: expected a header 'N time xmin ymin [zmin] xmax ymax [zmax]' "
                                     f"(6 values in 2D, 8 in 3D), got {len(words)} values")
                head = parse_table(data, a, b, len(words), int_columns=(0,), name=path, frame="a frame header",
                                   first_line=lineno)
                d = 3 if len(words) == 8 else 2
                if dim is not None and d != dim:
                    raise ValueError(f"{path}:{lineno}: a {d}D header, but dim={dim} was given")
                n, time = int(head.ints[0, 0]), float(head.values[0, 1])
                if n < 0:
                    raise ValueError(f"{path}:{lineno}: expected a particle count, got {words[0].decode()!r}")
                open_frame = (base + a, lineno, n, time, d, tuple(head.values[0].tolist()), base + b)
                taken = min(n, nlines - k - 1)
                remaining = n - taken
                k += 1 + taken
    if open_frame is not None:
        a, lineno, n, time = open_frame[:4]
        raise ValueError(f"{path}:{lineno}: the frame at t = {time:g} declares {n} particles but only "
                         f"{n - remaining} lines follow: the file is truncated (cut off while being "
                         f"written or copied); write it again or drop its last frame")
    if last_byte != b"\n" and frames:
        raise _cut_line_error(path, last_line)
    if not frames:   # only blank and '#' lines
        if not text_seen:
            raise _empty_file_error(path, "MercuryDPM .data frames ('N time xmin ...' headers)")
        raise ValueError(f"{path}: no frame header 'N time xmin ymin [zmin] xmax ymax [zmax]', only comment "
                         f"lines; expected a MercuryDPM .data file")
    return frames


def scan_fstat(path):
    """Frames of a .fstat file: list of (offset of the first header line, its line number, time, marker,
    offset of the frame's first interaction line, end of its lines, line number of that offset).
    One pass over windows of the file, keeping only the '#' lines (the lines between them are counted,
    not recorded)."""
    heads, ends, lines, texts = [], [], [], []
    size, text_line = 0, None         # text_line: the line of the first text before the first header
    text_after = False                # whether the lines after the last header hold text
    line = 1                          # the line number of the window's start, counted here
    last_byte = b"\n"
    with contextlib.closing(scan_windows(path, line_starts=False)) as windows:
        for data, lo, hi, base, _, _ in windows:
            size = base + hi
            if hi > lo:
                last_byte = bytes(data[hi - 1:hi])
            found = find_lines(data, b"#", lo, hi).tolist()
            if not heads and text_line is None:
                text = _TEXT.search(data, lo, found[0] if found else hi)
                if text is not None:   # its line: the newlines before it in the window
                    at = text.start()
                    text_line = line + count_lines(data, lo, at) - (at > lo and data[at - 1] != 10)
            at = lo
            for h in found:
                line += count_lines(data, at, h)   # at and h start lines: the lines from one to the other
                at = h
                e = data.find(b"\n", h, hi)
                e = hi if e < 0 else e + 1
                heads.append(base + h)
                ends.append(base + e)
                lines.append(line)
                texts.append(bytes(data[h + 1:e]))
            line += count_lines(data, at, hi)          # on to the next window's first line
            # whether the lines after the last header so far hold text (the search stops at the first)
            if len(found):
                text_after = _TEXT.search(data, ends[-1] - base, hi) is not None
            elif heads and not text_after:
                text_after = _TEXT.search(data, lo, hi) is not None
    if not heads:
        if text_line is None:
            raise _empty_file_error(path, "MercuryDPM .fstat frames ('# time marker' headers)")
        raise ValueError(f"{path}:1: contact line before the first '# time' header")
    if text_line is not None:
        raise ValueError(f"{path}:{text_line}: contact line before the first '# time' header "
                         f"(the first header is on line {lines[0]})")
    # runs of consecutive header lines: 3 per frame (a frame without contacts is followed at once by the next)
    runs, k = [], 0
    while k < len(heads):
        m = k
        while m + 1 < len(heads) and heads[m + 1] == ends[m]:
            m += 1
        runs.append((k, m + 1))
        k = m + 1
    frames = []
    for r, (a, b) in enumerate(runs):
        if (b - a) % FSTAT_HEADER_LINES:
            raise ValueError(f"{path}:{lines[a]}: {b - a} '#' header line{'s' if b - a > 1 else ''} in a row "
                             f"where .fstat frames have {FSTAT_HEADER_LINES} ('# time marker', '# xmin ymin zmin "
                             f"xmax ymax zmax', '# rmin rmax ...'): a header line is missing, or a line was "
                             f"inserted into a header (a damaged file; write it again)")
        for f in range(a, b, FSTAT_HEADER_LINES):
            words = texts[f].split()
            if not words:
                raise ValueError(f"{path}:{lines[f]}: expected '# time marker', got an empty header line")
            head = parse_table(texts[f], 0, len(texts[f]), len(words), name=path, frame="a frame header",
                               first_line=lines[f]).values[0]
            marker = int(head[1]) if len(head) > 1 else 0
            last = f + FSTAT_HEADER_LINES - 1
            rows_start = ends[last]
            rows_stop = heads[runs[r + 1][0]] if f + FSTAT_HEADER_LINES == b and r + 1 < len(runs) else \
                (heads[f + FSTAT_HEADER_LINES] if f + FSTAT_HEADER_LINES < b else size)
            frames.append((heads[f], lines[f], float(head[0]), marker, rows_start, rows_stop, lines[last] + 1))
    if last_byte != b"\n":
        raise _cut_line_error(path, line - 1)   # line: the one after the last (count_lines counts the cut one)
    last = frames[-1]
    if not text_after and any(f[5] > f[4] for f in frames[:-1]):
        raise ValueError(f"{path}:{last[1]}: the last frame (t = {last[2]:g}) has no interaction lines while "
                         f"earlier frames have some: the file is truncated (cut off while being written or "
                         f"copied); write it again, or delete that frame's three header lines if the run "
                         f"really ended without contacts")
    return frames


def read_restart(path):
    """Key-based parse of a .restart: species densities, the particles' invMass and positions (by id),
    periodic normals, the gravity vector (None when the file has no ``systemDimensions ... gravity gx gy gz`` line).

    Particles are the lines of the ``Particles N`` section whose first word names a particle class
    (``BaseParticle``, ``SphericalParticle``, ...); other lines with particle keys, such as the
    template particle embedded in an insertion boundary's line, are not particles. A section with
    fewer than N particle lines (a truncated file), or a file without one, is an error.
    """
    density, normals, particle_dim, gravity = {}, [], None, None
    inv_mass, positions = [], []
    declared, declared_line = None, None
    text = b"".join(iter_chunks(path))
    if not text.strip():
        raise _empty_file_error(path, "a MercuryDPM .restart")
    for lineno, raw in enumerate(text.split(b"\n"), 1):
        words = raw.decode("utf-8", errors="replace").split()
        if not words:
            continue
        keys = {w: k for k, w in reversed(list(enumerate(words)))}

        def val(key, n=1):
            k = keys[key]
            out = [float(x) for x in words[k + 1:k + 1 + n]]
            if len(out) != n or not all(np.isfinite(out)):
                raise ValueError
            return out

        if words[0] == "Particles" and len(words) == 2 and words[1].isdigit():
            declared, declared_line = int(words[1]), lineno
            continue
        try:
            if "particleDimensions" in keys:
                particle_dim = int(val("particleDimensions")[0])
            if "gravity" in keys and "systemDimensions" in keys and gravity is None:   # DPMBase::write's line
                gravity = val("gravity", 3)
            if "density" in keys and "id" in keys and words[0].endswith("Species"):
                density[int(val("id")[0])] = val("density")[0]
            elif words[0].endswith("Particle") and "invMass" in keys and "position" in keys:
                inv_mass.append(val("invMass")[0])
                positions.append(val("position", 3))
            elif words[0] == "PeriodicBoundary" and "normal" in keys:
                normals.append(val("normal", 3))
        except (ValueError, IndexError, OverflowError):
            raise ValueError(f"{path}:{lineno}: cannot read the values of this {words[0]} line "
                             f"(a damaged .restart?)") from None
    if declared is None:
        raise ValueError(f"{path}: no 'Particles N' line: a truncated or damaged .restart (MercuryDPM writes the "
                         f"particle section after the species, walls and boundaries); write it again, or pass "
                         f"fixed=, density= and periodic= instead")
    if len(inv_mass) != declared:
        raise ValueError(f"{path}:{declared_line}: 'Particles {declared}' but {len(inv_mass)} particle lines follow "
                         f"(a truncated or damaged .restart); write it again, or pass fixed= instead")
    # the file's order is the particle handler's, which is the order of the .data rows
    return {"density": density, "inv_mass": np.array(inv_mass, dtype=float),
            "positions": np.array(positions, dtype=float).reshape(-1, 3), "normals": normals,
            "particle_dim": particle_dim, "gravity": None if gravity is None else np.array(gravity)}


def _row_length_error(path, data, first_line, ncols, what, time, exc):
    """The first line of data whose number of values differs from ncols, as a ValueError in the
    'file:line: expected N columns' form; the parser's own error when every line has ncols values."""
    for k, line in enumerate(bytes(data).split(b"\n")):
        words = line.split()
        if words and len(words) != ncols:
            return ValueError(f"{path}:{first_line + k}: expected {ncols} columns for {what}, got {len(words)} "
                              f"(frame t = {time:g}): a value is missing or extra, so the columns would shift "
                              f"(a damaged file; write it again)")
    return exc


def read_particles(path, header, n, dim, rows_start, rows_stop):
    """The particles of a .data frame: (time, lower, upper, table, species) with the (n, DATA_COLUMNS[dim])
    particle table (extra trailing columns dropped) and the species column as int64.

    header: (line number, time, header values) from scan_data."""
    first_line, time, head = header
    ncol = DATA_COLUMNS[dim]
    lower, upper = np.array(head[2:2 + dim]), np.array(head[2 + dim:2 + 2 * dim])
    if n == 0:
        return time, lower, upper, np.zeros((0, ncol)), np.zeros(0, np.int64)
    with frame_range(path, rows_start, rows_stop) as (data, size):
        eol = data.find(b"\n", 0, size)
        width = len(data[:size if eol < 0 else eol].split())
        what = f"a {dim}D .data particle line"
        if width < ncol:
            raise ValueError(f"{path}:{first_line + 1}: expected {ncol} columns for {what}, got {width} "
                             f"(frame t = {time:g})")
        try:
            table = parse_table(data, 0, size, width, int_columns=(DATA_SPECIES[dim],), nrows=n, name=path,
                                frame=f"t = {time:g}", first_line=first_line + 1)
        except ValueError as exc:
            raise _row_length_error(path, data[:size], first_line + 1, width, what, time, exc) from None
    values = table.values if width == ncol else np.ascontiguousarray(table.values[:, :ncol])
    return time, lower, upper, values, table.ints[:, 0]


@contextlib.contextmanager
def fstat_rows(path, time, rows_start, rows_stop, first_line):
    """The interaction lines of a .fstat frame: an (M, W) table (W >= FSTAT_COLUMNS: extra trailing columns are
    kept, the C pass of the contacts skips them), the (M, 2) int64 indices i, j, and a function giving the 1-based
    line number of row k, valid inside the block; None, None, None if M = 0. The lines' times are checked against
    the frame's (within LINE_TIME_RTOL) by the caller, with the contacts (csrc/cg_fstat.h). The frame's text is in
    the reused frame buffer and the table in reused memory (parse_table's reuse: keep nothing of it, copy what is
    needed)."""
    with frame_range(path, rows_start, rows_stop) as (data, size):
        yield _fstat_rows(path, time, data, size, first_line)


def _fstat_rows(path, time, data, size, first_line):
    """fstat_rows of the text data[:size]; line_of reads data when called."""
    text = _TEXT.search(data, 0, size)
    if not text:
        return None, None, None
    eol = data.find(b"\n", text.start(), size)
    width = len(data[text.start():size if eol < 0 else eol].split())
    what = "an .fstat line 'time i j cx cy cz delta deltat fn ft nx ny nz tx ty tz'"
    if width < FSTAT_COLUMNS:
        line = first_line + bytes(data[:text.start()]).count(b"\n")
        raise ValueError(f"{path}:{line}: expected {FSTAT_COLUMNS} columns "
                         f"'time i j cx cy cz delta deltat fn ft nx ny nz tx ty tz', got {width}")
    try:
        table = parse_table(data, 0, size, width, int_columns=(1, 2), skip_blank=True, name=path,
                            frame=f"t = {time:g}", first_line=first_line, reuse=True)
    except ValueError as exc:
        raise _row_length_error(path, data[:size], first_line, width, what, time, exc) from None

    numbered = []

    def line_of(k):
        if not numbered:   # blank lines may sit between rows: number the non-blank lines once, on demand
            numbered.extend(first_line + j for j, line in enumerate(bytes(data[:size]).split(b"\n")) if line.strip())
        return numbered[k]

    return table.values, table.ints, line_of
