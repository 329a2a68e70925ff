"""Regenerate the embedded chute dataset (cgbound/data/chute_steady.h5) with LAMMPS.

The paper's Figs. 2-3 scene (cgbound.paper.scenes.chute: 1000 flowing particles, rough base, 26 degrees,
periodic 20 x 10, the paper's contact model, dt = t_c / 50) is run from rest to t = SPINUP, then
frames with contacts are written every INTERVAL over [SPINUP, SPINUP + WINDOW]. All frames go to
--full (not committed; ~40 MB); every --embed-every-th frame to the embedded file (<= 10 MB),
and the kinetic energy of the flow at every time unit to chute_kinetic_energy.csv.

    python scripts/make_chute_dataset.py --full chute_full.h5   # the committed dataset (~15-35 min here)
    python scripts/make_chute_dataset.py --from-full chute_full.h5   # re-select the embedded frames only
    python scripts/make_chute_dataset.py --spinup 20 --window 2 --out /tmp/quick.h5   # a quick try
"""
import argparse
import json
import os
import sys
import time

import numpy as np

from cgbound._atomic import atomic_write
from cgbound.readers.hdf5 import HDF5Snapshots, write_snapshots
from cgbound.paper.scenes import Frames, Run, chute, run_scene

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "cgbound", "data")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--spinup", type=float, default=2000.0, help="time before the averaging window (2000)")
    p.add_argument("--window", type=float, default=100.0, help="length of the averaging window (100)")
    p.add_argument("--interval", type=float, default=0.5, help="time between frames (0.5)")
    p.add_argument("--embed-every", type=int, default=2, help="embed every k-th frame (2)")
    p.add_argument("--from-full", default=None, help="take the frames from this --full file instead of simulating")
    p.add_argument("--seed", type=int, default=2012)
    p.add_argument("--out", default=os.path.join(DATA, "chute_steady.h5"))
    p.add_argument("--kinetic-energy", default=None, help="CSV of the kinetic energy (default beside --out)")
    p.add_argument("--full", default=None, help="also write all frames here (HDF5)")
    p.add_argument("--workdir", default=None, help="LAMMPS work directory (default: temporary)")
    args = p.parse_args(argv)

    if args.from_full:
        return embed(args, HDF5Snapshots(args.from_full))
    scene = chute(seed=args.seed)
    count = int(round(args.window / args.interval)) + 1
    print(scene)
    start = time.perf_counter()
    result = run_scene(scene, [Run(args.spinup, thermo_every=1.0), Frames(count, args.interval)], workdir=args.workdir)
    print(f"LAMMPS ran {args.spinup + args.window:g} time units "
          f"({(args.spinup + args.window) / scene.timestep:.3g} steps) in {result.wall_time:.0f} s; "
          f"read back in {time.perf_counter() - start - result.wall_time:.0f} s")
    info = {"script": "scripts/make_chute_dataset.py", "argv": sys.argv[1:], "seed": args.seed,
            "spinup": args.spinup, "window": args.window, "lammps_wall_time_s": round(result.wall_time, 1),
            "frame_interval": args.interval, "effects": list(scene.effects), "engine": "LAMMPS",
            "input_script": result.input_script}
    if args.full:
        write_snapshots(args.full, result.snapshots, provenance=info)
        print(f"wrote {args.full} ({os.path.getsize(args.full) / 1e6:.1f} MB, {len(result.snapshots)} frames)")
    thermo = result.thermo
    ke_path = args.kinetic_energy or os.path.join(os.path.dirname(os.path.abspath(args.out)), "chute_kinetic_energy.csv")

    def write_ke(path):
        np.savetxt(path, np.stack([thermo["time"], thermo["kinetic_energy"]], axis=1), fmt="%.10g", delimiter=",",
                   header="time,kinetic_energy (of the 1000 flowing particles; LAMMPS thermo)", comments="# ")
    atomic_write(ke_path, write_ke)
    print(f"wrote {ke_path}")
    return embed(args, result.snapshots, info)


def embed(args, frames, info=None):
    """Write every --embed-every-th frame to --out (with the run's provenance)."""
    if info is None:
        info = json.loads(frames.provenance)
    embedded = [frames[k] for k in range(0, len(frames), args.embed_every)]
    info = dict(info, frame_interval=info["frame_interval"] * args.embed_every)
    write_snapshots(args.out, embedded, provenance=info, compression="gzip")   # shipped: small over fast
    print(f"wrote {args.out} ({os.path.getsize(args.out) / 1e6:.2f} MB, {len(embedded)} frames, "
          f"t = {embedded[0].time:g} ... {embedded[-1].time:g})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
