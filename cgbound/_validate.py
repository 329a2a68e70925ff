"""Argument checks shared by the public classes: each names the argument and says what was expected."""
import numbers

import numpy as np


def real_array(value, name, ndim=None, shape=None, copy=True):
    """A float64 C-contiguous copy of value, checked for dimensions, shape and finiteness."""
    if value is None:
        raise TypeError(f"{name}: expected an array of real numbers, got None")
    try:
        arr = np.array(value, dtype=np.float64, copy=copy, order="C")
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected an array of real numbers ({exc})") from None
    if np.iscomplexobj(np.asarray(value)):
        raise TypeError(f"{name}: expected real numbers, got complex values")
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(f"{name}: expected a {ndim}-dimensional array, got shape {arr.shape}")
    if shape is not None:
        for axis, (want, got) in enumerate(zip(shape, arr.shape)):
            if want is not None and want != got:
                raise ValueError(f"{name}: expected shape {_shape_text(shape)}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(f"{name}: expected finite values, found {arr[tuple(bad)]} at index {tuple(int(b) for b in bad)}")
    arr.setflags(write=False)
    return arr


def index_array(value, name, length=None):
    """An int64 1-D array; rejects non-integer values instead of truncating them."""
    if value is None:
        raise TypeError(f"{name}: expected an array of integers, got None")
    raw = np.asarray(value)
    if raw.dtype.kind == "b" or raw.dtype.kind not in "iuf":
        if raw.size == 0 and raw.dtype.kind not in "b":
            raw = raw.astype(np.int64)
        else:
            raise TypeError(f"{name}: expected integers, got dtype {raw.dtype}")
    if raw.dtype.kind == "f":
        if not np.all(np.isfinite(raw)) or np.any(raw != np.round(raw)):
            raise TypeError(f"{name}: expected integers, got non-integral values")
    arr = np.array(raw, dtype=np.int64, order="C")
    if arr.ndim != 1:
        raise ValueError(f"{name}: expected a 1-dimensional array, got shape {arr.shape}")
    if length is not None and arr.shape[0] != length:
        raise ValueError(f"{name}: expected length {length}, got {arr.shape[0]}")
    arr.setflags(write=False)
    return arr


def bool_array(value, name, length):
    arr = np.asarray(value)
    if arr.dtype.kind not in "biu":
        raise TypeError(f"{name}: expected booleans, got dtype {arr.dtype}")
    if arr.shape != (length,):
        raise ValueError(f"{name}: expected shape ({length},), got {arr.shape}")
    if arr.dtype.kind != "b" and not np.all((arr == 0) | (arr == 1)):
        raise ValueError(f"{name}: expected booleans (0 or 1)")
    out = np.array(arr, dtype=bool)
    out.setflags(write=False)
    return out


def positive_number(value, name, allow_none=False):
    if value is None and allow_none:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name}: expected a positive number, got {value!r}")
    value = float(value)
    if not (np.isfinite(value) and value > 0.0):
        raise ValueError(f"{name}: expected a positive finite number, got {value!r}")
    return value


def _shape_text(shape):
    return "(" + ", ".join("N" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
