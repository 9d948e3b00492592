"""batch on a real Dask LocalCluster of two worker processes: the same files as --jobs 1,
failures named, clear errors for a bad or unreachable scheduler."""

from __future__ import annotations

import contextlib
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from helpers import NOISY, SAMPLE, cut_bvh, run_cli

import motionclean as mc
from motionclean.run import cluster
from motionclean.run.jobs import Job, run_job
from motionclean.steps.pipeline import Pipeline

pytest.importorskip("distributed", reason="the dask extra is not installed")


@pytest.fixture(scope="module")
def tree(tmp_path_factory):
    root = tmp_path_factory.mktemp("clips")
    for k in range(4):
        cut_bvh(NOISY, root / "in" / f"take{k}.bvh", 60 + 20 * k)
    (root / "in" / "broken.bvh").write_text("HIERARCHY\nROOT Hips\n{\n")
    return root


@pytest.mark.slow
def test_a_local_cluster_writes_what_one_process_writes(tree, capsys):
    code, out, err = run_cli(
        capsys, "batch", tree / "in", "-o", tree / "dask", "--scheduler", "local:2"
    )
    assert code == 1 and "broken.bvh" in err and err.count("motionclean: error:") == 1
    assert "on 2 workers" in out and "4 cleaned" in out
    # four clips of 60-120 frames: the cluster's start-up usually costs more than it gains,
    # and the run says so, with each worker's share (not the sum); on a loaded machine the
    # cleaning may take longer than the start-up (the wording: test_cluster_note_...)
    if "note: starting the local Dask cluster took" in out:
        spent = re.search(
            r"longer than the ([\d.]+) s each of its 2 workers spent cleaning \(([\d.]+) s", out
        )
        assert spent and abs(2 * float(spent[1]) - float(spent[2])) <= 0.11, out
    run_cli(capsys, "batch", tree / "in", "-o", tree / "serial", "-j", "1", "-q")
    code, out, _ = run_cli(
        capsys,
        "batch",
        tree / "in",
        "-o",
        tree / "dask",
        "--scheduler",
        "local:2",
        "--skip-existing",
        "--glob",
        "take*.bvh",
    )
    assert code == 0 and "4 skipped" in out and "Dask dashboard" not in out  # no cluster
    for k in range(4):
        name = f"take{k}.bvh"
        assert (tree / "dask" / name).read_bytes() == (tree / "serial" / name).read_bytes()


@pytest.mark.slow
def test_an_unreachable_scheduler_is_one_line_within_seconds(tree, capsys, monkeypatch):
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 0.5)  # the same path, sooner
    start = time.perf_counter()
    code, _, err = run_cli(
        capsys, "batch", tree / "in", "-o", tree / "x", "--scheduler", "tcp://127.0.0.1:9"
    )
    assert time.perf_counter() - start < 15
    assert code == 2 and "no Dask scheduler answers there" in err and "tcp://127.0.0.1:9" in err
    assert err.count("\n") == 1 and not (tree / "x").exists()  # (it had been made, empty)


@pytest.mark.parametrize(
    ("value", "message"),
    [("somewhere", "expected a scheduler address"), ("local:0", "at least one worker")],
)
def test_bad_scheduler_values_are_usage_errors(tree, capsys, value, message):
    code, _, err = run_cli(capsys, "batch", tree / "in", "-o", tree / "y", "--scheduler", value)
    assert code == 2 and message in err
    code, _, err = run_cli(
        capsys, "batch", tree / "in", "-o", tree / "y", "--scheduler", "local", "-j", "2"
    )
    assert code == 2 and "either --jobs" in err


@pytest.mark.slow
def test_the_clips_of_a_lost_worker_are_run_again_and_none_go_missing(tmp_path):
    from distributed import Client, LocalCluster

    steps = tuple(Pipeline.from_inline(["fairing:max_iterations=400,tol=0"]).describe())
    jobs = []
    for k in range(4):
        source = cut_bvh(SAMPLE, tmp_path / "in" / f"c{k}.bvh", 120)
        jobs.append(Job(str(source), str(tmp_path / "out" / f"c{k}.bvh"), steps, None))
    with (
        LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=":0") as local,
        Client(local) as client,
    ):
        results = cluster.run_jobs_on(client, jobs)
        while not any(client.processing().values()):
            time.sleep(0.05)
        busy = next(address for address, keys in client.processing().items() if keys)
        os.kill(client.run(os.getpid, workers=[busy])[busy], signal.SIGKILL)
        done = dict(results)
    assert sorted(done) == [0, 1, 2, 3]
    assert all(result.status == "ok" for result in done.values())
    expected = tmp_path / "serial.bvh"  # (the four clips are one clip's copies: one run)
    run_job(Job(jobs[0].source, str(expected), steps, None))
    for job in jobs:
        assert Path(job.target).read_bytes() == expected.read_bytes()


def descendants(pid: int) -> list[str]:
    children = subprocess.run(
        ["pgrep", "-P", str(pid)], capture_output=True, text=True, check=False
    ).stdout.split()
    return children + [grandchild for child in children for grandchild in descendants(int(child))]


def alive(pids: list[str]) -> list[str]:
    """Command lines of the processes of ``pids`` still running (one may exit while read)."""
    lines = []
    for pid in pids:
        with contextlib.suppress(FileNotFoundError, ProcessLookupError):
            lines.append(Path(f"/proc/{pid}/cmdline").read_text())
    return lines


@pytest.mark.slow
def test_sigterm_cancels_the_cluster_run_and_its_workers_exit(tmp_path):
    for k in range(8):
        cut_bvh(SAMPLE, tmp_path / "in" / f"c{k}.bvh", 300)
    command = [str(Path(sys.executable).parent / "motionclean"), "batch", str(tmp_path / "in")]
    process = subprocess.Popen(
        [
            *command,
            *("-o", str(tmp_path / "o"), "--scheduler", "local:2"),
            *("-f", "fairing:max_iterations=3000,tol=0"),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
    )
    deadline = time.monotonic() + 30
    while len(descendants(process.pid)) < 3 and time.monotonic() < deadline:
        time.sleep(0.2)  # two worker processes and multiprocessing's resource tracker
    time.sleep(1.0)
    workers = descendants(process.pid)
    process.send_signal(signal.SIGTERM)
    try:
        _, err = process.communicate(timeout=30)
    finally:
        process.kill()
    assert process.returncode == 130 and err.decode().strip() == "motionclean: error: interrupted"
    deadline = time.monotonic() + 5
    while alive(workers) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert len(workers) >= 3 and not alive(workers)
    assert len(list((tmp_path / "o").rglob("*.bvh"))) < 8


def test_without_dask_the_error_names_the_extra(tmp_path):
    cut_bvh(SAMPLE, tmp_path / "in" / "a.bvh", 20)
    hide = "import sys; sys.modules['distributed'] = None; from motionclean.cli import main; main()"
    done = subprocess.run(
        [sys.executable, "-c", hide, "batch", str(tmp_path / "in"), "-o", str(tmp_path / "o")]
        + ["--scheduler", "local:2"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 2 and "pip install 'motionclean[dask]'" in done.stderr
    assert done.stderr.count("\n") == 1 and not (tmp_path / "o" / "a.bvh").exists()


@pytest.mark.slow
def test_a_local_cluster_has_no_more_workers_than_clips(tmp_path, capsys):
    cut_bvh(NOISY, tmp_path / "in" / "one.bvh", 60)
    code, out, _ = run_cli(
        capsys, "batch", tmp_path / "in", "-o", tmp_path / "out", "--scheduler", "local:99999"
    )
    assert code == 0 and "on 1 worker " in out and (tmp_path / "out" / "one.bvh").exists()


def test_relative_paths_reach_a_worker_in_another_folder_as_the_clients(
    tmp_path, capsys, monkeypatch, dask_scheduler
):
    """Relative paths were resolved in the worker's folder: a worker started elsewhere read
    the clip of the same relative name there and wrote the outputs there (exit 0, the
    client's -o left empty). Every path a task carries is now absolute, from the client's
    folder; here the process, whose worker runs the tasks, moves to another folder holding
    clips of the same names once the jobs are made."""
    client, elsewhere = tmp_path / "client", tmp_path / "worker"
    for folder, frames in ((client, 40), (elsewhere, 20)):
        rig = cut_bvh(SAMPLE, folder / "rig.bvh", frames)
        cut_bvh(SAMPLE, folder / "in" / "a.bvh", frames)
        assert run_cli(capsys, "convert", rig, folder / "in" / "c.csv")[0] == 0
    sent = []
    real = cluster.run_jobs_on

    def run_jobs_on(client_, jobs):
        sent.extend(jobs)
        os.chdir(elsewhere)  # the worker's folder from now on
        try:
            yield from real(client_, jobs)
        finally:
            os.chdir(client)

    monkeypatch.setattr(cluster, "run_jobs_on", run_jobs_on)
    monkeypatch.chdir(client)
    code, out, err = run_cli(
        capsys,
        "batch",
        "in",
        "-o",
        "out",
        "--report-dir",
        "pages",
        "--skeleton",
        "rig.bvh",
        "--scheduler",
        dask_scheduler,
        "-q",
    )
    assert (code, out, err) == (0, "", "")
    for name in ("a.bvh", "c.csv"):
        assert mc.load(client / "out" / name, skeleton=client / "rig.bvh").n_frames == 40
        assert (client / "pages" / f"{name}.html").is_file()
    assert sorted(p.name for p in elsewhere.iterdir()) == ["in", "rig.bvh"]
    paths = [(j.source, j.target, j.report, j.read.skeleton) for j in sent]
    assert len(paths) == 2 and all(Path(p).is_absolute() for row in paths for p in row)
