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

from ._engine import core_kernel, core_target, scatter_fluctuation, scatter_points, scatter_segments
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
SOURCES = (PARTICLES, PARTICLE_FLUCTUATIONS, BULK_SEGMENTS, BOUNDARY_SEGMENTS, BOUNDARY_RAYS, BOUNDARY_POINTS,
           BULK_POINTS, PARTICLE_GRADIENTS)
#: sources that need the snapshot's contacts split into bulk and boundary
CONTACT_SOURCES = (BULK_SEGMENTS, BOUNDARY_SEGMENTS, BOUNDARY_RAYS, BOUNDARY_POINTS, BULK_POINTS)


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
)}

#: the primaries of radius powers: name -> power (the number density "nd" is power 0)
RADIUS_MOMENTS = {"nd": 0, **{f"r{k}": k for k in range(1, 6)}}

#: primaries that are kernel gradients (need a differentiable kernel)
GRADIENT_PRIMARIES = frozenset(p.name for p in PRIMARIES.values() if p.source == PARTICLE_GRADIENTS)

#: primaries that need the contacts split into bulk and boundary
CONTACT_PRIMARIES = frozenset(p.name for p in PRIMARIES.values() if p.source in CONTACT_SOURCES)


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
    return (m[:, None] * flowing_rows(snapshot, snapshot.velocities)).sum(axis=0) / m.sum()


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


def _particle_columns(snapshot, needed, u_ref):
    """The values summed over the flowing particles' positions, side by side in one (n, K) block.

    Returns the block and [(primary, first column, number of columns, shape per node)]. Each
    column is formed in place with the same floating-point operations as on its own. Primaries
    whose data the snapshot lacks (velocities, body force) are left out.
    """
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
    if not layout:
        return None, layout
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


def particle_sums(snapshot, needed, u_ref, target, kernel, P, nt):
    """Source PARTICLES: one scatter with all the needed columns (the stencil and weights are
    computed once; each column is summed exactly as on its own). Primaries whose data the
    snapshot lacks are zero."""
    out = {}
    block, layout = _particle_columns(snapshot, needed, u_ref)
    if layout:
        summed = scatter_points(target, kernel, flowing_rows(snapshot, snapshot.positions), block, n_threads=nt)
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
    start, vector, values = segment_sources(snapshot, part)
    return scatter_segments(target, kernel, start, vector, values, ray=ray, n_threads=nt).reshape(P, dim, dim)


def segment_sources(snapshot, part):
    """The segments of ``part`` (of split_contacts): starts (the flowing particle's centre), vectors (-a, to its
    partner or contact point) and values -f a, flat (n, D*D)."""
    start = np.take(snapshot.positions, part["i"], axis=0)
    return start, np.negative(part["branch"]), negated_outer(part["force"], part["branch"])


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
    return out


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


#: the primaries :func:`point_sources` gives
POINT_PRIMARIES = frozenset(p.name for p in PRIMARIES.values() if p.source in (PARTICLES, BOUNDARY_POINTS, BULK_POINTS))
