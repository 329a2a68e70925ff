"""Rotational fields: spin density, spin flux, couple stress and the torque densities of the
angular momentum balance (docs/theory.md, "Rotation and couple stress").

Pseudo-vectors (angular velocities, torques) have 3 components in 3D and one in 2D (the component
perpendicular to the plane, positive when (axis 0, axis 1, normal) is right-handed), so the cross
product of two in-plane vectors is the scalar a_0 b_1 - a_1 b_0 there. A field with a pseudo-vector
index therefore has that index of length 3 in 3D and none in 2D: the spin density is (P, 3) in 3D and
(P,) in 2D; the couple stress m[a, b] (torque component a carried across planes normal to b) is
(P, 3, 3) in 3D and (P, 2) in 2D.
"""
import numpy as np

from ._engine import core_kernel, core_target, scatter_points, scatter_segments
from ._threads import get_num_threads
from .fields import ROTATION_FIELDS, check_fields
from .grid import check_target, periodic_resolved_lengths
from .kernels import check_kernel, check_reach
from .primaries import flowing_rows, longest_branch, outer, reference_velocity
from .snapshot import Snapshot


#: fields that need angular velocities (and moments of inertia)
SPIN_FIELDS = ("spin_density", "angular_momentum_density", "spin_flux", "kinetic_spin_flux")
#: fields that also need the particles' velocities
MOVING_FIELDS = ("spin_flux", "kinetic_spin_flux")


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
    and ``wall_torque`` per boundary contact. A bulk contact gives two halves: (i, f, a_i) and (j, -f, a_j) with
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
            "force": force, "branch": branch, "torque": cross(force, branch),
            "pair_point": np.take(snapshot.positions, bulk["i"], axis=0) - a_i,
            "pair_moment": cross(bulk["force"], bulk["branch"]),
            "wall_point": boundary["point"], "wall_torque": cross(boundary["force"], boundary["branch"])}


def largest_couple(halves):
    """The largest torque x branch the couple stress sums (force x branch^2, which may overflow where
    force x branch does not); 0 without contacts."""
    if not halves["i"].size:
        return 0.0
    with np.errstate(over="ignore"):
        arm = np.abs(halves["branch"]).max(axis=1)
        return float((np.abs(pseudo_columns(halves["torque"])).max(axis=1) * arm).max())


def contact_torques(snapshot, halves=None):
    """The torque on every particle from its contacts, sum_j (c_ij - r_i) x f_ij: (N, 3) in 3D, (N,) in 2D
    (fixed particles: their flowing partners' halves are not theirs, so zero)."""
    halves = contact_halves(snapshot) if halves is None else halves
    out = np.zeros((snapshot.n_particles,) + pseudo_shape(snapshot.dim))
    np.add.at(out, halves["i"], halves["torque"])
    return out


def check_spin(snapshot, fields):
    """Raise before any work if a requested field needs angular velocities or moments of inertia that are missing."""
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


def rotation_fields(snapshot, where, kernel, fields=ROTATION_FIELDS):
    """The rotational fields of one snapshot on a Grid (with or without averaged axes) or at Points.

    Returns {name: array of shape target.field_shape + the field's own shape} (see the module docstring;
    ``spin_flux`` J[a, b] = sum_i I_i w_ia v_ib W_i is (P, 3, D) in 3D and (P, D) in 2D). The sign convention
    is the paper's (tension): m = -sum over contact halves of tau (x) a int_0^1 W(r - r_i + s a) ds.
    """
    if not isinstance(snapshot, Snapshot):
        raise TypeError(f"snapshot: expected a cg.Snapshot, got {type(snapshot).__name__}")
    fields = check_fields(fields, ROTATION_FIELDS)
    kernel = check_kernel(kernel)
    target = check_target(where, snapshot.dim, name="where")
    inertia = check_spin(snapshot, fields)
    dim = snapshot.dim
    largest = snapshot.largest_product
    if inertia is not None:
        flow_i = flowing_rows(snapshot, inertia)
        spin = flowing_rows(snapshot, snapshot.angular_velocities)
        largest = max(largest, float(np.abs(flow_i * np.abs(pseudo_columns(spin)).max(axis=1,
                                                                                      initial=0.0)).max(initial=0.0)))
    halves = None
    if set(fields) & {"couple_stress", "stress_torque_density", "boundary_couple_density"}:
        split = snapshot.split_contacts()
        halves = contact_halves(snapshot, split)
        largest = max(largest, largest_couple(halves))
    check_reach(kernel, dim, periodic_resolved_lengths(snapshot.box, target), largest, where="snapshot",
                n_resolved=len(target.resolved), avg_extent=target.avg_extent)
    core = core_target(target, snapshot.box)
    point_kernel = core_kernel(kernel, target.avg_extent)
    nt = get_num_threads()
    P = target.size
    tshape = pseudo_shape(dim)
    pos = flowing_rows(snapshot, snapshot.positions)
    out = {}
    if inertia is not None:
        s_i = pseudo_columns(spin) * flow_i[:, None]
        if pos.shape[0]:
            summed = scatter_points(core, point_kernel, pos, s_i, n_threads=nt)
        else:
            summed = np.zeros((P, s_i.shape[1]))
        for name in ("spin_density", "angular_momentum_density"):
            if name in fields:
                out[name] = summed.reshape((P,) + tshape).copy()
        if "spin_flux" in fields:
            v = flowing_rows(snapshot, snapshot.velocities)
            flux = (scatter_points(core, point_kernel, pos, outer(s_i, v), n_threads=nt) if pos.shape[0]
                    else np.zeros((P, s_i.shape[1] * dim)))
            out["spin_flux"] = flux.reshape((P,) + tshape + (dim,))
        if "kinetic_spin_flux" in fields:
            out["kinetic_spin_flux"] = kinetic_spin_flux(snapshot, s_i, summed, core, point_kernel, P, nt)
    if halves is not None:
        line_kernel = core_kernel(kernel, target.avg_extent, longest_branch(*split))
        if "couple_stress" in fields:
            out["couple_stress"] = couple_stress_sum(snapshot, halves, core, line_kernel, P, nt)
        for name, points, values in (("stress_torque_density", "pair_point", "pair_moment"),
                                     ("boundary_couple_density", "wall_point", "wall_torque")):
            if name in fields:
                out[name] = (scatter_points(core, line_kernel, halves[points], pseudo_columns(halves[values]),
                                            n_threads=nt).reshape((P,) + tshape)
                             if halves[points].shape[0] else np.zeros((P,) + tshape))
    return {name: out[name].reshape(target.field_shape + out[name].shape[1:]) for name in fields}


def kinetic_spin_flux(snapshot, s_i, spin, core, point_kernel, P, nt):
    """J' = sum_i I_i w_i (x) (v_i - V) W_i = J - s (x) V about the local velocity V = p / rho (0 where rho = 0,
    where every sum vanishes). Velocities are taken relative to the mass-weighted mean u_ref (J' does not
    depend on it), so that a large uniform flow costs no digits: J_w - s (x) V_w."""
    dim = snapshot.dim
    T = s_i.shape[1]
    pos = flowing_rows(snapshot, snapshot.positions)
    if not pos.shape[0]:
        return np.zeros((P,) + pseudo_shape(dim) + (dim,))
    u_ref = reference_velocity(snapshot)
    m = flowing_rows(snapshot, snapshot.masses)
    v_w = flowing_rows(snapshot, snapshot.velocities) - u_ref
    block = np.concatenate([m[:, None], m[:, None] * v_w, outer(s_i, v_w)], axis=1)
    sums = scatter_points(core, point_kernel, pos, block, n_threads=nt)
    rho, p_w, flux_w = sums[:, 0], sums[:, 1:1 + dim], sums[:, 1 + dim:].reshape(P, T, dim)
    V_w = np.zeros((P, dim))
    np.divide(p_w, rho[:, None], out=V_w, where=rho[:, None] > 0)
    return (flux_w - spin[:, :, None] * V_w[:, None, :]).reshape((P,) + pseudo_shape(dim) + (dim,))


def couple_stress_sum(snapshot, halves, core, line_kernel, P, nt, gradient=False):
    """m = -sum_halves tau (x) a int_0^1 W(r - r_i + s a) ds, from r_i to its contact point: (P, T, D) flat
    over the torque components (T = 3 in 3D, 1 in 2D); with ``gradient``, (P, T, D, D_res)."""
    dim = snapshot.dim
    T = 3 if dim == 3 else 1
    if not halves["i"].size:
        return np.zeros((P, T, dim) + ((len(core.axes),) if gradient else ())).reshape(
            (P,) + pseudo_shape(dim) + (dim,) + ((len(core.axes),) if gradient else ()))
    starts = np.take(snapshot.positions, halves["i"], axis=0)
    values = outer(np.negative(pseudo_columns(halves["torque"])), halves["branch"])
    summed = scatter_segments(core, line_kernel, starts, np.negative(halves["branch"]), values, gradient=gradient,
                              n_threads=nt)
    return summed.reshape((P,) + pseudo_shape(dim) + (dim,) + summed.shape[2:])
