"""Faults on the Dask path with real sockets and a real LocalCluster: an address that takes
the connection and never answers, one that answers in another protocol, malformed
addresses, workers that keep dying, Ctrl-C. Each ends in one line, never a hang."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from helpers import SAMPLE, answering_server, cut_bvh, run_cli, silent_server

from motionclean.run import cluster

pytest.importorskip("distributed", reason="the dask extra is not installed")


@pytest.fixture(scope="module")
def clips(tmp_path_factory):
    root = tmp_path_factory.mktemp("faults")
    for k in range(2):
        cut_bvh(SAMPLE, root / "in" / f"c{k}.bvh", 30)
    return root


@pytest.fixture
def quick_timeout(monkeypatch):
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 0.5)


@pytest.fixture
def silent_port():
    with silent_server() as port:
        yield port


@pytest.fixture
def http_port():
    with answering_server(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n") as port:
        yield port


def batch_on(capsys, clips, scheduler: str) -> tuple[int, str]:
    """A batch on ``scheduler`` that fails: nothing printed, no folder made (OUT_DIR and
    the report folder had been, left empty, whatever the scheduler said)."""
    code, out, err = run_cli(
        capsys,
        "batch",
        clips / "in",
        "-o",
        clips / "out",
        "--report-dir",
        clips / "pages",
        "--scheduler",
        scheduler,
        "-q",
    )
    assert out == "" and sorted(p.name for p in clips.iterdir()) == ["in"]
    return code, err


def one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("motionclean: error: "), err
    return lines[0]


def test_an_address_that_accepts_and_never_answers_is_named_within_the_timeout(
    clips, capsys, quick_timeout, silent_port
):
    start = time.monotonic()
    code, err = batch_on(capsys, clips, f"tcp://127.0.0.1:{silent_port}")
    seconds = time.monotonic() - start
    assert code == 2 and seconds < 10  # (1.5 x 0.5 s, and never forever)
    line = one_error_line(err)
    assert f"--scheduler tcp://127.0.0.1:{silent_port}: accepted the connection but sent " in line
    assert "no Dask handshake within 0.75 s" in line  # (1.5 times the connect timeout)


def test_an_http_answer_is_no_scheduler_and_no_memory_error(
    clips, capsys, quick_timeout, http_port
):
    code, err = batch_on(capsys, clips, f"tcp://127.0.0.1:{http_port}")
    assert code == 2
    line = one_error_line(err)
    assert f"tcp://127.0.0.1:{http_port}: something answers there, but not a Dask" in line


@pytest.mark.parametrize(
    ("address", "message"),
    [
        ("notaport", "expected a scheduler address such as tcp://HOST:8786"),
        ("tls://", "needs a port from 1 to 65535"),
        ("inproc://", "exists only inside one Python process"),
        ("inproc://192.0.2.2/1/1", "exists only inside one Python process"),
        ("tcp://127.0.0.1:notaport", "needs a port from 1 to 65535"),
        ("tcp://127.0.0.1", "needs a port from 1 to 65535"),
        ("tcp://127.0.0.1:8786/path", "needs a port from 1 to 65535"),
        ("tcp://127.0.0.1:0", "needs a port from 1 to 65535"),
        ("tcp://" + "h" * 300 + ":8786", "is no host name or IP address"),
        ("tcp://" + "a." * 130 + "b:8786", "is no host name or IP address"),
        ("tcp://[::1:8786", "is no host name or IP address"),
        ("tcp://[1::2::3]:8786", "is no host name or IP address"),
        ("tcp://h h:8786", "is no host name or IP address"),
    ],
)
def test_malformed_addresses_are_usage_lines_before_any_connection(clips, capsys, address, message):
    code, err = batch_on(capsys, clips, address)
    assert code == 2 and message in one_error_line(err) and "internal error" not in err


def test_a_tls_address_without_certificates_says_what_it_needs(
    clips, capsys, quick_timeout, http_port
):
    code, err = batch_on(capsys, clips, f"tls://127.0.0.1:{http_port}")
    assert code == 2 and "certificates in the Dask configuration" in one_error_line(err)


def spawned_workers() -> list[int]:
    """Dask worker processes this test process started (multiprocessing's spawn children,
    not its resource tracker)."""
    children = subprocess.run(
        ["pgrep", "-P", str(os.getpid())], capture_output=True, text=True, check=False
    ).stdout.split()
    pids = []
    for pid in map(int, children):
        with contextlib.suppress(OSError):
            if b"spawn_main" in Path(f"/proc/{pid}/cmdline").read_bytes():
                pids.append(pid)
    return pids


@contextlib.contextmanager
def killing_workers(every: float, monkeypatch):
    """Once the batch's cluster is up and its clips handed out, SIGKILL every Dask worker
    process every ``every`` seconds until the block ends."""
    handed_out = threading.Event()
    real = cluster.run_jobs_on

    def run_jobs_on(client, jobs):
        results = real(client, jobs)
        handed_out.set()
        return results

    monkeypatch.setattr(cluster, "run_jobs_on", run_jobs_on)
    done = threading.Event()
    kills = []

    def kill() -> None:
        while not handed_out.wait(0.05):
            if done.is_set():
                return
        while not done.wait(every):
            for pid in spawned_workers():
                with contextlib.suppress(OSError):
                    os.kill(pid, signal.SIGKILL)
                    kills.append(pid)

    thread = threading.Thread(target=kill, daemon=True)
    thread.start()
    try:
        yield kills
    finally:
        done.set()
        thread.join()


@pytest.mark.slow
def test_workers_killed_again_and_again_end_the_batch_naming_the_clips_not_done(
    tmp_path, capsys, monkeypatch
):
    """Dask restarts a killed worker; one killed while it starts stays gone. With none left
    the batch used to wait for good (and left a .tmp): now one line names what is not done.
    (The scheduler retries a task on workers that die far more often than its default 3
    times here, so no clip fails for that first: which came first was a race.)"""
    import dask

    monkeypatch.setattr(cluster, "WORKERLESS_S", 1.0)
    monkeypatch.setattr(cluster, "WATCH_S", 0.1)
    for k in range(3):
        cut_bvh(SAMPLE, tmp_path / "in" / f"c{k}.bvh", 300)
    slow = "fairing:max_iterations=3000,tol=0"
    start = time.monotonic()
    retried = dask.config.set({"distributed.scheduler.allowed-failures": 1000})
    with retried, killing_workers(0.3, monkeypatch) as kills:
        code, _, err = run_cli(
            capsys,
            "batch",
            tmp_path / "in",
            "-o",
            tmp_path / "out",
            "-f",
            slow,
            "--scheduler",
            "local:2",
            "-q",
        )
    assert time.monotonic() - start < 60 and kills
    assert code == 1
    lines = err.strip().splitlines()
    assert all(line.startswith("motionclean: error: ") for line in lines), err
    assert "the Dask cluster has had no worker for 1 s" in lines[-1]
    not_done = lines[-1].split("not done: ")[1].split(", ")
    assert len(lines) - 1 + len(not_done) == 3  # every clip named once: failed or not done
    assert not [p for p in tmp_path.rglob("*") if p.is_file() and p.parent.name == "out"]


def descendants(pid: int) -> list[int]:
    children = subprocess.run(
        ["pgrep", "-P", str(pid)], capture_output=True, text=True, check=False
    ).stdout.split()
    return [int(c) for c in children] + [g for c in children for g in descendants(int(c))]


def running(pids: list[int]) -> list[int]:
    alive = []
    for pid in pids:
        with contextlib.suppress(OSError, IndexError):
            if Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] not in "ZX":
                alive.append(pid)
    return alive


def _in_the_foreground() -> None:
    """Ctrl-C taken as a terminal's foreground job takes it: a test run started in the
    background of a script (``make test &``) ignores SIGINT, and its children inherit
    that (the batch had run to its end, exit 0, or past the 30 s of :func:`finish`)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def batch_under_way(tmp_path) -> tuple[subprocess.Popen, list[int]]:
    """``batch --scheduler local:1`` in a session of its own (as a shell runs a job), once
    its worker and the resource tracker run and its first clip is written (the cluster
    up: on a loaded machine a second after its processes appeared had been within its
    start)."""
    for k in range(6):
        cut_bvh(SAMPLE, tmp_path / "in" / f"c{k}.bvh", 150)
    command = [str(Path(sys.executable).parent / "motionclean"), "batch", str(tmp_path / "in")]
    process = subprocess.Popen(
        [*command, "-o", str(tmp_path / "o"), "--scheduler", "local:1", "-q"]
        + ["-f", "fairing:max_iterations=3000,tol=0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
        preexec_fn=_in_the_foreground,
    )
    deadline = time.monotonic() + 60
    written = tmp_path / "o"
    while time.monotonic() < deadline and not (
        len(descendants(process.pid)) >= 2 and any(written.glob("*.bvh"))
    ):
        time.sleep(0.1)
    return process, descendants(process.pid)


def finish(process: subprocess.Popen) -> str:
    """stderr once every process holding it has closed it (workers, tracker)."""
    try:
        _, err = process.communicate(timeout=30)
    finally:
        with contextlib.suppress(OSError):
            os.killpg(process.pid, signal.SIGKILL)
    return err.decode()


@pytest.mark.slow
def test_ctrl_c_to_the_whole_process_group_is_one_line(tmp_path):
    """A terminal sends Ctrl-C to every process of the job: the workers printed 68 lines of
    tracebacks, click an empty line. Now only the parent takes it."""
    process, workers = batch_under_way(tmp_path)
    os.killpg(process.pid, signal.SIGINT)
    err = finish(process)
    assert process.returncode == 130 and err == "motionclean: error: interrupted\n"
    deadline = time.monotonic() + 5
    while running(workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert len(workers) >= 2 and not running(workers)
    assert not [p for p in (tmp_path / "o").rglob("*.tmp")]


@pytest.mark.slow
def test_sigkill_of_the_parent_leaves_no_warning_and_no_worker(tmp_path):
    """The resource tracker warned about leaked semaphores on the caller's terminal."""
    process, workers = batch_under_way(tmp_path)
    process.kill()
    err = finish(process)
    assert process.returncode == -signal.SIGKILL and err == ""
    deadline = time.monotonic() + 5  # (the resource tracker cleans up after it lets go)
    while running(workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not running(workers)


def test_a_real_scheduler_passes_the_handshake_and_cleans_as_one_process(
    tmp_path, capsys, dask_scheduler
):
    """The handshake check lets a real scheduler through: the clips are those of -j 1."""
    for k in range(2):
        cut_bvh(SAMPLE, tmp_path / "in" / f"c{k}.bvh", 40)
    code, out, err = run_cli(
        capsys, "batch", tmp_path / "in", "-o", tmp_path / "dask", "--scheduler", dask_scheduler
    )
    assert (code, err) == (0, "") and "2 cleaned" in out and "Dask dashboard" in out
    run_cli(capsys, "batch", tmp_path / "in", "-o", tmp_path / "one", "-j", "1", "-q")
    for k in range(2):
        name = f"c{k}.bvh"
        assert (tmp_path / "dask" / name).read_bytes() == (tmp_path / "one" / name).read_bytes()


def test_a_dask_workers_address_is_no_scheduler(clips, capsys, dask_scheduler):
    """A worker speaks Dask's protocol but is no scheduler: the client's first call had
    escaped as an internal error (TypeError: Worker.identity() got an unexpected keyword
    argument); it is one line naming the address, exit 2."""
    from distributed import Client

    with Client(dask_scheduler, timeout=10) as client:
        worker = next(iter(client.scheduler_info()["workers"]))
    code, err = batch_on(capsys, clips, worker)
    line = one_error_line(err)
    assert code == 2 and f"--scheduler {worker}: what answers there is no Dask scheduler" in line
