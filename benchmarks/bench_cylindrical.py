"""Cost of a CylindricalGrid relative to Cartesian Points with the same node count.

    python benchmarks/bench_cylindrical.py [--silo [--z-averaged]] [--repeat 3]

Particles (random, 20,000): a ring-averaged node of the θ quadrature is N(r) Cartesian point evaluations
(times the z points when z is averaged), so the expected ratio is the mean number of quadrature points per
node; this prints it and the timed ratio (CPU time of one-thread runs, median of --repeat; interleaved).

--silo: the shipped silo frame (tests/data/lammps/silo: 2000 particles, 4742 contacts), density and the
contact stress on notebook 06's θ-averaged RZ grid (23 x 90 nodes, exact ring integrals) against Cartesian
Points at the same (r, 0, z) nodes, for the Gaussian w = 0.5 (cutoff 5w) and Lucy (cutoff 1.5); wall and CPU
seconds on the default threads.

--silo --z-averaged: the same frame on the θ- and z-averaged radial grid (23 rings over the whole height),
density, stress and the extended stress (its rays), against Points at the 23 (r, 0, 20) nodes.
"""
import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cgbound as cg  # noqa: E402
from cgbound.cylindrical_fields import quadrature  # noqa: E402
from common import header, timed  # noqa: E402


def silo(repeat, z_averaged=False, n_r=23):
    from cgbound.paper.scenes import SILO_TIMESTEP
    from cgbound.paper.scenes.lammps import PAIR_VALUES
    from cgbound.readers.lammps import LammpsReader
    data = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tests", "data", "lammps", "silo")
    frames = LammpsReader(os.path.join(data, "frames.atoms.dump.gz"), os.path.join(data, "frames.pairs.dump.gz"),
                          pair_values=PAIR_VALUES, walls=["wall0", "wall1"], body_force=(0.0, 0.0, -1.0),
                          dt=SILO_TIMESTEP, units="mercury")
    snap = frames[len(frames) - 1]
    grid = cg.CylindricalGrid(snap.box, axis_point=(0.0, 0.0, 0.0), axis="z", r=(0.0, 5.5, n_r), theta=None,
                              z=None if z_averaged else (-1.0, 41.0, 90))
    if z_averaged:
        cart = cg.Points(np.c_[grid.r, np.zeros_like(grid.r), np.full_like(grid.r, 20.0)])
        fields = ("density", "stress", "extended_stress")
    else:
        cart = cg.Points(grid.coordinates.reshape(-1, 3))
        fields = ("density", "stress")
    print(header())
    print(f"# silo frame: {snap}; {grid.size} nodes; fields {fields}; median of {repeat}")
    what = "R (θ- and z-averaged)" if z_averaged else "RZ (θ-averaged)"
    print(f"| kernel | CylindricalGrid {what} s | Points at the same nodes s | ratio |")
    print("|---|---|---|---|")
    for label, kernel in (("Gaussian w=0.5, cutoff 5w", cg.Gaussian(0.5)), ("Lucy cutoff 1.5", cg.Lucy(1.5))):
        t_cyl, t_cart = [], []
        for _ in range(repeat):
            for where, times in ((grid, t_cyl), (cart, t_cart)):
                start = time.perf_counter()
                cg.coarse_grain(snap, where, kernel, fields=fields)
                times.append(time.perf_counter() - start)
        a, b = sorted(t_cyl)[len(t_cyl) // 2], sorted(t_cart)[len(t_cart) // 2]
        print(f"| {label} | {a:.2f} | {b:.3f} | {a / b:.0f}x |")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--silo", action="store_true", help="the shipped silo frame with its contact stress")
    parser.add_argument("--z-averaged", action="store_true", help="with --silo: the z-averaged radial grid")
    parser.add_argument("--n-r", type=int, default=23, help="with --silo: rings (23, notebook 06's)")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    if args.silo:
        return silo(args.repeat, args.z_averaged, args.n_r)
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
