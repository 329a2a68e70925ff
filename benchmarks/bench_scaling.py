"""W3: random packings from 1e3 particles up, at fixed density: wall time and peak memory against N.

    python benchmarks/bench_scaling.py [--max-n 1e6] [--repeat 3] [--threads 2] [--line exact] [--plot out.png]

Particles uniform in a non-periodic cube at number density 1 (d = 1, volume fraction pi/6), every
pair closer than 1 in contact (about 2 contacts per particle); a grid of unit spacing (about N nodes);
Gaussian w = 1 with cutoff 3w; fields density, momentum, momentum flux, contact stress (as W1).
Each N runs in its own process, so that the peak resident memory (ru_maxrss) is that of one N;
"python+numpy" is the peak of a process that only imports cgbound, for reference. N = 1e7 needs
--max-n 1e7 (and about 10 GB of memory).
"""
import argparse
import json
import os
import resource
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cgbound as cg  # noqa: E402
from common import header, save_plot, timed  # noqa: E402

FIELDS = ("density", "momentum", "momentum_flux", "contact_stress")


def packing(n, seed=0):
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    L = n ** (1.0 / 3.0)
    pos = rng.uniform(0.0, L, (n, 3))
    pairs = cKDTree(pos).query_pairs(1.0, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    normal = pos[i] - pos[j]
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    force = normal * rng.uniform(0.9, 1.1, i.size)[:, None]
    box = cg.Box([0, 0, 0], [L, L, L])
    contacts = cg.Contacts(i, j, force, 0.5 * (pos[i] + pos[j]))
    return cg.Snapshot(pos, rng.normal(scale=0.1, size=pos.shape), np.ones(n), box=box, contacts=contacts)


def one(n, repeat, threads, line):
    """Runs in a child process: prints one JSON line."""
    snap = packing(n)
    L = float(snap.box.upper[0])
    shape = max(int(round(L)), 1)
    grid = cg.Grid(snap.box, (shape, shape, shape))
    kernel = cg.Gaussian(1.0, cutoff=3.0, line_quadrature=line)
    with cg.threads(threads):
        med, best, cpu = timed(lambda: cg.coarse_grain(snap, grid, kernel, fields=FIELDS), repeat, cpu=True)
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(json.dumps({"n": n, "contacts": len(snap.contacts), "nodes": shape ** 3, "median": med, "min": best, "cpu": cpu,
                      "peak_mb": peak_mb}))


def child(args_list):
    out = subprocess.run([sys.executable, os.path.abspath(__file__)] + args_list, capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(out.stderr)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--max-n", type=float, default=1e6)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--line", default="exact")
    parser.add_argument("--plot")
    parser.add_argument("--one", type=int, help=argparse.SUPPRESS)   # internal: run one N in this process
    args = parser.parse_args()
    line = args.line if args.line == "exact" else int(args.line)
    if args.one:
        one(args.one, args.repeat, args.threads, line)
        return
    probe = subprocess.run([sys.executable, "-c", "import resource, cgbound; "
                            "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)"],
                           capture_output=True, text=True, cwd="/")
    print(header(args.threads, extra=f"line_quadrature={line}"))
    print(f"# W3: random packings at number density 1, unit grid spacing, Gaussian w=1 c=3w; fields "
          f"{', '.join(FIELDS)}; medians of {args.repeat} runs; python+numpy+cgbound alone: "
          f"{float(probe.stdout.strip() or 'nan'):.0f} MB")
    print(f"{'N':>10}{'contacts':>10}{'nodes':>10}{'median s':>11}{'cpu s':>9}{'us/particle':>13}{'particles/s':>13}"
          f"{'peak MB':>10}")
    ns, times, mems = [], [], []
    n = 1000
    while n <= args.max_n:
        r = child(["--one", str(n), "--repeat", str(args.repeat), "--threads", str(args.threads), "--line", args.line])
        print(f"{r['n']:>10}{r['contacts']:>10}{r['nodes']:>10}{r['median']:>11.4f}{r['cpu']:>9.3f}"
              f"{1e6 * r['median'] / n:>13.3f}"
              f"{n / r['median']:>13.3g}{r['peak_mb']:>10.0f}", flush=True)
        ns.append(n)
        times.append(r["median"])
        mems.append(r["peak_mb"])
        n *= 10
    if args.plot:
        save_plot(args.plot, "W3 scaling (time and peak memory against N)", "particles N", "s per frame / GB",
                  {"median s/frame": (ns, times), "peak memory (GB)": (ns, [m / 1024 for m in mems])},
                  logx=True, logy=True)


if __name__ == "__main__":
    main()
