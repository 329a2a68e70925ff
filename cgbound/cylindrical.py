"""Cylindrical grids: nodes in (r, θ, z) about an axis, with θ and z resolved or averaged.

Conventions (docs/guide/cylindrical.md): the axis passes through ``axis_point`` along the unit vector
e_z; θ is measured from a fixed unit vector e_1 perpendicular to the axis towards e_2 = e_z × e_1
(for a box axis "z": e_1 = x̂, e_2 = ŷ; "x": e_1 = ŷ, e_2 = ẑ; "y": e_1 = ẑ, e_2 = x̂; for a general
direction e_1 is the box axis least aligned with it, made perpendicular); the local basis at angle θ is
e_r = cos θ e_1 + sin θ e_2, e_θ = -sin θ e_1 + cos θ e_2, e_z. Nodes are cell-centred like
:class:`cgbound.Grid`, so no node lies on the axis (r_min >= 0).
"""
import math
import numbers

import numpy as np

from ._validate import integer
from .box import Box

AXES = {"x": 0, "y": 1, "z": 2}
# the angle origin e_1 for each box axis (e_1, e_2 = e_z x e_1 a right-handed cyclic pair)
ANGLE_ORIGIN = {0: 1, 1: 2, 2: 0}


def _real(value, name, what):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name}: expected {what}, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name}: expected {what}, got {value!r}")
    return value


def _range(spec, name, lower_bound=None):
    """(lo, hi, n) checked: finite lo < hi, n a positive integer."""
    what = f"({name}_min, {name}_max, n_{name})"
    if isinstance(spec, (str, bytes)) or not hasattr(spec, "__len__") or len(spec) != 3:
        raise TypeError(f"{name}: expected {what}, got {spec!r}")
    lo = _real(spec[0], name, f"a finite {name}_min")
    hi = _real(spec[1], name, f"a finite {name}_max")
    n = integer(spec[2], name)
    if n < 1:
        raise ValueError(f"{name}: expected n_{name} >= 1, got {n}")
    if not hi > lo:
        raise ValueError(f"{name}: expected {name}_min < {name}_max, got {lo!r} >= {hi!r}")
    if lower_bound is not None and lo < lower_bound:
        raise ValueError(f"{name}: expected {name}_min >= {lower_bound}, got {lo!r}")
    return lo, hi, n


def _cell_centres(lo, hi, n):
    c = lo + (np.arange(n, dtype=float) + 0.5) * ((hi - lo) / n)
    c.setflags(write=False)
    return c


class CylindricalGrid:
    """Nodes in cylindrical coordinates (r, θ, z) about an axis; θ and z resolved or averaged.

    Parameters
    ----------
    box : Box
        The (3-D) region of the particles; when ``z`` is None the axial coordinate is averaged over
        the box's extent along ``axis`` (which must then be a box axis).
    axis_point : 3 floats
        A point on the axis; z is measured from it along ``axis``.
    axis : "x", "y", "z" or 3 floats
        The axis direction (normalised here).
    r : (r_min, r_max, n_r)
        Radial nodes, cell-centred: ``r_min + (k + 1/2)(r_max - r_min)/n_r``; r_min >= 0.
    theta : None or int
        None: fields averaged over θ (the ring average); n: n nodes ``(k + 1/2) 2π/n``.
    z : None or (z_min, z_max, n_z)
        None: averaged over the box's extent along the axis; else cell-centred axial nodes.

    Fields on it have shape ``(n_r, n_theta or 1, n_z or 1)`` (+ (3,) for vectors in (r, θ, z)
    components, + (3, 3) for tensors in the basis (e_r, e_θ, e_z)).
    """

    def __init__(self, box, axis_point=(0.0, 0.0, 0.0), axis="z", r=None, theta=None, z=None):
        if not isinstance(box, Box):
            raise TypeError(f"box: expected a cg.Box, got {type(box).__name__}")
        if box.dim != 3:
            raise ValueError(f"box: expected a 3-D box (cylindrical coordinates are 3-D only), got a {box.dim}-D box")
        try:
            point = np.array(axis_point, dtype=float)
        except (TypeError, ValueError):
            raise TypeError(f"axis_point: expected 3 finite floats, got {axis_point!r}") from None
        if point.shape != (3,) or not np.all(np.isfinite(point)):
            raise ValueError(f"axis_point: expected 3 finite floats, got {axis_point!r}")
        self.box_axis = None
        if isinstance(axis, str):
            if axis not in AXES:
                raise ValueError(f"axis: expected 'x', 'y', 'z' or a 3-vector, got {axis!r}")
            self.box_axis = AXES[axis]
            e_z = np.eye(3)[self.box_axis]
            e_1 = np.eye(3)[ANGLE_ORIGIN[self.box_axis]]
        else:
            try:
                direction = np.array(axis, dtype=float)
            except (TypeError, ValueError):
                raise TypeError(f"axis: expected 'x', 'y', 'z' or a 3-vector, got {axis!r}") from None
            if direction.shape != (3,) or not np.all(np.isfinite(direction)):
                raise ValueError(f"axis: expected 'x', 'y', 'z' or a finite 3-vector, got {axis!r}")
            norm = float(np.linalg.norm(direction))
            if norm == 0.0:
                raise ValueError("axis: expected a non-zero direction, got (0, 0, 0)")
            e_z = direction / norm
            for d in range(3):
                if np.array_equal(np.abs(e_z), np.eye(3)[d]):
                    self.box_axis = d
            if self.box_axis is not None and e_z[self.box_axis] > 0:
                e_1 = np.eye(3)[ANGLE_ORIGIN[self.box_axis]]
            else:
                least = int(np.argmin(np.abs(e_z)))
                e_1 = np.eye(3)[least] - e_z[least] * e_z
                e_1 /= np.linalg.norm(e_1)
        if r is None:
            raise TypeError("r: expected (r_min, r_max, n_r), got None")
        self.r_range = _range(r, "r", lower_bound=0.0)
        if theta is not None:
            theta = integer(theta, "theta")
            if theta < 1:
                raise ValueError(f"theta: expected None (averaged) or n_theta >= 1, got {theta}")
        if z is None:
            if self.box_axis is None or e_z[self.box_axis] < 0:
                raise ValueError("z: None averages over the box's extent along the axis, which needs axis 'x', 'y' "
                                 f"or 'z'; got axis {axis!r}: give z=(z_min, z_max, n_z)")
            self.z_range = None
        else:
            self.z_range = _range(z, "z")
        self.box = box
        self.axis_point = point
        self.axis_point.setflags(write=False)
        self.e_z = e_z
        self.e_1 = e_1
        self.e_2 = np.cross(e_z, e_1)
        self.r = _cell_centres(*self.r_range)
        self.n_theta = theta
        self.theta = _cell_centres(0.0, 2 * math.pi, theta if theta is not None else 1)
        if self.z_range is None:
            d = self.box_axis
            self.z_extent = (float(box.lower[d] - point[d]), float(box.upper[d] - point[d]))
            self.z = _cell_centres(*self.z_extent, 1)
        else:
            self.z = _cell_centres(*self.z_range)
        self.shape = (len(self.r), theta or 1, len(self.z))

    dim = 3

    @property
    def field_shape(self):
        return self.shape

    @property
    def size(self):
        return math.prod(self.shape)

    @property
    def theta_averaged(self):
        return self.n_theta is None

    @property
    def z_averaged(self):
        return self.z_range is None

    def basis(self, theta):
        """Rows e_r, e_θ, e_z at the angles ``theta`` in Cartesian components, shape theta.shape + (3, 3)."""
        theta = np.asarray(theta, dtype=float)
        c, s = np.cos(theta)[..., None], np.sin(theta)[..., None]
        e_r = c * self.e_1 + s * self.e_2
        e_t = -s * self.e_1 + c * self.e_2
        e_z = np.broadcast_to(self.e_z, e_r.shape)
        return np.stack([e_r, e_t, e_z], axis=-2)

    def cartesian(self, r, theta, z):
        """Cartesian positions of (r, θ, z) (broadcast), shape (..., 3)."""
        r, theta, z = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (r, theta, z)))
        return (self.axis_point + r[..., None] * (np.cos(theta)[..., None] * self.e_1 + np.sin(theta)[..., None] * self.e_2)
                + z[..., None] * self.e_z)

    @property
    def coordinates(self):
        """Cartesian node positions, shape ``shape + (3,)``; averaged coordinates hold their centre."""
        R, T, Z = np.meshgrid(self.r, self.theta, self.z, indexing="ij")
        return self.cartesian(R, T, Z)

    def __repr__(self):
        res = "R" + ("Θ" if self.n_theta else "") + ("Z" if self.z_range else "")
        return f"CylindricalGrid({res}, shape={self.shape}, axis={tuple(self.e_z)}, axis_point={tuple(self.axis_point)})"
