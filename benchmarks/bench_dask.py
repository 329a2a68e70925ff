"""Dask backends: many snapshots (serial vs 2 workers) and one big snapshot in tiles (time, peak memory).

    python benchmarks/bench_dask.py [--frames 200] [--path chute.h5] [--repeat 3] [--grids profile,xyz]
                                    [--averages mean,smooth]
                                    [--particles 1e6] [--tiles 2,2,2] [--workers 2] [--skip frames|tiled]

Table 1: CoarseGrain over --frames snapshots read from an HDF5 file (--path, a cgbound snapshot file
such as the chute data set; without it, chute-like random snapshots of ~1000 particles and ~2000
contacts, fixed seed, written to a temporary file), serial vs backend="dask" with --workers worker
processes (on a running cluster, and with the cluster's start-up included), for the time mean and for
Gaussian time smoothing (width 1) at 10 output times. Medians of --repeat runs.

Table 2: one random packing of --particles spheres (d = 1, volume fraction 0.5, contacts between
touching pairs) on a 3D grid: coarse_grain in a fresh process vs coarse_grain_tiled on --workers
workers; wall time and peak resident memory (ru_maxrss) of each process.

Dask's workers run the C core with one thread each (dask sets OMP_NUM_THREADS=1 in them); the
serial runs use the core's default threads (printed). The CPU model and thread count head each table.
"""
import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import cgbound as cg
from cgbound.executors import local_cluster
from cgbound._memory import core_threads
from common import cpu_model

FRAME_FIELDS = ("density", "velocity", "stress", "kinetic_stress")
TILE_FIELDS = ("density", "velocity", "stress")


def header(what):
    print(f"# {what}")
    print(f"# CPU: {cpu_model()}; cores: {os.cpu_count()}; serial core threads: {core_threads()}; "
          f"OpenMP build: {cg.have_openmp()}; cgbound {cg.__version__}; machine shared with other jobs "
          f"(load average {os.getloadavg()[0]:.1f})")


# --- workload 1: chute-like snapshots -------------------------------------------------------------

def chute_snapshot(seed, n=1000, n_base=200):
    """A chute-like frame: flowing spheres above a rough fixed base, x and y periodic, tilted gravity."""
    from scipy.spatial import cKDTree
    rng = np.random.default_rng(seed)
    lx, ly, lz = 20.0, 10.0, 12.0
    base = np.column_stack([rng.uniform(0, lx, n_base), rng.uniform(0, ly, n_base), rng.uniform(0, 0.5, n_base)])
    flow = np.column_stack([rng.uniform(0, lx, n - n_base), rng.uniform(0, ly, n - n_base),
                            rng.uniform(0.8, lz - 1, n - n_base)])
    pos = np.concatenate([base, flow])
    fixed = np.arange(n) < n_base
    vel = np.zeros((n, 3))
    vel[~fixed] = rng.normal(scale=0.3, size=(n - n_base, 3))
    vel[~fixed, 0] += 0.5 * pos[~fixed, 2]                    # shear profile
    # each particle touches its nearest neighbours (periodic in x, y): about 2 contacts per particle
    tree = cKDTree(pos, boxsize=[lx, ly, 1e9])
    _, nbr = tree.query(pos, k=5)
    pairs = {(min(a, b), max(a, b)) for a in range(n) for b in nbr[a, 1:] if not (fixed[a] and fixed[b])}
    pairs = np.array(sorted(pairs))
    i, j = pairs[:, 0], pairs[:, 1]
    d = pos[j] - pos[i]
    d[:, :2] -= np.array([lx, ly]) * np.round(d[:, :2] / [lx, ly])
    force = -d / np.linalg.norm(d, axis=1)[:, None] * rng.uniform(0.5, 1.5, len(i))[:, None]
    point = pos[i] + 0.5 * d
    box = cg.Box([0, 0, 0], [lx, ly, lz], periodic=(True, True, False))
    return cg.Snapshot(pos, vel, np.ones(n), box=box, contacts=cg.Contacts(i, j, force, point), fixed=fixed,
                       body_force=[0.4, 0.0, -0.9], time=0.5 * seed)


def bench_frames(args):
    from distributed import Client
    tmp = None
    path = args.path
    if path is None:
        tmp = tempfile.TemporaryDirectory()
        path = os.path.join(tmp.name, "chute_random.h5")
        cg.readers.write_snapshots(path, (chute_snapshot(seed) for seed in range(args.frames)))
    reader = cg.readers.HDF5Snapshots(path)
    n = min(args.frames, len(reader))
    first = reader[0]
    box = first.box
    grids = {"profile": ("Z profile, 100 nodes", cg.Grid(box, (1, 1, 100), average=("x", "y"))),
             "xyz": ("XYZ 40x20x24", cg.Grid(box, (40, 20, 24)))}
    grids = dict(grids[name] for name in args.grids.split(","))
    times = [reader[0].time, reader[n - 1].time]
    kernel = cg.Gaussian(0.5, cutoff=1.5)
    header(f"{n} frames of {os.path.basename(path) if args.path else 'random chute-like snapshots'} "
           f"({first.n_particles} particles, {len(first.contacts)} contacts in frame 0); fields "
           f"{', '.join(FRAME_FIELDS)}; Gaussian w=0.5 c=1.5; medians of {args.repeat}")
    print(f"{'grid':<22}{'average':<9}{'serial s':>10}{f'dask x{args.workers} s':>12}{'speed-up':>10}"
          f"{'with start-up s':>17}{'max rel. diff':>15}")
    cluster = local_cluster(args.workers)
    client = Client(cluster)
    try:
        for label, grid in grids.items():
            for average in args.averages.split(","):
                # smoothing: width 1 time unit, at 10 output times spread over the frames
                options = {"time_average": "mean"} if average == "mean" else \
                    {"time_average": 1.0, "times": np.linspace(times[0], times[-1], 10)}

                def run(**kw):
                    return cg.CoarseGrain(reader, grid, kernel, fields=FRAME_FIELDS, **options).run(
                        0, n, 1, **kw).results
                serial_t, dask_t, cold_t = [], [], []
                for _ in range(args.repeat):
                    t = time.perf_counter()
                    a = run()
                    serial_t.append(time.perf_counter() - t)
                    t = time.perf_counter()
                    b = run(backend="dask", client=client)
                    dask_t.append(time.perf_counter() - t)
                t = time.perf_counter()
                run(backend="dask", n_workers=args.workers)
                cold_t.append(time.perf_counter() - t)
                diff = max(float(np.nanmax(np.abs(a[f] - b[f])) / np.nanmax(np.abs(a[f]))) for f in FRAME_FIELDS)
                s, d = statistics.median(serial_t), statistics.median(dask_t)
                print(f"{label:<22}{average:<9}{s:>10.2f}{d:>12.2f}{s / d:>10.2f}{cold_t[0]:>17.2f}{diff:>15.1e}",
                      flush=True)
    finally:
        client.close()
        cluster.close()
        if tmp is not None:
            tmp.cleanup()


# --- workload 2: one big random packing in tiles ------------------------------------------------------

def packing(n, seed=0, phi=0.5):
    """n unit-diameter spheres at random in a non-periodic cube of volume fraction phi; contacts between
    pairs closer than a diameter (forces along the line of centres)."""
    from scipy.spatial import cKDTree
    rng = np.random.default_rng(seed)
    side = (n * np.pi / 6 / phi) ** (1 / 3)
    pos = rng.uniform(0, side, (n, 3))
    pairs = cKDTree(pos).query_pairs(1.0, output_type="ndarray")
    i, j = pairs[:, 0].astype(np.int64), pairs[:, 1].astype(np.int64)
    d = pos[i] - pos[j]
    dist = np.linalg.norm(d, axis=1)
    force = d / dist[:, None] * (1.0 - dist)[:, None]
    point = pos[j] + 0.5 * d
    del d, dist, pairs
    vel = rng.normal(scale=0.1, size=(n, 3))
    return cg.Snapshot(pos, vel, np.ones(n), box=cg.Box([0, 0, 0], [side] * 3),
                       contacts=cg.Contacts(i, j, force, point))


def tile_grid(snap, spacing):
    return cg.Grid(snap.box, tuple(max(1, int(round(L / spacing))) for L in snap.box.lengths))


TILE_KERNEL = dict(width=1.0, cutoff=3.0)


def single_process(n, spacing):
    """Run in a fresh process: JSON with wall time and peak RSS (before and after coarse graining)."""
    snap = packing(n)
    before = peak_rss_kb()
    t = time.perf_counter()
    cg.coarse_grain(snap, tile_grid(snap, spacing), cg.Gaussian(**TILE_KERNEL), fields=TILE_FIELDS)
    wall = time.perf_counter() - t
    peak = peak_rss_kb()
    print(json.dumps({"wall": wall, "rss_input_kb": before, "rss_peak_kb": peak, "contacts": len(snap.contacts)}))


def peak_rss_kb():
    """Peak resident memory of this process since it started (VmHWM: unlike ru_maxrss, not inherited
    from the parent that forked it)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


def bench_tiled(args):
    from distributed import Client
    n = int(float(args.particles))
    tiles = tuple(int(t) for t in args.tiles.split(","))
    out = subprocess.run([sys.executable, __file__, "--single", str(n), "--spacing", str(args.spacing)],
                         capture_output=True, text=True, check=True, cwd=os.path.dirname(os.path.abspath(__file__)))
    single = json.loads(out.stdout.strip().splitlines()[-1])
    snap = packing(n)
    grid = tile_grid(snap, args.spacing)
    header(f"random packing: {n} particles, {len(snap.contacts)} contacts, grid {grid.shape}, fields "
           f"{', '.join(TILE_FIELDS)}, Gaussian w=1 c=3, tiles {tiles}")
    cluster = local_cluster(args.workers)
    client = Client(cluster)
    try:
        idle = client.run(peak_rss_kb)
        t = time.perf_counter()
        cg.coarse_grain_tiled(snap, grid, cg.Gaussian(**TILE_KERNEL), fields=TILE_FIELDS, tiles=tiles, client=client)
        wall = time.perf_counter() - t
        peaks = client.run(peak_rss_kb)
    finally:
        client.close()
        cluster.close()
    mb = 1024.0
    print(f"{'run':<34}{'wall s':>9}{'peak RSS MB':>13}{'of which input/idle MB':>23}")
    print(f"{'single process coarse_grain':<34}{single['wall']:>9.1f}{single['rss_peak_kb'] / mb:>13.0f}"
          f"{single['rss_input_kb'] / mb:>23.0f}")
    for k, (addr, peak) in enumerate(sorted(peaks.items())):
        print(f"{f'tiled: worker {k}':<34}{wall if k == 0 else float('nan'):>9.1f}{peak / mb:>13.0f}"
              f"{idle[addr] / mb:>23.0f}")
    print(f"{'tiled: client (holds the snapshot)':<34}{'':>9}{peak_rss_kb() / mb:>13.0f}{'':>23}", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--path", default=None, help="cgbound HDF5 snapshot file (e.g. the chute data set)")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--particles", default="1e6", help="particles of the tiled packing (1e7 needs ~10 GB)")
    parser.add_argument("--spacing", type=float, default=2.0, help="grid spacing of the tiled packing")
    parser.add_argument("--tiles", default="2,2,2")
    parser.add_argument("--grids", default="profile,xyz", help="frames table: profile and/or xyz")
    parser.add_argument("--averages", default="mean,smooth", help="frames table: mean and/or smooth")
    parser.add_argument("--skip", choices=("frames", "tiled"), default=None)
    parser.add_argument("--single", type=int, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.single is not None:
        single_process(args.single, args.spacing)
        return
    if args.skip != "frames":
        bench_frames(args)
    if args.skip != "tiled":
        bench_tiled(args)


if __name__ == "__main__":
    main()
