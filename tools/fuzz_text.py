"""Long-running fuzz of the C text parser (cgbound.readers._text) against a pure-Python twin.

    python tools/fuzz_text.py --seconds 600          # a nightly-style run
    python tools/fuzz_text.py --cases 300 --seed 1   # what tests/test_text_parser.py runs

Each case is one of: a batch of random doubles formatted as the engines write them (repr, %.17g,
%g, %e, %.Ne, %.Nf, exact halfway decimals, long digit strings), or a genuine dump frame mutated
(bytes flipped, inserted, deleted or duplicated, lines cut, NaN/text/NUL/non-ASCII injected, CRLF,
tabs). The twin splits lines with Python and converts tokens with float() (restricted to the
documented grammar); the parser must give the same values bit for bit, or an error at the same
line; and (every third case) cut into 2-8 parts, one thread each, the same result as in one pass.
Prints the cases tried, the tokens compared and the failures (exit status 1 if any).
"""
import argparse
import math
import pathlib
import random
import re
import struct
import sys
import time
from decimal import Decimal

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
try:  # an installed (e.g. sanitizer) build first; else the checkout this script sits in
    from cgbound import _engine
    from cgbound.readers import _text
except ImportError:
    sys.path.insert(0, str(HERE.parent))
    from cgbound import _engine
    from cgbound.readers import _text

DUMPS = sorted((HERE.parent / "tests" / "data").glob("*/**/*.dump"))
NUMBER = re.compile(rb"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
SPECIAL = re.compile(rb"[+-]?(nan|inf|infinity|1\.#(inf|ind|qnan|snan)0*)", re.IGNORECASE)
SEPARATORS = re.compile(rb"[ \t\r\v\f]+")


class TwinError(Exception):
    def __init__(self, line):
        super().__init__(line)
        self.line = line


def twin_token(tok):
    if NUMBER.fullmatch(tok):
        return float(tok)
    m = SPECIAL.fullmatch(tok)
    if not m:
        return None
    low = tok.lower().lstrip(b"+-")
    sign = -1.0 if tok.startswith(b"-") else 1.0
    if low.startswith(b"1.#"):
        return math.copysign(math.inf if low[3:6] == b"inf" else math.nan, sign)
    return float(tok)


def twin_parse(text, ncols):
    """(rows, ncols) float64 by Python, or TwinError(1-based line) at the first bad line."""
    lines = text.split(b"\n")
    if lines and lines[-1] == b"":
        lines.pop()
    rows = []
    for i, line in enumerate(lines):
        tokens = [t for t in SEPARATORS.split(line) if t]
        if len(tokens) != ncols:
            raise TwinError(i + 1)
        row = [twin_token(t) for t in tokens]
        if any(v is None for v in row):
            raise TwinError(i + 1)
        rows.append(row)
    return np.array(rows, dtype=np.float64).reshape(-1, ncols)


def bits(a):
    return np.ascontiguousarray(a, dtype=np.float64).view(np.int64)


def raw_parse(text, ncols, flags, parts):
    """The C parser's raw result (cg_text_parse_table_parts): rows bit for bit, count, end, error, nan/inf report."""
    values, _, nrows, end, error, nonfinite = _engine.text_parse_table(text, 0, len(text), ncols, bytes(ncols), -1,
                                                                       flags, 1, parts)
    return bits(values[:nrows]).tobytes(), nrows, end, error, nonfinite


def check(text, ncols, parts=1):
    """Compare parser and twin on one text, and the parse cut into parts (> 1: one thread each) with one pass;
    returns (tokens compared, failure message or None)."""
    if parts > 1:
        for flags in (0, 1):  # blank lines an error, skipped
            if raw_parse(text, ncols, flags, parts) != raw_parse(text, ncols, flags, 1):
                return 0, f"cut into {parts} parts (flags {flags}), the result differs from one pass"
    try:
        expected = twin_parse(text, ncols)
    except TwinError as exc:
        expected = exc
    try:
        got = _text.parse_table(text, ncols=ncols, allow_nonfinite=True, name="fuzz").values
    except ValueError as exc:
        if not isinstance(expected, TwinError):
            return 0, f"parser error {exc} where the twin reads {len(expected)} rows"
        if f"fuzz, line {expected.line}:" not in str(exc) and f"fuzz, line {expected.line}," not in str(exc):
            return 0, f"parser error {exc}, twin error at line {expected.line}"
        return 0, None
    if isinstance(expected, TwinError):
        return 0, f"parser read {len(got)} rows, twin error at line {expected.line}"
    if got.shape != expected.shape or not np.array_equal(bits(got), bits(expected)):
        bad = np.flatnonzero(bits(got).ravel() != bits(expected).ravel()) if got.shape == expected.shape else [0]
        return 0, f"values differ (first at flat index {bad[0]})"
    return got.size, None


def random_doubles(rng, n=2000):
    tokens = []
    for _ in range(n):
        kind = rng.random()
        if kind < 0.4:
            x = struct.unpack("<d", struct.pack("<Q", rng.getrandbits(64)))[0]
            if not math.isfinite(x):
                x = rng.uniform(-1.0, 1.0)
        elif kind < 0.7:
            x = rng.uniform(-1, 1) * 10.0 ** rng.randint(-30, 30)
        elif kind < 0.85:
            x = rng.uniform(1, 2) * 2.0 ** rng.randint(-1074, 1023)
            mid = (Decimal(x) + Decimal(math.nextafter(x, math.inf))) / 2
            tokens.append(str(mid) if rng.random() < 0.5 else f"{mid:.{rng.randint(15, 25)}e}")
            continue
        else:
            digits = "".join(rng.choice("0123456789") for _ in range(rng.randint(1, 25)))
            tokens.append(f"{rng.choice(['', '-', '+'])}{digits}e{rng.randint(-340, 320)}")
            continue
        fmt = rng.choice(["%r", "%.17g", "%g", "%e", "%.{k}e", "%.{k}g", "%.{k}f"])
        if fmt == "%r":
            tokens.append(repr(x))
        else:
            if fmt == "%.{k}f" and abs(x) > 1e30:
                fmt = "%.{k}e"
            tokens.append(fmt.format(k=rng.randint(0, 25)) % x)
    ncols = rng.choice([1, 2, 5, 7])
    tokens += ["0"] * (-len(tokens) % ncols)
    seps = [" ", "  ", "\t", " \t "]
    lines = [rng.choice(seps).join(tokens[i:i + ncols]) for i in range(0, len(tokens), ncols)]
    end = rng.choice(["\n", "\r\n"])
    return (end.join(lines) + rng.choice(["", end])).encode(), ncols


INJECT = [b"nan", b"-inf", b"x", b"\x00", b"\xc3\xa9", b"\xff", b"1e", b"--1", b"1.2.3", b" ", b"\t", b"\r\n",
          b"\n", b"\n\n", b"1e999", b"4.9e-324", b"0x1p3", b"1_0"]


def mutated_frame(rng, frames):
    text, ncols = rng.choice(frames)
    data = bytearray(text)
    for _ in range(rng.randint(1, 4)):
        if not data:
            break
        at = rng.randrange(len(data))
        op = rng.random()
        if op < 0.25:
            data[at] = rng.randrange(256)
        elif op < 0.5:
            data[at:at] = rng.choice(INJECT)
        elif op < 0.65:
            del data[at:at + rng.randint(1, 20)]
        elif op < 0.8:
            end = data.find(b"\n", at)
            line_start = data.rfind(b"\n", 0, at) + 1
            if end > 0:
                data[end + 1:end + 1] = data[line_start:end + 1]  # duplicate a line
        else:
            del data[at:]  # truncate
    return bytes(data), ncols


def genuine_frames():
    frames = []
    for path in DUMPS:
        raw = path.read_bytes()
        lines = raw.split(b"\n")
        for i, line in enumerate(lines):
            if line.startswith(b"ITEM: ATOMS") or line.startswith(b"ITEM: ENTRIES"):
                ncols = len(line.split()) - 2
                count = int(lines[i - 5])  # TIMESTEP, t, NUMBER OF, count, BOX BOUNDS, 3 bounds
                body = b"\n".join(lines[i + 1:i + 1 + min(count, 40)]) + b"\n"
                if count:
                    frames.append((body, ncols))
    return frames


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=None, help="number of cases (default: until --seconds)")
    ap.add_argument("--seconds", type=float, default=60.0, help="time budget when --cases is not given")
    ap.add_argument("--seed", type=int, default=None)
    args = ap.parse_args(argv)
    seed = args.seed if args.seed is not None else random.randrange(2 ** 32)
    rng = random.Random(seed)
    frames = genuine_frames()
    t0 = time.monotonic()
    cases = tokens = 0
    failures = []
    while (cases < args.cases) if args.cases is not None else (time.monotonic() - t0 < args.seconds):
        text, ncols = random_doubles(rng) if rng.random() < 0.5 else mutated_frame(rng, frames)
        n, failure = check(text, ncols, parts=1 if cases % 3 else 2 + cases // 3 % 7)
        cases += 1
        tokens += n
        if failure:
            failures.append((failure, text[:200]))
            print(f"FAIL case {cases}: {failure}\n  text[:200] = {text[:200]!r}", file=sys.stderr)
    print(f"fuzz_text: seed {seed}, {cases} cases, {tokens} tokens compared bit for bit, {len(failures)} failures, "
          f"{time.monotonic() - t0:.1f} s")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
