"""Entry points: coarse_grain (one snapshot) and CoarseGrain (many snapshots)."""
import contextlib
import itertools

import numpy as np

from ._memory import core_threads
from ._validate import flag, integer, positive_number, real_array
from .averaging import FramePlan, fill_partial, read_frame, run_blocks
from .block_errors import block_assignment, block_errors, check_block_memory
from .cylindrical import CylindricalGrid
from .cylindrical_fields import coarse_grain_cylindrical
from .executors import check_backend, executor
from .fields import (DEFAULT_COUPLE_STRESS_FORM, check_convention, check_couple_stress_form,
                     check_differentiable, check_fields)
from .grid import Grid, Points
from .kernels import check_kernel
from .pipeline import DEFAULT_FIELDS, check_branch_line, check_memory, prepare, run_snapshot, shape_fields
from .progress import progress, progress_bar
from .readahead import read_ahead
from .result import Result
from .snapshot import Snapshot


def coarse_grain(snapshot, grid, kernel, fields=DEFAULT_FIELDS, convention="tension", species=None,
                 couple_stress_form=DEFAULT_COUPLE_STRESS_FORM):
    """Coarse-grained fields of one snapshot.

    Parameters
    ----------
    snapshot : Snapshot
    grid : Grid, Points, CylindricalGrid or (P, D) array of evaluation points
    kernel : Gaussian, Lucy or Heaviside
    fields : sequence of str
        Any of density, momentum, velocity, momentum_flux, kinetic_stress,
        contact_stress, boundary_stress, interaction_force_density,
        body_force_density, stress, extended_stress, volume_fraction, pressure,
        temperature, and the others of ``cg.FIELD_NAMES`` (structure, gradients and
        rheology, rotation: spin_density, angular_momentum_density, spin_flux,
        kinetic_spin_flux, couple_stress, stress_torque_density,
        boundary_couple_density, which need angular velocities where they sum spins).
        Only what these need is computed.
    convention : {"tension", "compression"}
        Sign of stresses: the paper's tension-positive Cauchy stress, or MercuryCG's
        compression-positive one. Pressure is compression-positive in both.
    species : int, optional
        Partial fields of one species; other species act as boundary, so the
        interaction force density is the force density they exert.
    couple_stress_form : {"contact_point", "branch_line"}
        How couple_stress, stress_torque_density and boundary_couple_density split the
        contact torques (docs/theory.md, "Rotation and couple stress"): torque densities at
        the contact points (the default), or the antisymmetric part of the paper's stress
        spread along the branch lines (at points and on grids without averaged axes).

    Returns
    -------
    Result
    """
    if isinstance(grid, CylindricalGrid):
        return coarse_grain_cylindrical(snapshot, grid, kernel, fields, convention, species)
    job = prepare(snapshot, grid, kernel, fields, convention, species, couple_stress_form=couple_stress_form)
    if species is not None and not np.any(snapshot.species[~snapshot.fixed] == species):
        raise ValueError(f"species: {species} is not among the snapshot's flowing particles (their species: "
                         f"{sorted(set(np.asarray(snapshot.species[~snapshot.fixed]).tolist()))}; fixed particles do "
                         f"not count); partial fields of it would be zero")
    return run_snapshot(job)


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
    errors : None or "blocks"
        "blocks" (with ``time_average="mean"``): also the standard error of every field's time
        average from the means of ``n_blocks`` consecutive blocks of frames, in
        ``results.errors[field]`` (shaped like the field), with the median lag-1 correlation of
        consecutive block means in ``results.block_correlation[field]``; a
        ``cgbound.CorrelatedBlocksWarning`` when those are correlated (the error bars are then too
        small). See docs/theory.md, "Error bars on time averages".
    n_blocks : int
        Blocks for ``errors="blocks"`` (at least 2; default 10), at most the number of frames.
    couple_stress_form : as for :func:`coarse_grain`

    Notes
    -----
    Use ``run(start, stop, step, verbose)``, which returns self; the fields are in ``results``.
    ``run(..., backend="dask", client=...)`` spreads blocks of frames over a dask.distributed
    cluster with the same result (see docs/guide/scaling.md). In this process, the frames of a
    reader are read one ahead in a background thread while the previous one is coarse grained
    (the same result as reading first; at most one frame is held ahead).
    """

    def __init__(self, snapshots, grid, kernel, fields=DEFAULT_FIELDS, convention="tension", species=None,
                 time_average="mean", times=None, errors=None, n_blocks=10,
                 couple_stress_form=DEFAULT_COUPLE_STRESS_FORM):
        if isinstance(snapshots, Snapshot):
            raise TypeError("snapshots: expected a sequence or iterable of cg.Snapshot, got a single cg.Snapshot "
                            "(use cg.coarse_grain, or wrap it in a list)")
        if not (hasattr(snapshots, "__iter__") or (hasattr(snapshots, "__len__") and hasattr(snapshots, "__getitem__"))):
            raise TypeError(f"snapshots: expected a sequence or iterable of cg.Snapshot, got {type(snapshots).__name__}")
        self.snapshots = snapshots
        self.grid = grid
        self._target = grid if isinstance(grid, (Grid, Points, CylindricalGrid)) else Points(grid, _name="grid")
        self.kernel = check_kernel(kernel)
        self.fields = check_fields(fields)
        self.convention = check_convention(convention)
        check_differentiable(self.kernel, self.fields)
        self.couple_stress_form = check_couple_stress_form(couple_stress_form)
        check_branch_line(self.couple_stress_form, self.fields, self.kernel)
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
        if errors not in (None, "blocks"):
            raise ValueError(f"errors: expected None or 'blocks' (standard errors from block means), got {errors!r}")
        if errors is not None and time_average != "mean":
            raise ValueError(f"errors: expected time_average='mean' for errors='blocks' (the error of a time "
                             f"average), got time_average={self.time_average!r}")
        self.errors = errors
        self.n_blocks = integer(n_blocks, "n_blocks")
        if self.n_blocks < 2:
            raise ValueError(f"n_blocks: expected at least 2 blocks (a standard error needs two), got {self.n_blocks}")
        self.results = None

    def _frames(self, start, stop, step):
        snaps = self.snapshots
        if hasattr(snaps, "__len__") and hasattr(snaps, "__getitem__"):
            for index in range(*slice(start, stop, step).indices(len(snaps))):
                yield index, read_frame(snaps, index, index)
        else:
            if any(x is not None for x in (start, stop, step)) and not all(
                    (x is None or x >= 0) for x in (start, stop, step)):
                raise ValueError("start, stop, step: expected values >= 0 for snapshots without len(), "
                                 f"got start={start}, stop={stop}, step={step}")
            for index, snap in itertools.islice(enumerate(snaps), start, stop, step):
                yield index, snap

    def _progress(self, iterable, total, verbose):
        if not verbose:
            return iterable
        return progress_bar(total, "frame", iterable)

    def _plan(self):
        mode = self.time_average
        if mode == "smooth" and self.times is None:
            mode = "store"  # the output times are the frames' own: known once every frame is read
        return FramePlan(self.grid, self.kernel, self.fields, self.convention, self.species, mode,
                         self.time_width, self.times, couple_stress_form=self.couple_stress_form)

    def run(self, start=None, stop=None, step=None, verbose=False, *, backend="serial", client=None, n_workers=None):
        """Coarse-grain frames ``start:stop:step``; returns self, with the fields in ``results``.

        Parameters
        ----------
        start, stop, step : int, optional
            The frames to use, as in ``frames[start:stop:step]``.
        verbose : bool
            Show a progress bar.
        backend : "serial" (this process) or "dask" (blocks of frames on a dask.distributed cluster;
            the snapshots must be a list or a reader, which workers read themselves)
        client : dask.distributed.Client, optional
            The cluster to use (left open). None with backend="dask": a LocalCluster of ``n_workers``
            processes (default 2), closed afterwards.
        n_workers : int, optional
            Workers of the LocalCluster made when no client is given.
        """
        start = integer(start, "start", allow_none=True)
        stop = integer(stop, "stop", allow_none=True)
        step = integer(step, "step", allow_none=True)
        if step == 0:
            raise ValueError("step: expected a non-zero integer or None, got 0")
        verbose = flag(verbose, "verbose")
        backend, n_workers = check_backend(backend, client, n_workers)
        total = None
        if hasattr(self.snapshots, "__len__"):
            total = len(range(*slice(start, stop, step).indices(len(self.snapshots))))
        n_times = len(self.times) if self.times is not None else (total or 1)
        check_memory(self._target, self.fields, self._target.dim, core_threads(), frames=total or 1,
                      time_average=self.time_average, n_times=n_times)
        plan = self._plan()
        if self.errors is not None:
            if total is None:
                raise TypeError(f"snapshots: expected a sequence with len() for errors='blocks' (the blocks are cut "
                                f"before reading), got {type(self.snapshots).__name__}")
            if total < self.n_blocks:
                raise ValueError(f"n_blocks: expected at most the number of frames selected ({total}), "
                                 f"got {self.n_blocks}")
            check_block_memory(self._target, self.fields, self._target.dim, self.n_blocks)
            plan.block_of = block_assignment(range(*slice(start, stop, step).indices(len(self.snapshots))),
                                             self.n_blocks)
        if backend == "dask":
            if total is None or not hasattr(self.snapshots, "__getitem__"):
                raise TypeError(f"snapshots: expected a list or a reader (len() and indexing) for backend='dask', "
                                f"got {type(self.snapshots).__name__}")
            indices = list(range(*slice(start, stop, step).indices(len(self.snapshots))))
            if not indices:
                self._no_frames(start, stop, step)
            with executor("dask", client, n_workers) as cluster:
                partial = run_blocks(cluster, plan, self.snapshots, indices, progress(verbose, len(indices), "frame"))
        else:
            frames = self._frames(start, stop, step)
            if hasattr(self.snapshots, "take"):
                # a reader (cgbound.readers.FrameSequence): the next frame is read while this one is coarse
                # grained; lists are in memory already, and other iterables run the user's code, which
                # may expect the calling thread
                frames = read_ahead(frames)
            with contextlib.closing(frames):
                partial = fill_partial(plan, self._progress(frames, total, verbose))
            if not partial.times:
                self._no_frames(start, stop, step)
            if plan.mode == "store":
                partial = partial.smoothed(partial.times)
        flat, out_times = partial.finish()
        leading = () if self.time_average == "mean" else (len(out_times),)
        shaped = shape_fields(flat, partial.target, partial.dim, leading)
        self.n_frames = len(partial.times)
        self.results = Result(shaped, partial.target, partial.kernel, self.convention, out_times, partial.box,
                              units=partial.units, n_frames=self.n_frames,
                              time_average=self.time_average if self.time_average != "smooth" else self.time_width)
        if self.errors is not None:
            errors, self.results.block_correlation = block_errors(partial, self.n_blocks)
            self.results.errors = shape_fields(errors, partial.target, partial.dim)
            self.results.n_blocks = self.n_blocks
        self.frame_times = np.asarray(partial.times)
        return self

    def _no_frames(self, start, stop, step):
        if hasattr(self.snapshots, "__len__") and len(self.snapshots) == 0:
            raise ValueError("snapshots: expected at least one snapshot, got an empty sequence")
        raise ValueError(f"start, stop, step: expected a selection of at least one frame, got none "
                         f"(start={start}, stop={stop}, step={step})")
