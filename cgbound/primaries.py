"""The catalogue of primary sums, and how one snapshot is reduced to them.

A *primary* is one kernel sum over a snapshot (one pass of the C core); every field of
:data:`cgbound.fields.FIELDS` is derived from primaries after any averaging over snapshots.
Each primary is described once, in :data:`PRIMARIES`: its rank per node, the objects it sums
over (its *source*), its symbol and equation in Weinhart et al. (2012), and its slow NumPy twin
in ``tests/oracle.py``. Each source has one small compute function below.

Momentum is summed relative to a reference velocity ``u_ref`` so that a large uniform flow
does not cost digits in the kinetic stress.
"""
from typing import NamedTuple, Optional

import numpy as np

from ._engine import (KINETIC_FLUX, KINETIC_MASS, KINETIC_MOMENTUM, core_kernel, core_target, scatter_fluctuation,
                      scatter_points, scatter_points_kinetic, scatter_segment_moments,
                      scatter_segments, scatter_segments_outer, symmetric_index)
from ._threads import get_num_threads

#: what a primary sums over
PARTICLES = "particles"                            # flowing particles' centres
PARTICLE_FLUCTUATIONS = "particle fluctuations"    # flowing particles, about the node's velocity
BULK_SEGMENTS = "bulk segments"                    # branch lines of contacts between flowing particles
BOUNDARY_SEGMENTS = "boundary segments"            # lines from a flowing particle to its boundary contact
BOUNDARY_RAYS = "boundary rays"                    # rays from a flowing particle through its boundary contact
BOUNDARY_POINTS = "boundary points"                # boundary contact points
BULK_POINTS = "bulk contact points"                # contact points of contacts between flowing particles
PARTICLE_GRADIENTS = "particle gradients"          # flowing particles' centres, the kernel's gradient
SPINNING_PARTICLES = "spinning particles"        # flowing particles' centres, weighted by I_i w_i
CONTACT_HALVES = "contact halves"                # lines from each flowing particle to each of its contact points
CONTACT_LINES = "contact lines"                  # branch lines (bulk) and lines to boundary contact points, with
#                                                  the kernel's first moment along them
SOURCES = (PARTICLES, PARTICLE_FLUCTUATIONS, BULK_SEGMENTS, BOUNDARY_SEGMENTS, BOUNDARY_RAYS, BOUNDARY_POINTS,
           BULK_POINTS, PARTICLE_GRADIENTS, SPINNING_PARTICLES, CONTACT_HALVES, CONTACT_LINES)
#: sources that need the snapshot's contacts split into bulk and boundary
CONTACT_SOURCES = (BULK_SEGMENTS, BOUNDARY_SEGMENTS, BOUNDARY_RAYS, BOUNDARY_POINTS, BULK_POINTS, CONTACT_HALVES,
                   CONTACT_LINES)


class Primary(NamedTuple):
    name: str              # the key in the primaries dict and in FIELDS
    description: str
    rank: int              # 0: scalar, 1: vector, 2: tensor per node
    source: str            # one of SOURCES
    symbol: str            # as in the paper
    equation: Optional[str]  # the paper's equation number (None: not in the paper)
    twin: str              # its slow NumPy twin in tests/oracle.py


PRIMARIES = {p.name: p for p in (
    Primary("rho", "density: sum_i m_i W_i", 0, PARTICLES, "ρ", "3", "oracle_scatter_points"),
    Primary("p_w", "momentum relative to u_ref: sum_i m_i (v_i - u_ref) W_i", 1, PARTICLES, "p", "4",
            "oracle_scatter_points"),
    Primary("k", "momentum flux: sum_i m_i v_i v_i W_i", 2, PARTICLES, "k", "14", "oracle_scatter_points"),
    Primary("sk", "kinetic stress: -sum_i m_i v'_i v'_i W_i", 2, PARTICLE_FLUCTUATIONS, "σᵏ", "17a",
            "oracle_scatter_fluctuation"),
    Primary("sb", "contact stress: -sum_ij f_ij r_ij int_0^1 W(r - r_i + s r_ij) ds", 2, BULK_SEGMENTS, "σᵇ",
            "17b", "oracle_scatter_segments"),
    Primary("sw", "boundary stress: -sum_ik f_ik a_ik int_0^1 W(r - r_i + s a_ik) ds", 2, BOUNDARY_SEGMENTS,
            "σʷ", "20b", "oracle_scatter_segments"),
    Primary("t", "interaction force density: sum_ik f_ik W(r - c_ik)", 1, BOUNDARY_POINTS, "t", "21",
            "oracle_scatter_points"),
    Primary("b", "body force density: sum_i m_i b_i W_i", 1, PARTICLES, "b", "8", "oracle_scatter_points"),
    Primary("phi", "volume fraction: sum_i V_i W_i (V_i the particle's volume)", 0, PARTICLES, "φ", None,
            "oracle_scatter_points"),
    Primary("sx", "ray term of the extended stress: -sum_ik f_ik a_ik int_0^inf W(r - r_i + s a_ik) ds", 2,
            BOUNDARY_RAYS, "σ′ ray term", "24", "oracle_scatter_segments"),
    # structure (docs/theory.md, "Structure"): not in the paper
    Primary("nd", "number density: sum_i W_i", 0, PARTICLES, "n", None, "oracle_scatter_points"),
    *(Primary(f"r{k}", f"radius moment {k}: sum_i r_i^{k} W_i", 0, PARTICLES, f"M{k}", None, "oracle_scatter_points")
      for k in range(1, 6)),
    Primary("fb", "bulk fabric: sum_ij n_ij n_ij W(r - c_ij), n_ij = r_ij / |r_ij|", 2, BULK_POINTS, "Fᵇ", None,
            "oracle_scatter_points"),
    Primary("fw", "boundary fabric: sum_ik n_ik n_ik W(r - c_ik), n_ik = a_ik / |a_ik|", 2, BOUNDARY_POINTS, "Fʷ",
            None, "oracle_scatter_points"),
    Primary("phi_d", "volume-weighted diameter sum: sum_i V_i d_i W_i (d_i = 2 a_i)", 0, PARTICLES, "φ d̄", None,
            "oracle_scatter_points"),
    Primary("grad_rho", "density gradient: sum_i m_i grad W_i ([b] = d/dr_b)", 1, PARTICLE_GRADIENTS, "∇ρ", None,
            "oracle_scatter_points"),
    Primary("grad_p_w", "momentum gradient relative to u_ref: sum_i m_i (v_i - u_ref) grad W_i ([a, b] = d p_a/dr_b)",
            2, PARTICLE_GRADIENTS, "∇p", None, "oracle_scatter_points"),
    # rotation (docs/theory.md, "Rotation and couple stress"): not in the paper. The rank counts the
    # pseudo-vector index (3 components in 3D, 1 in 2D: see rotation_shape)
    Primary("spin", "spin density: sum_i I_i w_i W_i", 1, SPINNING_PARTICLES, "s", None, "oracle_rotation"),
    Primary("spin_flux", "spin flux: sum_i I_i w_i v_i W_i", 2, SPINNING_PARTICLES, "J", None, "oracle_rotation"),
    Primary("spin_flux_w", "spin flux relative to u_ref: sum_i I_i w_i (v_i - u_ref) W_i", 2, SPINNING_PARTICLES,
            "J_w", None, "oracle_rotation"),
    Primary("couple", "couple stress, contact-point form: -sum over contact halves tau (x) a int_0^1 W(r - r_i + s a) "
            "ds", 2, CONTACT_HALVES, "m", None, "oracle_rotation"),
    Primary("pair_torque", "stress torque density, contact-point form: sum_ij (f_ij x r_ij) W(r - c_ij)", 1,
            BULK_POINTS, "T", None, "oracle_rotation"),
    Primary("wall_couple", "boundary couple density, contact-point form: sum_ik (f_ik x a_ik) W(r - c_ik)", 1,
            BOUNDARY_POINTS, "t_c", None, "oracle_rotation"),
    Primary("couple_bl", "couple stress, branch-line form: -sum_c [f_c x int_0^1 (x_c(s) - c_c) W(r - x_c(s)) ds] "
            "(x) b_c, x_c(s) = r_i - s b_c", 2, CONTACT_LINES, "m", None, "oracle_rotation"),
    Primary("pair_torque_bl", "stress torque density, branch-line form (eps : sigma of the contact stress): "
            "sum_ij (f_ij x r_ij) int_0^1 W(r - r_i + s r_ij) ds", 1, BULK_SEGMENTS, "T", None, "oracle_rotation"),
    Primary("wall_couple_bl", "boundary torque density, branch-line form (eps : sigma of the boundary stress): "
            "sum_ik (f_ik x a_ik) int_0^1 W(r - r_i + s a_ik) ds", 1, BOUNDARY_SEGMENTS, "t_c", None,
            "oracle_rotation"),
)}

#: the primaries of radius powers: name -> power (the number density "nd" is power 0)
RADIUS_MOMENTS = {"nd": 0, **{f"r{k}": k for k in range(1, 6)}}

#: primaries that are kernel gradients (need a differentiable kernel)
GRADIENT_PRIMARIES = frozenset(p.name for p in PRIMARIES.values() if p.source == PARTICLE_GRADIENTS)

#: primaries that need the contacts split into bulk and boundary
CONTACT_PRIMARIES = frozenset(p.name for p in PRIMARIES.values() if p.source in CONTACT_SOURCES)


#: primaries with a pseudo-vector (first) index: 3 components in 3D, 1 in 2D
PSEUDO_PRIMARIES = frozenset(p.name for p in PRIMARIES.values() if p.source in (SPINNING_PARTICLES, CONTACT_HALVES,
                                                                                CONTACT_LINES)
                             or p.name in ("pair_torque", "wall_couple", "pair_torque_bl", "wall_couple_bl"))


def rank(name):
    """Rank per node of primary ``name``."""
    return PRIMARIES[name].rank


def flowing_rows(snapshot, array):
    """The rows of ``array`` (N rows, one per particle) of the flowing particles, in order.

    With no fixed particle this is ``array`` itself, not a copy: the callers only read it.
    """
    if not snapshot.fixed.any():
        return array
    return array[snapshot.flowing]


def reference_velocity(snapshot):
    """Mass-weighted mean velocity of the flowing particles (any constant would do)."""
    if snapshot.velocities is None or snapshot.fixed.all():
        return np.zeros(snapshot.dim)
    m = flowing_rows(snapshot, snapshot.masses)
    # (einsum: no (N, D) temporary, and no strided reduction over it: a third of the time)
    return np.einsum("n,nj->j", m, flowing_rows(snapshot, snapshot.velocities)) / m.sum()


def outer_into(a, b, out):
    """out[:, Db*r + c] = a[:, r] * b[:, c] (one product each, no temporary); ``out`` may be a column slice
    of a wider block. einsum without a summed index is 2-3x faster than per-column multiplies or
    broadcasting over the short last axes, with the same single rounding."""
    view = out.view()
    view.shape = (out.shape[0], a.shape[1], b.shape[1])    # raises rather than copy
    np.einsum("ni,nj->nij", a, b, out=view)
    return out


def outer(a, b):
    """a outer b per row, flat (n, Da*Db)."""
    return outer_into(a, b, np.empty((a.shape[0], a.shape[1] * b.shape[1])))


def negated_outer(force, branch):
    """-(force outer branch), flat (n, D*D): (-f) b is -(f b) exactly (rounding is symmetric in sign)."""
    n, dim = force.shape
    return outer_into(np.negative(force), branch, np.empty((n, dim * dim)))


def check_computable(snapshot, needed, split=None):
    """Raise, before any kernel work, if the snapshot lacks what the needed primaries require.

    Returns the split contacts (or None if no contact primary is needed) so that they are not split twice.
    """
    if "phi_d" in needed and snapshot.radii is None:
        raise ValueError("snapshot.radii: expected radii for the field 'inertial_number' (the local mean diameter), "
                         "got None")
    if "phi" in needed and snapshot.radii is None:
        raise ValueError("snapshot.radii: expected radii for the field 'volume_fraction', got None")
    if needed & set(RADIUS_MOMENTS) - {"nd"} and snapshot.radii is None:
        raise ValueError("snapshot.radii: expected radii for the size moments (size_moment_k, mean_radius, "
                         "radius_spread, radius_skewness), got None")
    if not needed & CONTACT_PRIMARIES:
        return None
    if split is None:
        split = snapshot.split_contacts()
    boundary = split[1]
    for name, part in (("fb", split[0]), ("fw", boundary)):
        if name in needed and part["i"].size and np.any(np.all(part["branch"] == 0.0, axis=1)):
            k = int(np.flatnonzero(np.all(part["branch"] == 0.0, axis=1))[0])
            what = ("bulk contacts between particles at distinct centres" if name == "fb" else
                    "boundary contact points away from the particle centre")
            raise ValueError(f"contacts: expected {what} for 'fabric' and 'coordination_number' (the contact normal "
                             f"is the unit branch vector), got a zero branch at particle {int(part['i'][k])}")
    if "sx" in needed and boundary["i"].size:
        at_centre = np.all(boundary["branch"] == 0.0, axis=1)
        if np.any(at_centre):
            k = int(boundary["i"][np.flatnonzero(at_centre)[0]])
            raise ValueError("contacts.point: expected boundary contact points away from the particle centre for "
                             "'extended_stress' (the direction of the ray, eq. 24, is undefined), got one at the "
                             f"centre of particle {k}")
    return split


def longest_branch(bulk, boundary):
    """The longest contact branch vector (bulk and boundary), 0 without contacts."""
    return max((float(np.sqrt(np.einsum("ij,ij->i", part["branch"], part["branch"]).max()))
                for part in (bulk, boundary) if part["branch"].shape[0]), default=0.0)


def _particle_layout(snapshot, needed):
    """The columns of the values summed over the flowing particles' positions: [(primary, first column, number
    of columns, shape per node)], side by side in PRIMARIES' order. Primaries whose data the snapshot lacks
    (velocities, body force) are left out."""
    dim = snapshot.dim
    present = {"p_w": snapshot.velocities, "k": snapshot.velocities, "b": snapshot.body_force}
    wanted = [name for name, p in PRIMARIES.items()
              if p.source == PARTICLES and name in needed and present.get(name, True) is not None]
    layout, width = [], 0
    for name in wanted:
        shape = (dim,) * PRIMARIES[name].rank
        size = dim ** PRIMARIES[name].rank
        layout.append((name, width, size, shape))
        width += size
    return layout


def _particle_columns(snapshot, needed, u_ref, layout=None):
    """The values summed over the flowing particles' positions, side by side in one (n, K) block.

    Returns the block and its layout (_particle_layout, or ``layout`` if given). Each column is formed in place
    with the same floating-point operations as on its own.
    """
    dim = snapshot.dim
    if layout is None:
        layout = _particle_layout(snapshot, needed)
    if not layout:
        return None, layout
    width = layout[-1][1] + layout[-1][2]
    m = flowing_rows(snapshot, snapshot.masses)
    block = np.empty((m.shape[0], width))
    # column by column: NumPy's loops over a short last axis cost more than the arithmetic
    for name, start, size, shape in layout:
        cols = block[:, start:start + size]
        if name == "rho":
            cols[:, 0] = m
        elif name == "p_w":
            v = flowing_rows(snapshot, snapshot.velocities)
            for r in range(dim):
                np.subtract(v[:, r], u_ref[r], out=cols[:, r])
                np.multiply(m, cols[:, r], out=cols[:, r])
        elif name == "k":
            v = flowing_rows(snapshot, snapshot.velocities)
            outer_into(v, v, cols)
            for r in range(size):
                np.multiply(m, cols[:, r], out=cols[:, r])
        elif name == "b":
            g = flowing_rows(snapshot, snapshot.body_force)
            for r in range(dim):
                np.multiply(m, g[:, r], out=cols[:, r])
        elif name == "phi":
            r = flowing_rows(snapshot, snapshot.radii)
            cols[:, 0] = np.pi * r**2 if dim == 2 else 4.0 / 3.0 * np.pi * r**3
        elif name in RADIUS_MOMENTS:
            cols[:, 0] = 1.0 if name == "nd" else flowing_rows(snapshot, snapshot.radii) ** RADIUS_MOMENTS[name]
        elif name == "phi_d":
            r = flowing_rows(snapshot, snapshot.radii)
            cols[:, 0] = (np.pi * r**2 if dim == 2 else 4.0 / 3.0 * np.pi * r**3) * (2.0 * r)
    return block, layout


def _zeros(name, P, dim):
    return np.zeros((P,) + (dim,) * PRIMARIES[name].rank)


#: the primaries whose columns the core can form itself from masses and velocities (scatter_points_kinetic: the
#: same values, in _particle_layout's order)
KINETIC_PARTS = {"rho": KINETIC_MASS, "p_w": KINETIC_MOMENTUM, "k": KINETIC_FLUX}


def _kinetic_parts(snapshot, layout):
    """The KINETIC_* mask of the layout's primaries if the core can form all of them (with velocities), else 0."""
    names = [name for name, *_ in layout]
    if not names or snapshot.velocities is None or not set(names) <= set(KINETIC_PARTS):
        return 0
    return sum(KINETIC_PARTS[name] for name in names)


def particle_sums(snapshot, needed, u_ref, target, kernel, P, nt):
    """Source PARTICLES: one scatter with all the needed columns (the stencil and weights are
    computed once; each column is summed exactly as on its own). Primaries whose data the
    snapshot lacks are zero. Mass, momentum and momentum flux alone are formed in the core particle by particle
    (the same values as _particle_columns', without its (n, K) block; the flux's upper triangle only, mirrored
    here: m v_r v_c = m v_c v_r exactly)."""
    out = {}
    layout = _particle_layout(snapshot, needed)
    parts = _kinetic_parts(snapshot, layout)
    pos = flowing_rows(snapshot, snapshot.positions)
    if parts:
        summed = scatter_points_kinetic(target, kernel, pos, flowing_rows(snapshot, snapshot.masses),
                                        flowing_rows(snapshot, snapshot.velocities), np.asarray(u_ref, float), parts,
                                        n_threads=nt)
        start, dim = 0, snapshot.dim
        for name, _, size, shape in layout:     # the flux as its upper triangle: mirrored (a C-contiguous copy)
            if name == "k":
                out[name] = np.take(summed, [start + c for c in symmetric_index(dim)], axis=1).reshape((P,) + shape)
                size = dim * (dim + 1) // 2
            else:
                out[name] = summed[:, start:start + size].reshape((P,) + shape)
            start += size
    elif layout:
        block, _ = _particle_columns(snapshot, needed, u_ref, layout)
        summed = scatter_points(target, kernel, pos, block, n_threads=nt)
        del block
        for name, start, size, shape in layout:
            out[name] = summed[:, start:start + size].reshape((P,) + shape)
    for name in ("p_w", "k", "b"):
        if name in needed and name not in out:
            out[name] = _zeros(name, P, snapshot.dim)
    return out


def gradient_sums(snapshot, needed, u_ref, target, kernel, P, nt, resolved):
    """Source PARTICLE_GRADIENTS: one gradient scatter of [m, m (v - u_ref)] (the columns the needed
    gradients use). The core gives the D_res resolved derivatives; the derivatives along averaged axes
    are zero (the marginal does not depend on them) and are stored as zeros, so every gradient has D
    components: grad_rho (P, D), grad_p_w (P, D, D) with [a, b] = d p_a / d r_b."""
    dim = snapshot.dim
    names = [name for name in ("grad_rho", "grad_p_w") if name in needed]
    pos = flowing_rows(snapshot, snapshot.positions)
    out = {name: _zeros(name, P, dim) for name in names}
    has_v = snapshot.velocities is not None
    width = (1 if "grad_rho" in names else 0) + (dim if "grad_p_w" in names and has_v else 0)
    if not width or not pos.shape[0] or not resolved:
        return out
    m = flowing_rows(snapshot, snapshot.masses)
    block = np.empty((m.shape[0], width))
    col = 0
    if "grad_rho" in names:
        block[:, 0] = m
        col = 1
    if "grad_p_w" in names and has_v:
        v = flowing_rows(snapshot, snapshot.velocities)
        for r in range(dim):
            np.subtract(v[:, r], u_ref[r], out=block[:, col + r])
            np.multiply(m, block[:, col + r], out=block[:, col + r])
    summed = scatter_points(target, kernel, pos, block, gradient=True, n_threads=nt)   # (P, width, D_res)
    del block
    axes = list(resolved)
    col = 0
    if "grad_rho" in names:
        out["grad_rho"][:, axes] = summed[:, 0, :]
        col = 1
    if "grad_p_w" in names and has_v:
        out["grad_p_w"][:, :, axes] = summed[:, col:col + dim, :]
    return out


def fluctuation_sum(snapshot, rho, p_w, u_ref, target, kernel, P, nt):
    """Source PARTICLE_FLUCTUATIONS: the kinetic stress about each node's own velocity p_w / rho."""
    pos = flowing_rows(snapshot, snapshot.positions)
    if snapshot.velocities is None or not pos.shape[0]:
        return _zeros("sk", P, snapshot.dim)
    m = flowing_rows(snapshot, snapshot.masses)
    v_w = flowing_rows(snapshot, snapshot.velocities) - u_ref
    node_v = np.zeros((P, snapshot.dim))
    np.divide(p_w, rho[:, None], out=node_v, where=rho[:, None] > 0)
    return scatter_fluctuation(target, kernel, pos, m, v_w, node_v, n_threads=nt)


def segment_sum(snapshot, part, target, kernel, P, nt, ray=False):
    """Sources BULK_SEGMENTS, BOUNDARY_SEGMENTS (``part`` of split_contacts) and BOUNDARY_RAYS
    (``ray``): -f a from each contact's flowing particle along -a (to its partner or contact point)."""
    dim = snapshot.dim
    if not part["i"].size:
        return np.zeros((P, dim, dim))
    # the values -f a = f (x) (-a) ((-f) a is -(f a) exactly) along -a, formed by the core segment by segment:
    # segment_sources' segments and values without its (n, D*D) array, nor an (n, D) one of -a (negate)
    return scatter_segments_outer(target, kernel, segment_starts(snapshot, part), part["branch"], part["force"],
                                  ray=ray, n_threads=nt, negate=True).reshape(P, dim, dim)


def segment_starts(snapshot, part):
    """The starts of the segments of ``part`` (of split_contacts): the flowing particles' centres (its start,
    gathered there; parts built otherwise, with i only, are gathered here)."""
    start = part.get("start")
    return np.take(snapshot.positions, part["i"], axis=0) if start is None else start


def segment_geometry(snapshot, part):
    """The segments of ``part`` (of split_contacts): starts (:func:`segment_starts`) and vectors (-a, to the
    partner or contact point)."""
    return segment_starts(snapshot, part), np.negative(part["branch"])


def segment_sources(snapshot, part):
    """The segments of ``part`` (of split_contacts), :func:`segment_geometry`, with their values -f a, flat
    (n, D*D)."""
    return (*segment_geometry(snapshot, part), negated_outer(part["force"], part["branch"]))


def boundary_point_sum(snapshot, boundary, target, kernel, P, nt):
    """Source BOUNDARY_POINTS: the boundary contacts' forces at their contact points."""
    if not boundary["i"].size:
        return _zeros("t", P, snapshot.dim)
    return scatter_points(target, kernel, boundary["point"], boundary["force"], n_threads=nt)


def fabric_sum(snapshot, part, target, kernel, P, nt):
    """Sources BULK_POINTS (``part`` the bulk contacts) and BOUNDARY_POINTS (the boundary contacts, for "fw"):
    n n at each contact point, n the unit branch vector (its sign does not matter)."""
    dim = snapshot.dim
    if not part["i"].size:
        return np.zeros((P, dim, dim))
    n = part["branch"] / np.sqrt(np.einsum("ij,ij->i", part["branch"], part["branch"]))[:, None]
    return scatter_points(target, kernel, part["point"], outer(n, n), n_threads=nt).reshape(P, dim, dim)


def compute_primaries(snapshot, target, kernel, needed, u_ref, split=None):
    """Primary sums of one snapshot at the target's nodes, flat over nodes: shape (P, ...).

    ``split``: the result of ``check_computable`` if already called (checks are repeated otherwise).
    The primaries summed over particle positions may be views of one (P, K) block of sums.
    """
    split = check_computable(snapshot, needed, split)
    P = target.size
    where = core_target(target, snapshot.box)
    point_kernel = core_kernel(kernel, target.avg_extent)
    nt = get_num_threads()
    out = particle_sums(snapshot, needed, u_ref, where, point_kernel, P, nt)
    if needed & GRADIENT_PRIMARIES:
        out.update(gradient_sums(snapshot, needed, u_ref, where, point_kernel, P, nt, target.resolved))
    if "sk" in needed:
        out["sk"] = fluctuation_sum(snapshot, out.get("rho"), out.get("p_w"), u_ref, where, point_kernel, P, nt)
    if needed & CONTACT_PRIMARIES:
        bulk, boundary = split
        longest = longest_branch(bulk, boundary) if kernel.resolves_from_branch else None
        line_kernel = core_kernel(kernel, target.avg_extent, longest)
        if "sb" in needed:
            out["sb"] = segment_sum(snapshot, bulk, where, line_kernel, P, nt)
        if "sw" in needed:
            out["sw"] = segment_sum(snapshot, boundary, where, line_kernel, P, nt)
        if "sx" in needed:
            out["sx"] = segment_sum(snapshot, boundary, where, line_kernel, P, nt, ray=True)
        if "t" in needed:
            out["t"] = boundary_point_sum(snapshot, boundary, where, line_kernel, P, nt)
        if "fb" in needed:
            out["fb"] = fabric_sum(snapshot, bulk, where, line_kernel, P, nt)
        if "fw" in needed:
            out["fw"] = fabric_sum(snapshot, boundary, where, line_kernel, P, nt)
        if needed & ROTATION_CONTACT_PRIMARIES:
            out.update(contact_torque_sums(snapshot, split, needed, where, line_kernel, P, nt))
    if needed & SPIN_PRIMARIES:
        out.update(spin_sums(snapshot, needed, u_ref, where, point_kernel, P, nt))
    return out


# --- rotation (docs/theory.md, "Rotation and couple stress") ---

#: primaries summed over the spinning particles, and over the contacts
SPIN_PRIMARIES = frozenset(p.name for p in PRIMARIES.values() if p.source == SPINNING_PARTICLES)
ROTATION_CONTACT_PRIMARIES = PSEUDO_PRIMARIES - SPIN_PRIMARIES


def cross(a, b):
    """a x b per row: (n, 3) for 3D rows, (n,) (the out-of-plane component a_0 b_1 - a_1 b_0) for 2D rows."""
    if a.shape[1] == 3:
        return np.cross(a, b)
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def pseudo_columns(values):
    """Pseudo-vectors as (n, T) columns: T = 3 in 3D, 1 in 2D (stored as (n,))."""
    return values[:, None] if values.ndim == 1 else values


def pseudo_shape(dim):
    """The shape of one pseudo-vector: (3,) in 3D, () in 2D."""
    return (3,) if dim == 3 else ()


def contact_halves(snapshot, split=None):
    """Every contact as seen by each flowing particle it touches.

    Returns a dict: ``i`` (the flowing particle), ``force`` (on it), ``branch`` a = r_i - c (minimum image; c the
    contact point), ``torque`` (c - r_i) x f = f x a; then ``pair_point`` (one contact point per bulk contact,
    r_i - a_i) and ``pair_moment`` f_ij x r_ij (r_ij = r_i - r_j, minimum image) per bulk contact; ``wall_point``
    and ``wall_torque`` per boundary contact; ``bulk_lever`` a_i per bulk contact. A bulk contact gives two halves: (i, f, a_i) and (j, -f, a_j) with
    a_j = a_i - r_ij, so that both halves meet at one contact point whatever the periodic images.
    """
    bulk, boundary = snapshot.split_contacts() if split is None else split
    dim = snapshot.dim
    if bulk["i"].size:
        a_i = snapshot.box.minimum_image(np.take(snapshot.positions, bulk["i"], axis=0) - bulk["point"])
    else:
        a_i = np.zeros((0, dim))
    a_j = a_i - bulk["branch"]
    force = np.concatenate([bulk["force"], np.negative(bulk["force"]), boundary["force"]])
    branch = np.concatenate([a_i, a_j, boundary["branch"]])
    return {"i": np.concatenate([bulk["i"], bulk["j"], boundary["i"]]).astype(np.int64),
            "force": force, "branch": branch, "torque": cross(force, branch), "bulk_lever": a_i,
            "pair_point": np.take(snapshot.positions, bulk["i"], axis=0) - a_i,
            "pair_moment": cross(bulk["force"], bulk["branch"]),
            "wall_point": boundary["point"], "wall_torque": cross(boundary["force"], boundary["branch"])}


def largest_couple(halves):
    """The largest torque x length the couple stresses sum (force x length^2, which may overflow where
    force x branch does not; the lengths are the halves' and the bulk branches, at most twice as long);
    0 without contacts."""
    if not halves["i"].size:
        return 0.0
    with np.errstate(over="ignore"):
        arm = np.abs(halves["branch"]).max(axis=1)
        force = np.abs(halves["force"]).max(axis=1)
        return float((force * arm * arm).max() * 4 * halves["force"].shape[1])


def couple_stress_sum(snapshot, halves, core, line_kernel, P, nt, gradient=False):
    """Source CONTACT_HALVES: m = -sum_halves tau (x) a int_0^1 W(r - r_i + s a) ds, from r_i to its contact point:
    (P, T, D) flat over the torque components (T = 3 in 3D, 1 in 2D); with ``gradient``, (P, T, D, D_res)."""
    dim = snapshot.dim
    T = 3 if dim == 3 else 1
    extra = (len(core.axes),) if gradient else ()
    if not halves["i"].size:
        return np.zeros((P, T, dim) + extra)
    starts = np.take(snapshot.positions, halves["i"], axis=0)
    values = outer(np.negative(pseudo_columns(halves["torque"])), halves["branch"])
    summed = scatter_segments(core, line_kernel, starts, np.negative(halves["branch"]), values, gradient=gradient,
                              n_threads=nt)
    return summed.reshape((P, T, dim) + extra)


def contact_lines(snapshot, split, halves):
    """The lines of the branch-line form: each bulk contact once, from r_i along -r_ij to r_j, then each boundary
    contact from r_i along -a to its contact point. Returns (starts, b, force, lever a = r_i - c)."""
    bulk, boundary = split
    starts = np.take(snapshot.positions, np.concatenate([bulk["i"], boundary["i"]]).astype(np.int64), axis=0)
    b = np.concatenate([bulk["branch"], boundary["branch"]])
    force = np.concatenate([bulk["force"], boundary["force"]])
    lever = np.concatenate([halves["bulk_lever"], boundary["branch"]])
    return starts, b, force, lever


def branch_line_couple_sum(snapshot, split, halves, core, line_kernel, P, nt, gradient=False):
    """Source CONTACT_LINES: m = -sum_c [f x int_0^1 (x(s) - c) W(r - x(s)) ds] (x) b, x(s) = r_i - s b, which
    is -sum_c (f x a) (x) b psi_c + sum_c (f x b) (x) b chi_c with psi the kernel's line integral and chi its
    first moment int_0^1 s W(r - r_i + s b) ds: (P, T, D) (with ``gradient`` (P, T, D, D_res))."""
    dim = snapshot.dim
    T = 3 if dim == 3 else 1
    extra = (len(core.axes),) if gradient else ()
    starts, b, force, lever = contact_lines(snapshot, split, halves)
    if not starts.shape[0]:
        return np.zeros((P, T, dim) + extra)
    vec = np.negative(b)
    line = scatter_segments(core, line_kernel, starts, vec, outer(np.negative(pseudo_columns(cross(force, lever))), b),
                            gradient=gradient, n_threads=nt)
    moment = scatter_segment_moments(core, line_kernel, starts, vec, outer(pseudo_columns(cross(force, b)), b),
                                     gradient=gradient, n_threads=nt)
    return (line + moment).reshape((P, T, dim) + extra)


def contact_torque_sums(snapshot, split, needed, core, line_kernel, P, nt):
    """The contact primaries of the couple stress and the torque densities (either form)."""
    dim = snapshot.dim
    T = 3 if dim == 3 else 1
    halves = contact_halves(snapshot, split)
    bulk, boundary = split
    out = {}
    if "couple" in needed:
        out["couple"] = couple_stress_sum(snapshot, halves, core, line_kernel, P, nt)
    if "couple_bl" in needed:
        out["couple_bl"] = branch_line_couple_sum(snapshot, split, halves, core, line_kernel, P, nt)
    for name, points, values in (("pair_torque", "pair_point", "pair_moment"),
                                 ("wall_couple", "wall_point", "wall_torque")):
        if name in needed:
            out[name] = (scatter_points(core, line_kernel, halves[points], pseudo_columns(halves[values]),
                                        n_threads=nt) if halves[points].shape[0] else np.zeros((P, T)))
    for name, part in (("pair_torque_bl", bulk), ("wall_couple_bl", boundary)):
        if name in needed:
            # eps : sigma of the contact (boundary) stress: (f x b) along the same lines as sigma
            out[name] = (scatter_segments(core, line_kernel, np.take(snapshot.positions, part["i"], axis=0),
                                          np.negative(part["branch"]),
                                          pseudo_columns(cross(part["force"], part["branch"])), n_threads=nt)
                         if part["i"].size else np.zeros((P, T)))
    return out


def spin_sums(snapshot, needed, u_ref, core, point_kernel, P, nt):
    """Source SPINNING_PARTICLES: one scatter of the needed columns of [I w, I w (x) v, I w (x) (v - u_ref)]."""
    dim = snapshot.dim
    inertia = flowing_rows(snapshot, snapshot.inertia("the rotational fields"))
    s_i = pseudo_columns(flowing_rows(snapshot, snapshot.angular_velocities)) * inertia[:, None]
    T = s_i.shape[1]
    columns, layout = [], []
    if "spin" in needed:
        columns.append(s_i)
        layout.append(("spin", (T,)))
    if "spin_flux" in needed:
        columns.append(outer(s_i, flowing_rows(snapshot, snapshot.velocities)))
        layout.append(("spin_flux", (T, dim)))
    if "spin_flux_w" in needed:
        columns.append(outer(s_i, flowing_rows(snapshot, snapshot.velocities) - u_ref))
        layout.append(("spin_flux_w", (T, dim)))
    pos = flowing_rows(snapshot, snapshot.positions)
    width = sum(int(np.prod(shape)) for _, shape in layout)
    summed = (scatter_points(core, point_kernel, pos, np.concatenate(columns, axis=1), n_threads=nt)
              if pos.shape[0] else np.zeros((P, width)))
    out, start = {}, 0
    for name, shape in layout:
        size = int(np.prod(shape))
        out[name] = summed[:, start:start + size].reshape((P,) + shape)
        start += size
    return out


#: fields that need angular velocities (and moments of inertia)
SPIN_FIELDS = ("spin_density", "angular_momentum_density", "spin_flux", "kinetic_spin_flux")
#: fields that also need the particles' velocities
MOVING_FIELDS = ("spin_flux", "kinetic_spin_flux")
#: fields summed over the contacts (they need their torque x length to stay in range)
CONTACT_ROTATION_FIELDS = ("couple_stress", "stress_torque_density", "boundary_couple_density")


def check_spin(snapshot, fields):
    """Raise before any work if a requested field needs angular velocities, velocities or moments of inertia that
    are missing; returns the moments of inertia (None if no field needs them)."""
    wanted = [f for f in fields if f in SPIN_FIELDS]
    if not wanted:
        return None
    if snapshot.angular_velocities is None:
        raise ValueError(f"snapshot.angular_velocities: expected angular velocities for the field {wanted[0]!r}, "
                         f"got None")
    moving = [f for f in wanted if f in MOVING_FIELDS]
    if moving and snapshot.velocities is None:
        raise ValueError(f"snapshot.velocities: expected velocities for the field {moving[0]!r}, got None")
    return snapshot.inertia(f"the field {wanted[0]!r}")


def rotation_largest(snapshot, fields):
    """The largest value the rotational fields sum times a kernel value (I w v, torque x length), 0 without any,
    for the overflow check; raises (check_spin) if their data are missing."""
    inertia = check_spin(snapshot, fields)
    largest = 0.0
    if inertia is not None:
        flow_i = flowing_rows(snapshot, inertia)
        spin = np.abs(pseudo_columns(flowing_rows(snapshot, snapshot.angular_velocities))).max(axis=1, initial=0.0)
        speed = 1.0
        if snapshot.velocities is not None and any(f in MOVING_FIELDS for f in fields):
            speed = max(1.0, float(np.abs(flowing_rows(snapshot, snapshot.velocities)).max(initial=0.0)))
        with np.errstate(over="ignore"):
            largest = float((flow_i * spin).max(initial=0.0)) * speed
    if any(f in CONTACT_ROTATION_FIELDS for f in fields):
        largest = max(largest, largest_couple(contact_halves(snapshot)))
    return largest


def point_sources(snapshot, needed, u_ref, split=None):
    """The needed primaries that are sums over points (sources PARTICLES, BOUNDARY_POINTS, BULK_POINTS), as
    [(positions (S, D), [(name, values (S,) + (D,) * rank)])], for targets that integrate the kernel
    themselves (the ring averages of a CylindricalGrid). Primaries whose data the snapshot lacks are absent
    (they are zero). ``split``: the result of ``check_computable``."""
    dim = snapshot.dim
    groups = []
    block, layout = _particle_columns(snapshot, needed, u_ref)
    if layout:
        groups.append((flowing_rows(snapshot, snapshot.positions),
                       [(name, block[:, start:start + size].reshape((-1,) + shape))
                        for name, start, size, shape in layout]))
    if split is not None:
        bulk, boundary = split
        rows = []
        if "t" in needed and boundary["i"].size:
            rows.append(("t", boundary["force"]))
        if "fw" in needed and boundary["i"].size:
            n = boundary["branch"] / np.sqrt(np.einsum("ij,ij->i", boundary["branch"], boundary["branch"]))[:, None]
            rows.append(("fw", outer(n, n).reshape(-1, dim, dim)))
        if rows:
            groups.append((boundary["point"], rows))
        if "fb" in needed and bulk["i"].size:
            n = bulk["branch"] / np.sqrt(np.einsum("ij,ij->i", bulk["branch"], bulk["branch"]))[:, None]
            groups.append((bulk["point"], [("fb", outer(n, n).reshape(-1, dim, dim))]))
    return groups


def gradient_sources(snapshot, needed, u_ref):
    """The needed gradient primaries (source PARTICLE_GRADIENTS) as point sources of the kernel's gradient:
    (positions (S, D), [(name, values (S,) + (D,) * (rank - 1))]), values m for grad_rho and m (v - u_ref) for
    grad_p_w (absent without velocities: zero), for targets that integrate the kernel themselves."""
    rows = []
    if "grad_rho" in needed or "grad_p_w" in needed:
        m = flowing_rows(snapshot, snapshot.masses)
        if "grad_rho" in needed:
            rows.append(("grad_rho", m))
        if "grad_p_w" in needed and snapshot.velocities is not None:
            v = flowing_rows(snapshot, snapshot.velocities)
            rows.append(("grad_p_w", m[:, None] * (v - u_ref)))
    return flowing_rows(snapshot, snapshot.positions), rows


#: the primaries :func:`point_sources` gives
POINT_PRIMARIES = frozenset(p.name for p in PRIMARIES.values() if p.source in (PARTICLES, BOUNDARY_POINTS, BULK_POINTS))
