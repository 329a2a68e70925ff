"""Peak memory of reading a large dump frame by frame: it should stay near one frame's tables.

    python benchmarks/bench_reader_memory.py [--size-gb 1.0] [--dir /tmp/cgbound-bench-memory] [--gzip]

Writes (once, into --dir) a LAMMPS ``dump custom`` of --size-gb GB: the W1 lattice's atoms (97,336 particles,
13 columns, about 10 MB of text per frame) repeated with increasing timesteps; with --gzip also a gzipped
copy. Each file is then read in a fresh process through ``LammpsReader``, every frame turned into a
Snapshot and dropped. Printed: the process's anonymous resident memory (``RssAnon`` of /proc/self/status:
the heap, NumPy arrays, zlib state) after ``import cgbound``, its largest value while reading (sampled after
the scan and after every frame), their difference, the size of one frame's parsed table, and the largest
file-backed resident memory (``RssFile``: pages of the memory-mapped dump, which the kernel reclaims at will
and which is not the reader's memory). The reader keeps one frame at a time, so the growth should be a few
frames' tables, whatever the file size.
"""
import argparse
import gzip
import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from common import header  # noqa: E402
from workloads import lattice  # noqa: E402

COLUMNS = "id type x y z vx vy vz fx fy fz radius mass"


def one_frame_text(snap):
    """The body of one frame (everything after its TIMESTEP value) as bytes."""
    n = snap.n_particles
    lines = [f"ITEM: NUMBER OF ATOMS\n{n}\nITEM: BOX BOUNDS ff ff ff\n"]
    lines += [f"{float(lo)!r} {float(hi)!r}\n" for lo, hi in zip(snap.box.lower, snap.box.upper)]
    lines.append(f"ITEM: ATOMS {COLUMNS}\n")
    body = np.concatenate([snap.positions, snap.velocities, np.zeros((n, 3)), np.full((n, 1), 0.5),
                           snap.masses[:, None]], axis=1)
    fmt = "%d 1 " + " ".join(["%.17g"] * body.shape[1]) + "\n"
    lines += [fmt % (k + 1, *row) for k, row in enumerate(body.tolist())]
    return "".join(lines).encode()


def write_dump(path, size_bytes):
    """A dump of about size_bytes: one frame repeated with timesteps 0, 1000, 2000, ..."""
    stamp = f"{path}.done-{size_bytes}"
    if os.path.exists(stamp):
        return
    body = one_frame_text(lattice())
    frames = max(1, round(size_bytes / len(body)))
    with open(path, "wb") as fh:
        for k in range(frames):
            fh.write(f"ITEM: TIMESTEP\n{1000 * k}\n".encode())
            fh.write(body)
    open(stamp, "w").close()


def gzip_copy(path):
    target = path + ".gz"
    if not os.path.exists(target + ".done"):
        with open(path, "rb") as src, gzip.open(target, "wb", compresslevel=1) as dst:
            shutil.copyfileobj(src, dst, 16 << 20)
        open(target + ".done", "w").close()
    return target


def measure(path):
    """Run in a fresh process: JSON with the anonymous resident memory before and while reading every frame."""
    import cgbound as cg

    def rss_mb():
        with open("/proc/self/status") as fh:
            fields = dict(line.split(":", 1) for line in fh if line.startswith("Rss"))
        return {k: int(v.split()[0]) / 1024.0 for k, v in fields.items()}

    before = rss_mb()["RssAnon"]
    reader = cg.readers.LammpsReader(path)
    peak_anon, peak_file = rss_mb()["RssAnon"], rss_mb()["RssFile"]
    start = time.perf_counter()
    frames = 0
    table_mb = 0.0
    for snap in reader:
        frames += 1
        table_mb = snap.n_particles * 13 * 8 / 2**20     # the parsed table of one frame, float64
        now = rss_mb()
        peak_anon, peak_file = max(peak_anon, now["RssAnon"]), max(peak_file, now["RssFile"])
        del snap
    wall = time.perf_counter() - start
    print(json.dumps({"frames": frames, "before_mb": before, "peak_mb": peak_anon, "file_mb": peak_file,
                      "table_mb": table_mb, "wall": wall}))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size-gb", type=float, default=1.0)
    parser.add_argument("--dir", default="/tmp/cgbound-bench-memory")
    parser.add_argument("--gzip", action="store_true", help="also read a gzipped copy")
    parser.add_argument("--measure", help=argparse.SUPPRESS)      # internal: the child process
    args = parser.parse_args()
    if args.measure:
        measure(args.measure)
        return
    if not args.size_gb > 0:
        parser.error(f"--size-gb: expected a positive size, got {args.size_gb}")
    os.makedirs(args.dir, exist_ok=True)
    path = os.path.join(args.dir, "atoms.dump")
    write_dump(path, int(args.size_gb * 2**30))
    paths = [path] + ([gzip_copy(path)] if args.gzip else [])
    print(header(1))
    print(f"{'file':<16}{'size MB':>10}{'frames':>8}{'frame table MB':>16}{'anon after import':>19}"
          f"{'anon peak':>11}{'growth MB':>11}{'file-backed MB':>16}{'wall s':>8}")
    for p in paths:
        out = subprocess.run([sys.executable, os.path.abspath(__file__), "--measure", p], check=True,
                             capture_output=True, text=True)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        print(f"{os.path.basename(p):<16}{os.path.getsize(p) / 2**20:>10.0f}{r['frames']:>8}{r['table_mb']:>16.1f}"
              f"{r['before_mb']:>19.0f}{r['peak_mb']:>11.0f}{r['peak_mb'] - r['before_mb']:>11.0f}{r['file_mb']:>16.0f}"
              f"{r['wall']:>8.1f}")


if __name__ == "__main__":
    main()
