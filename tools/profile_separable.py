"""Where the Gaussian's exact contact stress on W1 spends its instructions (callgrind) or its time (perf).

    python tools/profile_separable.py callgrind [--cutoff 3] [--n 46] [--keep FILE]
    python tools/profile_separable.py perf [--cutoff 3] [--n 46]
    python tools/profile_separable.py annotate FILE [--cutoff 3] [--n 46]   (an existing callgrind output)

W1 (benchmarks/workloads.py's lattice, n^3 particles, XYZ grid n^3), field contact_stress alone, Gaussian w = 1,
cutoff c w, normalize="truncated", exact line integrals, one thread, one call. callgrind counts instructions
(valgrind hides AVX-512, so the 4-wide AVX2 build runs there); perf samples time (perf record -e cpu-clock: the
build the CPU picks, 8-wide with AVX-512; hardware counters are not needed). Source lines need the extension
built with -g (the code is the same): CFLAGS=-g python setup.py build_ext --inplace.

The lines of csrc/cg_separable.c (and the exponential of cg_vmath.h, inlined into it) are grouped by the function
they belong to, and the body of the visit by its sections (found by comments in it); each group is printed as a
share, per contact and per node of the capsules (the nodes within the cutoff of a segment: the rule's, whose
ball holds the whole segment, and the cut ones, evaluated by the closed form), counted here in NumPy.
"""
import argparse
import collections
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SOURCE = os.path.join(ROOT, "csrc", "cg_separable.c")
# sections of the visit's body: (a comment or statement that starts one, its name), in source order
VISIT_SECTIONS = [
    ("/* the rule: G points on the object", "visit: stencil, exponential tables"),
    ("rows whose line misses the capsule carry nothing", "visit: plane masks"),
    ("/* the nodes of the row that receive anything", "visit: row's rule interval (ball masks)"),
    ("/* the capsule's nodes (row_distance2's operations)", "visit: row's capsule mask, cut nodes gathered"),
    ("cg_index a = 0, b = n2;", "visit: scalar row path (n2 > 64), row's accumulation call"),
]
FUNCTION = re.compile(r"^(?:INLINE|static|int|void|HOT_CLONES)\b.*?\b(\w+)\s*\(")

WORKER = r"""
import os, sys
sys.path.insert(0, os.path.join({root!r}, "benchmarks"))
import cgbound as cg
from workloads import lattice
snap = lattice(n={n})
grid = cg.Grid(snap.box, ({n}, {n}, {n}))
with cg.threads(1):
    cg.coarse_grain(snap, grid, cg.Gaussian(1.0, cutoff={cutoff}, normalize="truncated"), fields=("contact_stress",))
"""


def line_groups():
    """Group name per line number (1-based) of cg_separable.c."""
    with open(SOURCE) as f:
        lines = f.read().splitlines()
    groups, current, in_visit, section = {}, "file scope", False, None
    for number, text in enumerate(lines, 1):
        m = FUNCTION.match(text)
        if m and not text.rstrip().endswith(";"):
            name = m.group(1)
            in_visit = name == "VISIT_SEPARABLE"
            current = "visit" if in_visit else name
            section = None
        if in_visit:
            for marker, name in VISIT_SECTIONS:
                if marker in text:
                    section = name
            groups[number] = section or "visit: stencil, exponential tables"
        else:
            groups[number] = current
    return groups


def capsule_counts(n, cutoff):
    """(contacts, capsule nodes, of which the rule's) of W1 at this cutoff (w = 1), counted node by node."""
    import numpy as np
    sys.path[:0] = [ROOT, os.path.join(ROOT, "benchmarks")]
    from workloads import lattice
    snap = lattice(n=n)
    c = snap.contacts
    a, e = snap.positions[c.i], snap.positions[c.j] - snap.positions[c.i]
    h = (snap.box.upper - snap.box.lower) / n
    R2 = cutoff * cutoff
    span = int(np.ceil((2 * cutoff + np.abs(e).max()) / h.min())) + 2
    offsets = np.stack(np.meshgrid(*[np.arange(span)] * 3, indexing="ij"), -1).reshape(-1, 3)
    capsule = rule = 0
    for s in range(0, len(a), 500):   # chunks of 500 contacts (5w: 3,375 stencil offsets each)
        A, E = a[s:s + 500], e[s:s + 500]
        first = np.floor((np.minimum(A, A + E) - cutoff - snap.box.lower) / h - 0.5)
        idx = first[:, None, :] + offsets[None]
        inside = np.all((idx >= 0) & (idx < n), axis=2)
        q = snap.box.lower + (idx + 0.5) * h - A[:, None, :]
        L2 = (E * E).sum(1)[:, None]
        t = np.clip((q * E[:, None, :]).sum(2) / L2, 0.0, 1.0)
        d2 = ((q - t[..., None] * E[:, None, :]) ** 2).sum(2)
        both = ((q * q).sum(2) < R2) & (((q - E[:, None, :]) ** 2).sum(2) < R2)
        capsule += int((inside & (d2 < R2)).sum())
        rule += int((inside & both).sum())
    return len(a), capsule, rule


def report(costs, unit, n, cutoff):
    contacts, nodes, rule = capsule_counts(n, cutoff)
    total = sum(costs.values())
    print(f"# W1 n={n}: {contacts} contacts; capsule nodes {nodes} ({nodes / contacts:.1f} per contact: "
          f"{rule / contacts:.1f} by the rule, {(nodes - rule) / contacts:.1f} cut); cutoff {cutoff} w")
    print(f"# total {total:.4g} {unit}: {total / contacts:.0f} per contact, {total / nodes:.1f} per capsule node")
    print(f"{'share':>7} {'per contact':>12} {'per node':>9}  group")
    for name, value in sorted(costs.items(), key=lambda kv: -kv[1]):
        print(f"{100 * value / total:6.1f}% {value / contacts:12.0f} {value / nodes:9.2f}  {name}")


def annotate_callgrind(path):
    """Instructions per group from a callgrind output (callgrind_annotate's per-line listing)."""
    text = subprocess.run(["callgrind_annotate", "--auto=yes", "--show-percs=no", "--threshold=100", path],
                          check=True, stdout=subprocess.PIPE, text=True, cwd=ROOT).stdout
    groups, costs, current, number = line_groups(), collections.Counter(), None, 0
    for line in text.splitlines():
        m = re.match(r"-- Auto-annotated source: (\S+)", line)
        if m:
            current, number = m.group(1), 0
            continue
        if current is None or "=>" in line:
            continue
        m = re.match(r"-- line (\d+)", line)
        if m:
            number = int(m.group(1)) - 1
            continue
        m = re.match(r"\s*([\d,]+|\.)\s", line)
        if not m:
            continue
        number += 1
        if m.group(1) == ".":
            continue
        count = int(m.group(1).replace(",", ""))
        if current.endswith("cg_vmath.h"):
            costs["cg_exp_in_place (cg_vmath.h)"] += count
        elif current.endswith("cg_separable.c"):
            costs[groups.get(number, "?")] += count
    return costs


def run_callgrind(args):
    out = args.keep or tempfile.mktemp(suffix=".callgrind")
    code = WORKER.format(root=ROOT, n=args.n, cutoff=args.cutoff)
    env = dict(os.environ, PYTHONPATH=ROOT)
    subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", sys.executable, "-c", code],
                   check=True, env=env)
    return annotate_callgrind(out)


def run_perf(args):
    data = tempfile.mktemp(suffix=".perf")
    code = WORKER.format(root=ROOT, n=args.n, cutoff=args.cutoff)
    env = dict(os.environ, PYTHONPATH=ROOT)
    subprocess.run(["perf", "record", "-e", "cpu-clock", "-F", "2000", "-o", data, sys.executable, "-c", code],
                   check=True, env=env)
    text = subprocess.run(["perf", "report", "-i", data, "--no-children", "--sort", "srcline"], check=True,
                          stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True).stdout
    os.unlink(data)
    groups, costs = line_groups(), collections.Counter()
    for line in text.splitlines():
        m = re.match(r"\s*([\d.]+)%\s+(\S+):(\d+)", line)
        if not m:
            continue
        share, name, number = float(m.group(1)), m.group(2), int(m.group(3))
        if name.endswith("cg_vmath.h"):
            costs["cg_exp_in_place (cg_vmath.h)"] += share
        elif name.startswith("cg_separable"):  # cg_separable_wide.c includes cg_separable.c
            costs[groups.get(number, "?")] += share
        else:
            costs["outside cg_separable.c"] += share
    return costs


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("mode", choices=["callgrind", "perf", "annotate"])
    parser.add_argument("file", nargs="?", help="annotate: a callgrind output file")
    parser.add_argument("--cutoff", type=float, default=3.0, help="cutoff in w (default 3)")
    parser.add_argument("--n", type=int, default=46, help="lattice size (default 46: W1)")
    parser.add_argument("--keep", help="callgrind: keep the output in this file")
    args = parser.parse_args()
    if args.mode == "annotate":
        if not args.file:
            parser.error("annotate: expected a callgrind output file, got none")
        report(annotate_callgrind(args.file), "instructions", args.n, args.cutoff)
    elif args.mode == "callgrind":
        report(run_callgrind(args), "instructions", args.n, args.cutoff)
    else:
        costs = run_perf(args)
        costs.pop("outside cg_separable.c", None)
        report(costs, "% of samples", args.n, args.cutoff)


if __name__ == "__main__":
    main()
