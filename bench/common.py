"""What the benchmark scripts share: where the corpus is, and best-of-N timing (wall clock
or process CPU).

The scripts run as ``python bench/<name>.py``, which puts this folder first on ``sys.path``,
so they import this module as ``common``. It imports nothing from the package itself.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable
from pathlib import Path

#: The project folder (the parent of ``bench/``).
ROOT = Path(__file__).resolve().parents[1]

#: The CMU corpus beside the project: ``../shared/corpus/cmu``.
CORPUS = ROOT.parent / "shared" / "corpus" / "cmu"


def corpus_clips(pattern: str = "*.bvh") -> list[Path]:
    """The corpus clips matching ``pattern``, sorted; exits with a message if there are none."""
    clips = sorted(CORPUS.glob(pattern))
    if not clips:
        raise SystemExit(f"no corpus clips {pattern} in {CORPUS}")
    return clips


def elapsed(fn: Callable[[], object]) -> float:
    """Wall-clock time of one call ``fn()``, in seconds."""
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def best_of(fn: Callable[[], object], repeats: int, warm_up: bool = False) -> float:
    """Shortest of ``repeats`` timed calls ``fn()``, in seconds (``inf`` for none); with
    ``warm_up`` one untimed call first (allocator, caches)."""
    if warm_up:
        fn()
    return min((elapsed(fn) for _ in range(repeats)), default=math.inf)


def best_cpu(fn: Callable[[], object], repeats: int) -> float:
    """Shortest process CPU time of ``repeats`` calls ``fn()``, in seconds, after one
    untimed call (steadier than wall-clock time on a shared machine)."""
    fn()
    times = []
    for _ in range(repeats):
        start = time.process_time()
        fn()
        times.append(time.process_time() - start)
    return min(times)


def cpu_ratio(base: Callable[[], object], other: Callable[[], object], rounds: int) -> float:
    """Median over ``rounds`` of the process CPU time of ``other()`` over that of
    ``base()`` timed just before it, after one untimed call of each: the pair sees the
    same state of a shared machine, whose speed drifts between separate bests (footlock
    on 131_02 read 0.79-1.80 default runs from two bests of five, 1.13-1.28 paired)."""
    base(), other()

    def cpu(fn: Callable[[], object]) -> float:
        start = time.process_time()
        fn()
        return time.process_time() - start

    return float(statistics.median(cpu(other) / cpu(base) for _ in range(rounds)))
