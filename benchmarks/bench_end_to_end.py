"""End to end on the W1 lattice: read two frames + coarse grain them, cgbound from MercuryDPM, LAMMPS and HDF5
files, side by side with MercuryCG on the same MercuryDPM files (one run).

    python benchmarks/bench_end_to_end.py [--mercurycg PATH] [--threads 2] [--repeat 1] [--mercury-repeat 1]
                                          [--formats mercury,lammps,hdf5] [--workdir DIR]

W1: the 46^3 simple-cubic lattice of benchmarks/workloads.py (97,336 particles, 285,660 contacts), two frames
(times 0 and 1) written as
  mercury  NAME.data + NAME.fstat (cgbound's MercuryDPM writer, each pair on two lines: ~85 MB of text)
  lammps   atoms.dump (dump custom: id type x y z vx vy vz radius mass) + pairs.dump (dump local: patom1 patom2
           fx fy fz, each pair once)
  hdf5     w1.h5 (cgbound's write_snapshots)
cgbound: the reader built and both frames read on --threads threads (read), then coarse_grain of each frame (Gaussian w = 1.0,
cutoff 3w, normalize="truncated", XYZ 46^3 grid; density, momentum, momentum flux, contact stress) with
--threads threads (coarse grain); total = read + coarse grain; run = the same work as a user writes it,
CoarseGrain(reader, ..., time_average="none").run() (the next frame read in a thread while one is coarse
grained); medians of --repeat runs.
MercuryCG (PATH, optional): its -coordinates O run is its reading time, its -coordinates XYZ -function Gauss
-w 1.0 run the total, the difference its coarse graining; best of --mercury-repeat runs.
Prints the CPU model, cores, threads, vector build and load average (before and after).
"""
import argparse
import math
import os
import shutil
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import numpy as np  # noqa: E402

import cgbound as cg  # noqa: E402
from cgbound.readers import HDF5Snapshots, LammpsReader, MercuryReader, write_snapshots  # noqa: E402
from bench_parse import write_rows  # noqa: E402
from bench_vs_mercurycg import FIELDS, N, NAME, run_mercurycg, write_frames  # noqa: E402
from common import header, timed  # noqa: E402
from workloads import lattice  # noqa: E402

FORMATS = ("mercury", "lammps", "hdf5")
TIMES = (0.0, 1.0)


def kernel():
    return cg.Gaussian(1.0, cutoff=3.0, normalize="truncated")


def frames_of(snap):
    """The two frames every format holds: the lattice with radii 0.5 at times 0 and 1."""
    return [cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box, contacts=snap.contacts,
                        radii=np.full(snap.n_particles, 0.5), time=t) for t in TIMES]


def write_lammps(snap, directory, fmt="%.17g"):
    """atoms.dump and pairs.dump (dump local, each pair once, the force on patom1) of the two frames."""
    n, c = snap.n_particles, snap.contacts
    lo, hi = snap.box.lower, snap.box.upper
    bounds = "".join(f"{float(a)!r} {float(b)!r}\n" for a, b in zip(lo, hi))
    with open(os.path.join(directory, "atoms.dump"), "w") as fh:
        for step, _ in enumerate(TIMES):
            fh.write(f"ITEM: TIMESTEP\n{step * 1000}\nITEM: NUMBER OF ATOMS\n{n}\nITEM: BOX BOUNDS ff ff ff\n"
                     f"{bounds}ITEM: ATOMS id type x y z vx vy vz radius mass\n")
            write_rows(fh, np.column_stack([np.arange(1, n + 1), np.ones(n), snap.positions, snap.velocities,
                                            np.full(n, 0.5), snap.masses]), fmt)
    with open(os.path.join(directory, "pairs.dump"), "w") as fh:
        for step, _ in enumerate(TIMES):
            fh.write(f"ITEM: TIMESTEP\n{step * 1000}\nITEM: NUMBER OF ENTRIES\n{len(c.i)}\nITEM: BOX BOUNDS ff ff ff\n"
                     f"{bounds}ITEM: ENTRIES c_pp[1] c_pp[2] c_pl[1] c_pl[2] c_pl[3]\n")
            write_rows(fh, np.column_stack([c.i + 1, c.j + 1, c.force]), fmt)


def readers(directory):
    """Builders of each format's reader over the files in directory."""
    density = 1.0 / (4.0 / 3.0 * math.pi * 0.5 ** 3)    # the lattice's unit masses at radius 0.5
    return {
        "mercury": lambda: MercuryReader(os.path.join(directory, NAME + ".data"),
                                         os.path.join(directory, NAME + ".fstat"), density=density),
        "lammps": lambda: LammpsReader(os.path.join(directory, "atoms.dump"), os.path.join(directory, "pairs.dump"),
                                       pair_style="total", pair_values=("fx", "fy", "fz")),
        "hdf5": lambda: HDF5Snapshots(os.path.join(directory, "w1.h5")),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--mercurycg", help="path of the MercuryCG executable (optional)")
    parser.add_argument("--threads", type=int, default=2, help="cgbound threads (default 2)")
    parser.add_argument("--repeat", type=int, default=1, help="cgbound runs per format (median)")
    parser.add_argument("--mercury-repeat", type=int, default=1, help="MercuryCG runs (best; ~16 s each)")
    parser.add_argument("--formats", default=",".join(FORMATS), help=f"some of {','.join(FORMATS)}")
    parser.add_argument("--workdir", help="where to write the files (default: a temporary directory, removed)")
    args = parser.parse_args()
    formats = [f for f in args.formats.split(",") if f]
    if not formats or any(f not in FORMATS for f in formats):
        parser.error(f"--formats: expected some of {','.join(FORMATS)}, got {args.formats!r}")
    if args.threads < 1 or args.repeat < 1 or args.mercury_repeat < 1:
        parser.error("--threads, --repeat, --mercury-repeat: expected >= 1")
    exe = None
    if args.mercurycg:
        exe = os.path.abspath(args.mercurycg)
        if not (os.path.isfile(exe) and os.access(exe, os.X_OK)):
            parser.error(f"--mercurycg: expected an executable file, got {args.mercurycg!r}")

    print(header(threads=args.threads), flush=True)
    snap = lattice(n=N)
    grid = cg.Grid(snap.box, (N, N, N))
    directory = args.workdir or tempfile.mkdtemp(prefix="cgbound_e2e_")
    os.makedirs(directory, exist_ok=True)
    try:
        stamp = os.path.join(directory, "written")   # a --workdir written before is reused
        if not os.path.exists(stamp):
            write_frames(snap, directory)
            write_lammps(snap, directory)
            write_snapshots(os.path.join(directory, "w1.h5"), frames_of(snap))
            open(stamp, "w").close()
        sizes = {"mercury": (NAME + ".data", NAME + ".fstat"), "lammps": ("atoms.dump", "pairs.dump"),
                 "hdf5": ("w1.h5",)}
        megabytes = {f: sum(os.path.getsize(os.path.join(directory, p)) for p in sizes[f]) / 1e6 for f in formats}
        rows = []
        if exe:
            upper = float(snap.box.upper[0])
            xyz = ["-coordinates", "XYZ", "-n", str(N), "-x", "0", f"{upper}", "-y", "0", f"{upper}",
                   "-z", "0", f"{upper}", "-function", "Gauss", "-w", "1.0"]
            # best wall time of each (run_mercurycg gives every run's wall and CPU times)
            reading = min(run_mercurycg(exe, directory, ["-coordinates", "O"], args.mercury_repeat)[0])
            total = min(run_mercurycg(exe, directory, xyz, args.mercury_repeat)[0])
            rows.append(("MercuryCG (MercuryDPM files, serial)", megabytes.get("mercury", float("nan")), reading,
                         total - reading, total, total))
        build = readers(directory)
        for name in formats:
            frames = []

            def read():
                with cg.threads(args.threads):   # frames of >= 4 MB of text parse on these threads
                    reader = build[name]()
                    frames[:] = [reader[k] for k in range(len(reader))]

            def coarse():
                with cg.threads(args.threads):
                    for s in frames:
                        cg.coarse_grain(s, grid, kernel(), fields=FIELDS)

            def pipelined():
                with cg.threads(args.threads):
                    cg.CoarseGrain(build[name](), grid, kernel(), fields=FIELDS, time_average="none").run()

            read_time, _ = timed(read, args.repeat)
            assert len(frames) == 2 and all(len(s.contacts.i) == len(snap.contacts.i) for s in frames), name
            coarse_time, _ = timed(coarse, args.repeat)
            frames.clear()
            run_time, _ = timed(pipelined, args.repeat)
            rows.append((f"cgbound from {name} ({args.threads} threads)", megabytes[name], read_time, coarse_time,
                         read_time + coarse_time, run_time))
    finally:
        if not args.workdir:
            shutil.rmtree(directory, ignore_errors=True)

    print(f"# W1: {snap.n_particles} particles, {len(snap.contacts.i)} contacts, 2 frames; Gaussian w = 1.0, cutoff "
          f"3w, normalize='truncated', XYZ grid {N}^3; fields {', '.join(FIELDS)}")
    print(f"{'run':44}{'MB':>8}{'read s':>9}{'coarse s':>10}{'total s':>9}{'run s':>8}{'MB/s read':>11}")
    for label, mb, r, c, t, u in rows:
        print(f"{label:44}{mb:8.1f}{r:9.2f}{c:10.2f}{t:9.2f}{u:8.2f}{mb / r:11.1f}")
    if exe:
        base = rows[0][4]
        for label, _, _, _, t, u in rows[1:]:
            print(f"# {label}: total {base / t:.1f}x, run {base / u:.1f}x faster than MercuryCG")
    print(f"# load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
