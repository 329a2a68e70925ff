"""Entry points: coarse_grain (one snapshot) and CoarseGrain (many snapshots)."""
import sys

import numpy as np

from ._memory import check_fits, core_threads, per_node_doubles
from ._validate import flag, integer, positive_number, real_array
from .fields import (PrimaryAverage, check_computable, check_convention, check_fields, compute_primaries, derive,
                     needed_primaries, reference_velocity, FIELDS)
from .grid import Grid, Points, check_target
from .kernels import check_kernel
from .result import Result
from .snapshot import Snapshot

DEFAULT_FIELDS = ("density", "velocity", "stress")


def _prepare(snapshot, grid, kernel, fields, convention, species):
    if not isinstance(snapshot, Snapshot):
        raise TypeError(f"snapshot: expected a cg.Snapshot, got {type(snapshot).__name__}")
    target = check_target(grid, snapshot.dim)
    kernel = check_kernel(kernel)
    fields = check_fields(fields)
    convention = check_convention(convention)
    species = integer(species, "species", allow_none=True)
    if species is not None:
        snapshot = snapshot.species_view(species)
    return snapshot, target, kernel, fields, convention


def _field_ranks():
    return {name: spec[0] for name, spec in FIELDS.items()}


def _check_memory(target, fields, dim, threads, frames=1, time_average="mean", n_times=1):
    needed = needed_primaries(fields)
    doubles = per_node_doubles(needed, fields, _field_ranks(), dim, threads, frames, time_average, n_times)
    check_fits("grid", target.size, doubles, what=f"fields {', '.join(fields)}"
               + (f" over {frames} frames" if frames > 1 else ""))


def _shape_fields(flat, target, dim, leading=()):
    shaped = {}
    for name, value in flat.items():
        rank = FIELDS[name][0]
        shaped[name] = value.reshape(leading + target.field_shape + (dim,) * rank)
    return shaped


def coarse_grain(snapshot, grid, kernel, fields=DEFAULT_FIELDS, convention="tension", species=None):
    """Coarse-grained fields of one snapshot.

    Parameters
    ----------
    snapshot : Snapshot
    grid : Grid, Points or (P, D) array of evaluation points
    kernel : Gaussian, Lucy or Heaviside
    fields : sequence of str
        Any of density, momentum, velocity, momentum_flux, kinetic_stress,
        contact_stress, boundary_stress, interaction_force_density,
        body_force_density, stress, extended_stress, volume_fraction, pressure,
        temperature. Only what these need is computed.
    convention : {"tension", "compression"}
        Sign of stresses: the paper's tension-positive Cauchy stress, or MercuryCG's
        compression-positive one. Pressure is compression-positive in both.
    species : int, optional
        Partial fields of one species; other species act as boundary, so the
        interaction force density is the force density they exert.

    Returns
    -------
    Result
    """
    snapshot, target, kernel, fields, convention = _prepare(snapshot, grid, kernel, fields, convention, species)
    needed = needed_primaries(fields)
    split = check_computable(snapshot, needed)
    _check_memory(target, fields, snapshot.dim, core_threads(max(snapshot.n_particles, len(snapshot.contacts))))
    u_ref = reference_velocity(snapshot)
    primaries = compute_primaries(snapshot, target, kernel, needed, u_ref, split)
    flat = derive(primaries, fields, u_ref, snapshot.dim, convention)
    return Result(_shape_fields(flat, target, snapshot.dim), target, kernel, convention, [snapshot.time], snapshot.box)


class CoarseGrain:
    """Coarse graining over many snapshots (MDAnalysis-style analysis object).

    Parameters
    ----------
    snapshots : sequence of Snapshot (a list, or a reader with len() and indexing), or an iterable
    grid, kernel, fields, convention, species : as for :func:`coarse_grain`
    time_average : "mean", "none" or a positive float
        "mean": one result, the mean over the frames (the kinetic stress about the
        mean velocity, exactly). "none": every frame, stacked on a leading axis.
        A float: Gaussian smoothing in time with that standard deviation, evaluated
        at ``times`` (default: the frames' times), on a leading axis.
    times : array_like, optional
        Output times for Gaussian time smoothing.

    Use ``run(start, stop, step, verbose)``, which returns self; the fields are in ``results``.
    """

    def __init__(self, snapshots, grid, kernel, fields=DEFAULT_FIELDS, convention="tension", species=None,
                 time_average="mean", times=None):
        if isinstance(snapshots, Snapshot):
            raise TypeError("snapshots: expected a sequence or iterable of cg.Snapshot, got a single cg.Snapshot "
                            "(use cg.coarse_grain, or wrap it in a list)")
        if not (hasattr(snapshots, "__iter__") or (hasattr(snapshots, "__len__") and hasattr(snapshots, "__getitem__"))):
            raise TypeError(f"snapshots: expected a sequence or iterable of cg.Snapshot, got {type(snapshots).__name__}")
        self.snapshots = snapshots
        self.grid = grid
        self._target = grid if isinstance(grid, (Grid, Points)) else Points(grid, _name="grid")
        self.kernel = check_kernel(kernel)
        self.fields = check_fields(fields)
        self.convention = check_convention(convention)
        self.species = integer(species, "species", allow_none=True)
        if isinstance(time_average, str):
            if time_average not in ("mean", "none"):
                raise ValueError(f"time_average: expected 'mean', 'none' or a positive width, got {time_average!r}")
            self.time_width = None
        else:
            self.time_width = positive_number(time_average, "time_average")
            time_average = "smooth"
        self.time_average = time_average
        if times is not None and time_average != "smooth":
            raise ValueError(f"times: expected None unless time_average is a width (Gaussian smoothing in time), "
                             f"got times with time_average={time_average!r}")
        self.times = None if times is None else real_array(times, "times", ndim=1)
        self.results = None

    def _frames(self, start, stop, step):
        snaps = self.snapshots
        if hasattr(snaps, "__len__") and hasattr(snaps, "__getitem__"):
            for index in range(*slice(start, stop, step).indices(len(snaps))):
                yield index, snaps[index]
        else:
            if any(x is not None for x in (start, stop, step)) and not all(
                    (x is None or x >= 0) for x in (start, stop, step)):
                raise ValueError("start, stop, step: expected values >= 0 for snapshots without len(), "
                                 f"got start={start}, stop={stop}, step={step}")
            import itertools
            for index, snap in itertools.islice(enumerate(snaps), start, stop, step):
                yield index, snap

    def _progress(self, iterable, total, verbose):
        if not verbose:
            return iterable
        try:
            from tqdm.auto import tqdm
        except ImportError:
            return _SimpleProgress(iterable, total)
        return tqdm(iterable, total=total, desc="coarse graining", unit="frame")

    def run(self, start=None, stop=None, step=None, verbose=False):
        """Coarse-grain frames ``start:stop:step``; returns self, with the fields in ``results``."""
        start = integer(start, "start", allow_none=True)
        stop = integer(stop, "stop", allow_none=True)
        step = integer(step, "step", allow_none=True)
        if step == 0:
            raise ValueError("step: expected a non-zero integer or None, got 0")
        verbose = flag(verbose, "verbose")
        needed = needed_primaries(self.fields)
        total = None
        if hasattr(self.snapshots, "__len__"):
            total = len(range(*slice(start, stop, step).indices(len(self.snapshots))))
        n_times = len(self.times) if self.times is not None else (total or 1)
        _check_memory(self._target, self.fields, self._target.dim, core_threads(), frames=total or 1,
                      time_average=self.time_average, n_times=n_times)
        frames = []
        averages = None
        u_ref = None
        target = kernel = None
        dim = box = None
        times = []
        smooth_buffer = []
        for index, snap in self._progress(self._frames(start, stop, step), total, verbose):
            try:
                snap, target, kernel, _, _ = _prepare(snap, self.grid, self.kernel, self.fields, self.convention,
                                                      self.species)
            except (TypeError, ValueError) as exc:
                raise type(exc)(f"frame {index}: {exc}") from exc
            if u_ref is None:
                u_ref = reference_velocity(snap)
                dim, box = snap.dim, snap.box
            elif snap.dim != dim:
                raise ValueError(f"frame {index}: snapshot: expected a {dim}D snapshot like the first frame, got {snap.dim}D")
            try:
                split = check_computable(snap, needed)
            except ValueError as exc:
                raise ValueError(f"frame {index}: {exc}") from exc
            prim = compute_primaries(snap, target, kernel, needed, u_ref, split)
            times.append(snap.time)
            if self.time_average == "mean":
                if averages is None:
                    averages = PrimaryAverage(needed)
                averages.add(prim)
            elif self.time_average == "none":
                frames.append(derive(prim, self.fields, u_ref, dim, self.convention))
            else:
                smooth_buffer.append(prim)
        if not times:
            if total is not None and len(self.snapshots) == 0:
                raise ValueError("snapshots: expected at least one snapshot, got an empty sequence")
            raise ValueError(f"start, stop, step: expected a selection of at least one frame, got none "
                             f"(start={start}, stop={stop}, step={step})")
        if self.time_average == "mean":
            flat = derive(averages.result(), self.fields, u_ref, dim, self.convention)
            shaped = _shape_fields(flat, target, dim)
            out_times = [float(np.mean(times))]
        elif self.time_average == "none":
            shaped = {name: np.stack([f[name] for f in frames]) for name in self.fields}
            shaped = _shape_fields(shaped, target, dim, leading=(len(frames),))
            out_times = times
        else:
            out_times = np.asarray(times if self.times is None else self.times, dtype=float)
            per_time = []
            for t_out in out_times:
                acc = PrimaryAverage(needed)
                for t_s, prim in zip(times, smooth_buffer):
                    acc.add(prim, float(np.exp(-0.5 * ((t_s - t_out) / self.time_width) ** 2)))
                if acc.weight == 0.0:
                    raise ValueError(f"times: expected output times within reach of the frames (Gaussian weights "
                                     f"underflow beyond ~38 widths), got {t_out} with no frame in reach")
                per_time.append(derive(acc.result(), self.fields, u_ref, dim, self.convention))
            shaped = {name: np.stack([f[name] for f in per_time]) for name in self.fields}
            shaped = _shape_fields(shaped, target, dim, leading=(len(per_time),))
        self.results = Result(shaped, target, kernel, self.convention, out_times, box)
        self.n_frames = len(times)
        self.frame_times = np.asarray(times)
        return self


class _SimpleProgress:
    """Fallback progress report on stderr when tqdm is not installed."""

    def __init__(self, iterable, total):
        self.iterable, self.total = iterable, total

    def __iter__(self):
        count = 0
        for item in self.iterable:
            yield item
            count += 1
            print(f"\rcoarse graining: {count}/{self.total or '?'} frames", end="", file=sys.stderr)
        print(file=sys.stderr)
