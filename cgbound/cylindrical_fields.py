"""Fields on a :class:`~cgbound.cylindrical.CylindricalGrid`, from the Cartesian engine at quadrature points.

The θ-average of a field over a ring is the average over θ of the Cartesian field at points of the ring,
rotated into the local basis (e_r, e_θ, e_z). The primary sums (density, momentum, stresses, the
interaction force density, ...) are linear in the kernel, so they are evaluated exactly by the Cartesian
engine at :class:`~cgbound.grid.Points` on the rings, rotated per point, averaged with the quadrature
weights, and only then turned into fields by the same :func:`~cgbound.fields.derive` as on a Grid
(velocity = averaged momentum / averaged density, never an average of ratios; the kinetic stress is the
spread about the averaged velocity, -(k - p p / rho) of the averaged primaries, as on a Grid's averaged axes).

On a θ-averaged grid the sums over points (particles, contact points), the gradient primaries, the contact
and boundary stress's line integrals and the extended stress's rays (finite branches past every ring's reach)
are the exact ring integrals of :mod:`cgbound.cylindrical_ring` (round-off), on a z-averaged grid averaged
over z exactly too (:func:`~cgbound.cylindrical_ring.axial_rule`; the line integrals and rays by
:mod:`cgbound.cylindrical_axial_segments`). On a θ-resolved z-averaged grid the point sums and gradients are
the kernel's exact line integrals along each node's z-line (:func:`~cgbound.cylindrical_ring.axial_line_average`),
and the stresses' line integrals and rays exact z-averages too
(:func:`~cgbound.cylindrical_axial.axial_segment_average`). A θ-resolved, z-resolved grid's nodes are
Cartesian points: the engine evaluates there (:func:`quadrature`, one point per node).

:func:`quadrature` also builds the rules the exact paths replaced, which no field uses any more (the
benchmarks time against them): in θ the periodic trapezoidal rule with ``theta_points(r, kernel)`` points
(spectral for a smooth integrand: exact to round-off for a Gaussian whose cutoff jump is below round-off,
cutoff >= 9 w; with the default 5 w cutoff the jump exp(-12.5) ~ 4e-6 limits it); over z (when averaged) the
Gauss-Legendre rule with ``z_points`` points over the box's extent along the axis (which the balance residual
on z-averaged grids still takes, :func:`line_z_rule`).
"""
import math

import numpy as np

from .cylindrical import CylindricalGrid
from .cylindrical_axial import axial_line_integrals
from .cylindrical_axial_segments import ray_lengths, z_averaged_ring_segments
from .cylindrical_ring import axial_line_average, ring_average, ring_average_segments
from .fields import ROTATION_FIELDS, check_fields, derive
from .grid import Points
from .kernels import Gaussian
from .pipeline import prepare, shape_fields
from .primaries import (GRADIENT_PRIMARIES, POINT_PRIMARIES, PRIMARIES, compute_primaries, gradient_sources,
                        point_sources, segment_sources)
from .result import Result
from .snapshot import Snapshot


#: the most trapezoidal points on one ring (the quadrature's memory grows with them)
MAX_THETA_POINTS = 1e6


def theta_points(r, kernel):
    """Trapezoidal points on a ring of radius r: the Fourier modes of exp(r ρ cos θ / w²) decay like
    exp(-k² w² / 2 r ρ) for particles out to ρ = r + cutoff, so k ~ sqrt(80 r ρ) / w leaves < 1e-17."""
    w = kernel.scale
    rho = r + float(kernel.radius)
    n = max(16.0, math.ceil(math.sqrt(80.0 * r * rho) / w) + 16.0)
    if n > MAX_THETA_POINTS:
        raise ValueError(f"kernel: a kernel scale of {w:g} on rings of radius up to {r:g} needs {n:.3g} points per "
                         f"ring for the fields still computed by quadrature (at most {MAX_THETA_POINTS:g}); use a "
                         "wider kernel or a smaller radial range")
    n = int(n)
    # compact kernels (Lucy, Heaviside) are finitely smooth in θ: the rule converges algebraically; twice the points
    return n if isinstance(kernel, Gaussian) else 2 * n


#: the most Gauss-Legendre points over the axial extent (the rule's eigenproblem grows as their cube)
MAX_Z_POINTS = 1e4


def z_points(length, kernel):
    """Gauss-Legendre points over an axial extent ``length`` (about 2 per kernel scale, and 8 more)."""
    n = math.ceil(2.0 * length / kernel.scale) + 8.0
    if n > MAX_Z_POINTS:
        raise ValueError(f"kernel: a kernel scale of {kernel.scale:g} over an axial extent of {length:g} "
                         f"needs {n:.3g} points in z for the fields still computed by quadrature (at most "
                         f"{MAX_Z_POINTS:g}); use a wider kernel, or resolve z (z=(z_min, z_max, n_z))")
    return int(n)


def quadrature(grid, kernel):
    """Points (Q, 3), their angles (Q,), weights (Q,), and each node's first point (n_nodes,).

    Nodes in C order of ``grid.shape``; each node's points are contiguous and its weights sum to 1.
    """
    if grid.z_averaged:
        lo, hi = grid.z_extent
        x, wz = np.polynomial.legendre.leggauss(z_points(hi - lo, kernel))
        zs = 0.5 * (hi + lo) + 0.5 * (hi - lo) * x
        wz = 0.5 * wz
    positions, angles, weights, starts = [], [], [], []
    count = 0
    for r in grid.r:
        if grid.theta_averaged:
            n = theta_points(r, kernel)
            ring = (np.arange(n) + 0.5) * (2 * math.pi / n)
            wt = np.full(n, 1.0 / n)
            thetas = [(ring, wt)]
        else:
            thetas = [(np.array([t]), np.ones(1)) for t in grid.theta]
        for ring, wt in thetas:
            for z in (grid.z if not grid.z_averaged else [None]):
                if z is None:
                    T, Z = np.meshgrid(ring, zs, indexing="ij")
                    W = np.outer(wt, wz)
                else:
                    T, Z = ring, np.full(ring.shape, z)
                    W = wt
                T, Z, W = T.ravel(), Z.ravel(), W.ravel()
                positions.append(grid.cartesian(r, T, Z))
                angles.append(T)
                weights.append(W)
                starts.append(count)
                count += T.size
    return np.concatenate(positions), np.concatenate(angles), np.concatenate(weights), np.array(starts)


def line_z_rule(grid, kernel):
    """The axial points (n_z, q) and weights of the line integrals on a θ-averaged grid: each z node itself, or on a
    z-averaged grid Gauss-Legendre over its extent (the point sums average over z exactly)."""
    if grid.z_averaged:
        lo, hi = grid.z_extent
        x, wz = np.polynomial.legendre.leggauss(z_points(hi - lo, kernel))
        return (0.5 * (hi + lo) + 0.5 * (hi - lo) * x)[None, :], 0.5 * wz[None, :]
    return grid.z[:, None], np.ones((len(grid.z), 1))


def rotate(values, rank, basis):
    """Cartesian components (Q, 3, ...) of rank ``rank`` into the local basis rows ``basis`` (Q, 3, 3)."""
    if rank == 0:
        return values
    if rank == 1:
        return np.einsum("qia,qa->qi", basis, values)
    return np.einsum("qia,qab,qjb->qij", basis, values, basis)


def ring_sums(job, grid, needed):
    """The primaries ``needed`` averaged over each node of ``grid`` (θ and/or z as the grid asks), in the local
    basis, flat over nodes: {name: (n_nodes,) + (3,) * rank}. ``job``: from :func:`~cgbound.pipeline.prepare`
    (its snapshot, kernel and split contacts; its target is not used).

    On a θ-averaged grid the sums over points (particles, contact points), the contact and boundary
    stress's line integrals, the extended stress's rays and the gradient primaries are the exact ring
    integrals of :mod:`cgbound.cylindrical_ring` (on a z-averaged grid exactly averaged over z, the line
    integrals and rays by :mod:`cgbound.cylindrical_axial_segments`); on a θ-resolved z-averaged grid the
    point sums and gradients are exact line integrals along each node's z-line, and the stresses' line
    integrals and the extended stress's rays exact z-averages (:mod:`cgbound.cylindrical_axial`). The other
    primaries come from the Cartesian engine at the quadrature points."""
    zero = np.zeros(3)
    averaged = {}
    if grid.theta_averaged:
        for positions, columns in point_sources(job.snapshot, needed, zero, job.split):
            sums = ring_average(grid, job.kernel, positions, [(v, PRIMARIES[name].rank) for name, v in columns])
            averaged.update({name: s for (name, _), s in zip(columns, sums)})
        lines = [(name, part) for name, part in zip(("sb", "sw"), job.split or ()) if name in needed]
        if "sx" in needed and job.split:     # the rays: segments long enough to leave every ring's reach
            lines.append(("sx", job.split[1]))
        for name, part in lines:
            starts, vectors, values = segment_sources(job.snapshot, part)
            values = values.reshape(-1, 3, 3)
            if name == "sx":         # ∫₀^∞ W(x - q - s v) ds = L ∫₀¹ W(x - q - s' L v) ds' past the reach
                length = ray_lengths(grid, job.kernel, starts, vectors)
                vectors, values = vectors * length[:, None], values * length[:, None, None]
            if grid.z_averaged:      # s outside, each point's exact axial average inside
                averaged[name] = z_averaged_ring_segments(grid, job.kernel, starts, vectors, values)
            else:
                averaged[name] = ring_average_segments(grid, job.kernel, starts, vectors, values, grid.z[:, None],
                                                       np.ones((len(grid.z), 1)))
        positions, rows = gradient_sources(job.snapshot, needed, zero)
        if rows and len(positions):
            sums = ring_average(grid, job.kernel, positions, [(v, PRIMARIES[name].rank - 1) for name, v in rows],
                                gradient=True)
            averaged.update({name: g for (name, _), g in zip(rows, sums)})
        for name in needed & (POINT_PRIMARIES | GRADIENT_PRIMARIES) - set(averaged):   # no data (velocities, ...)
            averaged[name] = np.zeros((grid.size,) + (3,) * PRIMARIES[name].rank)
    elif grid.z_averaged:            # θ resolved: the z-averages are exact line integrals along the z-lines
        for positions, columns in point_sources(job.snapshot, needed, zero, job.split):
            sums = axial_line_average(grid, job.kernel, positions,
                                      [(v, PRIMARIES[name].rank) for name, v in columns])
            averaged.update({name: s for (name, _), s in zip(columns, sums)})
        positions, rows = gradient_sources(job.snapshot, needed, zero)
        if rows and len(positions):
            sums = axial_line_average(grid, job.kernel, positions,
                                      [(v, PRIMARIES[name].rank - 1) for name, v in rows], gradient=True)
            averaged.update({name: g for (name, _), g in zip(rows, sums)})
        for name in needed & (POINT_PRIMARIES | GRADIENT_PRIMARIES) - set(averaged):
            averaged[name] = np.zeros((grid.size,) + (3,) * PRIMARIES[name].rank)
        averaged.update(axial_line_integrals(job, grid, needed))
    rest = needed - set(averaged)
    if not rest:
        return averaged
    positions, angles, weights, starts = quadrature(grid, job.kernel)
    sums = compute_primaries(job.snapshot, Points(positions), job.kernel, rest, zero, job.split)
    basis = grid.basis(angles)
    for name, value in sums.items():
        rank = PRIMARIES[name].rank
        local = rotate(np.asarray(value).reshape((len(positions),) + (3,) * rank), rank, basis)
        local = local * weights.reshape((-1,) + (1,) * rank)
        averaged[name] = np.ascontiguousarray(np.add.reduceat(local, starts, axis=0))   # (nodes,) + (3,) * rank
    return averaged



def check_ring_arguments(snapshot, grid, kernel, fields, convention="tension", species=None):
    """Raise before any work if the fields of ``snapshot`` cannot be computed on ``grid``; returns the
    checked job of a one-point target (its kernel, fields, convention)."""
    if not isinstance(grid, CylindricalGrid):
        raise TypeError(f"grid: expected a cg.CylindricalGrid, got {type(grid).__name__}")
    if not isinstance(snapshot, Snapshot):
        raise TypeError(f"snapshot: expected a cg.Snapshot, got {type(snapshot).__name__}")
    if snapshot.dim != 3:
        raise ValueError(f"snapshot: expected a 3-D snapshot for a CylindricalGrid, got a {snapshot.dim}-D one")
    rotational = [name for name in check_fields(fields) if name in ROTATION_FIELDS]
    if rotational:
        raise ValueError(f"fields: expected fields without a pseudo-vector index on a cg.CylindricalGrid, got "
                         f"{rotational} (use a Grid or Points)")
    # checks every argument (kernel, fields, convention, species) on a one-point target before the work
    job = prepare(snapshot, Points(grid.axis_point[None, :]), kernel, fields, convention, species)
    if grid.theta_averaged and "sx" in job.needed and job.split:     # rays that never leave: refused now
        ray_lengths(grid, job.kernel, *segment_sources(job.snapshot, job.split[1])[:2])
    return job


def ring_primaries(snapshot, grid, kernel, fields, convention="tension", species=None):
    """The checked job and the primaries the fields need, averaged over each node's quadrature points and
    rotated into (e_r, e_θ, e_z): a dict flat over nodes (shape (n_nodes,) + (3,) * rank), about the
    reference velocity 0. What :func:`coarse_grain_cylindrical` derives one snapshot's fields from, and
    what time averages (:mod:`cgbound.averaging`) sum over frames.

    The gradient primaries are the Cartesian gradients rotated on every index and averaged: the ring
    average of e_a · ∇p · e_b is the cylindrical gradient of the θ-averaged field in physical components
    (∂/∂r and ∂/∂z of the averaged components, and the hoop terms -p_θ/r, p_r/r in the θ column; see
    docs/guide/cylindrical.md). On a z-averaged grid the fields do not depend on z: the z column is zero,
    as along a Grid's averaged axes.
    """
    job = check_ring_arguments(snapshot, grid, kernel, fields, convention, species)   # (its target is not used)
    zero = np.zeros(3)       # a reference velocity constant in Cartesian components is not one in (r, θ, z)
    # the kinetic stress of a ring is the velocity spread about the ring's averaged velocity (as on a Grid's
    # averaged axes): -(k - p p / rho) from the averaged primaries, not the average of pointwise spreads
    needed = (job.needed - {"sk"}) | ({"k", "p_w", "rho"} if "sk" in job.needed else set())
    averaged = ring_sums(job, grid, needed)
    if "sk" in job.needed:
        rho, p = averaged["rho"], averaged["p_w"]
        spread = np.einsum("ni,nj->nij", p, p)
        np.divide(spread, rho[:, None, None], out=spread, where=rho[:, None, None] > 0)
        averaged["sk"] = np.ascontiguousarray(spread - averaged["k"].reshape(spread.shape))
    if grid.z_averaged:
        for name in job.needed & GRADIENT_PRIMARIES:
            averaged[name][..., 2] = 0.0
    return job, averaged


def coarse_grain_cylindrical(snapshot, grid, kernel, fields, convention="tension", species=None):
    """Fields of one snapshot on a CylindricalGrid (see :func:`cgbound.coarse_grain`)."""
    job, averaged = ring_primaries(snapshot, grid, kernel, fields, convention, species)
    zero = np.zeros(3)
    flat = derive(averaged, job.fields, zero, 3, job.convention)
    flat = {name: np.ascontiguousarray(v) for name, v in flat.items()}
    return Result(shape_fields(flat, grid, 3), grid, job.kernel, job.convention, [job.snapshot.time],
                  job.snapshot.box, units=job.snapshot.units, n_frames=1)
