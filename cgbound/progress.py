"""Progress bars: tqdm when installed, else a plain count on stderr."""
import sys


def progress_bar(total, unit, iterable=None):
    """tqdm when installed, else a plain count on stderr; ``update(n)`` and iteration both work."""
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return SimpleProgress(iterable, total, unit)
    return tqdm(iterable, total=total, desc="coarse graining", unit=unit)


def progress(verbose, total, unit):
    """A progress bar over ``total`` units if ``verbose``, else one that shows nothing."""
    return progress_bar(total, unit) if verbose else NoProgress()


class SimpleProgress:
    """Fallback progress report on stderr when tqdm is not installed."""

    def __init__(self, iterable, total, unit="frame"):
        self.iterable, self.total, self.unit, self.count = iterable, total, unit, 0

    def update(self, n=1):
        self.count += n
        print(f"\rcoarse graining: {self.count}/{self.total or '?'} {self.unit}s", end="", file=sys.stderr)

    def close(self):
        print(file=sys.stderr)

    def __iter__(self):
        for item in self.iterable:
            yield item
            self.update()
        self.close()


class NoProgress:
    """A progress bar that shows nothing."""

    def update(self, n=1):
        pass

    def close(self):
        pass
