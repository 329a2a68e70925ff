"""The demo configuration: the paper's Fig. 1 scene, five fixed and five flowing discs in static balance.

The contact forces are the frictionless normal forces that balance gravity
exactly, so the momentum balance of eq. (6) holds with zero time derivative:
div(sigma) + t + b = 0 everywhere, and the interaction force density carries
the whole weight of the flow into the base.
"""
import numpy as np

from .box import Box
from .snapshot import Contacts, Snapshot


def boundary_2d():
    """Five fixed discs (diameter 1) at z = 0 and five flowing discs stacked on them, gravity -z."""
    h = np.sqrt(3.0) / 2.0
    fixed_x = np.arange(5.0)
    lower_x = np.arange(4.0) + 0.5
    positions = np.concatenate([
        np.stack([fixed_x, np.zeros(5)], axis=1),
        np.stack([lower_x, np.full(4, h)], axis=1),
        [[2.0, 2 * h]],
    ])
    n = positions.shape[0]
    fixed = np.zeros(n, bool)
    fixed[:5] = True
    # touching pairs (centre distance 1) that carry load; neighbours in the same
    # row just touch, carrying nothing, which makes the statics determinate
    pairs = [(i, j) for i in range(5, n) for j in range(n)
             if j != i and (fixed[j] or j > i) and abs(np.linalg.norm(positions[i] - positions[j]) - 1.0) < 1e-9
             and abs(positions[i, 1] - positions[j, 1]) > 1e-9]
    normals = np.array([positions[i] - positions[j] for i, j in pairs])  # unit: distance 1
    # equilibrium of each flowing disc: sum of lambda_c n_c (+ on i, - on j) = -m g = (0, +1)
    flowing = list(range(5, n))
    A = np.zeros((2 * len(flowing), len(pairs)))
    for c, (i, j) in enumerate(pairs):
        A[2 * flowing.index(i):2 * flowing.index(i) + 2, c] += normals[c]
        if not fixed[j]:
            A[2 * flowing.index(j):2 * flowing.index(j) + 2, c] -= normals[c]
    rhs = np.tile([0.0, 1.0], len(flowing))
    lam = np.linalg.lstsq(A, rhs, rcond=None)[0]
    if np.any(lam < -1e-12):  # pragma: no cover - the geometry above is compressive
        raise RuntimeError("demo configuration is not in compression")
    i = np.array([p[0] for p in pairs])
    j = np.array([p[1] for p in pairs])
    force = lam[:, None] * normals
    point = 0.5 * (positions[i] + positions[j])
    box = Box([-0.75, -0.75], [4.75, 2.75], periodic=(False, False))
    return Snapshot(positions, np.zeros_like(positions), np.ones(n), box=box,
                    contacts=Contacts(i, j, force, point), fixed=fixed, body_force=[0.0, -1.0],
                    radii=np.full(n, 0.5))
