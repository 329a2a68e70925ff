"""Cost of each gradient/rheology field on W1 (46^3 lattice, 46^3 XYZ grid) relative to the stress.

    python benchmarks/bench_rheology.py [--repeat 3] [--threads 1] [--kernels g0.5,lucy] [--workloads W1,W2]
                                        [--set rheology|rotation]

For each kernel: one frame of ``stress`` alone, each new field alone, and ``stress`` together with each
new field, timed round-robin (every repeat runs every request once, in turn, so a change of the machine's
load hits all of them alike); the medians and the ratio to ``stress`` alone. CPU time of the process is
printed beside the wall time: on a shared machine it is the steadier of the two for one thread. Prints the
CPU model, core count, thread count and load average with every table. ``--set rotation`` times the
rotational fields instead (the lattice given random angular velocities; ``couple_stress`` in both forms,
``branch_line`` marked "(bl)").
"""
import argparse
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import numpy as np  # noqa: E402

import cgbound as cg  # noqa: E402
from common import header, thread_list  # noqa: E402
from workloads import lattice  # noqa: E402

NEW_FIELDS = ("density_gradient", "momentum_gradient", "velocity_gradient", "strain_rate", "spin", "shear_rate",
              "shear_stress", "friction", "inertial_number")
ROTATION_FIELDS = ("spin_density", "spin_flux", "kinetic_spin_flux", "couple_stress", "couple_stress (bl)",
                   "stress_torque_density", "boundary_couple_density")
KERNELS = {"g0.5": ("Gaussian w=0.5 c=3w", lambda: cg.Gaussian(0.5, cutoff=1.5)),
           "lucy": ("Lucy c=1.5", lambda: cg.Lucy(1.5))}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--threads", default="1", help="comma-separated thread counts (default 1)")
    parser.add_argument("--kernels", default="g0.5,lucy", help=f"some of {','.join(KERNELS)}")
    parser.add_argument("--workloads", default="W1", help="W1 (46^3 grid) and/or W2 (Z profile of 100 nodes)")
    parser.add_argument("--set", choices=("rheology", "rotation"), default="rheology",
                        help="the gradient/rheology fields or the rotational ones")
    args = parser.parse_args()
    snap = lattice()
    omega = np.random.default_rng(1).normal(size=snap.positions.shape)
    snap = cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box, contacts=snap.contacts,
                       radii=[0.5] * snap.n_particles,           # inertial_number needs radii
                       angular_velocities=omega if args.set == "rotation" else None)
    new_fields = ROTATION_FIELDS if args.set == "rotation" else NEW_FIELDS
    grids = {"W1": cg.Grid(snap.box, (46, 46, 46)), "W2": cg.Grid(snap.box, (1, 1, 100), average=("x", "y"))}
    requests = [("stress",)] + [(f,) for f in new_fields] + [("stress", f) for f in new_fields]
    for nt in thread_list(args.threads):
        print(header(nt, extra="shared machine: other jobs ran beside this one"))
        print(f"# {snap.n_particles} particles, {len(snap.contacts)} contacts; medians of {args.repeat} "
              f"round-robin runs of one frame")
        print(f"{'workload':<9}{'kernel':<21}{'fields':<34}{'median s':>10}{'cpu s':>9}{'/ stress':>10}"
              f"{'cpu / stress':>14}")
        for name in args.workloads.split(","):
            grid = grids[name]
            for key in args.kernels.split(","):
                label, make = KERNELS[key]
                kernel = make()
                walls = {r: [] for r in requests}
                cpus = {r: [] for r in requests}
                with cg.threads(nt):
                    cg.coarse_grain(snap, grid, kernel, fields=("stress",))            # warm-up
                    for _ in range(args.repeat):
                        for r in requests:
                            form = "branch_line" if any(f.endswith(" (bl)") for f in r) else "contact_point"
                            fields = tuple(f.replace(" (bl)", "") for f in r)
                            start, start_cpu = time.perf_counter(), time.process_time()
                            cg.coarse_grain(snap, grid, kernel, fields=fields, couple_stress_form=form)
                            walls[r].append(time.perf_counter() - start)
                            cpus[r].append(time.process_time() - start_cpu)
                base, base_cpu = statistics.median(walls[requests[0]]), statistics.median(cpus[requests[0]])
                for r in requests:
                    med, cpu = statistics.median(walls[r]), statistics.median(cpus[r])
                    print(f"{name:<9}{label:<21}{'+'.join(r):<34}{med:>10.3f}{cpu:>9.3f}{med / base:>10.2f}"
                          f"{cpu / base_cpu:>14.2f}", flush=True)


if __name__ == "__main__":
    main()
