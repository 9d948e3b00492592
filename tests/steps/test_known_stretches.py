"""A step that treats each column on its own (``StepSpec.column_wise``) on a clip with
dropouts: the known stretches of the columns with gaps run as columns of one array, those
of one length together, and each comes out as the step gives it run alone."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from helpers import NOISY

import motionclean as mc
from motionclean.core import quat
from motionclean.core.motion import hold_missing
from motionclean.steps import REGISTRY, StepData
from motionclean.steps.pipeline import Pipeline, make_step

FRAMES = 150
#: The joints the steps run on; all but Head have gaps.
JOINTS = ("Hips", "LeftHip", "LeftKnee", "LeftToe", "RightHip", "Chest", "LeftWrist", "Head")
COLUMN_WISE = sorted(name for name, spec in REGISTRY.items() if spec.column_wise)
#: Fewer iterations than the default for the slow steps (the tests stay fast).
QUICK = {"fairing": {"max_iterations": 10}, "sse-fairing": {"max_iterations": 10}}
#: sse-fairing's per-signal sums run in another order for several signals than for one
#: (``filters.fairing.GROUP_SAMPLES``): equal within rounding (relative and absolute), not
#: bit for bit.
ROUNDING = {"sse-fairing": 1e-14}


def _same(name: str, a: np.ndarray, b: np.ndarray) -> bool:
    """``a`` and ``b`` equal, within :data:`ROUNDING` for the step ``name``."""
    rounding = ROUNDING.get(name, 0.0)
    return np.allclose(a, b, rtol=rounding, atol=rounding) if rounding else np.array_equal(a, b)


@pytest.fixture(scope="module")
def gappy() -> mc.Motion:
    """The noisy sample's first 150 frames with dropouts in :data:`JOINTS` but Head:
    single frames, runs (one at each end), and LeftToe in shreds (stretches of 1 to a few
    frames); LeftKnee flips by half a turn inside a known stretch."""
    clip = mc.load(NOISY)
    q, t = clip.rotations[:FRAMES].copy(), clip.translations[:FRAMES].copy()
    hips, left_hip, knee, toe = (clip.names.index(n) for n in JOINTS[:4])
    q[70:, knee] = quat.multiply(q[70:, knee], np.array([0.0, 1.0, 0.0, 0.0]))
    rng = np.random.default_rng(3)
    with_gaps = [clip.names.index(n) for n in JOINTS[:-1]]
    missing = np.zeros((FRAMES, clip.n_joints), dtype=bool)
    missing[rng.integers(0, FRAMES, 60), rng.choice(with_gaps, 60)] = True
    missing[:4, left_hip] = missing[-6:, knee] = missing[40:52, hips] = True
    missing[:, toe] |= rng.random(FRAMES) < 0.4
    return clip.replace(
        rotations=hold_missing(q, missing),
        translations=hold_missing(t, missing),
        missing=missing,
        source_values=None,
    )


def _run(name: str, clip: mc.Motion, column_wise: bool = True, **params) -> tuple:
    """Step ``name`` on :data:`JOINTS` of ``clip``: its rotations, translations and notes;
    ``column_wise`` False runs each known stretch alone (the path of a step that reads the
    clip)."""
    table = {"filter": name, **QUICK.get(name, {}), **params, "joints": list(JOINTS)}
    step = make_step(table, "test")
    step = dataclasses.replace(step, spec=dataclasses.replace(step.spec, column_wise=column_wise))
    out, logs = Pipeline([step], "test").run(clip)
    return out.rotations, out.translations, logs[0].notes


def _alone(name: str, q: np.ndarray, p: np.ndarray, frame_time: float) -> StepData:
    """The step (uncut at flips) on one stretch of one column, as it is."""
    step = make_step({"filter": name, **QUICK.get(name, {}), "cut_deg": 180.0}, "test")
    assert step.spec.run is not None
    return step.spec.run(StepData(q.copy(), p.copy(), frame_time), step.params)


def _stretches(column: np.ndarray) -> list[tuple[int, int]]:
    """``(first, stop)`` of the known stretches of 2 frames or more of one ``missing``
    column."""
    edges = np.flatnonzero(np.diff(np.concatenate([[True], column, [True]]).astype(np.int8)))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True) if b - a > 1]


@pytest.mark.parametrize("name", COLUMN_WISE)
def test_each_known_stretch_is_the_step_run_on_it_alone(gappy, name):
    """Every known stretch of every column with gaps, rotations and the root's positions,
    as the step gives it alone; missing samples and stretches of one frame as they were."""
    rotations, translations, _ = _run(name, gappy, cut_deg=180.0)
    assert gappy.missing is not None
    checked = 0
    for j in np.flatnonzero(gappy.missing.any(axis=0)):
        for first, stop in _stretches(gappy.missing[:, j]):
            cut = slice(first, stop)
            p = gappy.translations[cut, j : j + 1]
            alone = _alone(name, gappy.rotations[cut, j : j + 1], p, gappy.frame_time)
            assert _same(name, rotations[cut, j : j + 1], alone.rotations)
            if j == 0:  # (the root: the only joint with position channels)
                assert alone.translations is not None
                assert _same(name, translations[cut, :1], alone.translations)
            checked += 1
        lone = np.ones(FRAMES, dtype=bool)  # missing, or known on one frame alone
        for first, stop in _stretches(gappy.missing[:, j]):
            lone[first:stop] = False
        assert np.array_equal(rotations[lone, j], gappy.rotations[lone, j])
    assert checked > 40


@pytest.mark.parametrize("name", COLUMN_WISE)
def test_stretches_together_are_the_stretches_one_by_one(gappy, name):
    """Cut at flips too (the default cut_deg): the result and each joint's merged notes
    as when each known stretch runs on its own."""
    together = _run(name, gappy)
    one_by_one = _run(name, gappy, column_wise=False)
    for a, b in zip(together[:2], one_by_one[:2], strict=True):
        assert _same(name, a, b)
    assert together[2] == one_by_one[2]


def test_every_step_cut_at_flips_treats_each_column_on_its_own():
    cut = {name for name, spec in REGISTRY.items() if spec.cuts_at_flips}
    assert cut < set(COLUMN_WISE)
    assert "footlock" not in COLUMN_WISE  # (reads the clip: each stretch with it as context)
