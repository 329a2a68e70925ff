"""Coarse-grained fields as NumPy arrays shaped like the grid, with metadata."""
import numpy as np

from .fields import FIELDS


class Result:
    """Fields on a grid or at points.

    Each requested field is an attribute (and an item): an array shaped like the
    grid (``grid.shape``, or ``(P,)`` for points), followed by ``(D,)`` for vectors
    and ``(D, D)`` for tensors; with ``time_average="none"`` or time smoothing a
    leading time axis comes first. Velocity and temperature are NaN where the
    density is zero.

    With ``CoarseGrain(..., errors="blocks")``: ``errors[field]`` the standard error of the time
    average (shaped like the field), ``block_correlation[field]`` the median lag-1 correlation of
    consecutive block means, ``n_blocks``; otherwise these are None.
    """

    errors = block_correlation = n_blocks = None     # set by CoarseGrain.run with errors="blocks"

    def __init__(self, fields, grid, kernel, convention, times, box):
        self._fields = dict(fields)
        self.grid = grid
        self.kernel = kernel
        self.convention = convention
        self.times = np.asarray(times, dtype=float)
        self.box = box

    @property
    def fields(self):
        return tuple(self._fields)

    @property
    def coordinates(self):
        """Node coordinates, shape ``grid.shape + (D,)`` (or ``(P, D)`` for points)."""
        return self.grid.coordinates

    def __getattr__(self, name):
        fields = self.__dict__.get("_fields", {})
        if name in fields:
            return fields[name]
        if name in FIELDS:
            raise AttributeError(f"field {name!r} was not requested; computed fields: {', '.join(fields)}")
        raise AttributeError(name)

    def __getitem__(self, name):
        return self._fields[name]

    def __contains__(self, name):
        return name in self._fields

    def __dir__(self):
        return list(super().__dir__()) + list(self._fields)

    def as_dict(self):
        return dict(self._fields)

    def to_hdf5(self, path, provenance=None):
        """Write fields, coordinates and metadata to HDF5 (atomically); returns the path."""
        from .writers import write_hdf5
        return write_hdf5(self, path, provenance)

    def to_npz(self, path):
        """Write fields, coordinates and JSON metadata to a compressed .npz (atomically)."""
        from .writers import write_npz
        return write_npz(self, path)

    def to_vtk(self, path, frame=None):
        """Write a legacy VTK rectilinear grid for ParaView (atomically)."""
        from .writers import write_vtk
        return write_vtk(self, path, frame)

    def to_xarray(self):
        """The fields as an xarray.Dataset (needs xarray)."""
        from .writers import to_xarray
        return to_xarray(self)

    def _summary_rows(self):
        for name, value in self._fields.items():
            finite = value[np.isfinite(value)]
            rng = f"[{finite.min():.4g}, {finite.max():.4g}]" if finite.size else "no finite values"
            yield name, value.shape, rng

    def _repr_html_(self):
        """A table of the fields for Jupyter."""
        import html
        head = html.escape(f"{self.grid!r}, {self.kernel!r}, convention={self.convention!r}, "
                           f"{self.times.size} snapshot time(s)")
        rows = "".join(f"<tr><td><code>{html.escape(n)}</code></td><td>{html.escape(str(s))}</td>"
                       f"<td>{html.escape(r)}</td></tr>" for n, s, r in self._summary_rows())
        return (f"<div><b>cgbound.Result</b> {head}<table><thead><tr><th>field</th><th>shape</th>"
                f"<th>range</th></tr></thead><tbody>{rows}</tbody></table></div>")

    def __repr__(self):
        lines = [f"<cgbound.Result {self.grid!r}, {self.kernel!r}, convention={self.convention!r}, "
                 f"{self.times.size} snapshot time(s)>"]
        for name, shape, rng in self._summary_rows():
            lines.append(f"  {name:<26} {str(shape):<18} {rng}")
        return "\n".join(lines)
