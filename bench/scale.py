"""Long clips: read + write, clean and memory from 1k to 100k frames, against peers.

Run ``python bench/scale.py [--frames 1000 10000 100000]``. The clips are the corpus clip
131_02 (31 joints, 1,247 frames) cut or repeated to each length, every value's text kept.
For each length it measures, in this process (best of at least three interleaved runs for
read + write and ``np.loadtxt``, best of two for ``clean``: the first touch of fresh memory
costs this machine more than the work on it):

- read + write with every rotation changed (motionclean ``load`` + ``save``; the change
  itself, one quaternion product, is not timed: pybvh changes nothing) against pybvh
  (``read_bvh_file`` + ``write_bvh_file``): the ratio pybvh / motionclean (above 1: faster);
- the default ``clean`` with an HTML report (the CLI, in process) against ``np.loadtxt`` of
  the same MOTION block (the floor of any text reader): the ratio clean / loadtxt;
- peak resident memory of a fresh process running that ``clean``, over the file size;
- the terminal output of that ``clean``: lines and the longest line.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
from common import best_of, corpus_clips, elapsed

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


def build_clip(source: Path, frames: int, target: Path) -> Path:
    """``source`` cut or repeated to ``frames`` frames (rows copied as text)."""
    raw = source.read_bytes()
    head, _, rest = raw.partition(b"MOTION")
    lines = rest.splitlines()
    at = next(i for i, line in enumerate(lines) if line.strip().startswith(b"Frame Time"))
    rows = [line for line in lines[at + 1 :] if line.strip()]
    body = [rows[i % len(rows)] for i in range(frames)]
    eol = b"\r\n" if b"\r\n" in raw[:4096] else b"\n"
    text = eol.join([b"MOTION", b"Frames: %d" % frames, lines[at].strip(), *body]) + eol
    target.write_bytes(head + text)
    return target


def read_write(clip: Path, out: Path, repeats: int) -> tuple[float, float]:
    """Best read + write time of motionclean (every rotation changed) and of pybvh."""
    import pybvh

    turn = quat.from_axis_angle(np.array([0.48, 0.6, 0.64]), np.deg2rad(0.5))

    def ours() -> float:
        motion: list[mc.Motion] = []
        read = elapsed(lambda: motion.append(mc.load(clip)))
        changed = motion[0].replace(rotations=quat.multiply(motion[0].rotations, turn))
        return read + elapsed(lambda: mc.save(changed, out / "mc.bvh"))

    def theirs() -> None:
        pybvh.write_bvh_file(pybvh.read_bvh_file(clip), out / "pybvh.bvh")

    ours_t = theirs_t = np.inf
    for _ in range(repeats):  # interleaved
        ours_t = min(ours_t, ours())
        theirs_t = min(theirs_t, elapsed(theirs))
    return ours_t, theirs_t


def motion_block(clip: Path) -> str:
    text = clip.read_text()
    at = text.index("Frame Time:")
    return text[text.index("\n", at) + 1 :]


def clean(clip: Path, out: Path) -> tuple[float, list[str]]:
    """Wall time and terminal lines of the default ``clean`` with an HTML report."""
    args = ["clean", str(clip), "-o", str(out / "clean.bvh"), "--report", str(out / "r.html")]
    stdout = io.StringIO()

    def run() -> None:
        with contextlib.redirect_stdout(stdout), contextlib.suppress(SystemExit):
            cli_main(args)

    seconds = elapsed(run)
    return seconds, stdout.getvalue().splitlines()


def peak_memory(clip: Path, out: Path) -> int:
    """Peak resident bytes of a fresh process running the default ``clean`` with HTML."""
    args = ["clean", str(clip), "-o", str(out / "peak.bvh"), "--report", str(out / "p.html")]
    done = subprocess.run(
        [sys.executable, "-c", PEAK, *args], capture_output=True, text=True, check=True
    )
    return int(done.stdout.split()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, nargs="+", default=[1000, 10_000, 100_000])
    args = parser.parse_args()
    source = next(c for c in corpus_clips() if c.name == "131_02.bvh")
    warnings.filterwarnings("ignore")  # pybvh warns about world-up guesses
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        for frames in args.frames:
            clip = build_clip(source, frames, out / f"scale_{frames}.bvh")
            repeats = max(3, 30_000 // frames)
            ours, theirs = read_write(clip, out, repeats)
            block = motion_block(clip)
            loadtxt = best_of(lambda b=block: np.loadtxt(io.StringIO(b)), 3)
            clean_s, lines = min(clean(clip, out) for _ in range(2))
            peak = peak_memory(clip, out)
            size = clip.stat().st_size
            rows.append((frames, size, ours, theirs, clean_s, loadtxt, peak, lines))

    print("Long clips: 131_02 (31 joints) cut or repeated; ratios measured in one process\n")
    print(
        "| frames | file MB | read + write ms | pybvh ms | pybvh / ours | clean + HTML s "
        "| loadtxt s | clean / loadtxt | peak MB | peak / file | terminal lines | longest |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for frames, size, ours, theirs, clean_s, loadtxt, peak, lines in rows:
        print(
            f"| {frames:,} | {size / 1e6:.1f} | {ours * 1e3:.0f} | {theirs * 1e3:.0f} "
            f"| {theirs / ours:.2f} | {clean_s:.2f} | {loadtxt:.2f} | {clean_s / loadtxt:.1f} "
            f"| {peak / 1e6:.0f} | {peak / size:.1f} | {len(lines)} "
            f"| {max(map(len, lines), default=0)} |"
        )


if __name__ == "__main__":
    main()
