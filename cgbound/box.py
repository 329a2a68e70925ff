"""The simulation box: bounds and periodicity per axis."""
import numpy as np

from . import _engine
from ._validate import flag, real_array

AXIS_NAMES = ("x", "y", "z")


class Box:
    """Axis-aligned box ``[lower, upper]`` with a periodic flag per axis.

    Parameters
    ----------
    lower, upper : array_like, shape (D,)
        Bounds, D = 2 or 3, with ``lower < upper``. In 2D the axes are called x and z.
    periodic : bool or sequence of D bools
        Periodic axes; branch vectors use the minimum image along them and kernels
        are summed over all periodic images.
    """

    def __init__(self, lower, upper, periodic=False):
        lower = real_array(lower, "lower", ndim=1)
        upper = real_array(upper, "upper", ndim=1)
        if lower.shape[0] not in (2, 3):
            raise ValueError(f"lower: expected 2 or 3 coordinates, got {lower.shape[0]}")
        if upper.shape != lower.shape:
            raise ValueError(f"upper: expected {lower.shape[0]} coordinates like lower, got {upper.shape[0]}")
        if np.any(upper <= lower):
            raise ValueError(f"upper: expected upper > lower on every axis, got lower={lower.tolist()}, upper={upper.tolist()}")
        dim = lower.shape[0]
        with np.errstate(over="ignore"):
            if not np.all(np.isfinite(upper - lower)):
                raise ValueError(f"upper: expected box lengths (upper - lower) within the floating-point range, "
                                 f"got lower={lower.tolist()}, upper={upper.tolist()}")
        if isinstance(periodic, (str, bytes)) or periodic is None:
            raise TypeError(f"periodic: expected a bool or {dim} bools, got {periodic!r}")
        try:
            ndim = np.ndim(periodic)
        except (ValueError, TypeError):      # ragged
            raise ValueError(f"periodic: expected a bool or {dim} bools, got {periodic!r}") from None
        if ndim == 0:
            periodic = (flag(periodic, "periodic"),) * dim
        else:
            given = periodic
            periodic = list(np.asarray(periodic, dtype=object).ravel()) if ndim == 1 else []
            if len(periodic) != dim:
                raise ValueError(f"periodic: expected a bool or {dim} bools, got {given!r}")
            periodic = tuple(flag(p, "periodic") for p in periodic)
        self.lower = lower
        self.upper = upper
        self.periodic = tuple(bool(p) for p in periodic)

    @property
    def dim(self):
        return self.lower.shape[0]

    @property
    def lengths(self):
        return self.upper - self.lower

    @property
    def axis_names(self):
        return ("x", "z") if self.dim == 2 else AXIS_NAMES

    def minimum_image(self, vectors):
        """Copy of ``vectors`` ((N, D)) with each component along a periodic axis replaced by its
        minimum image: ``v - L round(v / L)`` (ties to even) when ``|v| > L/2``, else ``v`` unchanged
        (the core's rule, the one the coarse graining uses for contact branches)."""
        vectors = real_array(vectors, "vectors", ndim=2, shape=(None, self.dim))
        return _engine.minimum_image(vectors, self.periodic, [float(x) for x in self.lengths])

    def wrap(self, positions):
        """Copy of ``positions`` ((N, D)) moved into ``[lower, upper)`` along the periodic axes.

        A coordinate already inside is kept exactly; any other becomes ``lower + mod(x - lower, L)``
        (NumPy's ``mod``), and a result that rounds up to ``upper`` becomes ``lower``.
        """
        positions = real_array(positions, "positions", ndim=2, shape=(None, self.dim))
        return _engine.wrap(positions, self.periodic, self.lower, self.upper)

    def __eq__(self, other):
        return (isinstance(other, Box) and self.dim == other.dim and np.array_equal(self.lower, other.lower)
                and np.array_equal(self.upper, other.upper) and self.periodic == other.periodic)

    def __hash__(self):
        return hash((tuple(self.lower), tuple(self.upper), self.periodic))

    def __repr__(self):
        return f"Box(lower={self.lower.tolist()}, upper={self.upper.tolist()}, periodic={self.periodic})"
