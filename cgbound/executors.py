"""Where tasks run: in this process (:class:`SerialExecutor`) or on a dask.distributed cluster
(:class:`DaskExecutor`). Executors receive functions and their data, nothing of the analysis.

Dask is imported here only when a Dask run starts, never at ``import cgbound``.
"""
import contextlib
import os

from ._validate import integer

BACKENDS = ("serial", "dask")


def check_backend(backend, client, n_workers):
    """Checked (backend, n_workers); client and n_workers only make sense with backend="dask"."""
    if not isinstance(backend, str):
        raise TypeError(f"backend: expected 'serial' or 'dask', got {backend!r}")
    if backend not in BACKENDS:
        raise ValueError(f"backend: expected 'serial' or 'dask', got {backend!r}")
    if n_workers is not None:
        try:
            n_workers = integer(n_workers, "n_workers")
        except TypeError:
            raise TypeError(f"n_workers: expected a positive integer or None, got {n_workers!r}") from None
        if n_workers < 1:
            raise ValueError(f"n_workers: expected a positive integer or None, got {n_workers!r}")
    if backend == "serial":
        if client is not None:
            raise ValueError(f"client: expected None with backend='serial' (use backend='dask'), "
                             f"got {type(client).__name__}")
        if n_workers is not None:
            raise ValueError(f"n_workers: expected None with backend='serial' (use backend='dask'), got {n_workers}")
    elif client is not None and n_workers is not None:
        raise ValueError(f"n_workers: expected None when a client is given (the client's cluster has its own "
                         f"workers), got {n_workers}")
    return backend, n_workers


def distributed():
    """The dask.distributed module, or an ImportError saying how to install it."""
    try:
        import distributed as dd
    except ImportError as exc:
        raise ImportError("backend='dask' needs dask.distributed: pip install 'cgbound[dask]' "
                          "(or pip install 'dask[distributed]')") from exc
    return dd


def local_cluster(n_workers):
    """A LocalCluster of ``n_workers`` single-threaded worker processes (dashboard on a free port).

    Dask sets OMP_NUM_THREADS=1 (and similar) in *this* process's environment before spawning its
    workers, and leaves it there; it is put back afterwards, so that a serial run later in the same
    session still uses every core.
    """
    import dask
    dd = distributed()
    keys = list(dask.config.get("distributed.nanny.pre-spawn-environ", {}) or {})
    saved = {key: os.environ.get(key) for key in keys}
    try:
        return dd.LocalCluster(n_workers=n_workers, processes=True, threads_per_worker=1, dashboard_address=":0")
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


@contextlib.contextmanager
def dask_client(client, n_workers):
    """The given client (left open), or a LocalCluster of n_workers processes (default 2) closed on exit."""
    dd = distributed()
    if client is not None:
        if not isinstance(client, dd.Client):
            raise TypeError(f"client: expected a dask.distributed.Client or None, got {type(client).__name__}")
        yield client
        return
    cluster = local_cluster(n_workers or 2)
    try:
        with dd.Client(cluster) as own:
            yield own
    finally:
        cluster.close()


@contextlib.contextmanager
def executor(backend, client=None, n_workers=None):
    """The executor of ``backend`` (checked by :func:`check_backend`), open for the ``with`` block."""
    if backend == "serial":
        yield SerialExecutor()
        return
    with dask_client(client, n_workers) as own:
        yield DaskExecutor(own)


class _Done:
    """The result of a task already run (what SerialExecutor.submit returns)."""

    def __init__(self, value):
        self.value = value

    def result(self):
        return self.value


def _combined(parts, combine):
    merged = None
    for k, part in enumerate(parts):
        merged = part if k == 0 else combine(merged, part)
    return merged


class SerialExecutor:
    """Runs every task at once, in this process."""

    n_threads = 1

    def scatter(self, data, broadcast=False):
        return data

    def submit(self, func, *args):
        """Run ``func`` now; results of earlier submissions among ``args`` are passed as their values."""
        return _Done(func(*(a.result() if isinstance(a, _Done) else a for a in args)))

    def gather_in_order(self, futures, sizes, progress, combine):
        """The results of ``futures`` combined in list order with ``combine(a, b)``."""
        def results():
            for future, size in zip(futures, sizes):
                yield future.result()
                progress.update(size)
        return _combined(results(), combine)

    def stream(self, func, jobs, consume, progress, in_flight_per_thread=1):
        """``consume(key, func(*args))`` for each ``(key, args)`` of ``jobs``, one after another."""
        for key, args in jobs:
            consume(key, func(*args))
            progress.update()

    def cancel(self, futures):
        pass


class DaskExecutor:
    """Runs tasks on the workers of a dask.distributed client."""

    def __init__(self, client):
        self.client = client
        self.n_threads = max(1, sum(client.nthreads().values()))

    def scatter(self, data, broadcast=False):
        return self.client.scatter(data, broadcast=broadcast, hash=False)

    def submit(self, func, *args):
        return self.client.submit(func, *args, pure=False)

    def gather_in_order(self, futures, sizes, progress, combine):
        """Results of ``futures`` combined in list order (``combine(a, b)``) as they arrive; a worker's
        exception is re-raised here with its own type, and the remaining futures are cancelled."""
        dd = distributed()
        position = {future.key: k for k, future in enumerate(futures)}
        arrived, merged, next_k = {}, None, 0
        try:
            for future in dd.as_completed(futures):
                k = position[future.key]
                arrived[k] = future.result()
                future.release()
                progress.update(sizes[k])
                while next_k in arrived:
                    part = arrived.pop(next_k)
                    merged = part if merged is None else combine(merged, part)
                    next_k += 1
        except BaseException:
            self.client.cancel(futures)
            raise
        return merged

    def stream(self, func, jobs, consume, progress, in_flight_per_thread=1):
        """``consume(key, func(*args))`` for each ``(key, args)`` of ``jobs``, in the order they finish.

        The first argument of each job (its bulky data) is scattered on its own; only
        ``in_flight_per_thread`` jobs per worker thread are on the cluster at once, so neither
        the workers nor this process hold every job's data.
        """
        dd = distributed()
        jobs = iter(jobs)
        key_of = {}
        running = dd.as_completed()

        def submit_next():
            job = next(jobs, None)
            if job is None:
                return
            key, (data, *rest) = job
            future = self.submit(func, self.scatter(data), *rest)
            key_of[future.key] = (key, future)
            running.add(future)

        try:
            for _ in range(in_flight_per_thread * self.n_threads):
                submit_next()
            for future in running:
                consume(key_of.pop(future.key)[0], future.result())
                future.release()
                progress.update()
                submit_next()
        except BaseException:
            self.client.cancel([f for _, f in key_of.values()])
            raise

    def cancel(self, futures):
        self.client.cancel(futures)
