"""Keyframes to frames: the grid of a glTF animation's key times (its frame time) and each
channel sampled on it (``STEP``, ``LINEAR``, ``CUBICSPLINE``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core import quat
from ...core.checks import within_magnitude
from ...core.motion import (
    MAX_FRAME_TIME,
    MIN_FRAME_TIME,
    RATES_ACCEPTED,
)
from .container import IN_RANGE, Buffers, fail, index_of, read_accessor

#: Largest grid, in joint samples (frames x joints) per keyframe of the whole animation:
#: more means keys too far apart for the frame time found (memory must follow the file, not
#: its times). A baked export holds about one key per joint sample, a hand-keyed one with a
#: key every half second on every joint at 60 fps 30; one sampler's keys moved 5,000 s away
#: had made 600,024 frames of 23 joints from 652 keys (3.3 GB read from 42 KB).
MAX_SAMPLES_PER_KEY = 250


#: A channel whose keys lie within this fraction of a frame of the grid (plus two float32
#: rounding steps of the time itself: key times are float32) is read as it is.
ON_GRID = 1e-3


FLOAT32_TIME = 2.0**-22


#: A frame rate within this fraction of a whole number is that number: exporters' float32
#: key times are off by up to about 1e-5 (Blender's 120 fps export reads as 119.9995).
SNAP = 1e-4


@dataclass(frozen=True)
class Keys:
    times: np.ndarray  # (K,)
    values: np.ndarray  # (K, n), or (K, 3, n) for CUBICSPLINE (in-tangent, value, out-tangent)
    interpolation: str
    input: int


def channel_sampler(animation: dict, channel: dict, a: int, path) -> tuple[int, dict]:
    """The index and object of the sampler of ``channel`` in animation ``a``."""
    samplers = animation.get("samplers", [])
    s = index_of(channel.get("sampler"), len(samplers), f"animations[{a}] channel sampler", path)
    sampler = samplers[s]
    if not isinstance(sampler, dict):
        fail(f"animations[{a}].samplers[{s}] is not an object", path)
    return s, sampler


def read_keys(document: dict, buffers: Buffers, a: int, c: int, width: int, path) -> Keys:
    """The keys of channel ``c`` of animation ``a`` (values ``width`` numbers each)."""
    animation = document["animations"][a]
    s, sampler = channel_sampler(animation, animation["channels"][c], a, path)
    interpolation = sampler.get("interpolation", "LINEAR")
    if interpolation not in ("LINEAR", "STEP", "CUBICSPLINE"):
        fail(
            f"animations[{a}].samplers[{s}]: interpolation {str(interpolation)[:20]!r} is unknown",
            path,
        )
    times = read_accessor(document, buffers, sampler.get("input"), path)
    values = read_accessor(document, buffers, sampler.get("output"), path)
    if times.shape[1] != 1 or values.shape[1] != width:
        fail(
            f"animations[{a}].samplers[{s}]: input must be scalars and output {width} values each",
            path,
        )
    times = times[:, 0]
    per_key = 3 if interpolation == "CUBICSPLINE" else 1
    if values.shape[0] != per_key * times.size or times.size == 0:
        fail(
            f"animations[{a}].samplers[{s}]: {values.shape[0]} outputs for {times.size} keys "
            f"({interpolation}: expected {per_key * times.size})",
            path,
        )
    if not (np.isfinite(times).all() and within_magnitude(values)):
        fail(
            f"animations[{a}].samplers[{s}]: a key time or value is not a finite number{IN_RANGE}",
            path,
        )
    if np.any(np.diff(times) <= 0.0):
        fail(f"animations[{a}].samplers[{s}]: key times do not increase", path)
    if per_key == 3:
        values = values.reshape(times.size, 3, width)
    return Keys(times, values, interpolation, sampler["input"])


def key_grid(keys: list[Keys], n_joints: int, path) -> tuple[float, float, int]:
    """Start time, frame time and frame count of the grid all channels of a skeleton of
    ``n_joints`` are sampled on (refused past :data:`MAX_SAMPLES_PER_KEY`)."""
    timed = [k.times for k in keys if k.times.size >= 2]
    start = min(float(k.times[0]) for k in keys)
    end = max(float(k.times[-1]) for k in keys)
    if not timed:
        return start, 1.0 / 30.0, 1
    dt = _frame_time(min(timed, key=key_step), start)
    if not MIN_FRAME_TIME <= dt <= MAX_FRAME_TIME:  # as every reader refuses such a rate
        fail(
            f"keys {dt:.6g} s apart: no usable frame rate ({RATES_ACCEPTED})",
            path,
        )
    frames = int(round((end - start) / dt)) + 1
    total_keys = sum(k.times.size for k in keys)
    if frames * n_joints > MAX_SAMPLES_PER_KEY * total_keys:
        fail(
            f"keys {end - start:.6g} s apart at {dt:.6g} s per frame: {frames} frames of "
            f"{n_joints} joints for {total_keys} keys (at most {MAX_SAMPLES_PER_KEY} joint "
            "samples per key); refused",
            path,
        )
    return start, dt, frames


def _frame_time(times: np.ndarray, start: float) -> float:
    """The frame time of the finest channel's key ``times`` (the grid starting at
    ``start``): a whole rate's within :data:`SNAP` while the keys stay on its grid, else
    the step the float32 times measure, made exact (:func:`_exact`)."""
    dt = key_step(times)
    rate = round(1.0 / dt)
    if rate > 0 and abs(1.0 / dt - rate) <= SNAP / dt:
        whole = 1.0 / rate
        grid = start + whole * np.round((times - start) / whole)
        if on_grid(times, grid, whole):
            return whole
    return _exact(dt, FLOAT32_TIME * float(np.abs(times).max()) / (times.size - 1))


def _exact(dt: float, error: float) -> float:
    """The frame time that key times measure as ``dt``, give or take their float32 rounding
    ``error``: a whole or NTSC rate's (n * 1000/1001: 30000/1001 is 29.97 fps) exactly where
    one lies within it, else the shortest decimal that does (``0.0083333``, not
    ``0.00833330026837097``)."""
    whole, ntsc = round(1.0 / dt), round(1001.0 / (1000.0 * dt))
    for exact in (1.0 / max(whole, 1), 1001.0 / (1000 * max(ntsc, 1))):
        if abs(exact - dt) <= error:
            return exact
    decimals = (float(f"{dt:.{digits}g}") for digits in range(1, 18))
    return next(value for value in decimals if abs(value - dt) <= error)


def on_grid(times: np.ndarray, grid: np.ndarray, frame_time: float) -> bool:
    """True when float32 key ``times`` are the ``grid`` times (see :data:`ON_GRID`)."""
    allowed = ON_GRID * frame_time + FLOAT32_TIME * np.abs(grid)
    return bool(np.all(np.abs(times - grid) <= allowed))


def key_step(times: np.ndarray) -> float:
    """A channel's key step: its span over its steps when they are uniform (within 10 %),
    accurate however long the clip (float32 times); else the median step."""
    steps = np.diff(times)
    mean = float(times[-1] - times[0]) / steps.size
    return mean if np.all(np.abs(steps - mean) <= 0.1 * mean) else float(np.median(steps))


def sample_keys(keys: Keys, times: np.ndarray, rotation: bool) -> np.ndarray:
    """Values of a channel at ``times`` (``STEP``, ``LINEAR`` or ``CUBICSPLINE``: the package's
    docstring)."""
    t = keys.times
    k = np.clip(np.searchsorted(t, times, side="right") - 1, 0, max(t.size - 2, 0))
    if t.size == 1:
        value = keys.values[:, 1] if keys.interpolation == "CUBICSPLINE" else keys.values
        return np.repeat(value, times.size, axis=0)
    span = t[k + 1] - t[k]
    u = np.clip((times - t[k]) / span, 0.0, 1.0)[:, None]
    if keys.interpolation == "STEP":
        return keys.values[np.where(times >= t[k + 1], k + 1, k)]
    if keys.interpolation == "LINEAR":
        a, b = keys.values[k], keys.values[k + 1]
        if rotation:
            return quat.slerp(a, b, u[:, 0])
        return a + (b - a) * u
    v, tangent_in, tangent_out = keys.values[:, 1], keys.values[:, 0], keys.values[:, 2]
    u2, u3 = u * u, u * u * u
    d = span[:, None]
    out = (
        (2 * u3 - 3 * u2 + 1) * v[k]
        + (u3 - 2 * u2 + u) * d * tangent_out[k]
        + (-2 * u3 + 3 * u2) * v[k + 1]
        + (u3 - u2) * d * tangent_in[k + 1]
    )
    return quat.normalize(out) if rotation else out


def as_wxyz(values: np.ndarray) -> np.ndarray:
    """glTF ``(x, y, z, w)`` along the last axis as ``(w, x, y, z)``."""
    return values[..., [3, 0, 1, 2]]
