"""Argument checks shared by the public classes: each names the argument and says what was expected."""
import numbers

import numpy as np


def _as_raw_array(value, name, what):
    """np.asarray(value) with the conversion errors named; ragged input is a ValueError."""
    try:
        return np.asarray(value)
    except ValueError as exc:
        raise ValueError(f"{name}: expected a rectangular array of {what}, got a ragged sequence ({exc})") from None
    except TypeError as exc:
        raise TypeError(f"{name}: expected an array of {what} ({exc})") from None


def _check_object_reals(raw, name):
    """An object array converts to float only if every element is a real, non-bool number."""
    for index, item in np.ndenumerate(raw):
        if isinstance(item, (bool, np.bool_)) or not isinstance(item, numbers.Real):
            raise TypeError(f"{name}: expected real numbers, got {item!r} at index {tuple(int(k) for k in index)}")


def real_array(value, name, ndim=None, shape=None, copy=True):
    """A float64 C-contiguous copy of value, checked for dtype, dimensions, shape and finiteness.

    Strings, booleans, complex numbers, date-times and objects other than real
    numbers are a TypeError (no silent parsing, truncation or NaN from None).
    """
    if value is None:
        raise TypeError(f"{name}: expected an array of real numbers, got None")
    raw = _as_raw_array(value, name, "real numbers")
    kind = raw.dtype.kind
    if kind == "c":
        raise TypeError(f"{name}: expected real numbers, got complex values (dtype {raw.dtype})")
    if kind == "O":
        _check_object_reals(raw, name)
    elif kind not in "iuf":
        raise TypeError(f"{name}: expected real numbers, got dtype {raw.dtype}")
    try:
        arr = np.array(raw, dtype=np.float64, copy=copy, order="C")
    except OverflowError:
        raise ValueError(f"{name}: expected numbers within the floating-point range (below 1.8e308), "
                         f"got an integer too large for a double") from None
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected an array of real numbers ({exc})") from None
    _check_real_array(arr, name, ndim, shape, True)
    arr.setflags(write=False)
    return arr


def _check_real_array(arr, name, ndim, shape, finite):
    """real_array's checks of a float64 array: dimensions, shape, and (if finite) finiteness."""
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(f"{name}: expected a {ndim}-dimensional array, got shape {arr.shape}")
    if shape is not None:
        for axis, (want, got) in enumerate(zip(shape, arr.shape)):
            if want is not None and want != got:
                raise ValueError(f"{name}: expected shape {_shape_text(shape)}, got {arr.shape}")
    if finite and not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(f"{name}: expected finite values, got {arr[tuple(bad)]} at index {tuple(int(b) for b in bad)}")


def read_only(arr):
    """A read-only view of arr (the array itself is left writable)."""
    view = arr.view()
    view.setflags(write=False)
    return view


def reader_real_array(parsed):
    """real_array for the arrays a reader has just produced (the internal path, Snapshot.from_reader): a float64
    ndarray is taken without a copy (a read-only view; a C-contiguous copy of a strided one) with real_array's
    checks of dimensions and shape, and of finiteness unless its name is in ``parsed`` (arrays the reader parsed
    with the C text layer, which refuses nan/inf, and did not compute on). Anything else goes through
    real_array."""
    def convert(value, name, ndim=None, shape=None):
        if not (isinstance(value, np.ndarray) and value.dtype == np.float64):
            return real_array(value, name, ndim, shape)
        _check_real_array(value, name, ndim, shape, name not in parsed)
        arr = np.ascontiguousarray(value)
        return read_only(arr) if arr is value else _frozen(arr)
    return convert


def _frozen(arr):
    arr.setflags(write=False)
    return arr


def reader_index_array(value, name, length=None):
    """index_array for a reader's int64 1-D ndarray: taken as a read-only view (length checked); anything else
    goes through index_array."""
    if not (isinstance(value, np.ndarray) and value.dtype == np.int64 and value.ndim == 1):
        return index_array(value, name, length)
    if length is not None and value.shape[0] != length:
        raise ValueError(f"{name}: expected length {length}, got {value.shape[0]}")
    return read_only(np.ascontiguousarray(value))


def reader_bool_array(value, name, length):
    """bool_array for a reader's bool ndarray of the right shape: a read-only view; anything else goes through
    bool_array."""
    if not (isinstance(value, np.ndarray) and value.dtype == np.bool_ and value.shape == (length,)):
        return bool_array(value, name, length)
    return read_only(np.ascontiguousarray(value))


_INT64_MAX = np.iinfo(np.int64).max


def index_array(value, name, length=None):
    """An int64 1-D array; rejects non-integer values instead of truncating them.

    Integer dtypes of any width and signedness are accepted, and so are floats
    holding integral values; booleans, strings, complex and objects are a TypeError,
    NaN, Inf, fractions and values beyond int64 a ValueError.
    """
    if value is None:
        raise TypeError(f"{name}: expected an array of integers, got None")
    raw = _as_raw_array(value, name, "integers")
    if raw.dtype.kind == "b" or raw.dtype.kind not in "iuf":
        if raw.size == 0 and raw.dtype.kind not in "bc":
            raw = np.zeros(raw.shape, np.int64)
        else:
            raise TypeError(f"{name}: expected integers, got dtype {raw.dtype}")
    if raw.ndim != 1:
        raise ValueError(f"{name}: expected a 1-dimensional array, got shape {raw.shape}")
    if length is not None and raw.shape[0] != length:
        raise ValueError(f"{name}: expected length {length}, got {raw.shape[0]}")
    if raw.dtype.kind == "f":
        finite = np.isfinite(raw)
        if not np.all(finite):
            k = int(np.flatnonzero(~finite)[0])
            raise ValueError(f"{name}: expected finite integers, got {raw[k]} at index {k}")
        frac = raw != np.round(raw)
        if np.any(frac):
            k = int(np.flatnonzero(frac)[0])
            raise ValueError(f"{name}: expected integral values, got {raw[k]} at index {k}")
        big = np.abs(raw) >= 2.0**63
        if np.any(big):
            k = int(np.flatnonzero(big)[0])
            raise ValueError(f"{name}: expected integers that fit in int64, got {raw[k]} at index {k}")
    elif raw.dtype.kind == "u" and raw.size and raw.max() > _INT64_MAX:
        k = int(np.argmax(raw > _INT64_MAX))
        raise ValueError(f"{name}: expected integers that fit in int64, got {raw[k]} at index {k}")
    arr = np.array(raw, dtype=np.int64, order="C")
    arr.setflags(write=False)
    return arr


def bool_array(value, name, length):
    """A bool 1-D array from booleans, or from integers / floats holding 0 and 1."""
    if value is None:
        raise TypeError(f"{name}: expected an array of booleans, got None")
    arr = _as_raw_array(value, name, "booleans")
    if arr.dtype.kind not in "biuf":
        raise TypeError(f"{name}: expected booleans, got dtype {arr.dtype}")
    if arr.shape != (length,):
        raise ValueError(f"{name}: expected shape ({length},), got {arr.shape}")
    if arr.dtype.kind != "b":
        bad = ~((arr == 0) | (arr == 1))
        if np.any(bad):
            k = int(np.flatnonzero(bad)[0])
            raise ValueError(f"{name}: expected booleans (0 or 1), got {arr[k]} at index {k}")
    out = np.array(arr, dtype=bool)
    out.setflags(write=False)
    return out


def _scalar(value):
    """A 0-d numeric array stands for its element."""
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "biufc":
        return value[()]
    return value


def _to_float(value, name):
    """float(value), with an int too large for a double a ValueError naming the argument."""
    try:
        return float(value)
    except OverflowError:
        raise ValueError(f"{name}: expected a number within the floating-point range (below 1.8e308), "
                         f"got an integer of about 2**{int(value).bit_length()}") from None


def _real_number(value, name, expected):
    """float(value) of a real, non-bool number (or a 0-d array of one); else a TypeError saying ``expected``."""
    value = _scalar(value)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name}: expected {expected}, got {value!r}")
    return _to_float(value, name)


def positive_number(value, name, allow_none=False):
    if value is None and allow_none:
        return None
    value = _real_number(value, name, "a positive number")
    if not (np.isfinite(value) and value > 0.0):
        raise ValueError(f"{name}: expected a positive finite number, got {value!r}")
    return value


def finite_number(value, name):
    value = _real_number(value, name, "a finite real number")
    if not np.isfinite(value):
        raise ValueError(f"{name}: expected a finite real number, got {value!r}")
    return value


def integer(value, name, allow_none=False):
    """A Python int from an integer (not bool); None passes if allowed."""
    if value is None and allow_none:
        return None
    value = _scalar(value)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        what = "an integer or None" if allow_none else "an integer"
        raise TypeError(f"{name}: expected {what}, got {value!r}")
    return int(value)


def counts_per_axis(value, name, dim, unit, hint=""):
    """D positive ints (one per axis) from a sequence, e.g. nodes or tiles per axis (``unit``: "node",
    "tile"); ``hint`` follows "expected D positive integers" in the message for a non-sequence."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise TypeError(f"{name}: expected {dim} positive integers{hint}, got {value!r}")
    value = tuple(value)
    if len(value) != dim:
        raise ValueError(f"{name}: expected {dim} positive integers (one per axis), got {value!r}")
    try:
        counts = tuple(integer(n, name) for n in value)
    except TypeError:
        raise TypeError(f"{name}: expected {dim} positive integers, got {value!r}") from None
    if any(n < 1 for n in counts):
        raise ValueError(f"{name}: expected positive {unit} counts, got {value!r}")
    return counts


def flag(value, name):
    """A Python bool from a bool (or 0/1 integer); anything else (strings, None) is a TypeError."""
    value = _scalar(value)
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, numbers.Integral) and int(value) in (0, 1):
        return bool(value)
    raise TypeError(f"{name}: expected True or False, got {value!r}")


def _shape_text(shape):
    return "(" + ", ".join("N" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"


def abs_max_per_row(values):
    """The largest absolute value of each row of a 2-D array: np.abs(values).max(axis=1), the same values
    (NaN where a row holds one), taken column by column: numpy's reduction along a short last axis (the
    d = 2 or 3 components of a vector) costs several times more."""
    out = np.abs(values[:, 0])
    for k in range(1, values.shape[1]):
        np.maximum(out, np.abs(values[:, k]), out=out)
    return out
