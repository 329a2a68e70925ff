"""The Gaussian's exact contact stress on the W1 lattice, this tree against a baseline tree, interleaved.

    python benchmarks/bench_gauss_exact.py [--baseline TREE] [--cutoffs 3,5] [--threads 1,2] [--rounds 3]
                                           [--repeat 3]

W1 (or --workload jittered: its particles moved by up to 0.05, no contact along an axis): the 46^3 simple-cubic
lattice of benchmarks/workloads.py (285,660 contacts) on an XYZ grid of 46^3 nodes;
field: contact_stress alone; kernel: Gaussian w = 1.0, normalize="truncated", exact line integrals (the default
line_quadrature), at each cutoff (in w). Each measurement runs in a fresh process importing cgbound from a tree
(this one, or --baseline: another checkout with its extension built in place, e.g. a git worktree of main), and
the trees alternate round by round, so that a busy machine's slow minutes fall on both alike. Per round and tree:
the median wall time of --repeat calls (after one warm-up) and, for one thread, the median CPU time of the process
(steadier than wall time on a shared machine). Prints the CPU, cores, vector build and load average.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
THIS_TREE = os.path.dirname(HERE)


def worker(cutoff, threads, repeat, workload="w1"):
    """One measurement in this process: prints a JSON line {wall, cpu, header}."""
    sys.path.insert(0, HERE)
    import cgbound as cg
    from common import header, timed

    from workloads import lattice

    snap = lattice(n=46)
    grid = cg.Grid(snap.box, (46, 46, 46))
    if workload == "jittered":
        # every particle moved by up to 0.05 along each axis (fixed seed): the same contacts and grid, none along
        # a grid axis (the general exact path)
        import numpy as np

        rng = np.random.default_rng(1)
        pos = snap.positions + rng.uniform(-0.05, 0.05, snap.positions.shape)
        c = snap.contacts
        snap = cg.Snapshot(pos, snap.velocities, snap.masses, box=snap.box,
                           contacts=cg.Contacts(c.i, c.j, c.force, 0.5 * (pos[c.i] + pos[c.j])))
    kernel = cg.Gaussian(1.0, cutoff=cutoff, normalize="truncated")
    with cg.threads(threads):
        wall, _, cpu = timed(lambda: cg.coarse_grain(snap, grid, kernel, fields=("contact_stress",)), repeat,
                             warmup=1, cpu=True)
    print(json.dumps({"wall": wall, "cpu": cpu, "header": header(threads=threads)}))


def measure(tree, cutoff, threads, repeat, workload="w1"):
    env = dict(os.environ, PYTHONPATH=tree)
    out = subprocess.run([sys.executable, os.path.abspath(__file__), "--worker", str(cutoff), str(threads),
                          str(repeat), workload], env=env, check=True, stdout=subprocess.PIPE, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--baseline", help="another source tree with its extension built in place (optional)")
    parser.add_argument("--cutoffs", default="3,5", help="comma-separated cutoffs in w (default 3,5)")
    parser.add_argument("--threads", default="1,2", help="comma-separated thread counts (default 1,2)")
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds per tree (default 3)")
    parser.add_argument("--repeat", type=int, default=3, help="timed calls per measurement (default 3)")
    parser.add_argument("--workload", choices=("w1", "jittered"), default="w1",
                        help="w1 (default: every contact along a grid axis) or jittered (W1 with every particle "
                             "moved by up to 0.05 per axis: no contact along an axis)")
    parser.add_argument("--worker", nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(float(args.worker[0]), int(args.worker[1]), int(args.worker[2]), args.worker[3])
        return
    try:
        cutoffs = [float(c) for c in args.cutoffs.split(",") if c]
        threads = [int(t) for t in args.threads.split(",") if t]
    except ValueError:
        parser.error(f"--cutoffs, --threads: expected comma-separated numbers, got {args.cutoffs!r}, {args.threads!r}")
    if not cutoffs or min(cutoffs) <= 0 or not threads or min(threads) < 1:
        parser.error(f"--cutoffs, --threads: expected positive values, got {args.cutoffs!r}, {args.threads!r}")
    if args.rounds < 1 or args.repeat < 1:
        parser.error(f"--rounds, --repeat: expected >= 1, got {args.rounds}, {args.repeat}")
    trees = {"this": THIS_TREE}
    if args.baseline:
        baseline = os.path.abspath(args.baseline)
        if not os.path.isdir(os.path.join(baseline, "cgbound")):
            parser.error(f"--baseline: expected a source tree with a cgbound/ package, got {args.baseline!r}")
        trees = {"baseline": baseline, "this": THIS_TREE}
    print(f"# {args.workload} contact stress, Gaussian w = 1.0 exact; trees: {trees}; {args.rounds} alternating rounds, "
          f"medians of {args.repeat} calls each")
    first = True
    for cutoff in cutoffs:
        for t in threads:
            results = {name: [] for name in trees}
            for _ in range(args.rounds):
                for name, tree in trees.items():
                    r = measure(tree, cutoff, t, args.repeat, args.workload)
                    if first:
                        print(r["header"])
                        first = False
                    results[name].append(r)
            row = f"cutoff {cutoff:g}w, {t} thread(s):"
            for name, rs in results.items():
                wall = statistics.median(r["wall"] for r in rs)
                cpu = statistics.median(r["cpu"] for r in rs)
                row += f"  {name} wall {wall:.3f} s" + (f" (CPU {cpu:.3f} s)" if t == 1 else "")
            if len(trees) == 2:
                walls = [statistics.median(r["wall"] for r in rs) for rs in results.values()]
                row += f"  ratio baseline/this {walls[0] / walls[1]:.2f}"
            print(row, flush=True)
    print(f"# load average after: {'%.2f %.2f %.2f' % os.getloadavg()}")


if __name__ == "__main__":
    main()
