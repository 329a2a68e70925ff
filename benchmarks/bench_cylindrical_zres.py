"""Cost and accuracy of the exact z-averaged line integrals on θ-RESOLVED z-averaged CylindricalGrids.

    python benchmarks/bench_cylindrical_zres.py [--repeat 3] [--n-theta 16] [--n-r 12]

The shipped silo frame (tests/data/lammps/silo: 2000 particles, 4742 contacts, walls), grid r = (0, 5.5, n_r),
θ = n_theta, z averaged over the box. The contact stress's segments ("sb"), the boundary stress's ("sw") and the
extended stress's rays ("sx"): the exact path (cgbound.cylindrical_axial.axial_line_integrals) against the rule
it replaced (the Cartesian engine at z_points(L, kernel) Gauss-Legendre points per node, reduced with
cylindrical_fields.quadrature's weights), CPU seconds of one thread, median of --repeat, interleaved; and the
former rule's error against the exact sums (relative to each primary's largest component).
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cgbound as cg  # noqa: E402
from cgbound.cylindrical_axial import axial_line_integrals  # noqa: E402
from cgbound.cylindrical_fields import check_ring_arguments, quadrature, rotate, z_points  # noqa: E402
from cgbound.primaries import compute_primaries  # noqa: E402
from common import header, timed  # noqa: E402

NEEDED = {"sb", "sw", "sx"}


def silo_frame():
    from cgbound.paper.scenes import SILO_TIMESTEP
    from cgbound.paper.scenes.lammps import PAIR_VALUES
    from cgbound.readers.lammps import LammpsReader
    data = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tests", "data", "lammps", "silo")
    frames = LammpsReader(os.path.join(data, "frames.atoms.dump.gz"), os.path.join(data, "frames.pairs.dump.gz"),
                          pair_values=PAIR_VALUES, walls=["wall0", "wall1"], body_force=(0.0, 0.0, -1.0),
                          dt=SILO_TIMESTEP, units="mercury")
    return frames[len(frames) - 1]


def former_rule(job, grid):
    """The replaced rule: the Cartesian engine at Gauss-Legendre points in z, rotated and averaged per node."""
    positions, angles, weights, starts = quadrature(grid, job.kernel)
    sums = compute_primaries(job.snapshot, cg.Points(positions), job.kernel, NEEDED, np.zeros(3), job.split)
    basis = grid.basis(angles)
    out = {}
    for name, value in sums.items():
        local = rotate(np.asarray(value).reshape(-1, 3, 3), 2, basis) * weights[:, None, None]
        out[name] = np.add.reduceat(local, starts, axis=0)
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--n-theta", type=int, default=16)
    parser.add_argument("--n-r", type=int, default=12)
    args = parser.parse_args()
    snap = silo_frame()
    grid = cg.CylindricalGrid(snap.box, axis_point=(0.0, 0.0, 0.0), axis="z", r=(0.0, 5.5, args.n_r),
                              theta=args.n_theta)
    print(header(threads=1, extra=f"silo frame {snap}; {grid.size} nodes (θ resolved, z averaged)"))
    print("| kernel | exact s | former rule s (z points) | ratio | former rule's error sb / sw / sx |")
    print("|---|---|---|---|---|")
    lo, hi = grid.z_extent
    with cg.threads(1):
        for label, kernel in (("Gaussian w=0.5, cutoff 5w", cg.Gaussian(0.5)),
                              ("Gaussian w=0.5, cutoff 3w", cg.Gaussian(0.5, cutoff=1.5)),
                              ("Lucy cutoff 1.5", cg.Lucy(1.5)), ("Heaviside cutoff 1.0", cg.Heaviside(1.0))):
            job = check_ring_arguments(snap, grid, kernel, ("contact_stress", "boundary_stress", "extended_stress"))
            t_new, t_old = [], []
            for _ in range(args.repeat):                 # interleaved
                t_new.append(timed(lambda: axial_line_integrals(job, grid, NEEDED), 1, cpu=True)[2])
                t_old.append(timed(lambda: former_rule(job, grid), 1, cpu=True)[2])
            exact, old = axial_line_integrals(job, grid, NEEDED), former_rule(job, grid)
            errors = " / ".join(f"{np.abs(old[n] - exact[n]).max() / np.abs(exact[n]).max():.1e}"
                                for n in ("sb", "sw", "sx"))
            a, b = float(np.median(t_new)), float(np.median(t_old))
            print(f"| {label} | {a:.2f} | {b:.2f} ({z_points(hi - lo, kernel)}) | {a / b:.2f} | {errors} |")


if __name__ == "__main__":
    main()
