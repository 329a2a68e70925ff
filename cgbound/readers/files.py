"""Several files as one dataset: glob patterns, natural (numeric) order, and their frames concatenated.

LAMMPS writes one file per frame (``dump ... dump.*`` puts the timestep in the name) and MercuryDPM
with ``-fileType multiple`` writes ``name.data.0``, ``name.data.1``, ...: the files are ordered by the
numbers in their names (``dump.900`` before ``dump.1000``), not by string, and the frames' times are
checked to increase from one file to the next.
"""
import glob
import gzip
import os
import re

from ._sequence import FrameSequence

_NUMBER = re.compile(r"(\d+)")


GZIP_MAGIC = b"\x1f\x8b"


def is_gzip(path):
    with open(path, "rb") as f:
        return f.read(2) == GZIP_MAGIC


def open_input(path, text=False):
    """Open a data file for reading, gzip-compressed or not (told by its first bytes, not its name):
    compressed files are decompressed as a stream (seek and tell count decompressed bytes)."""
    if is_gzip(path):
        return gzip.open(path, "rt" if text else "rb")
    return open(path, "r" if text else "rb")


def decode_text(path, data, what="a text file", error=ValueError):
    """``data`` (bytes read from ``path``) as UTF-8 text, or ``error`` naming the file and the line of the
    first NUL byte or byte that is not UTF-8 (a damaged file, or a binary file given where text is read)."""
    bad = data.find(b"\0")
    if bad < 0:
        try:
            return data.decode("utf-8")
        except UnicodeDecodeError as exc:
            bad = exc.start
    line = data.count(b"\n", 0, bad) + 1
    raise error(f"{path}: line {line}: byte {data[bad]:#04x} is not UTF-8 text; {what} was expected (the file is "
                f"damaged, or another kind of file was given)")


def natural_key(path):
    """Sort key that orders the digit runs of a name by value: ``a.9`` < ``a.10``."""
    return [int(part) if part.isdigit() else part for part in _NUMBER.split(os.path.basename(str(path)))]


class CompanionFileWarning(UserWarning):
    """A file the reader would use lies beside its input but was not given (and was not declined)."""


def companion(path, old, new):
    """``name.fstat`` for ``name.data`` (``name.fstat.3`` for ``name.data.3``), if that file exists."""
    base = os.path.basename(path)
    head, sep, tail = base.rpartition(old)
    if not sep:
        return None
    candidate = os.path.join(os.path.dirname(path), head + new + tail)
    return candidate if os.path.isfile(candidate) else None


def has_pattern(path):
    return any(c in str(path) for c in "*?[")


def expand_paths(paths, name="paths"):
    """The files named by ``paths`` (a path, a glob pattern, or a sequence of them), in natural order.

    A pattern that matches nothing and a path that does not exist are errors naming them.
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    out = []
    for item in paths:
        item = os.fspath(item)
        if os.path.exists(item):
            if os.path.isdir(item):
                raise IsADirectoryError(f"{name}: {item!r} is a directory; expected a file or a glob pattern")
            out.append(item)
        elif has_pattern(item):
            matched = sorted((p for p in glob.glob(item) if os.path.isfile(p)), key=natural_key)
            if not matched:
                raise FileNotFoundError(f"{name}: the pattern {item!r} matches no file")
            out.extend(matched)
        else:
            raise FileNotFoundError(f"{name}: no such file: {item!r}")
    if not out:
        raise ValueError(f"{name}: expected at least one file, got none")
    if len(set(map(os.path.abspath, out))) != len(out):
        raise ValueError(f"{name}: a file is named twice ({', '.join(out)})")
    return sorted(out, key=natural_key) if len(out) > 1 else out


class ConcatenatedFrames(FrameSequence):
    """The frames of several readers one after another (one reader per file)."""

    def __init__(self, readers, name="paths"):
        self.readers = list(readers)
        self._frames = [(r, k) for r, reader in enumerate(self.readers) for k in range(len(reader))]
        self._check_order(name)
        # readers that check a frame against its neighbours' boxes (LAMMPS, LIGGGHTS: a deforming box) see across files
        for k, reader in enumerate(self.readers):
            link = getattr(reader, "_link_files", None)
            if link is not None:
                link(self.readers[k - 1] if k else None, self.readers[k + 1] if k + 1 < len(self.readers) else None)

    def _check_order(self, name):
        """Each file's frames must come after the previous file's (timesteps, or else times, from the readers' own
        locators: ``timesteps`` or ``frame_times``)."""
        last = None
        for reader in self.readers:
            steps, what = getattr(reader, "timesteps", None), "timestep"
            if not steps:
                steps, what = getattr(reader, "frame_times", None), "time"
            if not steps:
                continue
            if last is not None and steps[0] <= last[0]:
                show = str if what == "timestep" else "{:g}".format
                raise ValueError(f"{name}: the frames of {describe(reader)} (first {what} {show(steps[0])}) do not "
                                 f"come after those of {describe(last[1])} (last {what} {show(last[0])}); name the "
                                 f"files so "
                                 f"that their numbers give the time order, or pass them in order")
            last = (steps[-1], reader)

    def _snapshot(self, position):
        r, k = self._frames[position]
        return self.readers[r][k]

    def __repr__(self):
        return f"ConcatenatedFrames({len(self.readers)} files, {len(self)} frames)"


def describe(reader):
    for attr in ("atoms_path", "data_path", "path"):
        if getattr(reader, attr, None):
            return os.path.basename(getattr(reader, attr))
    return repr(reader)
