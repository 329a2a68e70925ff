"""W1 (46^3 XYZ grid) and W2 (Z profile of 100 nodes) on the 46^3 lattice: wall time per frame.

    python benchmarks/bench_lattice.py [--repeat 3] [--workloads W1,W2]

Prints the CPU model and thread count with the table; medians of --repeat runs.
"""
import argparse
import os
import platform
import statistics
import time

import cgbound as cg
from workloads import lattice

FIELDS = ("density", "momentum", "momentum_flux", "contact_stress")


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--workloads", default="W1,W2")
    args = parser.parse_args()
    snap = lattice()
    box = snap.box
    kernels = [("Gaussian w=0.5 c=3w", cg.Gaussian(0.5, cutoff=1.5)), ("Gaussian w=1.0 c=3w", cg.Gaussian(1.0, cutoff=3.0)),
               ("Lucy c=1.5", cg.Lucy(1.5))]
    grids = {"W1": cg.Grid(box, (46, 46, 46)), "W2": cg.Grid(box, (1, 1, 100), average=("x", "y"))}
    threads = os.environ.get("OMP_NUM_THREADS", str(os.cpu_count()))
    print(f"# CPU: {cpu_model()}; cores: {os.cpu_count()}; OMP_NUM_THREADS: {threads}; "
          f"OpenMP build: {cg.have_openmp()}; cgbound {cg.__version__}")
    print(f"# {snap.n_particles} particles, {len(snap.contacts)} contacts; fields: {', '.join(FIELDS)}")
    print(f"{'workload':<9}{'kernel':<22}{'median s/frame':>15}{'min':>9}{'particles/s':>14}")
    for name in args.workloads.split(","):
        grid = grids[name]
        for label, kernel in kernels:
            times = []
            for _ in range(args.repeat):
                start = time.perf_counter()
                cg.coarse_grain(snap, grid, kernel, fields=FIELDS)
                times.append(time.perf_counter() - start)
            med = statistics.median(times)
            print(f"{name:<9}{label:<22}{med:>15.3f}{min(times):>9.3f}{snap.n_particles / med:>14.3g}", flush=True)


if __name__ == "__main__":
    main()
