"""Depth profiles of a flow over a rough base (the paper's Fig. 3), with the boundary correction of eq. (27).

Averaging over the two horizontal axes is analytic (exact kernel marginals) and over time is the
mean over the frames. Stresses here are compression-positive, as in the paper's Fig. 3.
"""
import numpy as np

from ._validate import positive_number
from .box import Box
from .coarse import CoarseGrain
from .grid import Grid
from .kernels import Gaussian, check_kernel

PROFILE_FIELDS = ("density", "stress", "interaction_force_density", "body_force_density")


def integral_from_above(values, z):
    """The integral of ``values`` from each node ``z`` to infinity (trapezoids; values ~0 above the top node)."""
    values = np.asarray(values, float)
    steps = 0.5 * (values[1:] + values[:-1]) * np.diff(z)
    out = np.zeros_like(values)
    out[:-1] = np.cumsum(steps[::-1])[::-1]
    return out


def _level(z, values, fraction):
    """Highest height where ``values`` (a profile falling with height) is still at or above
    ``fraction`` of its maximum, refined linearly to the crossing with the next node."""
    target = fraction * values.max()
    k = np.flatnonzero(values >= target)[-1]
    if k + 1 >= len(z):
        return float(z[k])
    v0, v1 = values[k], values[k + 1]
    return float(z[k] + (z[k + 1] - z[k]) * (v0 - target) / (v0 - v1))


class DepthProfiles:
    """Depth profiles of density and normal stress, averaged over x, y and time (Fig. 3).

    Parameters
    ----------
    width : float
        Coarse-graining width w (the paper uses d / 4).
    kernel : Kernel, optional
        Default ``Gaussian(width)``.
    spacing : float, optional
        Distance between profile nodes (default w / 8).
    z_range : (float, float), optional
        Profile extent; default from the first frame: the lowest flowing particle minus 2,
        the highest plus 2 and the kernel cutoff (the integrals to infinity need the top).
    threshold : float
        Bed and surface are where the extended stress reaches (1 - threshold) of its maximum
        and falls to threshold of it (the paper: 2 %).
    rays : bool
        Also compute the extended stress directly from eq. (24) (ray integrals) as a check of eq. (27).

    Results (after ``run``)
    -----------------------
    z, density, stress_zz (sigma_zz without the boundary correction), ifd_z (t_z),
    extended_stress_zz (sigma'_zz from eq. 27), weight (-int_z^inf rho g_z dz, the weight of the
    flow above z per unit area), bed, surface, lithostatic_error (max |sigma'_zz - weight| between bed
    and surface, relative to the weight of the whole flow), ray_extended_stress_zz (if rays),
    result (the underlying cgbound Result).
    """

    def __init__(self, width=0.25, kernel=None, spacing=None, z_range=None, threshold=0.02, rays=False):
        self.width = positive_number(width, "width")
        self.kernel = Gaussian(self.width) if kernel is None else check_kernel(kernel)
        self.spacing = self.width / 8 if spacing is None else positive_number(spacing, "spacing")
        if z_range is not None:
            lo, hi = (float(v) for v in z_range)
            if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
                raise ValueError(f"z_range: expected (lower, upper) with lower < upper, got {z_range!r}")
            z_range = (lo, hi)
        self.z_range = z_range
        self.threshold = positive_number(threshold, "threshold")
        if self.threshold >= 0.5:
            raise ValueError(f"threshold: expected a fraction below 0.5, got {threshold!r}")
        self.rays = bool(rays)

    def _grid(self, first):
        dim = first.dim
        if self.z_range is None:
            z = first.positions[first.flowing, -1]
            lo, hi = z.min() - 2.0, z.max() + 2.0 + self.kernel.radius
        else:
            lo, hi = self.z_range
        n = max(2, int(np.ceil((hi - lo) / self.spacing)))
        lower = np.array(first.box.lower, float)
        upper = np.array(first.box.upper, float)
        lower[-1], upper[-1] = lo, lo + n * self.spacing
        box = Box(lower, upper, periodic=first.box.periodic)
        shape = (1,) * (dim - 1) + (n,)
        return Grid(box, shape, average=tuple(range(dim - 1)))

    def run(self, snapshots, start=None, stop=None, step=None, verbose=False):
        """Average over ``snapshots[start:stop:step]``; returns self."""
        first = snapshots[0 if start is None else start]
        grid = self._grid(first)
        fields = PROFILE_FIELDS + (("extended_stress",) if self.rays else ())
        cg = CoarseGrain(snapshots, grid, self.kernel, fields=fields, convention="compression")
        r = cg.run(start, stop, step, verbose=verbose).results
        self.result = r
        self.grid = grid
        self.z = grid.axis_coordinates[-1]
        zz = (-1, -1)
        self.density = r.density.reshape(-1)
        self.stress_zz = r.stress[..., zz[0], zz[1]].reshape(-1)
        self.ifd_z = r.interaction_force_density[..., -1].reshape(-1)
        body_z = r.body_force_density[..., -1].reshape(-1)
        # eq. (27) in the compression convention: sigma'_zz = sigma_zz + int_z^inf t_z dz'
        self.extended_stress_zz = self.stress_zz + integral_from_above(self.ifd_z, self.z)
        self.weight = -integral_from_above(body_z, self.z)
        if self.rays:
            self.ray_extended_stress_zz = r.extended_stress[..., -1, -1].reshape(-1)
        s = self.extended_stress_zz
        self.bed = _level(self.z, s, 1.0 - self.threshold)
        self.surface = _level(self.z, s, self.threshold)
        bulk = (self.z >= self.bed) & (self.z <= self.surface)
        self.total_weight = float(self.weight.max())
        self.lithostatic_error = float(np.max(np.abs(s[bulk] - self.weight[bulk])) / self.total_weight)
        return self

    def summary(self):
        return (f"bed z = {self.bed:.3f}, surface z = {self.surface:.3f} (height {self.surface - self.bed:.3f}); "
                f"lithostatic error {100 * self.lithostatic_error:.3f} % of the weight of the flow "
                f"({self.total_weight:.4g} per unit area)")

    PROFILES = ("z", "density", "stress_zz", "ifd_z", "extended_stress_zz", "weight")
    SCALARS = ("bed", "surface", "lithostatic_error", "total_weight", "width")

    def to_hdf5(self, path):
        """Write the profiles (datasets) and bed, surface, lithostatic error (attributes) atomically."""
        import h5py

        from ._atomic import atomic_write

        def write(tmp):
            with h5py.File(tmp, "w") as f:
                f.attrs["format"] = "cgbound-depth-profiles"
                for name in self.SCALARS:
                    f.attrs[name] = getattr(self, name)
                f.attrs["kernel"] = repr(self.kernel)
                for name in self.PROFILES:
                    f.create_dataset(name, data=getattr(self, name))
        return atomic_write(path, write)

    def plot(self, ax=None):
        """Fig. 3: sigma_zz without (dashed) and with (solid) the IFD correction, and the weight (red dotted)."""
        import matplotlib.pyplot as plt
        if ax is None:
            _, ax = plt.subplots(figsize=(4.5, 4.5))
        ax.plot(self.stress_zz, self.z, "k--", label=r"$\sigma_{zz}$")
        ax.plot(self.extended_stress_zz, self.z, "k-", label=r"$\sigma'_{zz}$ (eq. 27)")
        ax.plot(self.weight, self.z, "r:", lw=2, label=r"$-\int_z^\infty \rho g_z\,dz'$")
        for level in (self.bed, self.surface):
            ax.axhline(level, color="0.6", lw=1)
        ax.set_xlabel("downward normal stress")
        ax.set_ylabel("z")
        ax.legend(loc="upper right", fontsize=8)
        return ax
