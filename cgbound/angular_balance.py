"""The intrinsic angular momentum balance, checked pointwise with analytic kernel gradients
(docs/theory.md, "Rotation and couple stress")."""
import numpy as np

from ._engine import core_kernel, core_target, point_target, scatter_points
from ._memory import check_fits, core_threads
from ._threads import get_num_threads
from .grid import Points, check_target, periodic_resolved_lengths
from .kernels import check_kernel, check_reach
from .fields import DEFAULT_COUPLE_STRESS_FORM, check_couple_stress_form
from .primaries import (branch_line_couple_sum, contact_halves, contact_torque_sums, couple_stress_sum, largest_couple,
                        longest_branch, pseudo_columns)
from .residual import relative_residual
from .rotation import contact_torques
from .snapshot import Snapshot, pseudo_vector_array


class AngularMomentumBalance:
    """Terms of ds/dt + div(J) - div(m) - T - t_c - tau_ext at each point.

    The kinetic parts of ds/dt and of the divergence of the spin flux J = sum_i I_i w_i v_i W_i are the
    same sum, sum_i I_i w_i (v_i . grad W_i), and cancel identically; what remains is
    ``residual = forcing - div_couple_stress - stress_torque_density - boundary_couple_density
    - external_torque_density`` with ``forcing = sum_i I_i dw_i/dt W_i = sum_i tau_i W_i``.

    Attributes: residual and the terms (all (P, 3) in 3D, (P, 1) in 2D), scale and relative
    (``|residual| / scale``, (P,)). The scale is the peak kernel value times the largest torque
    (or a larger term actually seen), as for :class:`cgbound.MomentumBalance`.
    """

    TERMS = ("forcing", "div_couple_stress", "stress_torque_density", "boundary_couple_density",
             "external_torque_density")

    def __init__(self, points, terms, reach=0.0):
        self.points = points
        for name, value in terms.items():
            setattr(self, name, value)
        self.residual = (self.forcing - self.div_couple_stress - self.stress_torque_density
                         - self.boundary_couple_density - self.external_torque_density)
        self.scale, self.relative = relative_residual(self.residual, terms, reach)

    def __repr__(self):
        worst = float(self.relative.max()) if self.relative.size else 0.0
        return f"<AngularMomentumBalance at {self.points.size} points, max relative residual {worst:.3g}>"


def angular_momentum_balance_residual(snapshot, points, kernel, torques=None, external_torques=None,
                                      couple_stress_form=DEFAULT_COUPLE_STRESS_FORM):
    """Residual of the intrinsic angular momentum balance at points, for any data.

    I_i dw_i/dt = tau_i (the total torque on particle i) is the rate of the spin; the balance
    ds/dt + div J = div m + T + t_c + tau_ext holds pointwise when tau_i is the sum of its contact
    torques (c_ij - r_i) x f_ij and its external torque.

    Parameters
    ----------
    snapshot : Snapshot
    points : Points or (P, D) array
    kernel : Gaussian or Lucy (the residual is round-off small for Lucy and for a Gaussian whose
        cutoff makes the tail negligible)
    torques : (N, 3) array in 3D, (N,) or (N, 1) in 2D, optional
        Total torque on each particle (e.g. ``snapshot.torques`` from a dump). Default: the contact
        torques plus ``external_torques``, which makes the residual a test of the coarse graining itself.
    external_torques : like torques, optional
        Torques not from the contacts (e.g. a driving motor); their density is a term of the balance.
    couple_stress_form : "contact_point" or "branch_line"
        The split of the contact torques whose terms are checked (docs/theory.md): with "branch_line" the
        stress torque density is eps : sigma of the contact stress and the boundary term eps : sigma of the
        boundary stress, both along the same lines as the stresses.
    """
    if not isinstance(snapshot, Snapshot):
        raise TypeError(f"snapshot: expected a cg.Snapshot, got {type(snapshot).__name__}")
    kernel = check_kernel(kernel)
    check_couple_stress_form(couple_stress_form)
    if not kernel.differentiable:
        raise ValueError(f"kernel: expected a differentiable kernel (Gaussian or Lucy) for the angular momentum "
                         f"balance, got {kernel!r}")
    target = check_target(points, snapshot.dim, name="points")
    if not isinstance(target, Points):
        raise TypeError(f"points: expected cg.Points or a (P, D) array (the balance is checked pointwise), "
                        f"got {type(target).__name__}")
    dim, n, P = snapshot.dim, snapshot.n_particles, target.size
    T = 3 if dim == 3 else 1
    external = (None if external_torques is None
                else pseudo_vector_array(external_torques, "external_torques", n, dim).reshape(n, T))
    split = snapshot.split_contacts()
    halves = contact_halves(snapshot, split)
    if torques is None:
        torques = pseudo_columns(contact_torques(snapshot, halves))
        if external is not None:
            torques = torques + external
    else:
        torques = pseudo_vector_array(torques, "torques", n, dim).reshape(n, T)
    largest = max(float(np.abs(torques).max(initial=0.0)), float(np.abs(halves["torque"]).max(initial=0.0)),
                  float(np.abs(halves["pair_moment"]).max(initial=0.0)),
                  float(np.abs(external).max(initial=0.0)) if external is not None else 0.0)
    # the couple stress's segments carry torque x branch (checked, not part of the scale)
    check_reach(kernel, dim, periodic_resolved_lengths(snapshot.box, target),
                max(snapshot.largest_product, largest, largest_couple(halves)), where="snapshot (or torques)")
    threads = core_threads(max(n, len(snapshot.contacts)))
    check_fits("points", P, threads * T * dim * dim + 8 * T, what="the angular momentum balance terms")
    where = core_target(target, snapshot.box)
    point_kernel = core_kernel(kernel, 1.0)
    line_kernel = core_kernel(kernel, 1.0, longest_branch(*split))
    nt = get_num_threads()
    flow = snapshot.flowing
    pos = snapshot.positions[flow]
    zero = np.zeros((P, T))

    def points_value(x, values, k=point_kernel):
        return scatter_points(where, k, x, pseudo_columns(values), n_threads=nt) if x.shape[0] else zero

    terms = {"forcing": points_value(pos, torques[flow])}
    if couple_stress_form == "contact_point":
        grad = couple_stress_sum(snapshot, halves, where, line_kernel, P, nt, gradient=True)   # (P, T, D, D)
        terms["stress_torque_density"] = points_value(halves["pair_point"], halves["pair_moment"], line_kernel)
        terms["boundary_couple_density"] = points_value(halves["wall_point"], halves["wall_torque"], line_kernel)
    else:
        grad = branch_line_couple_sum(snapshot, split, halves, where, line_kernel, P, nt, gradient=True)
        sums = contact_torque_sums(snapshot, split, {"pair_torque_bl", "wall_couple_bl"}, where, line_kernel, P, nt)
        terms["stress_torque_density"] = sums["pair_torque_bl"]
        terms["boundary_couple_density"] = sums["wall_couple_bl"]
    terms["div_couple_stress"] = np.einsum("ptbb->pt", grad)
    terms["external_torque_density"] = points_value(pos, external[flow]) if external is not None else zero
    origin = np.zeros((1, dim))
    peak = scatter_points(point_target(origin), point_kernel, origin, np.ones((1, 1)))[0, 0]
    return AngularMomentumBalance(target, terms, reach=peak * largest)
