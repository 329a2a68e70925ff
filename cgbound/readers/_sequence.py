"""The lazy frame sequence every reader is (len(), indexing, slicing, iteration, cheap pickling), and
what the readers share: the body-force argument, the cached frame objects, the repr."""
import numbers
import os

import numpy as np

from ..units import as_units


def file_name(path):
    """A path's base name as the repr shows it (``None`` when there is no file)."""
    return repr(None if path is None else os.path.basename(path))


class FrameSequence:
    """Base class of the readers.

    A subclass keeps ``self._frames``, a list with one small locator per frame (offsets,
    frame numbers: never arrays), and implements ``_snapshot(position)`` for the frame at
    a valid non-negative position and ``_describe()`` for its repr. Slicing returns a copy of
    the reader restricted to those frames; ``_cache``, if a subclass uses one, is dropped from
    slices and pickles.
    """

    _frames = ()
    _cache = None
    _units = None

    @property
    def units(self):
        """The units of the frames (a :class:`cgbound.Units`, see :mod:`cgbound.units`), or None when not
        known. Setting it (a system name such as ``"si"``, a mapping of length, mass and time, or a Units)
        gives every snapshot read afterwards these units; a reader made with ``units=`` sets it."""
        return self._units

    @units.setter
    def units(self, value):
        self._units = as_units(value)

    def _with_units(self, snapshot):
        if self._units is not None:
            snapshot.units = self._units
        return snapshot

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
        return self._with_units(self._snapshot(self._position(index)))

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
            yield self._with_units(self._snapshot(k))

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_cache"] = None
        return state

    def __repr__(self):
        sources, details = self._describe()
        units = [f"units={self._units.name or self._units.as_dict()!r}"] if self._units is not None else []
        return f"{type(self).__name__}({', '.join([*sources, f'{len(self)} frames', *details, *units])})"

    def _describe(self):  # pragma: no cover - abstract
        """Two lists of strings for the repr: where the frames come from, and details after the frame count."""
        raise NotImplementedError

    def _snapshot(self, position):  # pragma: no cover - abstract
        raise NotImplementedError

    @staticmethod
    def _check_body_force(g, dim, program=None):
        """``body_force`` as a (dim,) float array, or None. With ``program`` named, a 2D run also takes
        that program's 3 components (the third must be 0)."""
        if g is None:
            return None
        g = np.asarray(g, dtype=float)
        if program is not None and dim == 2 and g.shape == (3,):
            if g[2] != 0:
                raise ValueError(f"body_force: a 2D {program} run has no z component; got a non-zero third value")
            g = g[:2]
        if g.shape != (dim,) or not np.all(np.isfinite(g)):
            raise ValueError(f"body_force: expected {dim} finite values, got {g.tolist()}")
        return g


class FrameReader(FrameSequence):
    """A reader that builds one frame object per frame: the frame's ``snapshot`` plus what the format
    adds (IDs, overlaps, ...). A subclass implements ``_build(*locator)`` for the locator
    ``self._frames[k]``; the last frame built is kept, so ``frame(k)`` then ``reader[k]`` reads once.
    """

    def frame(self, index):
        """Frame ``index`` as the reader's frame object (its ``snapshot`` plus the format's data)."""
        k = self._position(index)
        if self._cache is not None and self._cache[0] == k:
            return self._cache[1]
        result = self._build(*self._frames[k])
        self._with_units(result.snapshot)
        self._cache = (k, result)
        return result

    def _snapshot(self, position):
        return self.frame(position).snapshot

    def _build(self, *locator):  # pragma: no cover - abstract
        raise NotImplementedError
