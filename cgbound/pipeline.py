"""The per-snapshot pipeline, written once: prepare → check → reference velocity → primaries →
derive → shape.

:func:`prepare` checks the arguments and what the snapshot must hold; :func:`run_snapshot` takes a
prepared :class:`Job` through the rest, with the primary sums computed by a function it is given
(the whole target at once, :func:`whole_target_sums`, or tile by tile in :mod:`cgbound.tiled`).
Time averages (:mod:`cgbound.averaging`) reuse :func:`prepare` and :func:`whole_target_sums`.
"""
from typing import NamedTuple, Optional

from ._memory import check_fits, core_threads, grid_doubles
from ._validate import integer
from .fields import (DEFAULT_COUPLE_STRESS_FORM, ROTATION_FIELDS, check_convention, check_couple_stress_form,
                     check_differentiable, check_fields, derive, field_shape, field_size, needed_primaries)
from .grid import Grid, check_target, periodic_resolved_lengths
from .kernels import check_kernel, check_reach
from .primaries import (PARTICLE_GRADIENTS, PARTICLES, PRIMARIES, check_computable, compute_primaries,
                        reference_velocity, rotation_largest)
from .result import Result
from .snapshot import Snapshot
from .units import check_fields as check_units_fields

DEFAULT_FIELDS = ("density", "velocity", "stress")


class Job(NamedTuple):
    """One snapshot's checked coarse graining: the snapshot seen by the species, and what to compute."""
    snapshot: Snapshot
    target: object            # Grid or Points
    kernel: object
    fields: tuple
    convention: str
    needed: set               # primary names
    split: Optional[tuple]    # Snapshot.split_contacts() if a contact primary is needed, else None


def check_arguments(snapshot, grid, kernel, fields, convention, species,
                    couple_stress_form=DEFAULT_COUPLE_STRESS_FORM):
    """Checked arguments of one coarse graining, and the snapshot seen by ``species``."""
    if not isinstance(snapshot, Snapshot):
        raise TypeError(f"snapshot: expected a cg.Snapshot, got {type(snapshot).__name__}")
    target = check_target(grid, snapshot.dim)
    kernel = check_kernel(kernel)
    fields = check_fields(fields)
    convention = check_convention(convention)
    check_differentiable(kernel, fields)
    species = integer(species, "species", allow_none=True)
    check_units_fields(snapshot.units, fields)
    check_branch_line(couple_stress_form, fields, kernel)
    if species is not None:
        snapshot = snapshot.species_view(species)
    largest = snapshot.largest_product
    if any(name in ROTATION_FIELDS for name in fields):
        largest = max(largest, rotation_largest(snapshot, fields))
    check_reach(kernel, snapshot.dim, periodic_resolved_lengths(snapshot.box, target), largest,
                n_resolved=len(target.resolved), avg_extent=target.avg_extent)
    return snapshot, target, kernel, fields, convention


def check_branch_line(couple_stress_form, fields, kernel):
    """The branch-line couple stress needs the kernel's first moment along lines, which the core gives for every
    kernel and target (over averaged axes: the Gaussian's marginals in closed form, Lucy's and Heaviside's by
    Gauss-Legendre panels); not for MercuryCG's approximate line integral."""
    check_couple_stress_form(couple_stress_form)
    if couple_stress_form != "branch_line":
        return
    wanted = [f for f in fields if f in ("couple_stress", "stress_torque_density", "boundary_couple_density")]
    if wanted and kernel.mercurycg_line:
        raise ValueError(f"couple_stress_form: 'branch_line' ({wanted[0]!r}) needs exact line integrals, got "
                         f"{kernel!r} (line_quadrature='mercurycg')")


def prepare(snapshot, grid, kernel, fields, convention, species, couple_stress_form=DEFAULT_COUPLE_STRESS_FORM):
    """Steps prepare and check: the :class:`Job`, raising before any work if it cannot be done."""
    snapshot, target, kernel, fields, convention = check_arguments(snapshot, grid, kernel, fields, convention,
                                                                   species, couple_stress_form)
    needed = needed_primaries(fields, couple_stress_form)
    return Job(snapshot, target, kernel, fields, convention, needed, check_computable(snapshot, needed))


def per_node_doubles(needed, fields, dim, threads, frames=1, time_average="mean", n_times=1):
    """Doubles per node held at the peak of a coarse-graining request.

    The estimate counts the primary sums kept at once, the C core's per-thread copies of the
    output of one scatter (the core gives each of its ``n_threads - 1`` extra threads a private
    copy of the output array, except on grids it cuts into slabs, where the threads write to the
    output itself), the derived fields and one temporary. Good enough to turn a hopeless request
    into a clear MemoryError instead of a crash or swapping; with slabs it counts copies that are
    not made.
    """
    prim = sum(dim ** PRIMARIES[p].rank for p in needed)
    # the primaries of the particles' positions are summed in one scatter (primaries.particle_sums)
    batched = sum(dim ** PRIMARIES[p].rank for p in needed if PRIMARIES[p].source == PARTICLES)
    # the gradients are one scatter too, D doubles per column
    gradients = sum(dim ** PRIMARIES[p].rank for p in needed if PRIMARIES[p].source == PARTICLE_GRADIENTS)
    widest = max([dim ** PRIMARIES[p].rank for p in needed if PRIMARIES[p].source not in (PARTICLES, PARTICLE_GRADIENTS)]
                 + [batched, gradients])
    scratch = dim if "sk" in needed else 0                  # node velocities for the fluctuation sum
    out = sum(field_size(f, dim) for f in fields)
    widest_field = max((field_size(f, dim) for f in fields), default=0)
    one_frame = prim + scratch + (threads - 1) * widest + out + widest_field + batched
    if time_average == "mean" and frames > 1:
        # running sums, their mean and the velocity spread, beside one frame's primaries
        return one_frame + 2 * prim + (dim * dim if "sk" in needed else 0)
    if time_average == "none":
        return one_frame + 2 * frames * out                 # every frame's fields, then the stacked copy
    if time_average == "smooth":
        return one_frame + frames * prim + 2 * prim + 2 * n_times * out
    return one_frame


def check_memory(target, fields, dim, threads, frames=1, time_average="mean", n_times=1):
    """Raise MemoryError naming the grid if the fields (and the core's scratch) cannot fit."""
    needed = needed_primaries(fields)
    doubles = per_node_doubles(needed, fields, dim, threads, frames, time_average, n_times)
    # the grid's own node coordinates, or the points' positions, are held beside the fields
    own = grid_doubles(target.shape) if isinstance(target, Grid) else target.size * dim
    check_fits("grid", target.size, doubles, what=f"fields {', '.join(fields)}"
               + (f" over {frames} frames" if frames > 1 else ""), extra_doubles=own)


def shape_fields(flat, target, dim, leading=()):
    """Fields flat over nodes reshaped to the target's shape (after ``leading`` axes)."""
    return {name: value.reshape(leading + target.field_shape + field_shape(name, dim))
            for name, value in flat.items()}


def whole_target_sums(job, u_ref):
    """Step primaries, all the target's nodes at once."""
    return compute_primaries(job.snapshot, job.target, job.kernel, job.needed, u_ref, job.split)


def run_snapshot(job, sums=whole_target_sums):
    """Steps reference velocity → primaries (``sums(job, u_ref)``) → derive → shape of a prepared job."""
    snap = job.snapshot
    check_memory(job.target, job.fields, snap.dim, core_threads(max(snap.n_particles, len(snap.contacts))))
    u_ref = reference_velocity(snap)
    flat = derive(sums(job, u_ref), job.fields, u_ref, snap.dim, job.convention)
    return Result(shape_fields(flat, job.target, snap.dim), job.target, job.kernel, job.convention, [snap.time],
                  snap.box, units=snap.units, n_frames=1)
