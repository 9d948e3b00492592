"""Batch throughput: `motionclean batch` wall time with --jobs N against --jobs 1.

    python bench/batch.py [--copies 10] [--repeats 3] [--jobs 2]

Copies the corpus clips (/work/shared/corpus/cmu, or $MOTIONCLEAN_CORPUS) COPIES times into a
temporary folder tree (3 x 10 = 30 clips by default) and times the batch command on it, end
to end in a fresh process (start-up and imports included), with the default pipeline,
alternating --jobs 1 and --jobs N, REPEATS times each. Last, the same pure numpy work is
run in one process and in N: the speed-up this machine's cores allow at all.

Other processes take cores away from a parallel run: before each run the script waits
(up to 30 s) until the machine has been at least 90 % idle for half a second, and prints
the idle share it saw (from /proc/stat).
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CORPUS = Path(os.environ.get("MOTIONCLEAN_CORPUS", ROOT.parent / "shared" / "corpus" / "cmu"))
COMMAND = (
    "import sys, time\nfrom motionclean.cli.batch import batch_command\n"
    "t = time.perf_counter()\ntry:\n"
    "    batch_command.main(sys.argv[1:], standalone_mode=False)\n"
    "finally:\n    print(f'{time.perf_counter() - t:.6f}', file=sys.stderr)"
)


def make_tree(folder: Path, copies: int) -> tuple[int, int]:
    """``copies`` copies of each corpus clip in sub-folders; returns (clips, frames)."""
    sources = sorted(CORPUS.glob("*.bvh"))
    if not sources:
        sys.exit(f"no corpus clips in {CORPUS}")
    frames = 0
    for k in range(copies):
        for source in sources:
            target = folder / f"take{k // 5}" / f"copy{k}" / source.name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, target)
            text = source.read_text()
            frames += int(text[text.index("Frames:") + 7 :].split()[0])
    return copies * len(sources), frames


def idle_share(seconds: float = 0.5) -> float | None:
    """Share of the machine's CPU time that was idle over ``seconds`` (Linux)."""

    def sample() -> list[int]:
        return [int(v) for v in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:9]]

    try:
        a = sample()
        time.sleep(seconds)
        b = sample()
    except OSError:
        return None
    d = [y - x for x, y in zip(a, b, strict=True)]
    return (d[3] + d[4]) / max(sum(d), 1)


def wait_quiet(limit: float = 30.0) -> float | None:
    end = time.monotonic() + limit
    while True:
        idle = idle_share()
        if idle is None or idle >= 0.9 or time.monotonic() > end:
            return idle


def run(in_dir: Path, out_dir: Path, jobs: int | str) -> tuple[float, float]:
    """End-to-end wall time of one fresh `batch` process, and the time inside the command
    (without interpreter start-up and imports); ``jobs`` a number of local processes or a
    Dask scheduler address."""
    shutil.rmtree(out_dir, ignore_errors=True)
    environment = dict(os.environ, PYTHONPATH=str(ROOT))
    where = ["--scheduler", jobs] if isinstance(jobs, str) else ["-j", str(jobs)]
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", COMMAND, str(in_dir), "-o", str(out_dir), *where, "-q"],
        env=environment,
        check=True,
        stderr=subprocess.PIPE,
        text=True,
    )
    return time.perf_counter() - start, float(done.stderr.strip().splitlines()[-1])


def _numpy_work(_: int) -> float:
    """A fixed numpy workload (transcendentals on a clip-sized array), seconds."""
    a = np.random.default_rng(0).normal(size=(1000, 31, 4))
    start = time.perf_counter()
    for _ in range(1500):
        np.tan(a)
    return time.perf_counter() - start


def machine_ceiling(jobs: int) -> float:
    """Speed-up of the same pure numpy work in ``jobs`` processes against one: what this
    machine's cores give, whatever the program."""
    wait_quiet()
    start = time.perf_counter()
    for i in range(2 * jobs):
        _numpy_work(i)
    serial = time.perf_counter() - start
    with multiprocessing.get_context("fork").Pool(jobs) as pool:
        pool.map(_numpy_work, range(jobs))  # start the workers
        start = time.perf_counter()
        pool.map(_numpy_work, range(2 * jobs))
        parallel = time.perf_counter() - start
    return serial / parallel


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--copies", type=int, default=10)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    times: dict[int, list[tuple[float, float]]] = {1: [], args.jobs: []}
    with tempfile.TemporaryDirectory(prefix="motionclean-bench-") as tmp:
        in_dir, out_dir = Path(tmp) / "in", Path(tmp) / "out"
        clips, frames = make_tree(in_dir, args.copies)
        print(f"{clips} clips, {frames:,} frames, {os.cpu_count()} cores")
        run(in_dir, out_dir, 1)  # warm the file cache
        for _ in range(args.repeats):
            for jobs in times:
                idle = wait_quiet()
                times[jobs].append(run(in_dir, out_dir, jobs))
                seen = "" if idle is None else f" (machine {idle:.0%} idle before)"
                total, inside = times[jobs][-1]
                print(f"  --jobs {jobs}: {total:.2f} s, {inside:.2f} s in the command{seen}")
    print("\nwall time of a fresh process (and of the command itself, without start-up)\n")
    print("| jobs | best s | median s | clips/s | speed-up, best | speed-up, median |")
    print("|---:|---:|---:|---:|---:|---:|")
    ref = [
        (min(v[0] for v in times[1]), min(v[1] for v in times[1])),
        (statistics.median(v[0] for v in times[1]), statistics.median(v[1] for v in times[1])),
    ]
    for jobs, values in times.items():
        (bw, bi), (mw, mi) = [
            (pick(v[0] for v in values), pick(v[1] for v in values))
            for pick in (min, statistics.median)
        ]
        print(
            f"| {jobs} | {bw:.2f} ({bi:.2f}) | {mw:.2f} ({mi:.2f}) | {clips / bw:.1f} "
            f"| {ref[0][0] / bw:.2f}x ({ref[0][1] / bi:.2f}x) "
            f"| {ref[1][0] / mw:.2f}x ({ref[1][1] / mi:.2f}x) |"
        )
    print(
        f"\nmachine ceiling: the same pure numpy work in {args.jobs} processes runs "
        f"{machine_ceiling(args.jobs):.2f}x faster than in one"
    )
    with tempfile.TemporaryDirectory(prefix="motionclean-bench-") as tmp:
        in_dir, out_dir = Path(tmp) / "in", Path(tmp) / "out"
        make_tree(in_dir, args.copies)
        dask_figures(in_dir, out_dir, args.jobs, args.repeats)


def _nothing(x: int) -> int:
    return x


def dask_figures(in_dir: Path, out_dir: Path, jobs: int, repeats: int) -> None:
    """The same batch on a running Dask cluster of ``jobs`` worker processes (started once,
    like a real cluster) against --jobs ``jobs``, and the cost of one task."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        print("\ndask not installed (pip install motionclean[dask]): cluster figures skipped")
        return
    with (
        LocalCluster(
            n_workers=jobs, threads_per_worker=1, dashboard_address=":0", silence_logs=50
        ) as cluster,
        Client(cluster) as client,
    ):
        pool, dask = [], []
        for _ in range(repeats):
            wait_quiet()
            pool.append(run(in_dir, out_dir, jobs))
            wait_quiet()
            dask.append(run(in_dir, out_dir, cluster.scheduler_address))
        tasks = 2000
        client.gather(client.map(_nothing, range(100), pure=False))  # warm up
        start = time.perf_counter()
        client.gather(client.map(_nothing, range(tasks), pure=False))
        per_task = (time.perf_counter() - start) / tasks
    print(f"\nDask cluster of {jobs} worker processes against --jobs {jobs} (same clips):")
    for what, k in (("process", 0), ("command, without start-up", 1)):
        best_pool, best_dask = min(t[k] for t in pool), min(t[k] for t in dask)
        print(
            f"  {what}: --jobs {jobs} best {best_pool:.2f} s, --scheduler best {best_dask:.2f} s,"
            f" ratio {best_dask / best_pool:.2f} (target <= 1.25)"
        )
    print(f"  overhead of one task on this cluster: {per_task * 1e3:.2f} ms")


if __name__ == "__main__":
    main()
