"""Steps over half-turn flips nothing repaired: lee-shin keeps a flip a flip, not a fast turn;
the report counts no flip as jitter, names them where smoothing crossed them, and says which
joints fairing's bound left as they were."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import NOISY, degrees_between, with_t_pose

import motionclean as mc
from motionclean.core import quat
from motionclean.core.errors import UsageError
from motionclean.core.takes import take_starts
from motionclean.filters.linear import lee_shin
from motionclean.filters.masks import binomial
from motionclean.report.summary import build_series
from motionclean.run.jobs import clean_motion
from motionclean.steps.pipeline import Pipeline


def flipped_signal(frames: int = 200, at: int = 100) -> np.ndarray:
    """A slow turn about one axis, half a turn about another from frame ``at`` on."""
    angle = np.linspace(0.0, 1.0, frames)
    q = quat.exp(angle[:, None] * np.array([0.0, 0.0, 0.5]))
    flip = np.array([0.0, 1.0, 0.0, 0.0])  # half a turn about x
    q[at:] = quat.multiply(q[at:], flip)
    return q


def test_a_cut_filter_leaves_the_flip_and_filters_each_side_as_a_signal_of_its_own():
    q = flipped_signal()
    plain = lee_shin(q, binomial(2), 5)
    cut = lee_shin(q, binomial(2), 5, math.radians(90.0))
    steps = np.degrees(quat.angle_between(cut[:-1], cut[1:]))
    assert steps[99] > 179.0 and np.delete(steps, 99).max() < 1.0  # still one flip
    for side in (slice(0, 100), slice(100, None)):  # each side's ends mirrored (Eq. 26)
        alone = lee_shin(q[side], binomial(2), 5)
        assert degrees_between(cut[side], alone).max() < 1e-9
    assert degrees_between(cut, q).max() < 1e-9  # a constant turn: a fixed point each side
    assert degrees_between(plain, q).max() > 30.0  # the plain filter spins into the flip
    wide = lee_shin(q, binomial(40), 10, math.radians(90.0))  # a mask wider than a side
    assert degrees_between(wide, q).max() < 1e-9


def test_each_stretch_between_cuts_is_filtered_as_a_signal_of_its_own():
    """Many flips, stretches of one to forty frames, three columns (one never flips) and
    three passes: every stretch as lee_shin gives it alone (one frame: kept)."""
    rng = np.random.default_rng(8)
    q = quat.multiply(
        quat.exp(np.cumsum(rng.normal(scale=0.03, size=(160, 3, 3)), axis=0)),
        quat.exp(rng.normal(scale=0.01, size=(160, 3, 3))),
    )
    flip = np.array([0.0, 0.0, 1.0, 0.0])
    for column, starts in ((0, [10, 11, 12, 50, 90, 130]), (2, [1, 80, 159])):
        for at in starts:  # a half turn from each start on: a cut at every start
            q[at:, column] = quat.multiply(q[at:, column], flip)
    out = lee_shin(q, binomial(3), 3, math.radians(90.0))
    for column, starts in ((0, [10, 11, 12, 50, 90, 130]), (1, []), (2, [1, 80, 159])):
        edges = [0, *starts, 160]
        for first, stop in zip(edges[:-1], edges[1:], strict=True):
            part = q[first:stop, column]
            alone = lee_shin(part, binomial(3), 3) if stop - first > 1 else part
            assert degrees_between(out[first:stop, column], alone).max() < 1e-9


def test_a_cut_at_half_a_turn_or_more_is_the_plain_filter():
    q = flipped_signal()
    plain = lee_shin(q, binomial(2), 3)
    for cut in (math.pi, 10.0, math.inf):
        assert np.array_equal(lee_shin(q, binomial(2), 3, cut), plain)


def test_a_cut_filter_is_coordinate_invariant():
    rng = np.random.default_rng(3)
    q = quat.multiply(flipped_signal(), quat.exp(rng.normal(scale=0.02, size=(200, 3))))
    a, b = quat.normalize(rng.normal(size=4)), quat.normalize(rng.normal(size=4))
    cut = math.radians(90.0)
    turned = lee_shin(quat.multiply(quat.multiply(a, q), b), binomial(2), 3, cut)
    filtered = lee_shin(q, binomial(2), 3, cut)
    expected = quat.multiply(quat.multiply(a, filtered), b)
    assert degrees_between(turned, expected).max() < 1e-9
    steps = np.degrees(quat.angle_between(filtered[:-1], filtered[1:]))
    assert steps.max() > 170.0  # the flip is kept (the plain filter spreads it)


@pytest.mark.parametrize("cut", [0.0, -1.0, math.nan])
def test_a_cut_that_is_no_angle_is_refused(cut):
    with pytest.raises(ValueError, match="cut_above"):
        lee_shin(flipped_signal(), binomial(2), 1, cut)


@pytest.mark.parametrize("cut_deg", ["0", "700", "inf", "nan"])
def test_the_step_refuses_a_cut_outside_a_half_turn(cut_deg):
    with pytest.raises(UsageError, match="cut_deg must be a number > 0 and <= 180"):
        Pipeline.from_inline([f"lee-shin:cut_deg={cut_deg}"])


def test_the_step_leaves_unrepaired_flips_and_the_verdict_counts_the_jitter_elsewhere():
    """The noisy sample's RThumb flips by half turns five times; lee-shin alone (no despike)
    had spun it by up to 60 degrees around them, and counted the flips' accelerations as the
    jitter it removed."""
    clip = mc.load(NOISY)
    thumb = clip.names.index("RThumb")
    result = clean_motion(clip, Pipeline.from_inline(["lee-shin:k=2,iterations=3"]), "n.bvh")
    out = result.after
    assert degrees_between(out.rotations[:, thumb], clip.rotations[:, thumb]).max() < 10.0
    verdict = result.report["verdict"]
    assert verdict["noise_removed"] > 0.5, verdict["text"]  # (3 % with the flips counted)
    spun = clean_motion(
        clip, Pipeline.from_inline(["lee-shin:k=2,iterations=3,cut_deg=180"]), "n.bvh"
    )
    assert degrees_between(spun.after.rotations[:, thumb], clip.rotations[:, thumb]).max() > 30
    assert "smoothing moved RThumb" in spun.report["verdict"]["text"]
    assert "across 10 steps of over 90 degrees in the input" in spun.report["verdict"]["text"]
    assert "despike repairs them first" in spun.report["verdict"]["text"]
    kept = clean_motion(clip, Pipeline.from_inline(["despike", "multires:level=2"]), "n.bvh")
    assert "steps of over 90 degrees" not in kept.report["verdict"]["text"]  # repaired first


def test_the_report_counts_no_cut_dropout_or_rest_frame_as_an_unrepaired_jump(tmp_path):
    """Steps over 90 degrees the report tells as flips left in place are the motion's own:
    not the cut between two takes joined end to end, a dropout held across, nor the step
    out of a rest pose at the start (each had counted one)."""
    clip = mc.load(NOISY)  # its only jumps: RThumb's ten half-turn steps
    assert build_series(clip, clip)["unrepaired_jumps"] == {"RThumb": 10}
    turn = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), math.radians(170.0))
    second = clip.rotations[225:].copy()
    second[:, 0] = quat.multiply(turn, second[:, 0])  # a cut: the root turned away at once
    moved = clip.translations[225:].copy()
    moved[:, 0, 0] += 50.0
    joined = clip.replace(
        rotations=np.concatenate([clip.rotations[:150], second]),
        translations=np.concatenate([clip.translations[:150], moved]),
        source_values=None,
        source_rotations=None,
    )
    assert take_starts(joined).tolist() == [150]
    assert build_series(joined, joined)["unrepaired_jumps"] == {"RThumb": 10}
    shoulder = clip.names.index("RightShoulder")
    rotations, missing = clip.rotations.copy(), np.zeros((300, clip.n_joints), dtype=bool)
    rotations[1:45, shoulder] = rotations[45, shoulder]  # a dropout held: one step of 111 deg
    missing[1:45, shoulder] = True
    gappy = clip.replace(rotations=rotations, missing=missing)
    assert build_series(gappy, gappy)["unrepaired_jumps"] == {"RThumb": 10}
    posed = mc.load(with_t_pose(NOISY, tmp_path / "posed.bvh"))
    assert build_series(posed, posed)["unrepaired_jumps"] == {"RThumb": 10}


def test_fairing_says_which_joints_its_bound_left_as_they_were():
    """Fairing keeps the last iterate within epsilon_r; where the first would leave it
    (RThumb's half-turn flips fairing smooths across with cut_deg=180, a video estimate's
    noise), the joint stays as it was, and the report says so and what to change (the
    verdict had only "no rotation changed"). Cut at its flips, RThumb is smoothed."""
    clip = mc.load(NOISY)
    result = clean_motion(clip, Pipeline.from_inline(["fairing:cut_deg=180"]), "n.bvh")
    assert result.report["joints"]["RThumb"]["fairing"] == {"iterations": 0, "held_by_bound": True}
    assert result.report["joints"]["Head"]["fairing"]["iterations"] > 0
    notes = [n for n in result.report["notes"] if n.startswith("fairing left")]
    assert notes == [
        "fairing left 1 joint as it was (RThumb): its first step would move a sample beyond "
        "epsilon_r; a larger epsilon_r lets it smooth them"
    ]
    for step in ("fairing", "fairing:cut_deg=180,epsilon_r=inf", "fairing:max_iterations=0"):
        free = clean_motion(clip, Pipeline.from_inline([step]), "n.bvh")
        assert not any(n.startswith("fairing left") for n in free.report.get("notes", []))
    cut = clean_motion(clip, Pipeline.from_inline(["fairing"]), "n.bvh").report["joints"]
    assert cut["RThumb"]["fairing"] == {"iterations": 100, "held_by_bound": False}


def test_stretches_across_block_edges_match_each_alone_in_bounded_memory():
    """A wide mask (201 taps), two passes, cuts beside the 4,096-frame blocks the samples
    near a cut are summed in: each stretch as lee_shin gives it alone, and memory a few
    times the clip's (every frame's whole window gathered at once had taken some 75)."""
    import tracemalloc

    rng = np.random.default_rng(4)
    q = quat.exp(np.cumsum(rng.normal(scale=0.02, size=(8200, 4, 3)), axis=0))
    starts = [40, 4095, 4096, 4097, 8191, 8192, 8193]
    for at in starts:  # on two of the four columns
        q[at:, :2] = quat.multiply(q[at:, :2], np.array([0.0, 0.0, 1.0, 0.0]))
    tracemalloc.start()
    try:
        out = lee_shin(q, binomial(100), 2, math.radians(90.0))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 * q.nbytes
    edges = [0, *starts, 8200]
    for column in range(4):
        cuts = edges if column < 2 else [0, 8200]
        for first, stop in zip(cuts[:-1], cuts[1:], strict=True):
            part = q[first:stop, column]
            alone = lee_shin(part, binomial(100), 2) if stop - first > 1 else part
            assert degrees_between(out[first:stop, column], alone).max() < 1e-9


def test_the_verdict_blames_a_flip_only_for_a_change_beside_it():
    """A forearm flipped for ten frames (kept as a flip by lee-shin's cut) and, 150 frames
    on, a 60-degree one-frame glitch it smooths: the largest change is the glitch's, and
    the verdict had said it was moved "across 2 steps of over 90 degrees" (the flip's)."""
    clip = mc.load(NOISY)
    arm = clip.names.index("LeftElbow")
    q = clip.rotations.copy()
    q[100:110, arm] = quat.multiply(q[100:110, arm], np.array([0.0, 0.0, 1.0, 0.0]))
    q[260, arm] = quat.multiply(q[260, arm], quat.exp(np.array([0.0, math.radians(30), 0.0])))
    planted = clip.replace(rotations=q)
    kept = clean_motion(
        planted, Pipeline.from_inline(["lee-shin:k=3,joints=[LeftElbow]"]), "p.bvh"
    ).report
    text = kept["verdict"]["text"]
    assert "smoothing moved LeftElbow" in text and "steps of over 90 degrees" not in text, text
    spun_step = "lee-shin:k=3,joints=[LeftElbow],cut_deg=180"
    spun = clean_motion(planted, Pipeline.from_inline([spun_step]), "p.bvh")
    assert "moved LeftElbow by" in spun.report["verdict"]["text"]
    assert "across 2 steps of over 90 degrees" in spun.report["verdict"]["text"]
