"""Which continuum fields exist, what each needs, and how they are computed.

A snapshot is reduced to *primary* sums (one kernel pass each, computed only
when a requested field needs them); requested fields are derived from the
primaries after any averaging over snapshots. Momentum is accumulated relative
to a reference velocity ``u_ref`` so that a large uniform flow does not cost
digits in the kinetic stress.
"""
import numpy as np

from . import _core
from ._threads import get_num_threads

#: field name -> (rank, primaries it needs)
FIELDS = {
    "density": (0, ("rho",)),
    "momentum": (1, ("rho", "p_w")),
    "velocity": (1, ("rho", "p_w")),
    "momentum_flux": (2, ("k",)),
    "kinetic_stress": (2, ("rho", "p_w", "sk")),
    "contact_stress": (2, ("sb",)),
    "boundary_stress": (2, ("sw",)),
    "interaction_force_density": (1, ("t",)),
    "body_force_density": (1, ("b",)),
    "stress": (2, ("rho", "p_w", "sk", "sb", "sw")),
    "extended_stress": (2, ("rho", "p_w", "sk", "sb", "sx")),
    "volume_fraction": (0, ("phi",)),
    "pressure": (0, ("rho", "p_w", "sk", "sb", "sw")),
    "temperature": (0, ("rho", "p_w", "sk")),
}

#: fields whose sign depends on the stress convention
STRESS_FIELDS = ("kinetic_stress", "contact_stress", "boundary_stress", "stress", "extended_stress")

CONVENTIONS = ("tension", "compression")


def check_fields(fields):
    if isinstance(fields, str):
        fields = (fields,)
    try:
        fields = tuple(fields)
    except TypeError:
        raise TypeError(f"fields: expected a sequence of field names, got {fields!r}") from None
    if not fields:
        raise ValueError("fields: expected at least one field name, got none")
    for name in fields:
        if not isinstance(name, str):
            raise TypeError(f"fields: expected field names (strings), got {name!r}")
        if name not in FIELDS:
            raise ValueError(f"fields: expected some of {', '.join(FIELDS)}, got unknown field {name!r}")
    return tuple(dict.fromkeys(fields))


def check_convention(convention):
    if not isinstance(convention, str):
        raise TypeError(f"convention: expected 'tension' or 'compression', got {convention!r}")
    if convention not in CONVENTIONS:
        raise ValueError(f"convention: expected 'tension' (the paper's sign) or 'compression' (MercuryCG's), "
                         f"got {convention!r}")
    return convention


def needed_primaries(fields):
    needed = set()
    for name in fields:
        needed.update(FIELDS[name][1])
    return needed


def reference_velocity(snapshot):
    """Mass-weighted mean velocity of the flowing particles (any constant would do)."""
    if snapshot.velocities is None or snapshot.fixed.all():
        return np.zeros(snapshot.dim)
    m = flowing_rows(snapshot, snapshot.masses)
    return (m[:, None] * flowing_rows(snapshot, snapshot.velocities)).sum(axis=0) / m.sum()


def flowing_rows(snapshot, array):
    """The rows of ``array`` (N rows, one per particle) of the flowing particles, in order.

    With no fixed particle this is ``array`` itself, not a copy: the callers only read it.
    """
    if not snapshot.fixed.any():
        return array
    return array[snapshot.flowing]


def _outer(a, b):
    """a outer b per row, flat (n, Da*Db)."""
    return _outer_into(a, b, np.empty((a.shape[0], a.shape[1] * b.shape[1])))


def check_computable(snapshot, needed, split=None):
    """Raise, before any kernel work, if the snapshot lacks what the needed primaries require.

    Returns the split contacts (or None if no contact primary is needed) so that they are not split twice.
    """
    if "phi" in needed and snapshot.radii is None:
        raise ValueError("snapshot.radii: expected radii for the field 'volume_fraction', got None")
    if not needed & {"sb", "sw", "t", "sx"}:
        return None
    if split is None:
        split = snapshot.split_contacts()
    boundary = split[1]
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


def _particle_columns(snapshot, needed, u_ref, has_velocity):
    """The values summed over the flowing particles' positions, side by side in one (n, K) block.

    Returns the block and [(primary, first column, number of columns, shape per node)]. Each
    column is formed in place with the same floating-point operations as on its own.
    """
    dim = snapshot.dim
    wanted = []
    if "rho" in needed:
        wanted.append(("rho", ()))
    if "p_w" in needed and has_velocity:
        wanted.append(("p_w", (dim,)))
    if "k" in needed and has_velocity:
        wanted.append(("k", (dim, dim)))
    if "b" in needed and snapshot.body_force is not None:
        wanted.append(("b", (dim,)))
    if "phi" in needed:
        wanted.append(("phi", ()))
    layout, width = [], 0
    for name, shape in wanted:
        size = int(np.prod(shape, dtype=int))
        layout.append((name, width, size, shape))
        width += size
    if not layout:
        return None, layout
    m = flowing_rows(snapshot, snapshot.masses)
    n = m.shape[0]
    block = np.empty((n, width))
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
            _outer_into(v, v, cols)
            for r in range(size):
                np.multiply(m, cols[:, r], out=cols[:, r])
        elif name == "b":
            g = flowing_rows(snapshot, snapshot.body_force)
            for r in range(dim):
                np.multiply(m, g[:, r], out=cols[:, r])
        elif name == "phi":
            r = flowing_rows(snapshot, snapshot.radii)
            cols[:, 0] = np.pi * r**2 if dim == 2 else 4.0 / 3.0 * np.pi * r**3
    return block, layout


def _outer_into(a, b, out):
    """out[:, D*r + c] = a[:, r] * b[:, c]: one multiplication per column (faster than broadcasting
    over the short last axes, and no temporary)."""
    dim = b.shape[1]
    for r in range(a.shape[1]):
        for c in range(dim):
            np.multiply(a[:, r], b[:, c], out=out[:, dim * r + c])
    return out


def _negated_outer(force, branch):
    """-(force outer branch), flat (n, D*D): (-f) b is -(f b) exactly (rounding is symmetric in sign)."""
    n, dim = force.shape
    return _outer_into(np.negative(force), branch, np.empty((n, dim * dim)))


def compute_primaries(snapshot, target, kernel, needed, u_ref, split=None):
    """Primary sums of one snapshot at the target's nodes, flat over nodes: shape (P, ...).

    ``split``: the result of ``check_computable`` if already called (checks are repeated otherwise).
    The primaries summed over particle positions may be views of one (P, K) block of sums.
    """
    split = check_computable(snapshot, needed, split)
    dim = snapshot.dim
    P = target.size
    core_target = target._core_target(snapshot.box)
    core_kernel = kernel._core_args(target.avg_extent)
    has_velocity = snapshot.velocities is not None
    out = {}
    nt = get_num_threads()

    def points(positions, values):
        return _core.scatter_points(core_target, core_kernel, positions, values, n_threads=nt)

    # the primaries summed over the flowing particles' positions: one scatter with all their columns
    # (the stencil and weights are computed once; each column is summed exactly as on its own)
    pos = flowing_rows(snapshot, snapshot.positions)
    block, layout = _particle_columns(snapshot, needed, u_ref, has_velocity)
    if layout:
        summed = points(pos, block)
        del block
        for name, start, size, shape in layout:
            out[name] = summed[:, start:start + size].reshape((P,) + shape)
    if "p_w" in needed and not has_velocity:
        out["p_w"] = np.zeros((P, dim))
    if "k" in needed and not has_velocity:
        out["k"] = np.zeros((P, dim, dim))
    if "b" in needed and snapshot.body_force is None:
        out["b"] = np.zeros((P, dim))
    if "sk" in needed:
        if has_velocity and pos.shape[0]:
            rho = out["rho"]
            m = flowing_rows(snapshot, snapshot.masses)
            v_w = flowing_rows(snapshot, snapshot.velocities) - u_ref
            node_v = np.zeros((P, dim))
            np.divide(out["p_w"], rho[:, None], out=node_v, where=rho[:, None] > 0)
            out["sk"] = _core.scatter_fluctuation(core_target, core_kernel, pos, m, v_w, node_v, n_threads=nt)
        else:
            out["sk"] = np.zeros((P, dim, dim))

    contact_primaries = needed & {"sb", "sw", "t", "sx"}
    if contact_primaries:
        bulk, boundary = split
        longest = longest_branch(bulk, boundary) if kernel.resolves_from_branch else None
        core_kernel = kernel._core_args(target.avg_extent, longest)
        if "sb" in needed:
            if bulk["i"].size:
                start = np.take(snapshot.positions, bulk["i"], axis=0)
                values = _negated_outer(bulk["force"], bulk["branch"])
                out["sb"] = _core.scatter_segments(core_target, core_kernel, start, np.negative(bulk["branch"]),
                                                   values, n_threads=nt).reshape(P, dim, dim)
                del start, values
            else:
                out["sb"] = np.zeros((P, dim, dim))
        if needed & {"sw", "sx"} and boundary["i"].size:
            start = np.take(snapshot.positions, boundary["i"], axis=0)
            values = _negated_outer(boundary["force"], boundary["branch"])
            vectors = np.negative(boundary["branch"])
        if "sw" in needed:
            if boundary["i"].size:
                out["sw"] = _core.scatter_segments(core_target, core_kernel, start, vectors,
                                                   values, n_threads=nt).reshape(P, dim, dim)
            else:
                out["sw"] = np.zeros((P, dim, dim))
        if "sx" in needed:
            if boundary["i"].size:
                out["sx"] = _core.scatter_segments(core_target, core_kernel, start, vectors,
                                                   values, ray=True, n_threads=nt).reshape(P, dim, dim)
            else:
                out["sx"] = np.zeros((P, dim, dim))
        if "t" in needed:
            if boundary["i"].size:
                out["t"] = points(boundary["point"], boundary["force"])
            else:
                out["t"] = np.zeros((P, dim))
    return out


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


def derive(primaries, fields, u_ref, dim, convention):
    """Requested fields (flat over nodes, C-contiguous) from averaged primaries.

    A field equal to a C-contiguous primary is that array itself, not a copy: callers pass
    primaries they no longer need (and no two fields share one).
    """
    pr = primaries
    own = np.ascontiguousarray
    out = {}
    rho = pr.get("rho")
    sign = -1.0 if convention == "compression" else 1.0

    def velocity_w():
        V = np.full(pr["p_w"].shape, np.nan)
        np.divide(pr["p_w"], rho[:, None], out=V, where=rho[:, None] > 0)
        return V

    for name in fields:
        if name == "density":
            value = own(rho)
        elif name == "momentum":
            value = np.empty(pr["p_w"].shape)
            for r in range(dim):                       # p_w + rho u_ref, column by column
                np.multiply(rho, u_ref[r], out=value[:, r])
                np.add(pr["p_w"][:, r], value[:, r], out=value[:, r])
        elif name == "velocity":
            value = velocity_w() + u_ref
        elif name == "momentum_flux":
            value = own(pr["k"])
        elif name == "kinetic_stress":
            value = own(pr["sk"]) if sign == 1.0 else sign * pr["sk"]
        elif name == "contact_stress":
            value = own(pr["sb"]) if sign == 1.0 else sign * pr["sb"]
        elif name == "boundary_stress":
            value = own(pr["sw"]) if sign == 1.0 else sign * pr["sw"]
        elif name == "interaction_force_density":
            value = own(pr["t"])
        elif name == "body_force_density":
            value = own(pr["b"])
        elif name == "stress":
            value = sign * (pr["sk"] + pr["sb"] + pr["sw"])
        elif name == "extended_stress":
            value = sign * (pr["sk"] + pr["sb"] + pr["sx"])
        elif name == "volume_fraction":
            value = own(pr["phi"])
        elif name == "pressure":
            value = -np.trace(pr["sk"] + pr["sb"] + pr["sw"], axis1=1, axis2=2) / dim
        elif name == "temperature":
            value = np.full(rho.shape, np.nan)
            np.divide(-np.trace(pr["sk"], axis1=1, axis2=2), dim * rho, out=value, where=rho > 0)
        out[name] = value
    return out
