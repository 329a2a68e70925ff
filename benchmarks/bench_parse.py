"""Text parsing throughput on W1-sized dumps: the C text layer vs today's reader parsing vs `wc -l`.

    python benchmarks/bench_parse.py [--repeat 5] [--dir /tmp/cgbound-bench-parse] [--format %.17g]

Files (written once into --dir, 2 frames each, from the W1 lattice: 97,336 particles, 285,660 contacts):
  atoms.dump   LAMMPS dump custom: id type x y z vx vy vz fx fy fz radius mass
  pairs.dump   LAMMPS dump local: id1 id2 fx fy fz cx cy cz delta (both orientations: 571,320 rows)
  w1.data      MercuryDPM .data (14 columns, species an integer)
  w1.fstat     MercuryDPM .fstat (16 columns, each pair on two lines, as MercuryDPM writes it)
Methods, each over the whole file (both frames), file in the page cache:
  cg_text      mmap + find_lines (frame starts) + parse_table of every frame's rows, int columns as int64, into
               reused table memory as the readers parse (parse_table(reuse=True): the steady state of a reader,
               the memory's pages already faulted in by an earlier frame)
  cg_text new  the same into new tables (each frame's table faulted in and zeroed by the kernel)
  fromstring   what the LAMMPS reader does per frame: readline the rows, b"".join, np.fromstring(sep=" ")
  per-line     what the MercuryDPM reader does: readline, split, float() per word, np.array at the end
  reader       LAMMPS dumps only: the LAMMPS/LIGGGHTS reader's own parsing (readers/_lammps_dump.py):
               scan_dump (frame offsets, structure checks) + DumpIndex.read of every frame
  reader gz    the same on a gzipped copy (zlib stream into the same parser; with --gzip)
  wc -l        the same bytes through `wc -l` (a lower bound for any line-oriented reader)
MB/s = file size / median wall time (CPU time printed too). cg_text and reader run on one thread; with
--threads N > 1 also `cg_text Nt`, `cg_text new Nt` and `reader Nt`: frames of >= 4 MB cut at line starts over
N threads. A reader is alive throughout (the spare table and text are kept from run to run, as while a reader
reads frame after frame).
"""
import argparse
import mmap
import os
import resource
import shutil
import statistics
import subprocess
import sys
import time

import numpy as np

import cgbound as cg

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from common import header, timed  # noqa: E402
from workloads import lattice  # noqa: E402

from cgbound.readers import _text  # noqa: E402
from cgbound.readers._lammps_dump import scan_dump  # noqa: E402


def write_rows(fh, table, fmt):
    row = " ".join([fmt] * table.shape[1]) + "\n"
    for start in range(0, len(table), 20000):
        fh.write("".join(row % tuple(r) for r in table[start:start + 20000].tolist()))


def write_files(directory, fmt):
    os.makedirs(directory, exist_ok=True)
    paths = {name: os.path.join(directory, name) for name in ("atoms.dump", "pairs.dump", "w1.data", "w1.fstat")}
    stamp = os.path.join(directory, f"done-{fmt.replace('%', 'p')}")
    if os.path.exists(stamp):
        return paths
    snap = lattice()
    n, c = snap.n_particles, snap.contacts
    pos, vel = snap.positions, snap.velocities
    frc = np.zeros_like(pos)
    np.add.at(frc, c.i, c.force)
    np.add.at(frc, c.j, -c.force)
    rad = np.full(n, 0.5)
    ii = np.concatenate([c.i, c.j])
    jj = np.concatenate([c.j, c.i])
    ff = np.concatenate([c.force, -c.force])
    pp = np.concatenate([c.point, c.point])
    nrm = pos[ii] - pos[jj]
    dist = np.linalg.norm(nrm, axis=1)
    nrm /= dist[:, None]
    delta = 1.0 - dist
    fn = np.einsum("ij,ij->i", ff, nrm)
    with open(paths["atoms.dump"], "w") as fh:
        for step in (0, 1000):
            fh.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{n}\nITEM: BOX BOUNDS ff ff ff\n")
            fh.write("".join(f"{float(lo)!r} {float(hi)!r}\n" for lo, hi in zip(snap.box.lower, snap.box.upper)))
            fh.write("ITEM: ATOMS id type x y z vx vy vz fx fy fz radius mass\n")
            head = np.stack([np.arange(1, n + 1), np.ones(n, np.int64)], axis=1)
            body = np.concatenate([pos, vel, frc, rad[:, None], snap.masses[:, None]], axis=1)
            rowfmt = "%d %d " + " ".join([fmt] * body.shape[1]) + "\n"
            for s in range(0, n, 20000):
                fh.write("".join(rowfmt % (*h, *b) for h, b in zip(head[s:s + 20000].tolist(),
                                                                   body[s:s + 20000].tolist())))
    with open(paths["pairs.dump"], "w") as fh:
        for step in (0, 1000):
            fh.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ENTRIES\n{len(ii)}\nITEM: BOX BOUNDS ff ff ff\n")
            fh.write("".join(f"{float(lo)!r} {float(hi)!r}\n" for lo, hi in zip(snap.box.lower, snap.box.upper)))
            fh.write("ITEM: ENTRIES c_pl[1] c_pl[2] c_pl[3] c_pl[4] c_pl[5] c_pp[1] c_pp[2] c_pp[3] c_pp[4]\n")
            rowfmt = "%d %d " + " ".join([fmt] * 7) + "\n"
            body = np.concatenate([ff, pp, delta[:, None]], axis=1)
            for s in range(0, len(ii), 20000):
                fh.write("".join(rowfmt % (a + 1, b + 1, *r) for a, b, r in zip(
                    ii[s:s + 20000].tolist(), jj[s:s + 20000].tolist(), body[s:s + 20000].tolist())))
    with open(paths["w1.data"], "w") as fh:
        for t in (0.0, 0.5):
            lo, hi = snap.box.lower, snap.box.upper
            fh.write(f"{n} {t!r} {' '.join(map(repr, lo))} {' '.join(map(repr, hi))}\n")
            body = np.concatenate([pos, vel, rad[:, None], np.zeros((n, 6))], axis=1)
            rowfmt = " ".join([fmt] * body.shape[1]) + " 0\n"
            for s in range(0, n, 20000):
                fh.write("".join(rowfmt % tuple(r) for r in body[s:s + 20000].tolist()))
    with open(paths["w1.fstat"], "w") as fh:
        for t in (0.0, 0.5):
            fh.write(f"# {t!r} 1\n# 0 0 0 45.54 45.54 45.54\n# 0.5 0.5 0 0 0 0\n")
            tang = np.zeros_like(nrm)
            body = np.concatenate([pp, delta[:, None], np.zeros((len(ii), 1)), fn[:, None],
                                   np.zeros((len(ii), 1)), nrm, tang], axis=1)
            rowfmt = f"{t!r} %d %d " + " ".join([fmt] * body.shape[1]) + "\n"
            for s in range(0, len(ii), 20000):
                fh.write("".join(rowfmt % (a, b, *r) for a, b, r in zip(
                    ii[s:s + 20000].tolist(), jj[s:s + 20000].tolist(), body[s:s + 20000].tolist())))
    open(stamp, "w").close()
    return paths


# ---------------------------------------------------------------------------------------------
# the parsers

def frames_of(kind, mm, threads=1):
    """(start, stop, ncols, nrows, int_columns) of every frame's rows (frame starts found on threads)."""
    size = len(mm)
    if kind == "lammps":
        starts = list(_text.find_lines(mm, b"ITEM: TIMESTEP", threads=threads)) + [size]
        out = []
        for a, b in zip(starts[:-1], starts[1:]):
            head = bytes(mm[a:a + 4096]).split(b"\n")
            n = int(head[3])
            ncols = len(head[8].split()) - 2
            rows = a + sum(len(x) + 1 for x in head[:9])
            out.append((rows, b, ncols, n, (0, 1)))
        return out
    if kind == "data":  # frames delimited only by the declared count: parsed to find the next one
        out, pos = [], 0
        while pos < size:
            end = mm.find(b"\n", pos)
            n = int(bytes(mm[pos:end]).split()[0])
            pos = _text.parse_table(mm, end + 1, size, 14, int_columns=(13,), nrows=n, stop_after_rows=True).end
            out.append((end + 1, pos, 14, n, (13,)))
        return out
    # fstat: frames start at a '#' line after rows; the rows follow the 3 header lines
    heads = list(_text.find_lines(mm, b"#", threads=threads))
    starts = heads[0::3] + [size]
    out = []
    for k, a in enumerate(starts[:-1]):
        rows = heads[3 * k + 2]
        rows = mm.find(b"\n", rows) + 1
        out.append((rows, starts[k + 1], 16, None, (1, 2)))
    return out


def parse_cg_text(path, kind, threads=1, reuse=True):
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as mm:
        total = 0
        if kind == "data":  # the scan parses each frame already (as a reader would keep it)
            pos, size = 0, len(mm)
            while pos < size:
                end = mm.find(b"\n", pos)
                n = int(bytes(mm[pos:end]).split()[0])
                table = _text.parse_table(mm, end + 1, size, 14, int_columns=(13,), nrows=n, stop_after_rows=True,
                                          threads=threads, reuse=reuse)
                total, pos = total + len(table.values), table.end
                del table
            return total
        for start, stop, ncols, n, ints in frames_of(kind, mm, threads):
            total += len(_text.parse_table(mm, start, stop, ncols, int_columns=ints, nrows=n, threads=threads,
                                           reuse=reuse).values)
        return total


class _Reader:
    """Stands for a reader that lives through the runs: the spare text and table are kept while it does."""


def read_with_reader(path, kind, threads=1):
    """The LAMMPS reader's parsing: one scan, then every frame parsed (IDs and types as int64)."""
    with cg.threads(threads):
        index = scan_dump(path, kind)
        ints = ("c_pl[1]", "c_pl[2]") if kind == "local" else ()
        return sum(index.read(offset, ints)["n"] for offset, _ in index)


def gzipped_copy(path):
    out = path + ".gz"
    if not os.path.exists(out):
        import gzip
        with open(path, "rb") as a, gzip.open(out, "wb", compresslevel=6) as b:
            shutil.copyfileobj(a, b, 1 << 22)
    return out


def parse_fromstring(path, kind):
    """The LAMMPS reader's way (per frame: readline rows, join, np.fromstring)."""
    total = 0
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as mm:
        frames = frames_of(kind, mm)
    with open(path, "rb") as fh:
        for start, stop, ncols, n, _ in frames:
            fh.seek(start)
            raw = b"".join(fh.readline() for _ in range(n)) if n is not None else fh.read(stop - start)
            values = np.fromstring(raw.decode(), sep=" ")
            total += values.size // ncols
    return total


def parse_per_line(path, kind):
    """The MercuryDPM reader's way (readline, split, float() per word)."""
    total = 0
    with open(path, "rb") as fh:
        for line in fh:
            if line.startswith(b"#") or line.startswith(b"ITEM"):
                continue
            words = line.split()
            if kind == "data" and len(words) < 14 or kind == "lammps" and len(words) < 9:
                continue  # frame header lines
            row = [float(w) for w in [w.decode() for w in words]]
            total += len(row) > 0
    return total


def wc_l(path):
    subprocess.run(["wc", "-l", path], check=True, stdout=subprocess.DEVNULL)


def timed_wc(path, repeat):
    """Median wall time and median CPU time (user + system of the child) of `wc -l`."""
    wc_l(path)
    walls, cpus = [], []
    for _ in range(repeat):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        wc_l(path)
        walls.append(time.perf_counter() - start)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    return statistics.median(walls), statistics.median(cpus)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--dir", default="/tmp/cgbound-bench-parse")
    ap.add_argument("--format", default="%.17g", help="printf format of the floats in the files")
    ap.add_argument("--slow-repeat", type=int, default=1, help="repeats of the per-line Python parser")
    ap.add_argument("--skip-slow", action="store_true", help="time only cg_text, the reader and wc -l")
    ap.add_argument("--gzip", action="store_true", help="also time the LAMMPS reader on gzipped copies")
    ap.add_argument("--only", nargs="*", help="only these files (e.g. atoms.dump pairs.dump)")
    ap.add_argument("--threads", type=int, default=2, help="also time cg_text and the reader on this many threads")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    reader = _Reader()
    _text.hold_spare(reader)
    paths = write_files(args.dir, args.format)
    print(f"# files in {args.dir} (written or reused in {time.perf_counter() - t0:.1f} s); floats as {args.format}")
    print(header(threads=args.threads))
    have_wc = shutil.which("wc") is not None
    print("# MB/s = size / median wall time; MB/s cpu = size / median CPU time (on a loaded machine the CPU time\n"
          "# is the per-core figure); x wc -l = wall time / wc's wall time, cpu x wc = CPU time / wc's CPU time")
    print(f"{'file':<11} {'MB':>6} {'method':<14} {'median s':>9} {'min s':>8} {'cpu s':>7} {'MB/s':>8} "
          f"{'MB/s cpu':>9} {'x wc -l':>8} {'cpu x wc':>9}")
    kinds = {"atoms.dump": "lammps", "pairs.dump": "lammps", "w1.data": "data", "w1.fstat": "fstat"}
    for name, path in paths.items():
        if args.only and name not in args.only:
            continue
        kind = kinds[name]
        size = os.path.getsize(path) / 1e6
        wc, wc_cpu = timed_wc(path, args.repeat) if have_wc else (float("nan"), float("nan"))
        rows = parse_cg_text(path, kind)
        assert rows == parse_fromstring(path, kind), name
        methods = [("cg_text", lambda: parse_cg_text(path, kind), args.repeat),
                   ("fromstring", lambda: parse_fromstring(path, kind), args.repeat),
                   ("per-line", lambda: parse_per_line(path, kind), args.slow_repeat)]
        if kind == "lammps":
            dump_kind = "atoms" if name == "atoms.dump" else "local"
            assert read_with_reader(path, dump_kind) == rows, name
            methods.insert(1, ("reader", lambda: read_with_reader(path, dump_kind), args.repeat))
            if args.threads > 1:
                methods.insert(2, (f"reader {args.threads}t",
                                   lambda: read_with_reader(path, dump_kind, args.threads), args.repeat))
            if args.gzip:
                packed = gzipped_copy(path)
                methods.insert(2, ("reader gz", lambda: read_with_reader(packed, dump_kind), args.repeat))
        methods.insert(1, ("cg_text new", lambda: parse_cg_text(path, kind, reuse=False), args.repeat))
        if args.threads > 1:
            methods.insert(1, (f"cg_text {args.threads}t", lambda: parse_cg_text(path, kind, args.threads),
                               args.repeat))
            methods.insert(3, (f"cg_text new {args.threads}t",
                               lambda: parse_cg_text(path, kind, args.threads, reuse=False), args.repeat))
        if args.skip_slow:
            methods = [m for m in methods if m[0].startswith(("cg_text", "reader"))]
        for label, fn, repeat in methods:
            med, best, cpu = timed(fn, repeat, warmup=0, cpu=True)
            print(f"{name:<11} {size:6.1f} {label:<14} {med:9.3f} {best:8.3f} {cpu:7.3f} {size / med:8.1f} "
                  f"{size / cpu:9.1f} {med / wc:8.2f} {cpu / max(wc_cpu, 1e-9):9.2f}")
            if label.startswith("reader"):
                frames = len(scan_dump(path, "atoms" if name == "atoms.dump" else "local"))
                print(f"#   {label}: {frames} frames, {med / frames:.3f} s per frame (median wall), "
                      f"{cpu / frames:.3f} s CPU per frame")
        print(f"{name:<11} {size:6.1f} {'wc -l':<14} {wc:9.3f} {'':>8} {wc_cpu:7.3f} {size / wc:8.1f} "
              f"{size / max(wc_cpu, 1e-9):9.1f} {1.0:8.2f} {1.0:9.2f}")
        sys.stdout.flush()
    print(f"# load average at the end: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f}")


if __name__ == "__main__":
    main()
