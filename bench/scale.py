"""Long clips: read + write, clean and memory from 1k to 100k frames, against peers.

Run ``python bench/scale.py [--frames 1000 10000 100000] [--rounds 5]``. The clips are the
corpus clip 131_02 (31 joints, 1,247 frames) cut or played back and forth to each length,
every value's text kept. For each length it measures, in this process, in interleaved
rounds (ours, then the peer, then ours again in the next round: load on a shared machine
falls on both alike):

- read + write with every rotation changed (motionclean ``load`` + ``save``; the change
  itself, one quaternion product, is not timed: pybvh changes nothing) against pybvh
  (``read_bvh_file`` + ``write_bvh_file``): the ratio pybvh / motionclean (above 1: faster);
- the default ``clean`` with an HTML report (the CLI, in process) against ``np.loadtxt`` of
  the same MOTION block (the floor of any text reader): the ratio clean / loadtxt;
- peak resident memory of a fresh process running that ``clean``, over the file size;
- the terminal output of that ``clean``: lines and the longest line.

Each ratio is the median of the rounds' ratios, with their spread (lowest-highest); times
are medians. Short clips are timed several times a round (the best of them counts), so
each round's figure is not the timer's noise. The load average is printed before and after.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import subprocess
import sys
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
from common import corpus_clips, elapsed

import motionclean as mc
from motionclean.cli.main import main as cli_main
from motionclean.core import quat

# The child's own high-water mark (VmHWM, Linux): ru_maxrss would also count the resident
# memory of this benchmark process at the moment it started the child (kept across exec).
PEAK = """
import resource, sys, contextlib, io
from motionclean.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    try:
        main(sys.argv[1:])
    except SystemExit:
        pass
try:
    with open("/proc/self/status") as status:
        print(next(int(l.split()[1]) * 1024 for l in status if l.startswith("VmHWM:")))
except (OSError, StopIteration):
    print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024)
"""

#: Seconds of work a round gives each short measurement (timed that many times, best kept).
ROUND_SECONDS = 0.3


def build_clip(source: Path, frames: int, target: Path) -> Path:
    """``source`` cut or played back and forth to ``frames`` frames (rows copied as text):
    one continuous clip (repeated end to end, each repeat would start with a jump, a clip
    of takes joined end to end, cleaned take by take)."""
    raw = source.read_bytes()
    head, _, rest = raw.partition(b"MOTION")
    lines = rest.splitlines()
    at = next(i for i, line in enumerate(lines) if line.strip().startswith(b"Frame Time"))
    rows = [line for line in lines[at + 1 :] if line.strip()]
    period = max(2 * (len(rows) - 1), 1)
    body = [rows[min(i % period, period - i % period)] for i in range(frames)]
    eol = b"\r\n" if b"\r\n" in raw[:4096] else b"\n"
    text = eol.join([b"MOTION", b"Frames: %d" % frames, lines[at].strip(), *body]) + eol
    target.write_bytes(head + text)
    return target


def read_write_jobs(clip: Path, out: Path) -> tuple[Callable[[], float], Callable[[], float]]:
    """Timed read + write of motionclean (every rotation changed) and of pybvh."""
    import pybvh

    turn = quat.from_axis_angle(np.array([0.48, 0.6, 0.64]), np.deg2rad(0.5))

    def ours() -> float:
        motion: list[mc.Motion] = []
        read = elapsed(lambda: motion.append(mc.load(clip)))
        changed = motion[0].replace(rotations=quat.multiply(motion[0].rotations, turn))
        return read + elapsed(lambda: mc.save(changed, out / "mc.bvh"))

    def theirs() -> float:
        return elapsed(lambda: pybvh.write_bvh_file(pybvh.read_bvh_file(clip), out / "pybvh.bvh"))

    return ours, theirs


def motion_block(clip: Path) -> str:
    text = clip.read_text()
    at = text.index("Frame Time:")
    return text[text.index("\n", at) + 1 :]


def clean_job(clip: Path, out: Path, lines: list[str]) -> Callable[[], float]:
    """Timed default ``clean`` with an HTML report; its terminal lines go to ``lines``."""
    args = ["clean", str(clip), "-o", str(out / "clean.bvh"), "--report", str(out / "r.html")]

    def run() -> float:
        stdout = io.StringIO()

        def clean() -> None:
            with contextlib.redirect_stdout(stdout), contextlib.suppress(SystemExit):
                cli_main(args)

        seconds = elapsed(clean)
        lines[:] = stdout.getvalue().splitlines()
        return seconds

    return run


def peak_memory(clip: Path, out: Path) -> int:
    """Peak resident bytes of a fresh process running the default ``clean`` with HTML."""
    args = ["clean", str(clip), "-o", str(out / "peak.bvh"), "--report", str(out / "p.html")]
    done = subprocess.run(
        [sys.executable, "-c", PEAK, *args], capture_output=True, text=True, check=True
    )
    return int(done.stdout.split()[-1])


def interleaved(pairs: dict[str, tuple], rounds: int) -> dict[str, np.ndarray]:
    """``{name: (ours, peer)}`` of timed jobs run in ``rounds`` interleaved rounds (each job
    once a round, in turn, after a first run not kept); ``{"name/ours": times, "name/peer":
    times}``, one time per round. A job that takes under :data:`ROUND_SECONDS` is run that
    long a round and its best kept."""
    jobs = {
        f"{name}/{side}": job
        for name, pair in pairs.items()
        for side, job in zip(("ours", "peer"), pair, strict=True)
    }
    repeats = {}
    for key, job in jobs.items():  # warm up (allocator, caches) and size the repeats
        repeats[key] = max(1, int(ROUND_SECONDS / max(job(), 1e-6)))
    times: dict[str, list[float]] = {key: [] for key in jobs}
    for _ in range(rounds):
        for key, job in jobs.items():
            times[key].append(min(job() for _ in range(repeats[key])))
    return {key: np.array(value) for key, value in times.items()}


def spread(values: np.ndarray, digits: int = 2) -> str:
    """``median (lowest-highest)``."""
    return f"{np.median(values):.{digits}f} ({values.min():.{digits}f}-{values.max():.{digits}f})"


def load_average() -> str:
    try:
        with open("/proc/loadavg") as status:
            return " ".join(status.read().split()[:3])
    except OSError:
        return "unknown"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, nargs="+", default=[1000, 10_000, 100_000])
    parser.add_argument("--rounds", type=int, default=5, help="interleaved rounds (>= 5)")
    parser.add_argument("--source", type=Path, help="clip to cut or repeat (default: 131_02)")
    args = parser.parse_args()
    rounds = max(5, args.rounds)
    source = args.source or next(c for c in corpus_clips() if c.name == "131_02.bvh")
    warnings.filterwarnings("ignore")  # pybvh warns about world-up guesses
    load_before = load_average()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        for frames in args.frames:
            clip = build_clip(source, frames, out / f"scale_{frames}.bvh")
            block = motion_block(clip)
            lines: list[str] = []
            pairs = {
                "read + write": read_write_jobs(clip, out),
                "clean": (
                    clean_job(clip, out, lines),
                    lambda b=block: elapsed(lambda: np.loadtxt(io.StringIO(b))),
                ),
            }
            times = interleaved(pairs, rounds)
            peak = peak_memory(clip, out)
            rows.append((frames, clip.stat().st_size, times, peak, list(lines)))
    print(f"Long clips: 131_02 (31 joints) cut or played back and forth; {rounds} rounds")
    print(f"load average before {load_before}, after {load_average()}\n")
    print(
        "| frames | file MB | read + write ms | pybvh ms | pybvh / ours | clean + HTML s "
        "| loadtxt ms | clean / loadtxt | peak MB | peak / file | terminal lines | longest |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for frames, size, times, peak, lines in rows:
        ours, theirs = times["read + write/ours"], times["read + write/peer"]
        clean, loadtxt = times["clean/ours"], times["clean/peer"]
        print(
            f"| {frames:,} | {size / 1e6:.1f} | {np.median(ours) * 1e3:.0f} "
            f"| {np.median(theirs) * 1e3:.0f} | {spread(theirs / ours)} | {np.median(clean):.2f} "
            f"| {np.median(loadtxt) * 1e3:.0f} | {spread(clean / loadtxt, 1)} "
            f"| {peak / 1e6:.0f} | {peak / size:.1f} | {len(lines)} "
            f"| {max(map(len, lines), default=0)} |"
        )


if __name__ == "__main__":
    main()
