"""World space: forward kinematics on a long clip against one Lee-Shin pass of the same array.

Run: ``python bench/world.py``. 131_02 repeated to 100,000 frames x 31 joints; prints the
time of :func:`motionclean.core.kinematics.forward` (joints and end sites) and its ratio to one
5-tap Lee-Shin pass over the clip's rotations (target: under 1), best of 5 in wall-clock and
in the process's CPU time (both single-threaded; CPU time is steadier on a busy machine).
"""

from __future__ import annotations

import numpy as np
from common import ROOT, best_cpu, best_of, corpus_clips

import motionclean as mc
from motionclean.core import kinematics, quat
from motionclean.filters import lee_shin
from motionclean.filters.masks import binomial

FRAMES = 100_000


#: Other exporters' clips (tests/data/exporters/README.md) and the axis each stands along.
EXPORTERS = ROOT / "tests" / "data" / "exporters"
UP = {"video2bvh_zup.bvh": 2}


def up_axes() -> None:
    """The up direction on every real clip and its copies turned to each other axis, head
    up and head down (a half turn more about the next axis, as y-down camera coordinates
    have it)."""
    print(
        "| clip | up | before: the rest pose's tallest axis, turned to x, y, z "
        "| now: x, y, z, -x, -y, -z |"
    )
    print("| --- | --- | --- | --- |")
    right = old_right = total = 0
    for path in [*corpus_clips(), *sorted(EXPORTERS.glob("*.bvh"))]:
        motion = mc.load(path)
        up = UP.get(path.name, 1)
        found, old = [], []
        for sign in (1.0, -1.0):
            for target in range(3):
                if target == up:
                    clip = motion
                else:
                    axis = np.cross(np.eye(3)[up], np.eye(3)[target])
                    clip = kinematics.turned(motion, quat.from_axis_angle(axis, np.pi / 2))
                if sign < 0.0:
                    clip = kinematics.turned(
                        clip, quat.from_axis_angle(np.eye(3)[(target + 1) % 3], np.pi)
                    )
                found.append(kinematics.up_name(clip))
                right += found[-1] == ("-" if sign < 0.0 else "") + kinematics.AXES[target]
                total += 1
                if sign > 0.0:
                    old.append(int(np.argmax(np.ptp(kinematics.rest_positions(clip), axis=0))))
                    old_right += old[-1] == target
        axes = kinematics.AXES
        print(
            f"| {path.name} | {axes[up]} | {', '.join(axes[a] for a in old)} | {', '.join(found)} |"
        )
    print(
        f"\nright: {right} of {total} directions (the rest pose's tallest axis, head up "
        f"alone: {old_right} of {total // 2})\n"
    )


def main() -> None:
    up_axes()
    clip = mc.load(next(p for p in corpus_clips() if p.name == "131_02.bvh"))
    repeats = -(-FRAMES // clip.n_frames)
    index = np.tile(np.arange(clip.n_frames), repeats)[:FRAMES]
    long = clip.replace(
        rotations=clip.rotations[index], translations=clip.translations[index], source_values=None
    )
    rotations = long.rotations

    def forward() -> object:
        return kinematics.forward(long, end_sites=True)

    def one_pass() -> object:
        return lee_shin(rotations, binomial(2))

    finding = best_of(lambda: kinematics.body_height(long, kinematics.up_axis(long)), 5, True)
    print(f"up axis and body height of {FRAMES} frames: {finding * 1e3:.1f} ms\n")
    print(f"{FRAMES} frames x {clip.n_joints} joints        wall      CPU")
    fk = (best_of(forward, 5, warm_up=True), best_cpu(forward, 5))
    pass_ = (best_of(one_pass, 5, warm_up=True), best_cpu(one_pass, 5))
    print(f"forward (joints + end sites) {fk[0] * 1e3:8.1f} ms {fk[1] * 1e3:8.1f} ms")
    print(f"one Lee-Shin pass (5 taps)   {pass_[0] * 1e3:8.1f} ms {pass_[1] * 1e3:8.1f} ms")
    print(
        f"ratio forward / pass         {fk[0] / pass_[0]:8.2f}    {fk[1] / pass_[1]:8.2f}"
        "     (target < 1)"
    )


if __name__ == "__main__":
    main()
