"""Coarse-grained fields as NumPy arrays shaped like the grid, with metadata."""
import numpy as np

from .fields import FIELDS
from .units import SIMULATION_UNITS, as_units, unit


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

    def __init__(self, fields, grid, kernel, convention, times, box, units=None, n_frames=None, time_average=None):
        self._fields = dict(fields)
        self.grid = grid
        self.kernel = kernel
        self.convention = convention
        self.times = np.asarray(times, dtype=float)
        self.box = box
        #: the units of the particle data (a cgbound.Units, see cgbound.units), None when not known
        self.units = as_units(units)
        #: how many frames (snapshots) the fields were computed from (None when not recorded)
        self.n_frames = n_frames
        #: "mean", "none", a Gaussian smoothing width, or None for one snapshot
        self.time_average = time_average

    def unit(self, field):
        """The unit of ``field`` as CF-style text (``"kg m^-1 s^-2"`` for a 3-D stress in ``si``), or
        None when the units are not known (a snapshot or reader made without ``units=``)."""
        if field not in self._fields and field not in FIELDS:
            raise ValueError(f"field: expected one of {', '.join(self._fields)}, got {field!r}")
        return unit(field, self.units, self.box.dim)

    def plot(self, field, component=None, ax=None, **kwargs):
        """Plot ``field``: a depth profile on a grid with one resolved axis, a map with two (freud style:
        returns the matplotlib Axes, drawn into ``ax`` if given, e.g. one panel of a grid of subplots).

        ``component``: axis letters (``"z"``, ``"zz"``); None plots every component of a profile as a
        labelled line, and the norm on a map (``|v|``, or the largest singular value of a tensor). Labels
        carry the field's symbol, sign convention and unit (or "(simulation units)").
        """
        from . import plot
        return plot.plot(self, field, component=component, ax=ax, **kwargs)

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
            yield name, value.shape, rng, self.unit(name) or SIMULATION_UNITS

    def describe_times(self):
        """How the fields relate to time, in words (used by the reprs)."""
        t = self.times
        n = self.n_frames
        if self.time_average == "mean" and n is not None:
            return f"mean over {n} frame{'s' if n != 1 else ''} (mean time {float(t[0]):g})"
        if self.time_average == "none" and n is not None:
            return f"{n} frame{'s' if n != 1 else ''}, one per leading index"
        if self.time_average is not None and n is not None:
            return f"Gaussian time smoothing (width {self.time_average:g}) of {n} frames at {t.size} time(s)"
        if n == 1 and t.size == 1:
            return f"1 snapshot at t = {float(t[0]):g}"
        return f"{t.size} time(s)"

    def _head(self):
        units = f"{self.units}" if self.units is not None else SIMULATION_UNITS
        return (f"{self.grid!r}, {self.kernel!r}, convention={self.convention!r}, {self.describe_times()}, "
                f"{units}")

    def _repr_html_(self):
        """A table of the fields (shape, range, unit) for Jupyter."""
        import html
        rows = "".join(f"<tr><td><code>{html.escape(n)}</code></td><td>{html.escape(str(s))}</td>"
                       f"<td>{html.escape(r)}</td><td>{html.escape(u)}</td></tr>" for n, s, r, u in self._summary_rows())
        png = self._repr_png_()
        image = ""
        if png is not None:
            import base64
            image = (f'<img style="float:right" alt="first field" '
                     f'src="data:image/png;base64,{base64.b64encode(png).decode()}"/>')
        return (f"<div>{image}<b>cgbound.Result</b> {html.escape(self._head())}<table><thead><tr><th>field</th>"
                f"<th>shape</th><th>range</th><th>unit</th></tr></thead><tbody>{rows}</tbody></table></div>")

    def _repr_png_(self):
        """A small plot of the first field for Jupyter (PNG bytes), or None when it cannot be drawn
        (no matplotlib, points instead of a grid, no 1-D or 2-D grid)."""
        from . import plot
        return plot.thumbnail_png(self)

    def __repr__(self):
        lines = [f"<cgbound.Result {self._head()}>"]
        for name, shape, rng, u in self._summary_rows():
            lines.append(f"  {name:<26} {str(shape):<18} {rng:<26} {u}")
        return "\n".join(lines)
