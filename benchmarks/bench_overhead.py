"""W1: where one coarse_grain call spends its time outside the C scatters, and the scatters' page faults.

    python benchmarks/bench_overhead.py [--repeat 10] [--threads 2] [--keep] [--stub]

Every run of coarse_grain (W1: 46^3 lattice, 46^3 grid, Gaussian w=1 c=3, line_quadrature=1; fields density,
momentum, momentum_flux, contact_stress) is followed by the same scatter calls made alone with the same
arguments, so both see the same machine load. Columns: minimum and median over the runs of the whole call,
of the scatters inside it, of the rest (Python side: NumPy work, contact split, derived fields), of the same
scatters alone, and the median minor page faults inside the scatters and in the whole call.
--keep holds the previous result while the next call runs (as a caller storing results does; what glibc
returns to the system between calls, and so the page faults, depends on it). --stub replaces the scatters by
zeros of the right shape: the Python side alone, free of the scatters' noise.
"""
import argparse
import os
import resource
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cgbound as cg  # noqa: E402
from cgbound import _engine as engine_module  # noqa: E402  (the one module that calls _core)
from common import header  # noqa: E402
from workloads import lattice  # noqa: E402

FIELDS = ("density", "momentum", "momentum_flux", "contact_stress")


def faults():
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt


class TimedCore:
    """Stands in for the C module inside fields.py: times (or stubs) the scatter calls and records them."""

    def __init__(self, core, stub):
        self.core, self.stub = core, stub
        self.reset()

    def reset(self):
        self.seconds, self.faults, self.calls = 0.0, 0, []

    def __getattr__(self, name):
        fn = getattr(self.core, name)
        if not name.startswith("scatter"):
            return fn

        def timed_call(*args, **kwargs):
            if self.stub:
                target = args[0]
                nodes = int(np.prod([len(c) for c in target[2]])) if target[2] is not None else len(target[3])
                return np.zeros((nodes, args[-1].shape[1]))
            f0, t0 = faults(), time.perf_counter()
            out = fn(*args, **kwargs)
            self.seconds += time.perf_counter() - t0
            self.faults += faults() - f0
            self.calls.append((name, args, kwargs))
            return out
        return timed_call


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=10)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--keep", action="store_true", help="hold the previous result during the next call")
    parser.add_argument("--stub", action="store_true", help="replace the scatters by zeros (Python side only)")
    args = parser.parse_args()
    snap = lattice()
    grid = cg.Grid(snap.box, (46, 46, 46))
    kernel = cg.Gaussian(1.0, cutoff=3.0, line_quadrature=1)
    core = TimedCore(engine_module._core, args.stub)
    engine_module._core = core
    rows = {"whole call": [], "scatters inside": [], "rest (Python side)": [], "scatters alone": []}
    fault_inside, fault_all = [], []
    kept = None
    with cg.threads(args.threads):
        cg.coarse_grain(snap, grid, kernel, FIELDS)                 # warm-up: imports, first allocations
        for _ in range(args.repeat):
            core.reset()
            f0, t0 = faults(), time.perf_counter()
            result = cg.coarse_grain(snap, grid, kernel, FIELDS)
            whole = time.perf_counter() - t0
            fault_all.append(faults() - f0)
            kept = result if args.keep else None
            del result
            rows["whole call"].append(whole)
            rows["scatters inside"].append(core.seconds)
            rows["rest (Python side)"].append(whole - core.seconds)
            fault_inside.append(core.faults)
            alone = 0.0
            for name, call_args, kwargs in core.calls:
                t0 = time.perf_counter()
                getattr(core.core, name)(*call_args, **kwargs)
                alone += time.perf_counter() - t0
            rows["scatters alone"].append(alone)
    del kept
    print(header(args.threads, f"W1 {snap.n_particles} particles, {len(snap.contacts)} contacts, 46^3 nodes; "
                               f"{args.repeat} runs" + (", scatters stubbed" if args.stub else "")
                 + (", previous result kept" if args.keep else "")))
    print(f"{'':<22}{'min ms':>9}{'median ms':>11}")
    for name, values in rows.items():
        if args.stub and name.startswith("scatters"):
            continue
        ms = np.array(values) * 1e3
        print(f"{name:<22}{ms.min():>9.1f}{np.median(ms):>11.1f}")
    print(f"page faults: {int(np.median(fault_inside))} in the scatters, {int(np.median(fault_all))} in the whole "
          f"call (medians)")


if __name__ == "__main__":
    main()
