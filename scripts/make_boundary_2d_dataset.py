"""Regenerate the embedded Fig. 1 configuration (cgbound/data/boundary_2d.h5) with LAMMPS.

The paper's 2D scene (cgbound.paper.scenes.boundary_2d: five fixed and five flowing discs, gravity -z,
the paper's contact model) is relaxed until the kinetic energy of the flow is below 1e-20, and
the static frame with its contacts is written.

    python scripts/make_boundary_2d_dataset.py
"""
import argparse
import os
import sys

from cgbound.paper.scenes import Frames, Settle, boundary_2d, run_scene

HERE = os.path.dirname(os.path.abspath(__file__))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default=os.path.join(HERE, "..", "cgbound", "data", "boundary_2d.h5"))
    args = p.parse_args(argv)
    scene = boundary_2d()
    result = run_scene(scene, [Settle(tolerance=1e-20, chunk=0.5, max_time=100.0), Frames(1, 0.5)])
    snap = result.snapshots[0]
    print(f"{scene}\nrelaxed at t = {snap.time:g} (kinetic energy {result.thermo['kinetic_energy'][-1]:.2e}); "
          f"{len(snap.contacts)} contacts; LAMMPS took {result.wall_time:.1f} s")
    result.write_snapshots(args.out, provenance={"script": "scripts/make_boundary_2d_dataset.py"},
                           compression="gzip")   # shipped with the package: small over fast
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
