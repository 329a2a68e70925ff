"""Time averages of CoarseGrain: partial sums over blocks of frames, and their exact combination.

The frames of a block are coarse-grained into a :class:`Partial` (running sums, never divided);
the partials of consecutive blocks are merged in frame order; :meth:`Partial.finish` divides once
and derives the fields. Splitting the frames into blocks therefore changes only the order of the
additions, so a run on Dask agrees with one in this process to rounding. :func:`run_blocks` hands
the blocks to an executor (:mod:`cgbound.executors`).
"""
import numpy as np

from .cylindrical import CylindricalGrid
from .cylindrical_fields import check_ring_arguments, ring_primaries
from .fields import DEFAULT_COUPLE_STRESS_FORM, derive, needed_primaries
from .pipeline import Job, check_arguments, whole_target_sums
from .primaries import check_computable, reference_velocity
from .progress import NoProgress

#: blocks per worker thread: enough to balance uneven frames and to show progress, few enough
#: that the per-block sums sent back (one grid's worth each) stay small
BLOCKS_PER_THREAD = 4


class PrimaryAverage:
    """Weighted mean of primaries over snapshots, exact for the kinetic stress.

    Linear sums are averaged directly. The kinetic stress of the mean is the
    mean of the per-snapshot (fluctuation-form) kinetic stresses minus the
    spread of the snapshot velocities about the mean velocity (the parallel
    variance formula), all in the frame of u_ref.
    """

    def __init__(self, needed):
        self.needed = set(needed)
        self.sums = {}
        self.weight = 0.0
        self.count = 0
        self.spread = None  # sum of w rho V V (frame of u_ref)

    def add(self, primaries, weight=1.0):
        for name, value in primaries.items():
            if name in self.sums:
                self.sums[name] += weight * value
            else:
                self.sums[name] = weight * value
        if "sk" in self.needed:
            rho, p = primaries["rho"], primaries["p_w"]
            V = np.zeros_like(p)
            np.divide(p, rho[:, None], out=V, where=rho[:, None] > 0)
            term = weight * rho[:, None, None] * V[:, :, None] * V[:, None, :]
            self.spread = term if self.spread is None else self.spread + term
        self.weight += weight
        self.count += 1

    def merge(self, other):
        """Add another average's running sums (frames of a later block): the exact combination."""
        for name, value in other.sums.items():
            self.sums[name] = self.sums[name] + value if name in self.sums else value.copy()
        if other.spread is not None:
            self.spread = other.spread.copy() if self.spread is None else self.spread + other.spread
        self.weight += other.weight
        self.count += other.count
        return self

    def result(self):
        if self.count == 0:
            raise ValueError("no snapshots were averaged")
        out = {name: value / self.weight for name, value in self.sums.items()}
        if "sk" in self.needed and self.count > 1:
            rho, p = out["rho"], out["p_w"]
            V = np.zeros_like(p)
            np.divide(p, rho[:, None], out=V, where=rho[:, None] > 0)
            mean_spread = self.spread / self.weight - rho[:, None, None] * V[:, :, None] * V[:, None, :]
            out["sk"] = out["sk"] - mean_spread
        return out


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
                 u_ref=None, dim=None, couple_stress_form=DEFAULT_COUPLE_STRESS_FORM):
        self.grid, self.kernel, self.fields = grid, kernel, fields
        self.convention, self.species = convention, species
        self.couple_stress_form = couple_stress_form
        self.needed = needed_primaries(fields, couple_stress_form)
        self.mode, self.width = mode, width
        self.out_times = None if out_times is None else np.asarray(out_times, dtype=float)
        self.u_ref, self.dim = u_ref, dim
        self.block_of = None   # {frame index: error block} for errors="blocks" (cgbound.block_errors)

    def smoothing_at(self, out_times):
        plan = FramePlan(self.grid, self.kernel, self.fields, self.convention, self.species, "smooth",
                         self.width, out_times, self.u_ref, self.dim, self.couple_stress_form)
        return plan

    def first_frame(self, snapshot, index=0):
        """The reference velocity and dimension every frame of the run is computed with."""
        try:
            if isinstance(self.grid, CylindricalGrid):
                # ring primaries are summed about 0 (a constant Cartesian velocity is not one in (r, θ, z))
                check_ring_arguments(snapshot, self.grid, self.kernel, self.fields, self.convention, self.species)
                return np.zeros(3), 3
            snap = check_arguments(snapshot, self.grid, self.kernel, self.fields, self.convention, self.species,
                                   self.couple_stress_form)[0]
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
        self.units = None           # the first frame's (cgbound.units.Units or None)
        self.species_seen = set()   # the species of the frames read, when partial fields are asked for
        self.block_averages = {}    # error block -> PrimaryAverage of its frames (plan.block_of)
        self.block = None           # the error block of the frame being added

    def add(self, index, snapshot):
        """Coarse-grain frame ``index`` into the sums; any error names the frame."""
        self.block = None if self.plan.block_of is None else self.plan.block_of[index]
        try:
            self._add(snapshot)
        except Exception as exc:
            raise name_frame(exc, index) from exc
        self.indices.append(index)

    def _add(self, snapshot):
        plan = self.plan
        if isinstance(plan.grid, CylindricalGrid):
            # the ring averages of the primaries in (e_r, e_θ, e_z), always about the reference velocity 0
            job, prim = ring_primaries(snapshot, plan.grid, plan.kernel, plan.fields, plan.convention, plan.species)
            snap, target, kernel = job.snapshot, plan.grid, job.kernel
            if self.u_ref is None:
                self.u_ref, self.dim = np.zeros(3), 3
        else:
            snap, target, kernel, _, _ = check_arguments(snapshot, plan.grid, plan.kernel, plan.fields,
                                                         plan.convention, plan.species, plan.couple_stress_form)
            if self.u_ref is None:
                self.u_ref, self.dim = reference_velocity(snap), snap.dim
            elif snap.dim != self.dim:
                raise ValueError(f"snapshot: expected a {self.dim}D snapshot like the first frame, got {snap.dim}D")
            job = Job(snap, target, kernel, plan.fields, plan.convention, plan.needed,
                      check_computable(snap, plan.needed))
            prim = whole_target_sums(job, self.u_ref)
        if plan.species is not None:
            # the flowing particles' species: partial fields count no fixed particle, so a species only among the
            # fixed ones would give zero fields, like one absent
            self.species_seen.update(np.unique(snapshot.species[~snapshot.fixed]).tolist())
        if self.target is None:
            self.target, self.kernel, self.box = target, kernel, snap.box
            self.units = snap.units
        elif snap.units != self.units:
            raise ValueError(f"snapshot: expected the units of the first frame ({self.units}), got {snap.units}")
        self._add_primaries(snap.time, prim)

    def _add_primaries(self, time, prim):
        plan = self.plan
        self.times.append(time)
        if plan.mode == "mean":
            self.averages[0].add(prim)
            if plan.block_of is not None:
                self.block_averages.setdefault(self.block, PrimaryAverage(plan.needed)).add(prim)
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
            self.target, self.kernel, self.box, self.units = other.target, other.kernel, other.box, other.units
            self.u_ref, self.dim = other.u_ref, other.dim
        elif other.target is not None and other.units != self.units:
            raise ValueError(f"snapshot: expected the units of the first frame ({self.units}), got {other.units}")
        self.indices += other.indices
        self.species_seen |= other.species_seen
        self.times += other.times
        self.frames += other.frames
        for mine, theirs in zip(self.averages, other.averages):
            mine.merge(theirs)
        for block, theirs in other.block_averages.items():
            mine = self.block_averages.get(block)
            self.block_averages[block] = theirs if mine is None else mine.merge(theirs)
        return self

    def smoothed(self, out_times):
        """From stored primaries ("store"): the smoothing sums at ``out_times`` over this block's frames."""
        out = Partial(self.plan.smoothing_at(out_times))
        out.u_ref, out.dim = self.u_ref, self.dim
        out.target, out.kernel, out.box, out.units = self.target, self.kernel, self.box, self.units
        for time, prim in zip(self.times, self.frames):
            out._add_primaries(time, prim)
        out.indices, out.times = list(self.indices), list(self.times)
        out.species_seen = set(self.species_seen)
        return out

    def finish(self):
        """Fields (flat over nodes, with a leading time axis unless the mode is "mean") and their times."""
        plan = self.plan
        if plan.species is not None and plan.species not in self.species_seen:
            raise ValueError(f"species: {plan.species} is in none of the {len(self.times)} frames read (species of "
                             f"flowing particles present: {sorted(self.species_seen)}; fixed particles do not count); "
                             f"partial fields of it would be zero")
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


def fill_partial(plan, indexed_frames):
    """The Partial of ``(index, snapshot)`` pairs, added in order."""
    partial = Partial(plan)
    for index, snapshot in indexed_frames:
        partial.add(index, snapshot)
    return partial


def block_partial(plan, frames, indices):
    """Task: coarse-grain a block. ``frames[k]`` is frame ``indices[k]`` of the run."""
    return fill_partial(plan, ((index, read_frame(frames, position, index)) for position, index in enumerate(indices)))


def partial_times(partial):
    """Task: the frame times of a stored block (small, sent back before the smoothing sums)."""
    return list(partial.times)


def smoothed_partial(partial, out_times):
    """Task: the smoothing sums of a stored block at the run's output times."""
    return partial.smoothed(out_times)


def split_blocks(indices, n_blocks):
    """Consecutive runs of ``indices`` (frame order kept), as lists of ints."""
    n_blocks = max(1, min(n_blocks, len(indices)))
    return [[int(k) for k in chunk] for chunk in np.array_split(np.asarray(indices), n_blocks)]


class _Indexed:
    """Frames ``indices`` of a sequence that is not a reader: position k is ``sequence[indices[k]]``."""

    def __init__(self, sequence, indices):
        self.sequence, self.indices = sequence, list(indices)

    def __len__(self):
        return len(self.indices)

    def __getitem__(self, position):
        return self.sequence[self.indices[position]]


def block_frames(executor, snapshots, indices):
    """What a worker needs to read frames ``indices``: a restricted reader (paths and frame
    locators), the Snapshots themselves (scattered) for a list or tuple, else the sequence with the indices."""
    if hasattr(snapshots, "take"):   # a reader (cgbound.readers.FrameSequence)
        return snapshots.take(indices)
    if isinstance(snapshots, (list, tuple)):
        return executor.scatter([snapshots[k] for k in indices])
    return _Indexed(snapshots, indices)


def _merge(a, b):
    return a.merge(b)


def run_blocks(executor, plan, snapshots, indices, progress):
    """CoarseGrain.run's frames ``indices`` of ``snapshots`` in blocks on ``executor``: the merged Partial."""
    # a smoothing block sends back sums at every output time: one block per thread keeps that traffic
    # (and the client's additions) smallest
    per_thread = 1 if plan.mode in ("smooth", "store") else BLOCKS_PER_THREAD
    blocks = split_blocks(indices, per_thread * executor.n_threads)
    # every frame is computed relative to the first frame's mean velocity, as in a serial run
    first = executor.submit(first_frame_info, plan, block_frames(executor, snapshots, indices[:1]), indices[0])
    futures = [first]
    try:
        plan.u_ref, plan.dim = first.result()
        plan_future = executor.scatter(plan, broadcast=True)
        sizes = [len(b) for b in blocks]
        try:
            futures = [executor.submit(block_partial, plan_future, block_frames(executor, snapshots, b), b)
                       for b in blocks]
            if plan.mode != "store":
                return executor.gather_in_order(futures, sizes, progress, _merge)
            # smoothing at the frames' own times: the blocks keep their primaries on the workers,
            # send back their times, then the smoothing sums at all the times
            times = executor.gather_in_order([executor.submit(partial_times, f) for f in futures], sizes,
                                             progress, list.__add__)
        finally:
            progress.close()
        out_times = np.asarray(times, dtype=float)
        smoothed = [executor.submit(smoothed_partial, f, out_times) for f in futures]
        return executor.gather_in_order(smoothed, sizes, NoProgress(), _merge)
    finally:
        executor.cancel(futures)
