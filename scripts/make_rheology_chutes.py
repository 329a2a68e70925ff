"""Regenerate the shipped mu(I) chute profiles (cgbound/data/rheology_chutes.h5) with LAMMPS.

Two steps. ``simulate`` runs one inclination (cgbound.paper.scenes.inclined_chute: 1300 flowing
particles on a 10 x 10 rough base, from rest) for SPINUP time units, then writes frames with contacts
every INTERVAL over a WINDOW, to FRAMES_DIR/chute_<angle>deg.h5 (not committed; ~50 MB each) with the
kinetic energy of the flow at every time unit beside it. ``profiles`` coarse grains every frames
file in FRAMES_DIR into depth profiles with block error bars and writes them to --out (a few hundred kB).

    for a in 21 22.5 24 25.5 27; do python scripts/make_rheology_chutes.py simulate --angle $a --frames-dir runs & done
    python scripts/make_rheology_chutes.py profiles --frames-dir runs
"""
import argparse
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "cgbound", "data")


def main(argv=None):
    from cgbound.paper import chute_rheology
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="step", required=True)
    s = sub.add_parser("simulate", help="run one inclination with LAMMPS and write its frames")
    s.add_argument("--angle", type=float, required=True, help="inclination in degrees")
    s.add_argument("--frames-dir", required=True)
    s.add_argument("--spinup", type=float, default=chute_rheology.SPINUP)
    s.add_argument("--window", type=float, default=chute_rheology.WINDOW)
    s.add_argument("--interval", type=float, default=chute_rheology.INTERVAL)
    s.add_argument("--seed", type=int, default=chute_rheology.SEED)
    s.add_argument("--workdir", default=None, help="LAMMPS work directory (default: temporary)")
    q = sub.add_parser("profiles", help="coarse grain the frames of every inclination into the shipped profiles")
    q.add_argument("--frames-dir", required=True)
    q.add_argument("--out", default=os.path.join(DATA, "rheology_chutes.h5"))
    q.add_argument("--angles", type=float, nargs="+", default=None, help="only these inclinations (default: all)")
    args = p.parse_args(argv)
    if args.step == "simulate":
        path = chute_rheology.simulate(args.angle, args.frames_dir, spinup=args.spinup, window=args.window,
                                       interval=args.interval, seed=args.seed, workdir=args.workdir)
        print(f"wrote {path}")
        return 0
    chutes = chute_rheology.profiles_from_frames(args.frames_dir, angles=args.angles)
    chute_rheology.write_profiles(args.out, chutes)
    for c in chutes:
        print(c.summary())
    print(f"wrote {args.out} ({os.path.getsize(args.out) / 1e3:.0f} kB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
