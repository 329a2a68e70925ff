"""The lazy frame sequence every reader is: len(), indexing, slicing, iteration, cheap pickling."""
import numbers

import numpy as np


class FrameSequence:
    """Base class of the readers.

    A subclass keeps ``self._frames``, a list with one small locator per frame (offsets,
    frame numbers: never arrays), and implements ``_snapshot(position)`` for the frame at
    a valid non-negative position. Slicing returns a copy of the reader restricted to those
    frames; ``_cache``, if a subclass uses one, is dropped from slices and pickles.
    """

    _frames = ()
    _cache = None

    def __len__(self):
        return len(self._frames)

    def _position(self, index):
        """A valid non-negative position for an integer index (negative counts from the end)."""
        if isinstance(index, (bool, np.bool_)) or not isinstance(index, (numbers.Integral, np.integer)):
            raise TypeError(f"index: expected an integer or a slice, got {type(index).__name__}")
        n = len(self._frames)
        k = int(index)
        if k < 0:
            k += n
        if not 0 <= k < n:
            raise IndexError(f"index: frame {index} out of range for {n} frames")
        return k

    def __getitem__(self, index):
        if isinstance(index, slice):
            return self._restricted(list(self._frames)[index])
        return self._snapshot(self._position(index))

    def take(self, indices):
        """A copy of the reader restricted to the frames at ``indices`` (in that order).

        Cheap (it copies locators, not data), so a block of frames can be handed to a worker process.
        """
        return self._restricted([self._frames[self._position(k)] for k in indices])

    def _restricted(self, frames):
        out = object.__new__(type(self))
        out.__dict__.update(self.__dict__)
        out._frames = frames
        out._cache = None
        return out

    def __iter__(self):
        for k in range(len(self)):
            yield self._snapshot(k)

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_cache"] = None
        return state

    def _cached_frame(self, index):
        """The frame object ``self._build(*locator)`` at ``index``, keeping the last one built."""
        k = self._position(index)
        if self._cache is not None and self._cache[0] == k:
            return self._cache[1]
        result = self._build(*self._frames[k])
        self._cache = (k, result)
        return result

    def _snapshot(self, position):  # pragma: no cover - abstract
        raise NotImplementedError
