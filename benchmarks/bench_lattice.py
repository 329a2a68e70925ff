"""W1 (46^3 XYZ grid) and W2 (Z profile of 100 nodes) on the 46^3 lattice: wall time per frame.

    python benchmarks/bench_lattice.py [--repeat 3] [--workloads W1,W2] [--threads 1,2]
                                       [--kernels g0.5,g1.0,lucy] [--line exact,2,3] [--per-node]
                                       [--vectors wide,narrow] [--plot out.png]

Fields: density, momentum, momentum flux and contact stress. For every workload, kernel, line-integral
method (Gaussian only) and thread count: the median (and minimum) of --repeat runs of one frame,
CPU time of the process (all threads) and particles per second. --per-node also times the straightforward per-node evaluation (every node
of each stencil evaluated on its own, exact line integrals), the baseline of the "10x" target. --vectors narrow
times the AVX2/baseline build of the separable path on a CPU that has AVX-512 (wide: the default build).
Prints the CPU model, core count, thread count and load average with every table.
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cgbound as cg  # noqa: E402
from cgbound import _engine  # noqa: E402
from common import header, save_plot, thread_list, timed  # noqa: E402
from workloads import lattice  # noqa: E402

FIELDS = ("density", "momentum", "momentum_flux", "contact_stress")
KERNELS = {"g0.5": ("Gaussian w=0.5 c=3w", lambda lq: cg.Gaussian(0.5, cutoff=1.5, line_quadrature=lq)),
           "g1.0": ("Gaussian w=1.0 c=3w", lambda lq: cg.Gaussian(1.0, cutoff=3.0, line_quadrature=lq)),
           "lucy": ("Lucy c=1.5", lambda lq: cg.Lucy(1.5))}


def parse_line(text):
    return [x if x in ("exact", "auto") else int(x) for x in text.split(",") if x]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--workloads", default="W1,W2")
    parser.add_argument("--threads", default="2", help="comma-separated thread counts (default 2)")
    parser.add_argument("--kernels", default="g0.5,g1.0,lucy", help=f"some of {','.join(KERNELS)}")
    parser.add_argument("--line", default="exact", help="line-integral methods of the Gaussian: exact, auto and/or n")
    parser.add_argument("--per-node", action="store_true", help="also time the straightforward per-node path")
    parser.add_argument("--vectors", default="wide", help="wide (the default build) and/or narrow (AVX2/baseline)")
    parser.add_argument("--plot", help="write a bar chart of the medians to this PNG")
    args = parser.parse_args()
    builds = args.vectors.split(",")
    if not builds or any(b not in ("wide", "narrow") for b in builds):
        parser.error(f"--vectors: expected wide and/or narrow, got {args.vectors!r}")
    snap = lattice()
    box = snap.box
    grids = {"W1": cg.Grid(box, (46, 46, 46)), "W2": cg.Grid(box, (1, 1, 100), average=("x", "y"))}
    rows = []
    for vectors in builds:
        previous = _engine.set_wide_vectors(vectors == "wide")
        try:
            run_tables(args, snap, grids, thread_list(args.threads), rows, vectors)
        finally:
            _engine.set_wide_vectors(previous)
    if args.plot:
        plot(args.plot, rows)


def run_tables(args, snap, grids, nt_list, rows, vectors):
    for nt in nt_list:
        print(header(nt))
        print(f"# {snap.n_particles} particles, {len(snap.contacts)} contacts; fields: {', '.join(FIELDS)}; "
              f"medians of {args.repeat} runs")
        print(f"{'workload':<9}{'kernel':<22}{'line':<7}{'path':<10}{'median s/frame':>15}{'min':>9}"
              f"{'cpu s':>9}{'particles/s':>14}")
        for name in args.workloads.split(","):
            grid = grids[name]
            for key in args.kernels.split(","):
                label, make = KERNELS[key]
                methods = parse_line(args.line) if key != "lucy" else ["-"]
                for lq in methods:
                    paths = ["separable", "per-node"] if args.per_node and key != "lucy" else ["default"]
                    for path in paths:
                        kernel = make("exact" if lq == "-" else lq)
                        if path == "per-node":
                            kernel._per_node = True          # internal switch: the straightforward evaluation
                        with cg.threads(nt):
                            med, best, cpu = timed(lambda: cg.coarse_grain(snap, grid, kernel, fields=FIELDS),
                                                   args.repeat, cpu=True)
                        rows.append((name, label, str(lq), f"{path} {vectors}", nt, med))
                        print(f"{name:<9}{label:<22}{str(lq):<7}{path:<10}{med:>15.3f}{best:>9.3f}{cpu:>9.3f}"
                              f"{snap.n_particles / med:>14.3g}", flush=True)


def plot(path_png, rows):
    if rows:
        series = {}
        for name, label, lq, path, nt, med in rows:
            key = f"{name} {label} {lq} {path}"
            xs, ys = series.setdefault(key, ([], []))
            xs.append(nt)
            ys.append(med)
        save_plot(path_png, "W1/W2 lattice, s per frame", "threads", "median s/frame", series, logy=True)


if __name__ == "__main__":
    main()
