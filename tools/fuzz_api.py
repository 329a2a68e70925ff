"""Long runs of the adversarial API suite (tests/test_adversarial_api.py) with more examples and random seeds.

    python tools/fuzz_api.py --minutes 20 --examples 2000 --seed 1 --log fuzz_api.log

Each round runs every test of the suite, in a fresh pytest process, with ``--examples`` hypothesis
examples and the seed ``seed + round``; the run stops after ``--minutes`` (or ``--rounds``). It
prints, per round and in total, the API calls tried, the named errors among them and the failures
(hypothesis's falsifying examples go to the log). Exit status 1 if any round failed.
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--minutes", type=float, default=20.0, help="time budget (default 20)")
    parser.add_argument("--rounds", type=int, default=None, help="stop after this many rounds")
    parser.add_argument("--examples", type=int, default=2000, help="hypothesis examples per test and round")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first round")
    parser.add_argument("--log", default=None, help="append pytest's output here")
    parser.add_argument("-k", default=None, help="pytest -k expression (a subset of the suite)")
    args = parser.parse_args(argv)
    if args.minutes <= 0 or args.examples < 1 or (args.rounds is not None and args.rounds < 1):
        parser.error("--minutes, --examples and --rounds must be positive")

    deadline = time.monotonic() + 60.0 * args.minutes
    total_calls = total_named = failed_rounds = rounds = 0
    with tempfile.TemporaryDirectory() as scratch:
        counts_file = os.path.join(scratch, "counts")
        env = dict(os.environ, CGBOUND_ADVERSARIAL_EXAMPLES=str(args.examples), CGBOUND_ADVERSARIAL_RANDOM="1",
                   CGBOUND_FUZZ_COUNTS=counts_file,
                   PYTHONPATH=os.pathsep.join(p for p in (ROOT, os.environ.get("PYTHONPATH")) if p))
        while time.monotonic() < deadline and (args.rounds is None or rounds < args.rounds):
            seed = args.seed + rounds
            command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"--hypothesis-seed={seed}",
                       os.path.join(ROOT, "tests", "test_adversarial_api.py")] + (["-k", args.k] if args.k else [])
            start = time.monotonic()
            done = subprocess.run(command, env=env, cwd=ROOT, capture_output=True, text=True)
            try:
                with open(counts_file) as f:
                    calls, named = (int(x) for x in f.read().split())
                os.unlink(counts_file)
            except (OSError, ValueError):
                calls = named = 0
            total_calls += calls
            total_named += named
            rounds += 1
            failed_rounds += done.returncode != 0
            tail = (done.stdout.strip().splitlines() or [""])[-1]
            print(f"round {rounds} seed {seed}: {calls} calls ({named} named errors), "
                  f"{time.monotonic() - start:.0f} s, {tail}", flush=True)
            if args.log:
                with open(args.log, "a") as f:
                    f.write(f"===== round {rounds} seed {seed}\n{done.stdout}\n{done.stderr}\n")
    print(f"total: {rounds} rounds, {total_calls} API calls, {total_named} named errors, "
          f"{failed_rounds} failed rounds", flush=True)
    return 1 if failed_rounds else 0


if __name__ == "__main__":
    sys.exit(main())
