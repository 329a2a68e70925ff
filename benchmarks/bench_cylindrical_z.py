"""Cost of the exact z-average of the point-source ring sums on z-averaged CylindricalGrids.

The exact path (cgbound.cylindrical_ring.axial_rule) evaluates the ring moments at Gauss-Legendre points on
pieces of z per (ring, source) pair; the rule it replaced evaluated them at the z_points(L, kernel)
Gauss-Legendre points over the box's extent, i.e. the cost of a z-resolved grid with that many z nodes. This
prints, per kernel, the ring-moment evaluations per (ring, source) pair of both, and the CPU time of the
z-averaged grid (exact) and of the z-resolved grid with z_points nodes (the old rule's work), one thread,
median of 3, interleaved. Fields: density and momentum (point sums only).

Then the θ-RESOLVED z-averaged grid (r = (0, 4, 8), 16 θ): the exact path (one line integral per
(node, source), cylindrical_ring.axial_line_average) against the Gauss-Legendre rule it replaced (the Cartesian
engine at z_points(L, kernel) points per node, emulated here with cylindrical_fields.quadrature), interleaved.
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cgbound as cg  # noqa: E402
from cgbound.cylindrical_fields import z_points  # noqa: E402
from cgbound.cylindrical_ring import axial_rule  # noqa: E402
from cgbound.cylindrical_fields import quadrature  # noqa: E402
from common import header, timed  # noqa: E402


def old_theta_resolved(snap, grid, kernel, fields):
    """The replaced rule: the Cartesian engine at Gauss-Legendre points in z, averaged per node."""
    pos, _, weights, starts = quadrature(grid, kernel)
    res = cg.coarse_grain(snap, cg.Points(pos), kernel, fields=fields)
    return np.add.reduceat(np.asarray(res["density"]).ravel() * weights, starts)


def main():
    rng = np.random.default_rng(0)
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
    L = 10.0
    box = cg.Box([-5, -5, 0], [5, 5, L], periodic=[False, False, True])
    pos = np.c_[rng.uniform(-4.5, 4.5, (n, 2)), rng.uniform(0, L, n)]
    snap = cg.Snapshot(pos, rng.normal(size=(n, 3)), np.ones(n), box=box)
    fields = ("density", "momentum")
    print(header(threads=1, extra=f"{n} particles, box 10 x 10 x {L:g} (periodic z), r = (0, 4, 8)"))
    print("# kernel, z points per pair: exact / old GL (inside the support), CPU s: exact z-average, "
          "z-resolved with the old rule's node count, ratio")
    with cg.threads(1):
        for kernel in (cg.Gaussian(0.5), cg.Lucy(1.5), cg.Heaviside(1.0)):
            c = float(kernel.radius)
            averaged = cg.CylindricalGrid(box, (0, 0, 0), "z", r=(0, 4, 8))
            n_old = z_points(L, kernel)
            resolved = cg.CylindricalGrid(box, (0, 0, 0), "z", r=(0, 4, 8), z=(0, L, n_old))
            # points per pair: the exact rule for random pairs against the old rule's nodes inside the support
            r, rho = 2.0, rng.uniform(2.0 - c, 2.0 + c, 4000)
            zeta = rng.uniform(0, L, rho.size)
            pair, h, _ = axial_rule(kernel, r, rho, zeta, 0.0, L)
            exact_pts = h.size / rho.size
            old_pts = n_old * np.mean(2 * np.sqrt(np.maximum(c * c - (r - rho) ** 2, 0.0)) / L)
            t_new = timed(lambda: cg.coarse_grain(snap, averaged, kernel, fields=fields), 3, cpu=True)[2]
            t_old = timed(lambda: cg.coarse_grain(snap, resolved, kernel, fields=fields), 3, cpu=True)[2]
            print(f"{kernel!r}, {exact_pts:.1f} / {old_pts:.1f}, {t_new:.2f}, {t_old:.2f}, {t_new / t_old:.2f}")
        print("# theta-resolved z-averaged grid: kernel, CPU s: exact line integrals, old GL rule (points), ratio")
        for kernel in (cg.Gaussian(0.5), cg.Lucy(1.5), cg.Heaviside(1.0)):
            grid = cg.CylindricalGrid(box, (0, 0, 0), "z", r=(0, 4, 8), theta=16)
            t_new, t_old = [], []
            for _ in range(3):       # interleaved
                t_new.append(timed(lambda: cg.coarse_grain(snap, grid, kernel, fields=fields), 1, cpu=True)[2])
                t_old.append(timed(lambda: old_theta_resolved(snap, grid, kernel, fields), 1, cpu=True)[2])
            a, b = float(np.median(t_new)), float(np.median(t_old))
            print(f"{kernel!r}, {a:.3f}, {b:.3f} ({z_points(L, kernel)}), {a / b:.2f}")


if __name__ == "__main__":
    main()
