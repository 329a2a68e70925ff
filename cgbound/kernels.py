"""Coarse-graining kernels W (integral 1 over D dimensions).

All kernels are radial with compact support of radius ``radius``. Over averaged
grid axes the exact marginal over those axes is used (for the Gaussian: the
marginal of the untruncated Gaussian, cut off in the resolved subspace).
"""
from ._validate import positive_number

GAUSSIAN, LUCY, HEAVISIDE = 0, 1, 2

#: provisional default Gaussian cutoff in widths; to be set from the accuracy-vs-time study
DEFAULT_GAUSSIAN_CUTOFF = 5.0


class Kernel:
    """Base class; subclasses set ``_type``, ``width`` and ``radius``."""

    _type = None
    width = None
    radius = None
    truncated = False

    def _core_args(self, avg_extent):
        return (self._type, float(self.width if self.width is not None else self.radius),
                float(self.radius), int(self.truncated), float(avg_extent))

    @property
    def differentiable(self):
        """Whether the kernel has a useful gradient (needed by momentum_balance_residual)."""
        return True


class Gaussian(Kernel):
    """Gaussian W = (2 pi w^2)^(-D/2) exp(-r^2 / 2 w^2), zero beyond ``cutoff``.

    Parameters
    ----------
    width : float
        Standard deviation w.
    cutoff : float, optional
        Support radius as a distance (default ``5 * width``). The cutoff is the
        accuracy knob: the neglected tail carries a fraction ~exp(-c^2/2) c^(D-2) of the mass.
    normalize : {"full", "truncated"}
        "full" keeps the prefactor of the untruncated Gaussian (smooth, the momentum
        balance holds up to the tail); "truncated" renormalises over the cut-off ball
        as MercuryCG does (mass exact, a jump at the cutoff).
    """

    _type = GAUSSIAN

    def __init__(self, width, cutoff=None, normalize="full"):
        self.width = positive_number(width, "width")
        if cutoff is None:
            cutoff = DEFAULT_GAUSSIAN_CUTOFF * self.width
        self.radius = positive_number(cutoff, "cutoff")
        if not isinstance(normalize, str):
            raise TypeError(f"normalize: expected 'full' or 'truncated', got {normalize!r}")
        if normalize not in ("full", "truncated"):
            raise ValueError(f"normalize: expected 'full' or 'truncated', got {normalize!r}")
        self.normalize = normalize
        self.truncated = normalize == "truncated"

    @property
    def cutoff(self):
        return self.radius

    def __repr__(self):
        return f"Gaussian(width={self.width:g}, cutoff={self.radius:g}, normalize={self.normalize!r})"


class Lucy(Kernel):
    """Lucy polynomial W = C (1 + 3x)(1 - x)^3, x = r / cutoff < 1 (C^2 at the edge, no truncation error)."""

    _type = LUCY

    def __init__(self, cutoff):
        self.radius = positive_number(cutoff, "cutoff")

    @property
    def cutoff(self):
        return self.radius

    def __repr__(self):
        return f"Lucy(cutoff={self.radius:g})"


class Heaviside(Kernel):
    """Uniform ball of the given radius (for comparison with binning tools); its gradient is zero."""

    _type = HEAVISIDE

    def __init__(self, radius):
        self.radius = positive_number(radius, "radius")

    @property
    def differentiable(self):
        return False

    def __repr__(self):
        return f"Heaviside(radius={self.radius:g})"


def check_kernel(kernel, name="kernel"):
    if not isinstance(kernel, Kernel):
        raise TypeError(f"{name}: expected cg.Gaussian, cg.Lucy or cg.Heaviside, got {type(kernel).__name__}")
    return kernel


# the cutoff for a requested accuracy (kept in its own module; also cgbound.gaussian_cutoff_for)
from .truncation import gaussian_cutoff_for, gaussian_tail_fraction  # noqa: E402,F401
