"""The particle fields alone on W1 (46^3 lattice, XYZ grid 46^3, Gaussian w = 1, cutoff 3, truncated): s per frame.

    python benchmarks/bench_particle_fields.py [--repeat 7] [--threads 1,2] [--n 46] [--vectors wide,narrow]

Times coarse_grain with fields=("density",) and ("density", "momentum", "momentum_flux") (one point scatter
of 1 and 10 values per particle). Medians (and minima) of --repeat runs after one warm-up. To compare two
trees, run this alternately with PYTHONPATH set to each (the machine is shared: interleave, take medians).
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cgbound as cg  # noqa: E402
from cgbound import _engine  # noqa: E402
from common import header, thread_list, timed  # noqa: E402
from workloads import lattice  # noqa: E402

SETS = {"density": ("density",), "rho+p+k": ("density", "momentum", "momentum_flux")}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--threads", default="1,2")
    parser.add_argument("--n", type=int, default=46)
    parser.add_argument("--vectors", default="wide", help="wide (the default build) and/or narrow (AVX2/baseline)")
    args = parser.parse_args()
    snap = lattice(n=args.n)
    grid = cg.Grid(snap.box, (args.n,) * 3)
    kernel = cg.Gaussian(1.0, cutoff=3.0, normalize="truncated")
    for vectors in args.vectors.split(","):
        previous = _engine.set_wide_vectors(vectors == "wide")
        try:
            for nt in thread_list(args.threads):
                print(header(nt, f"{snap.n_particles} particles, grid {args.n}^3; medians of {args.repeat}"))
                for name, fields in SETS.items():
                    with cg.threads(nt):
                        med, best = timed(lambda: cg.coarse_grain(snap, grid, kernel, fields=fields), args.repeat,
                                          warmup=1)
                    print(f"{vectors:<7}threads {nt}  {name:<9}{med:>9.4f} s  (min {best:.4f})", flush=True)
        finally:
            _engine.set_wide_vectors(previous)


if __name__ == "__main__":
    main()
