"""The lithostatic balance of the chute with the paper's sampling: a frame every t_c / 2.

Contact forces in this collisional flow come in short, stiff impacts: the upward force of the base
on the flow fluctuates by ~20 % of the flow's weight from one instantaneous frame to the next, so an
average over N independent frames has a statistical error of ~20 % / sqrt(N) (the shipped 51 frames:
several per cent). The paper samples every t_c / 2, which resolves every impact, so the average is
the time integral of the momentum balance and the lithostatic balance holds to ~(change of vertical
momentum) / (window x weight).

This script continues the chute from the last shipped frame (positions and velocities; rotations and
tangential springs start from zero, so it first runs SETTLE time units), samples WINDOW time units
every t_c / 2 (dumps of ~0.25 MB per frame go to a temporary directory and are deleted), prints
the Fig. 3 numbers and writes the averaged profiles (a few kB) to cgbound/data/chute_dense_profiles.h5,
which notebook 03 and `cgbound demo` read (cgbound.paper.profiles.DepthProfiles.from_hdf5).

    python scripts/check_chute_dense_sampling.py --settle 20 --window 10
"""
import argparse
import json
import os
import shutil
import sys
import tempfile
import time


from cgbound.paper.datasets import chute_steady
from cgbound.paper.profiles import DepthProfiles
from cgbound.paper.scenes import PAPER_COLLISION_TIME, Frames, Run, Scene, chute, run_scene


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--settle", type=float, default=20.0)
    p.add_argument("--window", type=float, default=10.0)
    p.add_argument("--interval", type=float, default=PAPER_COLLISION_TIME / 2)
    p.add_argument("--width", type=float, default=0.25)
    p.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "cgbound", "data",
                                                 "chute_dense_profiles.h5"))
    args = p.parse_args(argv)

    frames = chute_steady()
    last = frames[len(frames) - 1]
    template = chute()
    scene = Scene("chute_continued", template.box, last.positions, last.radii, template.masses, template.contacts,
                  fixed=last.fixed, velocities=last.velocities, gravity=template.gravity, rotation=True,
                  timestep=template.timestep)
    count = int(round(args.window / args.interval)) + 1
    workdir = tempfile.mkdtemp(prefix="cgbound-dense-")
    try:
        start = time.perf_counter()
        run = run_scene(scene, [Run(args.settle), Frames(count, args.interval)], workdir=workdir)
        print(f"LAMMPS: {args.settle:g} + {args.window:g} time units, {count} frames in {run.wall_time:.0f} s "
              f"(total with reading {time.perf_counter() - start:.0f} s)")
        start = time.perf_counter()
        profiles = DepthProfiles(width=args.width, blocks=5).run(run.snapshots)
        print(f"profiles over {count} frames in {time.perf_counter() - start:.0f} s")
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
    print(profiles.summary())
    info = {"script": "scripts/check_chute_dense_sampling.py", "argv": sys.argv[1:], "settle": args.settle,
            "window": args.window, "interval": args.interval, "frames": count,
            "continued_from": f"last frame of the shipped chute (t = {last.time:g})", "lammps_wall_time_s": round(run.wall_time, 1)}
    profiles.to_hdf5(args.out, provenance=json.dumps(info))
    print(f"wrote {args.out}")
    weight = last.masses[last.flowing].sum() * abs(template.gravity[2])
    print(f"frames every {args.interval:g} over t = {run.snapshots[0].time:g} ... {run.snapshots[-1].time:g}; "
          f"weight of the flow {weight:.4g}")
    return 0 if profiles.lithostatic_error <= 0.01 else 1


if __name__ == "__main__":
    sys.exit(main())
