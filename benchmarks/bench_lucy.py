"""Lucy's (and Heaviside's) grid paths on the W1 lattice: the C scatters alone and the whole frame.

    python benchmarks/bench_lucy.py [--threads 1,2] [--rounds 5] [--cases w1-stress,w1-frame,...]
                                    [--compare PATH]

Cases (W1: the 46^3 lattice of benchmarks/workloads.py, 97,336 particles, 285,660 axis-aligned contacts,
XYZ grid 46^3, Lucy cutoff 1.5):
  w1-stress    the contact stress's segment scatter alone (scatter_segments, 9 values per contact)
  w1-frame     coarse_grain with density, momentum, momentum_flux, contact_stress (one frame)
  oblique      285,660 segments of length 0.99 in random directions from the lattice's particles (9 values)
  lucy-points  the particles' scatter alone (scatter_points, 13 values: mass, momentum, momentum flux)
  heaviside    the same with Heaviside, radius 1.5
  heaviside-stress  w1-stress with Heaviside, radius 1.5
  lucy-gradient  the particles' gradient scatter (scatter_points(gradient=True), 4 values: mass, momentum)
Every case runs once per round after a warm-up; the tables give medians over the rounds of the wall time
and of the process's CPU time (all threads; on one thread the better measure on a loaded machine, as it
leaves out the time other processes hold the core).
--compare PATH: another cgbound tree (built in place); each round runs this tree and PATH alternately,
each in a fresh process (PYTHONPATH set to the tree), so that both see the same machine load.
Prints the CPU model, core count, vector build and load average.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
CASES = ("w1-stress", "w1-frame", "oblique", "lucy-points", "heaviside", "heaviside-stress", "lucy-gradient")
FIELDS = ("density", "momentum", "momentum_flux", "contact_stress")


def worker(cases, threads):
    """One round: {case: {threads: [wall seconds, CPU seconds]}} for the cgbound found on sys.path."""
    sys.path.insert(0, HERE)
    import numpy as np

    import cgbound as cg
    from cgbound import _engine
    from workloads import lattice

    snap = lattice(n=46)
    grid = cg.Grid(snap.box, (46, 46, 46))
    target = _engine.core_target(grid, snap.box)
    lucy = cg.Lucy(1.5)
    klucy = _engine.core_kernel(lucy, 1.0)
    kheavi = _engine.core_kernel(cg.Heaviside(1.5), 1.0)
    c = snap.contacts
    pos = snap.positions
    start = np.ascontiguousarray(pos[c.i])
    branch = np.ascontiguousarray(pos[c.j] - pos[c.i])
    values = np.ascontiguousarray(np.einsum("ni,nj->nij", c.force, branch).reshape(-1, 9))
    rng = np.random.default_rng(1)
    direction = rng.normal(size=branch.shape)
    direction *= 0.99 / np.linalg.norm(direction, axis=1)[:, None]
    v = snap.velocities
    pvalues = np.ascontiguousarray(np.concatenate([np.ones((len(pos), 1)), v, np.einsum("ni,nj->nij", v, v)
                                                   .reshape(-1, 9)], axis=1))
    runs = {
        "w1-stress": lambda t: _engine.scatter_segments(target, klucy, start, branch, values, n_threads=t),
        "w1-frame": lambda t: _frame(cg, snap, grid, lucy, t),
        "oblique": lambda t: _engine.scatter_segments(target, klucy, start, direction, values, n_threads=t),
        "lucy-points": lambda t: _engine.scatter_points(target, klucy, pos, pvalues, n_threads=t),
        "heaviside": lambda t: _engine.scatter_points(target, kheavi, pos, pvalues, n_threads=t),
        "heaviside-stress": lambda t: _engine.scatter_segments(target, kheavi, start, branch, values, n_threads=t),
        "lucy-gradient": lambda t: _engine.scatter_points(target, klucy, pos, np.ascontiguousarray(pvalues[:, :4]),
                                                          gradient=True, n_threads=t),
    }
    out = {}
    for case in cases:
        out[case] = {}
        for t in threads:
            runs[case](t)  # warm-up
            begin, cpu = time.perf_counter(), time.process_time()
            runs[case](t)
            out[case][str(t)] = [time.perf_counter() - begin, time.process_time() - cpu]
    return out


def _frame(cg, snap, grid, kernel, t):
    with cg.threads(t):
        return cg.coarse_grain(snap, grid, kernel, fields=FIELDS)


def run_tree(tree, cases, threads):
    env = dict(os.environ, PYTHONPATH=tree)
    cmd = [sys.executable, os.path.abspath(__file__), "--worker", "--cases", ",".join(cases),
           "--threads", ",".join(map(str, threads))]
    proc = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, text=True, check=True)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--threads", default="1,2", help="comma-separated thread counts")
    parser.add_argument("--rounds", type=int, default=5, help="rounds (fresh processes each)")
    parser.add_argument("--cases", default=",".join(CASES), help=f"some of {','.join(CASES)}")
    parser.add_argument("--compare", help="another cgbound tree, timed alternately with this one")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    cases = [c for c in args.cases.split(",") if c]
    if not cases or any(c not in CASES for c in cases):
        parser.error(f"--cases: expected some of {','.join(CASES)}, got {args.cases!r}")
    try:
        threads = [int(t) for t in args.threads.split(",") if t]
    except ValueError:
        threads = []
    if not threads or min(threads) < 1:
        parser.error(f"--threads: expected positive integers, got {args.threads!r}")
    if args.rounds < 1:
        parser.error(f"--rounds: expected >= 1, got {args.rounds}")
    if args.worker:
        print(json.dumps(worker(cases, threads)))
        return
    this = os.path.dirname(HERE)
    trees = {"this": this}
    if args.compare:
        other = os.path.abspath(args.compare)
        if not os.path.isdir(os.path.join(other, "cgbound")):
            parser.error(f"--compare: expected a cgbound source tree, got {args.compare!r}")
        trees = {"compare": other, "this": this}
    sys.path.insert(0, HERE)
    sys.path.insert(0, this)
    from common import header

    print(header(threads=",".join(map(str, threads))))
    print(f"# trees: {trees}; medians of {args.rounds} rounds, each tree in a fresh process per round, "
          f"trees alternating")
    times = {name: {c: {t: [] for t in threads} for c in cases} for name in trees}
    for _ in range(args.rounds):
        for name, tree in trees.items():
            got = run_tree(tree, cases, threads)
            for c in cases:
                for t in threads:
                    times[name][c][t].append(got[c][str(t)])
    for column, what in ((0, "wall"), (1, "CPU")):
        cols = "".join(f"{f'{name} {t}T s':>16}" for t in threads for name in trees)
        print(f"{what + ' time':16}{cols}")
        for c in cases:
            row = f"{c:16}"
            for t in threads:
                for name in trees:
                    row += f"{statistics.median(r[column] for r in times[name][c][t]):16.4f}"
            print(row)
    print(f"# load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
