"""Running work on a dask.distributed cluster: CoarseGrain's blocks of frames (and the tiles of
:mod:`cgbound.tiled`). Dask is imported here only when a Dask run starts, never at ``import cgbound``.
"""
import contextlib
import numbers
import os

import numpy as np

from ._partial import block_partial, first_frame_info, partial_times, smoothed_partial
from .readers._sequence import FrameSequence

BACKENDS = ("serial", "dask")

#: blocks per worker thread: enough to balance uneven frames and to show progress, few enough
#: that the per-block sums sent back (one grid's worth each) stay small
BLOCKS_PER_THREAD = 4


def check_backend(backend, client, n_workers):
    """Checked (backend, n_workers); client and n_workers only make sense with backend="dask"."""
    if not isinstance(backend, str):
        raise TypeError(f"backend: expected 'serial' or 'dask', got {backend!r}")
    if backend not in BACKENDS:
        raise ValueError(f"backend: expected 'serial' or 'dask', got {backend!r}")
    if n_workers is not None:
        if isinstance(n_workers, (bool, np.bool_)) or not isinstance(n_workers, (numbers.Integral, np.integer)):
            raise TypeError(f"n_workers: expected a positive integer or None, got {n_workers!r}")
        if n_workers < 1:
            raise ValueError(f"n_workers: expected a positive integer or None, got {n_workers!r}")
        n_workers = int(n_workers)
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


def split_blocks(indices, n_blocks):
    """Consecutive runs of ``indices`` (frame order kept), as lists of ints."""
    n_blocks = max(1, min(n_blocks, len(indices)))
    return [[int(k) for k in chunk] for chunk in np.array_split(np.asarray(indices), n_blocks)]


class _Indexed:
    """Frames ``indices`` of a sequence that is not a reader: position k is ``sequence[indices[k]]``."""

    def __init__(self, sequence, indices):
        self.sequence, self.indices = sequence, list(indices)

    def __len__(self):
        return len(self.indices)

    def __getitem__(self, position):
        return self.sequence[self.indices[position]]


def block_frames(client, snapshots, indices):
    """What a worker needs to read frames ``indices``: a restricted reader (paths and frame
    locators), the Snapshots themselves (scattered) for a list or tuple, else the sequence with the indices."""
    if isinstance(snapshots, FrameSequence):
        return snapshots.take(indices)
    if isinstance(snapshots, (list, tuple)):
        return client.scatter([snapshots[k] for k in indices], hash=False)
    return _Indexed(snapshots, indices)


def _merge(a, b):
    return a.merge(b)


def gather_in_order(client, futures, sizes, progress, combine=_merge):
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
        client.cancel(futures)
        raise
    return merged


class _NoProgress:
    def update(self, n=1):
        pass

    def close(self):
        pass


def _progress(verbose, total, unit):
    if not verbose:
        return _NoProgress()
    from .coarse import progress_bar
    return progress_bar(total, unit)


def run_blocks(plan, snapshots, indices, client=None, n_workers=None, verbose=False):
    """CoarseGrain.run on Dask: the merged Partial of frames ``indices`` of ``snapshots``."""
    with dask_client(client, n_workers) as client:
        n_threads = max(1, sum(client.nthreads().values()))
        # a smoothing block sends back sums at every output time: one block per thread keeps that traffic
        # (and the client's additions) smallest
        per_thread = 1 if plan.mode in ("smooth", "store") else BLOCKS_PER_THREAD
        blocks = split_blocks(indices, per_thread * n_threads)
        # every frame is computed relative to the first frame's mean velocity, as in a serial run
        first = client.submit(first_frame_info, plan, block_frames(client, snapshots, indices[:1]), indices[0],
                              pure=False)
        futures = [first]
        try:
            plan.u_ref, plan.dim = first.result()
            plan_future = client.scatter(plan, broadcast=True, hash=False)
            sizes = [len(b) for b in blocks]
            bar = _progress(verbose, len(indices), "frame")
            try:
                futures = [client.submit(block_partial, plan_future, block_frames(client, snapshots, b), b, pure=False)
                           for b in blocks]
                if plan.mode != "store":
                    return gather_in_order(client, futures, sizes, bar)
                # smoothing at the frames' own times: the blocks keep their primaries on the workers,
                # send back their times, then the smoothing sums at all the times
                times = gather_in_order(client, [client.submit(partial_times, f, pure=False) for f in futures],
                                        sizes, bar, combine=list.__add__)
            finally:
                bar.close()
            out_times = np.asarray(times, dtype=float)
            smoothed = [client.submit(smoothed_partial, f, out_times, pure=False) for f in futures]
            return gather_in_order(client, smoothed, sizes, _NoProgress())
        finally:
            client.cancel(futures)


def run_tiles(jobs, n_tiles, grid, kernel, needed, u_ref, stitched, client=None, n_workers=None, verbose=False):
    """coarse_grain_tiled on Dask: ``jobs`` yields (ranges, tile data); results go to ``stitched.put``.

    Only a few tiles per worker thread are in flight at once, so the workers never hold the whole
    snapshot (nor the client every tile's copy of it).
    """
    from .tiled import TILES_IN_FLIGHT_PER_THREAD, _TileTarget, tile_primaries
    dd = distributed()
    with dask_client(client, n_workers) as client:
        n_threads = max(1, sum(client.nthreads().values()))
        jobs = iter(jobs)
        ranges_of = {}
        running = dd.as_completed()
        bar = _progress(verbose, n_tiles, "tile")

        def submit_next():
            job = next(jobs, None)
            if job is None:
                return
            ranges, data = job
            data_future = client.scatter(data, hash=False)
            future = client.submit(tile_primaries, data_future, _TileTarget(grid, ranges), kernel, needed, u_ref,
                                   pure=False)
            ranges_of[future.key] = (ranges, future)
            running.add(future)

        try:
            for _ in range(TILES_IN_FLIGHT_PER_THREAD * n_threads):
                submit_next()
            for future in running:
                stitched.put(ranges_of.pop(future.key)[0], future.result())
                future.release()
                bar.update()
                submit_next()
        except BaseException:
            client.cancel([f for _, f in ranges_of.values()])
            raise
        finally:
            bar.close()
