"""The one validation layer of the public array API (``quat``, ``filters``, ``multires``).

Public entry points call these once; the kernels behind them run unchecked. Errors name
the argument and what was expected, e.g. ``q: expected shape (..., 4), got (5, 3)``:
TypeError for something that is not an array of numbers, ValueError for a wrong shape,
NaN/inf, or quaternions that are not unit length. Scalar parameters go through
:func:`number`, :func:`whole` and :func:`frame_time`, which give the same kinds of errors.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable

import numpy as np

#: Largest accepted deviation of a quaternion's norm from 1 at a filter's entry.
UNIT_TOLERANCE = 1e-6
#: Largest accepted magnitude of a vector component (length units): squares and sums of
#: squares of differences stay finite, so the filters never overflow.
LARGEST_VALUE = 1e150
#: Accepted frame times, seconds: the rate ``1 / frame_time`` and products of it with
#: speeds or durations stay finite.
FRAME_TIME_RANGE = (1e-9, 1e9)
_ONES = np.ones(4)


def as_float_array(x, name: str) -> np.ndarray:
    """``x`` as a float64 array, or TypeError naming ``name`` (complex values too)."""
    if isinstance(x, np.ndarray) and x.dtype == np.float64:
        return x
    refused = x is None or isinstance(x, str | bytes | dict | set)
    try:  # converted once: a ragged list is refused here too
        raw = None if refused else np.asarray(x)
        complex_ = raw is not None and raw.dtype.kind == "c"
        array = None if raw is None or complex_ else np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        complex_, array = False, None
    if complex_:  # (float64 would drop the imaginary part, with a warning)
        raise TypeError(f"{name}: expected real numbers, got complex values")
    if array is None:
        raise TypeError(f"{name}: expected an array of numbers, got {type(x).__name__}")
    return array


def number(x, name: str) -> float:
    """``x`` as a float, or TypeError naming ``name`` (strings, None, arrays are refused)."""
    if isinstance(x, bool) or not isinstance(x, int | float | np.integer | np.floating):
        raise TypeError(f"{name}: expected a number, got {type(x).__name__}")
    try:
        return float(x)
    except OverflowError:  # an int beyond float64
        return math.copysign(math.inf, x)


def whole(x, name: str, minimum: int = 0, maximum: int | None = None) -> int:
    """``x`` as an int in ``[minimum, maximum]``: TypeError for a non-number, ValueError for a
    fraction or a value out of range."""
    value = number(x, name)
    if not (value == math.floor(value) if math.isfinite(value) else False):
        raise ValueError(f"{name}: expected a whole number, got {x!r}")
    if value < minimum or (maximum is not None and value > maximum):
        upper = f" and <= {maximum}" if maximum is not None else ""
        raise ValueError(f"{name}: expected a whole number >= {minimum}{upper}, got {x!r}")
    return int(x)


def frame_time(x, name: str = "frame_time") -> float:
    """Seconds per frame in :data:`FRAME_TIME_RANGE`, or TypeError / ValueError."""
    value = number(x, name)
    low, high = FRAME_TIME_RANGE
    if not low <= value <= high:  # also false for NaN
        raise ValueError(
            f"{name} must be a positive number of seconds in [{low:g}, {high:g}], got {value:g}"
        )
    return value


def path(x, name: str = "path") -> str | os.PathLike:
    """``x`` when it is a file path (``str`` or ``os.PathLike``, as :class:`pathlib.Path`),
    else TypeError naming ``name`` (bytes, numbers, open files are refused)."""
    if isinstance(x, str | os.PathLike) and not isinstance(os.fspath(x), bytes):
        return x
    raise TypeError(f"{name}: expected a file path (str or os.PathLike), got {type(x).__name__}")


def patterns(x, name: str) -> tuple[str, ...]:
    """``x`` as a tuple of strings (fnmatch patterns): a list, tuple or other iterable of
    str. A single ``str`` is refused (TypeError naming ``name``), as iterating it would
    give its characters as patterns; so is anything else that is not strings."""
    if isinstance(x, str | bytes):
        raise TypeError(
            f"{name}: expected a list of patterns, got a single {type(x).__name__} "
            f"({x!r}); write [{x!r}]"
        )
    if not isinstance(x, Iterable) or isinstance(x, dict):
        raise TypeError(f"{name}: expected a list of patterns (str), got {type(x).__name__}")
    items = tuple(x)
    odd = [item for item in items if not isinstance(item, str)]
    if odd:
        raise TypeError(f"{name}: expected patterns as str, got {type(odd[0]).__name__}")
    return items


def bool_mask(x, name: str, shape: tuple[int, ...], error: type[ValueError] = ValueError):
    """``x`` as a bool array of ``shape`` (a mask of samples: missing, kept), or ``error``
    (a ValueError) naming ``name``, its dtype and shape."""
    mask = np.asarray(x)
    if mask.dtype != bool or mask.shape != tuple(shape):
        raise error(
            f"{name}: expected a bool array of shape {tuple(shape)}, got {mask.dtype} {mask.shape}"
        )
    return mask


def shaped(x, width: int, name: str, signal: bool = False, min_frames: int = 0) -> np.ndarray:
    """``x`` as float64 with last axis ``width``; ``signal``: time-major ``(F, ..., width)``
    with at least ``min_frames`` frames. Shape only: O(1), for every public ``quat``
    function."""
    x = as_float_array(x, name)
    if signal:
        if x.ndim < 2 or x.shape[-1] != width or x.shape[0] < min_frames:
            at_least = f" with F >= {min_frames}" if min_frames else ""
            raise ValueError(f"{name}: expected shape (F, ..., {width}){at_least}, got {x.shape}")
    elif x.ndim < 1 or x.shape[-1] != width:
        raise ValueError(f"{name}: expected shape (..., {width}), got {x.shape}")
    return x


def _first_bad(bad: np.ndarray) -> tuple[int, ...]:
    return tuple(int(i) for i in np.unravel_index(int(np.argmax(bad)), bad.shape))


def finite(x: np.ndarray, name: str) -> np.ndarray:
    """``x`` unchanged, or ValueError naming the first NaN or infinite value."""
    with np.errstate(over="ignore", invalid="ignore"):
        if np.isfinite(np.sum(x)):  # one fast pass; a finite sum means finite values
            return x
    bad = ~np.isfinite(x)
    if bad.any():
        raise ValueError(f"{name}: NaN or infinite value at index {_first_bad(bad)}")
    return x


#: Quaternions whose norms are checked at a time (no clip-sized temporary).
UNIT_BLOCK = 1 << 16


def all_unit(q: np.ndarray) -> bool:
    """True when every quaternion of float64 ``(..., 4)`` ``q`` has a squared norm within
    ``2 UNIT_TOLERANCE`` of 1 (False for NaN and inf), in blocks along the first axis."""
    if q.ndim < 2:
        q = q.reshape(-1, 4)
    rows = max(1, UNIT_BLOCK // max(1, math.prod(q.shape[1:-1])))
    with np.errstate(over="ignore", invalid="ignore"):
        for at in range(0, q.shape[0], rows):
            error = np.square(q[at : at + rows].reshape(-1, 4)) @ _ONES  # one BLAS pass
            error -= 1.0
            np.abs(error, out=error)
            if not np.all(error <= 2.0 * UNIT_TOLERANCE):
                return False
    return True


def norm_text(norm: float) -> str:
    """A quaternion's norm for an error message: 6 significant digits, or as many as show
    how it differs from 1 (``1.000002``, not ``1``)."""
    text = f"{norm:.6g}"
    return f"{norm:.12g}" if text == "1" else text


def unit_quaternions(q, name: str = "q", signal: bool = True, min_frames: int = 0) -> np.ndarray:
    """``q`` checked to be finite unit quaternions ``(F, ..., 4)`` (``(..., 4)`` when not
    ``signal``): what every orientation filter takes."""
    q = shaped(q, 4, name, signal, min_frames)
    if all_unit(q):
        return q
    finite(q, name)
    with np.errstate(over="ignore", invalid="ignore"):
        error = np.abs(np.einsum("...i,...i->...", q, q) - 1.0)
    at = _first_bad(error > 2.0 * UNIT_TOLERANCE)
    norm = float(np.linalg.norm(q[at]))
    raise ValueError(
        f"{name}: not a unit quaternion at index {at} (norm {norm_text(norm)}); "
        "normalise with quat.normalize first"
    )


def bounded(x: np.ndarray, name: str) -> np.ndarray:
    """``x`` unchanged, or ValueError for NaN/inf or a magnitude above :data:`LARGEST_VALUE`."""
    finite(x, name)
    if x.size and (x.max() > LARGEST_VALUE or x.min() < -LARGEST_VALUE):
        at = _first_bad(np.abs(x) > LARGEST_VALUE)
        raise ValueError(
            f"{name}: value {float(x[at]):.3g} at index {at} is beyond +-{LARGEST_VALUE:g}"
        )
    return x


def vectors(p, name: str = "p", signal: bool = True, min_frames: int = 0) -> np.ndarray:
    """``p`` checked to be finite ``(F, ..., 3)`` vectors (``(..., 3)`` when not ``signal``),
    no component beyond :data:`LARGEST_VALUE`."""
    return bounded(shaped(p, 3, name, signal, min_frames), name)


#: Largest accepted magnitude of a value in a clip (degrees or length units): anything
#: larger is no capture and would overflow the arithmetic downstream.
MAX_MAGNITUDE = 1e12


def within_magnitude(values: np.ndarray) -> bool:
    """Whether every value of ``values`` is a number of at most :data:`MAX_MAGNITUDE` in
    size (False for NaN), by two reductions: no array-sized temporary."""
    if values.size == 0:
        return True
    # (the extremes compared as float64: a float16 array would cast the bound to inf)
    return bool(float(values.max()) <= MAX_MAGNITUDE and float(values.min()) >= -MAX_MAGNITUDE)
