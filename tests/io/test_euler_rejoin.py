"""The Euler write-back keeps its promise with frame ranges: a ranged Lee-Shin over
RThumb's half-turn flips, nothing repaired, turns the joint a full turn against the input
inside the range; the written channels rejoin the untouched frames after it without a step
larger than 180 degrees where the input's own step is smaller."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import NOISY, SAMPLE, max_degrees

import motionclean as mc
from motionclean.core.eulerjoin import JUMP_DEG
from motionclean.steps.pipeline import Pipeline


def rows(path: Path) -> np.ndarray:
    text = path.read_text().split("Frame Time:")[1].splitlines()[1:]
    return np.array([r.split() for r in text if r.strip()], dtype=float)


@pytest.mark.parametrize(
    ("source", "step"),
    [
        (SAMPLE, "lee-shin:k=2,iterations=5,frames=[40,60],blend=5"),  # wrote 478 degrees
        (SAMPLE, "lee-shin:k=2,iterations=5,frames=[45,52],blend=12"),  # 514
        (SAMPLE, "lee-shin:k=2,iterations=5,frames=[0,120],blend=0"),  # 362
        (NOISY, "lee-shin:k=2,iterations=5,frames=[40,60],blend=5"),  # 315
    ],
)
def test_a_ranged_smoothing_over_flips_rejoins_the_input_without_a_new_jump(source, step, tmp_path):
    clip = mc.load(source)
    out, _ = Pipeline.from_inline([step]).run(clip)
    target = tmp_path / "out.bvh"
    mc.save(out, target)
    read, written = rows(source), rows(target)
    step_in = np.abs(np.diff(read, axis=0))
    step_out = np.abs(np.diff(written, axis=0))
    new_jumps = (step_out > JUMP_DEG) & (step_out > step_in + 1e-6)
    assert not new_jumps.any(), np.argwhere(new_jumps)[:5]
    # the same rotations, and every frame outside the range as it was, byte for byte
    assert max_degrees(mc.load(target).rotations, out.rotations) < 1e-4
    first, last = (int(v) for v in step.split("frames=[")[1].split("]")[0].split(","))
    blend = int(step.rsplit("blend=", 1)[1])
    lines_in = source.read_text().splitlines()
    lines_out = target.read_text().splitlines()
    head = lines_in.index(next(line for line in lines_in if line.startswith("Frame Time")))
    for frame in (*range(0, max(first - blend, 0)), *range(last + blend + 1, clip.n_frames)):
        assert lines_out[head + 1 + frame] == lines_in[head + 1 + frame]


def test_an_identity_write_stays_byte_for_byte(tmp_path):
    clip = mc.load(SAMPLE)
    mc.save(clip, tmp_path / "same.bvh")
    assert (tmp_path / "same.bvh").read_bytes() == SAMPLE.read_bytes()


def test_the_step_floor_is_the_least_step_between_representations_bit_for_bit():
    """A run whose own largest step is no larger than the floor is left without a solve:
    the floor is, at its worst step, the least step any two representations take there
    (the same bits as the (54, 54) comparison), so no solve can do better than it; with
    no step just above it, the solve within it is the full solve's answer."""
    from motionclean.core import eulerjoin

    rng = np.random.default_rng(3)
    for trial in range(60):
        n = int(rng.integers(1, 30))
        angles = np.cumsum(rng.normal(0.0, rng.choice([1.0, 30.0, 120.0]), (n, 3)), axis=0)
        angles[:, 1] = np.clip(angles[:, 1], -95.0, 95.0)
        before = None if trial % 4 == 0 else angles[0] + rng.normal(0.0, 100.0, 3)
        after = None if trial % 5 == 0 else angles[-1] + rng.normal(0.0, 100.0, 3)
        cand = eulerjoin._candidates(angles)
        least = [
            np.abs(cand[i][None] - cand[i - 1][:, None]).max(axis=2).min() for i in range(1, n)
        ]
        if before is not None:
            least.append(np.abs(cand[0] - before).max(axis=1).min())
        if after is not None:
            least.append(np.abs(cand[-1] - after).max(axis=1).min())
        floor, alone = eulerjoin._step_floor(angles, before, after)
        assert floor == max(least, default=0.0)
        best = eulerjoin._least_largest_step(angles, before, after)
        assert eulerjoin._largest_step(best, before, after) >= floor
        if alone:  # the solve sought within the floor first finds the same representations
            assert np.array_equal(eulerjoin._least_largest_step(angles, before, after, floor), best)


def test_the_inputs_own_half_turn_flips_are_written_as_flips_not_solved(tmp_path):
    """Every rotation turned by half a degree: RThumb's captured half-turn flips are
    written as flips a few degrees longer or shorter than the input's (within
    JUMP_MARGIN), and no step is added or removed above 30 degrees on any channel."""
    from motionclean.core import eulerjoin, quat

    clip = mc.load(SAMPLE)
    turn = quat.from_axis_angle(np.array([0.48, 0.6, 0.64]), np.deg2rad(0.5))
    target = tmp_path / "turned.bvh"
    mc.save(clip.replace(rotations=quat.multiply(clip.rotations, turn)), target)
    step_in = np.abs(np.diff(rows(SAMPLE), axis=0))
    step_out = np.abs(np.diff(rows(target), axis=0))
    assert (step_in > JUMP_DEG).any()  # the sample flips: the case is exercised
    assert np.array_equal(step_out > 30.0, step_in > 30.0)
    assert (step_out[step_in > 30.0] <= step_in[step_in > 30.0] + eulerjoin.JUMP_MARGIN).all()
