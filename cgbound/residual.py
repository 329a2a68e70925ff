"""The momentum balance of eq. (6), checked pointwise with analytic kernel gradients (docs/theory.md, "Momentum balance")."""
import numpy as np

from ._engine import core_kernel, core_target, point_target, scatter_points, scatter_segments
from ._threads import get_num_threads
from ._memory import check_fits, core_threads
from .primaries import longest_branch, outer
from .grid import Points, check_target, periodic_resolved_lengths
from .kernels import check_kernel, check_reach
from .snapshot import Snapshot
from ._validate import real_array


def relative_residual(residual, terms, reach):
    """(scale, relative): the scale is the largest term magnitude seen or ``reach`` (what a term can reach),
    relative is ``|residual| / scale`` per point (``|residual|`` where the scale is 0)."""
    mags = [np.linalg.norm(v, axis=1) for v in terms.values()]
    seen = max((m.max() if m.size else 0.0) for m in mags) if mags else 0.0
    scale = float(max(seen, reach))
    norm = np.linalg.norm(residual, axis=1)
    return scale, (norm / scale if scale > 0 else norm)


class MomentumBalance:
    """Terms of dp/dt + div(rho V V) - div(sigma) - t - b at each point.

    The kinetic parts of dp/dt and of div(rho V V - sigma^k) are the same sum,
    sum_i m_i v_i (v_i . grad W_i), and cancel identically; what remains is
    ``residual = forcing - div_contact_stress - div_boundary_stress - t - b``
    with ``forcing = sum_i f_i W_i``.

    Attributes: residual, forcing, div_contact_stress, div_boundary_stress,
    interaction_force_density, body_force_density (all (P, D)), scale and
    relative (``|residual| / scale``, (P,)). The scale is the largest magnitude a term
    can reach: the peak kernel value times the largest particle or contact force
    (or a larger term actually seen), so points out of everyone's reach, where all
    terms vanish, do not turn round-off into a relative error of 1.
    """

    def __init__(self, points, terms, reach=0.0):
        self.points = points
        for name, value in terms.items():
            setattr(self, name, value)
        self.residual = (self.forcing - self.div_contact_stress - self.div_boundary_stress
                         - self.interaction_force_density - self.body_force_density)
        self.scale, self.relative = relative_residual(self.residual, terms, reach)

    def __repr__(self):
        worst = float(self.relative.max()) if self.relative.size else 0.0
        return f"<MomentumBalance at {self.points.size} points, max relative residual {worst:.3g}>"


def momentum_balance_residual(snapshot, points, kernel, forces=None):
    """Residual of the momentum balance (6) at points, for any data.

    Parameters
    ----------
    snapshot : Snapshot
    points : Points or (P, D) array
    kernel : Gaussian or Lucy (the residual is round-off small for Lucy and for a
        Gaussian whose cutoff makes the tail negligible)
    forces : (N, D) array, optional
        Total force on each particle (e.g. from the simulation's dump). Default:
        built from the contacts and body forces, which makes the residual a test
        of the coarse-graining itself; with dumped forces it also tests the data.
    """
    if not isinstance(snapshot, Snapshot):
        raise TypeError(f"snapshot: expected a cg.Snapshot, got {type(snapshot).__name__}")
    kernel = check_kernel(kernel)
    if not kernel.differentiable:
        raise ValueError(f"kernel: expected a differentiable kernel (Gaussian or Lucy) for the momentum balance, "
                         f"got {kernel!r}")
    target = check_target(points, snapshot.dim, name="points")
    if not isinstance(target, Points):
        raise TypeError(f"points: expected cg.Points or a (P, D) array (the balance is checked pointwise), "
                        f"got {type(target).__name__}")
    dim, P = snapshot.dim, target.size
    if forces is None:
        forces = snapshot.particle_forces()
    else:
        forces = real_array(forces, "forces", ndim=2, shape=(snapshot.n_particles, dim))
    check_reach(kernel, dim, periodic_resolved_lengths(snapshot.box, target),
                max(snapshot.largest_product, float(np.abs(forces).max(initial=0.0))), where="snapshot (or forces)")
    # the gradient scatter has D^3 doubles per node (and per thread); the terms D each
    threads = core_threads(max(snapshot.n_particles, len(snapshot.contacts)))
    check_fits("points", P, threads * dim ** 3 + 8 * dim, what="the momentum balance terms")
    where = core_target(target, snapshot.box)
    point_kernel = core_kernel(kernel, 1.0)
    flow = snapshot.flowing
    pos = snapshot.positions[flow]
    m = snapshot.masses[flow]

    nt = get_num_threads()

    def points_value(x, values):
        return scatter_points(where, point_kernel, x, values, n_threads=nt)

    def divergence(starts, vecs, tensors):
        # tensors (n, D*D) row-major over (alpha, beta); contract the gradient with beta
        g = scatter_segments(where, segment_kernel, starts, vecs, tensors, gradient=True, n_threads=nt)
        return np.einsum("pabb->pa", g.reshape(P, dim, dim, dim))

    terms = {"forcing": points_value(pos, forces[flow])}
    bulk, boundary = snapshot.split_contacts()
    # the contact stress's divergence with the line rule coarse_grain would use for these contacts
    segment_kernel = core_kernel(kernel, 1.0, longest_branch(bulk, boundary))
    zero = np.zeros((P, dim))
    terms["div_contact_stress"] = (divergence(snapshot.positions[bulk["i"]], -bulk["branch"],
                                              -outer(bulk["force"], bulk["branch"]))
                                   if bulk["i"].size else zero)
    if boundary["i"].size:
        terms["div_boundary_stress"] = divergence(snapshot.positions[boundary["i"]], -boundary["branch"],
                                                  -outer(boundary["force"], boundary["branch"]))
        terms["interaction_force_density"] = points_value(boundary["point"], boundary["force"])
    else:
        terms["div_boundary_stress"] = zero
        terms["interaction_force_density"] = zero
    terms["body_force_density"] = (points_value(pos, m[:, None] * snapshot.body_force[flow])
                                   if snapshot.body_force is not None else zero)
    return MomentumBalance(target, terms, reach=largest_term(snapshot, point_kernel, forces))


def largest_term(snapshot, point_kernel, forces):
    """The largest magnitude a term of the balance can reach: the peak kernel value (``point_kernel``, the
    core's description) times the largest particle, contact or body force."""
    dim = snapshot.dim
    flow = snapshot.flowing
    m = snapshot.masses[flow]
    origin = np.zeros((1, dim))
    peak = scatter_points(point_target(origin), point_kernel, origin, np.ones((1, 1)))[0, 0]
    largest = max(np.abs(forces[flow]).max(initial=0.0), np.abs(snapshot.contacts.force).max(initial=0.0),
                  np.abs(m[:, None] * snapshot.body_force[flow]).max(initial=0.0) if snapshot.body_force is not None
                  else 0.0)
    return peak * largest
