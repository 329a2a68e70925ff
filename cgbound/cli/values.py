"""Parsing the text of command-line values, each error naming its flag."""
import math
import os

from .errors import UsageError


def split_list(text):
    return [part.strip() for part in text.split(",")] if text.strip() else []


def numbers(text, flag, count=None, positive=False, allow_empty=False):
    """Comma-separated finite numbers (``count`` of them if given; empty entries as None if allowed)."""
    parts = split_list(text)
    values = []
    for part in parts:
        if part == "" and allow_empty:
            values.append(None)
            continue
        try:
            value = float(part)
        except ValueError:
            raise UsageError(flag, f"expected comma-separated numbers, got {text!r} ({part!r} is not a number)") \
                from None
        if not math.isfinite(value):
            raise UsageError(flag, f"expected finite numbers, got {text!r}")
        if positive and not value > 0:
            raise UsageError(flag, f"expected positive numbers, got {text!r}")
        values.append(value)
    if count is not None and len(values) != count:
        raise UsageError(flag, f"expected {count} comma-separated numbers for {count}-D data, got {text!r}")
    if not values:
        raise UsageError(flag, f"expected comma-separated numbers, got {text!r}")
    return values


def positive_number(text, flag):
    values = numbers(text, flag, positive=True)
    if len(values) != 1:
        raise UsageError(flag, f"expected one positive number, got {text!r}")
    return values[0]


def integers(text, flag, positive=False, allow_x=False):
    """Comma-separated integers (with ``allow_x`` also ``x`` as separator, for shapes such as ``1x1x400``)."""
    parts = split_list(text.replace("x", ",") if allow_x else text)
    out = []
    for part in parts:
        try:
            value = int(part)
        except ValueError:
            raise UsageError(flag, f"expected comma-separated integers, got {text!r} ({part!r} is not an integer)") \
                from None
        if positive and value < 1:
            raise UsageError(flag, f"expected positive integers, got {text!r}")
        out.append(value)
    if not out:
        raise UsageError(flag, f"expected comma-separated integers, got {text!r}")
    return out


def type_masses(text, flag="--masses"):
    """``TYPE=MASS,...`` (LAMMPS atom types) as a dict."""
    out = {}
    for part in split_list(text):
        key, sep, value = part.partition("=")
        try:
            if not sep:
                raise ValueError
            key, mass = int(key), float(value)
        except ValueError:
            raise UsageError(flag, f"expected TYPE=MASS pairs such as 1=0.52,2=1.0, got {text!r}") from None
        if not (math.isfinite(mass) and mass > 0):
            raise UsageError(flag, f"expected positive finite masses, got {part!r}")
        if key in out:
            raise UsageError(flag, f"type {key} is given twice in {text!r}")
        out[key] = mass
    if not out:
        raise UsageError(flag, f"expected TYPE=MASS pairs such as 1=0.52,2=1.0, got {text!r}")
    return out


def existing_file(path, flag):
    if not os.path.exists(path):
        raise UsageError(flag, f"no such file: {path!r}")
    if os.path.isdir(path):
        raise UsageError(flag, f"{path!r} is a directory; expected a file")
    return path


def output_directory_exists(path, flag):
    """A file to write: not a directory, and a symlink only if it leads to a file name in an existing directory
    (the writers replace the file a link points to), so that nothing is computed for a write that must fail."""
    if os.path.isdir(path):
        raise UsageError(flag, f"{path!r} is a directory; expected a file name")
    target = path
    if os.path.islink(path):
        try:
            os.stat(path)
        except FileNotFoundError:
            pass                  # a dangling link: the file it names is created (its directory is checked below)
        except OSError as exc:    # a loop of links
            raise UsageError(flag, f"{path!r} is a symlink that cannot be followed ({exc.strerror}); expected a "
                                   f"file name") from None
        target = os.path.realpath(path)
    directory = os.path.dirname(os.path.abspath(target))
    if not os.path.isdir(directory):
        via = f" (the target of the symlink {path!r})" if target != path else ""
        raise UsageError(flag, f"directory {directory!r}{via} does not exist")
    return path


def output_not_input(path, inputs, flag):
    """Refuse an output that is one of the input files (or a link to one): the write would replace the data."""
    if not os.path.exists(path):
        return path
    for item in inputs:
        try:
            same = os.path.samefile(path, item)
        except OSError:
            continue
        if same:
            raise UsageError(flag, f"{path!r} is the input file {item!r}: writing the fields there would replace the "
                                   f"data; choose another output file")
    return path


def _cgbound_output(path, ext):
    """Whether the existing file ``path`` is one cgbound wrote as a result (so replacing it loses nothing that
    cannot be computed again): an HDF5 file of fields (format attribute ``cgbound-fields``),
    an .npz with cgbound's metadata, a VTK file with cgbound's header line, a MercuryCG-format .stat."""
    try:
        if os.path.getsize(path) == 0:
            return True
        if ext in (".h5", ".hdf5"):
            import h5py
            with h5py.File(path, "r") as f:
                fmt = f.attrs.get("format", "")
            fmt = fmt.decode(errors="replace") if isinstance(fmt, bytes) else str(fmt)
            return fmt == "cgbound-fields"    # (not snapshots, nor the paper's costly profile and rheology files)
        if ext == ".npz":
            import numpy as np
            with np.load(path, allow_pickle=False) as data:
                return "metadata" in data.files and "cgbound_version" in str(data["metadata"])
        with open(path, "rb") as fh:
            head = fh.read(512)
        if ext == ".vtk":
            lines = head.split(b"\n")
            return len(lines) > 1 and lines[1].startswith(b"cgbound fields")
        return head.startswith(b"CG<")      # .stat: MercuryCG's layout (cgbound's or MercuryCG's own result)
    except Exception:   # unreadable as its extension says: not a cgbound result
        return False


def refuse_read_only(path, flag):
    """A file without write permission was made so to keep it: the writers replace by rename, which the file's own
    mode does not stop (only its directory's), so refuse it here."""
    mode = os.stat(path).st_mode
    if not mode & 0o222:
        raise UsageError(flag, f"{path!r} is read-only (mode {mode & 0o777:04o}); make it writable to replace it, or "
                               f"choose another file name")


def replaceable_output(path, flag):
    """An existing output file is replaced only when cgbound wrote it as a result: anything else (a snapshot file,
    another program's data that happens to have the extension) would be destroyed, so it is refused."""
    if not os.path.isfile(path):
        return path
    refuse_read_only(path, flag)
    ext = os.path.splitext(path)[1].lower()
    if not _cgbound_output(path, ext):
        raise UsageError(flag, f"{path!r} exists and is not a result file cgbound wrote (writing would replace its "
                               f"data); choose another output file, or move that one away first")
    return path


def replaceable_figure(path, flag):
    """An existing figure file is replaced only when Matplotlib wrote it (its metadata names Matplotlib: PNG and
    SVG near the start, PDF in the trailer's info): another file with the extension (a paper, a photograph) would
    be destroyed, so it is refused."""
    if not os.path.isfile(path):
        return path
    refuse_read_only(path, flag)
    if os.path.getsize(path) == 0:
        return path
    try:
        with open(path, "rb") as fh:
            head = fh.read(8192)
            fh.seek(max(0, os.path.getsize(path) - 8192))
            tail = fh.read()
    except OSError:
        head = tail = b""
    if b"Matplotlib" not in head and b"Matplotlib" not in tail:
        raise UsageError(flag, f"{path!r} exists and is not a figure cgbound (Matplotlib) wrote (writing would replace "
                               f"it); choose another file name, or move that one away first")
    return path
