"""BVH read + write speed against bvhio and pybvh, same process, same files.

Run ``python bench/io.py [--repeats N]``. For every corpus clip (../shared/corpus/cmu) it
times, best of N interleaved repeats:

- motionclean: ``load`` (parse + quaternions) and ``save`` twice: the identity save (the
  unchanged clip, which writes the source bytes) and the realistic cleaning save, after
  every rotation was changed (Euler angles recovered on the original branch, changed values
  printed in place of the old ones);
- bvhio: ``readAsBvh`` + ``writeBvh``;
- pybvh: ``read_bvh_file`` + ``write_bvh_file``.

Prints a markdown table of milliseconds and the read + write ratios of bvhio and pybvh over
motionclean (above 1: motionclean is faster).
"""

from __future__ import annotations

import argparse
import tempfile
import warnings
from pathlib import Path

import numpy as np
from common import corpus_clips, elapsed

import motionclean as mc
from motionclean.core import quat


def measure(clip: Path, out: Path, repeats: int) -> dict[str, float]:
    """Best time in seconds of each operation on ``clip`` (operations interleaved)."""
    import bvhio
    import pybvh

    motion = mc.load(clip)
    turn = quat.from_axis_angle(np.array([0.48, 0.6, 0.64]), np.deg2rad(0.5))
    changed = motion.replace(rotations=quat.multiply(motion.rotations, turn))
    theirs_bvhio = bvhio.readAsBvh(str(clip))
    theirs_pybvh = pybvh.read_bvh_file(clip)
    ops = {
        "mc read": lambda: mc.load(clip),
        "mc write identity": lambda: mc.save(motion, out / "mc_same.bvh"),
        "mc write changed": lambda: mc.save(changed, out / "mc_changed.bvh"),
        "pybvh read": lambda: pybvh.read_bvh_file(clip),
        "pybvh write": lambda: pybvh.write_bvh_file(theirs_pybvh, out / "pybvh.bvh"),
        "bvhio read": lambda: bvhio.readAsBvh(str(clip)),
        "bvhio write": lambda: bvhio.writeBvh(str(out / "bvhio.bvh"), theirs_bvhio),
    }
    best = dict.fromkeys(ops, np.inf)
    for _ in range(repeats):
        for name, fn in ops.items():
            best[name] = min(best[name], elapsed(fn))
    assert (out / "mc_same.bvh").read_bytes() == clip.read_bytes()
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    clips = corpus_clips()
    warnings.filterwarnings("ignore")  # pybvh warns about world-up guesses
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for clip in clips:
            t = measure(clip, Path(tmp), args.repeats)
            rows.append((clip, mc.load(clip).n_frames, t))

    ms = 1e3
    print(
        f"BVH read + write, best of {args.repeats}, milliseconds "
        "(motionclean write: identity / every rotation changed)\n"
    )
    print(
        "| clip | frames | motionclean read | write identity | write changed "
        "| pybvh read | pybvh write | bvhio read | bvhio write |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for clip, frames, t in rows:
        print(
            f"| {clip.name} | {frames} | {t['mc read'] * ms:.1f} "
            f"| {t['mc write identity'] * ms:.1f} | {t['mc write changed'] * ms:.1f} "
            f"| {t['pybvh read'] * ms:.1f} | {t['pybvh write'] * ms:.1f} "
            f"| {t['bvhio read'] * ms:.1f} | {t['bvhio write'] * ms:.1f} |"
        )

    print("\nRead + write: time of the peer / time of motionclean (above 1: motionclean faster)\n")
    print(
        "| clip | motionclean identity | motionclean changed | pybvh | bvhio "
        "| pybvh / mc (identity) | pybvh / mc (changed) | bvhio / mc (identity) "
        "| bvhio / mc (changed) |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for clip, _, t in rows:
        same = t["mc read"] + t["mc write identity"]
        edit = t["mc read"] + t["mc write changed"]
        pyb = t["pybvh read"] + t["pybvh write"]
        bio = t["bvhio read"] + t["bvhio write"]
        print(
            f"| {clip.name} | {same * ms:.1f} | {edit * ms:.1f} | {pyb * ms:.1f} "
            f"| {bio * ms:.1f} | {pyb / same:.2f} | {pyb / edit:.2f} | {bio / same:.1f} "
            f"| {bio / edit:.1f} |"
        )


if __name__ == "__main__":
    main()
