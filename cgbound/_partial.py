"""Partial sums of CoarseGrain over a block of frames, and their exact combination.

Serial and Dask runs share this code. The frames of a block are coarse-grained into a
:class:`Partial` (running sums, never divided); the partials of consecutive blocks are
merged in frame order; :meth:`Partial.finish` divides once and derives the fields. Splitting
the frames into blocks therefore changes only the order of the additions, so a Dask run
agrees with a serial one to rounding.
"""
import numpy as np

from ._validate import integer
from .fields import (PrimaryAverage, check_computable, check_convention, check_fields, compute_primaries, derive,
                     needed_primaries, reference_velocity)
from .grid import check_target, periodic_resolved_lengths
from .kernels import check_kernel, check_reach
from .snapshot import Snapshot


def prepare(snapshot, grid, kernel, fields, convention, species):
    """Checked arguments of one coarse graining, and the snapshot seen by ``species``."""
    if not isinstance(snapshot, Snapshot):
        raise TypeError(f"snapshot: expected a cg.Snapshot, got {type(snapshot).__name__}")
    target = check_target(grid, snapshot.dim)
    kernel = check_kernel(kernel)
    fields = check_fields(fields)
    convention = check_convention(convention)
    species = integer(species, "species", allow_none=True)
    if species is not None:
        snapshot = snapshot.species_view(species)
    check_reach(kernel, snapshot.dim, periodic_resolved_lengths(snapshot.box, target), snapshot.largest_product,
                n_resolved=len(target.resolved), avg_extent=target.avg_extent)
    return snapshot, target, kernel, fields, convention


def name_frame(exc, index):
    """``exc`` with ``frame <index>: `` before its message, of the same type (so it survives a trip
    from a worker process and is still caught by the caller's ``except``); exceptions whose type
    cannot be rebuilt from a message get a note naming the frame instead."""
    message = f"frame {index}: {exc}"
    try:
        named = type(exc)(message)
    except Exception:
        named = None
    if named is None or named.args != (message,):
        if hasattr(exc, "add_note"):
            exc.add_note(f"while reading or coarse graining frame {index}")
        return exc
    named.__cause__ = exc
    return named


def read_frame(frames, position, index):
    """``frames[position]``, which is frame ``index`` of the run, with read errors naming the frame."""
    try:
        return frames[position]
    except Exception as exc:
        raise name_frame(exc, index) from exc


class FramePlan:
    """Everything a block of frames needs besides the frames (picklable, sent to every worker).

    mode: "mean", "none", "smooth" (Gaussian weights at ``out_times``) or "store" (smoothing
    whose output times are the frames' own, unknown until every frame is read: primaries are kept).
    ``u_ref`` and ``dim`` come from the run's first frame (None: take them from the first frame added).
    """

    def __init__(self, grid, kernel, fields, convention, species, mode, width=None, out_times=None,
                 u_ref=None, dim=None):
        self.grid, self.kernel, self.fields = grid, kernel, fields
        self.convention, self.species = convention, species
        self.needed = needed_primaries(fields)
        self.mode, self.width = mode, width
        self.out_times = None if out_times is None else np.asarray(out_times, dtype=float)
        self.u_ref, self.dim = u_ref, dim

    def smoothing_at(self, out_times):
        plan = FramePlan(self.grid, self.kernel, self.fields, self.convention, self.species, "smooth",
                         self.width, out_times, self.u_ref, self.dim)
        return plan

    def first_frame(self, snapshot, index=0):
        """The reference velocity and dimension every frame of the run is computed with."""
        try:
            snap, _, _, _, _ = prepare(snapshot, self.grid, self.kernel, self.fields, self.convention, self.species)
        except Exception as exc:
            raise name_frame(exc, index) from exc
        return reference_velocity(snap), snap.dim


def first_frame_info(plan, frames, index):
    """Task: read the run's first frame (position 0 of ``frames``) and return (u_ref, dim)."""
    return plan.first_frame(read_frame(frames, 0, index), index)


class Partial:
    """Running sums over some frames of a run (see the module docstring).

    ``averages``: one PrimaryAverage (mode "mean") or one per output time ("smooth").
    ``frames``: the derived fields of each frame ("none") or its primaries ("store").
    """

    def __init__(self, plan):
        self.plan = plan
        self.u_ref, self.dim = plan.u_ref, plan.dim
        self.indices, self.times = [], []
        self.frames = []
        n_out = {"mean": 1, "smooth": 0 if plan.out_times is None else len(plan.out_times)}.get(plan.mode, 0)
        self.averages = [PrimaryAverage(plan.needed) for _ in range(n_out)]
        self.target = self.kernel = self.box = None

    def add(self, index, snapshot):
        """Coarse-grain frame ``index`` into the sums; any error names the frame."""
        try:
            self._add(snapshot)
        except Exception as exc:
            raise name_frame(exc, index) from exc
        self.indices.append(index)

    def _add(self, snapshot):
        plan = self.plan
        snap, target, kernel, _, _ = prepare(snapshot, plan.grid, plan.kernel, plan.fields, plan.convention,
                                             plan.species)
        if self.u_ref is None:
            self.u_ref, self.dim = reference_velocity(snap), snap.dim
        elif snap.dim != self.dim:
            raise ValueError(f"snapshot: expected a {self.dim}D snapshot like the first frame, got {snap.dim}D")
        split = check_computable(snap, plan.needed)
        prim = compute_primaries(snap, target, kernel, plan.needed, self.u_ref, split)
        if self.target is None:
            self.target, self.kernel, self.box = target, kernel, snap.box
        self._add_primaries(snap.time, prim)

    def _add_primaries(self, time, prim):
        plan = self.plan
        self.times.append(time)
        if plan.mode == "mean":
            self.averages[0].add(prim)
        elif plan.mode == "none":
            self.frames.append(derive(prim, plan.fields, self.u_ref, self.dim, plan.convention))
        elif plan.mode == "store":
            self.frames.append(prim)
        else:
            for acc, t_out in zip(self.averages, plan.out_times):
                acc.add(prim, float(np.exp(-0.5 * ((time - t_out) / plan.width) ** 2)))

    def merge(self, other):
        """Append the partial of the next block (in frame order); returns self."""
        if self.target is None:
            self.target, self.kernel, self.box = other.target, other.kernel, other.box
            self.u_ref, self.dim = other.u_ref, other.dim
        self.indices += other.indices
        self.times += other.times
        self.frames += other.frames
        for mine, theirs in zip(self.averages, other.averages):
            mine.merge(theirs)
        return self

    def smoothed(self, out_times):
        """From stored primaries ("store"): the smoothing sums at ``out_times`` over this block's frames."""
        out = Partial(self.plan.smoothing_at(out_times))
        out.u_ref, out.dim = self.u_ref, self.dim
        out.target, out.kernel, out.box = self.target, self.kernel, self.box
        for time, prim in zip(self.times, self.frames):
            out._add_primaries(time, prim)
        out.indices, out.times = list(self.indices), list(self.times)
        return out

    def finish(self):
        """Fields (flat over nodes, with a leading time axis unless the mode is "mean") and their times."""
        plan = self.plan
        if plan.mode == "mean":
            return derive(self.averages[0].result(), plan.fields, self.u_ref, self.dim, plan.convention), \
                [float(np.mean(self.times))]
        if plan.mode == "none":
            return {name: np.stack([f[name] for f in self.frames]) for name in plan.fields}, list(self.times)
        if plan.mode == "store":
            raise RuntimeError("Partial.finish: smoothing needs its output times first (call smoothed)")
        per_time = []
        for acc, t_out in zip(self.averages, plan.out_times):
            if acc.weight == 0.0:
                raise ValueError(f"times: expected output times within reach of the frames (Gaussian weights "
                                 f"underflow beyond ~38 widths), got {t_out} with no frame in reach")
            per_time.append(derive(acc.result(), plan.fields, self.u_ref, self.dim, plan.convention))
        return {name: np.stack([f[name] for f in per_time]) for name in plan.fields}, plan.out_times


def block_partial(plan, frames, indices):
    """Task: coarse-grain a block. ``frames[k]`` is frame ``indices[k]`` of the run."""
    partial = Partial(plan)
    for position, index in enumerate(indices):
        partial.add(index, read_frame(frames, position, index))
    return partial


def partial_times(partial):
    """Task: the frame times of a stored block (small, sent back before the smoothing sums)."""
    return list(partial.times)


def smoothed_partial(partial, out_times):
    """Task: the smoothing sums of a stored block at the run's output times."""
    return partial.smoothed(out_times)
