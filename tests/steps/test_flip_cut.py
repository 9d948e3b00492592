"""Smoothing steps cut at flips nothing repaired (``StepSpec.cuts_at_flips``): multires,
sse-fairing, fairing and bilateral smooth each stretch of a rotation column between steps
over ``cut_deg`` on its own, so a flip stays one step instead of a fast spin; positions
are not cut; ``cut_deg=180`` is each paper's method as printed, bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import NOISY, degrees_between

import motionclean as mc
from motionclean.core import quat
from motionclean.steps import REGISTRY, StepData
from motionclean.steps.pipeline import Pipeline, make_step

FRAMES = 120
HALF_TURN = np.array([0.0, 1.0, 0.0, 0.0])  # about x
JOINTS = ("RightWrist", "Head", "LeftKnee")
#: Frames each joint flips by half a turn at (a cut before each): Head never; LeftKnee's
#: stretches of one, two and one frame.
FLIPS = {"RightWrist": [30, 34, 70], "Head": [], "LeftKnee": [5, 6, 60, 61, 63]}
#: Each step with parameters under which it spins an uncut flip.
SPINNING = [
    ("multires", {}),
    ("sse-fairing", {}),
    ("fairing", {"epsilon_r": math.inf}),
    ("bilateral", {"sigma_t": 3.0}),
]
CUT_STEPS = sorted(name for name, spec in REGISTRY.items() if spec.cuts_at_flips)


@pytest.fixture(scope="module")
def clips() -> tuple[mc.Motion, mc.Motion]:
    """The noisy sample's first 120 frames, and the same with half-turn flips planted."""
    clip = mc.load(NOISY)
    calm = clip.replace(
        rotations=clip.rotations[:FRAMES].copy(),
        translations=clip.translations[:FRAMES].copy(),
        source_values=None,
    )
    q = calm.rotations.copy()
    for name, starts in FLIPS.items():
        j = calm.names.index(name)
        for at in starts:
            q[at:, j] = quat.multiply(q[at:, j], HALF_TURN)
    return calm, calm.replace(rotations=q)


def _run(step: tuple[str, dict], clip: mc.Motion, **more) -> mc.Motion:
    """``step`` (filter, parameters) on the root and :data:`JOINTS` of ``clip``."""
    name, params = step
    table = {"filter": name, **params, **more, "joints": ["Hips", *JOINTS]}
    return Pipeline.from_tables([table], "test").run(clip)[0]


def _alone(step: tuple[str, dict], q: np.ndarray, p: np.ndarray | None = None) -> StepData:
    """``step`` run on the columns ``q`` (and ``p``) as they are: uncut, no clip."""
    made = make_step({"filter": step[0], **step[1], "cut_deg": 180.0}, "test")
    assert made.spec.run is not None
    return made.spec.run(StepData(q.copy(), None if p is None else p.copy(), 1 / 120), made.params)


def _turns(q: np.ndarray) -> np.ndarray:
    """Degrees turned between consecutive frames, ``(F-1, ...)``."""
    return degrees_between(q[:-1], q[1:])


@pytest.mark.parametrize("step", SPINNING)
def test_a_flip_stays_one_step_and_the_frames_beside_it_move_little(clips, step):
    """Between consecutive frames the output turns no further than the step makes the
    motion without flips turn, plus the flip itself: each flip stays one step of about 180
    degrees (uncut, the steps spun them: frames beside moved by up to 180 degrees)."""
    calm, flipped = clips
    smoothed, out = _run(step, calm), _run(step, flipped)
    spun = _run(step, flipped, cut_deg=180.0)
    worst_spin = 0.0
    for name, starts in FLIPS.items():
        j = calm.names.index(name)
        at = np.array(starts, dtype=int) - 1  # the steps into each flip
        excess = _turns(out.rotations[:, j]) - _turns(smoothed.rotations[:, j])
        assert np.delete(excess, at).max() < 4.0, name
        assert np.all(_turns(out.rotations[:, j])[at] > 170.0), name
        moved = degrees_between(out.rotations[:, j], flipped.rotations[:, j]).max()
        assert moved < degrees_between(smoothed.rotations[:, j], calm.rotations[:, j]).max() + 3
        spin = _turns(spun.rotations[:, j]) - _turns(smoothed.rotations[:, j])
        worst_spin = max(worst_spin, np.delete(spin, at).max())
    assert worst_spin > 25.0  # the step as printed spins them


@pytest.mark.parametrize("step", SPINNING)
def test_each_stretch_is_the_step_run_on_it_alone(clips, step):
    """Every stretch between flips (one frame: kept) as the step gives it alone; the root's
    translations as the step gives them uncut."""
    _, flipped = clips
    out = _run(step, flipped)
    for name, starts in FLIPS.items():
        j = flipped.names.index(name)
        edges = [0, *starts, FRAMES]
        for first, stop in zip(edges[:-1], edges[1:], strict=True):
            part = flipped.rotations[first:stop, j : j + 1]
            expected = _alone(step, part).rotations if stop - first > 1 else part
            assert degrees_between(out.rotations[first:stop, j : j + 1], expected).max() < 1e-9
    root = _alone(step, flipped.rotations[:, :1], flipped.translations[:, :1])
    assert np.array_equal(out.translations[:, :1], root.translations)


@pytest.mark.parametrize("step", SPINNING)
def test_a_cut_at_half_a_turn_is_the_step_as_printed(clips, step):
    _, flipped = clips
    out = _run(step, flipped, cut_deg=180.0)
    columns = [flipped.names.index(n) for n in ("Hips", *JOINTS)]
    uncut = _alone(step, flipped.rotations[:, columns])
    assert np.array_equal(out.rotations[:, columns], uncut.rotations)


@pytest.mark.parametrize("step", SPINNING)
def test_a_cut_step_is_coordinate_invariant(clips, step):
    """``H(a q b) = a H(q) b``: a step's angle between frames, hence every cut, is
    invariant too."""
    _, flipped = clips
    rng = np.random.default_rng(5)
    a, b = quat.normalize(rng.normal(size=4)), quat.normalize(rng.normal(size=4))
    turned = flipped.replace(rotations=quat.multiply(quat.multiply(a, flipped.rotations), b))
    out, out_turned = _run(step, flipped), _run(step, turned)
    expected = quat.multiply(quat.multiply(a, out.rotations), b)
    assert degrees_between(out_turned.rotations, expected).max() < 1e-9


def test_each_known_stretch_of_a_column_with_dropouts_is_cut_at_its_flips(clips):
    """Dropouts and flips cut a column alike: each piece between them runs on its own."""
    _, flipped = clips
    j = flipped.names.index("RightWrist")
    missing = np.zeros((FRAMES, flipped.n_joints), dtype=bool)
    missing[50:55, j] = True
    gappy = flipped.replace(missing=missing)
    out = _run(SPINNING[0], gappy)
    for first, stop in ((0, 30), (30, 34), (34, 50), (55, 70), (70, FRAMES)):
        alone = _alone(SPINNING[0], gappy.rotations[first:stop, j : j + 1]).rotations
        assert degrees_between(out.rotations[first:stop, j : j + 1], alone).max() < 1e-9


def test_fairing_notes_a_joint_held_only_where_no_stretch_took_a_step():
    """A joint's note from its stretches: the most iterations; held by the bound only
    where none took an iteration (a stretch too short to fair counts as held)."""
    merge = REGISTRY["fairing"].merge_note
    assert merge is not None
    held = {"iterations": 0, "held_by_bound": True}
    short = {"iterations": 0, "held_by_bound": False}
    faired = {"iterations": 12, "held_by_bound": False}
    assert merge([(held, 40), (short, 2)]) == held
    assert merge([(held, 40), (faired, 30)]) == faired
    assert merge([(short, 2), (short, 3)]) == short


@pytest.mark.parametrize("name", CUT_STEPS)
def test_every_cut_step_takes_cut_deg_within_a_half_turn(name):
    assert CUT_STEPS == ["bilateral", "fairing", "multires", "sse-fairing"]
    assert make_step({"filter": name}, "test").params["cut_deg"] == 90.0
    for bad in ("0", "700", "inf", "nan"):
        with pytest.raises(mc.UsageError, match="cut_deg must be a number > 0 and <= 180"):
            Pipeline.from_inline([f"{name}:cut_deg={bad}"])
