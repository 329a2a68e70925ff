"""Regenerate the static silo test data (tests/data/lammps/silo/) with LAMMPS.

The silo scene (cgbound.paper.scenes.silo: spheres in a vertical cylinder of radius 4 with a flat
bottom, gravity -z, frictional Hookean contacts, wall friction) falls onto the bottom, is
relaxed until the kinetic energy of all particles is below the tolerance, the bottom is lowered by
0.2 d at constant speed over 10 time units so that the column slides down along the wall (mobilising
the wall friction), the column comes to rest again, and a few frames are
dumped (each inside its own ``run 0``, with the wall contacts of both walls). The LAMMPS dumps
are kept as they are, gzipped, with the input script and the data file.

    python scripts/make_silo_data.py
"""
import argparse
import gzip
import os
import resource
import shutil
import subprocess
import sys

from cgbound.paper.scenes import Frames, MoveWall, Settle, run_scene
from cgbound.paper.scenes import lammps as lmp_input
from cgbound.paper.scenes.runner import find_lammps
from cgbound.paper.scenes.silo import silo

HERE = os.path.dirname(os.path.abspath(__file__))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default=os.path.join(HERE, "..", "tests", "data", "lammps", "silo"))
    p.add_argument("--workdir", default=None, help="where LAMMPS runs (default: a temporary directory)")
    p.add_argument("--n-particles", type=int, default=2000)
    p.add_argument("--tolerance", type=float, default=1e-4, help="kinetic energy at which the column counts as at rest")
    p.add_argument("--frames", type=int, default=2)
    p.add_argument("--drop", type=float, default=0.2, help="how far the bottom is lowered after the first rest")
    p.add_argument("--lowering", type=float, default=10.0, help="in how many time units")
    args = p.parse_args(argv)
    scene = silo(n_particles=args.n_particles)
    # fall and come to rest; lower the bottom slowly so that the column slides down along the wall and
    # mobilises its friction (Janssen's assumption); come to rest again
    stages = [Settle(tolerance=args.tolerance, chunk=1.0, max_time=150.0), MoveWall(1, -args.drop, args.lowering),
              Settle(tolerance=args.tolerance, chunk=1.0, max_time=150.0), Frames(args.frames, 1.0)]
    result = run_scene(scene, stages, workdir=args.workdir)
    cpu = resource.getrusage(resource.RUSAGE_CHILDREN)
    snap = result.snapshots[-1]
    version = subprocess.run([find_lammps(), "-h"], capture_output=True, text=True).stdout.splitlines()[1].strip()
    print(f"{scene}\n{version}\nat rest at t = {result.snapshots[0].time:g} (kinetic energy "
          f"{result.thermo['kinetic_energy'][-1]:.2e}); {len(snap.contacts)} contacts in the last frame; "
          f"LAMMPS wall time {result.wall_time:.1f} s, CPU time {cpu.ru_utime + cpu.ru_stime:.1f} s")
    os.makedirs(args.out, exist_ok=True)
    for name in (lmp_input.FRAME_ATOMS, lmp_input.FRAME_PAIRS):
        with open(os.path.join(result.workdir, name), "rb") as src, \
                gzip.GzipFile(os.path.join(args.out, name + ".gz"), "wb", mtime=0) as dst:
            shutil.copyfileobj(src, dst)
    for name in (lmp_input.INPUT_FILE, lmp_input.DATA_FILE):
        shutil.copy(os.path.join(result.workdir, name), os.path.join(args.out, name))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
