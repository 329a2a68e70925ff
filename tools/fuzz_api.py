"""Long runs of the adversarial API suite (tests/test_adversarial_api.py) with more examples and random seeds.

    python tools/fuzz_api.py --minutes 20 --examples 2000 --seed 1 --log fuzz_api.log

Each round runs every test of the suite with ``--examples`` hypothesis examples and the seed
``seed + round``; the run stops after ``--minutes`` (or ``--rounds``). It prints, per round and in
total, the API calls tried, the named errors among them and the failures (with hypothesis's
falsifying example in the log). Exit status 1 if any round failed.
"""
import argparse
import io
import os
import sys
import time
from contextlib import redirect_stdout

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--minutes", type=float, default=20.0, help="time budget (default 20)")
    parser.add_argument("--rounds", type=int, default=None, help="stop after this many rounds")
    parser.add_argument("--examples", type=int, default=2000, help="hypothesis examples per test and round")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first round")
    parser.add_argument("--log", default=None, help="append pytest's output here")
    parser.add_argument("-k", default=None, help="pytest -k expression (a subset of the suite)")
    args = parser.parse_args(argv)
    if args.minutes <= 0 or args.examples < 1:
        parser.error("--minutes and --examples must be positive")

    os.environ["CGBOUND_ADVERSARIAL_EXAMPLES"] = str(args.examples)
    os.environ["CGBOUND_ADVERSARIAL_RANDOM"] = "1"
    sys.path.insert(0, ROOT)
    sys.path.insert(0, os.path.join(ROOT, "tests"))
    import pytest
    import adversarial_api

    deadline = time.monotonic() + 60.0 * args.minutes
    total_calls = total_named = failed_rounds = rounds = 0
    while time.monotonic() < deadline and (args.rounds is None or rounds < args.rounds):
        seed = args.seed + rounds
        before = dict(adversarial_api.COUNTS)
        buffer = io.StringIO()
        pytest_args = ["-q", "-p", "no:cacheprovider", f"--hypothesis-seed={seed}",
                       os.path.join(ROOT, "tests", "test_adversarial_api.py")]
        if args.k:
            pytest_args += ["-k", args.k]
        start = time.monotonic()
        with redirect_stdout(buffer):
            status = pytest.main(pytest_args)
        calls = adversarial_api.COUNTS["calls"] - before["calls"]
        named = adversarial_api.COUNTS["named_errors"] - before["named_errors"]
        total_calls += calls
        total_named += named
        rounds += 1
        failed_rounds += status != 0
        tail = buffer.getvalue().strip().splitlines()[-1:] or [""]
        print(f"round {rounds} seed {seed}: {calls} calls ({named} named errors), {time.monotonic() - start:.0f} s, "
              f"{tail[0]}", flush=True)
        if args.log:
            with open(args.log, "a") as f:
                f.write(f"===== round {rounds} seed {seed}\n{buffer.getvalue()}\n")
    print(f"total: {rounds} rounds, {total_calls} API calls, {total_named} named errors, "
          f"{failed_rounds} failed rounds", flush=True)
    return 1 if failed_rounds else 0


if __name__ == "__main__":
    sys.exit(main())
