"""Where the time per object goes: Python side, the core's per-object setup, the work per node.

    python benchmarks/bench_per_object.py [--repeat 7] [--threads 1] [--workloads W2,P100,W1]
                                          [--kernels lucy,heaviside,g1] [--sets stress,gradient]
                                          [--compare PATH_TO_OTHER_CORE.so]

Workloads on the 46^3 lattice (97,336 particles, 285,660 contacts): W2, the Z profile of 100 nodes
(x and y averaged); P100, 100 random points (a point target); W1, the 46^3 XYZ grid. Field sets:
``stress`` (density, momentum, momentum flux, contact stress: one particle scatter of 10 values and one
contact scatter) and ``gradient`` (density_gradient: one gradient scatter of the particles).

For every scatter call that ``coarse_grain`` makes, the same call is timed alone with the kernel as given
and with the same kernel shrunk to a radius of 1e-9 (each object then reaches at most one node): the
latter, per object, is the core's per-object cost (ordering, slabs, the loop over objects, images, the
stencil's bounds); the difference, divided by the (object, node) pairs inside the support, the cost per
node. "python" is coarse_grain's time outside the scatters per object (array preparation, contact split,
derived fields). Medians of --repeat runs, taken round-robin so that a change in the machine's load hits
every row alike. --compare PATH times a second build of the core (another checkout's
cgbound/_core*.so) in the same rounds, call by call, and says whether its results are the same bits.
Prints the CPU, threads and load average; on a shared machine compare rows of one run only. The same
per-object costs in instructions (callgrind, immune to the machine's load): tools/profile_per_object.py.
"""
import argparse
import importlib.machinery
import importlib.util
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cgbound as cg  # noqa: E402
from cgbound import _engine as engine_module  # noqa: E402  (the one module that calls _core)
from common import header, load_average  # noqa: E402
from workloads import lattice  # noqa: E402

KERNELS = {"lucy": lambda: cg.Lucy(1.5), "heaviside": lambda: cg.Heaviside(1.5),
           "g1": lambda: cg.Gaussian(1.0, cutoff=3.0)}
SETS = {"stress": ("density", "momentum", "momentum_flux", "contact_stress"), "gradient": ("density_gradient",)}
TINY = 1e-9


class Recorder:
    """Stands in for the C module inside _engine: records the scatter calls of one coarse_grain call."""

    def __init__(self, core):
        self.core, self.calls, self.seconds = core, [], 0.0

    def __getattr__(self, name):
        fn = getattr(self.core, name)
        if not name.startswith("scatter"):
            return fn

        def recorded(*args, **kwargs):
            t0 = time.perf_counter()
            out = fn(*args, **kwargs)
            self.seconds += time.perf_counter() - t0
            self.calls.append((name, args, kwargs))
            return out
        return recorded


def load_core(path):
    """Another build of the C core, loaded beside the package's own."""
    loader = importlib.machinery.ExtensionFileLoader("cgbound._core", path)
    spec = importlib.util.spec_from_file_location("cgbound._core", path, loader=loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def shrunk(kernel_tuple):
    """The core's kernel tuple with its support shrunk to TINY (same type, same averaging)."""
    ratio = kernel_tuple.width / kernel_tuple.radius
    return kernel_tuple._replace(width=TINY * ratio, radius=TINY)


def pairs_in_support(name, args):
    """(object, node) pairs with the node inside the object's support (ball or capsule)."""
    target, kernel, pos = args[0], args[1], args[2]
    R = kernel.radius
    vec = args[3] if name.startswith("scatter_segments") else np.zeros_like(pos)
    axes = list(target.axes) if target.coordinates is not None else list(range(pos.shape[1]))
    a, e = pos[:, axes], vec[:, axes]
    L2 = (e * e).sum(-1)

    def inside(q):                                                    # q: (n, D_res) node minus start
        s = np.clip(np.where(L2 > 0, (q * e).sum(-1) / np.where(L2 > 0, L2, 1.0), 0.0), 0.0, 1.0)
        return ((q - s[:, None] * e) ** 2).sum(-1) < R * R

    if target.coordinates is None:                                    # points: every point, objects in chunks
        return int(sum(inside(np.asarray(p)[None, :] - a).sum() for p in np.asarray(target.points)))
    # grids: the offsets of each object's stencil box, vectorised over the objects
    coords = [np.asarray(c) for c in target.coordinates]
    h = [c[1] - c[0] if len(c) > 1 else 1.0 for c in coords]
    low = np.minimum(a, a + e) - R
    first = [np.floor((low[:, d] - coords[d][0]) / h[d]).astype(np.int64) for d in range(len(axes))]
    extent = [int(np.ceil((2 * R + np.abs(e[:, d]).max()) / h[d])) + 2 for d in range(len(axes))]
    total = 0
    for offset in np.ndindex(*extent):
        idx = [first[d] + offset[d] for d in range(len(axes))]
        ok = np.ones(len(a), bool)
        for d in range(len(axes)):
            ok &= (idx[d] >= 0) & (idx[d] < len(coords[d]))
        node = np.stack([coords[d][np.clip(idx[d], 0, len(coords[d]) - 1)] for d in range(len(axes))], axis=1)
        total += int((ok & inside(node - a)).sum())
    return total


def targets(snap):
    rng = np.random.default_rng(3)
    return {"W2": cg.Grid(snap.box, (1, 1, 100), average=("x", "y")),
            "P100": cg.Points(snap.box.lower + rng.uniform(size=(100, 3)) * snap.box.lengths),
            "W1": cg.Grid(snap.box, (46, 46, 46))}


def timed_call(core, name, args, kwargs):
    t0 = time.perf_counter()
    out = getattr(core, name)(*args, **kwargs)
    return time.perf_counter() - t0, out


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--workloads", default="W2,P100")
    parser.add_argument("--kernels", default="lucy,heaviside,g1")
    parser.add_argument("--sets", default="stress,gradient")
    parser.add_argument("--compare", help="another build of the core (_core*.so) timed in the same rounds")
    args = parser.parse_args()
    snap = lattice()
    where = targets(snap)
    core = engine_module._core
    other = load_core(os.path.abspath(args.compare)) if args.compare else None
    print(header(args.threads, f"46^3 lattice: {snap.n_particles} particles, {len(snap.contacts)} contacts; "
                               f"medians of {args.repeat} round-robin runs"))
    print(f"{'workload':<9}{'kernel':<10}{'call':<26}{'objects':>8}{'nodes/obj':>10}{'python':>8}"
          f"{'setup':>8}{'per node':>9}{'total':>8}   ns per object (per node: ns per node)"
          + ("   other: setup, per node, total, same bits" if other else ""))
    for wl in args.workloads.split(","):
        for kname in args.kernels.split(","):
            for set_name in args.sets.split(","):
                fields = SETS[set_name]
                kernel = KERNELS[kname]()
                if set_name == "gradient" and kname == "heaviside":
                    continue                                # Heaviside has no gradient
                recorder = Recorder(core)
                engine_module._core = recorder
                try:
                    with cg.threads(args.threads):
                        cg.coarse_grain(snap, where[wl], kernel, fields)     # warm-up, and the calls recorded
                        wholes, insides = [], []
                        for _ in range(args.repeat):
                            recorder.calls, recorder.seconds = [], 0.0
                            t0 = time.perf_counter()
                            cg.coarse_grain(snap, where[wl], kernel, fields)
                            wholes.append(time.perf_counter() - t0)
                            insides.append(recorder.seconds)
                finally:
                    engine_module._core = core
                n_objects = sum(len(c[1][2]) for c in recorder.calls)
                python_ns = statistics.median(np.subtract(wholes, insides)) / n_objects * 1e9
                for name, cargs, ckwargs in recorder.calls:
                    ckwargs = dict(ckwargs, n_threads=args.threads)
                    small = (cargs[0], shrunk(cargs[1])) + tuple(cargs[2:])
                    builds = [("this", core)] + ([("other", other)] if other else [])
                    times = {(b, k): [] for b, _ in builds for k in ("full", "tiny")}
                    outs = {}
                    for r in range(args.repeat):
                        for b, module in (builds if r % 2 == 0 else builds[::-1]):
                            dt, outs[b] = timed_call(module, name, cargs, ckwargs)
                            times[(b, "full")].append(dt)
                            times[(b, "tiny")].append(timed_call(module, name, small, ckwargs)[0])
                    n = len(cargs[2])
                    pairs = pairs_in_support(name, cargs)
                    cells = []
                    for b, _ in builds:
                        full = statistics.median(times[(b, "full")]) * 1e9
                        tiny = statistics.median(times[(b, "tiny")]) * 1e9
                        cells.append((tiny / n, (full - tiny) / max(pairs, 1), full / n))
                    label = name.replace("scatter_", "") + (" grad" if ckwargs.get("gradient") else "")
                    setup, per_node, total = cells[0]
                    line = (f"{wl:<9}{kname:<10}{label:<26}{n:>8}{pairs / n:>10.2f}{python_ns:>8.0f}"
                            f"{setup:>8.0f}{per_node:>9.1f}{total:>8.0f}")
                    if other:
                        same = outs["this"].tobytes() == outs["other"].tobytes()
                        o_setup, o_node, o_total = cells[1]
                        line += f"   {o_setup:8.0f}{o_node:9.1f}{o_total:8.0f}  {same}"
                    print(line + f"   load {load_average().split()[0]}", flush=True)


if __name__ == "__main__":
    main()
