"""Coarse-graining kernels W (integral 1 over D dimensions).

All kernels are radial with compact support of radius ``radius``. Over averaged
grid axes the exact marginal over those axes is used (for the Gaussian: the
marginal of the untruncated Gaussian, cut off in the resolved subspace), or with
``averaged_axes="lower-dimensional"`` MercuryCG's convention: the kernel of the
resolved dimension itself (for a Z profile the 1-D Lucy), divided by the averaged extent.

Widths, cutoffs and radii must lie in LENGTH_RANGE (1e-60 to 1e60; a Gaussian's default cutoff of 5
widths may reach 5e60): outside it the kernel's peak or normalisation leaves the floating-point range.
Before any work, coarse graining also refuses a kernel whose peak times the snapshot's largest mass x
velocity^2 or force x branch overflows, and one reaching more than MAX_IMAGES periodic images.
"""
import math
import numbers

import numpy as np

from ._validate import positive_number

GAUSSIAN, LUCY, HEAVISIDE = 0, 1, 2

#: default Gaussian cutoff in widths, from the accuracy-vs-time study (docs/studies/accuracy-vs-time.md): every error measure sits
#: at the neglected tail Q(D/2, c^2/2), 1.5e-5 in 3D at 5w (below DEM statistical noise) for 1/2.8 of
#: the time of 8w; gaussian_cutoff_for(rtol) picks another
DEFAULT_GAUSSIAN_CUTOFF = 5.0

#: default line-integral method of the Gaussian along contact branches: "exact" (to round-off) or an
#: int n (n-point Gauss-Legendre rule). The study's rule for n depends on branch length / w
#: (docs/studies/accuracy-vs-time.md), so the default stays exact; "auto" applies that rule (~1e-5 for 2-3x speed)
DEFAULT_LINE_QUADRATURE = "exact"

#: the largest n of an n-point Gauss-Legendre line rule (CG_MAX_LINE_POINTS in csrc/cg.h)
MAX_LINE_POINTS = 16


#: line_points value meaning "auto": chosen per call from the longest branch (see auto_line_points)
AUTO_LINE_POINTS = -1
#: line_points value meaning "mercurycg": MercuryCG's approximate Gauss line integral along one resolved axis
MERCURYCG_LINE_POINTS = -2
#: "auto" uses at most this many points, and the exact form beyond (the study's rule)
AUTO_MAX_LINE_POINTS = 8


#: widths, cutoffs and radii accepted: the kernel's peak (~ L^-D), its gradient (~ L^-(D+1)) and its
#: normalisation (~ L^D) stay within 1e+-240 for D = 2 and 3, which leaves 1e68 of the double range for
#: masses, velocities and forces (outside it the peak or the line rule overflows or underflows: inf or 0
#: densities, NaN velocities)
LENGTH_RANGE = (1e-60, 1e60)


def kernel_length(value, name):
    """A positive finite length within LENGTH_RANGE (ValueError naming ``name`` otherwise)."""
    value = positive_number(value, name)
    lo, hi = LENGTH_RANGE
    if not lo <= value <= hi:
        raise ValueError(f"{name}: expected a length between {lo:g} and {hi:g} (the kernel's peak ~ {name}^-D and "
                         f"its normalisation must stay within the floating-point range; rescale your units), "
                         f"got {value!r}")
    return value


def check_line_quadrature(value, name="line_quadrature"):
    """"exact", "auto", "mercurycg", or an int n in 1..MAX_LINE_POINTS; returns the core's line_points
    (0 for exact, AUTO_LINE_POINTS for auto, MERCURYCG_LINE_POINTS for mercurycg)."""
    if isinstance(value, str):
        if value == "exact":
            return 0
        if value == "auto":
            return AUTO_LINE_POINTS
        if value == "mercurycg":
            return MERCURYCG_LINE_POINTS
        raise ValueError(f"{name}: expected 'exact', 'auto', 'mercurycg' or a number of Gauss-Legendre points "
                         f"1..{MAX_LINE_POINTS}, got {value!r}")
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name}: expected 'exact', 'auto' or an int number of Gauss-Legendre points "
                        f"1..{MAX_LINE_POINTS}, got {value!r}")
    if not 1 <= int(value) <= MAX_LINE_POINTS:
        raise ValueError(f"{name}: expected 'exact', 'auto' or a number of Gauss-Legendre points "
                         f"1..{MAX_LINE_POINTS}, got {value!r}")
    return int(value)


#: what a kernel is over the axes a Grid averages: "marginal" (the exact marginal of the D-dimensional kernel)
#: or "lower-dimensional" (MercuryCG's: the kernel of the resolved dimension, e.g. the 1-D Lucy for a Z profile)
AVERAGED_AXES = ("marginal", "lower-dimensional")


def check_averaged_axes(value, name="averaged_axes"):
    """"marginal" or "lower-dimensional"; returns whether it is the lower-dimensional kernel."""
    if not isinstance(value, str) or value not in AVERAGED_AXES:
        raise (ValueError if isinstance(value, str) else TypeError)(
            f"{name}: expected 'marginal' (the exact marginal of the D-dimensional kernel over the averaged axes) "
            f"or 'lower-dimensional' (MercuryCG's: the kernel of the resolved dimension), got {value!r}")
    return value == "lower-dimensional"


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
    #: over a Grid's averaged axes: "marginal" (default) or "lower-dimensional" (MercuryCG's convention)
    averaged_axes = "marginal"

    @property
    def scale(self):
        """The length over which the kernel varies: the Gaussian's width, a third of a compact kernel's radius
        (what quadrature panels along a ring, a branch or an axis are measured in)."""
        return float(self.width) if self.width is not None else float(self.radius) / 3.0

    @property
    def lower_dimensional(self):
        """Whether the kernel over averaged axes is the lower-dimensional one (MercuryCG's convention)."""
        return self.averaged_axes == "lower-dimensional"

    def _set_averaged_axes(self, value):
        check_averaged_axes(value)
        self.averaged_axes = value

    def _averaged_repr(self):
        return "" if self.averaged_axes == "marginal" else f", averaged_axes={self.averaged_axes!r}"

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
    def mercurycg_line(self):
        """Whether segments use MercuryCG's approximate Gauss line integral (line_quadrature="mercurycg")."""
        return self._line_points == MERCURYCG_LINE_POINTS

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

    #: whether the kernel has a useful gradient (needed by momentum_balance_residual)
    differentiable = True

    @property
    def cutoff(self):
        """The support radius: no particle farther than this from a node contributes to it."""
        return self.radius

    def peak_bound(self, dim):
        """An upper bound of the kernel's largest value in ``dim`` dimensions (3 L^-D with L the smaller of
        width and radius; every kernel here peaks below that)."""
        length = min(self.radius, self.width if self.width is not None else self.radius)
        return 3.0 * length ** -float(dim)

    @property
    def length_name(self):
        """The constructor argument that sets the kernel's scale (for messages)."""
        return self._length_name

    def __repr__(self):
        return f"{type(self).__name__}({self._length_name}={self.radius:g}{self._averaged_repr()})"


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
        points (errors at the 5w cutoff's ~1e-5 level, 2-3x faster contact stress), or
        "mercurycg": MercuryCG's approximation of the line integral on X, Y and Z profiles
        (an erf difference with a prefactor set by the branch's extent, 1e-3 to 1e-2 from the
        exact integral near the cutoff; only on grids resolving one axis), to reproduce
        MercuryCG's ContactStress exactly. Rays (extended_stress) are always exact.
    averaged_axes : {"marginal", "lower-dimensional"}
        The kernel over the axes a Grid averages. For the Gaussian both are the same kernel
        (the marginal of a Gaussian is the lower-dimensional Gaussian, cut off at ``cutoff`` in
        the resolved axes); accepted so that every kernel takes it (see :class:`Lucy`).
    """

    _type = GAUSSIAN
    _length_name = "width"

    def __init__(self, width, cutoff=None, normalize="full", line_quadrature=DEFAULT_LINE_QUADRATURE,
                 averaged_axes="marginal"):
        self.width = kernel_length(width, "width")
        # the default cutoff (5 widths) is not range-checked: it follows a checked width
        self.radius = (DEFAULT_GAUSSIAN_CUTOFF * self.width if cutoff is None else kernel_length(cutoff, "cutoff"))
        if not isinstance(normalize, str):
            raise TypeError(f"normalize: expected 'full' or 'truncated', got {normalize!r}")
        if normalize not in ("full", "truncated"):
            raise ValueError(f"normalize: expected 'full' or 'truncated', got {normalize!r}")
        self.normalize = normalize
        self.truncated = normalize == "truncated"
        self._line_points = check_line_quadrature(line_quadrature)
        self.line_quadrature = {0: "exact", AUTO_LINE_POINTS: "auto",
                                MERCURYCG_LINE_POINTS: "mercurycg"}.get(self._line_points, self._line_points)
        self._set_averaged_axes(averaged_axes)

    def __repr__(self):
        return (f"Gaussian(width={self.width:g}, cutoff={self.radius:g}, normalize={self.normalize!r}, "
                f"line_quadrature={self.line_quadrature!r}{self._averaged_repr()})")


class Lucy(Kernel):
    """Lucy polynomial W = C_D (1 + 3x)(1 - x)^3, x = r / cutoff < 1 (C^2 at the edge, no truncation error).

    C_D = 105 / (16 pi R^3) in 3-D, 5 / (pi R^2) in 2-D, 5 / (4 R) in 1-D (R = cutoff).

    Parameters
    ----------
    cutoff : float
        Support radius R (MercuryCG's Lucy ``width``).
    averaged_axes : {"marginal", "lower-dimensional"}
        The kernel over the axes a Grid averages. "marginal" (default): the exact marginal of
        the D-dimensional Lucy over them, so that a profile is the average of the D-dimensional
        field over the averaged extent. "lower-dimensional": MercuryCG's convention, the
        D_res-dimensional Lucy itself (for a Z profile ``C_1 (1 + 3x)(1 - x)^3`` with ``x = |z - z_i| / R``),
        divided by the averaged extent; it reproduces MercuryCG's X/Y/Z/XY/XZ/YZ ``.stat`` files.
        Both integrate to the same mass; the profiles differ by a few per cent where they vary
        on the scale of R.
    """

    _type = LUCY
    _length_name = "cutoff"

    def __init__(self, cutoff, averaged_axes="marginal"):
        self.radius = kernel_length(cutoff, "cutoff")
        self._set_averaged_axes(averaged_axes)


class Heaviside(Kernel):
    """Uniform ball of the given radius (for comparison with binning tools); its gradient is zero.

    ``averaged_axes``: "marginal" (default; over averaged axes the marginal of the D-dimensional ball,
    e.g. pi (R^2 - z^2) / (4/3 pi R^3) for a Z profile in 3-D) or "lower-dimensional" (MercuryCG's:
    the uniform D_res-dimensional ball, 1 / (2R) for a Z profile), divided by the averaged extent.
    """

    _type = HEAVISIDE
    _length_name = "radius"

    def __init__(self, radius, averaged_axes="marginal"):
        self.radius = kernel_length(radius, "radius")
        self._set_averaged_axes(averaged_axes)

    differentiable = False   # its gradient is zero away from the sphere and undefined on it



#: periodic images of one particle the core may sum: it visits them one by one (~ (2 cutoff / L + 2) per
#: periodic resolved axis, multiplied over the axes), and a kernel that wide is uniform along those axes
#: to many digits, which averaging the axes gives exactly and cheaply. 1e5 allows a cutoff of 50 box
#: lengths on two periodic axes (~1e4 images) and refuses a Gaussian 40 box lengths wide on three
#: (~6e7 images, tens of seconds per particle)
MAX_IMAGES = 1e5


def periodic_images(radius, periodic_lengths):
    """Periodic images of one particle whose support can reach a target inside the box."""
    counts = [2.0 * radius / length for length in periodic_lengths.values()]
    # 2 R / L may overflow to inf (then refused), where math.floor would raise
    return math.prod(math.floor(q) + 2.0 if q < 1e300 else math.inf for q in counts)


def check_reach(kernel, dim, periodic_lengths, largest_product, where="snapshot", n_resolved=None, avg_extent=1.0):
    """Refuse, before any work, a kernel whose support reaches more than MAX_IMAGES periodic images
    (``periodic_lengths``: {axis name: length} of the periodic resolved axes), or whose peak times
    ``largest_product`` (the snapshot's largest mass x velocity^2 or force x branch) overflows."""
    name = kernel.length_name
    if kernel.mercurycg_line and n_resolved != 1:
        raise ValueError(f"line_quadrature: 'mercurycg' is MercuryCG's line integral along one resolved axis "
                         f"(X, Y or Z profiles); expected a grid resolving one axis, got "
                         f"{'points (all axes resolved)' if n_resolved is None else f'a target resolving {n_resolved}'}")
    images = periodic_images(kernel.radius, periodic_lengths)
    if images > MAX_IMAGES:
        lengths = ", ".join(f"{axis} {length:g}" for axis, length in periodic_lengths.items())
        raise ValueError(f"{name}: expected a kernel whose support (radius {kernel.radius:g}) reaches at most "
                         f"{MAX_IMAGES:g} periodic images of a particle, got one reaching {images:.3g} images on the periodic box "
                         f"(lengths {lengths}); a kernel this wide is uniform along those axes: average over them "
                         f"(Grid(..., average=...)) or use a narrower kernel")
    peak = kernel.peak_bound(dim)
    if not 1e-300 <= avg_extent <= 1e300:
        raise ValueError(f"grid: expected averaged axes whose extent (the product of the box lengths along them) "
                         f"is within the floating-point range, got {avg_extent:.3g}; rescale the units")
    if n_resolved is not None and n_resolved < dim:
        # over averaged axes: the marginal over the resolved ones, divided by the averaged extent
        with np.errstate(over="ignore", divide="ignore"):
            peak = max(peak, kernel.peak_bound(n_resolved) / avg_extent, 1.0 / avg_extent)
    with np.errstate(over="ignore"):
        top = peak * max(largest_product, 1.0)
    if not top <= 1e300:
        if not peak <= 1e300:
            raise ValueError(f"grid: the kernel's peak over the averaged axes ({kernel!r} divided by the averaged "
                             f"extent {avg_extent:.3g}) overflows the floating-point range; rescale the units")
        raise ValueError(f"{name}: the kernel's peak (up to {peak:.3g} for {kernel!r} in {dim}D) "
                         f"times the {where}'s largest mass x velocity^2 or force x branch ({largest_product:.3g}) "
                         f"overflows the floating-point range; rescale the units (lengths, masses or velocities)")


def check_kernel(kernel, name="kernel"):
    if not isinstance(kernel, Kernel):
        raise TypeError(f"{name}: expected cg.Gaussian, cg.Lucy or cg.Heaviside, got {type(kernel).__name__}")
    return kernel


# the cutoff for a requested accuracy (kept in its own module; also cgbound.gaussian_cutoff_for)
from .truncation import gaussian_cutoff_for, gaussian_tail_fraction  # noqa: E402,F401
