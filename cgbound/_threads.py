"""How many threads the C core uses: set_num_threads, get_num_threads and the threads() context manager.

The count is passed to the core with every call (no global OpenMP state is
changed). ``None`` means the OpenMP default (OMP_NUM_THREADS, else all cores).
The core itself uses fewer threads for inputs too small to gain from them.
On grids long enough along their first (non-periodic) axis the core cuts the
work into slabs and results are the same bit for bit for any thread count;
otherwise they agree to rounding (per-thread sums are added in a fixed order).
"""
import contextlib
import contextvars

from . import _engine
from ._validate import integer

#: the most threads a count may ask for (the core takes a C int; thousands of threads help no machine this runs on)
MAX_THREADS = 4096
_default = None                                   # set_num_threads
_override = contextvars.ContextVar("cgbound_threads", default=None)   # threads(n), per thread / task


def _check(n, name="n"):
    if n is None:
        return None
    try:
        count = integer(n, name)
    except TypeError:
        raise TypeError(f"{name}: expected a positive int number of threads or None, got {n!r}") from None
    if count < 1 or count > MAX_THREADS:
        raise ValueError(f"{name}: expected a positive number of threads (at most {MAX_THREADS}) or None, got {n!r}")
    return count


def set_num_threads(n):
    """Use n threads in the C core from now on (None: the OpenMP default). Returns the previous setting."""
    global _default
    n = _check(n)
    previous, _default = _default, n
    return previous


def get_num_threads():
    """Threads the C core will use at most for a large enough input (1 without OpenMP)."""
    if not _engine.have_openmp():
        return 1
    n = _override.get()
    if n is None:
        n = _default
    return n if n is not None else _engine.default_threads()


@contextlib.contextmanager
def threads(n):
    """Context manager: ``with cgbound.threads(2): ...`` uses n threads inside the block (this thread only)."""
    token = _override.set(_check(n))
    try:
        yield
    finally:
        _override.reset(token)
