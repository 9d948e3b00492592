"""lee-shin over half-turn flips nothing repaired: a flip stays a flip, not a fast turn; the
report counts no flip as jitter."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import NOISY, degrees_between

import motionclean as mc
from motionclean.core import quat
from motionclean.filters.linear import lee_shin
from motionclean.filters.masks import binomial
from motionclean.run.jobs import clean_motion
from motionclean.steps.pipeline import Pipeline


def flipped_signal(frames: int = 200, at: int = 100) -> np.ndarray:
    """A slow turn about one axis, half a turn about another from frame ``at`` on."""
    angle = np.linspace(0.0, 1.0, frames)
    q = quat.exp(angle[:, None] * np.array([0.0, 0.0, 0.5]))
    flip = np.array([0.0, 1.0, 0.0, 0.0])  # half a turn about x
    q[at:] = quat.multiply(q[at:], flip)
    return q


def test_a_cut_filter_leaves_the_flip_and_smooths_each_side_as_the_filter_does():
    q = flipped_signal()
    plain = lee_shin(q, binomial(2), 5)
    cut = lee_shin(q, binomial(2), 5, math.radians(90.0))
    steps = np.degrees(quat.angle_between(cut[:-1], cut[1:]))
    assert steps[99] > 179.0 and np.delete(steps, 99).max() < 1.0  # still one flip
    # a constant turn is a fixed point away from the flip; beside it the cut step counts as
    # no motion, which moves a frame by at most about one frame's turn (0.29 degrees here)
    moved = degrees_between(cut, q)
    assert moved[:90].max() < 1e-9 and moved[110:].max() < 1e-9 and moved.max() < 0.5
    assert degrees_between(plain, q).max() > 30.0  # the plain filter spins into the flip


def test_a_cut_filter_is_coordinate_invariant():
    rng = np.random.default_rng(3)
    q = quat.multiply(flipped_signal(), quat.exp(rng.normal(scale=0.02, size=(200, 3))))
    a, b = quat.normalize(rng.normal(size=4)), quat.normalize(rng.normal(size=4))
    cut = math.radians(90.0)
    turned = lee_shin(quat.multiply(quat.multiply(a, q), b), binomial(2), 3, cut)
    expected = quat.multiply(quat.multiply(a, lee_shin(q, binomial(2), 3, cut)), b)
    assert degrees_between(turned, expected).max() < 1e-9


@pytest.mark.parametrize("cut", [0.0, -1.0, math.nan])
def test_a_cut_that_is_no_angle_is_refused(cut):
    with pytest.raises(ValueError, match="cut_above"):
        lee_shin(flipped_signal(), binomial(2), 1, cut)


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
        clip, Pipeline.from_inline(["lee-shin:k=2,iterations=3,cut_deg=inf"]), "n.bvh"
    )
    assert degrees_between(spun.after.rotations[:, thumb], clip.rotations[:, thumb]).max() > 30
    assert "smoothing moved RThumb" in spun.report["verdict"]["text"]
    assert "across 10 steps of over 90 degrees in the input" in spun.report["verdict"]["text"]
    assert "despike repairs them first" in spun.report["verdict"]["text"]
    kept = clean_motion(clip, Pipeline.from_inline(["despike", "multires:level=2"]), "n.bvh")
    assert "steps of over 90 degrees" not in kept.report["verdict"]["text"]  # repaired first
