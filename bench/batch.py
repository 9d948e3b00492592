"""Batch throughput: `motionclean batch` wall time with --jobs N against --jobs 1.

    python bench/batch.py [--copies 10] [--repeats 3] [--jobs 2]

Copies the corpus clips (/work/shared/corpus/cmu, or $MOTIONCLEAN_CORPUS) COPIES times into a
temporary folder tree (3 x 10 = 30 clips by default) and times the batch command on it, end
to end in a fresh process (start-up and imports included), with the default pipeline,
alternating --jobs 1 and --jobs N, REPEATS times each. Two environments are measured: as
the shell gives it, and with BLAS limited to one thread (OPENBLAS_NUM_THREADS=1 etc. set
before numpy is imported, which also lets batch fork its workers directly).

Other processes take cores away from a parallel run: before each run the script waits
(up to 30 s) until the machine has been at least 90 % idle for half a second, and prints
the idle share it saw (from /proc/stat).
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CORPUS = Path(os.environ.get("MOTIONCLEAN_CORPUS", ROOT.parent / "shared" / "corpus" / "cmu"))
ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
COMMAND = ("import sys, time\nfrom motionclean.batch import batch_command\n"
           "t = time.perf_counter()\ntry:\n"
           "    batch_command.main(sys.argv[1:], standalone_mode=False)\n"
           "finally:\n    print(f'{time.perf_counter() - t:.6f}', file=sys.stderr)")


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
            frames += int(text[text.index("Frames:") + 7:].split()[0])
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


def run(in_dir: Path, out_dir: Path, jobs: int, env: dict[str, str]) -> tuple[float, float]:
    """End-to-end wall time of one fresh `batch` process, and the time inside the command
    (without interpreter start-up and imports)."""
    shutil.rmtree(out_dir, ignore_errors=True)
    environment = dict(os.environ, PYTHONPATH=str(ROOT), **env)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", COMMAND, str(in_dir), "-o", str(out_dir),
                           "-j", str(jobs), "-q"], env=environment, check=True,
                          stderr=subprocess.PIPE, text=True)
    return time.perf_counter() - start, float(done.stderr.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--copies", type=int, default=10)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    variants = {"as given": {k: v for k, v in os.environ.items() if k in ONE_THREAD},
                "one BLAS thread": ONE_THREAD}
    rows = []
    with tempfile.TemporaryDirectory(prefix="motionclean-bench-") as tmp:
        in_dir, out_dir = Path(tmp) / "in", Path(tmp) / "out"
        clips, frames = make_tree(in_dir, args.copies)
        print(f"{clips} clips, {frames:,} frames, {os.cpu_count()} cores")
        run(in_dir, out_dir, 1, {})  # warm the file cache
        for name, env in variants.items():
            times: dict[int, list[tuple[float, float]]] = {1: [], args.jobs: []}
            for _ in range(args.repeats):
                for jobs in times:
                    idle = wait_quiet()
                    times[jobs].append(run(in_dir, out_dir, jobs, env))
                    seen = "" if idle is None else f" (machine {idle:.0%} idle before)"
                    total, inside = times[jobs][-1]
                    print(f"  {name}, --jobs {jobs}: {total:.2f} s, {inside:.2f} s in the "
                          f"command{seen}")
            rows.append((name, times))
    print("\nwall time of a fresh process (and of the command itself, without start-up)")
    print(f"{'environment':<18}{'jobs':>5}{'best s':>14}{'median s':>16}{'clips/s':>9}"
          f"{'speed-up best':>16}{'median':>14}")
    for name, times in rows:
        for jobs, values in times.items():
            cells = []
            for pick in (min, statistics.median):
                whole = pick(v[0] for v in values)
                inner = pick(v[1] for v in values)
                cells.append((whole, inner))
            ref = [(min(v[0] for v in times[1]), min(v[1] for v in times[1])),
                   (statistics.median(v[0] for v in times[1]),
                    statistics.median(v[1] for v in times[1]))]
            (bw, bi), (mw, mi) = cells
            print(f"{name:<18}{jobs:>5}{bw:>7.2f} ({bi:.2f}){mw:>9.2f} ({mi:.2f})"
                  f"{clips / bw:>9.1f}"
                  f"{ref[0][0] / bw:>8.2f}x ({ref[0][1] / bi:.2f}x)"
                  f"{ref[1][0] / mw:>6.2f}x ({ref[1][1] / mi:.2f}x)")


if __name__ == "__main__":
    main()
