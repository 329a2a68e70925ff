"""Rotational fields: spin density, spin flux, couple stress and the torque densities of the
angular momentum balance (docs/theory.md, "Rotation and couple stress").

Pseudo-vectors (angular velocities, torques) have 3 components in 3D and one in 2D (the component
perpendicular to the plane, positive when (axis 0, axis 1, normal) is right-handed), so the cross
product of two in-plane vectors is the scalar a_0 b_1 - a_1 b_0 there. A field with a pseudo-vector
index therefore has that index of length 3 in 3D and none in 2D (:func:`cgbound.fields.field_shape`):
the spin density is (P, 3) in 3D and (P,) in 2D; the couple stress m[a, b] (torque component a carried
across planes normal to b) is (P, 3, 3) in 3D and (P, 2) in 2D.

They are fields like the others (``cg.coarse_grain(..., fields=("spin_density", "couple_stress"))``,
``cg.CoarseGrain``); :func:`rotation_fields` is the same computation returning a dict.
"""
import numpy as np

from .fields import COUPLE_STRESS_FORMS, DEFAULT_COUPLE_STRESS_FORM, ROTATION_FIELDS, check_fields
from .pipeline import prepare, run_snapshot
from .primaries import (CONTACT_ROTATION_FIELDS, MOVING_FIELDS, SPIN_FIELDS, check_spin, contact_halves,
                        pseudo_shape, rotation_largest)

__all__ = ["ROTATION_FIELDS", "COUPLE_STRESS_FORMS", "SPIN_FIELDS", "MOVING_FIELDS", "check_spin",
           "rotation_largest", "contact_torques", "rotation_fields"]


def contact_torques(snapshot, halves=None):
    """The torque on every particle from its contacts, sum_j (c_ij - r_i) x f_ij: (N, 3) in 3D, (N,) in 2D
    (fixed particles: their flowing partners' halves are not theirs, so zero)."""
    halves = contact_halves(snapshot) if halves is None else halves
    out = np.zeros((snapshot.n_particles,) + pseudo_shape(snapshot.dim))
    np.add.at(out, halves["i"], halves["torque"])
    return out


def rotation_fields(snapshot, where, kernel, fields=ROTATION_FIELDS, couple_stress_form=DEFAULT_COUPLE_STRESS_FORM):
    """The rotational fields of one snapshot on a Grid (with or without averaged axes) or at Points.

    Returns {name: array of shape target.field_shape + the field's own shape} (see the module docstring;
    ``spin_flux`` J[a, b] = sum_i I_i w_ia v_ib W_i is (P, 3, D) in 3D and (P, D) in 2D). The sign convention
    is the paper's (tension). ``couple_stress_form``: "contact_point" (m = -sum over contact halves of
    tau (x) a int_0^1 W(r - r_i + s a) ds, torque densities at the contact points) or "branch_line" (the torque
    density is eps : sigma of the paper's stress; docs/theory.md). The same as ``cg.coarse_grain(snapshot,
    where, kernel, fields=fields, couple_stress_form=...)``, as a dict.
    """
    fields = check_fields(fields, ROTATION_FIELDS)
    result = run_snapshot(prepare(snapshot, where, kernel, fields, "tension", None,
                                  couple_stress_form=couple_stress_form))
    return {name: result[name] for name in fields}
