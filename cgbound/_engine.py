"""The one seam to the C core: the only module that imports ``_core``.

The core takes a target and a kernel as tuples it parses by position (see ``convert_target`` and
``convert_kernel`` in csrc/_coremodule.c). :class:`CoreTarget` and :class:`CoreKernel` name those
positions (they are still tuples); :func:`core_target` and :func:`core_kernel` build them from a
grid, point set or tile and from a kernel object, read by attribute only, so that this module
imports nothing above it. Every ``_core`` entry point the package uses is wrapped here.
"""
from typing import NamedTuple, Optional, Sequence

from . import _core


class CoreTarget(NamedTuple):
    """Where the core evaluates: resolved axes with node coordinates (a grid), or points."""
    dim: int
    axes: Sequence[int]               # the resolved axes, increasing
    coordinates: Optional[list]       # per resolved axis, the node coordinates (grids); else None
    points: Optional[object]          # (P, D) evaluation points; else None
    periodic: list                    # per resolved axis
    period: list                      # per resolved axis, the box length


class CoreKernel(NamedTuple):
    """The kernel as the core sees it (``type``: 0 Gaussian, 1 Lucy, 2 Heaviside)."""
    type: int
    width: float                      # the Gaussian's standard deviation; the radius for the others
    radius: float                     # support radius
    truncated: int                    # 1: Gaussian renormalised over the cut-off ball
    avg_extent: float                 # product of the averaged axes' lengths (1 without)
    line_points: int = 0              # Gauss-Legendre points along segments, 0 = exact
    per_node: int = 0                 # benchmarks only: no separable fast path
    lower_dimensional: int = 0        # 1: over averaged axes the D_res-dimensional kernel (MercuryCG's)
    mercurycg_line: int = 0           # 1: MercuryCG's approximate Gauss line integral (one resolved axis)


def core_target(target, box):
    """The core's description of ``target`` (a Grid, a tile of one, or Points) in ``box``.

    Grids and tiles give ``axis_coordinates`` for every axis; point sets give ``positions``.
    """
    resolved = tuple(target.resolved)
    positions = getattr(target, "positions", None)
    if positions is not None:
        return CoreTarget(target.dim, tuple(range(target.dim)), None, positions, list(box.periodic),
                          [float(x) for x in box.lengths])
    coordinates = target.axis_coordinates
    return CoreTarget(target.dim, resolved, [coordinates[d] for d in resolved], None,
                      [box.periodic[d] for d in resolved], [float(box.lengths[d]) for d in resolved])


def point_target(origin):
    """A target of one point ``origin`` (shape (1, D)), in unbounded space."""
    dim = origin.shape[1]
    return CoreTarget(dim, tuple(range(dim)), None, origin, [False] * dim, [1.0] * dim)


def core_kernel(kernel, avg_extent, longest_branch=None):
    """The core's description of ``kernel``; ``longest_branch`` resolves line_quadrature="auto"
    (exact without it)."""
    mercurycg = kernel.mercurycg_line
    points = 0 if mercurycg else kernel.line_points_for(longest_branch)
    return CoreKernel(kernel.kind, float(kernel.width if kernel.width is not None else kernel.radius),
                      float(kernel.radius), int(kernel.truncated), float(avg_extent), int(points),
                      int(kernel.per_node), int(kernel.lower_dimensional), int(mercurycg))


def scatter_points(target, kernel, positions, values, gradient=False, n_threads=0):
    """sum_i values_i W(r - positions_i) at the target's nodes (or its gradient), shape (P, K[, D])."""
    return _core.scatter_points(target, kernel, positions, values, gradient=gradient, n_threads=n_threads)


#: the parts of scatter_points_kinetic's values (csrc/cg.h's CG_KINETIC_*), in their order
KINETIC_MASS, KINETIC_MOMENTUM, KINETIC_FLUX = 1, 2, 4


def scatter_points_kinetic(target, kernel, positions, masses, velocities, u_ref, parts, n_threads=0):
    """scatter_points with each particle's values formed in the core: the ``parts`` (a mask of KINETIC_*) of
    [m, m (v - u_ref), m v (x) v] in that order, shape (P, K); no (n, K) array of values. The flux is symmetric:
    its D (D + 1) / 2 entries r <= c, row by row (the whole of it: ``[..., symmetric_index(D)]``)."""
    return _core.scatter_points_kinetic(target, kernel, positions, masses, velocities, u_ref, parts,
                                        n_threads=n_threads)


def symmetric_index(dim):
    """The column of each entry (r, c) of a symmetric D x D matrix, row-major, among its entries r <= c packed row
    by row (scatter_points_kinetic's flux): the whole matrix is ``packed[..., symmetric_index(D)]``."""
    column, k = {}, 0
    for r in range(dim):
        for c in range(r, dim):
            column[r, c] = column[c, r] = k
            k += 1
    return tuple(column[r, c] for r in range(dim) for c in range(dim))


def scatter_segments(target, kernel, starts, vectors, values, ray=False, gradient=False, n_threads=0):
    """sum_c values_c times the kernel integrated along starts_c + s vectors_c, s in [0, 1]
    (``ray``: s >= 0), or its gradient."""
    return _core.scatter_segments(target, kernel, starts, vectors, values, ray=ray, gradient=gradient,
                                  n_threads=n_threads)


def scatter_segments_outer(target, kernel, starts, vectors, factors, ray=False, gradient=False, n_threads=0,
                           negate=False):
    """scatter_segments with the values factors_c (x) vectors_c (flat (n, F*D), each 0.0 + a product), formed in
    the core segment by segment instead of as an (n, F*D) array; ``negate``: the vectors are -vectors (exactly,
    as np.negative gives them, without an (n, D) array of them)."""
    return _core.scatter_segments_outer(target, kernel, starts, vectors, factors, ray=ray, gradient=gradient,
                                        n_threads=n_threads, negate=negate)


def scatter_segment_moments(target, kernel, starts, vectors, values, gradient=False, n_threads=0):
    """sum_c values_c times the kernel's first moment along starts_c + s vectors_c, int_0^1 s W(r - starts_c
    - s vectors_c) ds, or its gradient (the full-dimensional kernel: no averaged axis)."""
    return _core.scatter_segment_moments(target, kernel, starts, vectors, values, gradient=gradient,
                                         n_threads=n_threads)


def scatter_fluctuation(target, kernel, positions, masses, velocities, node_velocity, n_threads=0):
    """The kinetic stress in fluctuation form, -sum_i m_i v'_i v'_i W_i, shape (P, D, D)."""
    return _core.scatter_fluctuation(target, kernel, positions, masses, velocities, node_velocity,
                                     n_threads=n_threads)


def minimum_image(vectors, periodic, period):
    """``vectors`` folded to their nearest periodic image along the periodic axes."""
    return _core.minimum_image(vectors, periodic, period)


def wrap(positions, periodic, lower, upper):
    """``positions`` moved into ``[lower, upper)`` along the periodic axes (others unchanged)."""
    return _core.wrap(positions, periodic, lower, upper)


def text_parse_table(data, start, stop, ncols, int_mask, max_rows, flags, n_threads=1, parts=0, out=None):
    """The C text parser over ``data[start:stop]`` (see csrc/cg_text.h and readers/_text.py), on up to
    n_threads threads for large ranges (parts > 0: cut into exactly that many parts whatever the size). out: None,
    or ``out(nbytes)`` giving a writable buffer for both tables (they are then views of it) or None (new arrays)."""
    return _core.text_parse_table(data, start, stop, ncols, int_mask, max_rows, flags, n_threads, parts, out)


def text_plan_lines(data, start, stop, parts):
    """``data[start:stop]`` cut at line starts into ``parts`` parts, the lines counted once (cg_text_plan_lines):
    (int64 offsets in data of the parts' starts and the end, int64 lines before each and in all)."""
    return _core.text_plan_lines(data, start, stop, parts)


def fstat_contacts(rows, partners, time, time_tolerance, positions, radii, fixed, periodic, period, rtol):
    """The contacts of a MercuryDPM .fstat frame in one C pass (csrc/cg_fstat.h): (0, (), (i, j, wall, force,
    point, overlap)), or (problem, (row, other_row, pair_lo, pair_hi, count, df, dc, force_row, force_other), None)
    with problem a CG_FSTAT_* code."""
    return _core.fstat_contacts(rows, partners, time, time_tolerance, positions, radii, fixed, periodic, period,
                                rtol)


def text_find_lines(data, start, stop, prefix, n_threads=1):
    """Byte offsets of the lines of ``data[start:stop]`` that start with ``prefix`` (ranges of 4 MB and more
    searched over up to n_threads threads)."""
    return _core.text_find_lines(data, start, stop, prefix, n_threads)


def text_count_lines(data, start, stop, n_threads=1):
    """The lines of ``data[start:stop]``: its newlines, plus one if it does not end with one (ranges of 4 MB and
    more counted over up to n_threads threads)."""
    return _core.text_count_lines(data, start, stop, n_threads)


def have_openmp():
    """Whether the core was built with OpenMP threads."""
    return _core.have_openmp()


def default_threads():
    """The OpenMP default number of threads."""
    return _core.default_threads()


def set_wide_vectors(wide):
    """Benchmarks and tests: run the Gaussian's AVX-512 build (True) or the narrow one; returns the previous."""
    return _core.set_wide_vectors(wide)


def wide_vectors():
    """Whether the Gaussian on grids runs its AVX-512 build."""
    return _core.wide_vectors()


def gaussian_erfcx(x):
    """Tests: erfcx(x) = exp(x^2) erfc(x) for finite x >= 0 (a 1-D array), as the exact Gaussian line integrals
    evaluate it."""
    return _core.gaussian_erfcx(x)


def gaussian_exp(x):
    """Tests: exp(x) for x <= 0 (a 1-D array), as every Gaussian path evaluates its weights (0 below -708)."""
    return _core.gaussian_exp(x)


def ring_kernel(kernel):
    """The core's description of ``kernel`` as the full 3-D kernel (the ring entry points)."""
    return CoreKernel(kernel.kind, float(kernel.width if kernel.width is not None else kernel.radius),
                      float(kernel.radius), int(kernel.truncated), 1.0)


def ring_moments(kernel, r, h, rho, gradient=False, n_moments=3, n_threads=0):
    """The angular moments (n_moments, n), m = 0 .. n_moments - 1 (n_moments 1 to 4), of the 3-D kernel over the ring of
    radius ``r`` seen by sources at axial offsets ``h`` and radii ``rho`` (csrc/cg_ring.c); with ``gradient`` those
    of W'(d)/d (grad W = W'(d)/d (x - q))."""
    return _core.ring_moments(ring_kernel(kernel), r, h, rho, gradient=gradient, n_moments=n_moments,
                              n_threads=n_threads)


def ring_segment_sum(kernel, r, z, segment, lo, hi, panels, geometry, tensors, weight, gradient=False, n_threads=0):
    """``weight`` times the θ-averages at the ring (r, z), in (e_r, e_θ, e_z), of ``tensors`` spread along the pieces
    [lo, hi] of segments (``geometry`` rows: start and vector in the ring's frame, relative to the axis point),
    each on ``panels`` Gauss-Legendre panels: (3, 3). With ``gradient`` the θ-average of the gradient (Gaussian
    and Lucy), (3, 3, 3) with [a, b, c] = ∂T_ab/∂x_c in (e_r, e_θ, e_z)."""
    return _core.ring_segment_sum(ring_kernel(kernel), r, z, segment, lo, hi, panels, geometry, tensors, weight,
                                  gradient=gradient, n_threads=n_threads)


def ring_segment_columns(kernel, rings, first, segment, lo, hi, panels, geometry, tensors, gradient=False, n_threads=0):
    """:func:`ring_segment_sum` for many rings at once: ``rings`` (C, 3) rows (r, z, weight), column c over its
    pieces first[c]:first[c + 1] (csrc/cg_ring.c, the same bits as one ring_segment_sum per column): (C, 9), with
    ``gradient`` (C, 27)."""
    return _core.ring_segment_columns(ring_kernel(kernel), rings, first, segment, lo, hi, panels, geometry, tensors,
                                      gradient=gradient, n_threads=n_threads)


def ring_axial_point_sum(kernel, r, lo, hi, xy, zeta, tensors, weights, n_threads=0):
    """Σ_j weights_j (θ-average of tensors_j W over the ring of radius ``r``, averaged exactly over z in [lo, hi])
    for point sources at in-plane ``xy`` (J, 2) and axial ``zeta`` (J,), ``tensors`` (J, 9), all in the ring frame
    (csrc/cg_ring.c): (3, 3) in the local basis."""
    return _core.ring_axial_point_sum(ring_kernel(kernel), r, lo, hi, xy, zeta, tensors, weights, n_threads=n_threads)


def quartic_roots(coef, n_threads=0):
    """The complex roots (n, 4), in no particular order, of the quartics ``coef`` (n, 5), highest power first, a
    nonzero leading coefficient (csrc/cg_quartic.c: Aberth-Ehrlich iteration)."""
    return _core.quartic_roots(coef, n_threads=n_threads)


def axial_segment_sum(kernel, bottoms, column, first, segment, lo, hi, panels, starts, vectors, values, n_threads=0):
    """Per column c (``bottoms`` (C, 3), pieces first[c]:first[c + 1]), the tensors ``values`` (K, 9) of segments
    starts + s vectors times int_lo^hi of the kernel's exact line integral along ``column`` from the column's
    bottom, seen from the segment's point s, summed over the pieces (csrc/cg_axial.c): (C, 9)."""
    return _core.axial_segment_sum(ring_kernel(kernel), bottoms, column, first, segment, lo, hi, panels, starts,
                                   vectors, values, n_threads=n_threads)
