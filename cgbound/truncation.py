"""Truncation error of the cut-off Gaussian, and the cheapest cutoff for a requested accuracy.

The mass a Gaussian of width w loses beyond a cutoff c w in D dimensions is the regularised upper
incomplete gamma function Q(D/2, c^2/2). The accuracy-versus-time study (benchmarks/accuracy_study.py)
measured that the relative L2 error of the contact stress, the virial and mass errors and the largest
momentum-balance residual of a dense packing all track this fraction (within a factor of about 1.3, and
below it for ``normalize="truncated"``), so it is the accuracy a cutoff buys. The cost grows like c^D.
"""
import math
import numbers

import numpy as np

from ._validate import positive_number


def _dimension(dim):
    if isinstance(dim, (bool, np.bool_)) or not isinstance(dim, numbers.Integral) or int(dim) not in (1, 2, 3):
        raise ValueError(f"dim: expected 1, 2 or 3 (the number of resolved axes), got {dim!r}")
    return int(dim)


def gaussian_tail_fraction(cutoff_over_width, dim=3):
    """Fraction of a D-dimensional Gaussian's mass beyond ``cutoff_over_width`` widths: Q(D/2, c^2/2).

    Closed forms from Q(1/2, x) = erfc(sqrt x), Q(1, x) = exp(-x) and
    Q(a + 1, x) = Q(a, x) + x^a exp(-x) / Gamma(a + 1). ``dim`` counts the resolved axes: averaged axes
    use the exact marginal of the untruncated Gaussian, so they add no truncation.
    """
    c = positive_number(cutoff_over_width, "cutoff_over_width")
    dim = _dimension(dim)
    x = 0.5 * c * c
    if dim % 2:
        a, q = 0.5, math.erfc(math.sqrt(x))
    else:
        a, q = 1.0, math.exp(-x)
    while a < 0.5 * dim:
        # x^a exp(-x) / Gamma(a + 1) in logs: no overflow for large cutoffs
        q += math.exp(a * math.log(x) - x - math.lgamma(a + 1.0))
        a += 1.0
    return q


def gaussian_cutoff_for(rtol, dim=3):
    """Smallest cutoff, in widths, whose neglected Gaussian tail is at most ``rtol`` of the mass.

    Use it as ``cg.Gaussian(w, cutoff=cg.gaussian_cutoff_for(1e-6) * w)``. With the default full
    normalisation the relative errors of the contact stress, of the integral identities and of the
    momentum balance are about ``rtol`` (see docs/studies/accuracy-vs-time.md); the work per particle
    and per contact grows like the cutoff to the power ``dim``.

    Parameters
    ----------
    rtol : float in (0, 1)
        Requested relative accuracy (tail mass fraction); below 1e-300 is clamped to 1e-300.
    dim : {1, 2, 3}
        Resolved axes of the grid (3 for an XYZ field, 1 for a profile).
    """
    rtol = positive_number(rtol, "rtol")
    if rtol >= 1.0:
        raise ValueError(f"rtol: expected a relative accuracy below 1, got {rtol!r}")
    dim = _dimension(dim)
    rtol = max(rtol, 1e-300)
    lo, hi = 0.0, 1.0
    while gaussian_tail_fraction(hi, dim) > rtol:
        lo, hi = hi, 2.0 * hi
    for _ in range(200):       # bisection to adjacent floats; the answer is the end meeting rtol
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if mid > 0 and gaussian_tail_fraction(mid, dim) <= rtol:
            hi = mid
        else:
            lo = mid
    return hi
