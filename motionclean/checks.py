"""The one validation layer of the public array API (``quat``, ``filters``, ``multires``).

Public entry points call these once; the kernels behind them run unchecked. Errors name
the argument and what was expected, e.g. ``q: expected shape (..., 4), got (5, 3)``:
TypeError for something that is not an array of numbers, ValueError for a wrong shape,
NaN/inf, or quaternions that are not unit length.
"""

from __future__ import annotations

import numpy as np

#: Largest accepted deviation of a quaternion's norm from 1 at a filter's entry.
UNIT_TOLERANCE = 1e-6
_ONES = np.ones(4)


def as_float_array(x, name: str) -> np.ndarray:
    """``x`` as a float64 array, or TypeError naming ``name``."""
    if isinstance(x, np.ndarray) and x.dtype == np.float64:
        return x
    try:
        array = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name}: expected an array of numbers, got {type(x).__name__}") from None
    return array


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


def unit_quaternions(q, name: str = "q", signal: bool = True, min_frames: int = 0) -> np.ndarray:
    """``q`` checked to be finite unit quaternions ``(F, ..., 4)`` (``(..., 4)`` when not
    ``signal``): what every orientation filter takes."""
    q = shaped(q, 4, name, signal, min_frames)
    with np.errstate(over="ignore", invalid="ignore"):
        error = np.square(q.reshape(-1, 4)) @ _ONES  # squared norms, one BLAS pass
        error = error.reshape(q.shape[:-1])
        error -= 1.0
        np.abs(error, out=error)
        if np.all(error <= 2.0 * UNIT_TOLERANCE):  # also false for NaN and inf
            return q
    finite(q, name)
    at = _first_bad(error > 2.0 * UNIT_TOLERANCE)
    norm = float(np.linalg.norm(q[at]))
    raise ValueError(
        f"{name}: not a unit quaternion at index {at} (norm {norm:.6g}); "
        "normalise with quat.normalize first"
    )


def vectors(p, name: str = "p", signal: bool = True, min_frames: int = 0) -> np.ndarray:
    """``p`` checked to be finite ``(F, ..., 3)`` vectors (``(..., 3)`` when not ``signal``)."""
    return finite(shaped(p, 3, name, signal, min_frames), name)
