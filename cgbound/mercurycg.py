"""Read and write MercuryCG ``.stat`` files, and convert between their columns and cgbound's fields.

The format (MercuryCG, the coarse-graining tool of MercuryDPM), as written by MercuryCG itself::

    CG<XYZ> min 2 1 -1 max 28 4 9 timeMin 15 n 13 3 10 width 1 Lucy cutoff 1
    time x y z 5:VolumeFraction 6:Density 7-9:Momentum 10-15:MomentumFlux 16-24:ContactStress 25-27:InteractionForce 28-33:ParticleSize
    15 3 1.5 -0.5 0 0 ...

Line 1: the resolved coordinates (``O``, ``X``, ``Z``, ``XZ``, ``XYZ``, ...), the box (``min``, ``max``),
optional ``timeMin``/``timeMax``, the node counts ``n`` (1 along averaged axes), and the kernel:
``width W Lucy cutoff W`` or ``width W Gauss width W cutoff 3W`` (also ``Heaviside``). Line 2: the
column names, 1-based column ranges. Then one row per node and time: the time, the node's resolved
coordinates, the values; nodes are cell-centred (``min + (k + 1/2) (max - min) / n``), as in
cgbound's :class:`~cgbound.grid.Grid`. Numbers have 6 significant digits.

Columns and their relation to cgbound's fields (3-D):

=================  ==========  ==========================================================
MercuryCG          components  cgbound
=================  ==========  ==========================================================
VolumeFraction     1           ``volume_fraction``
Density            1           ``density``
Momentum           3           ``momentum``
MomentumFlux       6 (xx xy    ``momentum_flux`` (sum of m v v, symmetric)
                   xz yy yz zz)
ContactStress      9 (xx xy    ``contact_stress + boundary_stress``, COMPRESSION-positive
                   xz yx ...)  (cgbound's ``convention="compression"``; minus the tension one)
InteractionForce   3           ``interaction_force_density`` (on the flow from the boundary)
ParticleSize       6           no cgbound field (moments of the particle radius, k = 0..5)
=================  ==========  ==========================================================

There is no kinetic-stress column: the kinetic stress is ``MomentumFlux - Momentum Momentum / Density``
(compression-positive). Kernels: MercuryCG's Lucy ``width`` is the cutoff radius, i.e.
``cgbound.Lucy(cutoff=width)``; MercuryCG's Gauss ``width`` is the standard deviation, cut off at
``3 width`` and renormalised over the truncated ball, i.e. ``cgbound.Gaussian(width, cutoff=3 * width,
normalize="truncated")``. Over averaged axes (X, Y, Z, XY, XZ, YZ files) MercuryCG uses the kernel of the
resolved dimension itself (for a Z profile with Lucy the 1-D Lucy 5/(4R) (1 + 3x)(1 - x)^3, divided by the
averaged area), where cgbound's default is the exact marginal of the 3-D kernel (1-5 % apart for Lucy);
``averaged_axes="lower-dimensional"`` on the kernel gives MercuryCG's, and :meth:`StatFile.kernel` returns
it. To reproduce a file: ``cg.coarse_grain(snapshot, stat.grid(snapshot.box.periodic), stat.kernel(),
fields, convention="compression")``. Writing refuses a Lucy or Heaviside result on a grid with averaged and
resolved axes that used the marginal, since the header would name MercuryCG's kernel. MercuryCG's Gauss
contact-stress line integral is an approximation; on X, Y and Z profiles ``line_quadrature="mercurycg"``
applies it (``StatFile.kernel()`` does), elsewhere cgbound's exact integral is used (1e-3 to 1e-2 apart).
"""
import gzip
import io
import os
import zlib
from dataclasses import dataclass, field

import numpy as np

from .box import Box
from .grid import Grid
from .kernels import Gaussian, Heaviside, Lucy
from .readers.files import decode_text

__all__ = ["StatFile", "read_stat", "write_stat", "to_fields", "stat_kernel", "COMPONENTS"]

AXES = "XYZ"

#: components of MercuryCG's columns, in file order
COMPONENTS = {
    "VolumeFraction": (),
    "Density": (),
    "Momentum": ("x", "y", "z"),
    "MomentumFlux": ("xx", "xy", "xz", "yy", "yz", "zz"),
    "ContactStress": ("xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz"),
    "InteractionForce": ("x", "y", "z"),
    "ParticleSize": ("0", "1", "2", "3", "4", "5"),
}
_SYMMETRIC = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]


@dataclass
class StatFile:
    """A MercuryCG ``.stat`` file.

    ``coordinates``: the resolved axes (``"XYZ"``, ``"Z"``, ``"O"`` for none); ``lower``, ``upper``
    (3,); ``n`` (3,) node counts; ``function`` (``"Lucy"``, ``"Gauss"``, ``"Heaviside"``);
    ``width``, ``cutoff``; ``time_min``/``time_max`` (None when absent); ``times`` (T,);
    ``axis_coordinates``: node coordinates of each resolved axis; ``columns``: MercuryCG's name ->
    array shaped ``(T,) + shape + components`` where ``shape`` is the node counts of the resolved
    axes (MomentumFlux expanded to a symmetric (3, 3), ContactStress to (3, 3)); ``column_order``:
    the names in file order; ``path``.
    """
    coordinates: str
    lower: np.ndarray
    upper: np.ndarray
    n: np.ndarray
    function: str
    width: float
    cutoff: float
    time_min: float = None
    time_max: float = None
    times: np.ndarray = None
    axis_coordinates: dict = field(default_factory=dict)
    columns: dict = field(default_factory=dict)
    column_order: tuple = ()
    path: str = None

    @property
    def shape(self):
        return tuple(int(self.n[AXES.index(a)]) for a in self.resolved)

    @property
    def resolved(self):
        return "" if self.coordinates == "O" else self.coordinates

    def kernel(self, averaged_axes="lower-dimensional", line_quadrature=None):
        """The cgbound kernel equal to MercuryCG's (see :func:`stat_kernel`); ``averaged_axes="marginal"``
        gives cgbound's default kernel over averaged axes instead, to see the difference.
        ``line_quadrature`` (Gauss only): None gives MercuryCG's approximate line integral ("mercurycg")
        on X, Y and Z profiles, where it is reproduced exactly, and the exact integral elsewhere."""
        if line_quadrature is None:
            line_quadrature = "mercurycg" if self.function == "Gauss" and len(self.resolved) == 1 else "exact"
        return stat_kernel(self.function, self.width, self.cutoff, averaged_axes=averaged_axes,
                           line_quadrature=line_quadrature)

    def grid(self, periodic=False):
        """The cgbound :class:`~cgbound.grid.Grid` of this file's nodes (``periodic``: the data's periodic
        axes, a bool or one per axis). With :meth:`kernel`, ``cg.coarse_grain(snapshot, stat.grid(
        snapshot.box.periodic), stat.kernel(), fields, convention="compression")`` reproduces the file."""
        averaged = tuple(a.lower() for a in AXES if a not in self.resolved)
        return Grid(Box(self.lower, self.upper, periodic=periodic), tuple(int(k) for k in self.n), average=averaged)


def stat_kernel(function, width, cutoff=None, averaged_axes="lower-dimensional", line_quadrature="exact"):
    """cgbound's kernel for MercuryCG's ``function`` and ``width``.

    Over averaged axes MercuryCG uses the kernel of the resolved dimension itself (the 1-D Lucy for a Z
    profile), hence ``averaged_axes="lower-dimensional"``; "marginal" gives cgbound's default (the exact
    marginal of the 3-D kernel) with the same width and cutoff. ``line_quadrature`` (Gauss only):
    "mercurycg" for MercuryCG's approximate line integral on X, Y and Z profiles (see
    :class:`~cgbound.kernels.Gaussian`).
    """
    if function == "Lucy":
        return Lucy(width, averaged_axes=averaged_axes)
    if function == "Gauss":
        return Gaussian(width, cutoff=3 * width if cutoff is None else cutoff, normalize="truncated",
                        averaged_axes=averaged_axes, line_quadrature=line_quadrature)
    if function == "Heaviside":
        return Heaviside(width, averaged_axes=averaged_axes)
    raise ValueError(f"function: expected Lucy, Gauss or Heaviside (MercuryCG's names), got {function!r}")


# ----------------------------------------------------------------------------------------------
def _header(path, line):
    tokens = line.split()
    if not tokens or not (tokens[0].startswith("CG<") and tokens[0].endswith(">")):
        raise ValueError(f"{path}: line 1: expected a MercuryCG header starting with CG<...>, got {line[:60]!r}")
    coords = tokens[0][3:-1]
    if coords != "O" and (not coords or any(c not in AXES for c in coords) or list(coords) != sorted(set(coords))):
        raise ValueError(f"{path}: line 1: expected coordinates O or a subset of XYZ in order, got {coords!r}")
    out = {"coordinates": coords}
    k = 1

    def numbers(count, what):
        nonlocal k
        try:
            values = [float(t) for t in tokens[k + 1:k + 1 + count]]
        except ValueError:
            values = []
        if len(values) != count:
            raise ValueError(f"{path}: line 1: expected {count} number(s) after {what!r}, got "
                             f"{' '.join(tokens[k + 1:k + 1 + count])!r}")
        k += 1 + count
        return values

    while k < len(tokens):
        key = tokens[k]
        if key in ("min", "max", "n"):
            out[key] = numbers(3, key)
        elif key in ("timeMin", "timeMax", "width", "cutoff"):
            out[key] = numbers(1, key)[0]
        elif key in ("Lucy", "Gauss", "Heaviside"):
            out["function"] = key
            k += 1
        else:
            raise ValueError(f"{path}: line 1: unknown header entry {key!r} (expected min, max, timeMin, timeMax, "
                             "n, width, Lucy/Gauss/Heaviside, cutoff)")
    for key in ("min", "max", "n", "width", "function"):
        if key not in out:
            raise ValueError(f"{path}: line 1: the header has no {key!r}")
    if "cutoff" not in out:
        out["cutoff"] = 3 * out["width"] if out["function"] == "Gauss" else out["width"]
    return out


def _column_line(path, line, coords):
    tokens = line.split()
    resolved = "" if coords == "O" else coords
    expected = ["time"] + [a.lower() for a in resolved]
    if tokens[:len(expected)] != expected:
        raise ValueError(f"{path}: line 2: expected the columns to start with {' '.join(expected)!r}, got "
                         f"{' '.join(tokens[:len(expected)])!r}")
    specs = []
    nxt = len(expected) + 1
    for tok in tokens[len(expected):]:
        span, _, name = tok.partition(":")
        try:
            lo, _, hi = span.partition("-")
            lo, hi = int(lo), int(hi) if hi else int(lo)
        except ValueError:
            raise ValueError(f"{path}: line 2: expected 'first[-last]:Name', got {tok!r}") from None
        if lo != nxt or hi < lo or not name:
            raise ValueError(f"{path}: line 2: column range {tok!r} does not follow column {nxt - 1}")
        count = hi - lo + 1
        if name in COMPONENTS and len(COMPONENTS[name]) != count and not (count == 1 and not COMPONENTS[name]):
            raise ValueError(f"{path}: line 2: {name} has {count} columns, MercuryCG writes "
                             f"{max(len(COMPONENTS[name]), 1)}")
        specs.append((name, lo - 1, count))
        nxt = hi + 1
    return specs, nxt - 1


def _expand(name, values):
    """Columns of one MercuryCG quantity -> cgbound's array layout (last axes)."""
    if name == "MomentumFlux":
        out = np.empty(values.shape[:-1] + (3, 3))
        for c, (a, b) in enumerate(_SYMMETRIC):
            out[..., a, b] = out[..., b, a] = values[..., c]
        return out
    if name == "ContactStress":
        return values.reshape(values.shape[:-1] + (3, 3))
    if values.shape[-1] == 1 and not COMPONENTS.get(name, ("?",)):
        return values[..., 0]
    return values


def _stat_text(path):
    """The text of a .stat file (plain or gzipped, by its magic bytes), or a ValueError naming the file."""
    with open(path, "rb") as fh:
        raw = fh.read()
    if raw[:2] == b"\x1f\x8b":
        try:
            raw = gzip.decompress(raw)
        except (OSError, EOFError, zlib.error) as exc:
            raise ValueError(f"{path}: a damaged gzip file ({exc}); decompress it with gunzip to see where") from None
    return decode_text(path, raw, "a MercuryCG .stat file")


def read_stat(path):
    """Read a MercuryCG ``.stat`` file into a :class:`StatFile`."""
    path = os.fspath(path)
    fh = io.StringIO(_stat_text(path))
    first = fh.readline()
    second = fh.readline()
    head = _header(path, first)
    specs, ncol = _column_line(path, second, head["coordinates"])
    try:
        rows = np.loadtxt(fh, ndmin=2)
    except ValueError as exc:
        raise ValueError(f"{path}: the data rows are not numbers: {exc}") from None
    if rows.shape[0] == 0:
        raise ValueError(f"{path}: no data rows")
    if not np.all(np.isfinite(rows)):
        row = int(np.flatnonzero(~np.all(np.isfinite(rows), axis=1))[0])
        raise ValueError(f"{path}: line {3 + row}: expected finite numbers, got {rows[row][~np.isfinite(rows[row])][0]} "
                         f"(MercuryCG writes finite values: the file is damaged)")
    if rows.shape[1] != ncol:
        raise ValueError(f"{path}: line 3: expected {ncol} columns (from line 2), got {rows.shape[1]}")
    coords = head["coordinates"]
    resolved = "" if coords == "O" else coords
    lower, upper = np.array(head["min"]), np.array(head["max"])
    n = np.array(head["n"], dtype=float)
    if np.any(n < 1) or np.any(n != np.round(n)):
        raise ValueError(f"{path}: line 1: expected positive integer node counts, got {head['n']}")
    n = n.astype(int)
    shape = tuple(int(n[AXES.index(a)]) for a in resolved)
    per_time = int(np.prod(shape)) if shape else 1
    if rows.shape[0] % per_time:
        raise ValueError(f"{path}: {rows.shape[0]} data rows is not a whole number of time blocks of {per_time} nodes")
    nt = rows.shape[0] // per_time
    rows = rows.reshape(nt, per_time, ncol)
    times = rows[:, 0, 0]
    if np.any(rows[:, :, 0] != times[:, None]):
        t = int(np.flatnonzero(np.any(rows[:, :, 0] != times[:, None], axis=1))[0])
        raise ValueError(f"{path}: the time block starting at row {3 + t * per_time} mixes times")
    axis_coordinates = {}
    index = []
    for c, a in enumerate(resolved):
        d = AXES.index(a)
        h = (upper[d] - lower[d]) / n[d]
        axis_coordinates[a.lower()] = lower[d] + (np.arange(n[d]) + 0.5) * h
        k = np.rint((rows[:, :, 1 + c] - lower[d]) / h - 0.5).astype(np.int64)
        if np.any((k < 0) | (k >= n[d])) or np.any(np.abs(axis_coordinates[a.lower()][np.clip(k, 0, n[d] - 1)]
                                                          - rows[:, :, 1 + c]) > 1e-4 * max(h, 1e-300) + 1e-5 * abs(rows[:, :, 1 + c])):
            raise ValueError(f"{path}: a {a.lower()} coordinate is not a node of the header's grid")
        index.append(k)
    flat = np.ravel_multi_index(index, shape) if shape else np.zeros((nt, 1), np.int64)
    order = np.argsort(flat, axis=1, kind="stable")
    if shape and np.any(np.take_along_axis(flat, order, axis=1) != np.arange(per_time)):
        raise ValueError(f"{path}: a time block does not hold every node exactly once")
    rows = np.take_along_axis(rows, order[:, :, None], axis=1)
    columns = {}
    for name, first, count in specs:
        values = rows[:, :, first:first + count].reshape((nt,) + shape + (count,))
        columns[name] = _expand(name, values)
    return StatFile(coordinates=coords, lower=lower, upper=upper, n=n, function=head["function"],
                    width=head["width"], cutoff=head["cutoff"], time_min=head.get("timeMin"),
                    time_max=head.get("timeMax"), times=times, axis_coordinates=axis_coordinates,
                    columns=columns, column_order=tuple(s[0] for s in specs), path=path)


def to_fields(stat, convention="tension"):
    """cgbound's fields from a :class:`StatFile` (arrays shaped like ``stat.columns``).

    Gives ``volume_fraction``, ``density``, ``momentum``, ``momentum_flux``,
    ``interaction_force_density``, ``contact_and_boundary_stress`` (cgbound's
    ``contact_stress + boundary_stress``), ``kinetic_stress`` (from MomentumFlux, Momentum and
    Density; NaN where the density is 0) and ``stress`` (their sum), in the given stress
    ``convention`` ("tension", the paper's, or "compression", MercuryCG's), as far as the file holds them.
    """
    if convention not in ("tension", "compression"):
        raise ValueError(f"convention: expected 'tension' or 'compression', got {convention!r}")
    sign = 1.0 if convention == "compression" else -1.0
    c = stat.columns
    out = {}
    for ours, theirs in (("volume_fraction", "VolumeFraction"), ("density", "Density"), ("momentum", "Momentum"),
                         ("momentum_flux", "MomentumFlux"), ("interaction_force_density", "InteractionForce")):
        if theirs in c:
            out[ours] = c[theirs].copy()
    if "ContactStress" in c:
        out["contact_and_boundary_stress"] = sign * c["ContactStress"]
    if all(k in c for k in ("MomentumFlux", "Momentum", "Density")):
        rho = c["Density"][..., None, None]
        pp = c["Momentum"][..., :, None] * c["Momentum"][..., None, :]
        with np.errstate(invalid="ignore", divide="ignore"):
            kinetic = np.where(rho > 0, c["MomentumFlux"] - pp / np.where(rho > 0, rho, 1.0), np.nan)
        out["kinetic_stress"] = sign * kinetic
        if "ContactStress" in c:
            out["stress"] = out["kinetic_stress"] + out["contact_and_boundary_stress"]
    return out


# ----------------------------------------------------------------------------------------------
def _kernel_header(kernel, grid):
    if grid.averaged and grid.resolved and isinstance(kernel, (Lucy, Heaviside)) and not kernel.lower_dimensional:
        # MercuryCG's header names its kernel, which over averaged axes is the lower-dimensional one
        raise ValueError(f"result: a MercuryCG .stat file of a {''.join(AXES[d] for d in grid.resolved)} grid holds "
                         f"MercuryCG's lower-dimensional {type(kernel).__name__} over the averaged axes; this result "
                         f"used the marginal of the 3-D kernel ({kernel!r}). Coarse grain with "
                         f"cg.{type(kernel).__name__}({kernel.radius:g}, averaged_axes='lower-dimensional')")
    if isinstance(kernel, Lucy):
        return f"width {kernel.cutoff:g} Lucy cutoff {kernel.cutoff:g}"
    if isinstance(kernel, Gaussian):
        if not (kernel.truncated and np.isclose(kernel.cutoff, 3 * kernel.width, rtol=1e-12)):
            raise ValueError(f"result: MercuryCG's Gauss is cut off at 3 widths and renormalised over the cut-off "
                             f"ball; this result used {kernel!r}. Coarse grain with "
                             f"cg.Gaussian({kernel.width:g}, cutoff={3 * kernel.width:g}, normalize='truncated')")
        return f"width {kernel.width:g} Gauss width {kernel.width:g} cutoff {kernel.cutoff:g}"
    if isinstance(kernel, Heaviside):
        return f"width {kernel.radius:g} Heaviside cutoff {kernel.radius:g}"
    raise ValueError(f"result: expected a Lucy, Gaussian or Heaviside kernel, got {kernel!r}")


def _mercury_columns(result, sign):
    """MercuryCG column name -> array (..., components) from the fields a result holds."""
    f = result.as_dict()
    out = {}
    if "volume_fraction" in f:
        out["VolumeFraction"] = f["volume_fraction"][..., None]
    if "density" in f:
        out["Density"] = f["density"][..., None]
    if "momentum" in f:
        out["Momentum"] = f["momentum"]
    if "momentum_flux" in f:
        k = f["momentum_flux"]
        out["MomentumFlux"] = np.stack([k[..., a, b] for a, b in _SYMMETRIC], axis=-1)
    contact = None
    if "contact_stress" in f and "boundary_stress" in f:
        contact = f["contact_stress"] + f["boundary_stress"]
    elif "stress" in f and "kinetic_stress" in f:
        contact = f["stress"] - f["kinetic_stress"]
    if contact is not None:
        out["ContactStress"] = sign * contact.reshape(contact.shape[:-2] + (9,))
    if "interaction_force_density" in f:
        out["InteractionForce"] = f["interaction_force_density"]
    return {name: out[name] for name in COMPONENTS if name in out}


def write_stat(path, result, *, time=None, time_min=None, time_max=None, digits=6):
    """Write a cgbound :class:`~cgbound.result.Result` on a 3-D :class:`~cgbound.grid.Grid` as a MercuryCG
    ``.stat`` file; returns the path.

    Written are the MercuryCG columns the result's fields give (see the module docstring):
    ContactStress needs ``contact_stress`` and ``boundary_stress`` (or ``stress`` and
    ``kinetic_stress``), and is written compression-positive whatever the result's convention.
    ParticleSize is not written (cgbound has no such field). ``time``: the time written on each row
    of a result without a time axis (default: the result's first snapshot time); results with a
    time axis (``time_average="none"``) write one block per time. ``digits``: significant digits
    (MercuryCG writes 6).
    """
    grid = result.grid
    if not isinstance(grid, Grid):
        raise ValueError(f"result: expected a result on a cg.Grid (MercuryCG writes grids), got {type(grid).__name__}")
    if grid.dim != 3:
        raise ValueError(f"result: expected a 3-D result (MercuryCG's stat files are 3-D), got {grid.dim}-D")
    if not (isinstance(digits, int) and 1 <= digits <= 17):
        raise ValueError(f"digits: expected an integer in 1..17, got {digits!r}")
    sign = -1.0 if result.convention == "tension" else 1.0
    columns = _mercury_columns(result, sign)
    if not columns:
        raise ValueError(f"result: no MercuryCG column can be written from the fields {list(result.fields)}; "
                         "expected some of density, volume_fraction, momentum, momentum_flux, contact_stress + "
                         "boundary_stress, interaction_force_density")
    kernel_text = _kernel_header(result.kernel, grid)
    resolved = "".join(AXES[d] for d in grid.resolved)
    coords = resolved or "O"
    shape = tuple(grid.shape[d] for d in grid.resolved)
    per_time = int(np.prod(shape)) if shape else 1
    first = next(iter(columns.values()))
    lead = first.shape[:first.ndim - len(grid.shape) - 1]
    if lead not in ((), (len(result.times),)):
        raise ValueError(f"result: fields shaped {first.shape} do not match the grid {grid.shape}")
    if lead:
        times = np.asarray(result.times, dtype=float)
    else:
        times = np.array([float(result.times[0]) if time is None else float(time)])
    blocks = [v.reshape((len(times), per_time, -1)) for v in columns.values()]
    # MercuryCG's node order: the last resolved axis fastest (C order over the grid's resolved axes)
    mesh = np.meshgrid(*[grid.axis_coordinates[d] for d in grid.resolved], indexing="ij")
    node_coords = np.stack([m.ravel() for m in mesh], axis=1) if shape else np.zeros((1, 0))
    fmt = f"%.{digits}g"

    def g(x):
        return fmt % x

    head = [f"CG<{coords}>", "min", *map(g, grid.box.lower), "max", *map(g, grid.box.upper)]
    if time_min is not None:
        head += ["timeMin", g(time_min)]
    if time_max is not None:
        head += ["timeMax", g(time_max)]
    head += ["n", *(str(k) for k in grid.shape), kernel_text]
    names = ["time"] + [a.lower() for a in resolved]
    col = len(names) + 1
    for name, v in columns.items():
        count = v.shape[-1]
        names.append(f"{col}:{name}" if count == 1 else f"{col}-{col + count - 1}:{name}")
        col += count
    lines = [" ".join(head), " ".join(names) + " "]
    for t, tv in enumerate(times):
        data = np.concatenate([np.full((per_time, 1), tv), node_coords] + [b[t] for b in blocks], axis=1)
        lines.extend(" ".join(fmt % x for x in row) for row in data)
    tmp = os.fspath(path) + ".part"
    with open(tmp, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    os.replace(tmp, path)
    return path
