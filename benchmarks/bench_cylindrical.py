"""Cost of a CylindricalGrid relative to Cartesian Points with the same node count.

A ring-averaged node is N(r) Cartesian point evaluations (times the z points when z is averaged), so
the expected ratio is the mean number of quadrature points per node; this prints it and the timed ratio
(CPU time of one-thread runs, median of 3; interleaved).
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cgbound as cg  # noqa: E402
from cgbound.cylindrical_fields import quadrature  # noqa: E402
from common import header, timed  # noqa: E402


def main():
    rng = np.random.default_rng(0)
    n = 20000
    box = cg.Box([-10, -10, 0], [10, 10, 20], periodic=[False, False, True])
    pos = np.c_[rng.uniform(-9, 9, (n, 2)), rng.uniform(0, 20, n)]
    snap = cg.Snapshot(pos, rng.normal(size=(n, 3)), np.ones(n), box=box)
    kernel = cg.Gaussian(1.0)
    fields = ("density", "velocity")
    print(header(threads=1))
    print("# grid, nodes, quadrature points per node, cylindrical / Cartesian CPU time")
    with cg.threads(1):
        for label, grid in [("R theta-avg, z=(0,20,10)", cg.CylindricalGrid(box, (0, 0, 0), "z", r=(0, 8, 16), z=(0, 20, 10))),
                            ("R theta=8, z=(0,20,10)", cg.CylindricalGrid(box, (0, 0, 0), "z", r=(0, 8, 16), theta=8, z=(0, 20, 10)))]:
            cart = cg.Points(grid.coordinates.reshape(-1, 3))
            per_node = len(quadrature(grid, kernel)[0]) / grid.size
            t_cyl = timed(lambda: cg.coarse_grain(snap, grid, kernel, fields=fields), 3, cpu=True)[2]
            t_cart = timed(lambda: cg.coarse_grain(snap, cart, kernel, fields=fields), 3, cpu=True)[2]
            print(f"{label}, {grid.size}, {per_node:.1f}, {t_cyl / t_cart:.1f}")


if __name__ == "__main__":
    main()
