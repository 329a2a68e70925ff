"""Depth profiles of a flow over a rough base (the paper's Fig. 3), with the boundary correction of eq. (27).

Averaging over the two horizontal axes is analytic (exact kernel marginals) and over time is the
mean over the frames. Stresses here are compression-positive, as in the paper's Fig. 3.
"""
import json

import numpy as np

from .._validate import positive_number
from ..box import Box
from ..coarse import CoarseGrain
from ..grid import Grid
from ..kernels import Gaussian, check_kernel
from ..units import as_units, label_units, unit

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
    blocks : int
        Estimate the sampling error of the lithostatic balance from this many contiguous blocks of
        frames (0: no estimate). Instantaneous contact forces of a collisional flow scatter widely
        from frame to frame; the paper samples every t_c / 2 for that reason.

    Notes
    -----
    Results (after ``run``): z, density, stress_zz (sigma_zz without the boundary correction), ifd_z (t_z),
    extended_stress_zz (sigma'_zz from eq. 27), weight (-int_z^inf rho g_z dz, the weight of the
    flow above z per unit area), bed, surface, lithostatic_error (max ``|sigma'_zz - weight|`` between bed
    and surface, relative to the weight of the whole flow), lithostatic_standard_error (its sampling
    error from block averages, same units), lithostatic_ok, ray_extended_stress_zz (if rays),
    result (the underlying cgbound Result).
    """

    def __init__(self, width=0.25, kernel=None, spacing=None, z_range=None, threshold=0.02, rays=False, blocks=5):
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
        if isinstance(blocks, bool) or not isinstance(blocks, int) or blocks < 0 or blocks == 1:
            raise ValueError(f"blocks: expected 0 (no error estimate) or an integer >= 2, got {blocks!r}")
        self.blocks = blocks

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

    def _average(self, snapshots, grid, start, stop, step, verbose=False, rays=False):
        """Averaged profiles over snapshots[start:stop:step]: the Result, sigma_zz, t_z, b_z."""
        fields = PROFILE_FIELDS + (("extended_stress",) if rays else ())
        r = CoarseGrain(snapshots, grid, self.kernel, fields=fields, convention="compression").run(
            start, stop, step, verbose=verbose).results
        return (r, r.stress[..., -1, -1].reshape(-1), r.interaction_force_density[..., -1].reshape(-1),
                r.body_force_density[..., -1].reshape(-1))

    @staticmethod
    def _balance(z, stress_zz, ifd_z, body_z):
        """sigma'_zz by eq. (27) (compression convention: sigma_zz + int_z^inf t_z dz') and the weight above z."""
        return stress_zz + integral_from_above(ifd_z, z), -integral_from_above(body_z, z)

    def _derive(self):
        self.extended_stress_zz, self.weight = self._balance(self.z, self.stress_zz, self.ifd_z, self.body_z)
        s = self.extended_stress_zz
        self.bed = _level(self.z, s, 1.0 - self.threshold)
        self.surface = _level(self.z, s, self.threshold)
        self._bulk = (self.z >= self.bed) & (self.z <= self.surface)
        self.total_weight = float(self.weight.max())
        self.lithostatic_error = float(np.max(np.abs(s[self._bulk] - self.weight[self._bulk])) / self.total_weight)

    def run(self, snapshots, start=None, stop=None, step=None, verbose=False):
        """Average over ``snapshots[start:stop:step]``; returns self."""
        if not (hasattr(snapshots, "__len__") and hasattr(snapshots, "__getitem__")):
            raise TypeError(f"snapshots: expected a sequence of cg.Snapshot with len() and indexing (a list or a "
                            f"reader), got {type(snapshots).__name__}")
        frames = range(len(snapshots))[slice(start, stop, step)]
        if len(frames) == 0:
            raise ValueError("snapshots: no frames in the range given by start, stop, step")
        grid = self._grid(snapshots[frames[0]])
        r, self.stress_zz, self.ifd_z, self.body_z = self._average(snapshots, grid, start, stop, step, verbose, self.rays)
        self.result, self.grid, self.n_frames = r, grid, len(frames)
        self.units, self.dim = r.units, grid.dim
        self.z = grid.axis_coordinates[-1]
        self.density = r.density.reshape(-1)
        if self.rays:
            self.ray_extended_stress_zz = r.extended_stress[..., -1, -1].reshape(-1)
        self._derive()
        # sampling error of the mismatch from the scatter of block averages (contiguous blocks of frames)
        self.lithostatic_standard_error = np.nan
        if self.blocks and len(frames) >= 2 * self.blocks:
            edges = np.linspace(0, len(frames), self.blocks + 1).astype(int)
            mismatch = []
            for b0, b1 in zip(edges[:-1], edges[1:]):
                sub = list(frames[b0:b1])
                _, stress_zz, ifd_z, body_z = self._average(snapshots, grid, sub[0], sub[-1] + 1, frames.step)
                extended, weight = self._balance(self.z, stress_zz, ifd_z, body_z)
                mismatch.append(extended - weight)
            se = np.std(mismatch, axis=0, ddof=1) / np.sqrt(self.blocks)
            self.lithostatic_standard_error = float(se[self._bulk].max() / self.total_weight)
        return self

    @classmethod
    def from_hdf5(cls, path):
        """Profiles written by :meth:`to_hdf5`; eq. (27), the weight, bed, surface and error are recomputed."""
        import h5py
        with h5py.File(path, "r") as f:
            if f.attrs.get("format") != "cgbound-depth-profiles":
                raise ValueError(f"path: {path!r} is not a cgbound depth-profile file")
            self = cls(width=float(f.attrs["width"]), spacing=float(f.attrs["spacing"]),
                       threshold=float(f.attrs["threshold"]), blocks=0)
            for name in cls.STORED:
                setattr(self, name, f[name][()])
            self.lithostatic_standard_error = float(f.attrs["lithostatic_standard_error"])
            self.n_frames = int(f.attrs["n_frames"])
            self.provenance = f.attrs.get("provenance", "")
            units = f.attrs.get("units_system", "")
            self.units = as_units(json.loads(units)) if units else None
            self.dim = int(f.attrs.get("dim", 3))
        self._derive()
        return self

    @property
    def lithostatic_ok(self):
        """The balance holds: within 1 %, or within 3 standard errors of the frames' sampling noise."""
        return self.lithostatic_error <= 0.01 or self.lithostatic_error <= 3 * self.lithostatic_standard_error

    def summary(self):
        return (f"bed z = {self.bed:.3f}, surface z = {self.surface:.3f} (height {self.surface - self.bed:.3f}); "
                f"lithostatic error {100 * self.lithostatic_error:.2f} % (sampling error "
                f"{100 * self.lithostatic_standard_error:.2f} %) of the weight of the flow ({self.total_weight:.4g} per unit area)")

    #: the units of the frames (a cgbound.Units), None when not known; the frames' dimension
    units, dim = None, 3

    STORED = ("z", "density", "stress_zz", "ifd_z", "body_z")
    #: the field whose unit each profile has (a weight per area is a stress)
    UNIT_OF = {"z": "length", "density": "density", "stress_zz": "stress", "ifd_z": "interaction_force_density",
               "body_z": "body_force_density", "extended_stress_zz": "stress", "weight": "stress"}
    PROFILES = STORED + ("extended_stress_zz", "weight")
    SCALARS = ("bed", "surface", "lithostatic_error", "lithostatic_standard_error", "total_weight", "width",
               "spacing", "threshold", "n_frames")

    def to_hdf5(self, path, provenance=""):
        """Write the profiles (datasets) and bed, surface, lithostatic error (attributes) atomically."""
        import h5py

        from .._atomic import atomic_write

        def write(tmp):
            with h5py.File(tmp, "w") as f:
                f.attrs["format"] = "cgbound-depth-profiles"
                for name in self.SCALARS:
                    f.attrs[name] = getattr(self, name)
                f.attrs["kernel"] = repr(self.kernel)
                f.attrs["provenance"] = provenance
                f.attrs["dim"] = self.dim
                if self.units is not None:
                    f.attrs["units_system"] = json.dumps(self.units.as_dict())
                for name in self.PROFILES:
                    data = f.create_dataset(name, data=getattr(self, name))
                    text = unit(self.UNIT_OF[name], self.units, self.dim)
                    if text is not None:
                        data.attrs["units"] = text
        return atomic_write(path, write)

    def plot(self, ax=None):
        """Fig. 3: -sigma_zz (compression positive) without (dashed) and with (solid) the IFD correction,
        the weight of the flow above z (red dotted), and the bed and surface heights (grey); every line is
        in the legend and the axes carry the units (or "(simulation units)"). Returns the Axes."""
        import matplotlib.pyplot as plt
        if ax is None:
            _, ax = plt.subplots(figsize=(4.5, 4.5), constrained_layout=True)
        ax.plot(self.stress_zz, self.z, "k--", label=r"$-\sigma_{zz}$ (no correction)")
        ax.plot(self.extended_stress_zz, self.z, "k-", label=r"$-\sigma'_{zz}$ (eq. 27)")
        ax.plot(self.weight, self.z, "r:", lw=2, label=r"$-\int_z^\infty \rho g_z\,dz'$ (weight above z)")
        ax.axhline(self.bed, color="0.6", lw=1, ls="-", label=f"bed (z = {self.bed:.2f})")
        ax.axhline(self.surface, color="0.6", lw=1, ls="-.", label=f"surface (z = {self.surface:.2f})")
        ax.set_xlabel(r"downward normal stress $-\sigma_{zz}$ (compression) "
                      + label_units("stress", self.units, self.dim))
        length = label_units("length", self.units, self.dim)
        ax.set_ylabel(f"z {length}")
        ax.legend(loc="upper right", fontsize=7)
        return ax
