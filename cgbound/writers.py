"""Writers for coarse-grained results: HDF5, NumPy .npz, VTK (ParaView) and xarray.

Every writer goes through a temporary file and a rename, so an existing file is
replaced only by a complete new one.

Units (when the result knows them, :mod:`cgbound.units`): CF-style ``units`` attributes on every field
and coordinate in HDF5 and xarray, the system in the metadata (``units_system``, JSON), and in VTK the
header line (legacy VTK has no attributes): ``cgbound fields; units <system>; <field> [<unit>]; ...``.
"""
import json

import numpy as np

from ._atomic import atomic_write
from .cylindrical import CylindricalGrid
from .fields import field_shape
from .grid import Grid
from .units import unit


def _metadata(result):
    from ._version import __version__

    k = result.kernel
    meta = {
        "cgbound_version": __version__,
        "kernel": type(k).__name__,
        "width": float(getattr(k, "width", None) or k.radius),
        "cutoff": float(k.radius),
        "normalize": getattr(k, "normalize", ""),
        "line_quadrature": str(getattr(k, "line_quadrature", "")),
        "averaged_axes": k.averaged_axes,
        "convention": result.convention,
        "times": [float(t) for t in np.atleast_1d(result.times)],
        "box_lower": result.box.lower.tolist(),
        "box_upper": result.box.upper.tolist(),
        "periodic": list(result.box.periodic),
    }
    if result.units is not None:
        meta["units_system"] = json.dumps(result.units.as_dict())
    if getattr(result, "n_frames", None) is not None:
        meta["n_frames"] = int(result.n_frames)
    g = result.grid
    if isinstance(g, Grid):
        meta.update(grid_shape=list(g.shape), averaged=[g.box.axis_names[d] for d in g.averaged])
    if isinstance(g, CylindricalGrid):
        # vectors and tensors are in the local basis (e_r, e_θ, e_z) of docs/guide/cylindrical.md
        meta.update(grid_shape=list(g.shape), components=list(CYLINDRICAL_AXES), cylindrical=json.dumps({
            "axis_point": g.axis_point.tolist(), "axis": g.e_z.tolist(), "angle_origin": g.e_1.tolist(),
            "theta_averaged": g.theta_averaged, "z_averaged": g.z_averaged}))
    return meta


#: the coordinates of a CylindricalGrid's axes, and the names of vector and tensor components on it
CYLINDRICAL_AXES = ("r", "theta", "z")


def axis_coordinates(grid):
    """[(name, node coordinates)] of a Grid's or a CylindricalGrid's axes (an averaged axis: its centre)."""
    if isinstance(grid, CylindricalGrid):
        return [(name, getattr(grid, name)) for name in CYLINDRICAL_AXES]
    return list(zip(grid.box.axis_names, grid.axis_coordinates))


def write_hdf5(result, path, provenance=None):
    """Fields, grid coordinates and metadata (kernel, width, cutoff, convention, version, provenance)."""
    import h5py

    meta = _metadata(result)

    def write(tmp):
        with h5py.File(tmp, "w") as f:
            f.attrs["format"] = "cgbound-fields"
            for key, value in meta.items():
                f.attrs[key] = value if not isinstance(value, list) or value else np.array([])
            f.attrs["provenance"] = provenance if isinstance(provenance, str) else json.dumps(provenance or {})
            length = unit("length", result.units, result.box.dim)
            coordinates = f.create_dataset("coordinates", data=result.coordinates)
            if length is not None:
                coordinates.attrs["units"] = length
            if isinstance(result.grid, (Grid, CylindricalGrid)):
                for name, axis in axis_coordinates(result.grid):
                    data = f.create_dataset(f"axes/{name}", data=axis)
                    if length is not None:
                        data.attrs["units"] = "radian" if name == "theta" else length
            fields = f.create_group("fields")
            for name in result.fields:
                data = fields.create_dataset(name, data=result[name], chunks=True if result[name].size > 1 else None,
                                             compression="gzip" if result[name].size > 1 else None)
                if result.units is not None:
                    data.attrs["units"] = result.unit(name)
    return atomic_write(path, write, suffix=".h5")


def write_npz(result, path):
    """Fields plus ``coordinates`` and a JSON ``metadata`` string in one compressed .npz."""
    arrays = {name: result[name] for name in result.fields}
    arrays["coordinates"] = result.coordinates
    arrays["metadata"] = np.array(json.dumps(_metadata(result)))

    def write(tmp):
        with open(tmp, "wb") as f:
            np.savez_compressed(f, **arrays)
    return atomic_write(path, write, suffix=".npz")


def write_vtk(result, path, frame=None):
    """Legacy binary VTK RECTILINEAR_GRID readable by ParaView (regular grids only).

    Scalars become SCALARS, vectors VECTORS (3 components; 2-D data is padded with a zero
    y component and laid out in ParaView's x, y, z), tensors TENSORS (3 x 3). With a
    leading time axis, ``frame`` selects which one to write.
    """
    grid = result.grid
    if not isinstance(grid, Grid):
        raise TypeError(f"result: VTK output needs a result on a cg.Grid (a rectilinear grid), got one on "
                        f"{type(grid).__name__}")
    dim = grid.dim
    leading = result[result.fields[0]].ndim - len(grid.shape) - len(field_shape(result.fields[0], dim))
    if leading and frame is None:
        raise ValueError("frame: this result has a time axis; choose a frame index")
    axes3 = list(grid.axis_coordinates) if dim == 3 else [grid.axis_coordinates[0], np.zeros(1), grid.axis_coordinates[1]]
    shape3 = [a.size for a in axes3]
    n = int(np.prod(shape3))

    def to3(vec):
        return vec if dim == 3 else np.stack([vec[..., 0], np.zeros(vec.shape[:-1]), vec[..., 1]], axis=-1)

    def write(tmp):
        with open(tmp, "wb") as f:
            f.write(b"# vtk DataFile Version 3.0\n" + _vtk_title(result).encode() + b"\nBINARY\nDATASET RECTILINEAR_GRID\n")
            f.write(f"DIMENSIONS {shape3[0]} {shape3[1]} {shape3[2]}\n".encode())
            for label, axis in zip("XYZ", axes3):
                f.write(f"{label}_COORDINATES {axis.size} double\n".encode())
                f.write(np.asarray(axis, ">f8").tobytes() + b"\n")
            f.write(f"POINT_DATA {n}\n".encode())
            for name in result.fields:
                value = result[name] if not leading else result[name][frame]
                rank = len(field_shape(name, dim))
                if dim == 2:
                    value = value.reshape((grid.shape[0], 1, grid.shape[1]) + value.shape[2:])
                # VTK point order: x fastest
                value = np.moveaxis(value, (0, 1, 2), (2, 1, 0))
                if rank == 0:
                    f.write(f"SCALARS {name} double 1\nLOOKUP_TABLE default\n".encode())
                    data = value
                elif rank == 1:
                    f.write(f"VECTORS {name} double\n".encode())
                    data = to3(value)
                else:
                    f.write(f"TENSORS {name} double\n".encode())
                    data = value if dim == 3 else _pad_tensor(value)
                f.write(np.ascontiguousarray(np.nan_to_num(data, nan=np.nan), ">f8").tobytes() + b"\n")
    return atomic_write(path, write, suffix=".vtk")


def _vtk_title(result):
    """The legacy VTK header line (at most 255 characters): the units of the fields when known."""
    if result.units is None:
        return "cgbound fields"
    title = f"cgbound fields; units {result.units.name or 'custom'}"
    full = title + "".join(f"; {name} [{result.unit(name)}]" for name in result.fields)
    title = full if len(full) <= 255 else title + f" (length {result.units.length}, mass {result.units.mass}, " \
        f"time {result.units.time})"
    return title.replace("\n", " ")[:255]


def _pad_tensor(t):
    out = np.zeros(t.shape[:-2] + (3, 3))
    idx = [0, 2]
    for a in range(2):
        for b in range(2):
            out[..., idx[a], idx[b]] = t[..., a, b]
    return out


def to_xarray(result):
    """An xarray.Dataset with named dimensions and coordinates (xarray is optional)."""
    try:
        import xarray as xr
    except ImportError as exc:
        raise ImportError("to_xarray needs xarray: pip install xarray") from exc
    grid = result.grid
    cylindrical = isinstance(grid, CylindricalGrid)
    names = CYLINDRICAL_AXES if cylindrical else result.box.axis_names
    comp = list(names)
    data_vars = {}
    coords = {}
    leading_dims = ()
    times = np.atleast_1d(result.times)
    for name in result.fields:
        value = result[name]
        rank = len(field_shape(name, result.box.dim))
        if isinstance(grid, (Grid, CylindricalGrid)):
            space = tuple(names)
        else:
            space = ("point",)
        n_lead = value.ndim - len(space) - rank
        leading_dims = ("time",) * n_lead
        dims = leading_dims + space + (("component",) if rank >= 1 else ()) + (("component2",) if rank == 2 else ())
        data_vars[name] = (dims, value, {"units": result.unit(name)} if result.units is not None else {})
    length = unit("length", result.units, result.box.dim)
    length_attrs = {"units": length} if length is not None else {}
    if isinstance(grid, (Grid, CylindricalGrid)):
        for name, axis in axis_coordinates(grid):
            coords[name] = (name, axis, {"units": "radian"} if name == "theta" and length is not None else length_attrs)
    else:
        for d, name in enumerate(names):
            coords[name] = ("point", grid.positions[:, d], length_attrs)
    coords["component"] = comp
    coords["component2"] = comp
    if leading_dims:
        time_unit = unit("time", result.units, result.box.dim)
        coords["time"] = ("time", times, {"units": time_unit} if time_unit is not None else {})
    attrs = {k: (json.dumps(v) if isinstance(v, list) else v) for k, v in _metadata(result).items()}
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)
