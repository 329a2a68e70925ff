"""Coarse-graining kernels W (integral 1 over D dimensions).

All kernels are radial with compact support of radius ``radius``. Over averaged
grid axes the exact marginal over those axes is used (for the Gaussian: the
marginal of the untruncated Gaussian, cut off in the resolved subspace).
"""
import numbers

import numpy as np

from ._validate import positive_number

GAUSSIAN, LUCY, HEAVISIDE = 0, 1, 2

#: default Gaussian cutoff in widths, from the accuracy-vs-time study (README): every error measure sits
#: at the neglected tail Q(D/2, c^2/2), 1.5e-5 in 3D at 5w (below DEM statistical noise) for 1/2.8 of
#: the time of 8w; gaussian_cutoff_for(rtol) picks another
DEFAULT_GAUSSIAN_CUTOFF = 5.0

#: default line-integral method of the Gaussian along contact branches: "exact" (to round-off) or an
#: int n (n-point Gauss-Legendre rule). The study's rule for n depends on branch length / w (README,
#: "Accuracy versus time"), so the default stays exact; "auto" applies that rule (~1e-5 for 2-3x speed)
DEFAULT_LINE_QUADRATURE = "exact"

#: the largest n of an n-point Gauss-Legendre line rule (CG_MAX_LINE_POINTS in csrc/cg.h)
MAX_LINE_POINTS = 16


#: line_points value meaning "auto": chosen per call from the longest branch (see auto_line_points)
AUTO_LINE_POINTS = -1
#: "auto" uses at most this many points, and the exact form beyond (the study's rule)
AUTO_MAX_LINE_POINTS = 8


def check_line_quadrature(value, name="line_quadrature"):
    """"exact", "auto", or an int n in 1..MAX_LINE_POINTS; returns the core's line_points
    (0 for exact, AUTO_LINE_POINTS for auto)."""
    if isinstance(value, str):
        if value == "exact":
            return 0
        if value == "auto":
            return AUTO_LINE_POINTS
        raise ValueError(f"{name}: expected 'exact', 'auto' or a number of Gauss-Legendre points "
                         f"1..{MAX_LINE_POINTS}, got {value!r}")
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name}: expected 'exact', 'auto' or an int number of Gauss-Legendre points "
                        f"1..{MAX_LINE_POINTS}, got {value!r}")
    if not 1 <= int(value) <= MAX_LINE_POINTS:
        raise ValueError(f"{name}: expected 'exact', 'auto' or a number of Gauss-Legendre points "
                         f"1..{MAX_LINE_POINTS}, got {value!r}")
    return int(value)


def auto_line_points(longest_branch, width):
    """The accuracy-vs-time study's rule: n = ceil(2 L / w + 2) Gauss-Legendre points for branches up to
    L long keep the stress and the momentum-balance residual at the 5w cutoff's level (~1e-5); more than
    AUTO_MAX_LINE_POINTS points: the exact form (0)."""
    if not longest_branch > 0.0:
        return 1
    n = int(np.ceil(2.0 * longest_branch / width + 2.0))
    return n if n <= AUTO_MAX_LINE_POINTS else 0


class Kernel:
    """Base class; subclasses set ``_type``, ``width`` and ``radius``."""

    _type = None
    width = None
    radius = None
    truncated = False
    _line_points = 0      # Gauss-Legendre points along segments, 0 = exact (Gaussian only)
    _per_node = False     # benchmarks only: evaluate node by node, without the separable fast path

    @property
    def kind(self):
        """The core's kernel type (GAUSSIAN, LUCY or HEAVISIDE)."""
        return self._type

    @property
    def per_node(self):
        """Benchmarks only: whether the core evaluates node by node (no separable fast path)."""
        return self._per_node

    def line_points_for(self, longest_branch):
        """The core's line_points; line_quadrature="auto" is resolved from the longest branch (exact without it)."""
        if self._line_points != AUTO_LINE_POINTS:
            return self._line_points
        return 0 if longest_branch is None else auto_line_points(longest_branch, self.width)

    @property
    def resolves_from_branch(self):
        """Whether the core's arguments depend on the longest contact branch (line_quadrature="auto")."""
        return self._line_points == AUTO_LINE_POINTS

    def with_resolved_line_quadrature(self, longest_branch):
        """This kernel with "auto" replaced by the rule it resolves to for ``longest_branch`` (else self)."""
        if self._line_points != AUTO_LINE_POINTS:
            return self
        import copy
        fixed = copy.copy(self)
        fixed._line_points = self.line_points_for(longest_branch)
        fixed.line_quadrature = fixed._line_points or "exact"
        return fixed

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
    line_quadrature : "exact", "auto" or int
        How the kernel is integrated along contact branches (contact and boundary
        stress): "exact" to round-off (the closed erf form, or a Gauss-Legendre rule
        where that is exact to round-off), n = 1..16 for the n-point Gauss-Legendre
        rule along each branch (faster, with an error that falls quickly with n when
        branches are shorter than a few widths), or "auto": per computation, the
        study's rule n = ceil(2 L / w + 2) for the longest branch L, exact beyond 8
        points (errors at the 5w cutoff's ~1e-5 level, 2-3x faster contact stress).
        Rays (extended_stress) are always exact.
    """

    _type = GAUSSIAN

    def __init__(self, width, cutoff=None, normalize="full", line_quadrature=DEFAULT_LINE_QUADRATURE):
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
        self._line_points = check_line_quadrature(line_quadrature)
        self.line_quadrature = {0: "exact", AUTO_LINE_POINTS: "auto"}.get(self._line_points, self._line_points)

    @property
    def cutoff(self):
        return self.radius

    def __repr__(self):
        return (f"Gaussian(width={self.width:g}, cutoff={self.radius:g}, normalize={self.normalize!r}, "
                f"line_quadrature={self.line_quadrature!r})")


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
