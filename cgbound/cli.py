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


KERNELS = ("gaussian", "lucy", "heaviside")


def _ints(text):
    return tuple(int(x) for x in text.replace("x", ",").split(",") if x.strip())


def run(args):
    import os
    import time

    from . import CoarseGrain, Gaussian, Grid, Heaviside, Lucy
    from .readers import open_dataset

    options = {}
    if args.format == "mercury" or (args.format is None and args.input.endswith(".data")):
        options = dict(fstat_path=args.pairs, density=args.density)
        if args.gravity:
            options["body_force"] = [float(x) for x in args.gravity.split(",")]
    elif args.format == "liggghts":
        options = dict(pairs=args.pairs, dimension=args.dimension,
                       fixed_types=_ints(args.fixed_types) if args.fixed_types else ())
        if args.gravity:
            options["body_force"] = [float(x) for x in args.gravity.split(",")]
    elif args.format == "lammps":
        options = dict(pairs=args.pairs, pair_style=args.pair_style, dimension=args.dimension,
                       fixed_types=_ints(args.fixed_types) if args.fixed_types else (),
                       walls=tuple(w for w in (args.walls or "").split(",") if w))
        if args.gravity:
            options["body_force"] = [float(x) for x in args.gravity.split(",")]
    data = open_dataset(args.input, format=args.format, **options)
    if len(data) == 0:
        raise SystemExit(f"{args.input}: no snapshots")
    first = data[0]
    if args.kernel == "gaussian":
        kernel = Gaussian(args.width, cutoff=args.cutoff, normalize=args.normalize)
    elif args.kernel == "lucy":
        kernel = Lucy(args.cutoff if args.cutoff is not None else 3 * args.width)
    else:
        kernel = Heaviside(args.cutoff if args.cutoff is not None else args.width)
    average = tuple(a for a in args.average.split(",") if a) if args.average else ()
    grid = Grid(first.box, _ints(args.grid), average=average)
    fields = tuple(f for f in args.fields.split(",") if f)
    time_average = args.time_average
    if time_average not in ("mean", "none"):
        time_average = float(time_average)
    start = time.perf_counter()
    analysis = CoarseGrain(data, grid, kernel, fields=fields, convention=args.convention,
                           time_average=time_average).run(args.start, args.stop, args.step, verbose=not args.quiet)
    out = analysis.results
    elapsed = time.perf_counter() - start
    ext = os.path.splitext(args.output)[1].lower()
    if ext in (".h5", ".hdf5"):
        out.to_hdf5(args.output, provenance={"input": os.path.abspath(args.input), "command": "cgbound run"})
    elif ext == ".npz":
        out.to_npz(args.output)
    elif ext == ".vtk":
        out.to_vtk(args.output, frame=0 if time_average not in ("mean",) else None)
    else:
        raise SystemExit(f"--output: expected a .h5, .npz or .vtk file name, got {args.output!r}")
    if args.png:
        import matplotlib
        matplotlib.use("Agg")
        from . import plot
        name = fields[0]
        if len(grid.resolved) == 1:
            ax = plot.profile(out, name)
        else:
            ax = plot.field_map(out, name)
        ax.figure.savefig(args.png, dpi=110)
    print(f"cgbound: {analysis.n_frames} frames of {first.n_particles} particles -> {', '.join(fields)} on "
          f"{grid!r} with {kernel!r} in {elapsed:.2f} s; wrote {args.output}")
    return 0


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

    r = sub.add_parser(
        "run", help="coarse-grain a dataset and write the fields",
        description="Read snapshots (cgbound HDF5, or LAMMPS dumps), coarse-grain them and write HDF5, .npz or VTK.",
        epilog="example: cgbound run chute.h5 --grid 1,1,400 --average x,y --width 0.25 "
               "--fields density,stress,interaction_force_density -o profile.h5 --png profile.png",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    r.add_argument("input", help="dataset to read (format from the extension unless --format is given)")
    r.add_argument("--format", choices=["hdf5", "lammps", "liggghts", "mdanalysis", "mercury"], help="input format (.h5 files are hdf5)")
    r.add_argument("--pairs", help="lammps/liggghts: the contact dump local file; mercury: the .fstat file")
    r.add_argument("--density", type=float, default=None, help="mercury: particle density (masses from radii)")
    r.add_argument("--pair-style", choices=["gran", "granular"], default="gran",
                   help="lammps: pair style family that wrote the contact dump")
    r.add_argument("--fixed-types", default="", help="lammps: atom types of fixed boundary particles, e.g. 2")
    r.add_argument("--walls", default="", help="lammps: IDs of fix wall/gran ... contacts, e.g. floor")
    r.add_argument("--gravity", default="", help="lammps: body force per unit mass, e.g. 0,0,-1")
    r.add_argument("--dimension", type=int, choices=[2, 3], default=3, help="lammps: dimension of the run")
    r.add_argument("-o", "--output", default="cgbound_fields.h5", help="output file: .h5, .npz or .vtk")
    r.add_argument("--kernel", choices=KERNELS, default="gaussian", help="coarse-graining kernel")
    r.add_argument("--width", type=float, default=0.25, help="Gaussian width w (also the default scale of the others)")
    r.add_argument("--cutoff", type=float, default=None,
                   help="support radius (Gaussian default 5 w; Lucy 3 w; Heaviside w)")
    r.add_argument("--normalize", choices=["full", "truncated"], default="full", help="Gaussian normalisation")
    r.add_argument("--grid", default="20,20,20", help="nodes per axis, e.g. 1,1,400 (averaged axes take 1)")
    r.add_argument("--average", default="", help="averaged axes, e.g. x,y")
    r.add_argument("--fields", default="density,velocity,stress", help="comma-separated field names")
    r.add_argument("--convention", choices=["tension", "compression"], default="tension", help="stress sign")
    r.add_argument("--time-average", default="mean", help="mean, none, or a Gaussian time width")
    r.add_argument("--start", type=int, default=None, help="first frame")
    r.add_argument("--stop", type=int, default=None, help="stop before this frame")
    r.add_argument("--step", type=int, default=None, help="frame step")
    r.add_argument("--png", default=None, help="also plot the first field (profile or map) to this PNG")
    r.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    r.set_defaults(func=run)
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
