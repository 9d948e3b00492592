"""A time column read onto a uniform frame grid: the frame time of a CSV's, OpenSim file's
or Motive export's times, and the error, naming the row, where they are not uniformly
sampled.

Times (seconds) must increase, each step must lie within :data:`TIME_TOLERANCE` of the mean
step and each time within that share of a frame of the uniform grid; a fixed rate with rows
skipped, a clock jump and times out of order are each said as such. Times written in
coarse steps (whole milliseconds at 144 or 240 fps) are fitted by least squares and put on
the nearest whole rate whose grid holds them. The frame time is rounded to 12 significant
digits, or is a template's where the column fits it.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime
from typing import NoReturn

import numpy as np

from ..core.errors import MotionError
from ..core.motion import MAX_FRAME_TIME, MIN_FRAME_TIME, RATES_ACCEPTED
from ..core.rates import whole_frames
from ..core.words import plural
from .bvh import SLOW_FRAME_TIME


def _fail(message: str, path, line: int) -> NoReturn:
    raise MotionError(message, path, int(line))


#: Largest allowed deviation of a time step, or of a time from the uniform grid, in frames.
TIME_TOLERANCE = 0.1


#: Times written in steps over this share of a frame are coarse (:func:`_whole_rate`).
COARSE_WRITTEN = 0.01


#: The units Unix times are written in besides seconds, and seconds' worth of each.
UNIX_UNITS = (("milliseconds", 1e3), ("microseconds", 1e6), ("nanoseconds", 1e9))


def unix_hint(value: float) -> str:
    """What a time beyond :data:`MAX_MAGNITUDE` seconds looks like: Unix time in one of
    :data:`UNIX_UNITS` where it reads so as a date from 2001 to 2286 (1e9 to 1e10 s, as
    1.7e12 ms does), said with that date and what to do; else nothing."""
    for unit, scale in UNIX_UNITS:
        seconds = value / scale
        if 1e9 <= seconds < 1e10:
            date = datetime.fromtimestamp(seconds, UTC).strftime("%Y-%m-%d %H:%M")
            return (
                f": it reads as Unix time in {unit} ({date} UTC); times are seconds: divide "
                f"the column by {scale:,.0f} (Unix times in seconds are read)"
            )
    return ""


#: What a file whose rows are not a fixed time apart is told to do.
UNEVEN_ADVICE = "export it at a fixed rate"


#: ... of one that keeps its rate but skips rows (a tracker dropping frames).
SKIPPED_ADVICE = (
    "give every frame its row (blank cells mark a dropout, which the fill-gaps step fills)"
)


def _off_grid(times: np.ndarray, mean: float) -> tuple[np.ndarray, np.ndarray]:
    """``(steps, times)`` masks of increasing ``times`` (seconds): the steps more than
    :data:`TIME_TOLERANCE` of ``mean`` away from it, the times that far off the grid of
    ``mean`` steps from the first."""
    grid = np.arange(times.size)
    return (
        np.abs(np.diff(times) - mean) > TIME_TOLERANCE * mean,
        np.abs(times - times[0] - grid * mean) > TIME_TOLERANCE * mean,
    )


def off_grid(times: np.ndarray) -> bool:
    """Whether increasing ``times`` (seconds) stray from a uniform grid: a step, or a
    time from the first, more than :data:`TIME_TOLERANCE` of the mean step off it."""
    steps, drift = _off_grid(times, (times[-1] - times[0]) / (times.size - 1))
    return bool(steps.any() or drift.any())


def slow_time_notes(frame_time: float) -> tuple[str, ...]:
    """The note on a time column stepping slower than :data:`~.bvh.SLOW_FRAME_TIME` (times
    in milliseconds read as seconds: 11.1 s per row for 90 fps)."""
    if frame_time <= SLOW_FRAME_TIME:
        return ()
    return (
        f"time steps of {frame_time:g} s per row, {1.0 / frame_time:.3g} fps: times are "
        f"read in seconds; were they milliseconds, the clip is {1000.0 / frame_time:.4g} "
        "fps and its time column should say so in seconds",
    )


def written_step(times: np.ndarray) -> float:
    """The step the times were written in, where they are whole multiples of 1 s, 0.1 s,
    ... or 1 microsecond (whole milliseconds: 0.001; Motive 1.23 writes 0.004, 0.008, ...
    for 1/240 s steps), else 0."""
    for digits in range(7):  # seconds to microseconds
        scaled = times * 10.0**digits
        if np.all(np.abs(scaled - np.round(scaled)) <= 1e-6):
            return 10.0**-digits
    return 0.0


def _coarse_grid(times: np.ndarray, mean: float, lines: np.ndarray, path, advice: str):
    """The frame time of ``times`` written in coarser steps than :data:`TIME_TOLERANCE` of
    a frame (:func:`written_step`: whole milliseconds at 144 or 240 fps, 4 or 5 ms apart
    for 4.17), where they are a uniform grid to within that step, rounded or cut: the
    grid's step by least squares (the ends' rounding, over a long take, would tilt the
    span's mean ``mean`` by about a step); a time further off is refused at its line; None
    for any other time column."""
    step = written_step(times)
    if not TIME_TOLERANCE * mean < step < mean:
        return None
    rows = _centred_rows(times.size)
    slope = float(rows @ (times - times.mean()) / (rows @ rows))
    # the nearest whole rate where its grid holds the times too (50 rows of 240 fps in
    # whole milliseconds fit 239.9 fps best)
    held = _held_by(times, (_whole_rate_step(slope), slope), step)
    if held is not None:
        return held
    off = times - rows * slope
    worst = int(np.argmax(np.abs(off - np.median(off))))
    _fail(
        f"not uniformly sampled: time {_seconds(times[worst])} s is "
        f"{abs(off[worst] - np.median(off)) * 1000:.3g} ms off the uniform grid of "
        f"{slope:.6g} s steps, more than the {step * 1000:g} ms its times are written in: "
        f"{advice}",
        path,
        int(lines[worst]),
    )


def _seconds(t: float) -> str:
    """A time in seconds for a message: 9 significant digits, more for a large time
    (Unix times, 1.7e9 s, to the hundred-thousandth of a second, not "1.7e+09")."""
    digits = 9 if not math.isfinite(t) or abs(t) < 1e4 else int(math.log10(abs(t))) + 6
    return f"{t:.{digits}g}"


def time_format(first: float, frame_time: float, n_frames: int) -> bytes:
    """The printf format of a written time column of ``n_frames`` rows from ``first`` s,
    ``frame_time`` s apart: 12 significant digits, or as many more (up to 17, a float's
    own) as keep each time to a millionth of a frame, or a float's resolution, where the
    times are large beside the step (Unix times: 1.7e9 s at 60 fps had been written
    1700000000.02, .03, ...; now to about 1e-5 of a frame)."""
    largest = max(abs(first), abs(first + n_frames * frame_time))
    ratio = largest / frame_time if frame_time > 0 else 0.0
    needed = math.ceil(math.log10(ratio)) + 6 if ratio > 1.0 and math.isfinite(ratio) else 0
    return b"%%.%dg" % min(17, max(12, needed))


def _out_of_order(times: np.ndarray, lines: np.ndarray, i: int, path) -> NoReturn:
    """Refuse the row that breaks the order of ``times`` first seen at row ``i`` (not after
    row ``i - 1``): row ``i - 1`` when it alone is out of line with both its neighbours (rows
    ``i - 2``, ``i``, ``i + 1`` in order, it not between them: a 5 s among tenths), else
    row ``i``."""
    if 2 <= i < times.size - 1 and times[i - 2] < times[i] < times[i + 1] <= times[i - 1]:
        _fail(
            f"time {_seconds(times[i - 1])} s is out of order (the row before has "
            f"{_seconds(times[i - 2])} s, the next {_seconds(times[i])} s)",
            path,
            int(lines[i - 1]),
        )
    again = " (the same time twice: delete the repeated row)" if times[i] == times[i - 1] else ""
    _fail(
        f"time does not increase ({_seconds(times[i])} s after {_seconds(times[i - 1])} s){again}",
        path,
        int(lines[i]),
    )


def _refuse_skipped_rows(
    times: np.ndarray, lines: np.ndarray, path, advice: str, frames: np.ndarray | None
) -> None:
    """Refuse increasing ``times`` (seconds) whose every step is, within
    :data:`TIME_TOLERANCE`, a whole number of their median step, some of them two or more
    (and the rows' ``frames`` numbers, where given, skip as far): a fixed rate with rows
    missing, said as such (on the row after the first gap) rather than as a rate the gaps'
    mean would give; ``advice`` ends the error."""
    steps = np.diff(times)
    step = float(np.median(steps))
    if not MIN_FRAME_TIME <= step <= MAX_FRAME_TIME:
        return
    # the step the whole span holds (times rounded to milliseconds make the median's off:
    # 0.017 s for 60 fps)
    count = np.maximum(np.rint(steps / step), 1.0)
    step = float((times[-1] - times[0]) / count.sum())
    count = np.rint(steps / step)
    skips = np.flatnonzero(count >= 2)
    whole = np.abs(steps - count * step) <= TIME_TOLERANCE * step
    if not skips.size or not whole.all():
        return
    if frames is not None and not np.array_equal(np.diff(frames)[skips], count[skips]):
        return  # frames numbered on: the times are uneven, no row is missing
    first = int(skips[0])
    others = f" and {plural(skips.size - 1, 'other gap')}" if skips.size > 1 else ""
    _fail(
        f"{plural(int(np.sum(count[skips] - 1)), 'row')} missing at a fixed rate of "
        f"{whole_frames(1.0 / step):.6g} fps ({step:.6g} s per row): time "
        f"{_seconds(times[first])} s is followed by {_seconds(times[first + 1])} s "
        f"({plural(int(count[first]) - 1, 'frame')} skipped){others}: {advice}",
        path,
        int(lines[first + 1]),
    )


def _refuse_jump(
    times: np.ndarray,
    steps: np.ndarray,
    mean: float,
    lines: np.ndarray,
    path,
    advice: str,
    frames: np.ndarray | None,
) -> None:
    """Refuse increasing ``times`` (seconds) whose first step over twice the median step
    ``steps`` hold drags the ``mean`` step more than :data:`TIME_TOLERANCE` beyond that
    median (a clock jump: a check against the mean would blame the first ordinary step,
    and say a mean step no row has), at the row after it, with the ``frames`` numbers on
    either side where given; ``advice`` ends the error."""
    median = float(np.median(steps))
    if not (MIN_FRAME_TIME <= median <= MAX_FRAME_TIME and mean > (1.0 + TIME_TOLERANCE) * median):
        return
    jumps = np.flatnonzero(steps > 2.0 * median)
    if not jumps.size:
        return
    i = int(jumps[0])
    numbers = (
        f" (frame {frames[i]:.0f}, then frame {frames[i + 1]:.0f})" if frames is not None else ""
    )
    _fail(
        f"not uniformly sampled: time {_seconds(times[i])} s is followed by "
        f"{_seconds(times[i + 1])} s{numbers}, a step of {steps[i]:.6g} s against a median "
        f"step of {median:.6g} s: {advice}",
        path,
        int(lines[i + 1]),
    )


def uniform_frame_time(
    times: np.ndarray,
    lines: np.ndarray,
    path,
    template: float | None,
    advice: str = UNEVEN_ADVICE,
    skipped_advice: str = SKIPPED_ADVICE,
    frames: np.ndarray | None = None,
) -> float:
    """The frame time of a uniformly sampled time column (see the module docstring);
    ``advice`` ends the error of one that is not, ``skipped_advice`` that of one that
    skips rows at a fixed rate (:func:`_refuse_skipped_rows`; ``frames``: the rows' frame
    numbers, where the file has them)."""
    n = times.size
    if n < 2:
        if template is not None:
            return template
        _fail(
            "a single row cannot give the frame time; at least two rows are needed",
            path,
            int(lines[0]),
        )
    with np.errstate(over="ignore", invalid="ignore"):  # +-1e308 spans: refused below
        steps = np.diff(times)
    back = np.flatnonzero(~(steps > 0))
    if back.size:
        _out_of_order(times, lines, back[0] + 1, path)
    grid = np.arange(n)
    if template is not None and np.all(
        np.abs(times - times[0] - grid * template) <= TIME_TOLERANCE * template
    ):
        return template
    with np.errstate(over="ignore", invalid="ignore"):
        mean = (times[-1] - times[0]) / (n - 1)
        if np.isfinite(mean):
            _refuse_skipped_rows(times, lines, path, skipped_advice, frames)
        _refuse_jump(times, steps, mean, lines, path, advice, frames)
    if not (MIN_FRAME_TIME <= mean <= MAX_FRAME_TIME):
        _fail(
            f"a time step of {mean:.6g} s gives no usable frame rate ({RATES_ACCEPTED})",
            path,
            int(lines[1]),
        )
    off, drift = _off_grid(times, mean)
    coarse = _coarse_grid(times, mean, lines, path, advice) if off.any() or drift.any() else None
    if coarse is not None:
        return float(f"{coarse:.12g}")
    if off.any():
        i = np.flatnonzero(off)[0] + 1
        _fail(
            f"not uniformly sampled: a time step of {steps[i - 1]:.6g} s against a mean "
            f"step of {mean:.6g} s (more than {TIME_TOLERANCE:.0%} apart): {advice}",
            path,
            int(lines[i]),
        )
    if drift.any():
        i = np.flatnonzero(drift)[0]
        _fail(
            f"not uniformly sampled: time {times[i]:.6g} s is more than "
            f"{TIME_TOLERANCE:.0%} of a frame off the uniform grid of {mean:.6g} s steps: "
            f"{advice}",
            path,
            int(lines[i]),
        )
    return float(f"{_whole_rate(times, mean):.12g}")


def _whole_rate(times: np.ndarray, mean: float) -> float:
    """``mean``, the span's step, or the nearest whole rate's step where the times are
    written in coarse steps (over 1 % of a frame: whole milliseconds) and that rate's grid
    holds them within a written step (50 rows of 120 fps in whole milliseconds had read
    120.098 fps; finer times keep their span's step)."""
    step = written_step(times)
    if not COARSE_WRITTEN * mean < step < mean:
        return mean
    held = _held_by(times, (_whole_rate_step(mean),), step)
    return mean if held is None else held


def _centred_rows(n: int) -> np.ndarray:
    """``(n,)`` row numbers centred on the middle row (a grid's step fitted or tried)."""
    return np.arange(n) - (n - 1) / 2.0


def _whole_rate_step(frame_time: float) -> float:
    """The frame time of the whole rate nearest to ``frame_time``'s."""
    return 1.0 / max(round(1.0 / frame_time), 1)


def _held_by(times: np.ndarray, steps, written: float) -> float | None:
    """The first of the frame times ``steps`` whose uniform grid holds every one of
    ``times`` within ``written``, the step they are written in (rounded or cut: their
    offsets from the grid spread over at most that, give or take TIME_TOLERANCE); None
    where none does."""
    rows = _centred_rows(times.size)
    for step in steps:
        off = times - rows * step
        if float(off.max() - off.min()) <= (1.0 + TIME_TOLERANCE) * written:
            return step
    return None
