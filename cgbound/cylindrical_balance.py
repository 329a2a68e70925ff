"""The momentum balance on θ-averaged fields of a CylindricalGrid, with its hoop terms (docs/guide/cylindrical.md,
"Momentum balance").

The Cartesian balance (:mod:`cgbound.residual`) holds at every point; averaged over a ring and written in the
local basis (e_r, e_θ, e_z) it reads, for the θ-averaged stress T (contact or boundary; divergence on the
second index, as in Cartesian coordinates)::

    (div T)_r = ∂T_rr/∂r + ∂T_rz/∂z + (T_rr - T_θθ)/r
    (div T)_θ = ∂T_θr/∂r + ∂T_θz/∂z + (T_rθ + T_θr)/r
    (div T)_z = ∂T_zr/∂r + ∂T_zz/∂z + T_zr/r

The last terms (the hoop terms) come from the turning of the basis with θ. The averaged stresses and their
r and z derivatives are the exact ring integrals of the Cartesian sums and of their analytic gradients (the
local basis does not depend on r or z; :mod:`cgbound.cylindrical_ring`), so the residual is round-off small
where the rules along the segments are (docs/guide/cylindrical.md, "Momentum balance").
"""
import copy

import numpy as np

from ._engine import core_kernel
from ._validate import real_array
from .cylindrical import CylindricalGrid
from .cylindrical_fields import line_z_rule
from .cylindrical_ring import ring_average, ring_average_segments
from .grid import Points, periodic_resolved_lengths
from .kernels import check_kernel, check_reach
from .primaries import segment_sources
from .residual import largest_term, relative_residual
from .snapshot import Snapshot

#: the terms of the balance, each (grid shape) + (3,) in (r, θ, z) components
TERMS = ("forcing", "div_contact_stress", "div_boundary_stress", "interaction_force_density", "body_force_density")


def hoop_terms(stress, r):
    """The hoop terms of the divergence of θ-averaged tensors ``stress`` (..., 3, 3) at radii ``r``
    (broadcast against ``stress[..., 0, 0]``): ((T_rr - T_θθ)/r, (T_rθ + T_θr)/r, T_zr/r)."""
    r = np.asarray(r, dtype=float)
    return np.stack([(stress[..., 0, 0] - stress[..., 1, 1]) / r, (stress[..., 0, 1] + stress[..., 1, 0]) / r,
                     stress[..., 2, 0] / r], axis=-1)


def cylindrical_divergence(stress, d_dr, d_dz, r):
    """div T of θ-averaged tensors in (r, θ, z) components: ∂T_ar/∂r + ∂T_az/∂z + the hoop terms."""
    return d_dr[..., :, 0] + d_dz[..., :, 2] + hoop_terms(stress, r)


class CylindricalMomentumBalance:
    """Terms of the momentum balance on θ-averaged fields, in (r, θ, z) components.

    ``residual = forcing - div_contact_stress - div_boundary_stress - interaction_force_density
    - body_force_density``, as in :class:`cgbound.MomentumBalance`: ``forcing`` (the ring average of
    sum_i f_i W_i) stands for ∂p/∂t + div(ρVV - σᵏ), whose kinetic parts cancel identically.

    Attributes, shaped like the grid's fields: the terms above and ``residual`` ((…, 3)); the θ-averaged
    ``contact_stress`` and ``boundary_stress`` (tension, (…, 3, 3)) with their radial and axial derivatives
    ``contact_stress_dr``, ``contact_stress_dz``, ``boundary_stress_dr``, ``boundary_stress_dz``; the hoop
    parts of the divergences ``hoop_contact_stress`` and ``hoop_boundary_stress`` ((…, 3)); ``scale`` (the
    largest term magnitude seen, or the largest a term can reach) and ``relative`` (``|residual| / scale``
    per node). ``grid`` is the CylindricalGrid.
    """

    def __init__(self, grid, fields, reach=0.0):
        self.grid = grid
        for name, value in fields.items():
            setattr(self, name, value)
        r = grid.r[:, None, None]
        self.hoop_contact_stress = hoop_terms(self.contact_stress, r)
        self.hoop_boundary_stress = hoop_terms(self.boundary_stress, r)
        self.div_contact_stress = cylindrical_divergence(self.contact_stress, self.contact_stress_dr,
                                                         self.contact_stress_dz, r)
        self.div_boundary_stress = cylindrical_divergence(self.boundary_stress, self.boundary_stress_dr,
                                                          self.boundary_stress_dz, r)
        self.residual = (self.forcing - self.div_contact_stress - self.div_boundary_stress
                         - self.interaction_force_density - self.body_force_density)
        flat = {name: getattr(self, name).reshape(-1, 3) for name in TERMS}
        self.scale, relative = relative_residual(self.residual.reshape(-1, 3), flat, reach)
        self.relative = relative.reshape(grid.shape)

    def __repr__(self):
        worst = float(self.relative.max()) if self.relative.size else 0.0
        return f"<CylindricalMomentumBalance on {self.grid!r}, max relative residual {worst:.3g}>"


def cylindrical_momentum_balance_residual(snapshot, grid, kernel, forces=None):
    """Residual of the momentum balance on the θ-averaged fields of a CylindricalGrid, with the hoop terms.

    Parameters
    ----------
    snapshot : Snapshot (3-D)
    grid : CylindricalGrid with ``theta=None`` (fields averaged over θ); z resolved or averaged (then the
        ∂/∂z terms are the z-averages of the axial derivatives: the net flux through the ends)
    kernel : Gaussian or Lucy. The θ-averages are exact ring integrals (cgbound.cylindrical_ring), Lucy's with
        the rule along the segments graded towards their closest approach to the ring. A Gaussian cut off at c
        leaves its jump exp(-c²/2w²) at the cutoff, as the Cartesian balance does (about 1e-5 of the largest term
        at the default 5 w, round-off from 9 w).
    forces : (N, 3) array, optional
        Total force on each particle, as for :func:`cgbound.momentum_balance_residual`.

    Returns
    -------
    CylindricalMomentumBalance
    """
    if not isinstance(snapshot, Snapshot):
        raise TypeError(f"snapshot: expected a cg.Snapshot, got {type(snapshot).__name__}")
    if not isinstance(grid, CylindricalGrid):
        raise TypeError(f"grid: expected a cg.CylindricalGrid, got {type(grid).__name__}")
    if not grid.theta_averaged:
        raise ValueError(f"grid: expected a θ-averaged CylindricalGrid (theta=None) for the balance with hoop terms, "
                         f"got one with {grid.n_theta} θ nodes")
    if snapshot.dim != 3:
        raise ValueError(f"snapshot: expected a 3-D snapshot for a CylindricalGrid, got a {snapshot.dim}-D one")
    kernel = check_kernel(kernel)
    if not kernel.differentiable:
        raise ValueError(f"kernel: expected a differentiable kernel (Gaussian or Lucy) for the momentum balance, "
                         f"got {kernel!r}")
    if forces is None:
        forces = snapshot.particle_forces()
    else:
        forces = real_array(forces, "forces", ndim=2, shape=(snapshot.n_particles, 3))
    check_reach(kernel, 3, periodic_resolved_lengths(snapshot.box, Points(grid.axis_point[None, :])),
                max(snapshot.largest_product, float(np.abs(forces).max(initial=0.0))), where="snapshot (or forces)")
    point_kernel = core_kernel(kernel, 1.0)
    bulk, boundary = snapshot.split_contacts()
    flow = snapshot.flowing
    z_nodes, z_weights = line_z_rule(grid, kernel)
    # on a z-averaged grid the point sums at the line integrals' axial points too (not exactly averaged over z):
    # the balance holds on every ring, so it holds for the same weighted sum of rings
    rings = grid
    if grid.z_averaged:
        rings = copy.copy(grid)
        rings.z_range, rings.z = (0.0, 0.0, z_nodes.size), z_nodes.ravel()

    def vector(positions_, values):
        summed = ring_average(rings, kernel, positions_, [(values, 1)])[0].reshape(len(grid.r), -1, 3)
        if grid.z_averaged:
            summed = (summed * z_weights.reshape(1, -1, 1)).sum(axis=1)
        return summed.reshape(grid.shape + (3,))

    def stress_and_derivatives(part):
        """The θ-averaged stress of contacts ``part`` in (r, θ, z), and its ∂/∂r and ∂/∂z."""
        if not part["i"].size:
            zero = np.zeros(grid.shape + (3, 3))
            return zero, zero, zero.copy()
        start, vec, values = segment_sources(snapshot, part)
        values = values.reshape(-1, 3, 3)
        sigma = ring_average_segments(grid, kernel, start, vec, values, z_nodes, z_weights)
        grad = ring_average_segments(grid, kernel, start, vec, values, z_nodes, z_weights, gradient=True)
        grad = grad.reshape(grid.shape + (3, 3, 3))                  # [..., α, β, γ] = ∂σ_αβ/∂x_γ, local basis
        return sigma.reshape(grid.shape + (3, 3)), grad[..., 0], grad[..., 2]

    fields = {"forcing": vector(snapshot.positions[flow], forces[flow])}
    fields["contact_stress"], fields["contact_stress_dr"], fields["contact_stress_dz"] = stress_and_derivatives(bulk)
    fields["boundary_stress"], fields["boundary_stress_dr"], fields["boundary_stress_dz"] = \
        stress_and_derivatives(boundary)
    zero = np.zeros(grid.shape + (3,))
    fields["interaction_force_density"] = (vector(boundary["point"], boundary["force"]) if boundary["i"].size
                                           else zero)
    fields["body_force_density"] = (vector(snapshot.positions[flow],
                                           snapshot.masses[flow, None] * snapshot.body_force[flow])
                                    if snapshot.body_force is not None else zero.copy())
    return CylindricalMomentumBalance(grid, fields, reach=largest_term(snapshot, point_kernel, forces))
