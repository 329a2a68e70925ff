"""cgbound's own HDF5 schema for many snapshots (read lazily, written atomically).

Schema (version 1)::

    /                       attrs: format = "cgbound-snapshots", schema_version = 1,
                                   dim, cgbound_version, provenance (free text, JSON if possible)
    /box                    attrs: lower (D,), upper (D,), periodic (D,) bool
    /frames/000000          attrs: time; a group per frame, numbered from 0
        positions   (N, D)  float64
        masses      (N,)    float64
        velocities  (N, D)  float64   optional (absent: static snapshot)
        fixed       (N,)    bool      optional
        species     (N,)    int64     optional
        radii       (N,)    float64   optional
        body_force  (N, D)  float64   optional
        angular_velocities, torques   (N, 3) in 3D, (N,) in 2D   float64   optional
        moments_of_inertia  (N,)      float64   optional (as given to the Snapshot)
        contacts/i, contacts/j (M,) int64; contacts/force, contacts/point (M, D) float64
        contacts/branch     (M, D)  float64   optional (Contacts.branch: pairs listed once per periodic image)

Datasets are stored contiguous and uncompressed by default (the fastest to read: float64 simulation data
compresses poorly, and decompression cost more than the rest of a frame's reading), or, with
``compression="gzip"`` or ``"lzf"``, in chunks of whole rows (about 1 MiB) with the shuffle filter; files
written by older versions (h5py's automatic chunks, gzip 4 and shuffle) read the same. A frame with
another box than /box stores its own box attrs on the frame group. See docs/guide/reading-data.md.
"""
import json
import os

import numpy as np

from .._atomic import atomic_write
from ..box import Box
from ..snapshot import Contacts, Snapshot
from ._sequence import FrameSequence

FORMAT = "cgbound-snapshots"
SCHEMA_VERSION = 1
_OPTIONAL = ("velocities", "fixed", "species", "radii", "body_force", "angular_velocities", "torques",
             "moments_of_inertia")


def _h5py():
    try:
        import h5py
    except ImportError as exc:  # pragma: no cover - h5py is a dependency
        raise ImportError("reading and writing HDF5 needs h5py: pip install h5py") from exc
    return h5py


#: the compressions write_snapshots offers: None (contiguous, the default), or a filter on whole-row chunks
COMPRESSIONS = (None, "gzip", "lzf")
#: bytes per chunk of a compressed dataset (whole rows): large enough that the per-chunk cost is negligible
CHUNK_BYTES = 1 << 20


def _put(group, name, data, compression=None):
    data = np.asarray(data)
    kwargs = {}
    if data.size > 0 and compression is not None:
        row_bytes = data.itemsize * int(np.prod(data.shape[1:], dtype=np.int64))
        rows = max(1, min(data.shape[0], CHUNK_BYTES // max(row_bytes, 1)))
        kwargs = dict(chunks=(rows,) + data.shape[1:], compression=compression, shuffle=True)
        if compression == "gzip":
            kwargs["compression_opts"] = 4
    group.create_dataset(name, data=data, **kwargs)


def write_snapshots(path, snapshots, provenance=None, compression=None):
    """Write snapshots (an iterable of Snapshot) to ``path`` in the schema above; returns the count.

    compression: None (the default: contiguous datasets, the fastest to read), "gzip" (smaller files,
    several times slower to read) or "lzf" (in between). The file is written beside the target and
    renamed into place, so an existing file is never left half-written.
    """
    if compression is not None and not (isinstance(compression, str) and compression in COMPRESSIONS):
        raise ValueError(f"compression: expected one of {COMPRESSIONS}, got {compression!r}")
    h5py = _h5py()
    from .._version import __version__

    count = 0

    def write(tmp):
        nonlocal count
        # the latest file format has compact per-dataset metadata (a third of a frame otherwise)
        with h5py.File(tmp, "w", libver="latest") as f:
            f.attrs["format"] = FORMAT
            f.attrs["schema_version"] = SCHEMA_VERSION
            f.attrs["cgbound_version"] = __version__
            f.attrs["provenance"] = provenance if isinstance(provenance, str) else json.dumps(provenance or {})
            frames = f.create_group("frames")
            box = None
            for k, snap in enumerate(snapshots):
                if not isinstance(snap, Snapshot):
                    raise TypeError(f"snapshots: item {k} is a {type(snap).__name__}, expected a cg.Snapshot")
                g = frames.create_group(f"{k:06d}")
                g.attrs["time"] = snap.time
                if box is None:
                    box = snap.box
                    b = f.create_group("box")
                    b.attrs["lower"], b.attrs["upper"] = snap.box.lower, snap.box.upper
                    b.attrs["periodic"] = np.array(snap.box.periodic)
                    f.attrs["dim"] = snap.dim
                elif snap.box != box:
                    g.attrs["lower"], g.attrs["upper"] = snap.box.lower, snap.box.upper
                    g.attrs["periodic"] = np.array(snap.box.periodic)
                _put(g, "positions", snap.positions, compression)
                _put(g, "masses", snap.masses, compression)
                for name in _OPTIONAL:
                    value = getattr(snap, name)
                    if name == "fixed" and not value.any():
                        continue
                    if value is not None:
                        _put(g, name, np.ascontiguousarray(value), compression)
                c = g.create_group("contacts")
                for name in ("i", "j", "force", "point"):
                    _put(c, name, getattr(snap.contacts, name), compression)
                if snap.contacts.branch is not None:
                    _put(c, "branch", snap.contacts.branch, compression)
                count += 1
            f.attrs["n_frames"] = count

    atomic_write(path, write, suffix=".h5")
    return count


class HDF5Snapshots(FrameSequence):
    """Lazy sequence of the Snapshots in a cgbound HDF5 file: ``len()``, indexing, slicing.

    Cheap to pickle (holds the path and frame indices, not arrays); each access opens the
    file, so it is safe to hand to worker processes. The schema's attributes are type-checked;
    h5py's errors on a damaged or truncated file come as OSError naming the path, a missing
    group or dataset as ValueError naming the path and the frame.
    """

    def __init__(self, path, frames=None, units=None):
        self.units = units
        self.path = os.fspath(path)
        with self._open() as f:
            n = self._header(f)
        self._frames = list(range(n)) if frames is None else list(frames)

    def _header(self, f):
        """Check the file's format and schema attributes; the number of frames it holds."""
        try:
            fmt = f.attrs.get("format")
            if isinstance(fmt, bytes):
                fmt = fmt.decode("utf-8", errors="replace")
            if fmt != FORMAT:
                raise ValueError(f"path: {self.path!r} is not a cgbound snapshot file (format attribute missing)")
            version = _attr(f, "schema_version", self.path, kind="integer")
            if version > SCHEMA_VERSION:
                raise ValueError(f"path: schema version {version} of {self.path!r} is newer than this cgbound reads")
            n = len(self._member(f, "frames", "the file"))
            self.provenance = f.attrs.get("provenance", "")
        except KeyError as exc:   # h5py reports a damaged object (a bad checksum) as a KeyError
            raise ValueError(f"{self.path}: cannot read the file's header ({exc.args[0] if exc.args else exc}); "
                             f"the file is damaged: write it again") from None
        except (OSError, RuntimeError) as exc:
            raise OSError(f"{self.path}: cannot read the file's header ({exc}); the file is damaged or truncated: "
                          f"write it again") from None
        return n

    @property
    def frame_times(self):
        """The frames' times (their ``time`` attributes; no dataset is read)."""
        with self._open() as f:
            frames = self._member(f, "frames", "the file")
            return [float(_attr(self._member(frames, f"{k:06d}", "/frames"), "time", self.path, f"frame {k:06d}",
                                kind="scalar")) for k in self._frames]

    def _open(self):
        h5py = _h5py()
        try:
            return h5py.File(self.path, "r")
        except (FileNotFoundError, IsADirectoryError, PermissionError):
            raise
        except OSError as exc:
            raise OSError(f"{self.path}: cannot open it as HDF5 ({exc}); the file is damaged, truncated or not "
                          f"HDF5: write it again") from None

    def _member(self, group, name, where):
        try:
            return group[name]
        except KeyError:
            raise ValueError(f"{self.path}: {where} has no {name!r} (a damaged file or another schema; expected "
                             f"the cgbound-snapshots layout, see cgbound/readers/hdf5.py)") from None

    def _snapshot(self, position):
        return self._read(self._frames[position])

    def _read(self, frame):
        where = f"frame {frame:06d}"
        with self._open() as f:
            try:
                return self._read_frame(f, frame, where)
            except (OSError, RuntimeError) as exc:
                raise OSError(f"{self.path}: cannot read {where} ({exc}); the file is damaged or truncated: "
                              f"write it again") from None
            except KeyError as exc:   # h5py reports a damaged object (a bad checksum) as a KeyError
                raise ValueError(f"{self.path}: cannot read {where} ({exc.args[0] if exc.args else exc}); the file "
                                 f"is damaged: write it again") from None

    def _read_frame(self, f, frame, where):
        g = self._member(self._member(f, "frames", "the file"), f"{frame:06d}", "/frames")
        src = g if "lower" in g.attrs else self._member(f, "box", "the file")
        label = f"{where}: the box" if src is g else "/box"
        lower = _attr(src, "lower", self.path, label)
        upper = _attr(src, "upper", self.path, label)
        periodic = _attr(src, "periodic", self.path, label, kind="bool")
        box = Box(lower, upper, periodic=tuple(bool(p) for p in periodic))
        data = {name: g[name][()] for name in _OPTIONAL if name in g}
        c = self._member(g, "contacts", where)
        arrays = [self._member(c, name, f"{where}/contacts")[()] for name in ("i", "j", "force", "point")]
        arrays.append(c["branch"][()] if "branch" in c else None)
        time = float(_attr(g, "time", self.path, where, kind="scalar"))
        positions, masses = self._member(g, "positions", where)[()], self._member(g, "masses", where)[()]
        try:
            return Snapshot(positions, data.get("velocities"), masses, box=box, contacts=Contacts(*arrays),
                            fixed=data.get("fixed"), species=data.get("species"), body_force=data.get("body_force"),
                            radii=data.get("radii"), time=time, angular_velocities=data.get("angular_velocities"),
                            torques=data.get("torques"), moments_of_inertia=data.get("moments_of_inertia"))
        except (ValueError, TypeError, IndexError) as exc:   # a dataset of the wrong shape, type or values: the file
            raise ValueError(f"{self.path}: {where} (t = {time:g}): {exc} (the file was not written by cgbound's "
                             f"write_snapshots, or was edited: write it again)") from None

    def _describe(self):
        return [repr(self.path)], []


def _attr(obj, name, path, where="the file", kind="floats"):
    """An attribute of the schema, type-checked: "floats" a 1-D array of finite numbers, "bool" a 1-D
    array of booleans (0/1 integers accepted), "scalar" one finite number, "integer" one integer."""
    if name not in obj.attrs:
        raise ValueError(f"{path}: {where} has no {name!r} attribute (a damaged file or another schema)")
    value = np.asarray(obj.attrs[name])
    expected = {"floats": "finite numbers", "bool": "booleans", "scalar": "a finite number",
                "integer": "an integer"}[kind]
    ok = value.dtype.kind in "biuf"
    if kind in ("floats", "bool"):
        ok = ok and value.ndim == 1
    else:
        ok = ok and value.ndim == 0
    if ok and kind == "bool":
        ok = value.dtype.kind == "b" or (value.dtype.kind in "iu" and np.all((value == 0) | (value == 1)))
    if ok and kind == "integer":
        ok = value.dtype.kind in "biu"
    if ok and kind in ("floats", "scalar"):
        ok = bool(np.all(np.isfinite(value)))
    if not ok:
        shown = value.tolist() if value.size <= 8 else f"{value.dtype} array of shape {value.shape}"
        raise ValueError(f"{path}: {where}: attribute {name!r} should hold {expected}, got {shown!r} "
                         f"(dtype {value.dtype}); the file was not written by cgbound's write_snapshots, or was "
                         f"edited: write it again")
    return value
