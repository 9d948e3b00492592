"""Run clip jobs on a Dask cluster (``batch --scheduler``), the same jobs as the local pool.

Each clip is one task: :func:`motionclean.jobs.run_job` on a :class:`~motionclean.jobs.Job`
(paths and step tables), so workers read and write the files themselves (shared storage)
and only the small :class:`~motionclean.jobs.FileResult` records come back. Needs the
``dask`` extra: ``pip install motionclean[dask]``.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Sequence
from contextlib import contextmanager

from .errors import UsageError
from .jobs import FileResult, Job, run_job

#: Seconds to wait for a scheduler before giving up.
CONNECT_TIMEOUT_S = 5
#: Times Dask retries a task whose worker died before the clip counts as failed.
RETRIES = 1


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


@contextmanager
def connect(scheduler: str, default_workers: int) -> Iterator[tuple[object, int]]:
    """A ``distributed.Client`` for ``scheduler`` (see :func:`parse_scheduler`) and the
    number of workers it has; a local cluster is started and closed here."""
    distributed = _distributed()
    address, count = parse_scheduler(scheduler)
    if address == "local":
        n = count or default_workers
        with (
            distributed.LocalCluster(
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=50,
            ) as cluster,
            distributed.Client(cluster) as client,
        ):
            yield client, n
        return
    try:
        client = distributed.Client(address, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError) as error:
        raise UsageError(
            f"--scheduler {address}: no Dask scheduler answers there within "
            f"{CONNECT_TIMEOUT_S} s ({type(error).__name__})"
        ) from None
    with client:
        workers = len(client.scheduler_info().get("workers", {})) or 1
        yield client, workers


def run_jobs_on(client, jobs: Sequence[Job]) -> Iterator[tuple[int, FileResult]]:
    """Run ``jobs`` as Dask tasks; yield ``(index, result)`` as each ends. A task whose
    worker died twice fails its clip instead of stopping the run; an interrupt cancels the
    tasks not yet done."""
    distributed = _distributed()
    futures = [
        client.submit(
            run_job, job, key=f"motionclean-{k}-{job.source}", retries=RETRIES, pure=False
        )
        for k, job in enumerate(jobs)
    ]
    index = {future.key: k for k, future in enumerate(futures)}
    try:
        for future in distributed.as_completed(futures):
            k = index[future.key]
            try:
                yield k, future.result()
            except Exception as error:  # a lost worker, a killed task
                job = jobs[k]
                reason = f"{job.source}: the Dask task failed ({type(error).__name__}: {error})"
                yield k, FileResult(job.source, job.target, "failed", error=reason)
    finally:
        client.cancel([f for f in futures if not f.done()])
