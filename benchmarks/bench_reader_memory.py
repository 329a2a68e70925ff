"""Peak memory of reading a large dump frame by frame: it should stay near one frame's tables.

    python benchmarks/bench_reader_memory.py [--size-gb 1.0] [--dir /tmp/cgbound-bench-memory] [--gzip]
                                             [--format lammps|mercury]

Writes (once, into --dir) a LAMMPS ``dump custom`` of --size-gb GB: the W1 lattice's atoms (97,336 particles,
13 columns, about 10 MB of text per frame) repeated with increasing timesteps; with --gzip also a gzipped
copy. Each file is then read in a fresh process through ``LammpsReader``, every frame turned into a
Snapshot and dropped. Printed: the process's anonymous resident memory (``RssAnon`` of /proc/self/status:
the heap, NumPy arrays, zlib state) after ``import cgbound``, its largest value while reading (sampled every
3 ms by a thread, and after the scan and every frame), their difference, the size of one frame's parsed table, and the largest
file-backed resident memory (``RssFile``: pages of the memory-mapped dump, which the kernel reclaims at will
and which is not the reader's memory). The reader keeps one frame at a time, so the growth should be a few
frames' tables, whatever the file size.

With --format mercury the same lattice, with its contacts, is written as MercuryDPM ``.data`` and ``.fstat``
files of --size-gb GB together (one frame written by cgbound's writer, repeated with times 0, 1, 2, ...) and
read through ``MercuryReader``; the frame table is then the particles' and the contacts' tables.
"""
import argparse
import gzip
import json
import os
import shutil
import subprocess
import sys
import threading
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


def write_mercury_pair(stem, size_bytes):
    """stem.data and stem.fstat of about size_bytes together: one frame repeated with times 0, 1, 2, ..."""
    stamp = f"{stem}.done-{size_bytes}"
    if os.path.exists(stamp):
        return
    import cgbound as cg
    from cgbound.readers.mercury import write_mercury

    snap = lattice()
    snap = cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box, contacts=snap.contacts,
                       radii=np.full(snap.n_particles, 0.5))
    write_mercury([snap], stem + ".one.data", stem + ".one.fstat")
    with open(stem + ".one.data", "rb") as fh:
        data = fh.read()
    with open(stem + ".one.fstat", "rb") as fh:
        fstat = fh.read()
    data_head, data_body = data.split(b"\n", 1)
    words = data_head.split()
    assert words[1] == b"0" and fstat.startswith(b"# 0 1\n")
    fstat_heads = b"\n".join(fstat.split(b"\n", 3)[1:3]) + b"\n"
    fstat_body = b"\n" + fstat.split(b"\n", 3)[3]
    frames = max(1, round(size_bytes / (len(data) + len(fstat))))
    with open(stem + ".data", "wb") as fd, open(stem + ".fstat", "wb") as ff:
        for k in range(frames):
            t = str(k).encode()
            fd.write(b" ".join([words[0], t] + words[2:]) + b"\n" + data_body)
            body = fstat_body.replace(b"\n0 ", b"\n" + t + b" ")
            ff.write(b"# " + t + b" 1\n" + fstat_heads + body[1:])
    os.remove(stem + ".one.data")
    os.remove(stem + ".one.fstat")
    open(stamp, "w").close()


def measure(path):
    """Run in a fresh process: JSON with the anonymous resident memory before and while reading every frame."""
    import cgbound as cg

    def rss_mb():
        with open("/proc/self/status") as fh:
            fields = dict(line.split(":", 1) for line in fh if line.startswith("Rss"))
        return {k: int(v.split()[0]) / 1024.0 for k, v in fields.items()}

    before = rss_mb()["RssAnon"]
    # a thread samples the anonymous memory every few ms, so the peak inside the scan and the parses is seen too
    sampled = {"anon": before, "stop": False}

    def sample():
        while not sampled["stop"]:
            sampled["anon"] = max(sampled["anon"], rss_mb()["RssAnon"])
            time.sleep(0.003)

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    mercury = path.endswith((".data", ".data.gz"))
    if mercury:
        fstat = path.replace(".data", ".fstat")
        reader = cg.readers.MercuryReader(path, fstat, density=6 / np.pi)
    else:
        reader = cg.readers.LammpsReader(path)
    peak_anon, peak_file = rss_mb()["RssAnon"], rss_mb()["RssFile"]
    start = time.perf_counter()
    frames = 0
    table_mb = 0.0
    for snap in reader:
        frames += 1
        if mercury:   # the .data table (14 columns) and the .fstat table (16 columns, two lines per pair)
            table_mb = (snap.n_particles * 14 + 2 * len(snap.contacts) * 16) * 8 / 2**20
        else:
            table_mb = snap.n_particles * 13 * 8 / 2**20     # the parsed table of one frame, float64
        now = rss_mb()
        peak_anon, peak_file = max(peak_anon, now["RssAnon"]), max(peak_file, now["RssFile"])
        del snap
    wall = time.perf_counter() - start
    sampled["stop"] = True
    sampler.join()
    peak_anon = max(peak_anon, sampled["anon"])
    print(json.dumps({"frames": frames, "before_mb": before, "peak_mb": peak_anon, "file_mb": peak_file,
                      "table_mb": table_mb, "wall": wall}))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size-gb", type=float, default=1.0)
    parser.add_argument("--dir", default="/tmp/cgbound-bench-memory")
    parser.add_argument("--gzip", action="store_true", help="also read a gzipped copy")
    parser.add_argument("--format", choices=("lammps", "mercury"), default="lammps",
                        help="a LAMMPS dump, or a MercuryDPM .data/.fstat pair")
    parser.add_argument("--measure", help=argparse.SUPPRESS)      # internal: the child process
    args = parser.parse_args()
    if args.measure:
        measure(args.measure)
        return
    if not args.size_gb > 0:
        parser.error(f"--size-gb: expected a positive size, got {args.size_gb}")
    os.makedirs(args.dir, exist_ok=True)
    if args.format == "mercury":
        stem = os.path.join(args.dir, "lattice")
        write_mercury_pair(stem, int(args.size_gb * 2**30))
        path = stem + ".data"
        if args.gzip:
            gzip_copy(stem + ".fstat")
    else:
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
        size = os.path.getsize(p) + (os.path.getsize(p.replace(".data", ".fstat")) if ".data" in p else 0)
        print(f"{os.path.basename(p):<16}{size / 2**20:>10.0f}{r['frames']:>8}{r['table_mb']:>16.1f}"
              f"{r['before_mb']:>19.0f}{r['peak_mb']:>11.0f}{r['peak_mb'] - r['before_mb']:>11.0f}{r['file_mb']:>16.0f}"
              f"{r['wall']:>8.1f}")


if __name__ == "__main__":
    main()
