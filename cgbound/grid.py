"""Where fields are evaluated: regular grids (with averaged axes) and point sets."""
import math
import numbers

import numpy as np

from ._memory import check_fits, grid_doubles
from ._validate import counts_per_axis, integer, real_array
from .box import Box


def _axis_index(name, dim):
    names = ("x", "z") if dim == 2 else ("x", "y", "z")
    if isinstance(name, str):
        if name not in names:
            raise ValueError(f"average: expected axis names {names} or indices, got unknown axis {name!r}")
        return names.index(name)
    try:
        index = integer(name, "average")
    except TypeError:
        raise TypeError(f"average: expected axis names {names} or indices, got {name!r}") from None
    if not 0 <= index < dim:
        raise ValueError(f"average: expected axis indices in [0, {dim}), got {index}")
    return index


def _averaged_axes(average, dim):
    if isinstance(average, (str, numbers.Integral)):
        average = (average,)
    try:
        average = tuple(average)
    except TypeError:
        raise TypeError(f"average: expected a sequence of axis names or indices, got {average!r}") from None
    axes = [_axis_index(a, dim) for a in average]
    if len(set(axes)) != len(axes):
        raise ValueError(f"average: expected each axis at most once, got {average!r}")
    return sorted(axes)


class Grid:
    """Regular grid of cell-centred nodes, ``lower + (k + 1/2) h`` along each resolved axis.

    Parameters
    ----------
    box : Box
        The region covered (also where averaged axes take their extent).
    shape : sequence of D ints
        Nodes per axis; averaged axes must have 1.
    average : sequence of axis names ("x", "y", "z"; in 2D "x", "z") or indices
        Axes averaged over analytically (exact kernel marginals divided by the box extent).
    """

    def __init__(self, box, shape, average=()):
        if not isinstance(box, Box):
            raise TypeError(f"box: expected a cg.Box, got {type(box).__name__}")
        dim = box.dim
        averaged = _averaged_axes(average, dim)
        if isinstance(shape, (bool, np.bool_)):
            raise TypeError(f"shape: expected {dim} positive integers, got {shape!r}")
        if isinstance(shape, numbers.Integral):
            shape = tuple(1 if d in averaged else int(shape) for d in range(dim))
        shape = counts_per_axis(shape, "shape", dim, "node")
        for d in averaged:
            if shape[d] != 1:
                raise ValueError(f"shape: expected 1 node along the averaged axis {box.axis_names[d]}, got {shape[d]}")
        # before allocating the axes (coarse graining checks the fields, with these axes, before its work)
        check_fits("shape", 0, 0, what=f"a grid of shape {shape!r}", extra_doubles=grid_doubles(shape))
        self.box = box
        self.shape = shape
        self.averaged = tuple(averaged)
        self.resolved = tuple(d for d in range(dim) if d not in averaged)
        spacing = box.lengths / np.array(self.shape, dtype=float)
        self.spacing = spacing
        axes = []
        for d in range(dim):
            # lower + (k + 1/2) h, computed in place (one array per axis: bitwise the same as the expression)
            c = np.arange(self.shape[d], dtype=float)
            c += 0.5
            c *= spacing[d]
            c += box.lower[d]
            c.setflags(write=False)
            axes.append(c)
        self.axis_coordinates = tuple(axes)

    @property
    def dim(self):
        return self.box.dim

    @property
    def size(self):
        return math.prod(self.shape)  # a Python int: no overflow for absurd shapes

    @property
    def avg_extent(self):
        return float(np.prod([self.box.lengths[d] for d in self.averaged])) if self.averaged else 1.0

    @property
    def coordinates(self):
        """Node coordinates, shape ``shape + (D,)``; averaged axes hold the box centre."""
        mesh = np.meshgrid(*self.axis_coordinates, indexing="ij")
        return np.stack(mesh, axis=-1)

    @property
    def field_shape(self):
        return self.shape

    def __repr__(self):
        names = self.box.axis_names
        res = "".join(names[d] for d in self.resolved).upper() or "O"
        return f"Grid({res}, shape={self.shape}, averaged={tuple(names[d] for d in self.averaged)})"


class Points:
    """Arbitrary evaluation points, shape (P, D); fields come back with shape (P, ...)."""

    averaged = ()
    avg_extent = 1.0

    def __init__(self, positions, _name="points"):
        pts = real_array(positions, _name, ndim=2)
        if pts.shape[1] not in (2, 3):
            raise ValueError(f"{_name}: expected shape (P, 2) or (P, 3), got {pts.shape}")
        self.positions = pts

    @property
    def dim(self):
        return self.positions.shape[1]

    @property
    def resolved(self):
        return tuple(range(self.dim))

    @property
    def size(self):
        return self.positions.shape[0]

    @property
    def field_shape(self):
        return (self.positions.shape[0],)

    @property
    def coordinates(self):
        return self.positions

    def __repr__(self):
        return f"Points({self.positions.shape[0]} points in {self.dim}D)"


def check_target(where, dim, name="grid"):
    if isinstance(where, (Grid, Points)):
        target = where
    else:
        target = Points(where, _name=name)
    if target.dim != dim:
        raise ValueError(f"{name}: expected a {dim}D grid or points like the snapshot, got a {target.dim}D {type(target).__name__}")
    return target


def periodic_resolved_lengths(box, target):
    """{axis name: period} of the target's resolved axes that are periodic in ``box``."""
    return {box.axis_names[d]: float(box.lengths[d]) for d in target.resolved if box.periodic[d]}
