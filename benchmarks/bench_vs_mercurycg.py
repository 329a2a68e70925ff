"""cgbound side by side with MercuryCG (MercuryDPM's serial coarse-graining tool) on the W1 lattice, one run.

    python benchmarks/bench_vs_mercurycg.py [--mercurycg PATH] [--repeat 3] [--mercury-repeat 3]
                                            [--threads 1,2] [--kernels gauss,gauss-auto,gauss5,lucy]
                                            [--workdir DIR]

W1: the 46^3 simple-cubic lattice of benchmarks/workloads.py (97,336 particles, 285,660 contacts) on an XYZ grid
of 46^3 nodes; fields density, momentum, momentum flux and contact stress. The lattice is written as two
MercuryDPM frames (NAME.data, NAME.fstat, with cgbound.readers.mercury's writer) and MercuryCG (PATH, optional:
without it only cgbound is timed) is run on them with -coordinates O (reading only) and -coordinates XYZ for each
kernel. MercuryCG prints no timing of its own, so its kernel time is a difference of whole runs:

    kernel time per frame = (best XYZ run - best reading run) / 2

where a run is the wall time of the whole process, the reading run (-coordinates O: the files read, the contacts
assigned, no grid) is the same reading and set-up the XYZ run does, and the difference over the 2 frames is what
the XYZ run spends on its grid (evaluating the kernel at the nodes and writing the .stat file). Each run is repeated
--mercury-repeat times (default 3) and the best taken: a reading run slowed by a busy neighbour would otherwise make
the difference too small (the reading run is the larger share of a Lucy run), so every run's wall and CPU time
(user + system of the child) are printed too, and the kernel time from the CPU times beside it.
cgbound coarse-grains the same snapshot in this process: the median of --repeat runs of one frame per thread
count.

Kernels (MercuryCG's Gauss has cutoff 3w, renormalised over the cut ball):
  gauss       Gaussian w = 1.0, cutoff 3w, exact line integrals (MercuryCG -function Gauss -w 1.0)
  gauss-auto  the same with line_quadrature="auto" (MercuryCG's run of gauss)
  gauss5      Gaussian w = 1.0 at cgbound's default cutoff 5w (no MercuryCG counterpart)
  lucy        Lucy, cutoff 1.5 (MercuryCG -function Lucy -w 1.5)
Prints the CPU model, core count, thread count, vector build and load average with the table.
"""
import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import numpy as np  # noqa: E402

import cgbound as cg  # noqa: E402
from cgbound.readers.mercury import write_mercury  # noqa: E402
from common import header, thread_list, timed  # noqa: E402
from workloads import lattice  # noqa: E402

FIELDS = ("density", "momentum", "momentum_flux", "contact_stress")
N = 46
NAME = "W1"
# key: (label, cgbound kernel, MercuryCG -function and -w, or None; the key whose MercuryCG run it shares)
KERNELS = {
    "gauss": ("Gaussian w=1.0 c=3w exact", lambda: cg.Gaussian(1.0, cutoff=3.0, normalize="truncated"),
              ("Gauss", 1.0)),
    "gauss-auto": ("Gaussian w=1.0 c=3w auto", lambda: cg.Gaussian(1.0, cutoff=3.0, normalize="truncated",
                                                                   line_quadrature="auto"), ("Gauss", 1.0)),
    "gauss5": ("Gaussian w=1.0 c=5w exact", lambda: cg.Gaussian(1.0), None),
    "lucy": ("Lucy c=1.5", lambda: cg.Lucy(1.5), ("Lucy", 1.5)),
}


def write_frames(snap, directory):
    """Two MercuryDPM frames of the snapshot (times 0 and 1), with radii 0.5 (d = 1)."""
    frames = [cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box, contacts=snap.contacts,
                          radii=np.full(snap.n_particles, 0.5), time=float(t)) for t in (0.0, 1.0)]
    write_mercury(frames, os.path.join(directory, NAME + ".data"), os.path.join(directory, NAME + ".fstat"))


def children_cpu():
    """User + system CPU seconds of this process' finished children."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_mercurycg(exe, directory, args, repeat):
    """Wall and CPU times (lists, one per run) of `repeat` runs of MercuryCG NAME args (in directory)."""
    walls, cpus = [], []
    for _ in range(repeat):
        out = os.path.join(directory, "out.stat")
        start, start_cpu = time.perf_counter(), children_cpu()
        proc = subprocess.run([exe, NAME] + args + ["-o", out], cwd=directory, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True)
        walls.append(time.perf_counter() - start)
        cpus.append(children_cpu() - start_cpu)
        if proc.returncode != 0:
            raise RuntimeError(f"MercuryCG {' '.join(args)} failed ({proc.returncode}):\n{proc.stdout[-2000:]}")
    return walls, cpus


def run_times(label, walls, cpus):
    """One line of raw run times, best first."""
    return (f"# MercuryCG {label}: wall " + " ".join(f"{w:.2f}" for w in walls) + " s; CPU "
            + " ".join(f"{c:.2f}" for c in cpus) + f" s (best wall {min(walls):.2f}, best CPU {min(cpus):.2f})")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--mercurycg", help="path of the MercuryCG executable (optional)")
    parser.add_argument("--repeat", type=int, default=3, help="cgbound runs per kernel and thread count")
    parser.add_argument("--mercury-repeat", type=int, default=3,
                        help="MercuryCG runs of the reading and of each kernel, the best taken (~8-20 s each)")
    parser.add_argument("--threads", default="2", help="comma-separated cgbound thread counts (default 2)")
    parser.add_argument("--kernels", default="gauss,gauss-auto,gauss5,lucy", help=f"some of {','.join(KERNELS)}")
    parser.add_argument("--workdir", help="where to write the MercuryDPM files (default: a temporary directory)")
    args = parser.parse_args()
    kernels = [k for k in args.kernels.split(",") if k]
    unknown = [k for k in kernels if k not in KERNELS]
    if unknown or not kernels:
        parser.error(f"--kernels: expected some of {','.join(KERNELS)}, got {args.kernels!r}")
    if args.repeat < 1 or args.mercury_repeat < 1:
        parser.error(f"--repeat and --mercury-repeat: expected >= 1, got {args.repeat} and {args.mercury_repeat}")
    threads = thread_list(args.threads)
    if not threads or min(threads) < 1:
        parser.error(f"--threads: expected positive integers, got {args.threads!r}")
    exe = None
    if args.mercurycg:
        exe = os.path.abspath(args.mercurycg)
        if not (os.path.isfile(exe) and os.access(exe, os.X_OK)):
            parser.error(f"--mercurycg: expected an executable file, got {args.mercurycg!r}")

    snap = lattice(n=N)
    grid = cg.Grid(snap.box, (N, N, N))
    mercury = {}
    if exe:
        directory = args.workdir or tempfile.mkdtemp(prefix="cgbound_w1_")
        os.makedirs(directory, exist_ok=True)
        try:
            write_frames(snap, directory)
            upper = float(snap.box.upper[0])
            xyz = ["-coordinates", "XYZ", "-n", str(N), "-x", "0", f"{upper}", "-y", "0", f"{upper}",
                   "-z", "0", f"{upper}"]
            print(f"# MercuryCG: {exe}; kernel time per frame = (best XYZ run - best reading run) / 2, runs of "
                  f"2 frames, best of {args.mercury_repeat} each")
            reading = run_mercurycg(exe, directory, ["-coordinates", "O"], args.mercury_repeat)
            print(run_times("reading run (-coordinates O)", *reading), flush=True)
            runs = {}
            for key in kernels:
                spec = KERNELS[key][2]
                if spec is None or spec in runs:
                    continue
                function, w = spec
                runs[spec] = run_mercurycg(exe, directory, xyz + ["-function", function, "-w", str(w)],
                                           args.mercury_repeat)
                print(run_times(f"XYZ run -function {function} -w {w}", *runs[spec]), flush=True)
                kernel_wall = (min(runs[spec][0]) - min(reading[0])) / 2.0
                kernel_cpu = (min(runs[spec][1]) - min(reading[1])) / 2.0
                print(f"# MercuryCG {function} kernel time per frame: {kernel_wall:.3f} s from wall times, "
                      f"{kernel_cpu:.3f} s from CPU times", flush=True)
            mercury = {key: (min(runs[KERNELS[key][2]][0]) - min(reading[0])) / 2.0 for key in kernels
                       if KERNELS[key][2] in runs}
        finally:
            if not args.workdir:
                shutil.rmtree(directory, ignore_errors=True)

    print(header(threads=",".join(map(str, threads))))
    print(f"# W1: {snap.n_particles} particles, {len(snap.contacts.i)} contacts, XYZ grid {N}^3; fields: "
          f"{', '.join(FIELDS)}; cgbound medians of {args.repeat} runs of one frame")
    cols = "".join(f"{f'cgbound {t}T s':>14}{'ratio':>8}" for t in threads)
    print(f"{'kernel':28}{'MercuryCG s':>12}{cols}")
    for key in kernels:
        label, make, _ = KERNELS[key]
        kernel = make()
        row = f"{label:28}" + (f"{mercury[key]:12.3f}" if key in mercury else f"{'-':>12}")
        for t in threads:
            with cg.threads(t):
                median, _ = timed(lambda: cg.coarse_grain(snap, grid, kernel, fields=FIELDS), args.repeat, warmup=1)
            ratio = f"{mercury[key] / median:7.1f}x" if key in mercury else f"{'-':>8}"
            row += f"{median:14.3f}{ratio}"
        print(row, flush=True)
    print(f"# load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
