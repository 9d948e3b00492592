"""Run clip jobs on a Dask cluster (``batch --scheduler``), the same jobs as the local pool.

Each clip is one task: :func:`motionclean.run.jobs.run_job` on a :class:`~motionclean.run.jobs.Job`
(paths and step tables), so workers read and write the files themselves (shared storage)
and only the small :class:`~motionclean.run.jobs.FileResult` records come back. Needs the
``dask`` extra: ``pip install motionclean[dask]``.
"""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import logging
import os
import re
import signal
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from ..core.errors import MotionError, UsageError
from .jobs import FileResult, Job, run_job
from .pool import input_size

#: Seconds a scheduler has to take a connection; it has :data:`ANSWER_SHARE` times as long
#: to also send its handshake.
CONNECT_TIMEOUT_S = 5
ANSWER_SHARE = 1.5
#: Seconds a local cluster may be without any worker before the run fails the clips not
#: done (Dask restarts a lost worker within seconds; one killed while starting stays gone).
WORKERLESS_S = 10.0
#: The same for a scheduler elsewhere, whose workers may be starting or scaling up.
REMOTE_WORKERLESS_S = 120.0
#: How often the run checks that its cluster has a worker, seconds.
WATCH_S = 0.5


def _distributed():
    try:
        import distributed
    except ImportError:
        raise UsageError(
            "--scheduler needs Dask: pip install 'motionclean[dask]' (dask and distributed)"
        ) from None
    return distributed


#: A host name (RFC 1123 labels, ``_`` as container names have it), an IPv4 address, or an
#: IPv6 address in brackets.
_HOST = re.compile(
    r"(?P<name>(?:[A-Za-z0-9_](?:[A-Za-z0-9_-]{0,61}[A-Za-z0-9_])?\.)*"
    r"[A-Za-z0-9_](?:[A-Za-z0-9_-]{0,61}[A-Za-z0-9_])?)|\[(?P<ipv6>[0-9A-Fa-f:.]+)\]",
    re.ASCII,
)
_EXAMPLE = "expected a scheduler address such as tcp://HOST:8786, or local[:N] for a cluster "
_EXAMPLE += "on this machine"


def parse_scheduler(text: str) -> tuple[str, int | None]:
    """``("local", N or None)`` for ``local[:N]``, else ``(address, None)`` for
    ``PROTOCOL://HOST:PORT`` (tcp, tls, ws or wss; a port from 1 to 65535). Anything else is
    a :class:`UsageError` saying what is wrong, before any connection is tried."""
    match = re.fullmatch(r"local(?::(\d+))?", text)
    if match:
        count = int(match.group(1)) if match.group(1) else None
        if count == 0:
            raise UsageError("--scheduler local:N needs at least one worker")
        return "local", count
    shown = repr(text[:80] + ("..." if len(text) > 80 else ""))
    protocol, sep, location = text.partition("://")
    if protocol == "inproc":
        raise UsageError(
            f"--scheduler {shown}: an inproc:// address exists only inside one Python "
            f"process; {_EXAMPLE}"
        )
    if not sep or protocol not in ("tcp", "tls", "ws", "wss"):
        raise UsageError(f"--scheduler {shown}: {_EXAMPLE}")
    host, colon, port = location.rpartition(":")
    if not colon or not port.isascii() or not port.isdigit() or not 0 < int(port) < 65536:
        raise UsageError(
            f"--scheduler {shown}: needs a port from 1 to 65535 after the host "
            f"({protocol}://HOST:PORT; a scheduler listens on 8786 by default)"
        )
    found = _HOST.fullmatch(host)
    if not found or (found.group("name") and len(host) > 253) or not _ipv6(found.group("ipv6")):
        raise UsageError(
            f"--scheduler {shown}: {host[:40]!r} is no host name or IP address (labels of at "
            "most 63 letters, digits or '-', 253 characters in all; IPv6 in [brackets])"
        )
    return text, None


def _ipv6(text: str | None) -> bool:
    """True when ``text`` is None (no IPv6 address given) or an IPv6 address."""
    try:
        return text is None or isinstance(ipaddress.ip_address(text), ipaddress.IPv6Address)
    except ValueError:
        return False


def _handshake(distributed, address: str) -> None:
    """Connect to ``address`` within :data:`CONNECT_TIMEOUT_S` and read the scheduler's
    handshake, all within :data:`ANSWER_SHARE` times it; a :class:`UsageError` naming the
    address says what went wrong.

    Dask's own timeout covers the TCP connect only: a port that accepts and never answers (a
    firewall black hole, a hung service) hung ``batch`` for good, and one that answers in
    another protocol (the dashboard's HTTP on 8787) had it allocate exabytes for a message
    length read from ``HTTP/1.1``.
    """
    from distributed.comm import connect as comm_connect

    options = distributed.Security().get_connection_args("client")
    answer_s = ANSWER_SHARE * CONNECT_TIMEOUT_S

    async def once() -> None:
        comm = await asyncio.wait_for(
            comm_connect(address, timeout=CONNECT_TIMEOUT_S, **options), answer_s
        )
        await comm.close()

    try:
        asyncio.run(once())
    except TimeoutError:  # (an OSError too: first) the connection was taken, then silence
        raise UsageError(
            f"--scheduler {address}: accepted the connection but sent no Dask handshake within "
            f"{answer_s:g} s (a firewall, a hung service, or another service's "
            "port: a scheduler listens on 8786, its dashboard on 8787)"
        ) from None
    except OSError as error:  # refused, unreachable, no such host, closed on us
        raise UsageError(
            f"--scheduler {address}: no Dask scheduler answers there within "
            f"{CONNECT_TIMEOUT_S:g} s ({_first_cause(error)})"
        ) from None
    except TypeError as error:  # tls:// without certificates: "TLS expects a ssl_context"
        raise UsageError(
            f"--scheduler {address}: cannot connect ({error}); a tls:// or wss:// scheduler "
            "needs the certificates in the Dask configuration (distributed.comm.tls.*)"
        ) from None
    except Exception as error:  # what another protocol's bytes give (MemoryError too)
        raise UsageError(
            f"--scheduler {address}: something answers there, but not a Dask scheduler "
            f"({type(error).__name__}; a scheduler listens on 8786, its dashboard on 8787)"
        ) from None


def _first_cause(error: BaseException) -> str:
    """The reason at the root of a chain of exceptions: 'Connection refused', 'Name or
    service not known', or the exception's type."""
    while error.__cause__ is not None:
        error = error.__cause__
    strerror = getattr(error, "strerror", None)
    return strerror if isinstance(strerror, str) else type(error).__name__


class _HeldInterrupts:
    """Ctrl-C and SIGTERM held, not raised, while a cluster or client starts (an interrupt
    inside Dask's start-up leaves a half-built cluster that fails at exit with a traceback);
    :meth:`release` raises a held one once everything can be closed in order.

    Ctrl-C (SIGINT) is blocked in this thread's signal mask, so it waits, pending. The
    threads Dask starts meanwhile inherit the mask, and so do the worker processes they
    spawn (at start and when a lost worker is restarted): a terminal sends Ctrl-C to the
    whole process group, and each worker printed its own traceback. The parent alone
    takes it and closes them. A thread started before the hold (Dask's, on import) still
    takes SIGINT, whose Python handler then runs in this thread: it is noted too, not
    raised inside Dask's start-up (the half-built cluster's nanny and worker had held the
    caller's pipes past 30 s after the one-line error). SIGTERM is noted by a handler as
    well: Dask stops its workers with SIGTERM, which they must not block.
    """

    def __init__(self) -> None:
        self.noted = False
        self.previous: dict[int, Any] = {}
        self.mask: set | None = None

    def hold(self) -> _HeldInterrupts:
        main = threading.current_thread() is threading.main_thread()
        if main and hasattr(signal, "pthread_sigmask"):  # (POSIX)
            for signum in (signal.SIGTERM, signal.SIGINT):
                self.previous[signum] = signal.signal(signum, self._note)
            self.mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        return self

    def _note(self, signum, frame) -> None:
        self.noted = True

    def release(self) -> None:
        """Take interrupts again; one that came meanwhile is raised now (KeyboardInterrupt)."""
        if self.mask is not None:
            for signum, previous in self.previous.items():
                signal.signal(signum, previous)
            signal.pthread_sigmask(signal.SIG_SETMASK, self.mask)  # a pending Ctrl-C: raised
            self.mask = None
        if self.noted:
            self.noted = False
            raise KeyboardInterrupt


#: Above every level Dask logs at: its log lines are off (see :func:`_silence_dask_logs`).
_SILENT = logging.CRITICAL + 1


def _silence_dask_logs() -> None:
    """Dask's own log lines off in this process for good: stderr carries motionclean's
    one-line errors, and Dask's comms log (with tracebacks) as workers die and after a
    cluster has closed, when no context could still hold them back."""
    names = [n for n in logging.root.manager.loggerDict if n.startswith("distributed.")]
    for name in ("distributed", *names):
        logging.getLogger(name).setLevel(_SILENT)


def _quiet_resource_tracker() -> None:
    """Start multiprocessing's resource tracker (a process of its own, which Dask's worker
    queues use) with warnings off: when ``batch`` is killed with SIGKILL it warned on the
    caller's terminal about the leaked semaphores it then cleans up."""
    from multiprocessing import resource_tracker

    flag = "ignore::UserWarning"
    sys.warnoptions.append(flag)  # read when the tracker's command line is made
    try:
        resource_tracker.ensure_running()
    finally:
        sys.warnoptions.remove(flag)


def _terminate_workers(cluster) -> None:
    """SIGTERM to each worker process of a local cluster: a busy worker finishes its clip
    before it heeds its nanny's stop (seconds after Ctrl-C); the clips are written
    atomically and batch removes a temporary file one leaves. Each nanny is told first
    that the cluster is closing: a nanny restarts a worker that exits on its own, and the
    new worker, still starting while the cluster closed, had held the caller's pipes for
    over 30 s on a loaded machine after the one-line error."""
    for nanny in list(cluster.workers.values()):
        with contextlib.suppress(Exception):  # (a nanny already gone)
            nanny.close_gracefully()
        pid = getattr(nanny, "pid", None)
        if pid:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGTERM)


@contextmanager
def connect(scheduler: str, default_workers: int, clips: int) -> Iterator[tuple[Any, int]]:
    """A ``distributed.Client`` for ``scheduler`` (see :func:`parse_scheduler`) and the
    number of workers it has; a local cluster is started and closed here, with no more
    workers than ``clips`` (each worker is a process: ``local:99999`` for a few clips
    would start thousands for nothing)."""
    distributed = _distributed()
    _silence_dask_logs()
    address, count = parse_scheduler(scheduler)
    if address == "local":
        n = max(1, min(count or default_workers, clips))
        _quiet_resource_tracker()
        held = _HeldInterrupts().hold()
        cluster = client = None
        try:
            cluster = distributed.LocalCluster(
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                dashboard_address=":0",  # a free port: 8787 may be taken
                silence_logs=_SILENT,  # the workers' logs too
            )
            client = distributed.Client(cluster)
        except Exception as error:  # a worker killed while starting, no memory, ...
            if cluster is not None:
                cluster.close()
            held.release()  # an interrupt meanwhile is what the user sees
            raise MotionError(
                f"--scheduler {scheduler}: the local Dask cluster did not start "
                f"({type(error).__name__}: {error})"
            ) from None
        with cluster, client:
            held.release()
            try:
                yield client, n
            except BaseException:  # Ctrl-C, SIGTERM: stop now, not once each clip is done
                _terminate_workers(cluster)
                raise
        return
    _handshake(distributed, address)
    held = _HeldInterrupts().hold()
    try:
        client = distributed.Client(address, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError) as error:
        held.release()
        raise UsageError(
            f"--scheduler {address}: no Dask scheduler answers there within "
            f"{CONNECT_TIMEOUT_S:g} s ({_first_cause(error)})"
        ) from None
    except Exception as error:  # a Dask worker's address: it answers, but no scheduler
        held.release()
        raise UsageError(
            f"--scheduler {address}: what answers there is no Dask scheduler (a worker's "
            f"address? {_first_cause(error)})"
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
    its ``allowed-failures``, 3 by default; a lost worker is restarted by its nanny); after
    that its clip fails with the reason instead of stopping the run or going missing. A
    cluster left without any worker (:data:`WORKERLESS_S` for a local one,
    :data:`REMOTE_WORKERLESS_S` for a scheduler elsewhere, which may be scaling up) ends
    the run with a :class:`ClusterLost` naming the clips not done. An interrupt cancels the
    tasks not yet done.
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
    patience = WORKERLESS_S if client.cluster is not None else REMOTE_WORKERLESS_S
    return _collect(distributed, client, futures, jobs, _Watch(client, futures, patience))


class ClusterLost(MotionError):
    """The cluster had no worker for too long; ``not_done`` are the indices of the jobs not
    done, which the message names."""

    def __init__(self, message: str, not_done: Sequence[int]) -> None:
        super().__init__(message)
        self.not_done = list(not_done)


class _Watch:
    """Checks every :data:`WATCH_S` that the cluster has a worker; after ``patience``
    seconds without one it cancels the tasks not done, which ends the run's wait."""

    def __init__(self, client, futures: dict, patience: float) -> None:
        self.client, self.futures, self.patience = client, futures, patience
        self.lost = False
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True, name="motionclean-watch")

    def _run(self) -> None:
        seen = time.monotonic()
        while not self.stop.wait(WATCH_S):
            try:
                workers = len(self.client.nthreads())
            except Exception:  # the scheduler itself gone: no worker either
                workers = 0
            if workers:
                seen = time.monotonic()
            elif time.monotonic() - seen >= self.patience:
                self.lost = True
                self.client.cancel([f for f in self.futures.values() if not f.done()])
                return

    def lost_message(self, not_done: Sequence[Job]) -> str:
        names = ", ".join(job.source for job in not_done[:5])
        more = f" and {len(not_done) - 5} more" if len(not_done) > 5 else ""
        plural = "s" if len(not_done) != 1 else ""
        return (
            f"the Dask cluster has had no worker for {self.patience:g} s (lost: killed, out "
            f"of memory, or never started); {len(not_done)} clip{plural} not done: "
            f"{names}{more}"
        )


def _task_failure(job: Job, error: BaseException) -> FileResult:
    if type(error).__name__ == "KilledWorker":  # the scheduler gave up on it
        reason = (
            f"{job.source}: every Dask worker that ran it died (killed or out of memory; "
            "the scheduler's allowed-failures reached)"
        )
    else:
        reason = f"{job.source}: the Dask task failed ({type(error).__name__}: {error})"
    return FileResult(job.source, job.target, "failed", error=reason)


def _collect(
    distributed, client, futures: dict, jobs: Sequence[Job], watch: _Watch
) -> Iterator[tuple[int, FileResult]]:
    index = {future.key: k for k, future in futures.items()}
    not_done: list[int] = []
    watch.thread.start()
    try:
        for future in distributed.as_completed(list(futures.values())):
            k = index[future.key]
            if watch.lost and future.cancelled():
                not_done.append(k)
                continue
            try:
                result = future.result()
            except Exception as error:  # a worker lost too often, a task cancelled
                result = _task_failure(jobs[k], error)
            yield k, result
    finally:
        watch.stop.set()
        client.cancel([f for f in futures.values() if not f.done()])
    if not_done:
        not_done.sort()
        raise ClusterLost(watch.lost_message([jobs[k] for k in not_done]), not_done)
