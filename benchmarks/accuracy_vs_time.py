"""What accuracy costs in time: sweep the knobs of the Gaussian (cutoff, normalisation, line integrals),
the kernel, the grid spacing and the width, against a converged reference (see accuracy_study.py).

    python benchmarks/accuracy_vs_time.py [--quick] [--repeat 3] [--csv out.csv] [--plot out.png]
                                          [--data snapshots.h5 [--frame -1]] [--sweeps cutoff,line,kernel,spacing]

Data: a generated dense packing on a rough fixed base (benchmarks/packing.py, fixed seed), or one frame of
a cgbound HDF5 snapshot file (--data). Prints the CPU model and thread count with the table.
"""
import argparse
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="CI size: small packing, fewer widths (< 30 s)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per setting; the median is reported")
    parser.add_argument("--csv", help="write the table as CSV")
    parser.add_argument("--plot", help="write the time-versus-error PNG")
    parser.add_argument("--data", help="cgbound HDF5 snapshot file (cgbound.readers.HDF5Snapshots)")
    parser.add_argument("--frame", type=int, default=-1, help="frame of --data (default: the last)")
    parser.add_argument("--size", type=float, help="side of the generated packing in diameters")
    parser.add_argument("--sweeps", default="cutoff,line,kernel,spacing")
    parser.add_argument("--threads", type=int, help="threads of the C core (OMP_NUM_THREADS, or "
                        "cgbound.set_num_threads where it exists); 1 is steadier on a shared machine")
    args = parser.parse_args(argv)
    if args.threads:
        # before cgbound (and its OpenMP runtime) is loaded: libgomp reads the variable at start-up
        os.environ["OMP_NUM_THREADS"] = str(args.threads)
    sys.path.insert(0, HERE)
    import accuracy_study as study
    if args.threads and hasattr(study.cg, "set_num_threads"):
        study.cg.set_num_threads(args.threads)
    config = study.QUICK if args.quick else study.FULL
    size = args.size or config["size"]
    snap, d = study.load_snapshot(args.data, args.frame, size=size)
    print(f"# {study.machine_line()}")
    print(f"# data: {args.data or f'generated packing, side {size:g} d'}: {snap}; d = {d:g}; "
          f"reference: Gaussian cutoff {study.REFERENCE_CUTOFF:g}w, exact erf; median of {args.repeat} runs")
    print(f"# line_quadrature option: {'yes' if study.has_line_quadrature() else 'no'}; "
          f"current DEFAULT_GAUSSIAN_CUTOFF = {study.DEFAULT_GAUSSIAN_CUTOFF:g}")
    rows = study.run_study(snap, d, config, repeat=args.repeat, sweeps=tuple(args.sweeps.split(",")))
    front = study.pareto_front(study.base_rows(rows, config["base_w_over_d"], config["base_h_over_w"]))
    print("# Pareto front (base width and grid): " + "; ".join(r["setting"] for r in front))
    if args.csv:
        study.write_csv(rows, args.csv)
        print(f"# wrote {args.csv}")
    if args.plot:
        study.plot(rows, args.plot, config, title=f"accuracy versus time ({study.cpu_model()})")
        print(f"# wrote {args.plot}")


if __name__ == "__main__":
    main()
