"""Run clip jobs on a Dask cluster (``batch --scheduler``), the same jobs as the local pool.

Each clip is one task: :func:`motionclean.run.jobs.run_job` on a :class:`~motionclean.run.jobs.Job`
(paths and step tables), so workers read and write the files themselves (shared storage)
and only the small :class:`~motionclean.run.jobs.FileResult` records come back. Needs the
``dask`` extra: ``pip install motionclean[dask]``.
"""

from __future__ import annotations

import re
import signal
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from ..core.errors import UsageError
from .jobs import FileResult, Job, run_job
from .pool import input_size

#: Seconds to wait for a scheduler before giving up.
CONNECT_TIMEOUT_S = 5


def _distributed():
    try:
        import distributed
    except ImportError:
        raise UsageError(
            "--scheduler needs Dask: pip install 'motionclean[dask]' (dask and distributed)"
        ) from None
    return distributed


def parse_scheduler(text: str) -> tuple[str, int | None]:
    """``("local", N or None)`` for ``local[:N]``, else ``("address", None)``."""
    match = re.fullmatch(r"local(?::(\d+))?", text)
    if match:
        count = int(match.group(1)) if match.group(1) else None
        if count == 0:
            raise UsageError("--scheduler local:N needs at least one worker")
        return "local", count
    if not re.fullmatch(r"(tcp|tls|ws|wss|inproc)://\S+", text):
        raise UsageError(
            f"--scheduler {text!r}: expected a scheduler address such as "
            "tcp://HOST:8786, or local[:N] for a cluster on this machine"
        )
    return text, None


class _HeldInterrupts:
    """Ctrl-C and SIGTERM noted, not raised, while a cluster or client starts (an interrupt
    inside Dask's start-up leaves a half-built cluster that fails at exit with a traceback);
    :meth:`release` raises the noted one once everything can be closed in order."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.noted = False
        self.previous: dict = {}

    def __enter__(self) -> _HeldInterrupts:
        if threading.current_thread() is threading.main_thread():
            self.previous = {s: signal.signal(s, self._note) for s in self.SIGNALS}
        return self

    def _note(self, signum, frame) -> None:
        self.noted = True

    def __exit__(self, *exc) -> None:
        for number, handler in self.previous.items():
            signal.signal(number, handler)

    def release(self) -> None:
        if self.noted:
            raise KeyboardInterrupt


@contextmanager
def connect(scheduler: str, default_workers: int, clips: int) -> Iterator[tuple[Any, int]]:
    """A ``distributed.Client`` for ``scheduler`` (see :func:`parse_scheduler`) and the
    number of workers it has; a local cluster is started and closed here, with no more
    workers than ``clips`` (each worker is a process: ``local:99999`` for a few clips
    would start thousands for nothing)."""
    distributed = _distributed()
    address, count = parse_scheduler(scheduler)
    if address == "local":
        n = max(1, min(count or default_workers, clips))
        with _HeldInterrupts() as held:
            cluster = distributed.LocalCluster(
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                dashboard_address=":0",  # a free port: 8787 may be taken
                silence_logs=50,
            )
            client = distributed.Client(cluster)
        with cluster, client:
            held.release()
            yield client, n
        return
    try:
        with _HeldInterrupts() as held:
            client = distributed.Client(address, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError) as error:
        raise UsageError(
            f"--scheduler {address}: no Dask scheduler answers there within "
            f"{CONNECT_TIMEOUT_S} s ({type(error).__name__})"
        ) from None
    with client:
        held.release()
        workers = len(client.scheduler_info().get("workers", {})) or 1
        yield client, workers


def run_jobs_on(client, jobs: Sequence[Job]) -> Iterator[tuple[int, FileResult]]:
    """Submit ``jobs`` as Dask tasks now; the returned iterator yields ``(index, result)``
    as each ends.

    The largest inputs go first, as in the local pool, so the run does not end waiting on
    one long clip. A task whose worker dies is run again elsewhere by the scheduler (up to
    its ``allowed-failures``, 3 by default); after that its clip fails with the reason
    instead of stopping the run or going missing. An interrupt cancels the tasks not yet
    done.
    """
    distributed = _distributed()
    order = sorted(range(len(jobs)), key=lambda k: -input_size(jobs[k].source))
    futures = {
        k: client.submit(
            run_job,
            jobs[k],
            key=f"motionclean-{k}-{jobs[k].source}",
            priority=len(jobs) - rank,
            pure=False,
        )
        for rank, k in enumerate(order)
    }
    return _collect(distributed, client, futures, jobs)


def _collect(
    distributed, client, futures: dict, jobs: Sequence[Job]
) -> Iterator[tuple[int, FileResult]]:
    index = {future.key: k for k, future in futures.items()}
    try:
        for future in distributed.as_completed(list(futures.values())):
            k = index[future.key]
            try:
                yield k, future.result()
            except Exception as error:  # a worker lost too often, a task cancelled
                job = jobs[k]
                reason = f"{job.source}: the Dask task failed ({type(error).__name__}: {error})"
                yield k, FileResult(job.source, job.target, "failed", error=reason)
    finally:
        client.cancel([f for f in futures.values() if not f.done()])
