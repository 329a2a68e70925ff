"""The ``cgbound`` command line."""
import argparse
import sys

import numpy as np


def _check_output_paths(args, names):
    """Refuse, before any work, output paths whose directory does not exist."""
    import os
    for name in names:
        path = getattr(args, name, None)
        if path:
            directory = os.path.dirname(os.path.abspath(path))
            if not os.path.isdir(directory):
                raise SystemExit(f"--{name}: directory {directory!r} does not exist")


def demo(args):
    """Fig. 3 on the shipped chute dataset: depth profiles, eq. (27), lithostatic balance, bed and surface."""
    import time

    _check_output_paths(args, ("output", "png"))
    from .kernels import Gaussian
    from .paper.datasets import chute_steady
    from .paper.profiles import DepthProfiles

    frames = chute_steady()
    start = time.perf_counter()
    profiles = DepthProfiles(width=args.width, kernel=Gaussian(args.width)).run(frames, verbose=not args.quiet)
    elapsed = time.perf_counter() - start
    first, last = frames[0], frames[len(frames) - 1]
    print(f"chute flow (LAMMPS, 26 degrees): {len(frames)} frames, t = {first.time:g} ... {last.time:g}, "
          f"{int(first.flowing.sum())} flowing + {int(first.fixed.sum())} base particles")
    print(f"depth profiles averaged over x, y, t with {profiles.kernel!r}: {len(profiles.z)} nodes in {elapsed:.2f} s")
    print(f"bed height      z = {profiles.bed:.3f}  (sigma'_zz within {100 * profiles.threshold:g} % of its maximum)")
    print(f"surface height  z = {profiles.surface:.3f}  (sigma'_zz down to {100 * profiles.threshold:g} % of it)")
    print(f"weight of the flow per unit area: {profiles.total_weight:.5g}")
    print(f"lithostatic error max |sigma'_zz - weight above z| / weight between bed and surface: "
          f"{100 * profiles.lithostatic_error:.2f} %  (sampling error of these frames, from "
          f"{profiles.blocks} block averages: {100 * profiles.lithostatic_standard_error:.2f} %)")
    expected = (first.masses[first.flowing] * -first.body_force[first.flowing, -1]).sum() / np.prod(first.box.lengths[:-1])
    mass_error = abs(profiles.total_weight / expected - 1)
    print(f"integral of rho g_z over z vs N m g cos(26) / area: relative difference {mass_error:.1e}")
    dense = None
    try:
        from .paper.datasets import chute_dense_profiles
        dense = chute_dense_profiles()
    except FileNotFoundError:
        pass
    if dense is not None:
        print(f"with the paper's sampling (profiles of {dense.n_frames} frames every t_c/2, shipped): lithostatic error "
              f"{100 * dense.lithostatic_error:.2f} %, bed z = {dense.bed:.3f}, surface z = {dense.surface:.3f}")
    profiles.to_hdf5(args.output)
    print(f"wrote {args.output}")
    if args.png:
        try:
            import matplotlib
        except ImportError:
            print("matplotlib is not installed: no PNG written", file=sys.stderr)
        else:
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt

            from ._atomic import atomic_write
            panels = [(profiles, f"{len(frames)} shipped frames, one per time unit")]
            if dense is not None:
                panels.append((dense, f"paper's sampling: {dense.n_frames} frames every $t_c/2$"))
            fig, axes = plt.subplots(1, len(panels), figsize=(4.6 * len(panels), 4.6), sharey=True,
                                     constrained_layout=True, squeeze=False)
            for ax, (prof, title) in zip(axes[0], panels):
                prof.plot(ax)
                ax.set_title(f"{title}\nw = {args.width:g} d, lithostatic error {100 * prof.lithostatic_error:.2f} %",
                             fontsize=9)
            atomic_write(args.png, lambda path: fig.savefig(path, dpi=110, format="png"), suffix=".png")
            print(f"wrote {args.png}")
    # the exit status checks what the shipped frames determine exactly: the weight carried by the
    # profiles (the lithostatic error itself is limited by sampling, see the note printed above)
    return 0 if mass_error < 1e-3 else 1


KERNELS = ("gaussian", "lucy", "heaviside")


def _ints(text):
    return tuple(int(x) for x in text.replace("x", ",").split(",") if x.strip())


def run(args):
    import os
    import time

    from . import CoarseGrain, Gaussian, Grid, Heaviside, Lucy
    from .readers import open_dataset

    _check_output_paths(args, ("output", "png"))
    options = {}
    if args.format == "mercury" or (args.format is None and args.input.endswith(".data")):
        options = dict(fstat_path=args.pairs, density=args.density)
    elif args.format == "liggghts":
        options = dict(pairs=args.pairs, dimension=args.dimension,
                       fixed_types=_ints(args.fixed_types) if args.fixed_types else ())
    elif args.format == "lammps":
        options = dict(pairs=args.pairs, pair_style=args.pair_style, dimension=args.dimension,
                       fixed_types=_ints(args.fixed_types) if args.fixed_types else (),
                       walls=tuple(w for w in (args.walls or "").split(",") if w))
    if args.gravity and options:  # the text formats take a body force; HDF5 and MDAnalysis data carry theirs
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
    p = sub.add_parser("demo", help="the paper's Fig. 3 on the shipped chute dataset (profiles, lithostatic check)",
                       description="Depth profiles of the shipped steady chute flow (LAMMPS, 1000 particles, 26 "
                                   "degrees) averaged over x, y and t: sigma_zz with and without the boundary "
                                   "correction (eq. 27), the weight of the flow, bed and surface heights, and "
                                   "the lithostatic error with its sampling error.",
                       epilog="example: cgbound demo --png fig3.png")
    p.add_argument("--width", type=float, default=0.25, help="Gaussian width w (default d/4 = 0.25)")
    p.add_argument("--output", default="cgbound_demo.h5", help="profiles file to write (default cgbound_demo.h5)")
    p.add_argument("--png", default=None, help="also plot the profiles to this PNG (needs matplotlib)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
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
