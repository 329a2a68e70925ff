"""The readers as users call them, this tree against another one: reader made + every frame read, in alternating
processes.

    python benchmarks/bench_readers.py [--against /work/main] [--rounds 6] [--repeat 3] [--threads 1 2]
                                       [--cases lammps,mercury,atoms,pairs] [--dir /tmp/cgbound-bench-readers]

Cases (files written once into --dir, then reused):
  lammps   LammpsReader(atoms.dump, pairs.dump, pair_style="total", pair_values=("fx", "fy", "fz")) on the W1 files
           of bench_end_to_end.py (97,336 atoms, 285,660 contacts, 2 frames, 45 MB), every frame's snapshot
  forces   the same with fx fy fz in the atoms dump (the sums of the contact forces, %.17g): the reader's default
           force-balance check runs on every frame
  mercury  MercuryReader(W1.data, W1.fstat, density=...) on the same lattice (each pair on two lines, 160 MB)
  atoms    bench_parse.py's atoms.dump (36 MB) through scan_dump + DumpIndex.read of every frame (its "reader" row)
  pairs    bench_parse.py's pairs.dump (120 MB, the IDs read as integers) likewise
Each round runs every case in a separate process of this tree and one of --against (PYTHONPATH=tree), which one
goes first alternating; each process reads once untimed, then --repeat times timed (a new reader each time).
Printed per case, thread count and tree: the median and minimum wall and CPU (process) time over every round.
Other processes share the cores: compare the CPU times of one-thread runs, and the minima of the wall times.
"""
import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
CASES = ("lammps", "forces", "mercury", "atoms", "pairs")


def reader_of(case, directory):
    """A function that makes the reader and reads every frame (imports from the tree on PYTHONPATH)."""
    from cgbound.readers import LammpsReader, MercuryReader
    from cgbound.readers._lammps_dump import scan_dump
    e2e, parse = os.path.join(directory, "e2e"), os.path.join(directory, "parse")

    def frames(reader):
        return [reader[k] for k in range(len(reader))]

    def dump(path, kind):
        index = scan_dump(path, kind)
        ints = ("c_pl[1]", "c_pl[2]") if kind == "local" else ()
        return [index.read(offset, ints) for offset, _ in index]

    density = 1.0 / (4.0 / 3.0 * math.pi * 0.5 ** 3)
    return {
        "lammps": lambda: frames(LammpsReader(os.path.join(e2e, "atoms.dump"), os.path.join(e2e, "pairs.dump"),
                                              pair_style="total", pair_values=("fx", "fy", "fz"))),
        "forces": lambda: frames(LammpsReader(os.path.join(e2e, "atoms_forces.dump"), os.path.join(e2e, "pairs.dump"),
                                              pair_style="total", pair_values=("fx", "fy", "fz"))),
        "mercury": lambda: frames(MercuryReader(os.path.join(e2e, "W1.data"), os.path.join(e2e, "W1.fstat"),
                                                density=density)),
        "atoms": lambda: dump(os.path.join(parse, "atoms.dump"), "atoms"),
        "pairs": lambda: dump(os.path.join(parse, "pairs.dump"), "local"),
    }[case]


def worker(case, threads, repeat, directory):
    import cgbound as cg
    run = reader_of(case, directory)
    out = []
    with cg.threads(threads):
        run()
        for _ in range(repeat):
            start, start_cpu = time.perf_counter(), time.process_time()
            run()
            out.append((time.perf_counter() - start, time.process_time() - start_cpu))
    print(json.dumps(out))


def write_files(directory):
    sys.path.insert(0, HERE)
    import bench_end_to_end as e2e
    from bench_parse import write_files as write_parse_files
    write_parse_files(os.path.join(directory, "parse"), "%.17g")
    where = os.path.join(directory, "e2e")
    os.makedirs(where, exist_ok=True)
    snap = None
    if not os.path.exists(os.path.join(where, "written")):
        snap = e2e.lattice(n=e2e.N)
        e2e.write_frames(snap, where)
        e2e.write_lammps(snap, where)
        open(os.path.join(where, "written"), "w").close()
    if not os.path.exists(os.path.join(where, "atoms_forces.dump")):
        import numpy as np
        snap = snap or e2e.lattice(n=e2e.N)
        n, forces = snap.n_particles, snap.particle_forces()
        bounds = "".join(f"{float(a)!r} {float(b)!r}\n" for a, b in zip(snap.box.lower, snap.box.upper))
        with open(os.path.join(where, "atoms_forces.dump.tmp"), "w") as fh:
            for step, _ in enumerate(e2e.TIMES):
                fh.write(f"ITEM: TIMESTEP\n{step * 1000}\nITEM: NUMBER OF ATOMS\n{n}\nITEM: BOX BOUNDS ff ff ff\n"
                         f"{bounds}ITEM: ATOMS id type x y z vx vy vz fx fy fz radius mass\n")
                e2e.write_rows(fh, np.column_stack([np.arange(1, n + 1), np.ones(n), snap.positions, snap.velocities,
                                                    forces, np.full(n, 0.5), snap.masses]), "%.17g")
        os.replace(os.path.join(where, "atoms_forces.dump.tmp"), os.path.join(where, "atoms_forces.dump"))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--against", default="/work/main", help="the other tree (its cgbound built in place)")
    parser.add_argument("--rounds", type=int, default=6)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--dir", default="/tmp/cgbound-bench-readers")
    parser.add_argument("--worker", nargs=4, metavar=("CASE", "THREADS", "REPEAT", "DIR"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        case, threads, repeat, directory = args.worker
        worker(case, int(threads), int(repeat), directory)
        return
    cases = [c for c in args.cases.split(",") if c]
    if not cases or any(c not in CASES for c in cases):
        parser.error(f"--cases: expected some of {','.join(CASES)}, got {args.cases!r}")
    trees = {"this": os.path.dirname(HERE), "against": os.path.abspath(args.against)}
    sys.path.insert(0, HERE)
    from common import header
    t0 = time.perf_counter()
    write_files(args.dir)
    print(f"# files in {args.dir} (written or reused in {time.perf_counter() - t0:.1f} s)")
    print(header(threads=",".join(map(str, args.threads)), extra=f"this: {trees['this']}; against: {trees['against']}"))
    results = {}
    for r in range(args.rounds):
        for case in cases:
            for threads in args.threads:
                order = list(trees.items()) if r % 2 == 0 else list(reversed(list(trees.items())))
                for name, tree in order:
                    proc = subprocess.run([sys.executable, os.path.abspath(__file__), "--worker", case, str(threads),
                                           str(args.repeat), args.dir], env=dict(os.environ, PYTHONPATH=tree),
                                          capture_output=True, text=True)
                    if proc.returncode:
                        sys.exit(f"{name} ({tree}), {case}: {proc.stderr[-2000:]}")
                    results.setdefault((case, threads, name), []).extend(json.loads(proc.stdout))
    print(f"{'case':8} {'threads':>7} {'tree':8} {'wall med':>9} {'wall min':>9} {'cpu med':>8} {'cpu min':>8} "
          f"{'runs':>5} {'cpu med / against':>18}")
    for case in cases:
        for threads in args.threads:
            against_cpu = statistics.median(c for _, c in results[(case, threads, "against")])
            for name in trees:
                runs = results[(case, threads, name)]
                walls, cpus = [w for w, _ in runs], [c for _, c in runs]
                print(f"{case:8} {threads:7} {name:8} {statistics.median(walls):9.4f} {min(walls):9.4f} "
                      f"{statistics.median(cpus):8.4f} {min(cpus):8.4f} {len(runs):5} "
                      f"{statistics.median(cpus) / against_cpu:18.3f}")
    print(f"# load average at the end: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f}")


if __name__ == "__main__":
    main()
