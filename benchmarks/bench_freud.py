"""W4: density only, cgbound side by side with freud's density.GaussianDensity, at 1 and 2 threads.

    python benchmarks/bench_freud.py [--repeat 5] [--threads 1,2] [--widths 0.5,1.0] [--plot out.png]

Same particles (the W1 lattice, 97,336 spheres), same 46^3 grid of cell-centred nodes, same width and
cutoff (3w), periodic box (freud's boxes are periodic). freud (pip install freud-analysis) computes in
single precision; the table also gives the largest difference relative to the peak density, to show
that both compute the same field. Medians of --repeat runs, after one untimed warm-up run each.
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cgbound as cg  # noqa: E402
from common import header, save_plot, thread_list, timed  # noqa: E402
from workloads import lattice  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--threads", default="1,2")
    parser.add_argument("--widths", default="0.5,1.0")
    parser.add_argument("--plot")
    args = parser.parse_args()
    try:
        import freud
    except ImportError:
        sys.exit("freud is not installed (pip install freud-analysis): W4 needs it")
    snap = lattice()
    L = float(snap.box.upper[0] - snap.box.lower[0])
    box = cg.Box(snap.box.lower, snap.box.upper, periodic=(True, True, True))
    pos = np.asarray(snap.positions)
    particles = cg.Snapshot(pos, None, np.ones(len(pos)), box=box)
    n = 46
    grid = cg.Grid(box, (n, n, n))
    fbox = freud.box.Box.cube(L)
    fpos = (pos - (np.asarray(box.lower) + 0.5 * L)).astype(np.float32)   # freud's box is centred on 0
    series = {}
    for nt in thread_list(args.threads):
        freud.parallel.set_num_threads(nt)
        print(header(nt, extra=f"freud {freud.__version__} with {freud.parallel.get_num_threads()} threads"))
        print(f"# W4: {len(pos)} particles, {n}^3 grid, density only, cutoff 3w; medians of {args.repeat} runs")
        print(f"{'width':<7}{'cgbound s':>11}{'freud s':>10}{'freud/cgbound':>15}{'cgbound cpu s':>15}"
              f"{'freud cpu s':>13}{'cgbound particles/s':>21}{'max |diff|/peak':>17}")
        for w in (float(x) for x in args.widths.split(",")):
            kernel = cg.Gaussian(w, cutoff=3 * w)
            gd = freud.density.GaussianDensity(n, 3 * w, w)

            def run_cgbound():
                return cg.coarse_grain(particles, grid, kernel, fields=("density",)).density

            with cg.threads(nt):
                t_cg, _, c_cg = timed(run_cgbound, args.repeat, warmup=1, cpu=True)
                ours = run_cgbound()
            t_fr, _, c_fr = timed(lambda: gd.compute((fbox, fpos)), args.repeat, warmup=1, cpu=True)
            theirs = np.asarray(gd.density, float)
            diff = np.abs(ours - theirs).max() / ours.max()
            print(f"{w:<7g}{t_cg:>11.4f}{t_fr:>10.4f}{t_fr / t_cg:>15.2f}{c_cg:>15.4f}{c_fr:>13.4f}"
                  f"{len(pos) / t_cg:>21.3g}{diff:>17.1e}", flush=True)
            for name, t in (("cgbound", t_cg), ("freud", t_fr)):
                xs, ys = series.setdefault(f"{name} w={w:g}", ([], []))
                xs.append(nt)
                ys.append(t)
    if args.plot:
        save_plot(args.plot, "W4 density on a 46^3 grid (97,336 particles)", "threads", "median s/frame", series,
                  logy=True)


if __name__ == "__main__":
    main()
