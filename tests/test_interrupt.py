"""Ctrl-C during a long computation in the C core raises KeyboardInterrupt promptly.

The core releases the GIL, so Python's own SIGINT handling would only notice
the signal after the call; the binding installs a temporary SIGINT handler
that makes the core stop (every thread) within a fraction of a second, and
restores Python's handler afterwards.
"""
import os
import signal
import sys
import threading
import time

import numpy as np
import pytest

import cgbound as cg

pytestmark = [pytest.mark.skipif(sys.platform == "win32" or threading.current_thread() is not threading.main_thread(),
                                 reason="needs POSIX signals delivered to the main thread"),
              pytest.mark.usefixtures("python_sigint_handler")]


def long_job():
    """A density computation that takes many seconds: every particle reaches every node."""
    rng = np.random.default_rng(0)
    box = cg.Box([0.0, 0.0, 0.0], [10.0, 10.0, 10.0])
    n = 4000
    snap = cg.Snapshot(rng.uniform(0, 10, (n, 3)), rng.normal(size=(n, 3)), np.ones(n), box=box)
    grid = cg.Grid(box, (100, 100, 100))
    kernel = cg.Gaussian(1.0, cutoff=100.0)  # the support covers the whole grid
    return snap, grid, kernel


def test_sigint_interrupts_a_long_computation():
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    snap, grid, kernel = long_job()
    sent = []

    def fire():
        sent.append(time.perf_counter())
        os.kill(os.getpid(), signal.SIGINT)

    timer = threading.Timer(0.5, fire)
    start = time.perf_counter()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            cg.coarse_grain(snap, grid, kernel, fields=("density",))
            # if the computation finished first, wait for the signal so that it
            # cannot escape the pytest.raises block (the test then fails on timing)
            time.sleep(5.0)
        stopped = time.perf_counter()
    finally:
        timer.cancel()
        timer.join()
    assert sent, "the computation finished before the signal was sent: make long_job longer"
    assert stopped - sent[0] < 1.5, f"KeyboardInterrupt came {stopped - sent[0]:.2f} s after SIGINT"
    assert sent[0] - start < 2.0
    # Python's handler is back, and the core still works normally
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    small = cg.Grid(snap.box, (4, 4, 4))
    out = cg.coarse_grain(snap, small, cg.Gaussian(1.0, cutoff=2.0), fields=("density",))
    assert np.all(np.isfinite(out.density)) and out.density.sum() > 0


def test_custom_python_handler_still_runs():
    """A user's SIGINT handler is chained: it runs, and the core call still stops."""
    calls = []

    def handler(signum, frame):
        calls.append(signum)
        raise RuntimeError("custom handler")

    snap, grid, kernel = long_job()
    previous = signal.signal(signal.SIGINT, handler)
    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    try:
        timer.start()
        start = time.perf_counter()
        with pytest.raises(RuntimeError, match="custom handler"):
            cg.coarse_grain(snap, grid, kernel, fields=("density",))
            time.sleep(5.0)
        assert time.perf_counter() - start < 2.0
        assert calls == [signal.SIGINT]
        assert signal.getsignal(signal.SIGINT) is handler
    finally:
        timer.cancel()
        timer.join()
        signal.signal(signal.SIGINT, previous)


def test_computation_in_a_worker_thread_is_unaffected():
    """Only the main thread installs the handler; other threads run to completion."""
    snap, _, _ = long_job()
    grid = cg.Grid(snap.box, (6, 6, 6))
    expected = cg.coarse_grain(snap, grid, cg.Gaussian(1.0, cutoff=3.0), fields=("density",)).density
    result = {}

    def work():
        result["density"] = cg.coarse_grain(snap, grid, cg.Gaussian(1.0, cutoff=3.0), fields=("density",)).density

    t = threading.Thread(target=work)
    t.start()
    t.join()
    np.testing.assert_array_equal(result["density"], expected)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
