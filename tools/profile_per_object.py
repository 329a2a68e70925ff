"""The core's fixed cost per object, in instructions (callgrind): each scatter call of bench_per_object's
workloads with the kernel shrunk to a radius of 1e-9 (each object reaches at most one node).

    python tools/profile_per_object.py [--workloads W2,P100] [--kernels lucy,heaviside,g1]
                                       [--sets stress,gradient] [--functions 12] [--full]

The calls are recorded outside valgrind (coarse_grain on the 46^3 lattice, as bench_per_object.py), then
replayed once each, one thread, under ``valgrind --tool=callgrind`` collecting only inside the C entry
points (cg_scatter_*), one dump per call. Prints instructions per object per call and, with --functions N,
the N functions with the most self instructions of each call. --full: the kernel as given instead (the
per-object cost with the work per node). valgrind hides AVX-512: the AVX2 build runs there.
"""
import argparse
import glob
import os
import pickle
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path[:0] = [ROOT, os.path.join(ROOT, "benchmarks")]

# --dump-after takes no wildcards
ENTRY_POINTS = ("cg_scatter_points", "cg_scatter_points_kinetic", "cg_scatter_segments", "cg_scatter_segments_outer",
                "cg_scatter_segment_moments", "cg_scatter_fluctuation")

WORKER = r"""
import pickle, sys
sys.path.insert(0, {root!r})
from cgbound import _engine
calls = pickle.load(open({path!r}, "rb"))
for name, args, kwargs in calls:
    getattr(_engine._core, name)(*args, **kwargs)
"""


def record(workloads, kernels, sets, full):
    """[(label, n_objects, (name, args, kwargs))] for every scatter call of the workloads."""
    import cgbound as cg
    from cgbound import _engine as engine_module
    import bench_per_object as bpo
    from workloads import lattice
    snap = lattice()
    where = bpo.targets(snap)
    out = []
    core = engine_module._core
    for wl in workloads:
        for kname in kernels:
            for set_name in sets:
                if set_name == "gradient" and kname == "heaviside":
                    continue
                recorder = bpo.Recorder(core)
                engine_module._core = recorder
                try:
                    with cg.threads(1):
                        cg.coarse_grain(snap, where[wl], bpo.KERNELS[kname](), bpo.SETS[set_name])
                finally:
                    engine_module._core = core
                for name, cargs, ckwargs in recorder.calls:
                    kernel = cargs[1] if full else bpo.shrunk(cargs[1])
                    call = (name, (cargs[0], kernel) + tuple(cargs[2:]), dict(ckwargs, n_threads=1))
                    label = name.replace("scatter_", "") + (" grad" if ckwargs.get("gradient") else "")
                    out.append((f"{wl:<6}{kname:<10}{label:<20}", len(cargs[2]), call))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--workloads", default="W2,P100")
    parser.add_argument("--kernels", default="lucy,heaviside,g1")
    parser.add_argument("--sets", default="stress,gradient")
    parser.add_argument("--functions", type=int, default=0)
    parser.add_argument("--full", action="store_true")
    parser.add_argument("--keep", help="a directory to keep the callgrind dumps in (callgrind_annotate --auto=yes)")
    args = parser.parse_args()
    calls = record(args.workloads.split(","), args.kernels.split(","), args.sets.split(","), args.full)
    with tempfile.TemporaryDirectory() as tmp:
        if args.keep:
            os.makedirs(args.keep, exist_ok=True)
            tmp = args.keep
        path = os.path.join(tmp, "calls.pickle")
        with open(path, "wb") as f:
            pickle.dump([c for _, _, c in calls], f)
        script = os.path.join(tmp, "worker.py")
        with open(script, "w") as f:
            f.write(WORKER.format(root=ROOT, path=path))
        base = os.path.join(tmp, "cg.out")
        for old in glob.glob(base + "*"):
            os.remove(old)                        # a kept directory's earlier dumps
        subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={base}",
                        "--toggle-collect=cg_scatter_*",
                        "--compress-strings=no"]
                       + [f"--dump-after={f}" for f in ENTRY_POINTS] + [sys.executable, script],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        dumps = sorted(glob.glob(base + ".*"), key=lambda p: int(re.search(r"\.(\d+)$", p).group(1)))
        dumps = [d for d in dumps if total_of(d) > 0]
        if len(dumps) != len(calls):
            sys.exit(f"{len(dumps)} dumps with instructions for {len(calls)} calls")
        print(f"# instructions per object, {'kernel as given' if args.full else 'kernel radius 1e-9'}, "
              "one thread, AVX2 build (callgrind)")
        for (label, n, _), dump in zip(calls, dumps):
            print(f"{label}{n:>8}{total_of(dump) / n:>10.1f}")
            if args.functions:
                for ir, fn in top_functions(dump, args.functions):
                    print(f"        {ir / n:10.1f}  {fn}")


def total_of(dump):
    with open(dump) as f:
        for line in f:
            if line.startswith("totals:") or line.startswith("summary:"):
                return int(line.split()[1])
    return 0


def top_functions(dump, count):
    text = subprocess.run(["callgrind_annotate", "--threshold=100", dump], capture_output=True, text=True).stdout
    rows = []
    for line in text.splitlines():
        m = re.match(r"\s*([\d,]+)\s+\([^)]*\)\s+(\S.*)$", line)
        if m and ":" in m.group(2) and "python-build" not in m.group(2) and "/csu/" not in m.group(2) \
                and not m.group(2).startswith("???"):
            rows.append((int(m.group(1).replace(",", "")), m.group(2).split(" [")[0]))
    return rows[:count]


if __name__ == "__main__":
    main()
