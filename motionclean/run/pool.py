"""Run clip jobs on a pool of local worker processes (what ``batch --jobs N`` uses).

Free of the command line; a script that calls :func:`run_jobs` needs the usual
``if __name__ == "__main__":`` guard of multiprocessing code.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
import time
from collections import deque
from collections.abc import Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

from .jobs import FileResult, Job, run_job

#: How often a worker checks that its parent is still there, seconds.
PARENT_POLL_S = 0.5


#: How long a worker told to stop may take to end before it is killed (seconds).
STOP_SECONDS = 5.0


def default_workers() -> int:
    """The number of cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _worker_setup(parent: int) -> None:
    """Worker initializer: Ctrl-C is handled by the parent, which stops handing out clips;
    SIGTERM (the parent's, or one sent to the whole process group by ``kill``, ``timeout``
    or a scheduler) ends the worker at once and silently, by the signal's default action,
    instead of the parent's handler it was forked with (a traceback per worker); the parent
    removes what it leaves and says the one line. A worker whose parent is gone (killed,
    even with SIGKILL) exits within a second instead of holding the caller's pipes open.
    Each worker cleans its clip on one thread: the workers already use the cores."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    os.environ["MOTIONCLEAN_THREADS"] = "1"

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        os._exit(1)

    threading.Thread(target=watch, daemon=True, name="motionclean-parent-watch").start()


def input_size(path: str) -> int:
    """Size of ``path`` in bytes (0 when it cannot be read): the order jobs are handed out."""
    try:
        return os.path.getsize(path)
    except OSError:
        return 0


def _context() -> multiprocessing.context.BaseContext:
    """Workers are forked where the platform allows it (nothing to import again), else
    spawned."""
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods else "spawn")


def run_jobs(jobs: Sequence[Job], workers: int) -> Iterator[tuple[int, FileResult]]:
    """Run ``jobs`` on ``workers`` local processes; yield ``(index, result)`` as each ends.

    One worker runs in this process. Several run in worker processes, handed the largest
    inputs first so that the run does not end waiting on one long clip, at most one clip
    per worker at a time. A worker that dies (killed, out of memory) breaks its pool: the
    clips not yet handed out go on in a new one, and those that were running when it
    broke run again one at a time after them, so only a clip that kills its worker alone
    fails ("the worker process died"); the others are cleaned.
    """
    if workers <= 1 or len(jobs) <= 1:
        for index, job in enumerate(jobs):
            yield index, run_job(job)
        return
    waiting = deque(sorted(range(len(jobs)), key=lambda i: -input_size(jobs[i].source)))
    suspects: deque[int] = deque()  # running when a worker died: one at a time, last
    while waiting or suspects:
        alone = not waiting
        source, limit = (suspects, 1) if alone else (waiting, min(workers, len(waiting)))
        yield from _run_pool(jobs, source, limit, suspects, alone)


def _run_pool(
    jobs: Sequence[Job], source: deque, limit: int, suspects: deque, alone: bool
) -> Iterator[tuple[int, FileResult]]:
    """The clips of ``source`` on a pool of ``limit`` workers, one each at a time, until
    they are done or a worker dies: then the clips running are added to ``suspects``, or,
    ``alone`` (one clip running), failed."""
    executor = ProcessPoolExecutor(
        max_workers=limit,
        mp_context=_context(),
        initializer=_worker_setup,
        initargs=(os.getpid(),),
    )
    running: dict = {}
    broken = False
    try:
        while (source or running) and not broken:
            while source and len(running) < limit:
                index = source.popleft()
                running[executor.submit(run_job, jobs[index])] = index
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            for future in done:
                index = running.pop(future)
                try:
                    yield index, future.result()
                except BrokenProcessPool:
                    broken = True
                    if alone:
                        job = jobs[index]
                        died = f"{job.source}: the worker process died"
                        yield index, FileResult(job.source, job.target, "failed", error=died)
                    else:
                        suspects.append(index)
        suspects.extend(running.values())  # (a broken pool's other clips: run again)
    except BaseException:  # Ctrl-C, SIGTERM, the caller gone: do not wait for running clips
        processes = list((getattr(executor, "_processes", None) or {}).values())
        executor.shutdown(wait=False, cancel_futures=True)
        for process in processes:
            process.terminate()
        deadline = time.monotonic() + STOP_SECONDS  # (one wait for all of them)
        for process in processes:  # (ended by the signal at once: none writes after this)
            process.join(timeout=max(deadline - time.monotonic(), 0.0))
            if process.is_alive():  # stopped (SIGSTOP) or stuck: ended for sure
                process.kill()
                process.join()
        raise
    executor.shutdown(wait=not broken)
