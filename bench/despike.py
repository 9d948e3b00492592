"""Flip and spike repair on the CMU corpus: what is repaired, steps before/after, and cost.

Run ``python bench/despike.py``. Prints markdown tables:

1. Per corpus clip: frames repaired (un-flipped / interpolated), and the largest
   frame-to-frame rotation step over all joints before and after ``despike`` (defaults).
2. Per repaired joint: the runs of frames un-flipped and interpolated.
3. Lower frame rates: each clip kept at every 2nd, 4th and 5th frame (60, 30, 24 fps).
   The joints repaired, the RMS and largest change of all other joints than RThumb
   (genuine motion, which must stay as it is unless a step is above the cap), and whether
   RThumb's un-flipped frames are the 120 fps ones, subsampled.
4. Why it comes first: five passes of the 5-tap binomial Lee-Shin filter on RThumb, the
   largest error on frames that despike leaves alone (the flips smeared onto their good
   neighbours), without and with despike first.
5. Cost of one despike pass against one Lee-Shin pass (binomial 5 taps) on the same
   rotations, same process (best of several runs).
"""

from __future__ import annotations

import numpy as np
from common import best_of, corpus_clips

import motionclean as mc
from motionclean.core import quat
from motionclean.filters.despike import despike, despike_positions, despike_with_report
from motionclean.filters.linear import lee_shin
from motionclean.filters.masks import binomial

REPEATS = 15  # timing runs, the best kept


def max_step(q: np.ndarray) -> tuple[float, int]:
    """Largest step (degrees) over all frames and joints, and its joint."""
    steps = np.rad2deg(quat.angle_between(q[:-1], q[1:]))
    j = int(np.argmax(steps.max(axis=0)))
    return float(steps[:, j].max()), j


def fmt_runs(runs) -> str:
    return ", ".join(f"{a}-{b - 1}" if b - a > 1 else f"{a}" for a, b in runs) or "-"


def main() -> None:
    motions = {path.name: mc.load(path) for path in corpus_clips()}

    print("## Repairs per corpus clip (defaults)\n")
    print(
        "| clip | frames | joints repaired | frames un-flipped | frames interpolated "
        "| largest step before (deg) | largest step after (deg) |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    detail = []
    reports = {}
    for name, m in motions.items():
        out, rep = despike_with_report(m.rotations, m.frame_time)
        reports[name] = (out, rep)
        before, jb = max_step(m.rotations)
        after, ja = max_step(out)
        joints = np.flatnonzero(rep.counts())
        print(
            f"| {name} | {m.n_frames} | {', '.join(m.names[j] for j in joints)} "
            f"| {int(rep.counts('unflipped').sum())} | {int(rep.counts('interpolated').sum())} "
            f"| {before:.1f} ({m.names[jb]}) | {after:.1f} ({m.names[ja]}) |"
        )
        for j in joints:
            detail.append((name, m.names[j], rep, j))
        moved = despike_positions(m.translations, m.frame_time)
        assert np.array_equal(moved, m.translations)  # no root jumps in the corpus

    print("\n## Repaired joints\n")
    print(
        "| clip | joint | un-flipped frames | interpolated frames | largest step before -> "
        "after (deg) |"
    )
    print("| --- | --- | --- | --- | --- |")
    for name, joint, rep, j in detail:
        print(
            f"| {name} | {joint} | {fmt_runs(rep.runs(j, 'unflipped'))} "
            f"| {fmt_runs(rep.runs(j, 'interpolated'))} "
            f"| {rep.max_step_before[j]:.1f} -> {rep.max_step_after[j]:.1f} |"
        )

    print("\n## Lower frame rates (defaults)\n")
    print(
        "| clip | fps | joints repaired | RMS / largest change, other joints than RThumb "
        "(deg) | RThumb un-flipped frames | same as at 120 fps |"
    )
    print("| --- | --- | --- | --- | --- | --- |")
    for name, m in motions.items():
        thumb = m.names.index("RThumb")
        full = reports[name][1].unflipped[:, thumb]
        others = np.arange(len(m.names)) != thumb
        for every in (2, 4, 5):
            q = quat.make_continuous(m.rotations[::every], axis=0)
            out, rep = despike_with_report(q, m.frame_time * every)
            change = np.rad2deg(quat.angle_between(out[:, others], q[:, others]))
            joints = np.flatnonzero(rep.counts())
            same = np.array_equal(rep.unflipped[:, thumb], full[::every])
            print(
                f"| {name} | {round(1 / (m.frame_time * every))} "
                f"| {', '.join(m.names[j] for j in joints)} "
                f"| {np.sqrt(np.mean(change**2)):.3f} / {change.max():.1f} "
                f"| {int(rep.counts('unflipped')[thumb])} | {'yes' if same else 'no'} |"
            )

    print("\n## Lee-Shin after despike (RThumb, binomial 5 taps x 5 passes)\n")
    print("| clip | largest error on untouched frames, raw (deg) | same after despike (deg) |")
    print("| --- | --- | --- |")
    mask = binomial(2)
    for name, m in motions.items():
        j = m.names.index("RThumb")
        out, rep = reports[name]
        good = ~rep.repaired[:, j]
        raw = lee_shin(m.rotations[:, j], mask, iterations=5)
        clean = lee_shin(out[:, j], mask, iterations=5)
        err_raw = np.rad2deg(quat.angle_between(raw, out[:, j]))[good].max()
        err_clean = np.rad2deg(quat.angle_between(clean, out[:, j]))[good].max()
        print(f"| {name} | {err_raw:.1f} | {err_clean:.1f} |")

    print("\n## Cost (same rotations, same process, best of 15)\n")
    print("| clip | despike (ms) | Lee-Shin pass (ms) | ratio |")
    print("| --- | --- | --- | --- |")
    for name, m in motions.items():
        t_d = best_of(lambda m=m: despike(m.rotations, m.frame_time), REPEATS)
        t_l = best_of(lambda m=m: lee_shin(m.rotations, mask, iterations=1), REPEATS)
        print(f"| {name} | {t_d * 1e3:.2f} | {t_l * 1e3:.2f} | {t_d / t_l:.2f} |")


if __name__ == "__main__":
    main()
