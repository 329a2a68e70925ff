"""Read ahead: the items of an iterable produced in a background thread, one item ahead of their use.

Reading a frame (the C text parser, h5py) and coarse graining the previous one (the C kernels) both
release the GIL, so running the two in different threads overlaps them. The reading thread starts
item k+1 only once item k has been handed out, so at most one item is held ahead of the one in use.
Whatever the iterable raises is raised, unchanged, where the item is asked for; the thread is
stopped and joined when the generator is closed (also after an error or Ctrl-C in the consumer),
after at most the one read in flight.
"""
import queue
import threading

_ITEM, _DONE, _ERROR = range(3)
#: how often the consumer waiting for an item wakes to let Python raise a pending KeyboardInterrupt
POLL_SECONDS = 0.1


def read_ahead(iterable):
    """Yield the items of ``iterable``, each produced in a background thread while the previous
    one is in use. Close the generator (``contextlib.closing``) to stop the thread deterministically."""
    items = queue.Queue()
    may_read = threading.Semaphore(1)   # one permit: one item read ahead of the one handed out
    stop = threading.Event()

    def produce():
        iterator = None
        try:
            iterator = iter(iterable)
            while True:
                may_read.acquire()
                if stop.is_set():
                    return
                try:
                    item = next(iterator)
                except StopIteration:
                    items.put((_DONE, None))
                    return
                items.put((_ITEM, item))
                del item                 # not held here once handed over
        except BaseException as exc:     # re-raised in the consumer, unchanged
            items.put((_ERROR, exc))
        finally:
            close = getattr(iterator, "close", None)
            if close is not None:        # a generator is closed in the thread that ran it
                close()

    thread = threading.Thread(target=produce, name="cgbound-read-ahead", daemon=True)
    thread.start()
    try:
        while True:
            try:
                # wake now and then: Ctrl-C delivered to the reading thread is raised here (in the main
                # thread) only when this thread runs Python code
                kind, value = items.get(timeout=POLL_SECONDS)
            except queue.Empty:
                continue
            if kind == _DONE:
                return
            if kind == _ERROR:
                raise value
            may_read.release()           # start reading the next item while this one is used
            yield value
            del value
    finally:
        stop.set()
        may_read.release()               # wake the thread if it waits for a permit
        thread.join()
