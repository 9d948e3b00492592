"""Independent parts of one clip's work, run on the machine's cores.

numpy releases the GIL inside its loops, so threads that work on separate blocks of
frames or separate joints run at the same time. Callers split work into parts whose
boundaries never depend on the number of threads, and every part computes exactly what
the whole would: a result is bit for bit the same with one thread or many.

``MOTIONCLEAN_THREADS`` sets the number of threads (default: the CPUs this process may
use, at most :data:`MAX_THREADS`); the worker processes of a local batch, which already
run one clip per core, set it to 1. A part that itself asks for parts runs them in its
own thread. Where the system refuses a thread (an address-space limit with no room left
for one more thread's stack), the parts run on the calling thread from then on.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

from .errors import UsageError
from .reserve import let_go

__all__ = ["MAX_THREADS", "in_parts", "run_parts", "thread_count"]

T = TypeVar("T")
R = TypeVar("R")

#: Most threads used for one clip (more cores than this bring little for one clip).
MAX_THREADS = 8
#: Fewest values worth sharing among threads (see :func:`run_parts`).
MIN_SHARED_SIZE = 1 << 18
_pool: ThreadPoolExecutor | None = None
_pool_lock = threading.Lock()
_inside = threading.local()
#: Set once the system refused a thread: parts run on the calling thread from then on.
_no_threads = threading.Event()


def thread_count() -> int:
    """Threads for one clip's parts: ``MOTIONCLEAN_THREADS`` if set (a whole number from 1 in
    ASCII digits, whitespace around it allowed, else :class:`UsageError`), else the CPUs
    this process may use; at most :data:`MAX_THREADS`."""
    text = os.environ.get("MOTIONCLEAN_THREADS", "").strip()
    if text:
        if not (text.isascii() and text.isdecimal() and int(text) > 0):
            raise UsageError(
                f"MOTIONCLEAN_THREADS={text!r}: expected a whole number of threads, 1 or more"
            )
        return min(int(text), MAX_THREADS)
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cpus = os.cpu_count() or 1
    return max(1, min(cpus, MAX_THREADS))


def _executor(workers: int) -> ThreadPoolExecutor:
    global _pool
    with _pool_lock:
        if _pool is None or _pool._max_workers != workers:
            if _pool is not None:
                _pool.shutdown(wait=False)
            _pool = _Pool(workers, thread_name_prefix="motionclean")
        return _pool


class _Refused(RuntimeError):
    """The system refused the pool its first thread: no part ran."""


class _Pool(ThreadPoolExecutor):
    """A thread pool that notes when the system refuses it a thread (an address-space
    limit that leaves no room for one more thread's stack: ``can't start new thread``).
    With threads already running, the part just queued is theirs to do (it is not lost,
    nor run twice); with none, :class:`_Refused` is raised and nothing queued ever runs."""

    def _adjust_thread_count(self) -> None:
        try:
            super()._adjust_thread_count()
        except RuntimeError as error:
            _no_threads.set()
            if not self._threads:
                raise _Refused(*error.args) from error


def _forget_pool() -> None:
    """A forked child has none of its parent's threads (nor its lock's holder): it starts
    its own pool. A refused thread stays refused: the child has its parent's limits."""
    global _pool, _pool_lock
    _pool = None
    _pool_lock = threading.Lock()


os.register_at_fork(after_in_child=_forget_pool)


def _part(function: Callable[[T], R], item: T) -> R:
    _inside.active = True
    try:
        return function(item)
    except MemoryError as error:
        let_go(error)  # room to travel up from this thread too
        raise
    finally:
        _inside.active = False


def run_parts(function: Callable[[T], R], items: Iterable[T], size: int | None = None) -> list[R]:
    """``[function(item) for item in items]``, the items run on :func:`thread_count`
    threads; results in the items' order, the first exception raised as it was. ``size``,
    the values all parts hold together: below :data:`MIN_SHARED_SIZE` they run on this
    thread (handing work to a thread would cost more than the work)."""
    items = list(items)
    workers = min(thread_count(), len(items))
    small = size is not None and size < MIN_SHARED_SIZE
    if workers <= 1 or small or getattr(_inside, "active", False) or _no_threads.is_set():
        return [function(item) for item in items]
    pool = _executor(workers)
    try:
        return list(pool.map(lambda item: _part(function, item), items))
    except _Refused:  # not a part's own RuntimeError, raised as it was
        pass
    # the system refused the pool its first thread: no part ran; this thread does them,
    # as every later call will
    _close(pool)
    return [function(item) for item in items]


def _close(pool: ThreadPoolExecutor) -> None:
    global _pool
    with _pool_lock:
        if _pool is pool:
            _pool = None
    pool.shutdown(wait=False)


def in_parts(stop: int, part: int, start: int = 0) -> Sequence[slice]:
    """``[start, stop)`` cut into slices of ``part`` items (the last may be shorter): a
    split that depends on the sizes only, never on the number of threads."""
    return [slice(at, min(at + part, stop)) for at in range(start, stop, max(1, part))]
