"""The ``cgbound`` command line."""
import argparse
import sys

import numpy as np


def demo(args):
    from . import Gaussian, Grid, coarse_grain, momentum_balance_residual
    from ._atomic import atomic_write
    from .demo import boundary_2d

    snap = boundary_2d()
    w = args.width
    grid = Grid(snap.box, (args.nodes, int(round(args.nodes * snap.box.lengths[1] / snap.box.lengths[0]))))
    kernel = Gaussian(w, cutoff=8 * w)
    out = coarse_grain(snap, grid, kernel, fields=("density", "stress", "interaction_force_density",
                                                   "body_force_density"))
    cell = float(np.prod(snap.box.lengths / np.array(grid.shape)))
    weight = -(snap.masses[snap.flowing][:, None] * snap.body_force[snap.flowing]).sum(axis=0)
    carried = out.interaction_force_density.reshape(-1, 2).sum(axis=0) * cell
    rng = np.random.default_rng(0)
    pts = snap.box.lower + rng.uniform(0, 1, (200, 2)) * snap.box.lengths
    res = momentum_balance_residual(snap, pts, kernel)
    from .plot import norm
    t_norm, sigma_norm = norm(out, "interaction_force_density"), norm(out, "stress")
    print(f"{snap!r}")
    print(f"kernel {kernel!r}, grid {grid.shape[0]} x {grid.shape[1]} nodes")
    print(f"weight of the flow           : {weight[1]:.12f}")
    print(f"integral of the IFD (x, z)   : {carried[0]:+.3e}, {carried[1]:.12f}")
    print(f"momentum balance, max |r|/scale at 200 random points: {res.relative.max():.2e}")
    print(f"max |t| = {t_norm.max():.4g}, max |eig sigma| = {sigma_norm.max():.4g}")

    def write(path):
        with open(path, "wb") as f:
            np.savez_compressed(f, x=grid.axis_coordinates[0], z=grid.axis_coordinates[1],
                                density=out.density, stress=out.stress,
                                interaction_force_density=out.interaction_force_density)
    atomic_write(args.output, write)
    print(f"wrote {args.output}")
    if args.png:
        try:
            import matplotlib
        except ImportError:
            print("matplotlib is not installed: no PNG written", file=sys.stderr)
        else:
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
            from . import plot
            fig, axes = plt.subplots(1, 2, figsize=(10, 3.6), constrained_layout=True)
            for ax, name in zip(axes, ("interaction_force_density", "stress")):
                plot.field_map(out, name, ax=ax)
                plot.particles(ax, snap)
            atomic_write(args.png, lambda path: fig.savefig(path, dpi=110, format="png"), suffix=".png")
            print(f"wrote {args.png}")
    ok = res.relative.max() < 1e-8 and abs(carried[1] - weight[1]) < 1e-8 * weight[1]
    return 0 if ok else 1


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="cgbound",
        description="Boundary-aware coarse graining of discrete-particle data.",
        epilog="example: cgbound demo --png demo.png")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("demo", help="coarse-grain the built-in Fig. 1 scene and check the momentum balance",
                       description="Coarse-grain the paper's Fig. 1 scene (five fixed, five flowing discs in "
                                   "static balance), print the checks and write the fields.",
                       epilog="example: cgbound demo --width 0.125 --png fig1.png")
    p.add_argument("--width", type=float, default=0.125, help="Gaussian width w (default d/8 = 0.125)")
    p.add_argument("--nodes", type=int, default=220, help="grid nodes along x (default 220)")
    p.add_argument("--output", default="cgbound_demo.npz", help="fields file to write (default cgbound_demo.npz)")
    p.add_argument("--png", default=None, help="also write the |t| and |sigma| maps as a PNG (needs matplotlib)")
    p.set_defaults(func=demo)
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
