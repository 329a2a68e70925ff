"""Choosing the coarse-graining width: fields as a function of w, and the plateau where they stop depending on it.

Coarse-grained fields depend on the width w of the kernel. Below the particle scale they resolve
single particles (density spikes); above the scale of the flow's gradients they smooth the flow
away. Between the two, if the scales separate, the fields hardly change with w: the plateau
(Weinhart, Thornton, Luding & Bokhove, Phys. Fluids 25, 070605 (2013)). :class:`WidthScan`
coarse-grains the same frames at several widths and measures, between consecutive widths, the
sensitivity

    s = (||F(w_k+1) - F(w_k)|| / ||F(w_k)||) / |ln(w_k+1 / w_k)|

(root mean square over the nodes and components with finite values in both): the relative change
of the field per e-fold of w, independent of how densely the widths are spaced. The plateau of a
field is the longest run of consecutive widths with s <= ``tolerance`` at every step (on a tie,
the narrowest: the finest resolution). See docs/theory.md, "Choosing the width".
"""
import numpy as np

from ._validate import positive_number, real_array
from .coarse import CoarseGrain, coarse_grain
from .fields import check_fields
from .kernels import Gaussian
from .pipeline import DEFAULT_FIELDS
from .snapshot import Snapshot


def check_kernel_family(kernel):
    """The kernel of width w: ``kernel(w)``; the classes Gaussian (w the width), Lucy (the cutoff) and Heaviside (the
    radius), or any callable returning a kernel."""
    if callable(kernel):
        return kernel
    raise TypeError(f"kernel: expected cg.Gaussian, cg.Lucy, cg.Heaviside or a callable width -> kernel, got {kernel!r}")


def sensitivity(narrow, wide, ratio):
    """Relative change between two fields per e-fold of width (``ratio`` = wide / narrow width); NaN without finite
    values or where the narrower field is zero."""
    both = np.isfinite(narrow) & np.isfinite(wide)
    if not both.any():
        return float("nan")
    size = np.sqrt(np.mean(narrow[both] ** 2))
    if size == 0.0:
        return float("nan")
    return float(np.sqrt(np.mean((wide[both] - narrow[both]) ** 2)) / size / abs(np.log(ratio)))


def longest_run(flat):
    """(first, last) width index of the longest run of consecutive steps flagged in ``flat`` (steps k: widths k, k+1),
    the narrowest on a tie; None if no step is flagged."""
    best, start = None, None
    for k, ok in enumerate(list(flat) + [False]):
        if ok and start is None:
            start = k
        elif not ok and start is not None:
            if best is None or k - start > best[1] - best[0]:
                best = (start, k)
            start = None
    return best


class WidthScan:
    """Fields at several coarse-graining widths, and where they stop depending on the width (freud-style).

    Parameters
    ----------
    snapshots : Snapshot, or a sequence of them (time-averaged with ``CoarseGrain``)
    grid : Grid, Points or (P, D) array
    widths : sequence of at least 3 increasing positive floats
    fields : sequence of str
    kernel : cg.Gaussian (default), cg.Lucy, cg.Heaviside or a callable width -> kernel
        The scanned length is the class's own: Gaussian width, Lucy cutoff, Heaviside radius.
    tolerance : float
        Largest relative change per e-fold of width (the sensitivity s) inside the plateau.
    convention, species : as for :func:`cgbound.coarse_grain`

    Use ``run()``, which returns self. Results: ``widths``; ``fields[name]`` of shape
    ``(len(widths),) + field shape``; ``sensitivity[name]`` (one value per step between
    consecutive widths); ``plateau[name]``: (narrowest, widest) width of the plateau, or None;
    ``plot(ax=None)``.
    """

    def __init__(self, snapshots, grid, widths, fields=DEFAULT_FIELDS, kernel=Gaussian, tolerance=0.05,
                 convention="tension", species=None):
        self.snapshots = snapshots
        self.grid = grid
        widths = real_array(widths, "widths", ndim=1)
        if widths.shape[0] < 3 or not np.all(widths > 0) or not np.all(np.diff(widths) > 0):
            raise ValueError(f"widths: expected at least 3 increasing positive widths, got {widths.tolist()!r}")
        self.widths = widths
        self.field_names = check_fields(fields)
        self.kernel = check_kernel_family(kernel)
        self.tolerance = positive_number(tolerance, "tolerance")
        self.convention, self.species = convention, species
        self.fields = self.sensitivity = self.plateau = None

    def _at(self, width):
        kernel = self.kernel(float(width))
        if isinstance(self.snapshots, Snapshot):
            return coarse_grain(self.snapshots, self.grid, kernel, self.field_names, self.convention, self.species)
        return CoarseGrain(self.snapshots, self.grid, kernel, self.field_names, self.convention, self.species).run().results

    def run(self):
        """Coarse-grain at every width; returns self."""
        per_width = [self._at(w) for w in self.widths]
        self.fields = {name: np.stack([r[name] for r in per_width]) for name in self.field_names}
        ratios = self.widths[1:] / self.widths[:-1]
        self.sensitivity = {name: np.array([sensitivity(f[k], f[k + 1], ratios[k]) for k in range(len(ratios))])
                            for name, f in self.fields.items()}
        self.plateau = {}
        for name, s in self.sensitivity.items():
            run = longest_run(s <= self.tolerance)
            self.plateau[name] = None if run is None else (float(self.widths[run[0]]), float(self.widths[run[1]]))
        return self

    def plot(self, ax=None):
        """The sensitivity of every field against the width (log-log), the tolerance and the plateaus; returns the axes."""
        if self.sensitivity is None:
            raise RuntimeError("WidthScan.plot: call run() first")
        import matplotlib.pyplot as plt
        if ax is None:
            ax = plt.figure().add_subplot()
        middle = np.sqrt(self.widths[1:] * self.widths[:-1])
        for name, s in self.sensitivity.items():
            line, = ax.loglog(middle, s, marker="o", label=name)
            if self.plateau[name] is not None:
                ax.axvspan(*self.plateau[name], color=line.get_color(), alpha=0.15)
        ax.axhline(self.tolerance, color="k", linestyle="--", linewidth=0.8, label="tolerance")
        ax.set_xlabel("coarse-graining width w")
        ax.set_ylabel("relative change per e-fold of w")
        ax.legend()
        return ax


def width_scan(snapshots, grid, widths, fields=DEFAULT_FIELDS, kernel=Gaussian, tolerance=0.05, convention="tension",
               species=None):
    """``WidthScan(...).run()``: the fields as a function of the width and their plateaus (see :class:`WidthScan`)."""
    return WidthScan(snapshots, grid, widths, fields, kernel, tolerance, convention, species).run()
