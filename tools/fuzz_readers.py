"""Corruption fuzzer over genuine files of every reader: same data, or a clear error naming the file.

    python tools/fuzz_readers.py --n 2000 --seed 1          # random cases, table by reader and outcome
    python tools/fuzz_readers.py --n 500 --show "wrong kind"  # and print the cases with that outcome

Each case copies a target's genuine files (tests/data, and an HDF5 file written by cgbound's
write_snapshots) into a scratch directory, corrupts ONE of them with one mutation, and reads every
frame through the public reader API. Its outcome is one of OUTCOMES:

- "same data": read without error, every frame equal bit for bit to the genuine files' frames;
- "fewer frames": read without error, the frames read equal to the first frames of the genuine files
  (a file cut at a frame boundary is a shorter genuine file);
- "read as something else": read without an error, but not the genuine data;
- "clear error": ValueError (content) or OSError (files), naming the corrupted file;
- "error not naming the file": of the right type, but the message does not say which file;
- "wrong kind": any other exception (UnicodeDecodeError, KeyError, IndexError, TypeError, ...);
- "hang": no answer within --timeout seconds; "crash": the reading process died.

Cases run in worker subprocesses (a crash is caught and the worker restarted) with a SIGALRM watchdog.
Whether an outcome breaks the contract depends on the mutation: see ``contract_applies``.
"""
import argparse
import contextlib
import gzip
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data"

OUTCOMES = ("same data", "fewer frames", "clear error", "read as something else", "error not naming the file",
            "wrong kind", "hang", "crash")
#: outcomes that keep the contract "same data or a clear error naming the file, of the right type"
GOOD = ("same data", "clear error")


# ------------------------------------------------------------------------------------------- targets
def _lammps(paths):
    from cgbound.readers import LammpsReader
    return LammpsReader(paths["atoms.dump"], paths["pairs.dump"], pair_style="gran",
                        pair_values=("dist", "fx", "fy", "fz", "p1", "p2", "p3", "p4"), body_force=(0.0, 0.0, -1.0),
                        walls=["w"], fixed_types=[2])


def _lammps_input(paths):
    from cgbound.readers import read_input
    return read_input(paths["in.hooke3d"])


def _liggghts(paths):
    from cgbound.readers import LiggghtsReader
    return LiggghtsReader(paths["atoms.dump"], paths["pairs.dump"],
                          pair_values=("pos", "id", "force", "torque", "delta", "contactPoint"), fixed_types=[2],
                          body_force=(0.0, 0.0, -9.81))


def _mercurydpm(paths):
    from cgbound.readers import MercuryReader
    return MercuryReader(paths["ChutePeriodicDemo_t15.data"], paths["ChutePeriodicDemo_t15.fstat"],
                         fixed=np.arange(210), density=6 / np.pi, periodic=(True, True, False),
                         body_force=(np.sin(np.radians(24)), 0, -np.cos(np.radians(24))))


def _mercurydpm_restart(paths):
    from cgbound.readers import MercuryReader
    return MercuryReader(paths["ChutePeriodicDemo.data"], False, restart_path=paths["ChutePeriodicDemo.restart"])


def _mercurycg(paths):
    from cgbound.mercurycg import read_stat
    return read_stat(paths["ChutePeriodicDemo_t15.Z_Gauss_w0.5.stat"])


def _yade(paths):
    from cgbound.readers import YadeReader
    return YadeReader(sorted(p for p in paths.values() if p.endswith(".npz")))


def _hdf5(paths):
    from cgbound.readers import open_dataset
    return open_dataset(paths["frames.h5"])


def _write_hdf5(directory):
    """An HDF5 file of the LAMMPS frames, written by cgbound's write_snapshots."""
    from cgbound.readers import write_snapshots
    paths = {name: str(DATA / "lammps" / "hooke3d" / name) for name in ("atoms.dump", "pairs.dump")}
    path = os.path.join(directory, "frames.h5")
    write_snapshots(path, list(_lammps(paths)))
    return path


#: name -> (genuine files {name: source path or callable writing it into a directory}, the files to
#: corrupt, the opener, binary)
TARGETS = {
    "lammps": ({"atoms.dump": DATA / "lammps/hooke3d/atoms.dump", "pairs.dump": DATA / "lammps/hooke3d/pairs.dump"},
               ("atoms.dump", "pairs.dump"), _lammps, False),
    "lammps_input": ({"in.hooke3d": DATA / "lammps/in.hooke3d"}, ("in.hooke3d",), _lammps_input, False),
    "liggghts": ({"atoms.dump": DATA / "liggghts/atoms.dump", "pairs.dump": DATA / "liggghts/pairs.dump"},
                 ("atoms.dump", "pairs.dump"), _liggghts, False),
    "mercurydpm": ({"ChutePeriodicDemo_t15.data": DATA / "mercurycg/ChutePeriodicDemo_t15.data",
                    "ChutePeriodicDemo_t15.fstat": DATA / "mercurycg/ChutePeriodicDemo_t15.fstat"},
                   ("ChutePeriodicDemo_t15.data", "ChutePeriodicDemo_t15.fstat"), _mercurydpm, False),
    "mercurydpm_restart": ({"ChutePeriodicDemo.data": DATA / "mercurydpm/ChutePeriodicDemo/ChutePeriodicDemo.data",
                            "ChutePeriodicDemo.restart":
                                DATA / "mercurydpm/ChutePeriodicDemo/ChutePeriodicDemo.restart"},
                           ("ChutePeriodicDemo.restart",), _mercurydpm_restart, False),
    "mercurycg": ({"ChutePeriodicDemo_t15.Z_Gauss_w0.5.stat":
                       DATA / "mercurycg/ChutePeriodicDemo_t15.Z_Gauss_w0.5.stat"},
                  ("ChutePeriodicDemo_t15.Z_Gauss_w0.5.stat",), _mercurycg, False),
    "yade": ({"yade_0000003000.npz": DATA / "yade/periodic/yade_0000003000.npz",
              "yade_0000004000.npz": DATA / "yade/periodic/yade_0000004000.npz"},
             ("yade_0000003000.npz", "yade_0000004000.npz"), _yade, True),
    "hdf5": ({"frames.h5": _write_hdf5}, ("frames.h5",), _hdf5, True),
}

TEXT_MUTATIONS = ("truncate", "delete_line", "duplicate_line", "token_nan", "token_inf", "token_1e999",
                  "token_letters", "token_empty", "add_token", "drop_token", "blank_lines", "nul_bytes",
                  "invalid_utf8", "crlf", "gzip", "empty", "directory", "wrong_format")
BINARY_MUTATIONS = ("truncate", "nul_bytes", "gzip", "empty", "directory", "wrong_format")


def mutations_of(target):
    return BINARY_MUTATIONS if TARGETS[target][3] else TEXT_MUTATIONS


# ----------------------------------------------------------------------------------------- mutations
NUMBER = re.compile(rb"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")


def _lines(data):
    return data.splitlines(keepends=True)


def _token_spans(line):
    return [m.span() for m in re.finditer(rb"[^ \t\r\n]+", line)]


def mutate(data, kind, rng):
    """(corrupted bytes or the marker "directory", whether the contract must hold for this case, detail)."""
    if kind == "empty":
        return b"", True, ""
    if kind == "directory":
        return "directory", True, ""
    if kind == "wrong_format":
        other = DATA / "lammps/in.hooke3d"        # a LAMMPS input script in place of a data file
        if other.read_bytes() == data:
            other = DATA / "liggghts/atoms.dump"  # and a dump in place of the script
        return other.read_bytes(), True, other.name
    if kind == "gzip":
        return gzip.compress(data, mtime=0), True, ""
    if kind == "crlf":
        return data.replace(b"\r\n", b"\n").replace(b"\n", b"\r\n"), True, ""
    if kind == "truncate":
        cut = rng.randrange(0, max(1, len(data)))
        rest = data[cut:data.find(b"\n", cut) if b"\n" in data[cut:] else len(data)]
        # a cut inside a row's last token changes that number only (and, at the end of the file, may
        # leave a genuine shorter file): not detectable; a cut that loses a token or whole lines is
        at_line_start = cut == 0 or data[cut - 1:cut] == b"\n"
        structural = at_line_start or bool(re.search(rb"[ \t]", rest))
        return data[:cut], structural, f"at byte {cut}"
    lines = _lines(data)
    if not lines:
        return data, False, "no lines"
    if kind == "nul_bytes":
        k = rng.randrange(0, len(data) + 1)
        return data[:k] + b"\0" * rng.choice((1, 4)) + data[k:], True, f"at byte {k}"
    if kind == "invalid_utf8":
        k = rng.randrange(0, len(data) + 1)
        return data[:k] + b"\xff\xfe" + data[k:], True, f"at byte {k}"
    i = rng.randrange(len(lines))
    where = f"line {i + 1}"
    if kind == "delete_line":
        return b"".join(lines[:i] + lines[i + 1:]), bool(lines[i].strip()), where
    if kind == "duplicate_line":
        return b"".join(lines[:i + 1] + [lines[i]] + lines[i + 1:]), bool(lines[i].strip()), where
    if kind == "blank_lines":
        return b"".join(lines[:i] + [b"\n" * rng.choice((1, 2))] + lines[i:]), True, where
    # token mutations: on a line with tokens; the contract is asserted where the token was a number
    candidates = [j for j, line in enumerate(lines) if _token_spans(line)]
    if not candidates:
        return data, False, "no tokens"
    i = rng.choice(candidates)
    line = lines[i]
    spans = _token_spans(line)
    a, b = spans[rng.randrange(len(spans))]
    numeric = bool(NUMBER.match(line[a:b]))
    where = f"line {i + 1}, token {line[a:b][:20]!r}"
    if kind == "add_token":
        new = line[:b] + b" 1" + line[b:]
        structural = numeric and len(spans) > 1
    elif kind == "drop_token":
        if b < len(line.rstrip(b"\r\n")):
            new = line[:a] + line[b:].lstrip(b" \t")      # a token inside the row, with its separator
        else:
            new = line[:a].rstrip(b" \t") + line[b:]      # the row's last token
        structural = numeric and len(spans) > 1
    else:
        word = {"token_nan": b"nan", "token_inf": b"-inf", "token_1e999": b"1e999", "token_letters": b"abc",
                "token_empty": b""}[kind]
        new = line[:a] + word + line[b:]
        structural = numeric and (kind != "token_empty" or len(spans) > 1)
    return b"".join(lines[:i] + [new] + lines[i + 1:]), structural, where


# --------------------------------------------------------------------------------------- reading
def digest(value):
    """A comparable picture of what a reader returned: arrays by dtype, shape and bytes, objects by
    their attributes (recursively)."""
    if isinstance(value, np.ndarray):
        return ("array", value.dtype.str, value.shape, value.tobytes())
    if isinstance(value, (list, tuple)):
        return (type(value).__name__, tuple(digest(v) for v in value))
    if isinstance(value, dict):
        return ("dict", tuple(sorted((str(k), digest(v)) for k, v in value.items())))
    if isinstance(value, (float, np.floating)):
        return ("float", np.float64(value).tobytes())
    if value is None or isinstance(value, (bool, int, str, bytes, np.integer, np.bool_)):
        return value if not isinstance(value, (np.integer, np.bool_)) else value.item()
    if hasattr(value, "__dict__"):
        return (type(value).__name__,
                tuple(sorted((k, digest(v)) for k, v in vars(value).items() if not k.startswith("_cache"))))
    return repr(value)


def read_all(target, paths):
    """The digests of every frame (or of the one object) read from ``paths`` by the target's reader."""
    opened = TARGETS[target][2](paths)
    if hasattr(opened, "__len__") and hasattr(opened, "__getitem__") and not isinstance(opened, dict) \
            and type(opened).__module__.startswith("cgbound.readers") and hasattr(opened, "_frames"):
        return [digest(opened[k]) for k in range(len(opened))]
    return [digest(opened)]


def strip_paths(frames, directory):
    """Digests with the scratch directory's name removed (readers may record their paths)."""
    return json.loads(json.dumps(_clean(frames, directory)))


def _clean(value, directory):
    if isinstance(value, str):
        return value.replace(directory, "<dir>")
    if isinstance(value, bytes):
        return value.hex()
    if isinstance(value, (list, tuple)):
        return [_clean(v, directory) for v in value]
    return value


def setup_files(target, directory):
    files, _, _, _ = TARGETS[target]
    paths = {}
    for name, source in files.items():
        if callable(source):
            paths[name] = source(directory)
        else:
            paths[name] = os.path.join(directory, name)
            shutil.copyfile(source, paths[name])
    return paths


class Timeout(Exception):
    pass


@contextlib.contextmanager
def watchdog(seconds):
    def ring(signum, frame):
        raise Timeout(f"no answer within {seconds} s")
    previous = signal.signal(signal.SIGALRM, ring)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


_GENUINE = {}


def genuine(target):
    """The digests of the target's genuine files (cached per process)."""
    if target not in _GENUINE:
        with tempfile.TemporaryDirectory() as directory:
            _GENUINE[target] = strip_paths(read_all(target, setup_files(target, directory)), directory)
    return _GENUINE[target]


def cases(seed, n, targets=None):
    """``n`` cases (target, file, mutation, case seed), drawn from ``seed``: every (target, mutation)
    pair in turn, so that a small n covers them all."""
    rng = random.Random(seed)
    pairs = [(t, m) for t in (targets or TARGETS) for m in mutations_of(t)]
    out = []
    for k in range(n):
        target, kind = pairs[k % len(pairs)]
        out.append((target, rng.choice(TARGETS[target][1]), kind, rng.randrange(2 ** 32)))
    return out


def run_case(target, file, kind, case_seed, timeout=20.0):
    """{"outcome", "structural", "detail", "error"} of one case, run in this process."""
    import warnings
    expected = genuine(target)
    with tempfile.TemporaryDirectory() as directory:
        paths = setup_files(target, directory)
        path = paths[file]
        corrupted, structural, detail = mutate(Path(path).read_bytes(), kind, random.Random(case_seed))
        if corrupted == "directory":
            os.remove(path)
            os.mkdir(path)
        else:
            Path(path).write_bytes(corrupted)
        error = None
        try:
            with watchdog(timeout), warnings.catch_warnings():
                warnings.simplefilter("ignore")
                got = strip_paths(read_all(target, paths), directory)
        except Timeout as exc:
            return dict(outcome="hang", structural=structural, detail=detail, error=str(exc))
        except Exception as exc:   # noqa: BLE001 -- classifying every exception is the point
            error = exc
    if error is None:
        if got == expected:
            outcome = "same data"
        elif 0 < len(got) < len(expected) and got == expected[:len(got)]:
            outcome = "fewer frames"
        else:
            outcome = "read as something else"
        return dict(outcome=outcome, structural=structural, detail=detail, error="")
    message = str(error)
    right_type = isinstance(error, (ValueError, OSError)) and not isinstance(error, UnicodeError)
    if not right_type:
        outcome = "wrong kind"
    elif os.path.basename(path) in message:
        outcome = "clear error"
    else:
        outcome = "error not naming the file"
    return dict(outcome=outcome, structural=structural, detail=detail,
                error=f"{type(error).__name__}: {message[:300]}")


#: mutations after which a file may still be genuine, per target: an input script is a program (a
#: deleted, repeated or blank line, a changed word, or an empty script says something else, not
#: something broken); MercuryCG writes nan where a field is undefined (and inf is its neighbour)
NOT_STRUCTURAL = {
    "lammps_input": {"truncate", "delete_line", "duplicate_line", "blank_lines", "token_nan", "token_inf",
                     "token_1e999", "token_letters", "token_empty", "add_token", "drop_token", "empty", "crlf"},
    "mercurycg": {"token_nan", "token_inf"},
}


def contract_applies(target, kind, structural):
    """Whether "same data or a clear error naming the file" must hold: mutations that change the
    structure (counts, row lengths, lost lines, non-numbers in numeric columns, nan in integer columns,
    blank lines, NUL bytes, invalid UTF-8, empty files, ...), not a changed digit of a number, which is
    a different genuine value. A truncation may also leave a genuine shorter file ("fewer frames")."""
    return structural and kind not in NOT_STRUCTURAL.get(target, ())


def broken(result):
    """Whether a result breaks the contract where it applies."""
    return contract_applies(result["target"], result["kind"], result["structural"]) and not acceptable(
        result, result["kind"])


def acceptable(result, kind):
    ok = GOOD + (("fewer frames",) if kind == "truncate" else ())
    return result["outcome"] in ok


# ----------------------------------------------------------------------------------------- driver
def worker(seed, n, start, targets, timeout):
    for index, (target, file, kind, case_seed) in enumerate(cases(seed, n, targets)):
        if index < start:
            continue
        result = run_case(target, file, kind, case_seed, timeout)
        print(json.dumps(dict(index=index, target=target, file=file, kind=kind, **result)), flush=True)


def run_all(seed, n, targets, timeout):
    """Every case's result, run in worker subprocesses (a crash marks its case and the run goes on)."""
    results, start = {}, 0
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    todo = cases(seed, n, targets)
    while start < n:
        command = [sys.executable, __file__, "--worker", "--seed", str(seed), "--n", str(n), "--start", str(start),
                   "--timeout", str(timeout)] + [a for t in (targets or []) for a in ("--target", t)]
        proc = subprocess.Popen(command, stdout=subprocess.PIPE, text=True, env=env)
        for line in proc.stdout:
            row = json.loads(line)
            results[row["index"]] = row
            start = row["index"] + 1
        proc.wait()
        if start < n and proc.returncode != 0:
            target, file, kind, _ = todo[start]
            results[start] = dict(index=start, target=target, file=file, kind=kind, outcome="crash", structural=True,
                                  detail="", error=f"worker exit status {proc.returncode}")
            start += 1
        elif start < n:
            break
    return [results[k] for k in sorted(results)]


def table(results):
    counts = defaultdict(Counter)
    for r in results:
        counts[r["target"]][r["outcome"]] += 1
    shown = [o for o in OUTCOMES if any(c[o] for c in counts.values())]
    head = ["reader"] + shown + ["cases", "contract broken"]
    rows = []
    for target in TARGETS:
        if target not in counts:
            continue
        n_broken = sum(1 for r in results if r["target"] == target and broken(r))
        rows.append([target] + [str(counts[target][o]) for o in shown]
                    + [str(sum(counts[target].values())), str(n_broken)])
    rows.append(["all"] + [str(sum(c[o] for c in counts.values())) for o in shown]
                + [str(len(results)), str(sum(1 for r in results if broken(r)))])
    widths = [max(len(x) for x in col) for col in zip(head, *rows)]
    lines = ["| " + " | ".join(h.ljust(w) for h, w in zip(head, widths)) + " |",
             "|" + "|".join("-" * (w + 2) for w in widths) + "|"]
    lines += ["| " + " | ".join(x.ljust(w) for x, w in zip(row, widths)) + " |" for row in rows]
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n", type=int, default=500, help="number of cases (default 500)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--target", action="append", choices=list(TARGETS), help="only these readers (repeatable)")
    parser.add_argument("--timeout", type=float, default=20.0, help="seconds before a case counts as a hang")
    parser.add_argument("--show", action="append", default=[], metavar="OUTCOME",
                        help="print the cases with this outcome (repeatable; 'broken': the cases breaking "
                             "the contract)")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--start", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        worker(args.seed, args.n, args.start, args.target, args.timeout)
        return 0
    results = run_all(args.seed, args.n, args.target, args.timeout)
    print(f"fuzz_readers: {len(results)} cases, seed {args.seed}; contract (same data or a clear ValueError/OSError "
          "naming the file) checked on structural mutations")
    print(table(results))
    by_kind = Counter((r["target"], r["kind"]) for r in results if broken(r))
    if by_kind:
        print("\ncontract broken, by reader and mutation: "
              + ", ".join(f"{t}/{k} {c}" for (t, k), c in sorted(by_kind.items())))
    for r in results:
        if r["outcome"] in args.show or ("broken" in args.show and broken(r)):
            print(f"  [{r['index']}] {r['target']} {r['file']} {r['kind']} {r['detail']}: {r['outcome']} {r['error']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
