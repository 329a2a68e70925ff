"""CoarseGrain.run reads a reader's next frame in a background thread while the current one is coarse
grained (cgbound/readahead.py): the same results bit for bit, the same errors, and no thread left behind."""
import contextlib
import os
import signal
import sys
import threading

import numpy as np
import pytest

import cgbound as cg
from cgbound.readahead import read_ahead
from cgbound.readers import LammpsReader

DATA = os.path.join(os.path.dirname(__file__), "data", "lammps", "hooke3d")
FIELDS = ("density", "velocity", "kinetic_stress")


def reader():
    return LammpsReader(os.path.join(DATA, "run_atoms.dump"))


def read_ahead_threads():
    return [t for t in threading.enumerate() if t.name == "cgbound-read-ahead"]


def run(snapshots, **options):
    box = reader()[0].box
    grid = cg.Grid(box, (3, 3, 4))
    return cg.CoarseGrain(snapshots, grid, cg.Gaussian(0.8), fields=FIELDS, **options).run()


@pytest.mark.parametrize("time_average", ["mean", "none", 1.0])
def test_results_are_bit_for_bit_those_of_frames_read_first(time_average):
    frames = reader()
    assert len(frames) >= 3
    ahead = run(frames, time_average=time_average)           # a reader: read ahead
    first = run(list(reader()), time_average=time_average)   # a list: every frame read before
    for name in FIELDS:
        a, b = getattr(ahead.results, name), getattr(first.results, name)
        assert a.shape == b.shape and a.tobytes() == b.tobytes(), name
    assert np.array_equal(ahead.frame_times, first.frame_times)
    assert not read_ahead_threads()


class FailingReader(LammpsReader):
    """Frame ``bad`` cannot be read (as a damaged file would)."""
    bad = 1

    def __getitem__(self, index):
        if isinstance(index, int) and index == self.bad:
            raise ValueError(f"{self.atoms_path}: frame {index} is damaged")
        return super().__getitem__(index)


def test_a_reading_error_names_the_frame_and_stops_the_thread():
    frames = FailingReader(os.path.join(DATA, "run_atoms.dump"))
    with pytest.raises(ValueError) as info:
        run(frames)
    assert str(info.value) == f"frame 1: {frames.atoms_path}: frame 1 is damaged"
    assert not read_ahead_threads()


def test_an_error_while_coarse_graining_stops_the_thread():
    frames = reader()
    grid = cg.Grid(cg.Box([0, 0], [1, 1]), (2, 2))   # a 2D grid for 3D frames: the first frame fails
    with pytest.raises(ValueError, match="frame 0"):
        cg.CoarseGrain(frames, grid, cg.Gaussian(0.8), fields=("density",)).run()
    assert not read_ahead_threads()


def test_read_ahead_is_one_item_ahead_and_joins_on_close():
    produced = []

    def items():
        for k in range(10):
            produced.append(k)
            yield k

    gen = read_ahead(items())
    with contextlib.closing(gen):
        assert next(gen) == 0
        for _ in range(100):                 # let the thread run as far as it may
            if len(produced) >= 2:
                break
            threading.Event().wait(0.01)
        threading.Event().wait(0.05)
        assert produced == [0, 1]            # item 1 is read ahead, item 2 not yet
        assert next(gen) == 1
    assert not read_ahead_threads()
    assert len(produced) <= 3


def test_interrupt_in_the_consumer_stops_the_thread():
    gen = read_ahead(iter(range(5)))
    with pytest.raises(KeyboardInterrupt):
        with contextlib.closing(gen):
            for k in gen:
                if k == 2:
                    raise KeyboardInterrupt
    assert not read_ahead_threads()


def test_the_iterable_is_closed_in_its_thread_and_errors_pass_unchanged():
    closed = []

    def items():
        try:
            yield 1
            raise KeyError("lost")
        finally:
            closed.append(threading.current_thread().name)

    with pytest.raises(KeyError, match="lost"):
        list(read_ahead(items()))
    assert closed == ["cgbound-read-ahead"]
    assert not read_ahead_threads()


class CtrlCReader(LammpsReader):
    """Reading frame 1 (in the read-ahead thread) presses Ctrl-C: the signal reaches the main thread."""

    def __getitem__(self, index):
        if isinstance(index, int) and index == 1:
            os.kill(os.getpid(), signal.SIGINT)
        return super().__getitem__(index)


@pytest.mark.skipif(sys.platform == "win32" or threading.current_thread() is not threading.main_thread(),
                    reason="needs POSIX signals delivered to the main thread")
@pytest.mark.usefixtures("python_sigint_handler")
def test_ctrl_c_during_a_run_over_a_reader_is_honoured_and_stops_the_thread():
    frames = CtrlCReader(os.path.join(DATA, "run_atoms.dump"))
    with pytest.raises(KeyboardInterrupt):
        run(frames)
        threading.Event().wait(5.0)      # the signal must not escape the pytest.raises block
    assert not read_ahead_threads()
